#!/usr/bin/env python3
"""OBJ loading speed: voxkit (the CLI's `load_ms`) against trimesh and Open3D
on the same files, with the disk-cache floor (reading the bytes) measured in
the same rounds. Rounds are interleaved so that the shared machine's slow
phases hit every reader; each figure is the median over rounds.

Usage (from the repository root, with the peers' venv, see
/work/shared/peers/README.md):
    PY=path/to/venv/bin/python
    $PY scripts/obj_load_speed.py --voxkit target/release/voxkit --rounds 5 FILE.obj...
    $PY scripts/obj_load_speed.py --make-sphere out/sphere.obj 8   # a large test file

Prints one Markdown table: file, MB, then MB/s for the floor, voxkit, trimesh
and Open3D, and voxkit's ratio to each.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time


def floor_s(path):
    t = time.perf_counter()
    with open(path, "rb") as f:
        f.read()
    return time.perf_counter() - t


def voxkit_s(binary, path, out):
    r = subprocess.run(
        [binary, "voxelize", path, "-r", "4", "-o", out, "--force", "--json", "-q"],
        capture_output=True, text=True, check=True,
    )
    return json.loads(r.stdout.splitlines()[0])["load_ms"] / 1e3


def trimesh_s(path):
    import trimesh
    t = time.perf_counter()
    trimesh.load(path, force="mesh", process=False)
    return time.perf_counter() - t


def open3d_s(path):
    import open3d as o3d
    t = time.perf_counter()
    o3d.io.read_triangle_mesh(path)
    return time.perf_counter() - t


def make_sphere(path, subdivisions):
    import trimesh
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    with open(path, "w") as f:
        f.write("".join(f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in m.vertices))
        f.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in m.faces))
    print(f"{path}: {len(m.faces)} triangles, {os.path.getsize(path) / 1e6:.1f} MB")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--voxkit", default="target/release/voxkit")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--make-sphere", nargs=2, metavar=("OUT", "SUBDIVISIONS"))
    ap.add_argument("files", nargs="*")
    a = ap.parse_args()
    if a.make_sphere:
        make_sphere(a.make_sphere[0], int(a.make_sphere[1]))
        return
    out = os.path.join(tempfile.mkdtemp(), "x.binvox")
    print("| file | MB | floor MB/s | voxkit MB/s | trimesh MB/s | Open3D MB/s | voxkit / trimesh | voxkit / Open3D |")
    print("|---|---|---|---|---|---|---|---|")
    for path in a.files:
        mb = os.path.getsize(path) / 1e6
        times = {"floor": [], "voxkit": [], "trimesh": [], "open3d": []}
        floor_s(path)  # warm the page cache
        for _ in range(a.rounds):
            times["floor"].append(floor_s(path))
            times["voxkit"].append(voxkit_s(a.voxkit, path, out))
            times["trimesh"].append(trimesh_s(path))
            times["open3d"].append(open3d_s(path))
        rate = {k: mb / statistics.median(v) for k, v in times.items()}
        print(
            f"| {os.path.basename(path)} | {mb:.1f} | {rate['floor']:.0f} | {rate['voxkit']:.0f} | "
            f"{rate['trimesh']:.0f} | {rate['open3d']:.0f} | {rate['voxkit'] / rate['trimesh']:.1f}x | "
            f"{rate['voxkit'] / rate['open3d']:.1f}x |"
        )
        sys.stdout.flush()


if __name__ == "__main__":
    main()
