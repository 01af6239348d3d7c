"""load_mesh reads PLY, STL and OFF: files written here from spot.obj give
the OBJ's mesh (exactly where the format holds f64, rounded to f32 where it
holds f32)."""

import struct

import numpy as np

import voxkit
from conftest import SPOT


def test_off_and_binary_ply_match_the_obj(tmp_path):
    v, f = voxkit.load_mesh(SPOT)
    off = tmp_path / "spot.off"
    lines = ["OFF", f"{len(v)} {len(f)} 0"]
    lines += [" ".join(repr(float(c)) for c in p) for p in v]
    lines += ["3 " + " ".join(str(int(i)) for i in t) for t in f]
    off.write_text("\n".join(lines) + "\n")
    ply = tmp_path / "spot.ply"
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(v)}\nproperty double x\nproperty double y\nproperty double z\n"
        f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    faces = b"".join(struct.pack("<B3i", 3, *map(int, t)) for t in f)
    ply.write_bytes(header.encode() + v.astype("<f8").tobytes() + faces)
    for path in (off, ply):
        v2, f2 = voxkit.load_mesh(path)
        assert np.array_equal(v2, v), path
        assert np.array_equal(f2, f), path


def test_binary_stl_merges_shared_corners(tmp_path):
    v, f = voxkit.load_mesh(SPOT)
    corners = v[f].astype("<f4")  # (M, 3, 3)
    rec = np.zeros(len(f), dtype=[("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["v"] = corners
    stl = tmp_path / "spot.stl"
    stl.write_bytes(b"\0" * 80 + struct.pack("<I", len(f)) + rec.tobytes())
    v2, f2 = voxkit.load_mesh(stl)
    assert f2.shape == f.shape
    assert np.array_equal(v2[f2], corners.astype(np.float64))
    assert len(v2) == len(np.unique(corners.reshape(-1, 3), axis=0))


def test_truncated_files_are_value_errors(tmp_path):
    p = tmp_path / "big.ply"
    p.write_bytes(
        b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
        b"property float x\nproperty float y\nproperty float z\nend_header\n"
    )
    try:
        voxkit.load_mesh(p)
    except ValueError as e:
        assert "1000000000000" in str(e)
    else:
        raise AssertionError("a header beyond the data must fail")
