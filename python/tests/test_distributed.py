"""voxkit.distributed: tiles mapped over a 2-worker LocalCluster (and over
dask.bag in this process) give the single-process store voxel for voxel in
every mode; a dataset maps one task per mesh. Needs the ``dask`` extra:
skipped without it."""

import numpy as np
import pytest

import voxkit
from conftest import BUNNY, FANDISK, SPOT, TEAPOT

pytest.importorskip("dask.bag")
distributed = pytest.importorskip("distributed")
zarr = pytest.importorskip("zarr", minversion="3")

from voxkit.distributed import render_tiled, voxelize_dataset, voxelize_tiled  # noqa: E402

H, ORIGIN = 0.00025, (-0.1, 0.03, -0.07)
MODES = ["thin", "thick", "conservative", "solid"]


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as c:
        yield c


def store_array(path):
    return zarr.open_group(str(path), mode="r")["0"][:]


@pytest.mark.parametrize("mode", MODES)
def test_tiles_on_a_local_cluster_equal_the_single_process_store(client, tmp_path, mode):
    whole = tmp_path / "whole.zarr"
    v, f = voxkit.load_mesh(BUNNY)
    voxkit.voxelize(v, f, voxel_size=H, origin=ORIGIN, mode=mode).save(whole)
    s = voxelize_tiled(BUNNY, tmp_path / "t.zarr", H, ORIGIN, 512, mode, client=client, progress=False)
    assert s["failed"] == [] and s["done"] == s["tiles"] >= 2, s
    a = store_array(whole)
    assert np.array_equal(store_array(tmp_path / "t.zarr"), a)
    assert s["voxels"] == int(a.sum())
    assert 0 < s["max_peak_rss_mib"] and s["max_estimated_mib"] > 0


def test_tiles_without_a_client_run_here_and_agree(tmp_path):
    s = voxelize_tiled(BUNNY, tmp_path / "t.zarr", H, ORIGIN, 512, "thin", progress=False)
    assert s["failed"] == [] and s["done"] == s["tiles"]
    v, f = voxkit.load_mesh(BUNNY)
    g = voxkit.voxelize(v, f, voxel_size=H, origin=ORIGIN)
    assert voxkit.load_grid(tmp_path / "t.zarr").indices().shape == g.indices().shape
    assert np.array_equal(np.sort(voxkit.load_grid(tmp_path / "t.zarr").indices(), axis=0),
                          np.sort(g.indices(), axis=0))


def test_failed_tiles_are_reported_not_raised(tmp_path):
    # The plan is for one lattice; tiles of another grid fail on the check.
    s = voxelize_tiled(BUNNY, tmp_path / "t.zarr", H, ORIGIN, 512, "thin", progress=False, retries=1)
    assert s["failed"] == []
    from voxkit.distributed import _map, _TileTask

    bad = _TileTask(str(BUNNY), str(tmp_path / "t.zarr"), H * 2, ORIGIN, 512, "thin", "winding", 4096, None)
    out = _map(bad, [(0, 0, 0)], None, 1, False)
    assert "error" in out[0] and out[0]["attempts"] == 2


def test_dataset_on_a_local_cluster(client, tmp_path):
    paths = [SPOT, TEAPOT, FANDISK, SPOT]
    s = voxelize_dataset(paths, tmp_path / "out", resolution=48, mode="solid", client=client, progress=False)
    assert s["failed"] == [] and s["done"] == 4, s
    for p, name in zip(paths, ["spot", "teapot", "fandisk", "spot_1"]):
        got = voxkit.load_grid(tmp_path / "out" / f"{name}.binvox")
        want = voxkit.voxelize(*voxkit.load_mesh(p), resolution=48, mode="solid")
        assert np.array_equal(got.indices(), want.indices()), name
    again = voxelize_dataset(paths, tmp_path / "out", resolution=48, client=client, progress=False)
    assert again["skipped"] == 4


def test_render_tiled_equals_the_single_process_render(client, tmp_path):
    store = tmp_path / "s.zarr"
    v, f = voxkit.load_mesh(SPOT)
    voxkit.voxelize(v, f, resolution=80).save(store)
    want_rgb, want_depth = voxkit.render(voxkit.load_grid(store), size=(203, 150), view="front", ray="6")
    # Rectangles that do not divide the frame, on two workers.
    s = render_tiled(store, tmp_path / "t.png", size=(203, 150), tile=64, client=client,
                     progress=False, view="front", ray="6")
    assert s["failed"] == [] and s["tiles"] == 4 * 3
    assert np.array_equal(s["rgb"], want_rgb)
    assert np.array_equal(s["depth"], want_depth)
    assert (tmp_path / "t.png").stat().st_size > 0
    # Each worker read the store once for the call.
    assert sum(not r["grid_cached"] for r in s["reports"]) <= 2


def test_render_tiled_here_and_of_a_pyramid_level(tmp_path, cli):
    store = tmp_path / "p.zarr"
    cli("voxelize", BUNNY, "-r", "128", "--pyramid", "-o", store)
    g1 = voxkit.load_grid(store, level=1)
    assert g1.dims == tuple((d + 1) // 2 for d in voxkit.load_grid(store).dims)
    want, _ = voxkit.render(g1, size=(96, 80))
    s = render_tiled(store, level=1, size=(96, 80), tile=40, progress=False)
    assert s["failed"] == [] and np.array_equal(s["rgb"], want)
    with pytest.raises(ValueError, match="does not apply"):
        render_tiled(store, size=(8, 8), volume="mip", progress=False)


def test_tiled_pyramid_on_a_local_cluster_equals_the_whole_store(client, tmp_path, cli):
    # Tiles of 1024 write levels 0 and 1 themselves; finish_tiled pools the rest.
    v, _ = voxkit.load_mesh(SPOT)
    h = float((v.max(axis=0) - v.min(axis=0)).max()) / 1300
    o = tuple(float(c) for c in v.min(axis=0))
    s = voxelize_tiled(SPOT, tmp_path / "t.zarr", h, o, 1024, "thin", client=client, progress=False, pyramid=True)
    assert s["failed"] == [] and s["done"] >= 2 and s["pyramid"]["from_level"] == 1, s["pyramid"]
    whole = tmp_path / "whole.zarr"
    cli("voxelize", SPOT, "--voxel-size", repr(h), "--origin", ",".join(map(repr, o)), "--pyramid", "-o", whole)
    levels = s["pyramid"]["levels"]
    assert levels == len(zarr.open_group(str(whole), mode="r").attrs["ome"]["multiscales"][0]["datasets"]) >= 5
    for level in range(levels):
        got = voxkit.load_grid(tmp_path / "t.zarr", level=level)
        assert got == voxkit.load_grid(whole, level=level), level
        assert len(got) > 0
