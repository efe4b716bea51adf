"""Type hints for texgraph (the extension module texgraph._texgraph)."""

from os import PathLike
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

Region = Tuple[Sequence[float], Sequence[float]]
Footprint = Union[float, Tuple[float, float, float]]

class GraphError(ValueError):
    """An invalid graph: ``str()`` is the rendered diagnostic text."""

    diagnostics: List["Diagnostic"]

class Diagnostic:
    """One problem with a graph, located as the command line prints it."""

    file: str
    line: Optional[int]
    column: Optional[int]
    node: Optional[str]
    cls: str
    message: str

class Graph:
    """A checked graph, from ``load`` or ``loads``."""

    @property
    def name(self) -> str: ...
    @property
    def outputs(self) -> Dict[str, str]:
        """``{output name: "scalar" | "vec3"}`` in file order."""
    @property
    def params(self) -> Dict[str, float]:
        """``{param name: value}`` with the ``set=`` values applied."""
    def tape(self, output: Optional[str] = None) -> str:
        """The tape disassembly, as ``texgraph check --tape`` prints it."""
    @overload
    def eval(
        self,
        points: npt.ArrayLike,
        output: None = None,
        f64: bool = False,
        out: Optional[Mapping[str, np.ndarray]] = None,
        threads: Optional[int] = None,
        footprint: Optional[Footprint] = None,
    ) -> Dict[str, np.ndarray]: ...
    @overload
    def eval(
        self,
        points: npt.ArrayLike,
        output: str,
        f64: bool = False,
        out: Optional[np.ndarray] = None,
        threads: Optional[int] = None,
        footprint: Optional[Footprint] = None,
    ) -> np.ndarray: ...
    @overload
    def bake(
        self,
        size: Union[int, Tuple[int, int, int]],
        region: Optional[Region] = None,
        output: None = None,
        threads: Optional[int] = None,
        f64: bool = False,
        allow_large: bool = False,
        filter: str = "point",
    ) -> Dict[str, np.ndarray]: ...
    @overload
    def bake(
        self,
        size: Union[int, Tuple[int, int, int]],
        region: Optional[Region] = None,
        output: str = ...,
        threads: Optional[int] = None,
        f64: bool = False,
        allow_large: bool = False,
        filter: str = "point",
    ) -> np.ndarray: ...

    def bake_mesh(
        self,
        path: Union[str, "PathLike[str]"],
        size: Union[int, Tuple[int, int]],
        output: Optional[str] = None,
        normal: Optional[str] = None,
        filter: str = "point",
        padding: int = 8,
        space: str = "object",
        normal_strength: float = 1.0,
        normal_y: str = "up",
        f64: bool = False,
        threads: Optional[int] = None,
    ) -> Any:
        """Bakes into a mesh's UV layout (`texgraph bake --mesh`): {name: (H, W[, 3]) float32},
        with "normal" when `normal=` names a height; with `output=` (and no `normal=`) that array."""
        ...

def load(path: Union[str, "PathLike[str]"], set: Optional[Mapping[str, float]] = None) -> Graph:
    """Reads and checks a graph file (imports relative to it)."""

def loads(text: str, name: str = "<string>", set: Optional[Mapping[str, float]] = None) -> Graph:
    """Checks a graph given as RON text (imports relative to the working folder)."""

def nodes() -> List[Dict[str, Any]]:
    """The node catalogue: kind, output, doc and args (name, type, default, doc)."""
