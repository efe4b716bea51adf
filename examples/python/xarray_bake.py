"""A bake as an xarray DataArray, with the voxel centres as coordinates.

    pip install ./python xarray
    python examples/python/xarray_bake.py
"""

import numpy as np
import xarray as xr

import texgraph

g = texgraph.load("graphs/library/wood.ron")
size = (48, 32, 16)                       # nx, ny, nz
region = ((-1.0, -1.0, 0.0), (1.0, 1.0, 0.5))
arrays = g.bake(size, region=region)


def centres(axis):
    lo, hi, n = region[0][axis], region[1][axis], size[axis]
    return lo + (np.arange(n) + 0.5) * (hi - lo) / n


coords = {"z": centres(2), "y": centres(1), "x": centres(0)}
data = xr.Dataset({
    name: xr.DataArray(a, dims=("z", "y", "x") if a.ndim == 3 else ("z", "y", "x", "channel"),
                       coords=coords if a.ndim == 3 else {**coords, "channel": ["r", "g", "b"]},
                       attrs={"graph": g.name, "type": g.outputs[name]})
    for name, a in arrays.items()
})
print(data)
# Selections by position, not index:
print(data.sel(x=0.0, y=0.0, z=0.25, method="nearest"))
