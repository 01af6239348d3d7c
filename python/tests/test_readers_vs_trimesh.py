"""PLY, STL and OFF read by voxkit and by trimesh (an independent reader,
issue 23), on files written here in every layout the formats allow: PLY
ascii and binary of both byte orders, with comments, obj_info, extra vertex
and face properties and every list count type; STL ascii (several solids,
odd spacing) and binary (a header that starts with ``solid``); OFF with
comments, blank lines, colours and the COFF/NOFF variants.

Triangle-only files must give the same triangles (same corners, same
orientation), as a multiset; polygon files the same triangle count, area and
bounding box (the two readers may fan a polygon from different corners).
trimesh is told not to process the mesh (no merging, no dropping). The
meshes have no degenerate triangles, which voxkit drops and trimesh keeps."""

import struct

import numpy as np
import pytest

import voxkit

trimesh = pytest.importorskip("trimesh")

SEEDS = [1, 2, 3]


def _random_mesh(seed, polygons=False):
    """A band of a perturbed sphere: triangles, or, with ``polygons``, some
    quads too (``"quads"``: quads only)."""
    rng = np.random.default_rng(seed)
    n_lat, n_lon = int(rng.integers(4, 9)), int(rng.integers(5, 11))
    scale = rng.uniform(0.01, 1000.0)
    centre = rng.uniform(-1e3, 1e3, 3)
    verts, index = [], {}
    for i in range(n_lat + 1):
        for j in range(n_lon):
            th, ph = np.pi * i / n_lat, 2 * np.pi * j / n_lon
            r = scale * (1 + 0.1 * rng.uniform())
            p = centre + r * np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
            index[i, j] = len(verts)
            verts.append(p)
    faces = []
    for i in range(1, n_lat - 1):
        for j in range(n_lon):
            a, b = index[i, j], index[i, (j + 1) % n_lon]
            c, d = index[i + 1, (j + 1) % n_lon], index[i + 1, j]
            if polygons == "quads" or (polygons and rng.uniform() < 0.5):
                faces.append([a, d, c, b])
            else:
                faces.append([a, d, c])
                faces.append([a, c, b])
    return np.array(verts), faces


def _canonical(tri):
    """A triangle as its corners, rotated so the smallest comes first
    (orientation kept)."""
    k = min(range(3), key=lambda i: tri[i])
    return tuple(tri[(k + i) % 3] for i in range(3))


def _triangles(v, f):
    return sorted(_canonical([tuple(map(float, v[i])) for i in t]) for t in f)


def _area(v, f):
    v, f = np.asarray(v, float), np.asarray(f)
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum()


def _theirs(path):
    m = trimesh.load(str(path), process=False, force="mesh")
    return np.asarray(m.vertices), np.asarray(m.faces)


def _same(path, polygons):
    v, f = voxkit.load_mesh(path)
    tv, tf = _theirs(path)
    assert len(f) == len(tf), path.name
    if polygons:
        assert np.allclose(_area(v, f), _area(tv, tf), rtol=1e-12), path.name
        # Only the corners faces use: a reader may keep unreferenced vertices.
        assert np.array_equal(v[np.unique(f)].min(0), tv[np.unique(tf)].min(0)), path.name
        assert np.array_equal(v[np.unique(f)].max(0), tv[np.unique(tf)].max(0)), path.name
    else:
        assert _triangles(v, f) == _triangles(tv, tf), path.name


# ---------------------------------------------------------------- PLY


def _ply(path, v, faces, fmt, count_type="uchar", index_type="int", extras=True):
    """Writes a PLY in ``fmt`` (ascii, binary_little_endian, binary_big_endian)."""
    head = [
        "ply",
        f"format {fmt} 1.0",
        "comment written by voxkit's tests",
        "obj_info a random surface",
        f"element vertex {len(v)}",
        "property double x",
        "property double y",
        "property double z",
    ]
    if extras:
        head += ["property uchar red", "property uchar green", "property uchar blue", "property float quality"]
    head += [f"element face {len(faces)}", f"property list {count_type} {index_type} vertex_indices"]
    if extras:
        head += ["property int flags"]
    head += ["end_header"]
    out = ("\n".join(head) + "\n").encode()
    if fmt == "ascii":
        rows = []
        for p in v:
            row = " ".join(repr(float(c)) for c in p)
            rows.append(row + (" 10 20 30 0.5" if extras else ""))
        for face in faces:
            rows.append(" ".join(map(str, [len(face), *face])) + (" 7" if extras else ""))
        return path.write_bytes(out + ("\n".join(rows) + "\n").encode())
    e = "<" if fmt == "binary_little_endian" else ">"
    codes = {"uchar": "B", "char": "b", "ushort": "H", "short": "h", "uint": "I", "int": "i",
             "uint8": "B", "int32": "i", "uint32": "I"}
    body = bytearray()
    for p in v:
        body += struct.pack(e + "3d", *p)
        if extras:
            body += struct.pack(e + "3Bf", 10, 20, 30, 0.5)
    for face in faces:
        body += struct.pack(e + codes[count_type], len(face))
        body += struct.pack(e + codes[index_type] * len(face), *face)
        if extras:
            body += struct.pack(e + "i", 7)
    path.write_bytes(out + bytes(body))


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
@pytest.mark.parametrize("polygons", [False, True])
def test_ply_matches_trimesh(tmp_path, seed, fmt, polygons):
    # trimesh 5.2 reads binary PLY lists only when all have one length.
    if polygons and fmt != "ascii":
        polygons = "quads"
    v, faces = _random_mesh(seed, polygons)
    path = tmp_path / "m.ply"
    _ply(path, v, faces, fmt, extras=not polygons)
    _same(path, polygons)


@pytest.mark.parametrize("count_type,index_type", [("uchar", "uint"), ("uint8", "int32"), ("ushort", "int"), ("int", "uint")])
@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test_ply_list_types_match_trimesh(tmp_path, count_type, index_type, fmt):
    v, faces = _random_mesh(7)
    path = tmp_path / "m.ply"
    _ply(path, v, faces, fmt, count_type, index_type, extras=False)
    _same(path, False)


# ---------------------------------------------------------------- STL


def _stl_ascii(path, v, faces, solids=2):
    tris = [t for face in faces for t in ([face] if len(face) == 3 else [])]
    chunks = np.array_split(np.arange(len(tris)), solids)
    lines = []
    for s, chunk in enumerate(chunks):
        lines.append(f"solid part{s}")
        for k in chunk:
            a, b, c = (v[i] for i in tris[k])
            n = np.cross(b - a, c - a)
            lines.append("  facet normal " + " ".join(f"{x:e}" for x in n))
            lines.append("    outer loop")
            for p in (a, b, c):
                lines.append("      vertex   " + "  ".join(repr(float(x)) for x in p))
            lines.append("    endloop")
            lines.append("  endfacet")
        lines.append(f"endsolid part{s}")
    path.write_text("\n".join(lines) + "\n")


def _stl_binary(path, v, faces):
    tris = [face for face in faces if len(face) == 3]
    header = b"solid but binary: some exporters start the header like this".ljust(80, b" ")
    body = bytearray(header + struct.pack("<I", len(tris)))
    for t in tris:
        a, b, c = (v[i] for i in t)
        body += struct.pack("<12fH", *np.cross(b - a, c - a), *a, *b, *c, 0)
    path.write_bytes(bytes(body))


@pytest.mark.parametrize("seed", SEEDS)
def test_stl_ascii_matches_trimesh(tmp_path, seed):
    # Both read ascii as float64 (repr() writes every digit a float64
    # needs), so the corners are equal bit for bit, not only within float32.
    v, faces = _random_mesh(seed)
    path = tmp_path / "m.stl"
    _stl_ascii(path, v, faces)
    _same(path, False)
    assert not np.array_equal(v, v.astype(np.float32)), "the check needs corners float32 cannot hold"


@pytest.mark.parametrize("seed", SEEDS)
def test_stl_binary_matches_trimesh(tmp_path, seed):
    # Binary STL stores float32: both readers see the same rounded corners,
    # but float32 rounding may make a thin triangle degenerate; drop those.
    v, faces = _random_mesh(seed)
    v32 = v.astype(np.float32).astype(np.float64)
    faces = [t for t in faces if np.linalg.norm(np.cross(v32[t[1]] - v32[t[0]], v32[t[2]] - v32[t[0]])) > 0]
    path = tmp_path / "m.stl"
    _stl_binary(path, v, faces)
    _same(path, False)


# ---------------------------------------------------------------- OFF


def _off(path, v, faces, kind="OFF"):
    lines = [kind, "# a comment line", ""]
    lines.append(f"{len(v)} {len(faces)} 0")
    for p in v:
        row = " ".join(repr(float(c)) for c in p)
        if kind == "COFF":
            row += " 255 128 0 255"
        elif kind == "NOFF":
            row += " 0 0 1"
        lines.append(row)
    for face in faces:
        lines.append(" ".join(map(str, [len(face), *face])) + ("  200 10 10" if kind == "COFF" else ""))
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("kind", ["OFF", "COFF"])
@pytest.mark.parametrize("polygons", [False, True])
def test_off_matches_trimesh(tmp_path, seed, kind, polygons):
    v, faces = _random_mesh(seed, polygons)
    path = tmp_path / "m.off"
    _off(path, v, faces, kind)
    _same(path, polygons)


def test_noff_reads_positions(tmp_path):
    # trimesh 5.2 does not read NOFF; the answer is the plain OFF's.
    v, faces = _random_mesh(4)
    _off(tmp_path / "plain.off", v, faces)
    _off(tmp_path / "normals.off", v, faces, "NOFF")
    pv, pf = voxkit.load_mesh(tmp_path / "plain.off")
    nv, nf = voxkit.load_mesh(tmp_path / "normals.off")
    assert _triangles(pv, pf) == _triangles(nv, nf)
