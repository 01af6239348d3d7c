#!/usr/bin/env python3
"""First-hit casting of a triangle mesh with Intel Embree (embreex: the CPU ray tracer trimesh
uses) along the pixel rays of a camera that `voxkit render --json` printed: the physical
reference for a voxel surface frame (issue 21: voxkit's frame × its threads against Embree's
single-thread frame, same rays).

usage (the render peer venv, with `pip install embreex`; scripts/setup_render_peer.sh):

    voxkit render MESH.obj -o x.png --json > vk.json
    ~/.cache/voxkit-peers/venv/bin/python scripts/embree_rays.py MESH.obj \
        --camera "$(python3 -c 'import json,sys; print(json.dumps(json.load(open("vk.json"))["camera"]))')" \
        --size 1024x1024 [--reps 5]

Pixel (x, y) of a W×H image, as voxkit casts it (src/cli/render.rs, `camera_json`):
n_x = 2(x + ½)/W − 1, n_y = 1 − 2(y + ½)/H; perspective: from `eye` along
normalize(f + r·n_x·s_r + u·n_y·s_u) with s_u = tan(fov/2), s_r = s_u·W/H; orthographic
(`ortho_height` h): from eye + r·n_x·s_r + u·n_y·s_u along f with s_u = h/2. The rays are
formed in float64 and handed to Embree in float32. Embree casts them in one `run` call on one
thread (embreex's `rtcIntersect1` loop). OBJ is read here (v and f records, negative indices,
polygons fanned): trimesh 5.2 misreads relative indices. Prints one JSON line: frame_ms_median
over --reps after a warm-up, hit_fraction, build_ms, triangles. Needs numpy and embreex only.
"""
import argparse
import json
import statistics
import time

import numpy as np
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh


def read_obj(path):
    verts, faces = [], []
    with open(path, encoding="latin-1") as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                verts.append([float(x) for x in parts[1:4]])
            elif parts[0] == "f":
                idx = []
                for p in parts[1:]:
                    i = int(p.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(verts) + i)
                faces += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    return np.asarray(verts, dtype=np.float64), np.asarray(faces, dtype=np.int64)


def pixel_rays(cam, w, h):
    """Origins and unit directions (float64, row-major from the top-left pixel)."""
    eye, r, u, f = (np.asarray(cam[k], dtype=np.float64)
                    for k in ("eye", "right_axis", "up_axis", "forward_axis"))
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    nx = 2.0 * (xs + 0.5) / w - 1.0
    ny = 1.0 - 2.0 * (ys + 0.5) / h
    if "ortho_height" in cam:
        su = cam["ortho_height"] * 0.5
        sr = su * w / h
        o = eye + nx[..., None] * sr * r + ny[..., None] * su * u
        d = np.broadcast_to(f, o.shape)
    else:
        su = np.tan(np.radians(cam["fov_y_deg"]) * 0.5)
        sr = su * w / h
        d = f + nx[..., None] * sr * r + ny[..., None] * su * u
        d = d / np.linalg.norm(d, axis=2, keepdims=True)
        o = np.broadcast_to(eye, d.shape)
    return o.reshape(-1, 3), d.reshape(-1, 3)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh")
    ap.add_argument("--camera", required=True, help="voxkit render --json's camera object (JSON text)")
    ap.add_argument("--size", default="1024x1024")
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args()
    w, h = (int(v) for v in a.size.split("x"))
    cam = json.loads(a.camera)
    V, F = read_obj(a.mesh)
    tri = np.ascontiguousarray(V[F], dtype=np.float32)
    t0 = time.perf_counter()
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, tri)
    build = time.perf_counter() - t0
    o, d = pixel_rays(cam, w, h)
    o = np.ascontiguousarray(o, dtype=np.float32)
    d = np.ascontiguousarray(d, dtype=np.float32)
    scene.run(o, d)  # warm-up (the scene's acceleration structure is committed here)
    ts, ids = [], None
    for _ in range(a.reps):
        t0 = time.perf_counter()
        ids = scene.run(o, d)
        ts.append((time.perf_counter() - t0) * 1000)
    print(json.dumps({"tool": "embree", "triangles": int(len(F)), "frame_ms_median": statistics.median(ts),
                      "frame_ms_all": ts, "build_ms": build * 1000,
                      "hit_fraction": float((np.asarray(ids) >= 0).mean()), "size": [w, h],
                      "projection": "ortho" if "ortho_height" in cam else "perspective"}))


if __name__ == "__main__":
    main()
