"""`Graph.bake_mesh`: the texels of `texgraph bake --mesh`, as NumPy arrays."""

import struct
import tempfile
import zlib
from pathlib import Path

import numpy as np
import pytest

import texgraph
from conftest import ROOT, run_cli

MESHES = ROOT / "examples" / "meshes"
MARBLE = str(ROOT / "graphs" / "seed003_marble.ron")


def read_png16_grey_or_rgb(path):
    """A 16-bit PNG's samples (the test's own reader: zlib and the five row filters)."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    width, height, depth, colour = header[:4]
    assert depth == 16
    channels = {0: 1, 2: 3}[colour]
    stride, bpp = width * channels * 2, channels * 2
    raw = zlib.decompress(idat)
    rows, prev = [], bytearray(stride)
    for j in range(height):
        kind, line = raw[j * (stride + 1)], bytearray(raw[j * (stride + 1) + 1:(j + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], prev[i - bpp] if i >= bpp else 0
            if kind == 1:
                line[i] = (line[i] + a) & 255
            elif kind == 2:
                line[i] = (line[i] + b) & 255
            elif kind == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prev = line
    samples = np.frombuffer(b"".join(rows), dtype=">u2").astype(np.uint16)
    return samples.reshape(height, width, channels).squeeze()


def encode16(values):
    """The command line's linear 16-bit encoding: clamp, scale, round half away, in f32."""
    v = np.nan_to_num(np.asarray(values, dtype=np.float32), nan=0.0)
    t = np.clip(v, 0, 1).astype(np.float32) * np.float32(65535)
    whole = np.trunc(t)
    return np.minimum(whole + ((t - whole) >= 0.5), 65535).astype(np.uint16)


@pytest.mark.parametrize("model", ["sphere.glb", "cube.obj"])
def test_bake_mesh_gives_the_texels_of_the_command_line(model):
    graph = texgraph.load(MARBLE)
    images = graph.bake_mesh(MESHES / model, (48, 32), normal="vein", padding=4)
    assert images["vein"].shape == (32, 48) and images["vein"].dtype == np.float32
    assert images["colour"].shape == (32, 48, 3)
    assert images["normal"].shape == (32, 48, 3)
    with tempfile.TemporaryDirectory() as out:
        run_cli("bake", MARBLE, "--mesh", MESHES / model, "--size", "48,32", "--normal", "vein",
                "--padding", "4", "--depth", "16", "--out", out, "--quiet")
        for name in ("vein", "normal"):
            png = read_png16_grey_or_rgb(Path(out) / f"seed003_marble.{name}.png")
            assert np.array_equal(png, encode16(images[name])), name
    single = graph.bake_mesh(MESHES / model, (48, 32), output="vein", padding=4)
    assert np.array_equal(single, images["vein"])


def test_bake_mesh_refuses_bad_input():
    graph = texgraph.load(MARBLE)
    with pytest.raises(ValueError, match="TEXCOORD_0"):
        graph.bake_mesh(MESHES / "no_uv.glb", 16)
    with pytest.raises(OSError, match="missing"):
        graph.bake_mesh(MESHES / "missing.obj", 16)
    with pytest.raises(ValueError, match="filter"):
        graph.bake_mesh(MESHES / "cube.obj", 16, filter="gauss")
    with pytest.raises(ValueError, match="scalar"):
        graph.bake_mesh(MESHES / "cube.obj", 16, normal="colour")
