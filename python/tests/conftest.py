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
