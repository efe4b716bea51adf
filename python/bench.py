"""Benchmark for the Python package (issue 34). Run from the repository root, with the package
installed in release (`pip install ./python`):

    python python/bench.py

1. `Graph.eval` on 10^6 points (one thread) against the Rust batch API on the same points
   (`cargo run --release --example batch_time`): the binding's own cost.
2. One Perlin noise sample per point, texgraph against the Python noise packages that install
   here: `noise.pnoise3` and `opensimplex.noise3` looping in Python, `pyfastnoisesimd` (SIMD,
   whole arrays). Missing packages are skipped with a note.

Prints medians (seconds) and ratios; name the CPU with them (`lscpu`).
"""

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# `python python/bench.py` puts python/ first on the path, where the package's source folder
# (without its compiled module) would shadow the installed package.
sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
import texgraph  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
N = 1_000_000


def median_time(f, runs=9):
    times = []
    for _ in range(runs):
        started = time.perf_counter()
        f()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def binding_overhead(graph_name):
    path = ROOT / "graphs" / graph_name
    pts = np.random.default_rng(3).uniform(-4.0, 4.0, size=(N, 3))
    g = texgraph.load(path)
    g.eval(pts[:1000], threads=1)
    out = {name: np.empty((N,) if t == "scalar" else (N, 3), np.float32) for name, t in g.outputs.items()}
    py_new = median_time(lambda: g.eval(pts, threads=1))
    py_out = median_time(lambda: g.eval(pts, threads=1, out=out))
    py_all = median_time(lambda: g.eval(pts))
    with tempfile.NamedTemporaryFile(suffix=".f64", delete=False) as f:
        pts.astype("<f8").tofile(f)
    try:
        done = subprocess.run(
            ["cargo", "run", "--quiet", "--release", "--example", "batch_time", "--", str(path), f.name, "9"],
            cwd=ROOT, capture_output=True, text=True, check=True)
    finally:
        os.unlink(f.name)
    rust = float(done.stdout.split()[0])
    print(f"{graph_name}: {N} points, one thread")
    print(f"  Rust Tape::eval_batch (one call)         {rust:.4f} s")
    print(f"  Graph.eval(points, threads=1)            {py_new:.4f} s  ({py_new / rust:.3f}x)")
    print(f"  Graph.eval(points, threads=1, out=...)   {py_out:.4f} s  ({py_out / rust:.3f}x)")
    print(f"  Graph.eval(points) on {os.cpu_count()} cores          {py_all:.4f} s")


def noise_packages():
    n = 100_000
    pts = np.random.default_rng(5).uniform(-4.0, 4.0, size=(n, 3))
    g = texgraph.loads('Graph(nodes: { "n": Noise(input: Position, basis: Perlin) }, outputs: { "v": "n" })')
    ours = median_time(lambda: g.eval(pts, output="v", threads=1))
    print(f"One Perlin sample at each of {n} points, one thread:")
    print(f"  texgraph Graph.eval                      {ours:.5f} s")
    xs, ys, zs = (pts[:, i].tolist() for i in range(3))
    try:
        import noise
        t = median_time(lambda: [noise.pnoise3(x, y, z) for x, y, z in zip(xs, ys, zs)], runs=3)
        print(f"  noise.pnoise3 in a Python loop           {t:.5f} s  ({t / ours:.1f}x texgraph)")
    except ImportError:
        print("  noise: not installed (pip install noise needs a C compiler)")
    try:
        import opensimplex
        opensimplex.seed(0)
        t = median_time(lambda: [opensimplex.noise3(x, y, z) for x, y, z in zip(xs, ys, zs)], runs=3)
        print(f"  opensimplex.noise3 in a Python loop      {t:.5f} s  ({t / ours:.1f}x texgraph)")
    except ImportError:
        print("  opensimplex: not installed")
    try:
        import pyfastnoisesimd as fns
        gen = fns.Noise(numWorkers=1)
        gen.noiseType = fns.NoiseType.Perlin
        coords = fns.empty_coords(n)
        coords[:, :n] = pts.T.astype(np.float32)
        t = median_time(lambda: gen.genFromCoords(coords))
        print(f"  pyfastnoisesimd genFromCoords (SIMD)     {t:.5f} s  ({t / ours:.2f}x texgraph)")
    except ImportError:
        print("  pyfastnoisesimd: not installed (no wheel for this Python)")


if __name__ == "__main__":
    binding_overhead(sys.argv[1] if len(sys.argv) > 1 else "seed003_marble.ron")
    noise_packages()
