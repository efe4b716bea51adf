"""Bad input: clear Python exceptions, never a crash."""

import numpy as np
import pytest

import texgraph
from conftest import GRAPHS

MARBLE = GRAPHS[0].parent / "seed003_marble.ron"


def test_invalid_graph_raises_graph_error_with_locations(tmp_path):
    bad = tmp_path / "bad.ron"
    bad.write_text('Graph(\n    nodes: {\n        "n": Fbn(Position),\n    },\n    outputs: { "v": "n" },\n)\n')
    with pytest.raises(texgraph.GraphError) as caught:
        texgraph.load(bad)
    err = caught.value
    assert isinstance(err, ValueError)
    assert str(err).startswith(f"error[unknown-kind]: {bad}:3:14:")
    (d,) = err.diagnostics
    assert (d.file, d.line, d.column, d.node, d.cls) == (str(bad), 3, 14, "n", "unknown-kind")
    assert "Fbn" in d.message
    # The command line prints the same text.
    from conftest import cli_path
    import subprocess
    done = subprocess.run([str(cli_path()), "check", str(bad)], capture_output=True, text=True)
    assert done.returncode == 1 and done.stderr == str(err)


def test_loads_errors_name_the_given_file():
    with pytest.raises(texgraph.GraphError) as caught:
        texgraph.loads('Graph(nodes: { "a": Sin("b") }, outputs: { "v": "a" })', name="inline.ron")
    (d,) = caught.value.diagnostics
    assert d.file == "inline.ron" and d.line == 1 and d.cls == "unknown-reference"


def test_missing_file():
    with pytest.raises(FileNotFoundError):
        texgraph.load("/no/such/graph.ron")


def test_unknown_param_and_output_name_the_known_ones():
    with pytest.raises(KeyError, match='"period", "distortion", "octaves"'):
        texgraph.load(MARBLE, set={"perod": 2.0})
    g = texgraph.load(MARBLE)
    with pytest.raises(KeyError, match='"colour", "vein"'):
        g.eval(np.zeros((1, 3)), output="colur")
    with pytest.raises(ValueError):
        texgraph.load(MARBLE, set={"period": "wide"})


@pytest.mark.parametrize("pts", [
    np.zeros((4, 2)), np.zeros(3), np.zeros((2, 3, 1)), np.array([["a", "b", "c"]]),
    np.zeros((2, 3), dtype=complex), [[1, 2]], "points",
])
def test_wrong_points_name_the_expected_shape(pts):
    g = texgraph.load(MARBLE)
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        g.eval(pts)


@pytest.mark.parametrize("out", [
    np.zeros(10, np.float64),         # wrong dtype
    np.zeros(9, np.float32),          # wrong length
    np.zeros((10, 1), np.float32),    # wrong shape
    np.zeros(20, np.float32)[::2],    # not contiguous
    [0.0] * 10,                       # not an array
])
def test_wrong_out_arrays(out):
    g = texgraph.load(MARBLE)
    with pytest.raises(ValueError, match=r"float32 array of shape \[10\]"):
        g.eval(np.zeros((10, 3)), output="vein", out=out)


def test_read_only_out_and_dict_out_errors():
    g = texgraph.load(MARBLE)
    ro = np.zeros(10, np.float32)
    ro.flags.writeable = False
    with pytest.raises(ValueError):
        g.eval(np.zeros((10, 3)), output="vein", out=ro)
    with pytest.raises(KeyError, match="colour"):
        g.eval(np.zeros((10, 3)), out={"vein": np.zeros(10, np.float32)})
    with pytest.raises(ValueError, match="dict"):
        g.eval(np.zeros((10, 3)), out=np.zeros(10, np.float32))


def test_bad_footprints_and_threads():
    g = texgraph.load(MARBLE)
    with pytest.raises(ValueError, match="footprint"):
        g.eval(np.zeros((2, 3)), footprint=-1.0)
    with pytest.raises(ValueError, match="footprint"):
        g.eval(np.zeros((2, 3)), footprint=(1.0, 2.0))
    with pytest.raises((OverflowError, TypeError, ValueError)):
        g.eval(np.zeros((2, 3)), threads=-1)
