#!/usr/bin/env python3
"""Generate the test/example meshes used by `texgraph bake`.

Run from anywhere:

    python3 examples/meshes/make_meshes.py

Writes every model into the directory this script lives in. Python 3 standard
library only; the output is deterministic (byte-identical on every run).

Conventions (see README.md):
  * glTF: UV origin top-left, v grows downwards.
  * OBJ:  vt = (u, 1 - v_gltf) (v grows upwards); v/vt/vn lists are in the
    same order as the glTF vertex arrays, faces are triangles in the same
    order and with the same corner order as the glTF index buffer.
  * All positions, normals and UVs are rounded to f32 before being written,
    so both formats carry bit-identical values. UVs are further snapped to
    multiples of 2^-24 so that 1 - v is exact in f32 as well.

Made by the texgraph project; released under CC0 1.0.
"""

import base64
import json
import math
import os
import struct

OUT_DIR = os.path.dirname(os.path.abspath(__file__))
GENERATOR = "texgraph examples/meshes/make_meshes.py"

ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963
FLOAT = 5126
UNSIGNED_SHORT = 5123
UNSIGNED_INT = 5125


# ---------------------------------------------------------------------------
# f32 helpers
# ---------------------------------------------------------------------------

def f32(x):
    """Round a Python float to the nearest f32 (as a Python float); -0 -> 0."""
    y = struct.unpack("<f", struct.pack("<f", x))[0]
    return y + 0.0  # turns -0.0 into 0.0


def quv(x):
    """Snap a texture coordinate in [0,1] to a multiple of 2^-24.

    Both x and 1 - x are then exact f32 values, so OBJ's vt = 1 - v_gltf and a
    reader's v_gltf = 1 - vt are exact in f32 (and f64) arithmetic and both
    formats give bit-identical UVs.
    """
    assert 0.0 <= x <= 1.0, x
    q = round(x * 16777216.0) / 16777216.0
    assert f32(q) == q and f32(1.0 - q) == 1.0 - q
    return q


def fmt(x):
    """Shortest decimal text that parses back to the identical f32."""
    if x != x:
        return "nan"
    for prec in range(1, 10):
        s = "%.*g" % (prec, x)
        if f32(float(s)) == x:
            return s
    return "%.9g" % x  # unreachable: 9 significant digits always round-trip


def normalize(v):
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / n, v[1] / n, v[2] / n)


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0])


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


# ---------------------------------------------------------------------------
# Mesh container
# ---------------------------------------------------------------------------

class Mesh:
    def __init__(self, name):
        self.name = name
        self.positions = []  # (x, y, z) f32
        self.normals = []    # (x, y, z) f32, unit length
        self.uvs = []        # (u, v_gltf) f32, or None for "no UVs"
        self.triangles = []  # (a, b, c) 0-based vertex indices

    def add(self, p, n, uv=None):
        self.positions.append(tuple(f32(c) for c in p))
        nn = normalize(n)
        self.normals.append(tuple(f32(c) for c in nn))
        if uv is not None:
            self.uvs.append((quv(uv[0]), quv(uv[1])))
        return len(self.positions) - 1

    def tri(self, a, b, c):
        self.triangles.append((a, b, c))

    @property
    def has_uvs(self):
        return len(self.uvs) > 0

    def check(self, lo=0.0, hi=1.0):
        """Sanity checks: bounds, unit normals, UV range, outward winding."""
        nv = len(self.positions)
        assert len(self.normals) == nv
        assert not self.uvs or len(self.uvs) == nv
        for p in self.positions:
            for c in p:
                assert lo <= c <= hi, (self.name, p)
        for n in self.normals:
            assert abs(math.sqrt(dot(n, n)) - 1.0) < 1e-6, (self.name, n)
        for uv in self.uvs:
            assert 0.0 <= uv[0] <= 1.0 and 0.0 <= uv[1] <= 1.0, (self.name, uv)
        for (a, b, c) in self.triangles:
            assert max(a, b, c) < nv
            pa, pb, pc = self.positions[a], self.positions[b], self.positions[c]
            gn = cross(sub(pb, pa), sub(pc, pa))
            assert dot(gn, gn) > 0.0, (self.name, "degenerate", (a, b, c))
            avg = tuple(self.normals[a][k] + self.normals[b][k]
                        + self.normals[c][k] for k in range(3))
            assert dot(gn, avg) > 0.0, (self.name, "winding", (a, b, c))


# ---------------------------------------------------------------------------
# Models
# ---------------------------------------------------------------------------

def make_plane():
    """Square in z = 0.5 over [0,1]^2, 4x4 quads, normal +z, u = x, v = 1 - y."""
    m = Mesh("plane")
    n = 4
    for j in range(n + 1):          # rows along y
        for i in range(n + 1):      # columns along x
            x, y = i / n, j / n
            m.add((x, y, 0.5), (0.0, 0.0, 1.0), (x, 1.0 - y))

    def vid(i, j):
        return j * (n + 1) + i

    for j in range(n):
        for i in range(n):
            a, b = vid(i, j), vid(i + 1, j)
            c, d = vid(i + 1, j + 1), vid(i, j + 1)
            m.tri(a, b, c)
            m.tri(a, c, d)
    return m


def make_sphere():
    """UV sphere, centre 0.5, radius 0.4, 32 segments x 16 rings.

    u = longitude / 2pi (seam duplicated at u = 0 and u = 1),
    v_gltf = colatitude / pi (v = 0 at the +z pole). Each pole has one vertex
    per segment, at u = (s + 0.5) / 32.
    """
    m = Mesh("sphere")
    segs, rings = 32, 16
    cx = cy = cz = 0.5
    radius = 0.4

    def ring_vertex(r, s):
        theta = math.pi * r / rings
        phi = 2.0 * math.pi * (s % segs) / segs  # s == segs: same as s == 0
        nrm = (math.sin(theta) * math.cos(phi),
               math.sin(theta) * math.sin(phi),
               math.cos(theta))
        pos = (cx + radius * nrm[0], cy + radius * nrm[1], cz + radius * nrm[2])
        return m.add(pos, nrm, (s / segs, r / rings))

    top = [m.add((cx, cy, cz + radius), (0.0, 0.0, 1.0), ((s + 0.5) / segs, 0.0))
           for s in range(segs)]
    ring = {}
    for r in range(1, rings):
        for s in range(segs + 1):
            ring[(r, s)] = ring_vertex(r, s)
    bottom = [m.add((cx, cy, cz - radius), (0.0, 0.0, -1.0),
                    ((s + 0.5) / segs, 1.0))
              for s in range(segs)]

    for s in range(segs):
        m.tri(top[s], ring[(1, s)], ring[(1, s + 1)])
    for r in range(1, rings - 1):
        for s in range(segs):
            a, b = ring[(r, s)], ring[(r + 1, s)]
            c, d = ring[(r + 1, s + 1)], ring[(r, s + 1)]
            m.tri(a, b, c)
            m.tri(a, c, d)
    for s in range(segs):
        m.tri(ring[(rings - 1, s)], bottom[s], ring[(rings - 1, s + 1)])
    return m


# 3 x 2 atlas: islands of side 0.3; columns start at u = 0.025, 0.35, 0.675
# (gaps and margins 0.025), rows start at v = 0.1, 0.6 (margins 0.1, gap 0.2).
CUBE_ISLAND = 0.3
CUBE_U0 = (0.025, 0.35, 0.675)
CUBE_V0 = (0.1, 0.6)
# (normal, right, up, column, row); right x up == normal, so the image of each
# face is upright and un-mirrored when the face is viewed from outside.
CUBE_FACES = (
    ((1, 0, 0), (0, 1, 0), (0, 0, 1), 0, 0),     # +x
    ((0, 1, 0), (-1, 0, 0), (0, 0, 1), 1, 0),    # +y
    ((0, 0, 1), (1, 0, 0), (0, 1, 0), 2, 0),     # +z
    ((-1, 0, 0), (0, -1, 0), (0, 0, 1), 0, 1),   # -x
    ((0, -1, 0), (1, 0, 0), (0, 0, 1), 1, 1),    # -y
    ((0, 0, -1), (1, 0, 0), (0, -1, 0), 2, 1),   # -z
)


def make_cube():
    """Cube [0.2,0.8]^3, flat normals, each face its own island in a 3x2 atlas."""
    m = Mesh("cube")
    half = 0.3
    for (nrm, right, up, col, row) in CUBE_FACES:
        assert cross(right, up) == nrm
        centre = tuple(0.5 + half * c for c in nrm)
        corners = []
        for (s, t) in ((0, 0), (1, 0), (1, 1), (0, 1)):
            pos = tuple(centre[k] + half * (2 * s - 1) * right[k]
                        + half * (2 * t - 1) * up[k] for k in range(3))
            uv = (CUBE_U0[col] + CUBE_ISLAND * s,
                  CUBE_V0[row] + CUBE_ISLAND * (1 - t))
            corners.append(m.add(pos, nrm, uv))
        a, b, c, d = corners
        m.tri(a, b, c)
        m.tri(a, c, d)
    return m


KNOT_P, KNOT_Q = 2, 3
KNOT_R, KNOT_r, KNOT_TUBE = 0.25, 0.12, 0.07
KNOT_SEGS, KNOT_SIDES = 200, 25


def knot_curve(t):
    """(2,3) torus knot centred at the origin."""
    w = KNOT_R + KNOT_r * math.cos(KNOT_Q * t)
    return (w * math.cos(KNOT_P * t), w * math.sin(KNOT_P * t),
            -KNOT_r * math.sin(KNOT_Q * t))


def make_knot():
    """(2,3) torus-knot tube, 200 x 25 quads = 10 000 triangles.

    u = arc parameter along the knot in [0,1], v = angle around the tube in
    [0,1]; both seams duplicated (bit-identical positions/normals).
    """
    m = Mesh("knot")
    segs, sides = KNOT_SEGS, KNOT_SIDES
    vid = {}
    for i in range(segs + 1):
        t = 2.0 * math.pi * (i % segs) / segs
        p1 = knot_curve(t)
        p2 = knot_curve(t + 0.01)
        tan = normalize(sub(p2, p1))
        nn = (p1[0] + p2[0], p1[1] + p2[1], p1[2] + p2[2])
        bn = normalize(cross(tan, nn))
        nn = cross(bn, tan)  # unit: bn and tan are orthonormal
        for j in range(sides + 1):
            a = 2.0 * math.pi * (j % sides) / sides
            ca, sa = math.cos(a), math.sin(a)
            nrm = (ca * nn[0] + sa * bn[0], ca * nn[1] + sa * bn[1],
                   ca * nn[2] + sa * bn[2])
            pos = tuple(0.5 + p1[k] + KNOT_TUBE * nrm[k] for k in range(3))
            vid[(i, j)] = m.add(pos, nrm, (i / segs, j / sides))
    # (tangent) x (around) points inwards for this frame, so go around first.
    for i in range(segs):
        for j in range(sides):
            a, b = vid[(i, j)], vid[(i, j + 1)]
            c, d = vid[(i + 1, j + 1)], vid[(i + 1, j)]
            m.tri(a, b, c)
            m.tri(a, c, d)
    return m


def check_knot_clearance():
    """The tube must not self-intersect: distinct strands > 2 * tube apart."""
    n = 1000
    pts = [knot_curve(2.0 * math.pi * k / n) for k in range(n)]
    best = float("inf")
    skip = n // 10  # ignore neighbours along the curve (t within 0.63 rad)
    for a in range(n):
        for b in range(a + skip, a + n - skip + 1):
            d = sub(pts[a], pts[b % n])
            best = min(best, dot(d, d))
    best = math.sqrt(best)
    assert best > 2.0 * KNOT_TUBE * 1.2, best
    return best


def make_no_uv():
    m = Mesh("no_uv")
    n = (0.0, 0.0, 1.0)
    m.add((0.2, 0.2, 0.5), n)
    m.add((0.8, 0.2, 0.5), n)
    m.add((0.5, 0.8, 0.5), n)
    m.tri(0, 1, 2)
    return m


# ---------------------------------------------------------------------------
# glTF / GLB writer
# ---------------------------------------------------------------------------

def pad4(data, fill=b"\x00"):
    return data + fill * ((-len(data)) % 4)


def build_gltf(mesh):
    """Return (gltf_json_dict_without_buffer_uri, binary_buffer_bytes)."""
    blobs = []
    buffer_views = []
    accessors = []
    offset = 0

    def add_view(data, target):
        nonlocal offset
        assert offset % 4 == 0
        buffer_views.append({"buffer": 0, "byteOffset": offset,
                             "byteLength": len(data), "target": target})
        blobs.append(pad4(data))
        offset += len(blobs[-1])
        return len(buffer_views) - 1

    nv = len(mesh.positions)

    pos_bytes = b"".join(struct.pack("<3f", *p) for p in mesh.positions)
    view = add_view(pos_bytes, ARRAY_BUFFER)
    mins = [min(p[k] for p in mesh.positions) for k in range(3)]
    maxs = [max(p[k] for p in mesh.positions) for k in range(3)]
    accessors.append({"bufferView": view, "componentType": FLOAT,
                      "count": nv, "type": "VEC3", "min": mins, "max": maxs})
    attributes = {"POSITION": len(accessors) - 1}

    nrm_bytes = b"".join(struct.pack("<3f", *n) for n in mesh.normals)
    view = add_view(nrm_bytes, ARRAY_BUFFER)
    accessors.append({"bufferView": view, "componentType": FLOAT,
                      "count": nv, "type": "VEC3"})
    attributes["NORMAL"] = len(accessors) - 1

    if mesh.has_uvs:
        uv_bytes = b"".join(struct.pack("<2f", *uv) for uv in mesh.uvs)
        view = add_view(uv_bytes, ARRAY_BUFFER)
        accessors.append({"bufferView": view, "componentType": FLOAT,
                          "count": nv, "type": "VEC2"})
        attributes["TEXCOORD_0"] = len(accessors) - 1

    flat = [i for t in mesh.triangles for i in t]
    if nv <= 65535:
        ctype, code = UNSIGNED_SHORT, "H"
    else:
        ctype, code = UNSIGNED_INT, "I"
    idx_bytes = struct.pack("<%d%s" % (len(flat), code), *flat)
    view = add_view(idx_bytes, ELEMENT_ARRAY_BUFFER)
    accessors.append({"bufferView": view, "componentType": ctype,
                      "count": len(flat), "type": "SCALAR"})
    indices = len(accessors) - 1

    buf = b"".join(blobs)
    assert len(buf) % 4 == 0
    doc = {
        "asset": {"version": "2.0", "generator": GENERATOR,
                  "copyright": "texgraph project, CC0 1.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": mesh.name}],
        "meshes": [{"name": mesh.name,
                    "primitives": [{"attributes": attributes,
                                    "indices": indices, "mode": 4}]}],
        "accessors": accessors,
        "bufferViews": buffer_views,
        "buffers": [{"byteLength": len(buf)}],
    }
    return doc, buf


def write_file(name, data, written):
    path = os.path.join(OUT_DIR, name)
    with open(path, "wb") as f:
        f.write(data)
    written.append(name)


def gltf_text(doc):
    return (json.dumps(doc, indent=2) + "\n").encode("utf-8")


def write_gltf_separate(mesh, name, bin_name, written):
    doc, buf = build_gltf(mesh)
    doc["buffers"][0] = {"uri": bin_name, "byteLength": len(buf)}
    write_file(bin_name, buf, written)
    write_file(name, gltf_text(doc), written)


def write_gltf_embedded(mesh, name, written):
    doc, buf = build_gltf(mesh)
    uri = ("data:application/octet-stream;base64,"
           + base64.b64encode(buf).decode("ascii"))
    doc["buffers"][0] = {"uri": uri, "byteLength": len(buf)}
    write_file(name, gltf_text(doc), written)


def write_glb(mesh, name, written):
    doc, buf = build_gltf(mesh)
    js = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    js = pad4(js, b" ")
    bin_chunk = pad4(buf, b"\x00")
    total = 12 + 8 + len(js) + 8 + len(bin_chunk)
    out = (struct.pack("<4sII", b"glTF", 2, total)
           + struct.pack("<II", len(js), 0x4E4F534A) + js
           + struct.pack("<II", len(bin_chunk), 0x004E4942) + bin_chunk)
    assert len(out) == total
    write_file(name, out, written)


# ---------------------------------------------------------------------------
# OBJ writer
# ---------------------------------------------------------------------------

def obj_text(mesh):
    lines = [
        "# texgraph example mesh '%s' (generated by make_meshes.py)" % mesh.name,
        "# Made by the texgraph project; CC0 1.0 (public domain dedication).",
        "# vt v axis points up: vt = (u, 1 - v_gltf).",
        "# %d vertices, %d triangles" % (len(mesh.positions), len(mesh.triangles)),
        "o %s" % mesh.name,
    ]
    for p in mesh.positions:
        lines.append("v %s %s %s" % tuple(fmt(c) for c in p))
    for uv in mesh.uvs:
        # Exact: uvs are multiples of 2^-24 (see quv), so 1 - v is an f32.
        flipped = 1.0 - uv[1]
        assert f32(flipped) == flipped and 1.0 - flipped == uv[1]
        lines.append("vt %s %s" % (fmt(uv[0]), fmt(flipped)))
    for n in mesh.normals:
        lines.append("vn %s %s %s" % tuple(fmt(c) for c in n))
    for (a, b, c) in mesh.triangles:
        if mesh.has_uvs:
            lines.append("f %d/%d/%d %d/%d/%d %d/%d/%d"
                         % (a + 1, a + 1, a + 1, b + 1, b + 1, b + 1,
                            c + 1, c + 1, c + 1))
        else:
            lines.append("f %d//%d %d//%d %d//%d"
                         % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1))
    return ("\n".join(lines) + "\n").encode("ascii")


def write_obj(mesh, name, written, limit=None):
    data = obj_text(mesh)
    if limit is not None and len(data) >= limit:
        print("skipping %s: %d bytes >= %d" % (name, len(data), limit))
        return
    write_file(name, data, written)


NAN_OBJ = """\
# texgraph example mesh 'nan' (generated by make_meshes.py)
# Made by the texgraph project; CC0 1.0 (public domain dedication).
# One triangle whose first position has a NaN x coordinate (invalid input).
o nan
v nan 0.0 0.0
v 0.8 0.2 0.5
v 0.5 0.8 0.5
vt 0.2 0.2
vt 0.8 0.2
vt 0.5 0.8
vn 0 0 1
vn 0 0 1
vn 0 0 1
f 1/1/1 2/2/2 3/3/3
"""


# ---------------------------------------------------------------------------

def main():
    written = []
    tris = {}

    plane = make_plane()
    sphere = make_sphere()
    cube = make_cube()
    check_knot_clearance()
    knot = make_knot()
    no_uv = make_no_uv()
    for m in (plane, sphere, cube, no_uv):
        m.check(0.0, 1.0)
    knot.check(0.05, 0.95)
    for m in (plane, sphere, cube, knot, no_uv):
        tris[m.name] = len(m.triangles)

    write_gltf_separate(plane, "plane.gltf", "plane.bin", written)
    write_obj(plane, "plane.obj", written)

    write_glb(sphere, "sphere.glb", written)
    write_gltf_embedded(sphere, "sphere_embedded.gltf", written)
    write_obj(sphere, "sphere.obj", written)

    write_glb(cube, "cube.glb", written)
    write_obj(cube, "cube.obj", written)

    write_glb(knot, "knot.glb", written)

    write_glb(no_uv, "no_uv.glb", written)
    write_obj(no_uv, "no_uv.obj", written)

    write_file("nan.obj", NAN_OBJ.encode("ascii"), written)
    tris["nan"] = 1

    print("%-22s %10s %10s" % ("file", "bytes", "triangles"))
    for name in written:
        size = os.path.getsize(os.path.join(OUT_DIR, name))
        stem = name.split(".")[0].replace("_embedded", "")
        count = "" if name.endswith(".bin") else str(tris[stem])
        print("%-22s %10d %10s" % (name, size, count))


if __name__ == "__main__":
    main()
