"""line / lines against the CLI's `voxkit line` and against each other."""

import json

import numpy as np
import pytest

import voxkit

KINDS = ["26", "18", "tripod", "aw", "adaptive"]


def segments(n, seed=42, span=40.0):
    rng = np.random.default_rng(seed)
    a = rng.uniform(-span, span, size=(n, 3))
    b = a + rng.uniform(-span, span, size=(n, 3))
    s = np.hstack([a, b])
    s[:5] = np.round(s[:5])  # lattice endpoints too
    return s


@pytest.mark.parametrize("kind", KINDS)
def test_line_equals_the_cli(cli, kind):
    segs = segments(25)
    r = cli("line", "--algo", kind, *[repr(float(x)) for x in segs.reshape(-1)])
    expect = [json.loads(l) for l in r.stdout.splitlines()]
    for s, e in zip(segs, expect):
        got = voxkit.line(s[:3], s[3:], kind)
        assert got.dtype == np.int64 and got.shape[1] == 3
        assert got.tolist() == e


def test_adaptive_flag_box_equals_the_cli(cli):
    s = [0.2, 0.1, 0.0, 17.0, 9.4, -5.2]
    r = cli("line", "--algo", "adaptive", "--flag-box", "4,0,-4,9,8,1", *map(str, s))
    assert voxkit.line(s[:3], s[3:], "adaptive", flag_box=(4, 0, -4, 9, 8, 1)).tolist() == json.loads(r.stdout)
    assert voxkit.line(s[:3], s[3:], "adaptive").tolist() == voxkit.line(s[:3], s[3:], "26").tolist()


@pytest.mark.parametrize("kind", KINDS)
def test_lines_batches_line(kind):
    segs = segments(3000, seed=7)
    vox, off = voxkit.lines(segs, kind)
    assert vox.dtype == np.int64 and off.dtype == np.int64
    assert off.shape == (len(segs) + 1,) and off[0] == 0 and off[-1] == len(vox)
    for i in [0, 1, 4, 1023, 1024, 2999]:
        assert np.array_equal(vox[off[i]:off[i + 1]], voxkit.line(segs[i, :3], segs[i, 3:], kind))


def test_line_properties():
    # 26-line from lattice points: d26 + 1 voxels, consecutive voxels 26-adjacent.
    v = voxkit.line((0, 0, 0), (7, -3, 2))
    assert len(v) == 8 and (np.abs(np.diff(v, axis=0)).max(axis=1) == 1).all()
    t = voxkit.line((0, 0, 0), (7, -3, 2), "tripod")
    assert (np.abs(np.diff(t, axis=0)).sum(axis=1) == 1).all()  # 6-connected
    assert len(voxkit.lines(np.zeros((0, 6)))[0]) == 0
