#!/usr/bin/env python3
"""voxkit called from Python against trimesh `voxelized` and Open3D
`VoxelGrid.create_from_triangle_mesh`, in one process and one run, every
tool's voxels scored by the library's measure (`voxkit measure`).

usage (from the repository root; a Python with numpy, trimesh and open3d,
e.g. the peers' virtualenv of ../shared/peers/README.md, and this package):

    pip install --target /tmp/voxkit-site ./python      # leaves the venv untouched
    PYTHONPATH=/tmp/voxkit-site ../shared/peers/.venv/bin/python scripts/compare_python.py \\
        [--meshes M ...] [--res 256 512 1024] [--trimesh-max 256] [--reps 5]

All tools get the same (vertices, faces) arrays (`voxkit.load_mesh`) and the
same pitch h = longest bounding-box side / RES. Times are in-process wall
times of the one call (mesh arrays already in memory), the median of --reps
calls after one warm-up call:
* voxkit: `voxkit.voxelize(v, f, resolution=RES, mode=…)` with its default
  threads (all cores) and with `threads=1`; `+indices` adds the
  `grid.indices()` call that hands the voxels to numpy. `voxelize_ms` is the
  library's own time inside the same calls (`grid.stats`), so
  `wall / voxelize_ms` is the binding's overhead;
* Open3D: `create_from_triangle_mesh(mesh, voxel_size=h)` (single-threaded;
  getting its voxels into numpy, `get_voxels()`, is not timed);
* trimesh: `Trimesh(v, f, process=False).voxelized(h)` (method
  `subdivide`, single-threaded), for RES up to --trimesh-max (it takes
  seconds at 256 and grows 4× per doubling, in time and memory).

Error: `voxkit.measure(mesh, indices, origin, h)` on each tool's own lattice
(the library function behind `voxkit measure`: missing / extra voxels against
the exact conservative set, centre-to-surface distances, tunnel verdicts of
closed meshes). voxkit's own grids are measured by `grid.measure` (as
`voxkit voxelize --measure`: the reference restricted to the fitted grid box,
which is closed at its faces); `beyond` counts the reference voxels outside
that box, which `voxkit measure` on the widened lattice reports as missing.

Prints one JSON line per row, then markdown tables.
"""

import argparse
import json
import os
import statistics
import time
from pathlib import Path

import numpy as np

import voxkit

ROOT = Path(__file__).resolve().parent.parent
KEYS = ["reference_voxels", "missing", "extra", "max_distance", "mean_distance", "tunnel6", "tunnel26"]


def median_time(fn, reps):
    fn()  # warm-up: thread pool start, first touches
    times, out = [], None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = fn()
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times), out


def voxkit_rows(name, v, f, res, mode, reps):
    rows = []
    for threads in [None, 1]:
        stats = []

        def call():
            g = voxkit.voxelize(v, f, resolution=res, mode=mode, threads=threads)
            stats.append(g.stats["voxelize_ms"])
            return g

        wall, g = median_time(call, reps)
        lib = statistics.median(stats[1:])
        with_idx, _ = median_time(lambda: voxkit.voxelize(v, f, resolution=res, mode=mode, threads=threads).indices(), reps)
        row = dict(mesh=name, res=res, tool=f"voxkit {mode}", threads="all" if threads is None else 1,
                   ms=wall, voxelize_ms=lib, overhead=wall / lib, ms_with_indices=with_idx, voxels=len(g))
        if threads is None:
            m = g.measure(v, f)
            wide = voxkit.measure((v, f), g.indices(), g.origin, g.voxel_size)
            row.update({k: m[k] for k in KEYS})
            row["beyond"] = wide["reference_voxels"] - m["reference_voxels"]
        rows.append(row)
    return rows


def open3d_row(name, v, f, res, h, reps):
    import open3d as o3d

    om = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(f.astype(np.int32)))
    wall, vg = median_time(lambda: o3d.geometry.VoxelGrid.create_from_triangle_mesh(om, voxel_size=h), reps)
    idx = np.array([x.grid_index for x in vg.get_voxels()], dtype=np.int64).reshape(-1, 3)
    m = voxkit.measure((v, f), idx, np.asarray(vg.origin), float(vg.voxel_size))
    return dict(mesh=name, res=res, tool=f"open3d {o3d.__version__}", threads=1, ms=wall, voxels=len(idx),
                **{k: m[k] for k in KEYS})


def trimesh_row(name, v, f, res, h, reps):
    import trimesh

    tm = trimesh.Trimesh(v, f, process=False)
    wall, vg = median_time(lambda: tm.voxelized(h), reps)
    idx = np.unique(np.asarray(vg.sparse_indices, dtype=np.int64), axis=0)
    t = np.asarray(vg.transform, dtype=np.float64)
    pitch = float(t[0, 0])
    m = voxkit.measure((v, f), idx, t[:3, 3] - 0.5 * pitch, pitch)
    return dict(mesh=name, res=res, tool=f"trimesh {trimesh.__version__}", threads=1, ms=wall, voxels=len(idx),
                **{k: m[k] for k in KEYS})


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", nargs="+", default=["data/meshes/obj/stanford-bunny.obj", "data/meshes/obj/spot.obj"])
    ap.add_argument("--res", nargs="+", type=int, default=[256, 512, 1024])
    ap.add_argument("--modes", nargs="+", default=["thin", "conservative"])
    ap.add_argument("--trimesh-max", type=int, default=256)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--trimesh-reps", type=int, default=1)
    a = ap.parse_args()
    print(json.dumps(dict(uptime=os.getloadavg(), cpus=os.cpu_count(), voxkit=voxkit.__version__,
                          numpy=np.__version__)), flush=True)
    rows = []
    for mesh in a.meshes:
        v, f = voxkit.load_mesh(ROOT / mesh)
        name = Path(mesh).name
        used = v[np.unique(f)]
        longest = float((used.max(0) - used.min(0)).max())
        for res in a.res:
            h = longest / res
            for mode in a.modes:
                for r in voxkit_rows(name, v, f, res, mode, a.reps):
                    rows.append(r)
                    print(json.dumps(r), flush=True)
            rows.append(open3d_row(name, v, f, res, h, a.reps))
            print(json.dumps(rows[-1]), flush=True)
            if res <= a.trimesh_max:
                rows.append(trimesh_row(name, v, f, res, h, a.trimesh_reps))
                print(json.dumps(rows[-1]), flush=True)
    print(json.dumps(dict(uptime_end=os.getloadavg())), flush=True)

    fmt_t = lambda x: "–" if x is None else ("yes" if x else "no")
    print()
    print("| mesh | res | tool | threads | ms | voxels | missing | extra | max dist | mean dist | 6-tunnel | 26-tunnel |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "missing" not in r:
            continue
        print(f"| {r['mesh']} | {r['res']} | {r['tool']} | {r['threads']} | {r['ms']:.1f} | {r['voxels']:,} | "
              f"{r['missing']:,} | {r['extra']:,} | {r['max_distance']:.3f} | {r['mean_distance']:.3f} | "
              f"{fmt_t(r['tunnel6'])} | {fmt_t(r['tunnel26'])} |")
    print()
    print("| mesh | res | voxkit mode | threads | Python wall ms | library voxelize_ms | wall / library | + indices() ms | Open3D ms | Open3D ÷ voxkit |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    o3d = {(r["mesh"], r["res"]): r["ms"] for r in rows if r["tool"].startswith("open3d")}
    for r in rows:
        if not r["tool"].startswith("voxkit"):
            continue
        peer = o3d.get((r["mesh"], r["res"]))
        print(f"| {r['mesh']} | {r['res']} | {r['tool'][7:]} | {r['threads']} | {r['ms']:.1f} | {r['voxelize_ms']:.1f} | "
              f"{r['overhead']:.3f} | {r['ms_with_indices']:.1f} | {peer:.0f} | {peer / r['ms']:.0f}× |")


if __name__ == "__main__":
    main()
