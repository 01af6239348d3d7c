"""Voxelization across processes and machines with Dask.

Install the extra: ``pip install ./python[dask]``.

Two maps, each the same code on a laptop (``client=None``: Dask's local
schedulers) and on a cluster (a ``distributed.Client``):

* :func:`voxelize_tiled` cuts one large grid into tiles that write into one
  shared OME-Zarr store. The plan (``voxkit voxelize … --plan``) writes the
  store's metadata once and lists the tiles that meet the mesh; each task
  voxelizes one tile (``--tile I,J,K``) and writes only that tile's shards,
  so tasks never write the same object and a failed task is simply run again.
  The merged store equals the single-process voxelization voxel for voxel.
* :func:`voxelize_dataset` voxelizes many meshes, one task per mesh.

A tile should be seconds of work (Dask's per-task overhead is milliseconds,
a ``LocalCluster`` takes about 2 s to start): 1024³ tiles (8 shards of 512³)
are the default. Paths must be visible to every worker (a shared
filesystem).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional, Sequence

from . import _voxkit

__all__ = ["plan_tiled", "voxelize_tile", "voxelize_tiled", "voxelize_dataset"]


def _require_dask():
    try:
        import dask  # noqa: F401
        import dask.bag  # noqa: F401
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "voxkit.distributed needs Dask: pip install './python[dask]' (dask[bag] and distributed)"
        ) from e


def _origin(origin: Optional[Sequence[float]]):
    if origin is None:
        return None
    o = tuple(float(c) for c in origin)
    if len(o) != 3:
        raise ValueError(f"origin must have 3 coordinates, got {origin!r}")
    return o


def plan_tiled(
    mesh_path: os.PathLike,
    store: os.PathLike,
    voxel_size: float,
    origin: Optional[Sequence[float]] = None,
    tile_size: int = 1024,
    mode: str = "thin",
    *,
    inside: str = "winding",
    force: bool = False,
    max_memory_mib: int = 4096,
) -> dict:
    """Write the store's metadata and return the plan (``voxkit voxelize
    MESH --voxel-size H --origin X,Y,Z -o STORE --tile-size N --plan``): a
    dict with ``dims``, ``voxel_size``, ``origin``, ``tile_size``,
    ``tile_counts`` and ``tiles`` (the ``[i, j, k]`` that meet the mesh)."""
    return json.loads(
        _voxkit.plan_tiles(
            os.fspath(mesh_path),
            os.fspath(store),
            float(voxel_size),
            _origin(origin),
            int(tile_size),
            mode,
            inside,
            bool(force),
            int(max_memory_mib),
        )
    )


def voxelize_tile(
    mesh_path: os.PathLike,
    store: os.PathLike,
    voxel_size: float,
    origin: Optional[Sequence[float]],
    tile_size: int,
    tile: Sequence[int],
    mode: str = "thin",
    *,
    inside: str = "winding",
    max_memory_mib: int = 4096,
    threads: Optional[int] = None,
) -> dict:
    """Voxelize one tile of a planned store (``--tile I,J,K``) and return
    its report (``voxels``, ``triangles``, ``shards``, ``voxelize_ms``,
    ``write_ms``, ``estimated_mib``, ``peak_rss_mib``, …). Idempotent."""
    t = tuple(int(c) for c in tile)
    return json.loads(
        _voxkit.voxelize_tile(
            os.fspath(mesh_path),
            os.fspath(store),
            float(voxel_size),
            _origin(origin),
            int(tile_size),
            t,
            mode,
            inside,
            int(max_memory_mib),
            threads,
        )
    )


def _with_retries(fn, retries: int):
    """``fn`` run again up to ``retries`` times on an exception; the last
    exception is returned (not raised) so that one bad task does not stop
    the map, and the summary lists it."""

    def run(item):
        last = None
        for attempt in range(retries + 1):
            try:
                out = fn(item)
                out["attempts"] = attempt + 1
                return out
            except Exception as e:  # noqa: BLE001 - reported in the summary
                last = e
        return {"error": f"{type(last).__name__}: {last}", "attempts": retries + 1, "item": repr(item)}

    return run


def _map(fn, items: List[Any], client, retries: int, progress: bool) -> List[dict]:
    """``fn`` over ``items``: with ``client``, ``client.map`` (Dask retries
    a task whose worker died; our wrapper retries exceptions); without, a
    ``dask.bag`` of one item per partition on the local process pool."""
    _require_dask()
    run = _with_retries(fn, retries)
    if not items:
        return []
    if client is not None:
        futures = client.map(run, items, retries=retries, pure=False)
        if progress:
            from distributed import progress as dask_progress

            dask_progress(futures)
        return client.gather(futures)
    import dask.bag as db

    bag = db.from_sequence(items, npartitions=len(items)).map(run)
    if progress:
        from dask.diagnostics import ProgressBar

        with ProgressBar():
            return bag.compute(scheduler="synchronous")
    return bag.compute(scheduler="synchronous")


class _TileTask:
    """One tile's work, picklable for the workers."""

    def __init__(self, mesh_path, store, voxel_size, origin, tile_size, mode, inside, max_memory_mib, threads):
        self.args = (mesh_path, store, voxel_size, origin, tile_size)
        self.mode, self.inside = mode, inside
        self.max_memory_mib, self.threads = max_memory_mib, threads

    def __call__(self, tile):
        out = voxelize_tile(
            *self.args,
            tile,
            self.mode,
            inside=self.inside,
            max_memory_mib=self.max_memory_mib,
            threads=self.threads,
        )
        out["tile"] = list(tile)
        return out


def voxelize_tiled(
    mesh_path: os.PathLike,
    store: os.PathLike,
    voxel_size: float,
    origin: Optional[Sequence[float]] = None,
    tile_size: int = 1024,
    mode: str = "thin",
    client=None,
    *,
    inside: str = "winding",
    retries: int = 2,
    force: bool = False,
    progress: bool = True,
    threads: Optional[int] = None,
    max_memory_mib: int = 4096,
) -> dict:
    """Voxelize ``mesh_path`` into the OME-Zarr ``store`` tile by tile.

    Plans (metadata written once, tiles that meet the mesh listed), then maps
    the tiles with ``client.map`` (a ``distributed.Client``) or, without a
    client, a ``dask.bag`` run in this process one tile after another (each
    tile uses every core). Failed tiles are retried ``retries`` times (a
    tile rewrites its whole shards, so a retry repairs a half-written one).
    ``threads`` caps each tile's threads (e.g. ``threads_per_worker``).

    Returns a summary: ``store``, ``dims``, ``tiles`` (planned), ``done``,
    ``failed`` (list of ``{tile, error}``), ``voxels``, ``seconds``,
    ``plan_seconds``, ``tile_seconds`` (sum of the tiles' own times),
    ``max_peak_rss_mib``, ``max_estimated_mib`` and ``reports`` (one per
    tile). The store equals ``voxkit voxelize MESH --voxel-size H --origin
    X,Y,Z -o whole.zarr`` voxel for voxel.
    """
    start = time.perf_counter()
    plan = plan_tiled(
        mesh_path, store, voxel_size, origin, tile_size, mode, inside=inside, force=force, max_memory_mib=max_memory_mib
    )
    plan_seconds = time.perf_counter() - start
    task = _TileTask(
        os.fspath(mesh_path),
        os.fspath(store),
        float(voxel_size),
        _origin(origin),
        int(tile_size),
        mode,
        inside,
        int(max_memory_mib),
        threads,
    )
    tiles = [tuple(t) for t in plan["tiles"]]
    reports = _map(task, tiles, client, retries, progress)
    failed = [r for r in reports if "error" in r]
    done = [r for r in reports if "error" not in r]
    return {
        "store": os.fspath(store),
        "dims": plan["dims"],
        "tile_size": plan["tile_size"],
        "tiles": len(tiles),
        "done": len(done),
        "failed": failed,
        "voxels": sum(r["voxels"] for r in done),
        "seconds": time.perf_counter() - start,
        "plan_seconds": plan_seconds,
        "tile_seconds": sum((r["load_ms"] + r["voxelize_ms"] + r["write_ms"]) / 1e3 for r in done),
        "max_peak_rss_mib": max((r["peak_rss_mib"] or 0.0 for r in done), default=0.0),
        "max_estimated_mib": max((r["estimated_mib"] for r in done), default=0.0),
        "reports": reports,
    }


class _MeshTask:
    """One mesh of a dataset, picklable for the workers."""

    def __init__(self, kwargs: Dict[str, Any], overwrite: bool):
        self.kwargs, self.overwrite = kwargs, overwrite

    def __call__(self, item):
        from . import load_mesh, voxelize

        src, dst = item
        t = time.perf_counter()
        if not self.overwrite and os.path.exists(dst):
            return {"mesh": src, "output": dst, "skipped": True, "seconds": 0.0}
        Path(dst).parent.mkdir(parents=True, exist_ok=True)
        grid = voxelize(*load_mesh(src), **self.kwargs)
        grid.save(dst)
        return {
            "mesh": src,
            "output": dst,
            "skipped": False,
            "voxels": len(grid),
            "dims": list(grid.dims),
            "seconds": time.perf_counter() - t,
        }


def voxelize_dataset(
    paths: Iterable[os.PathLike],
    out_dir: os.PathLike,
    *,
    resolution: Optional[int] = None,
    voxel_size: Optional[float] = None,
    mode: str = "thin",
    inside: str = "winding",
    format: str = "binvox",
    client=None,
    retries: int = 2,
    overwrite: bool = False,
    progress: bool = True,
    threads: Optional[int] = None,
    max_memory_mib: int = 4096,
) -> dict:
    """Voxelize every mesh of ``paths`` into ``out_dir`` (one task per mesh,
    mapped as in :func:`voxelize_tiled`): ``NAME.FORMAT`` for each mesh
    (``format``: ``binvox``, ``vox``, ``npy``, ``nrrd`` or ``zarr``; equal
    names get ``_1``, ``_2``, …). Existing outputs are skipped unless
    ``overwrite`` (so a re-run resumes). Returns ``done``, ``skipped``,
    ``failed`` (with errors), ``voxels``, ``seconds`` and ``reports``."""
    if format not in ("binvox", "vox", "npy", "nrrd", "zarr"):
        raise ValueError(f"format must be binvox, vox, npy, nrrd or zarr, got {format!r}")
    start = time.perf_counter()
    out_dir = Path(out_dir)
    seen: Dict[str, int] = {}
    items = []
    for p in paths:
        stem = Path(p).stem
        n = seen.get(stem, 0)
        seen[stem] = n + 1
        name = stem if n == 0 else f"{stem}_{n}"
        items.append((os.fspath(p), os.fspath(out_dir / f"{name}.{format}")))
    kwargs: Dict[str, Any] = {"mode": mode, "inside": inside, "max_memory_mib": max_memory_mib, "threads": threads}
    if voxel_size is not None:
        kwargs["voxel_size"] = voxel_size
    else:
        kwargs["resolution"] = 256 if resolution is None else resolution
    reports = _map(_MeshTask(kwargs, overwrite), items, client, retries, progress)
    failed = [r for r in reports if "error" in r]
    ok = [r for r in reports if "error" not in r]
    return {
        "meshes": len(items),
        "done": sum(1 for r in ok if not r["skipped"]),
        "skipped": sum(1 for r in ok if r["skipped"]),
        "failed": failed,
        "voxels": sum(r.get("voxels", 0) for r in ok),
        "seconds": time.perf_counter() - start,
        "reports": reports,
    }
