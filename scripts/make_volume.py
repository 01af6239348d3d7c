#!/usr/bin/env python3
"""Writes a synthetic scalar volume as a detached NRRD: soft Gaussian blobs inside a turbulent
spherical shell, the kind of data volume renderers meet in simulation output.

    python scripts/make_volume.py OUT.nhdr [--n 512] [--dtype float32|int16|uint8] [--seed 7]

* blobs: 12 Gaussians (sigma 12-40 voxels, amplitude 0.5-1.0), centres in the middle 60% of the box;
* shell: a sphere of radius 0.42 n whose radius is perturbed by a sum of random plane waves
  (the turbulence), thickness ~3% of n, value 0.6-1.0 varying along it;
* everything else: low-level noise (0-0.05), so no brick is exactly empty.

Integer dtypes scale [0, 1.2] to the type's range (int16: 0..32000, uint8: 0..255). Written slab by
slab (no n^3 float64 temporaries), then renamed into place.
"""
import argparse
import os
from pathlib import Path

import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path)
    ap.add_argument("--n", type=int, default=512)
    ap.add_argument("--dtype", default="float32", choices=["float32", "int16", "uint8"])
    ap.add_argument("--seed", type=int, default=7)
    a = ap.parse_args()
    n = a.n
    rng = np.random.default_rng(a.seed)
    centres = rng.uniform(0.2 * n, 0.8 * n, size=(12, 3))
    sigmas = rng.uniform(12.0, 40.0, size=12) * n / 512
    amps = rng.uniform(0.5, 1.0, size=12)
    waves = rng.normal(size=(24, 3))
    waves /= np.linalg.norm(waves, axis=1, keepdims=True)
    freqs = rng.uniform(2.0, 14.0, size=24)
    phases = rng.uniform(0, 2 * np.pi, size=24)
    wamps = rng.uniform(0.2, 1.0, size=24) / freqs
    idx = np.arange(n, dtype=np.float32)
    y, x = np.meshgrid(idx, idx, indexing="ij")
    raw = a.out.with_suffix(".raw")
    tmp = raw.with_suffix(".raw.tmp")
    scale = {"float32": 1.0, "int16": 32000 / 1.2, "uint8": 255 / 1.2}[a.dtype]
    with open(tmp, "wb") as f:
        for z in range(n):
            v = rng.uniform(0.0, 0.05, size=(n, n)).astype(np.float32)
            for (cx, cy, cz), s, amp in zip(centres, sigmas, amps):
                gz = np.exp(-0.5 * ((z - cz) / s) ** 2)
                if gz < 1e-6:
                    continue
                v += (amp * gz * np.exp(-0.5 * (((x - cx) / s) ** 2 + ((y - cy) / s) ** 2))).astype(np.float32)
            px, py, pz = (x - n / 2) / n, (y - n / 2) / n, (z - n / 2) / n
            r = np.sqrt(px * px + py * py + pz * pz)
            turb = np.zeros_like(r)
            for d, fq, ph, wa in zip(waves, freqs, phases, wamps):
                turb += wa * np.sin(2 * np.pi * fq * (d[0] * px + d[1] * py + d[2] * pz) + ph)
            shell = np.exp(-0.5 * ((r - 0.42 - 0.05 * turb) / 0.015) ** 2)
            v += (shell * (0.8 + 0.2 * np.sin(9 * px + 7 * py + 5 * pz))).astype(np.float32)
            out = v * scale
            if a.dtype == "float32":
                out.astype("<f4").tofile(f)
            else:
                info = np.iinfo(a.dtype)
                np.clip(np.rint(out), info.min, info.max).astype("<i2" if a.dtype == "int16" else "u1").tofile(f)
    os.replace(tmp, raw)
    nrrd_type = {"float32": "float", "int16": "short", "uint8": "uchar"}[a.dtype]
    hdr = (
        "NRRD0004\n"
        f"# voxkit scripts/make_volume.py --n {n} --dtype {a.dtype} --seed {a.seed}: blobs in a turbulent shell\n"
        f"type: {nrrd_type}\n"
        "dimension: 3\n"
        f"sizes: {n} {n} {n}\n"
        "spacings: 1 1 1\n"
        "endian: little\n"
        "encoding: raw\n"
        f"data file: {raw.name}\n"
    )
    t = a.out.with_suffix(".nhdr.tmp")
    t.write_text(hdr)
    os.replace(t, a.out)
    print(a.out)


if __name__ == "__main__":
    main()
