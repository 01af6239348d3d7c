"""Shared fixtures: the repository's meshes and the `voxkit` command line
(for comparing the package with the CLI's files)."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MESHES = ROOT / "data" / "meshes"
SPOT = MESHES / "obj" / "spot.obj"
BUNNY = MESHES / "obj" / "stanford-bunny.obj"
FANDISK = MESHES / "obj" / "fandisk.obj"
TEAPOT = MESHES / "obj" / "teapot.obj"
SUZANNE = MESHES / "gltf" / "Suzanne" / "Suzanne.gltf"
CT_HEAD = ROOT / "data" / "volumes" / "headsq_quarter" / "headsq_quarter.nhdr"


def read_png_rgb(path):
    """The RGB pixels (H, W, 3) of an 8-bit RGB or RGBA PNG, decoded with
    the standard library's zlib (no imaging package)."""
    import struct
    import zlib

    import numpy as np

    data = Path(path).read_bytes()
    chunks, i = [], 8
    while i < len(data):
        n, kind = struct.unpack(">I4s", data[i:i + 8])
        chunks.append((kind, data[i + 8:i + 8 + n]))
        i += 12 + n
    w, h, depth, ctype = struct.unpack(">IIBB", chunks[0][1][:10])
    assert depth == 8
    raw = zlib.decompress(b"".join(c for k, c in chunks if k == b"IDAT"))
    bpp = {2: 3, 6: 4}[ctype]
    stride = w * bpp
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - bpp] if x >= bpp else 0
            b, c = prev[x], prev[x - bpp] if x >= bpp else 0
            p = a + b - c
            pred = [0, a, b, (a + b) // 2, a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else (b if abs(p - b) <= abs(p - c) else c)][f]
            line[x] = (line[x] + pred) & 0xFF
        rows.append(bytes(line))
        prev = line
    return np.frombuffer(b"".join(rows), np.uint8).reshape(h, w, bpp)[..., :3]


def _cli_path():
    env = os.environ.get("VOXKIT_CLI")
    if env:
        return Path(env)
    for p in (ROOT / "target" / "release" / "voxkit", shutil.which("voxkit")):
        if p and Path(p).exists():
            return Path(p)
    return None


@pytest.fixture(scope="session")
def cli():
    """Runs the `voxkit` binary (VOXKIT_CLI, else target/release/voxkit).
    Missing: the test is skipped, or fails when VOXKIT_CLI names a file
    that is not there (CI sets it)."""
    path = _cli_path()
    if path is None:
        pytest.skip("the voxkit CLI is not built (cargo build --release, or set VOXKIT_CLI)")
    if not path.exists():
        pytest.fail(f"VOXKIT_CLI={path} does not exist")

    def run(*args, check=True):
        r = subprocess.run([str(path), *map(str, args)], capture_output=True, text=True)
        if check and r.returncode != 0:
            raise AssertionError(f"voxkit {' '.join(map(str, args))} failed ({r.returncode}): {r.stderr}")
        return r

    return run
