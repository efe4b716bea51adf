"""texgraph from NumPy: load a graph, evaluate it at points, bake a volume.

    pip install ./python          # from the repository root, once
    python examples/python/numpy_basics.py
"""

import numpy as np

import texgraph

g = texgraph.load("graphs/seed003_marble.ron", set={"octaves": 8})
print(g, g.outputs, g.params)

# Points: any (N, 3) array; float32 or float64 arrays are read in place.
pts = np.random.default_rng(0).uniform(-1.0, 1.0, size=(100_000, 3))
values = g.eval(pts)                                  # {"colour": (N, 3), "vein": (N,)} float32
print("vein mean", values["vein"].mean(), "colour mean", values["colour"].mean(axis=0))

# One output, in f64, written into an array you own.
vein = np.empty(len(pts))
g.eval(pts, output="vein", f64=True, out=vein)

# The mean over a box of side 0.05 around each point (filtered evaluation).
smooth = g.eval(pts, output="vein", footprint=0.05)
print("point vs filtered spread", vein.std(), smooth.std())

# A bake: voxel centres of a 64³ grid over the unit cube, (z, y, x) order.
volume = g.bake(64, output="vein")
print(volume.shape, volume.dtype, volume.min(), volume.max())
