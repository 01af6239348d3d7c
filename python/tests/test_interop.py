"""Real trimesh and Open3D objects in, trimesh objects out, and trimesh's
binvox reader on our files. The Open3D test is skipped where Open3D is not
installed (it runs in the peers' environment, ../shared/peers/.venv)."""

import numpy as np
import pytest

import voxkit
from conftest import BUNNY, SPOT


def test_trimesh_mesh_in():
    trimesh = pytest.importorskip("trimesh")
    v, f = voxkit.load_mesh(SPOT)
    tm = trimesh.Trimesh(vertices=v, faces=f, process=False)
    for mode in ["thin", "conservative"]:
        a = voxkit.voxelize(tm, resolution=48, mode=mode)
        b = voxkit.voxelize(v, f, resolution=48, mode=mode)
        assert np.array_equal(a.indices(), b.indices())
    # A processed trimesh (merged vertices) is the same surface.
    tp = trimesh.Trimesh(vertices=v, faces=f, process=True)
    assert np.array_equal(voxkit.voxelize(tp, resolution=48).indices(), voxkit.voxelize(v, f, resolution=48).indices())
    m = voxkit.voxelize(tm, resolution=32, mode="conservative").measure(tm)
    assert (m["missing"], m["extra"]) == (0, 0)


def test_trimesh_reads_our_binvox(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    g = voxkit.voxelize(*voxkit.load_mesh(BUNNY), resolution=64, mode="thin")
    p = tmp_path / "bunny.binvox"
    g.save(p)
    with open(p, "rb") as fh:
        tv = trimesh.exchange.binvox.load_binvox(fh)
    # binvox stores a cube of side max(dims); trimesh reads it whole.
    m = np.asarray(tv.matrix)
    assert m.shape == (max(g.dims),) * 3
    nx, ny, nz = g.dims
    assert np.array_equal(m[:nx, :ny, :nz], g.dense())
    assert not m[nx:].any() and not m[:, ny:].any() and not m[:, :, nz:].any()
    # The header's frame as trimesh reads it: translate = our origin, and
    # trimesh 5.2 spreads binvox's `scale` (= max(dims) * voxel_size) over
    # max(dims) - 1 steps (its own reading of binvox: index 0 and index n-1
    # at the ends of the box), so its pitch is a little larger than ours.
    n = max(g.dims)
    np.testing.assert_allclose(tv.transform[:3, 3], g.origin, rtol=1e-6)
    np.testing.assert_allclose(np.diag(tv.transform)[:3], g.voxel_size * n / (n - 1), rtol=1e-6)


def test_to_trimesh():
    trimesh = pytest.importorskip("trimesh")
    g = voxkit.voxelize(*voxkit.load_mesh(SPOT), resolution=40, mode="thick")
    tv = g.to_trimesh()
    assert isinstance(tv, trimesh.voxel.VoxelGrid)
    assert tv.shape == g.dims and int(tv.filled_count) == len(g)
    np.testing.assert_allclose(np.asarray(tv.points), g.points(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(tv.pitch, [g.voxel_size] * 3)


def test_open3d_mesh_in():
    o3d = pytest.importorskip("open3d")
    v, f = voxkit.load_mesh(SPOT)
    om = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(f.astype(np.int32)))
    for mode in ["thin", "solid"]:
        a = voxkit.voxelize(om, resolution=48, mode=mode)
        b = voxkit.voxelize(v, f, resolution=48, mode=mode)
        assert np.array_equal(a.indices(), b.indices())
    # Open3D's own voxels scored by the library on Open3D's lattice: close to
    # the exact conservative set of the 1/256-voxel mesh (Open3D decides
    # touches in f64 on the unrounded mesh, so a few touching voxels differ:
    # 4 missing and 3 extra of 6,350 here with Open3D 0.20).
    h = a.voxel_size
    og = o3d.geometry.VoxelGrid.create_from_triangle_mesh(om, voxel_size=h)
    idx = np.array([vx.grid_index for vx in og.get_voxels()], dtype=np.int64)
    m = voxkit.measure(om, idx, np.asarray(og.origin), h)
    assert m["missing"] + m["extra"] < 0.002 * m["reference_voxels"], m
    assert m["max_distance"] < 0.87 and m["tunnel6"] is False
