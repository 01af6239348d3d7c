#!/usr/bin/env python3
"""Writes a scene of many meshes as one OBJ: copies of a mesh on an N x N x N lattice of cells,
each turned by a random rotation, scaled by 0.7-1.0 and moved off its cell's centre, so that
copies never touch and no two are alike. The scale-out measurements (docs/scale-out.md) use it.

    python scripts/make_scene.py OUT.obj [--mesh data/meshes/obj/stanford-bunny.obj] [--n 3] [--seed 11]

The default (27 Stanford bunnies) has 1.875M triangles. Vertices are written with 9 significant
digits (the scene is a fresh mesh, not a copy of a measured one), through a temporary file
renamed into place.
"""
import argparse
import os
from pathlib import Path

import numpy as np


def read_obj(path):
    """Positions and triangles of a triangle OBJ (`v x y z`, `f a b c` with optional /t/n)."""
    verts, faces = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append([float(t) for t in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(t.split("/")[0]) for t in line.split()[1:]]
                idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    faces.append([idx[0], idx[k], idx[k + 1]])
    return np.array(verts, dtype=np.float64), np.array(faces, dtype=np.int64)


def random_rotation(rng):
    """A uniformly random rotation (QR of a Gaussian matrix, signs fixed)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path)
    ap.add_argument("--mesh", type=Path, default=Path(__file__).resolve().parent.parent / "data/meshes/obj/stanford-bunny.obj")
    ap.add_argument("--n", type=int, default=3, help="copies along each axis (n^3 in all)")
    ap.add_argument("--seed", type=int, default=11)
    a = ap.parse_args()
    v, f = read_obj(a.mesh)
    v = v - (v.min(axis=0) + v.max(axis=0)) / 2
    radius = np.linalg.norm(v, axis=1).max()  # a copy fits a ball of this radius
    cell = 2.0 * radius
    rng = np.random.default_rng(a.seed)
    tmp = a.out.with_name(a.out.name + ".tmp")
    nv = 0
    with open(tmp, "w") as out:
        out.write(f"# {a.n ** 3} copies of {a.mesh.name}, make_scene.py --n {a.n} --seed {a.seed}\n")
        for i in range(a.n):
            for j in range(a.n):
                for k in range(a.n):
                    s = rng.uniform(0.7, 1.0)
                    centre = (np.array([i, j, k]) + 0.5) * cell
                    centre += rng.uniform(-1, 1, size=3) * (1.0 - s) * radius
                    p = (v @ random_rotation(rng).T) * s + centre
                    np.savetxt(out, p, fmt="v %.9g %.9g %.9g")
                    np.savetxt(out, f + 1 + nv, fmt="f %d %d %d")
                    nv += len(p)
    os.replace(tmp, a.out)
    print(f"{a.out}: {a.n ** 3} copies, {nv} vertices, {a.n ** 3 * len(f)} triangles")


if __name__ == "__main__":
    main()
