"""texgraph: procedural solid textures from RON node graphs, evaluated into NumPy arrays.

    >>> import numpy as np, texgraph
    >>> g = texgraph.load("graphs/seed003_marble.ron", set={"period": 2.5})
    >>> g.outputs
    {'colour': 'vec3', 'vein': 'scalar'}
    >>> v = g.eval(np.random.rand(1000, 3))          # {'colour': (1000, 3), 'vein': (1000,)}
    >>> vol = g.bake(64, output="vein")              # (64, 64, 64) float32, z, y, x

- ``load(path, set=None)`` / ``loads(text, name="<string>", set=None)`` read and check a graph
  (``GraphError``, a ``ValueError``, for an invalid one: ``str()`` is the command line's
  diagnostic text, ``.diagnostics`` the list of ``Diagnostic`` with file, line, column, node,
  cls and message).
- ``Graph.eval(points, ...)`` evaluates at an (N, 3) array of points, ``Graph.bake(size, ...)``
  over a grid of voxel centres; both release the GIL and run on the library's thread pool.
- ``nodes()`` lists the node catalogue.
- A ``Graph`` pickles (its text, file name and ``set`` values), so it can go to
  ``multiprocessing`` or ``concurrent.futures`` workers.

Values are those of the ``texgraph`` command line bit for bit (``eval --points``, ``bake
--format raw --raw-type f32``). Documentation: docs/python.md in the texgraph repository.
"""

from ._texgraph import Diagnostic, Graph, GraphError, __version__, _restore, load, loads, nodes

__all__ = ["Diagnostic", "Graph", "GraphError", "load", "loads", "nodes", "__version__"]
