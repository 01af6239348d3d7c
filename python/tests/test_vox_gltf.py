"""MagicaVoxel .vox scenes and glTF extensions through voxkit.load_grid /
voxkit.load_mesh: the conformance corpus of tests/data/formats (written by
make_vox_gltf.py, whose answers are the geometry it encoded)."""

import json
import warnings

import numpy as np
import pytest

import voxkit
from conftest import ROOT

FORMATS = ROOT / "tests" / "data" / "formats"
EXPECTED = json.loads((FORMATS / "vox_gltf_expected.json").read_text())


def world_voxels(grid):
    """Voxel indices in world voxel units (the .vox origin is in voxels)."""
    assert grid.voxel_size == 1.0
    return {tuple(int(c) for c in v) for v in grid.indices() + grid.origin.astype(np.int64)}


@pytest.mark.parametrize("name", ["instanced.vox", "rotations_odd.vox", "rotations_even.vox", "groups.vox"])
def test_vox_scene_graphs(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # these files skip nothing
        g = voxkit.load_grid(FORMATS / "vox" / name)
    want = {tuple(v) for v in EXPECTED["vox"][name]["voxels"]}
    assert world_voxels(g) == want


@pytest.mark.parametrize("name", ["hidden.vox", "animation_frames.vox", "keyframes.vox"])
def test_vox_skips_what_the_editor_hides_with_warnings(name):
    want = EXPECTED["vox"][name]
    with pytest.warns(UserWarning) as record:
        g = voxkit.load_grid(FORMATS / "vox" / name)
    messages = [str(w.message) for w in record]
    for w in want["warnings"]:
        assert any(w in m and name in m for m in messages), (w, messages)
    assert world_voxels(g) == {tuple(v) for v in want["voxels"]}


@pytest.mark.parametrize(
    "name",
    sorted(n for n, w in EXPECTED["gltf"].items() if "positions" in w and not w.get("warnings")),
)
def test_gltf_extensions_load(name):
    want = EXPECTED["gltf"][name]
    v, f = voxkit.load_mesh(FORMATS / "gltf" / name)
    np.testing.assert_allclose(v, np.array(want["positions"]), rtol=1e-6, atol=1e-6)
    assert len(f) == want["triangles"]


def test_gltf_without_scene_warns():
    with pytest.warns(UserWarning, match="no scene"):
        v, f = voxkit.load_mesh(FORMATS / "gltf" / "no_scene_root_nodes.gltf")
    assert len(f) == 8


@pytest.mark.parametrize("name", sorted(n for n, w in EXPECTED["gltf"].items() if "error" in w))
def test_gltf_refusals_are_one_line(name):
    with pytest.raises(ValueError) as e:
        voxkit.load_mesh(FORMATS / "gltf" / name)
    msg = str(e.value)
    assert "\n" not in msg and len(msg) - len(str(FORMATS / "gltf" / name)) < 300
    for w in EXPECTED["gltf"][name]["error"]:
        assert w in msg
