"""voxelize / VoxelGrid / load_mesh / load_grid against the CLI's files and
against each other."""

import numpy as np
import pytest

import voxkit
from conftest import BUNNY, FANDISK, SPOT, SUZANNE, TEAPOT

MODES = ["thin", "thick", "conservative", "solid"]


@pytest.mark.parametrize("mesh", [SPOT, BUNNY, FANDISK, TEAPOT, SUZANNE], ids=lambda p: p.name)
@pytest.mark.parametrize("mode", MODES)
def test_files_identical_to_the_cli(cli, tmp_path, mesh, mode):
    res = 40 if mode == "solid" else 56
    ref = tmp_path / "cli.binvox"
    cli("voxelize", mesh, "-r", res, "-o", ref, "--mode", mode, "-q")
    ours = tmp_path / "py.binvox"
    g = voxkit.voxelize(voxkit.load_mesh(mesh), resolution=res, mode=mode)
    g.save(ours)
    assert ours.read_bytes() == ref.read_bytes()
    back = voxkit.load_grid(ref)
    # binvox stores a cube of side max(dims): the same voxels in it.
    assert back.dims == (max(g.dims),) * 3 and len(back) == len(g)
    assert np.array_equal(back.indices(), g.indices())


@pytest.mark.parametrize("mode", ["thin", "conservative"])
def test_voxel_size_and_origin_identical_to_the_cli(cli, tmp_path, mode):
    ref = tmp_path / "cli.binvox"
    cli("voxelize", SPOT, "--voxel-size", "0.021", "--origin", "-0.3,0.011,2", "-o", ref, "--mode", mode, "-q")
    ours = tmp_path / "py.binvox"
    voxkit.voxelize(*voxkit.load_mesh(SPOT), voxel_size=0.021, origin=(-0.3, 0.011, 2), mode=mode).save(ours)
    assert ours.read_bytes() == ref.read_bytes()


def test_snap_identical_to_the_cli(cli, tmp_path):
    ref = tmp_path / "cli.binvox"
    cli("voxelize", SPOT, "-r", 64, "-o", ref, "--snap", "-q")
    ours = tmp_path / "py.binvox"
    voxkit.voxelize(*voxkit.load_mesh(SPOT), resolution=64, snap=True).save(ours)
    assert ours.read_bytes() == ref.read_bytes()


@pytest.mark.parametrize("inside", ["winding", "parity"])
def test_inside_test_identical_to_the_cli(cli, tmp_path, inside):
    ref = tmp_path / "cli.binvox"
    cli("voxelize", BUNNY, "-r", 48, "-o", ref, "--mode", "solid", "--inside", inside, "-q")
    ours = tmp_path / "py.binvox"
    voxkit.voxelize(*voxkit.load_mesh(BUNNY), resolution=48, mode="solid", inside=inside).save(ours)
    assert ours.read_bytes() == ref.read_bytes()


def test_inside_tests_agree_on_a_closed_mesh():
    mesh = voxkit.load_mesh(SPOT)
    winding = voxkit.voxelize(mesh, resolution=48, mode="solid", inside="winding")
    parity = voxkit.voxelize(mesh, resolution=48, mode="solid", inside="parity")
    assert np.array_equal(winding.indices(), parity.indices())
    with pytest.raises(ValueError, match="inside"):
        voxkit.voxelize(mesh, resolution=48, mode="solid", inside="vote")


def test_load_mesh_arrays():
    v, f = voxkit.load_mesh(SPOT)
    assert v.dtype == np.float64 and v.ndim == 2 and v.shape[1] == 3 and v.flags.c_contiguous
    assert f.dtype == np.int64 and f.shape[1] == 3 and f.min() >= 0 and f.max() < len(v)
    v2, f2 = voxkit.load_mesh(str(SUZANNE))
    assert len(f2) > 0 and np.isfinite(v2).all()


@pytest.mark.parametrize("mode", MODES)
def test_dense_indices_points_and_len_agree(mode):
    g = voxkit.voxelize(*voxkit.load_mesh(SPOT), resolution=48, mode=mode)
    d = g.dense()
    assert d.dtype == np.bool_ and d.shape == g.dims and d.flags.c_contiguous
    idx = g.indices()
    assert idx.dtype == np.int32 and idx.shape == (len(g), 3)
    assert np.array_equal(np.argwhere(d), idx)
    assert int(d.sum()) == len(g) == g.stats["voxels"]
    p = g.points()
    assert p.dtype == np.float64 and p.shape == idx.shape
    np.testing.assert_allclose(p, g.origin + (idx + 0.5) * g.voxel_size, rtol=0, atol=1e-12)


def test_frame_of_resolution_fit():
    v, f = voxkit.load_mesh(SPOT)
    g = voxkit.voxelize(v, f, resolution=64)
    lo, hi = v[np.unique(f)].min(0), v[np.unique(f)].max(0)
    assert np.array_equal(g.origin, lo)
    assert g.voxel_size == pytest.approx((hi - lo).max() / 64, rel=1e-15)
    assert max(g.dims) == 64
    assert isinstance(g.dims, tuple) and all(isinstance(x, int) for x in g.dims)
    assert g.indices().min() >= 0 and (g.indices().max(0) < np.array(g.dims)).all()


def test_voxel_size_of_longest_side_over_n_is_resolution_n():
    v, f = voxkit.load_mesh(FANDISK)
    a = voxkit.voxelize(v, f, resolution=70, mode="thick")
    b = voxkit.voxelize(v, f, voxel_size=a.voxel_size, mode="thick")
    assert a.dims == b.dims and np.array_equal(a.origin, b.origin)
    assert np.array_equal(a.indices(), b.indices())


def test_origin_pins_the_lattice():
    v, f = voxkit.load_mesh(SPOT)
    h = 0.02
    g = voxkit.voxelize(v, f, voxel_size=h, origin=(0.005, 0.0, -0.0031))
    k = (g.origin - np.array([0.005, 0.0, -0.0031])) / h
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)
    lo, hi = v.min(0), v.max(0)
    assert (g.origin <= lo + 1e-9).all() and (g.origin > lo - h).all()
    assert (g.origin + np.array(g.dims) * h >= hi - 1e-9).all()


def test_input_dtypes_and_layouts_give_the_same_voxels():
    v, f = voxkit.load_mesh(SPOT)
    ref = voxkit.voxelize(v, f, resolution=40).indices()
    variants = [
        (v, f.astype(np.int32)),
        (v, f.astype(np.uint32)),
        (v, f.astype(np.uint64)),
        (v, f.astype(np.int16) if len(v) < 2**15 else f),
        (np.asfortranarray(v), np.asfortranarray(f)),  # non-C strides, read in place
        (np.hstack([v, v])[:, :3], f),  # a strided view
        (v.tolist(), f.tolist()),  # plain lists
        ((v, f), None),  # the pair load_mesh returns
    ]
    for vv, ff in variants:
        assert np.array_equal(voxkit.voxelize(vv, ff, resolution=40).indices(), ref)
    # float32 vertices round differently only below 1/256 voxel: same mesh,
    # nearly the same voxels.
    g32 = voxkit.voxelize(v.astype(np.float32), f, resolution=40)
    assert abs(len(g32) - len(ref)) < 0.01 * len(ref)


@pytest.mark.parametrize("ext", ["binvox", "vox", "npy", "nrrd", "zarr"])
def test_save_and_load_grid_round_trip(tmp_path, ext):
    g = voxkit.voxelize(*voxkit.load_mesh(TEAPOT), resolution=50, mode="thick")
    p = tmp_path / f"t.{ext}"
    g.save(p)
    back = voxkit.load_grid(p)
    # binvox stores a cube of side max(dims); the others keep the dims.
    assert back.dims == ((max(g.dims),) * 3 if ext == "binvox" else g.dims)
    assert np.array_equal(back.indices(), g.indices())
    assert back.stats is None
    if ext == "zarr":
        assert np.array_equal(back.origin, g.origin) and back.voxel_size == g.voxel_size
    if ext in ("binvox", "nrrd"):
        np.testing.assert_allclose(back.origin, g.origin, rtol=1e-6)
        assert back.voxel_size == pytest.approx(g.voxel_size, rel=1e-6)
    if ext == "npy":
        assert np.array_equal(np.load(p).astype(bool), g.dense())
    if ext == "binvox":
        nx, ny, nz = g.dims
        assert np.array_equal(back.dense()[:nx, :ny, :nz], g.dense())


def test_save_refuses_to_overwrite_when_asked(tmp_path):
    g = voxkit.voxelize(*voxkit.load_mesh(SPOT), resolution=16)
    p = tmp_path / "s.binvox"
    g.save(p)
    with pytest.raises(FileExistsError):
        g.save(p, overwrite=False)
    g.save(p)  # overwrite=True by default


def test_tunnels_and_measure():
    v, f = voxkit.load_mesh(SPOT)
    thin = voxkit.voxelize(v, f, resolution=64, mode="thin")
    t6 = thin.tunnels(6)
    assert t6["tunnel"] is False and t6["enclosed"] > 0
    assert thin.tunnels(26)["tunnel"] is True
    m = thin.measure(v, f)
    assert m["extra"] == 0 and m["missing"] > 0 and m["closed"] is True and m["tunnel6"] is False
    cons = voxkit.voxelize(v, f, resolution=64, mode="conservative")
    mc = cons.measure(v, f)
    assert (mc["missing"], mc["extra"]) == (0, 0)
    assert mc["reference_voxels"] == len(cons)
    assert mc["max_distance"] <= 3**0.5 / 2 + 1e-9
    # The module-level measure (`voxkit measure`) widens the grid, so the
    # voxels beyond the closed box that the surface only touches on the
    # box's faces count as missing there, and only they.
    mi = voxkit.measure((v, f), cons.indices(), cons.origin, cons.voxel_size)
    assert mi["extra"] == 0 and mi["missing"] > 0
    assert mi["reference_voxels"] - mi["missing"] == mc["reference_voxels"]


def test_measure_of_a_saved_grid_and_of_the_cli(cli, tmp_path):
    v, f = voxkit.load_mesh(BUNNY)
    p = tmp_path / "b.binvox"
    import json

    out = json.loads(cli("voxelize", BUNNY, "-r", 64, "-o", p, "--mode", "thick", "--json", "--measure", "-q").stdout)
    g = voxkit.load_grid(p)
    m = g.measure(v, f)
    for k in ["reference_voxels", "missing", "extra", "far_voxels", "closed", "tunnel6", "tunnel26"]:
        assert m[k] == out[k], k
    assert m["max_distance"] == pytest.approx(out["max_distance"], rel=1e-12)
    assert m["mean_distance"] == pytest.approx(out["mean_distance"], rel=1e-9)
    fresh = voxkit.voxelize(v, f, resolution=64, mode="thick").measure(v, f)
    assert {k: m[k] for k in ["missing", "extra", "tunnel6"]} == {k: fresh[k] for k in ["missing", "extra", "tunnel6"]}


def test_stats_are_the_librarys():
    g = voxkit.voxelize(*voxkit.load_mesh(BUNNY), resolution=64)
    s = g.stats
    assert s["voxels"] == len(g) and s["triangles"] > 60000
    assert s["voxelize_ms"] >= s["kernel_ms"] > 0
    assert "VoxelGrid(dims=" in repr(g)


def test_grids_compare_by_frame_and_voxels(tmp_path):
    v, f = voxkit.load_mesh(SPOT)
    a = voxkit.voxelize(v, f, resolution=40)
    assert a == voxkit.voxelize(v, f, resolution=40)
    assert a != voxkit.voxelize(v, f, resolution=40, mode="thick")
    assert a != voxkit.voxelize(v, f, resolution=41)
    assert (a == "a grid") is False
    a.save(tmp_path / "a.zarr")
    assert voxkit.load_grid(tmp_path / "a.zarr") == a
