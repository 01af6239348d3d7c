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

from voxkit.distributed import voxelize_dataset, voxelize_tiled  # noqa: E402

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
