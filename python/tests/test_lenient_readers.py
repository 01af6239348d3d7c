"""Files other tools write (issue 23), read from Python through the same
readers as the command line: a lenient OBJ (Latin-1 names, CRLF, a line
continuation, a missing material library, partial vertex colours), a binvox
header with comments, and NRRD with bzip2 encoding, 2-D images and 4-D
volumes with a size-1 axis, compared with pynrrd (an independent reader)."""

import numpy as np
import pytest

import voxkit

CUBE_V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
CUBE_F = ["1 4 3 2", "5 6 7 8", "-8 -7 -3 -4", "2 3 7 6", "-5 -1 -2 -6", "1 5 8 4"]


def _cube_corners(v, f):
    return sorted(tuple(map(tuple, v[t])) for t in f)


def test_lenient_obj_gives_the_plain_cube(tmp_path):
    plain = "".join(f"v {x} {y} {z}\n" for x, y, z in CUBE_V) + "".join(f"f {f}\n" for f in CUBE_F)
    (tmp_path / "plain.obj").write_text(plain)
    want = _cube_corners(*voxkit.load_mesh(tmp_path / "plain.obj"))
    assert len(want) == 12

    lines = [b"mtllib missing_mat\xe9riaux.mtl", b"o Cub\xe9", b"usemtl rouge_\xe9t\xe9"]
    for i, (x, y, z) in enumerate(CUBE_V):
        colour = b" 1 0 0" if i < 3 else b""  # colours on 3 of 8 vertices
        lines.append(f"v {x} {y} {z}".encode() + colour)
    for f in CUBE_F:
        a, b, c, d = f.split()
        lines.append(f"f {a} {b} \\\r\n {c} {d}".encode())  # continued over CRLF
    (tmp_path / "messy.obj").write_bytes(b"\r\n".join(lines) + b"\r\n")
    v, f = voxkit.load_mesh(tmp_path / "messy.obj")
    assert _cube_corners(v, f) == want


def test_binvox_with_comment_lines(tmp_path):
    data = bytes([0, 3, 1, 1, 0, 4])
    (tmp_path / "a.binvox").write_bytes(b"#binvox 1\ndim 2 2 2\ntranslate 0 0 0\nscale 2\ndata\n" + data)
    (tmp_path / "b.binvox").write_bytes(
        b"#binvox 1\n# made by a converter\ndim 2 2 2\n#\ntranslate 0 0 0\nscale 2\ndata\n" + data
    )
    a = voxkit.load_grid(tmp_path / "a.binvox")
    b = voxkit.load_grid(tmp_path / "b.binvox")
    assert a.dims == b.dims
    assert np.array_equal(a.indices(), b.indices())
    assert len(b.indices()) == 1


def _pynrrd():
    return pytest.importorskip("nrrd", reason="pynrrd is the reference (installed by .ci/run)")


@pytest.mark.parametrize("detached", [False, True])
def test_nrrd_bzip2_matches_pynrrd(tmp_path, detached):
    nrrd = _pynrrd()
    rng = np.random.default_rng(7)
    data = rng.integers(-2000, 2000, size=(6, 5, 4)).astype(np.int16)
    path = tmp_path / ("v.nhdr" if detached else "v.nrrd")
    nrrd.write(
        str(path),
        data,
        header={"encoding": "bzip2", "space directions": np.diag([0.5, 0.75, 2.0]), "space": "left-posterior-superior",
                "space origin": np.array([1.0, 2.0, 3.0])},
        index_order="F",
        detached_header=detached,
    )
    ref, header = nrrd.read(str(path), index_order="F")
    arr, spacing, origin = voxkit.read_volume(path)
    assert arr.dtype == ref.dtype
    assert np.array_equal(arr, ref)
    assert np.allclose(spacing, [0.5, 0.75, 2.0])
    assert np.allclose(origin, header["space origin"])


def test_nrrd_2d_and_squeezed_4d_match_pynrrd(tmp_path):
    nrrd = _pynrrd()
    img = np.arange(12, dtype=np.uint16).reshape(4, 3) * 1000
    nrrd.write(str(tmp_path / "img.nrrd"), img, header={"encoding": "bzip2"}, index_order="F")
    ref, _ = nrrd.read(str(tmp_path / "img.nrrd"), index_order="F")
    arr, spacing, _ = voxkit.read_volume(tmp_path / "img.nrrd")
    assert arr.shape == (4, 3, 1)
    assert np.array_equal(arr[:, :, 0], ref)

    vol = np.arange(1 * 4 * 3 * 2, dtype=np.float32).reshape(1, 4, 3, 2) / 8
    nrrd.write(
        str(tmp_path / "v4.nrrd"),
        vol,
        header={"encoding": "gzip", "kinds": ["scalar", "domain", "domain", "domain"]},
        index_order="F",
    )
    ref, _ = nrrd.read(str(tmp_path / "v4.nrrd"), index_order="F")
    arr, _, _ = voxkit.read_volume(tmp_path / "v4.nrrd")
    assert arr.shape == (4, 3, 2)
    assert np.array_equal(arr, ref[0])

    # A 4-D volume with no axis of size 1 is refused in one line.
    nrrd.write(str(tmp_path / "bad.nrrd"), np.zeros((2, 2, 2, 2), np.uint8), index_order="F")
    with pytest.raises(ValueError) as e:
        voxkit.read_volume(tmp_path / "bad.nrrd")
    assert "bad.nrrd" in str(e.value) and "\n" not in str(e.value)
