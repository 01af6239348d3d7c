#!/usr/bin/env python3
"""Voxelize the same meshes at the same resolutions with voxkit, Open3D and
trimesh in one run, and measure every tool's output with the same exact
measure (`voxkit measure`: missing/extra voxels against the exact
conservative set on that tool's own lattice, centre-to-surface distances,
tunnel verdicts on closed meshes).

usage (from the repository root, with the peers' virtualenv, see
../shared/peers/README.md):

    cargo build --release
    ../shared/peers/.venv/bin/python scripts/compare_peers.py \
        [--meshes M ...] [--res 256 512 1024] [--trimesh-max 256] [--reps 3]

Times are each tool's in-process voxelization step only (mesh loading and
file writing excluded): voxkit's `voxelize_ms` (quantization + kernel +
brick assembly; run with all cores and again with RAYON_NUM_THREADS=1),
Open3D's `create_from_triangle_mesh` call and trimesh's `voxelized` call
(both single-threaded). Each time is the median of --reps process runs.
Prints one JSON line per (mesh, res, tool) and a markdown table at the end.

Solid mode against libigl's winding number and trimesh's fill, on meshes with
holes: scripts/compare_solid.py.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
VOXKIT = ROOT / "target" / "release" / "voxkit"


def run_json(cmd, env=None):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed ({r.returncode}):\n{r.stderr}")
    lines = [l for l in r.stdout.splitlines() if l.startswith("{")]
    return json.loads(lines[-1])


def measure(mesh, coords_npz, tmp):
    """`voxkit measure` on a peer's .npz (coords, origin, voxel_size)."""
    d = np.load(coords_npz)
    coords = np.ascontiguousarray(d["coords"], dtype=np.int32).reshape(-1, 3)
    npy = Path(tmp) / "coords.npy"
    np.save(npy, coords)
    o = [float(x) for x in d["origin"]]
    h = float(d["voxel_size"])
    return run_json([VOXKIT, "measure", mesh, npy, "--origin", *map(repr, o), "--voxel-size", repr(h)])


KEYS = ["reference_voxels", "missing", "extra", "max_distance", "mean_distance", "far_voxels", "closed", "tunnel6", "tunnel26"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", nargs="+", default=["data/meshes/obj/stanford-bunny.obj", "data/meshes/obj/spot.obj"])
    ap.add_argument("--res", nargs="+", type=int, default=[256, 512, 1024])
    ap.add_argument("--trimesh-max", type=int, default=256, help="largest RES given to trimesh (it is slow)")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--peers", default=str(ROOT.parent / "shared" / "peers"))
    a = ap.parse_args()
    if not VOXKIT.exists():
        raise SystemExit(f"{VOXKIT} missing: run `cargo build --release` first")
    py = sys.executable
    peers = Path(a.peers)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for mesh in a.meshes:
            for res in a.res:
                out = Path(tmp) / "v.binvox"
                for mode in ["thin", "conservative"]:
                    base = [VOXKIT, "voxelize", mesh, "-r", str(res), "-o", out, "--mode", mode, "--json", "-q", "--force"]
                    m = run_json(base + ["--measure"])
                    t_all = [m["voxelize_ms"]] + [run_json(base)["voxelize_ms"] for _ in range(a.reps - 1)]
                    env1 = dict(os.environ, RAYON_NUM_THREADS="1")
                    t_one = [run_json(base, env1)["voxelize_ms"] for _ in range(a.reps)]
                    rows.append(dict(mesh=Path(mesh).name, res=res, tool=f"voxkit {mode}",
                                     ms=statistics.median(t_all), ms_1thread=statistics.median(t_one),
                                     voxels=m["voxels"], **{k: m[k] for k in KEYS}))
                    print(json.dumps(rows[-1]), flush=True)
                tools = [("open3d", peers / "voxelize_open3d.py", [])]
                if res <= a.trimesh_max:
                    tools.append(("trimesh", peers / "voxelize_trimesh.py", []))
                for name, script, extra in tools:
                    npz = Path(tmp) / f"{name}.npz"
                    runs = [run_json([py, script, mesh, str(res), npz, *extra]) for _ in range(a.reps)]
                    m = measure(mesh, npz, tmp)
                    t = statistics.median(r["elapsed_s"] for r in runs) * 1e3
                    rows.append(dict(mesh=Path(mesh).name, res=res, tool=name, ms=t, ms_1thread=t,
                                     voxels=runs[-1]["voxels"], **{k: m[k] for k in KEYS}))
                    print(json.dumps(rows[-1]), flush=True)
    print()
    print("| mesh | res | tool | time (ms) | 1 thread (ms) | voxels | exact conservative | missing | extra | max dist | mean dist | 6-tunnel | 26-tunnel |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    fmt_t = lambda v: "–" if v is None else ("yes" if v else "no")
    for r in rows:
        print(f"| {r['mesh']} | {r['res']} | {r['tool']} | {r['ms']:.1f} | {r['ms_1thread']:.1f} | {r['voxels']:,} | "
              f"{r['reference_voxels']:,} | {r['missing']:,} | {r['extra']:,} | {r['max_distance']:.3f} | "
              f"{r['mean_distance']:.3f} | {fmt_t(r['tunnel6'])} | {fmt_t(r['tunnel26'])} |")


if __name__ == "__main__":
    main()
