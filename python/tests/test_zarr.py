"""OME-Zarr stores: what voxkit writes, zarr-python 3 and dask.array read
voxel for voxel; the metadata validates as OME-Zarr 0.5 (ome-zarr-models);
tiles merge into the whole run. Needs the ``zarr`` extra (zarr, dask,
ome-zarr-models): skipped without it."""

import json
import os
import signal
import subprocess

import numpy as np
import pytest

import voxkit
from conftest import BUNNY, SPOT, TEAPOT

zarr = pytest.importorskip("zarr", minversion="3")
da = pytest.importorskip("dask.array")

MODES = ["thin", "thick", "conservative", "solid"]


def zyx_nonzero(a):
    """(K, 3) x, y, z indices of the nonzero voxels of a z, y, x array,
    sorted as voxkit's indices (bricks in z, y, x order, then inside)."""
    z, y, x = np.nonzero(np.asarray(a))
    return np.stack([x, y, z], axis=1)


def same_voxels(a, b):
    sa = {tuple(r) for r in np.asarray(a).tolist()}
    sb = {tuple(r) for r in np.asarray(b).tolist()}
    return sa == sb


@pytest.mark.parametrize("mode", MODES)
def test_cli_store_equals_binvox_and_reads_in_zarr_and_dask(cli, tmp_path, mode):
    store, binvox = tmp_path / "b.zarr", tmp_path / "b.binvox"
    cli("voxelize", BUNNY, "-r", "96", "--mode", mode, "-o", store)
    cli("voxelize", BUNNY, "-r", "96", "--mode", mode, "-o", binvox)
    g, b = voxkit.load_grid(store), voxkit.load_grid(binvox)
    assert same_voxels(g.indices(), b.indices())
    np.testing.assert_allclose(g.origin, b.origin, rtol=1e-6)
    group = zarr.open_group(str(store), mode="r")
    arr = group["0"]
    assert arr.dtype == np.uint8 and arr.shape == tuple(reversed(g.dims))
    data = arr[:]
    assert set(np.unique(data).tolist()) <= {0, 1}
    assert same_voxels(zyx_nonzero(data), g.indices())
    lazy = da.from_zarr(str(store), component="0", chunks=(512, 512, 512))
    assert same_voxels(zyx_nonzero(lazy.compute()), g.indices())
    assert int(lazy.sum().compute()) == len(g)


def test_metadata_validates_as_ome_zarr_0_5(cli, tmp_path):
    models = pytest.importorskip("ome_zarr_models.v05.image")
    store = tmp_path / "p.zarr"
    cli("voxelize", SPOT, "-r", "150", "-o", store, "--pyramid")
    group = zarr.open_group(str(store), mode="r")
    image = models.Image.from_zarr(group)
    ms = image.ome_attributes.multiscales[0]
    assert [a.name for a in ms.axes] == ["z", "y", "x"]
    assert [d.path for d in ms.datasets] == ["0", "1", "2"]
    vk = group.attrs["voxkit"]
    h = vk["voxel_size"]
    t = group.attrs["ome"]["multiscales"][0]["datasets"][0]["coordinateTransformations"]
    assert t[0]["scale"] == [h, h, h]
    ox, oy, oz = vk["origin"]
    assert t[1]["translation"] == pytest.approx([oz + h / 2, oy + h / 2, ox + h / 2], rel=0, abs=0)


def test_pyramid_levels_are_max_pooled(cli, tmp_path):
    store = tmp_path / "p.zarr"
    cli("voxelize", TEAPOT, "-r", "150", "--mode", "solid", "-o", store, "--pyramid")
    group = zarr.open_group(str(store), mode="r")
    prev = group["0"][:]
    for level in (1, 2):
        nz, ny, nx = prev.shape
        pad = np.zeros((nz + nz % 2, ny + ny % 2, nx + nx % 2), np.uint8)
        pad[:nz, :ny, :nx] = prev
        pooled = pad.reshape(pad.shape[0] // 2, 2, pad.shape[1] // 2, 2, pad.shape[2] // 2, 2).max(axis=(1, 3, 5))
        cur = group[str(level)][:]
        assert np.array_equal(cur, pooled), level
        prev = cur


def plan(cli, store, mode, *extra):
    r = cli("voxelize", BUNNY, "--voxel-size", "0.00025", "--origin", "-0.1,0.03,-0.07",
            "--mode", mode, "-o", store, "--tile-size", "512", "--plan", *extra)
    return json.loads(r.stdout)


def run_tile(cli, store, mode, tile, check=True):
    return cli("voxelize", BUNNY, "--voxel-size", "0.00025", "--origin", "-0.1,0.03,-0.07",
               "--mode", mode, "-o", store, "--tile-size", "512", "--tile", ",".join(map(str, tile)),
               "--json", check=check)


@pytest.mark.parametrize("mode", MODES)
def test_cli_tiles_merge_into_the_whole_run(cli, tmp_path, mode):
    whole, tiled = tmp_path / "whole.zarr", tmp_path / "tiled.zarr"
    cli("voxelize", BUNNY, "--voxel-size", "0.00025", "--origin", "-0.1,0.03,-0.07",
        "--mode", mode, "-o", whole)
    p = plan(cli, tiled, mode)
    assert p["tile_count"] >= 2, p
    assert not os.path.exists(tiled / "0" / "c"), "the plan writes metadata only"
    for t in p["tiles"]:
        r = json.loads(run_tile(cli, tiled, mode, t).stdout)
        assert r["tile"] == t and r["peak_rss_mib"] > 0 and r["estimated_mib"] > 0
    a = zarr.open_group(str(whole), mode="r")["0"][:]
    b = zarr.open_group(str(tiled), mode="r")["0"][:]
    assert a.shape == b.shape and np.array_equal(a, b)
    # Re-running a tile changes nothing.
    run_tile(cli, tiled, mode, p["tiles"][0])
    assert np.array_equal(zarr.open_group(str(tiled), mode="r")["0"][:], a)


def test_a_torn_or_killed_tile_is_repaired_by_running_it_again(cli, tmp_path):
    whole, tiled = tmp_path / "whole.zarr", tmp_path / "tiled.zarr"
    cli("voxelize", BUNNY, "--voxel-size", "0.00025", "--origin", "-0.1,0.03,-0.07", "-o", whole)
    p = plan(cli, tiled, "thin")
    for t in p["tiles"]:
        run_tile(cli, tiled, "thin", t)
    shards = sorted(str(q) for q in (tiled / "0" / "c").rglob("*") if q.is_file())
    # Tear one shard (a write cut short) and delete another.
    with open(shards[0], "r+b") as f:
        f.truncate(os.path.getsize(shards[0]) // 2)
    os.remove(shards[-1])
    # A tile killed while it runs (SIGKILL at some point of its work).
    from conftest import _cli_path

    t = p["tiles"][0]
    proc = subprocess.Popen(
        [str(_cli_path()), "voxelize", str(BUNNY), "--voxel-size", "0.00025", "--origin", "-0.1,0.03,-0.07",
         "-o", str(tiled), "--tile-size", "512", "--tile", ",".join(map(str, t)), "-q"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    try:
        proc.wait(timeout=0.3)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    for t in p["tiles"]:
        run_tile(cli, tiled, "thin", t)
    a = zarr.open_group(str(whole), mode="r")["0"][:]
    assert np.array_equal(zarr.open_group(str(tiled), mode="r")["0"][:], a)


@pytest.mark.parametrize("ray", ["adaptive", "6", "26", "aw"])
def test_an_opened_store_renders_as_the_loaded_grid(tmp_path, ray):
    store = tmp_path / "s.zarr"
    voxkit.voxelize(*voxkit.load_mesh(BUNNY), resolution=200).save(store)
    opened = voxkit.open_store(store)
    assert opened.dims == voxkit.load_grid(store).dims
    assert opened.chunks_decoded == 0 and opened.stored_chunks > 0
    want = voxkit.render(voxkit.load_grid(store), size=(120, 90), ray=ray, normals="smooth")
    got = voxkit.render(opened, size=(120, 90), ray=ray, normals="smooth")
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    # A window of the frame is the frame's pixels.
    part = voxkit.render(opened, size=(120, 90), ray=ray, pixels=(30, 20, 50, 40))
    assert np.array_equal(part[0], want[0][20:60, 30:80])
    assert 0 < opened.chunks_decoded <= opened.stored_chunks
    assert opened.pages_built > 0 and opened.memory_bytes > 0


def test_open_store_leaves_foreign_stores_to_load_grid_and_caps_memory(tmp_path):
    foreign = tmp_path / "f.zarr"
    group = zarr.open_group(str(foreign), mode="w")
    a = group.create_array("0", shape=(40, 50, 60), chunks=(16, 16, 16), dtype="uint8")
    block = np.zeros((40, 50, 60), dtype=np.uint8)
    block[10:30, 5:45, 20:50] = 1
    a[:] = block
    assert voxkit.open_store(foreign) is None
    assert len(voxkit.load_grid(foreign)) == int(block.sum())
    store = tmp_path / "s.zarr"
    voxkit.voxelize(*voxkit.load_mesh(SPOT), resolution=600).save(store)
    tight = voxkit.open_store(store, max_memory_mib=1)
    with pytest.raises(MemoryError, match="chunks the rays reach"):
        voxkit.render(tight, size=(64, 64))
