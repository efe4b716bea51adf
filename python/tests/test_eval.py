"""Graph.eval against `texgraph eval --points`, bit for bit, on every graph of graphs/."""

import numpy as np
import pytest

import texgraph
from conftest import GRAPHS, cli_eval, points, same_bits


@pytest.mark.parametrize("path", GRAPHS, ids=lambda p: p.relative_to(p.parents[1]).as_posix())
def test_eval_matches_the_command_line(path):
    g = texgraph.load(path)
    pts = points(40)
    for f64 in (False, True):
        expected = cli_eval(path, pts, f64=f64)
        got = g.eval(pts, f64=f64)
        assert list(got) == list(expected) == list(g.outputs)
        for name, values in got.items():
            assert values.dtype == (np.float64 if f64 else np.float32)
            shape = (len(pts),) if g.outputs[name] == "scalar" else (len(pts), 3)
            assert values.shape == shape
            assert same_bits(values, expected[name]), (path.name, name, f64)


def test_float32_points_and_one_output():
    path = GRAPHS[0].parent / "seed003_marble.ron"
    g = texgraph.load(path)
    pts = points(100).astype(np.float32)
    expected = cli_eval(path, pts.astype(np.float64), output="vein")
    got = g.eval(pts, output="vein")
    assert isinstance(got, np.ndarray) and got.shape == (len(pts),)
    assert same_bits(got, expected["vein"])
    # Lists, integer arrays and strided views are converted; the values are the same.
    assert same_bits(g.eval(pts.tolist(), output="vein"), got)
    grid = np.arange(30).reshape(10, 3)
    assert same_bits(g.eval(grid, output="vein"), g.eval(grid.astype(np.float64), output="vein"))
    wide = np.zeros((len(pts), 6), dtype=np.float32)
    wide[:, ::2] = pts
    assert same_bits(g.eval(wide[:, ::2], output="vein"), got)


def test_out_is_written_in_place():
    g = texgraph.load(GRAPHS[0].parent / "seed003_marble.ron")
    pts = points(5000)
    vein = np.full(len(pts), -1.0, dtype=np.float32)
    back = g.eval(pts, output="vein", out=vein)
    assert back is vein
    assert same_bits(vein, g.eval(pts, output="vein"))
    outs = {"colour": np.empty((len(pts), 3), np.float64), "vein": np.empty(len(pts), np.float64)}
    result = g.eval(pts, f64=True, out=outs)
    assert result["colour"] is outs["colour"] and result["vein"] is outs["vein"]
    assert same_bits(outs["colour"], g.eval(pts, f64=True)["colour"])


@pytest.mark.parametrize("threads", [None, 1, 2, 3])
def test_threads_do_not_change_values(threads):
    g = texgraph.load(GRAPHS[0].parent / "seed003_marble.ron")
    pts = points(20000)
    assert same_bits(g.eval(pts, output="vein", threads=threads), g.eval(pts, output="vein", threads=1))


def test_set_overrides_params():
    path = GRAPHS[0].parent / "seed003_marble.ron"
    g = texgraph.load(path, set={"period": 2.5, "octaves": 3})
    assert g.params["period"] == 2.5 and g.params["octaves"] == 3
    plain = texgraph.load(path)
    assert plain.params["period"] != 2.5
    pts = points(50)
    from conftest import run_cli
    import os, tempfile
    with tempfile.NamedTemporaryFile("w", suffix=".txt", delete=False) as f:
        f.write("\n".join(" ".join(repr(float(c)) for c in p) for p in pts) + "\n")
    try:
        text = run_cli("eval", path, "--points", f.name, "--set", "period=2.5", "--set", "octaves=3")
    finally:
        os.unlink(f.name)
    vein = np.array([float(l.split()[1]) for l in text.splitlines() if l.startswith("vein ")], np.float32)
    assert same_bits(g.eval(pts, output="vein"), vein)
    assert not same_bits(plain.eval(pts, output="vein"), vein)


def test_loads_and_describe():
    text = (
        'Graph(params: { "f": 3.0 }, nodes: { "p": Position, "s": Sin("p.x"), '
        '"t": Mul("s", "f") }, outputs: { "wave": "t" })'
    )
    g = texgraph.loads(text, name="wave.ron", set={"f": 2.0})
    assert g.name == "wave.ron"
    assert g.outputs == {"wave": "scalar"} and g.params == {"f": 2.0}
    x = np.array([[0.5, 0.0, 0.0], [1.0, 2.0, 3.0]])
    assert np.allclose(g.eval(x, output="wave", f64=True), 2.0 * np.sin(x[:, 0]))
    assert "instructions" in g.tape()
    kinds = {n["kind"]: n for n in texgraph.nodes()}
    assert {"Fbm", "ColorRamp", "Sin", "Position"} <= set(kinds)
    assert any(a["name"] == "octaves" for a in kinds["Fbm"]["args"])


def test_footprint_filters():
    g = texgraph.load(GRAPHS[0].parent / "seed003_marble.ron")
    pts = points(64)[:64]
    point = g.eval(pts, output="vein", f64=True)
    tiny = g.eval(pts, output="vein", f64=True, footprint=0.0)
    assert same_bits(point, tiny)
    huge = g.eval(pts, output="vein", f64=True, footprint=1e6)
    assert np.ptp(huge) < 0.05 * np.ptp(point)
    assert g.eval(pts, output="vein", footprint=(0.1, 0.2, 0.0)).shape == (64,)


def test_empty_points():
    g = texgraph.load(GRAPHS[0].parent / "seed003_marble.ron")
    got = g.eval(np.zeros((0, 3)))
    assert got["colour"].shape == (0, 3) and got["vein"].shape == (0,)


def test_graphs_pickle_and_go_to_worker_processes():
    import concurrent.futures
    import multiprocessing
    import pickle

    path = GRAPHS[0].parent / "library" / "marble_tiles.ron"   # imports another graph file
    g = texgraph.load(path, set={"tile": 0.25})
    back = pickle.loads(pickle.dumps(g))
    assert (back.name, back.outputs, back.params) == (g.name, g.outputs, g.params)
    pts = points(200)
    for name, values in g.eval(pts).items():
        assert same_bits(back.eval(pts)[name], values)
    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(max_workers=1, mp_context=context) as pool:
        remote = pool.submit(_eval_in_worker, g, pts).result(timeout=120)
    for name, values in g.eval(pts).items():
        assert same_bits(remote[name], values)


def _eval_in_worker(graph, pts):
    return graph.eval(pts)
