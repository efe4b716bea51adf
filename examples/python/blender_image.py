"""Blender: an image (and a material using it) from a texgraph bake.

Install texgraph into Blender's own Python once (the wheel is abi3, so it fits any Blender
with Python >= 3.9):

    /path/to/blender/4.x/python/bin/python3.11 -m pip install ./python

then run this in Blender's Text Editor, or `blender --background --python
examples/python/blender_image.py`. Set GRAPH to a graph file's absolute path.
"""

import os

import bpy
import numpy as np

import texgraph

GRAPH = os.environ.get("TEXGRAPH_GRAPH", os.path.abspath("graphs/seed003_marble.ron"))
SIZE = 512

g = texgraph.load(GRAPH)
name = next((n for n, t in g.outputs.items() if t == "vec3"), next(iter(g.outputs)))
# One slice at z = 0.5, (1, SIZE, SIZE[, 3]); Blender's pixel rows start at the bottom, as y does.
rgb = g.bake((SIZE, SIZE, 1), region=((0, 0, 0.499), (1, 1, 0.501)), output=name)[0]
if rgb.ndim == 2:
    rgb = np.repeat(rgb[:, :, None], 3, axis=2)
rgba = np.concatenate([rgb.clip(0, 1), np.ones((SIZE, SIZE, 1), np.float32)], axis=2)

image = bpy.data.images.new(f"texgraph {os.path.basename(GRAPH)}", SIZE, SIZE, float_buffer=True)
image.pixels.foreach_set(rgba.ravel())
image.update()

material = bpy.data.materials.new("texgraph")
material.use_nodes = True
nodes = material.node_tree.nodes
tex = nodes.new("ShaderNodeTexImage")
tex.image = image
material.node_tree.links.new(tex.outputs["Color"], nodes["Principled BSDF"].inputs["Base Color"])
print("made image", image.name)
