"""A slice of a graph with matplotlib: a 512 × 512 × 1 bake at z = 0.5, shown and saved.

    pip install ./python matplotlib
    python examples/python/matplotlib_slice.py [graph.ron] [slice.png]
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import texgraph

path = sys.argv[1] if len(sys.argv) > 1 else "graphs/seed003_marble.ron"
out = sys.argv[2] if len(sys.argv) > 2 else "slice.png"
g = texgraph.load(path)
colour = next((n for n, t in g.outputs.items() if t == "vec3"), None)
name = colour or next(iter(g.outputs))
# One voxel thick around z = 0.5: region z from 0.499 to 0.501.
image = g.bake((512, 512, 1), region=((0, 0, 0.499), (1, 1, 0.501)), output=name)[0]
fig, ax = plt.subplots(figsize=(6, 6))
ax.imshow(image.clip(0, 1), origin="lower", extent=(0, 1, 0, 1), cmap=None if colour else "gray")
ax.set(title=f"{g.name}: {name} at z = 0.5", xlabel="x", ylabel="y")
fig.savefig(out, dpi=100)
print("wrote", out)
