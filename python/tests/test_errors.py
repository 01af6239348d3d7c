"""Every bad input raises the right Python exception with the library's
message, and none takes the interpreter down."""

import subprocess
import sys

import numpy as np
import pytest

import voxkit
from conftest import CT_HEAD, SPOT

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
F = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]], dtype=np.int64)


def nan_vertices():
    v = V.copy()
    v[2, 1] = np.nan
    return v


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda: voxkit.voxelize(nan_vertices(), F, resolution=8), ValueError, "non-finite"),
        (lambda: voxkit.voxelize(V, F + 10, resolution=8), ValueError, "vertex index"),
        (lambda: voxkit.voxelize(V, -F, resolution=8), ValueError, "vertex index -"),
        (lambda: voxkit.voxelize(V[:, :2], F, resolution=8), ValueError, "vertices must have 3 columns"),
        (lambda: voxkit.voxelize(V, F[:, :2], resolution=8), ValueError, "faces must have 3 columns"),
        (lambda: voxkit.voxelize(V, F.astype(float), resolution=8), ValueError, "integer"),
        (lambda: voxkit.voxelize(V, np.array([[0, 0, 1]]), resolution=8), ValueError, "empty mesh"),
        (lambda: voxkit.voxelize(np.zeros((3, 3)), np.array([[0, 1, 2]])), ValueError, "empty mesh"),
        (lambda: voxkit.voxelize(V, F, resolution=8, threads=0), ValueError, "threads"),
        (lambda: voxkit.voxelize(V, F, resolution=0), ValueError, "resolution"),
        (lambda: voxkit.voxelize(V, F, resolution=-3), ValueError, "resolution"),
        (lambda: voxkit.voxelize(V, F, resolution=2.5), ValueError, "integer"),
        (lambda: voxkit.voxelize(V, F, resolution=8, voxel_size=0.1), ValueError, "not both"),
        (lambda: voxkit.voxelize(V, F, origin=(0, 0, 0)), ValueError, "voxel_size"),
        (lambda: voxkit.voxelize(V, F, voxel_size=0.0), ValueError, "voxel size"),
        (lambda: voxkit.voxelize(V, F, voxel_size=float("nan")), ValueError, "voxel size"),
        (lambda: voxkit.voxelize(V, F, voxel_size=0.1, origin=(0, float("inf"), 0)), ValueError, "origin"),
        (lambda: voxkit.voxelize(V, F, voxel_size=1e-300), ValueError, "per axis"),
        (lambda: voxkit.voxelize(V, F, resolution=8, mode="hollow"), ValueError, "mode"),
        (lambda: voxkit.voxelize("not a mesh"), TypeError, "vertices"),
        (lambda: voxkit.voxelize(V, F, resolution=4000, mode="solid", max_memory_mib=16), MemoryError, "memory limit"),
        (lambda: voxkit.voxelize(V, F, resolution=64, max_memory_mib=0), MemoryError, "memory limit"),
        (lambda: voxkit.voxelize(V, F, voxel_size=1e-5), MemoryError, "memory limit"),
        (lambda: voxkit.load_mesh("/nonexistent/x.obj"), FileNotFoundError, "nonexistent"),
        (lambda: voxkit.load_mesh(SPOT.with_suffix(".xyz")), ValueError, "unknown mesh format"),
        (lambda: voxkit.load_grid("/nonexistent/g.binvox"), FileNotFoundError, "nonexistent"),
        (lambda: voxkit.load_grid("g.xyz"), ValueError, "unknown voxel format"),
        (lambda: voxkit.read_volume("/nonexistent/v.nrrd"), OSError, "nonexistent"),
        (lambda: voxkit.line((0, 0, 0), (1, float("nan"), 0)), ValueError, "not finite"),
        (lambda: voxkit.line((0, 0, 0), (3e9, 0, 0)), ValueError, "supported range"),
        (lambda: voxkit.line((0, 0, 0), (1, 1, 1), kind="bresenham"), ValueError, "kind"),
        (lambda: voxkit.line((0, 0), (1, 1, 1)), ValueError, "three"),
        (lambda: voxkit.lines(np.zeros((3, 5))), ValueError, r"\(N, 6\)"),
        (lambda: voxkit.lines(np.array([[0, 0, 0, 1, 1, 1], [0, 0, 0, np.nan, 0, 0.0]])), ValueError, "segment 1"),
        (lambda: voxkit.render(np.zeros((4, 4))), ValueError, "3D"),
        (lambda: voxkit.render(np.ones((4, 4, 4), bool), ray="7"), ValueError, "ray"),
        (lambda: voxkit.render(np.ones((4, 4, 4), bool), view="sideways"), ValueError, "view"),
        (lambda: voxkit.render(np.ones((4, 4, 4), bool), size=(0, 10)), ValueError, "size"),
        (lambda: voxkit.render(np.ones((4, 4, 4), bool), fov=180), ValueError, "field of view"),
        (lambda: voxkit.render(np.ones((4, 4, 4), bool), eye=(2, 2, 2), target=(2, 2, 2)), ValueError, "eye"),
        (lambda: voxkit.render(np.ones((4, 4, 4), bool), size=(100000, 100000)), MemoryError, "memory limit"),
        (lambda: voxkit.render(np.zeros((4, 4, 4), np.complex64)), ValueError, "volume"),
        (lambda: voxkit.render(np.arange(64.0).reshape(4, 4, 4), volume="xray"), ValueError, "volume"),
        (lambda: voxkit.render(np.arange(64.0).reshape(4, 4, 4), iso=3.0), ValueError, "iso"),
        (lambda: voxkit.render(np.arange(64.0).reshape(4, 4, 4), volume="composite", tf="x"), ValueError, "transfer function"),
        (lambda: voxkit.render(np.arange(64.0).reshape(4, 4, 4), spacing=(1, 0, 1)), ValueError, "singular"),
    ],
)
def test_bad_input_raises(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


def test_grid_method_errors(tmp_path):
    g = voxkit.voxelize(V, F, resolution=8)
    with pytest.raises(ValueError, match="connectivity"):
        g.tunnels(18)
    with pytest.raises(ValueError, match="unknown voxel format"):
        g.save(tmp_path / "g.txt")
    with pytest.raises(FileNotFoundError):
        g.save(tmp_path / "missing-dir" / "g.binvox")
    with pytest.raises(MemoryError):
        g.dense(max_memory_mib=0)
    with pytest.raises(ValueError, match="non-finite"):
        g.measure(nan_vertices(), F)
    with pytest.raises(ValueError, match="volume, iso, window and tf"):
        voxkit.render(g, volume="mip")


def test_corrupt_files_are_value_errors(tmp_path):
    p = tmp_path / "bad.binvox"
    p.write_bytes(b"#binvox 1\ndim 4 4 4\ntranslate 0 0 0\nscale 1\ndata\n\x01")
    with pytest.raises(ValueError):
        voxkit.load_grid(p)
    o = tmp_path / "bad.obj"
    o.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    with pytest.raises(ValueError, match="bad.obj"):
        voxkit.load_mesh(o)
    n = tmp_path / "bad.nrrd"
    n.write_text("NRRD0004\ntype: float\ndimension: 3\nsizes: 4 4\n")
    with pytest.raises(ValueError):
        voxkit.read_volume(n)
    assert CT_HEAD.exists()


def test_a_panic_is_a_runtime_error_not_a_crash():
    with pytest.raises(RuntimeError, match="internal error.*deliberate test panic"):
        voxkit._voxkit._panic_for_test()
    # The interpreter carries on.
    assert len(voxkit.voxelize(V, F, resolution=4)) > 0


def test_bad_mesh_does_not_crash_a_fresh_interpreter():
    code = (
        "import numpy as np, voxkit\n"
        "v = np.random.default_rng(1).normal(size=(50, 3)); v[7] = np.inf\n"
        "f = np.random.default_rng(2).integers(0, 60, size=(80, 3))\n"
        "for args in [(v, f), (np.nan_to_num(v, posinf=1e300), f % 50), (v[:, :1], f)]:\n"
        "    try: voxkit.voxelize(*args, resolution=32)\n"
        "    except (ValueError, MemoryError) as e: print(type(e).__name__)\n"
        "print('alive')\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().splitlines()[-1] == "alive"
