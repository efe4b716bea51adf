"""Shared helpers: the repository's graphs and the texgraph command line to compare against.

The command line is $TEXGRAPH_CLI, else the newest of target/{debug,release}/texgraph (CI sets
TEXGRAPH_CLI to the build its Python package was built beside).
"""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
GRAPHS = sorted((ROOT / "graphs").glob("*.ron")) + sorted((ROOT / "graphs" / "library").glob("*.ron"))


def cli_path():
    given = os.environ.get("TEXGRAPH_CLI")
    if given:
        return Path(given)
    found = [p for p in (ROOT / "target" / d / "texgraph" for d in ("debug", "release")) if p.exists()]
    if not found:
        pytest.skip("no texgraph binary: cargo build first, or set TEXGRAPH_CLI")
    return max(found, key=lambda p: p.stat().st_mtime)


def run_cli(*args):
    done = subprocess.run([str(cli_path()), *map(str, args)], capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError(f"texgraph {' '.join(map(str, args))} failed: {done.stderr}")
    return done.stdout


def cli_eval(graph, points, f64=False, output=None):
    """`texgraph eval GRAPH --points FILE`: {output: array} parsed from its lines."""
    import tempfile

    with tempfile.NamedTemporaryFile("w", suffix=".txt", delete=False) as f:
        for p in points:
            f.write(" ".join(repr(float(c)) for c in p) + "\n")
        name = f.name
    try:
        args = ["eval", graph, "--points", name] + (["--f64"] if f64 else [])
        if output:
            args += ["--output", output]
        text = run_cli(*args)
    finally:
        os.unlink(name)
    values = {}
    for line in text.splitlines():
        name, *numbers = line.split()
        values.setdefault(name, []).append([float(v) for v in numbers])
    dtype = np.float64 if f64 else np.float32
    return {k: np.array(v, dtype=np.float64).astype(dtype).squeeze(axis=1) if len(v[0]) == 1
            else np.array(v, dtype=np.float64).astype(dtype) for k, v in values.items()}


def same_bits(a, b):
    """Equal bit for bit, NaNs (whose payload the command line's text does not keep) aside."""
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    nan = np.isnan(a) & np.isnan(b)
    return bool(np.all((a == b) & (np.signbit(a) == np.signbit(b)) | nan))


def points(n, seed=7):
    """n points in [-4, 4]^3, and the stability cases: huge, negative, far, non-finite."""
    rng = np.random.default_rng(seed)
    p = rng.uniform(-4.0, 4.0, size=(n, 3))
    special = np.array([
        [0.0, 0.0, 0.0],
        [-0.5, 0.25, -1e-9],
        [1e6, -1e6, 12345.678],
        [-1e30, 3.0, 1e30],
        [np.nan, 1.0, 2.0],
        [np.inf, 0.0, -np.inf],
    ])
    return np.concatenate([p, special])
