"""Graph.bake against `texgraph bake --format raw --raw-type f32`, bit for bit, on every graph."""

import tempfile
from pathlib import Path

import numpy as np
import pytest

import texgraph
from conftest import GRAPHS, run_cli, same_bits

SIZE = (7, 5, 3)
REGION = ((-1.5, 0.25, -3.0), (2.0, 1.0, 4.5))


def cli_bake(path, size, region, *flags):
    """The raw files of a command-line bake: {output: array of (nz, ny, nx[, 3])}."""
    out = Path(tempfile.mkdtemp())
    r = ",".join(map(repr, region[0])) + ":" + ",".join(map(repr, region[1]))
    run_cli("bake", path, "--format", "raw", "--raw-type", "f32", "--size", ",".join(map(str, size)),
            f"--region={r}", "--out", out, "-q", *flags)
    arrays = {}
    for raw in out.glob("*.raw"):
        name = raw.name[len(Path(path).stem) + 1:-len(".raw")]
        data = np.fromfile(raw, dtype="<f4")
        nx, ny, nz = size
        arrays[name] = data.reshape((nz, ny, nx, -1)).squeeze(axis=3) if data.size == nx * ny * nz \
            else data.reshape((nz, ny, nx, 3))
        raw.unlink()
    for f in out.iterdir():
        f.unlink()
    out.rmdir()
    return arrays


@pytest.mark.parametrize("path", GRAPHS, ids=lambda p: p.relative_to(p.parents[1]).as_posix())
def test_bake_matches_the_command_line(path):
    g = texgraph.load(path)
    expected = cli_bake(path, SIZE, REGION)
    got = g.bake(SIZE, region=REGION)
    assert set(got) == set(expected) == set(g.outputs)
    nx, ny, nz = SIZE
    for name, values in got.items():
        assert values.dtype == np.float32
        assert values.shape == ((nz, ny, nx) if g.outputs[name] == "scalar" else (nz, ny, nx, 3))
        assert same_bits(values, expected[name]), (path.name, name)


@pytest.mark.parametrize("name", ["seed003_marble.ron", "stone.ron", "library/wood.ron"])
def test_f64_and_box_bakes_match_the_command_line(name):
    path = GRAPHS[0].parent / name
    g = texgraph.load(path)
    assert all(same_bits(v, cli_bake(path, SIZE, REGION, "--f64")[k])
               for k, v in g.bake(SIZE, region=REGION, f64=True).items())
    assert all(same_bits(v, cli_bake(path, SIZE, REGION, "--filter", "box")[k])
               for k, v in g.bake(SIZE, region=REGION, filter="box").items())


def test_voxel_centres_are_eval_points():
    g = texgraph.load(GRAPHS[0].parent / "seed003_marble.ron")
    vol = g.bake(4, output="vein")
    c = (np.arange(4) + 0.5) / 4
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    # A bake compiles for its region (precision per instruction); at these points in [0, 1]³
    # every scalar runs in f32 either way.
    assert np.allclose(vol.ravel(), g.eval(pts, output="vein"), atol=1e-6)


def test_bake_refuses_large_volumes_and_bad_grids():
    g = texgraph.load(GRAPHS[0].parent / "seed003_marble.ron")
    with pytest.raises(ValueError, match="allow_large=True"):
        g.bake(1024)
    with pytest.raises(ValueError, match="zero dimension"):
        g.bake((4, 0, 4))
    with pytest.raises(ValueError, match="not a finite interval"):
        g.bake(4, region=((0, 0, 0), (float("nan"), 1, 1)))
    with pytest.raises(ValueError, match="filter"):
        g.bake(4, filter="gauss")
    with pytest.raises(KeyError, match="vein"):
        g.bake(4, output="veins")
