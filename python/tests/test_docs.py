"""The docstrings' examples run (from the repository root, where their
paths point)."""

import doctest
import os

import numpy as np

import voxkit
from conftest import ROOT


def test_docstring_examples(monkeypatch):
    monkeypatch.chdir(ROOT)
    r = doctest.testmod(voxkit, extraglobs={"voxkit": voxkit, "np": np}, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert r.attempted > 10 and r.failed == 0, r


def test_public_api_has_docstrings():
    for name in voxkit.__all__:
        assert getattr(voxkit, name).__doc__, name
    for m in ["indices", "dense", "points", "save", "tunnels", "measure", "to_trimesh"]:
        assert getattr(voxkit.VoxelGrid, m).__doc__, m
    assert os.path.exists(os.path.join(os.path.dirname(voxkit.__file__), "_voxkit.pyi"))
    assert os.path.exists(os.path.join(os.path.dirname(voxkit.__file__), "py.typed"))
