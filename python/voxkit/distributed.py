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
* :func:`render_tiled` splits one picture of a store into rectangles of
  pixels, renders each on a worker and stitches them: the same picture,
  pixel for pixel, as :func:`voxkit.render` of the whole store.

A tile should be seconds of work (Dask's per-task overhead is milliseconds,
a ``LocalCluster`` takes about 2 s to start): 1024³ tiles (8 shards of 512³)
are the default. Paths must be visible to every worker (a shared
filesystem).
"""

from __future__ import annotations

import json
import os
import time
import uuid
from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional, Sequence

import numpy as np

from . import _voxkit

__all__ = ["plan_tiled", "voxelize_tile", "voxelize_tiled", "finish_tiled", "voxelize_dataset", "render_tiled"]


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
    pyramid: bool = False,
) -> dict:
    """Write the store's metadata and return the plan (``voxkit voxelize
    MESH --voxel-size H --origin X,Y,Z -o STORE --tile-size N --plan``): a
    dict with ``dims``, ``voxel_size``, ``origin``, ``tile_size``,
    ``tile_counts``, ``tiles`` (the ``[i, j, k]`` that meet the mesh),
    ``levels`` and ``tile_levels`` (with ``pyramid``: the levels each tile
    writes itself; :func:`finish_tiled` builds the others)."""
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
            bool(pyramid),
        )
    )


def finish_tiled(store: os.PathLike, *, max_memory_mib: int = 4096) -> dict:
    """Build the pyramid levels of a tiled store that span several tiles
    (``voxkit voxelize … --finish``), once every tile is done: max-pooled
    from the last level the tiles wrote, in this process."""
    return json.loads(_voxkit.finish_tiles(os.fspath(store), int(max_memory_mib)))


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
    pyramid: bool = False,
) -> dict:
    """Voxelize ``mesh_path`` into the OME-Zarr ``store`` tile by tile.

    Plans (metadata written once, tiles that meet the mesh listed), then maps
    the tiles with ``client.map`` (a ``distributed.Client``) or, without a
    client, a ``dask.bag`` run in this process one tile after another (each
    tile uses every core). Failed tiles are retried ``retries`` times (a
    tile rewrites its whole shards, so a retry repairs a half-written one).
    ``threads`` caps each tile's threads (e.g. ``threads_per_worker``).
    ``pyramid``: the store gets multiscale levels (as ``--pyramid``); the
    tiles write those they can and :func:`finish_tiled` the rest here,
    once every tile succeeded (summary key ``pyramid``).

    Returns a summary: ``store``, ``dims``, ``tiles`` (planned), ``done``,
    ``failed`` (list of ``{tile, error}``), ``voxels``, ``seconds``,
    ``plan_seconds``, ``tile_seconds`` (sum of the tiles' own times),
    ``max_peak_rss_mib``, ``max_estimated_mib`` and ``reports`` (one per
    tile). The store equals ``voxkit voxelize MESH --voxel-size H --origin
    X,Y,Z -o whole.zarr`` voxel for voxel.
    """
    start = time.perf_counter()
    plan_args = (mesh_path, store, voxel_size, origin, tile_size, mode)
    plan_kwargs = dict(inside=inside, force=force, max_memory_mib=max_memory_mib, pyramid=pyramid)
    if client is not None:
        # Planned on a worker: it keeps the mesh loaded and quantized for
        # its tiles (one parse fewer on the critical path).
        plan = client.submit(plan_tiled, *plan_args, pure=False, **plan_kwargs).result()
    else:
        plan = plan_tiled(*plan_args, **plan_kwargs)
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
    finished = None
    if plan["levels"] > plan["tile_levels"] and not failed:
        finished = finish_tiled(store, max_memory_mib=max_memory_mib)
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
        "pyramid": finished,
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


# The grid a worker process read for the render_tiled call that `token`
# names: every rectangle of one call on that worker reuses it, and a new
# call (a store voxelized again since) reads the store anew.
_RENDER_GRID: Dict[str, Any] = {}


class _RenderTask:
    """One rectangle of pixels of a frame, picklable for the workers."""

    def __init__(self, store, level, max_memory_mib, options, token):
        self.store, self.level, self.max_memory_mib = store, level, max_memory_mib
        self.options, self.token = options, token

    def __call__(self, rect):
        from . import load_grid, open_store, render

        t = time.perf_counter()
        cached = _RENDER_GRID.get("token") == self.token
        if not cached:
            _RENDER_GRID.clear()
            # A store voxkit wrote is opened, not loaded: each worker decodes
            # only the chunks its rectangles' rays reach (and keeps them for
            # its next rectangles); another tool's store is loaded whole.
            grid = open_store(self.store, level=self.level, max_memory_mib=self.max_memory_mib)
            if grid is None:
                grid = load_grid(self.store, level=self.level, max_memory_mib=self.max_memory_mib)
            _RENDER_GRID["grid"] = grid
            _RENDER_GRID["token"] = self.token
        load_s = time.perf_counter() - t
        rgb, depth = render(_RENDER_GRID["grid"], pixels=rect, max_memory_mib=self.max_memory_mib, **self.options)
        return {
            "rect": list(rect),
            "rgb": rgb,
            "depth": depth,
            "grid_cached": cached,
            "load_seconds": load_s,
            "seconds": time.perf_counter() - t,
        }


def render_tiled(
    store: os.PathLike,
    out: Optional[os.PathLike] = None,
    *,
    level: int = 0,
    size: Sequence[int] = (1024, 1024),
    tile: int = 256,
    client=None,
    retries: int = 2,
    progress: bool = True,
    overwrite: bool = False,
    max_memory_mib: int = 4096,
    **options: Any,
) -> dict:
    """Render a voxel store (``level`` of its pyramid) as :func:`voxkit.render`
    would, split into ``tile`` × ``tile`` rectangles of pixels mapped over
    ``client`` (or run here without one), then stitched.

    Every worker opens the store (shared filesystem) once per call, reads
    only the chunks its rectangles' rays reach (:func:`voxkit.open_store`),
    and renders its rectangles with the frame's camera: each ray depends on its
    pixel alone, so the stitched picture equals the single-process render
    pixel for pixel. ``options`` are :func:`voxkit.render`'s (``eye``,
    ``view``, ``ray``, ``fov``, …). ``out``: also write the picture as PNG.

    Returns ``rgb`` (H, W, 3 uint8), ``depth`` (H, W float32), ``tiles``,
    ``failed`` (rectangles with their errors: their pixels stay
    background/``inf``), ``seconds`` and ``reports`` (per rectangle, without
    the pixels).
    """
    w, h = (int(size[0]), int(size[1]))
    if w <= 0 or h <= 0 or tile <= 0:
        raise ValueError(f"size and tile must be positive, got size={size!r}, tile={tile!r}")
    for bad in ("pixels", "volume", "iso", "window", "tf"):
        if bad in options:
            raise ValueError(f"render_tiled renders voxel stores; {bad!r} does not apply")
    start = time.perf_counter()
    rects = [(x, y, min(tile, w - x), min(tile, h - y)) for y in range(0, h, tile) for x in range(0, w, tile)]
    task = _RenderTask(os.fspath(store), int(level), int(max_memory_mib), dict(options, size=(w, h)), uuid.uuid4().hex)
    reports = _map(task, rects, client, retries, progress)
    bg = np.asarray(options.get("background", (0.07, 0.08, 0.1)), dtype=np.float64)
    rgb = np.empty((h, w, 3), dtype=np.uint8)
    rgb[:] = np.clip(bg * 255.0 + 0.5, 0, 255).astype(np.uint8)
    depth = np.full((h, w), np.inf, dtype=np.float32)
    failed = []
    for r in reports:
        if "error" in r:
            failed.append(r)
            continue
        x, y, rw, rh = r.pop("rect")
        rgb[y : y + rh, x : x + rw] = r.pop("rgb")
        depth[y : y + rh, x : x + rw] = r.pop("depth")
        r["rect"] = [x, y, rw, rh]
    if out is not None:
        from . import write_png

        write_png(out, rgb, overwrite=overwrite)
    return {
        "rgb": rgb,
        "depth": depth,
        "tiles": len(rects),
        "failed": failed,
        "seconds": time.perf_counter() - start,
        "reports": reports,
    }
