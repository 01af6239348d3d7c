#!/usr/bin/env python3
"""The scale-out measurement of docs/scale-out.md: one scene voxelized into an OME-Zarr store by
one process (`voxkit voxelize`, every core) and by tiles mapped over a Dask LocalCluster, in
interleaved rounds on the same machine, then the two stores compared voxel for voxel.

    python scripts/scale_out.py [--scene SCENE.obj] [--dims 8192] [--tile-size 1024] [--workers 2]
        [--rounds 2] [--work DIR] [--json OUT.json] [--tiled-only]

The scene (scripts/make_scene.py: 27 transformed Stanford bunnies, 1.9M triangles) is made when
missing. The lattice is fixed so that the scene's longest side spans `--dims - 2` voxels, with one
voxel of margin (origin = min - h).

Per round it reports the single process's wall time (the CLI's own phases and peak RSS beside
it) and the tiled run's: wall time from plan to the last tile (the cluster's start-up, reported
apart, is not in it), the plan, the sum of the tiles' own times, the scheduling overhead
(wall - plan - sum of tile times / workers), the tile times' spread, and each worker's peak RSS
(VmHWM, read from the workers after the run: Python, Dask and voxkit together) beside the
largest tile's memory estimate. Each tiled round starts a fresh cluster so that peaks are the
round's own. Needs `pip install ./python[dask]`.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import voxkit
from voxkit.distributed import voxelize_tiled

ROOT = Path(__file__).resolve().parent.parent


def cli_path():
    return os.environ.get("VOXKIT_CLI") or str(ROOT / "target" / "release" / "voxkit")


def vm_hwm_mib():
    """This process's peak resident set (VmHWM) in MiB."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    return None


def single(cli, scene, h, origin, store, max_memory):
    t = time.perf_counter()
    out = subprocess.run(
        [cli, "voxelize", str(scene), "--voxel-size", repr(h), "--origin", ",".join(map(repr, origin)),
         "-o", str(store), "--json", "--force", "--max-memory", str(max_memory)],
        check=True, capture_output=True, text=True,
    )
    wall = time.perf_counter() - t
    j = json.loads(out.stdout)
    return {"wall_s": wall, "voxels": j["voxels"], "dims": j["dims"], "load_ms": j["load_ms"],
            "voxelize_ms": j["voxelize_ms"], "write_ms": j["write_ms"], "peak_rss_mib": j["peak_rss_mib"],
            "estimated_mib": j["estimated_mib"]}


def tiled(scene, h, origin, store, tile_size, workers, max_memory):
    import distributed

    t = time.perf_counter()
    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                  dashboard_address=None, memory_limit=0) as cluster, \
            distributed.Client(cluster) as client:
        startup = time.perf_counter() - t
        idle = client.run(vm_hwm_mib)
        s = voxelize_tiled(scene, store, h, origin, tile_size, "thin", client=client, force=True,
                           progress=False, threads=1, max_memory_mib=max_memory)
        peaks = client.run(vm_hwm_mib)
    if s["failed"]:
        raise SystemExit(f"tiles failed: {s['failed'][:3]}")
    reps = s["reports"]
    tile_s = [(r["load_ms"] + r["voxelize_ms"] + r["write_ms"]) / 1e3 for r in reps]
    return {
        "wall_s": s["seconds"],
        "cluster_startup_s": startup,
        "plan_s": s["plan_seconds"],
        "tiles": s["tiles"],
        "voxels": s["voxels"],
        "tile_seconds_sum": s["tile_seconds"],
        "tile_s_median": statistics.median(tile_s),
        "tile_s_max": max(tile_s),
        "mesh_loads": sum(not r["mesh_cached"] for r in reps),
        "tile_load_s_max": max(r["load_ms"] for r in reps) / 1e3,
        "voxelize_s_sum": sum(r["voxelize_ms"] for r in reps) / 1e3,
        "write_s_sum": sum(r["write_ms"] for r in reps) / 1e3,
        "overhead_s": s["seconds"] - s["plan_seconds"] - s["tile_seconds"] / workers,
        "bytes": sum(r["bytes"] for r in reps),
        "shards": sum(r["shards"] for r in reps),
        "worker_idle_rss_mib": sorted(idle.values()),
        "worker_peak_rss_mib": sorted(peaks.values()),
        "max_tile_estimate_mib": s["max_estimated_mib"],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", type=Path, default=Path("/tmp/voxkit-scale/scene.obj"))
    ap.add_argument("--dims", type=int, default=8192)
    ap.add_argument("--tile-size", type=int, default=1024)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--work", type=Path, default=None, help="where the stores go (default: next to the scene)")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--tiled-only", action="store_true", help="no single-process run (e.g. 16384^3)")
    ap.add_argument("--max-memory", type=int, default=16384, help="MiB, for both runs")
    a = ap.parse_args()
    if not a.scene.exists():
        a.scene.parent.mkdir(parents=True, exist_ok=True)
        subprocess.run([sys.executable, str(ROOT / "scripts" / "make_scene.py"), str(a.scene)], check=True)
    work = a.work or a.scene.parent
    work.mkdir(parents=True, exist_ok=True)
    v, f = voxkit.load_mesh(a.scene)
    lo, hi = v.min(axis=0), v.max(axis=0)
    h = float((hi - lo).max()) / (a.dims - 2)
    origin = tuple(float(c) - h for c in lo)
    cli = cli_path()
    whole, tiles = work / f"whole-{a.dims}.zarr", work / f"tiled-{a.dims}.zarr"
    rounds = []
    for r in range(a.rounds):
        row = {"round": r + 1}
        if not a.tiled_only:
            row["single"] = single(cli, a.scene, h, origin, whole, a.max_memory)
            print(f"round {r + 1} single: {json.dumps(row['single'])}", flush=True)
        row["tiled"] = tiled(a.scene, h, origin, tiles, a.tile_size, a.workers, a.max_memory)
        print(f"round {r + 1} tiled: {json.dumps(row['tiled'])}", flush=True)
        if not a.tiled_only:
            row["ratio_tiled_over_single"] = row["tiled"]["wall_s"] / row["single"]["wall_s"]
            print(f"round {r + 1}: tiled / single = {row['ratio_tiled_over_single']:.3f}", flush=True)
        rounds.append(row)
    result = {"scene": str(a.scene), "triangles": int(len(f)), "dims": a.dims, "voxel_size": h,
              "origin": origin, "tile_size": a.tile_size, "workers": a.workers, "cpus": os.cpu_count(),
              "rounds": rounds}
    result["tiled_store_bytes"] = sum(p.stat().st_size for p in tiles.rglob("*") if p.is_file())
    if not a.tiled_only:
        t = time.perf_counter()
        equal = voxkit.load_grid(whole, max_memory_mib=a.max_memory) == voxkit.load_grid(tiles, max_memory_mib=a.max_memory)
        result["stores_equal"] = bool(equal)
        result["compare_s"] = time.perf_counter() - t
        print(f"stores equal: {equal} ({result['compare_s']:.1f} s)", flush=True)
    if a.json:
        a.json.write_text(json.dumps(result, indent=1))
    print(json.dumps({k: val for k, val in result.items() if k != "rounds"}))


if __name__ == "__main__":
    main()
