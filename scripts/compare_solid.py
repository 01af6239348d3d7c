#!/usr/bin/env python3
"""Solid voxelization of meshes with holes: voxkit `--mode solid` against
libigl's generalized winding number and trimesh's `voxelized(h).fill()`
(issue 14), plus a winding-number check of voxkit's solid on any OBJ.

usage (from the repository root, with the peers' virtualenv, see
../shared/peers/README.md; `cargo build --release` first):

    # the holes table: closed meshes with 0/1/5/20/40 % of their triangles deleted
    ../shared/peers/.venv/bin/python scripts/compare_solid.py \
        [--meshes spot fandisk bunny | PATH.obj ...] [--fractions 0 1 5 20 40] \
        [--res 128] [--seed 0] [--reps 1] [--no-trimesh] [--keep DIR] [--voxkit BIN]

    # the speed table (issue 22): voxkit against libigl, interleaved rounds
    ../shared/peers/.venv/bin/python scripts/compare_solid.py --speed \
        [--rounds 3] [--fractions 5 20 40] [--res 128 256] [--scanned-res 512 1024] [--voxkit BIN]
        [--baseline OLD_BIN] [--meshes spot bunny | PATH.obj ...] [--subdivide N]

    # the correctness check: voxkit solid against the winding number, one mesh
    ../shared/peers/.venv/bin/python scripts/compare_solid.py \
        --check-winding MESH.obj -r 128 [--exact] [--margin 0.05] [--allow 0] [--voxkit BIN]

HOLES MODE. For each closed mesh (Spot and fandisk are watertight; the
Stanford bunny gets its 5 base holes closed here, each boundary loop fanned
from its centroid), a seeded random permutation of the triangles is drawn and
its first 0/1/5/20/40 % deleted (nested; 0 % is the closed mesh itself). Every tool gets
the same holed (V, F), written as OBJ with positive indices and the full
vertex list. Scored per tool:

  * voxkit: `voxelize --mode solid --json`, the .binvox read back;
  * libigl: `igl.fast_winding_number(V, F, Q)` at every voxel centre Q of
    voxkit's lattice, inside where w >= 1/2;
  * trimesh: `Trimesh(V, F).voxelized(h).fill()` on trimesh's own lattice.

The reference is the CLOSED mesh's solid: libigl's fast winding number of the
closed mesh at the same centres (checked against voxkit's solid of the closed
mesh; the count of disagreements is printed as tool "check"). Voxels whose
closed cube meets the closed surface (the exact conservative set, from
../shared/peers/conservative_ref.py, grown by 1/256 voxel to absorb voxkit's
vertex quantization) are not scored. Score = voxels of the grid box, not in
that set, whose candidate solid differs from the reference: `wrong_pct` as %
of those voxels, `wrong_pct_inside` as % of those inside the reference (the
denominator that reproduces issue 14's table). Two tables are printed.
Also printed for voxkit: its disagreements with libigl on the HOLED mesh at
centres off the holed surface (issue 14's criterion), and how many of them
have the fast winding number within --margin of 1/2.

LATTICES. voxkit's lattice is origin = bbox min of the vertices the triangles
use, h = longest side / res, dims = ceil(extent / h); voxel (i, j, k) has its
centre at origin + (i + 1/2) h. The binvox file pads to a cube (dim D = max
dims, scale = D h, data order x, z, y with y fastest), so it is cropped to the
dims of `--json`. Deleting triangles could shrink that bbox, so one triangle at
each of the 6 extreme vertices is never deleted (at most 6 triangles), and the
holed run's dims/translate/scale are checked to equal the closed run's.
trimesh puts voxel centres at integer multiples n h of world space; it is
scored on the box of those voxels that meet the closed mesh's bbox, with the
reference and the conservative set rebuilt on that lattice.

Times: voxkit's `voxelize_ms` (all cores), libigl the fast_winding_number call
(IGL_NUM_THREADS threads, default all cores; it holds the GIL), trimesh
voxelized + fill (one thread); median of --reps. On a shared machine they vary
by 2x or more between runs.

SPEED MODE (`--speed`). One run, every case measured in the same rounds
(round r runs voxkit then libigl on case 1, then case 2, ...; medians over the
rounds), so the machine's slow phases hit both tools. Cases: Spot and the
bunny (holes closed as above) with 5, 20 and 40 % of their triangles deleted
(same seeded deletions as holes mode) at each `--res` (default 128 and 256);
a `--meshes` file whose holes the fans cannot close (a vertex starting two
boundary edges, like the teapot's) keeps its own holes and the deletions add
to them;
the bunny as scanned (its 5 base holes) at each `--scanned-res` (512, 1024);
the closed bunny at 1024 (voxkit only: its time and memory target). Both tools
run as child processes: voxkit `voxelize --mode solid --json` (its
`voxelize_ms`), libigl a Python child that loads V, F and voxkit's lattice,
builds the centres and times `igl.fast_winding_number` alone; peak RSS:
voxkit's own `peak_rss_mib`, the libigl child's VmHWM (it includes the
interpreter, numpy and the centres it is given, 24 B each). Above 20M centres libigl is timed on a
sample of 4M centres spread over the box and its time extrapolated per query
(printed `est`). Wrong voxels (at res <= 256, where the reference costs
seconds): centres off the holed mesh's conservative set (grown by 1/256) where
the tool differs from the winding number (libigl's fast one, recomputed
exactly within --margin of 1/2: the check mode's reference).

CHECK MODE. `--check-winding MESH.obj -r N` runs voxkit solid on the mesh and
counts the voxel centres, off the mesh's (grown) conservative set, where
voxkit's solid and the winding number (w >= 1/2) disagree. w is the fast
winding number, recomputed exactly (`igl.winding_number`) wherever it lies
within --margin of 1/2 (--exact: exactly everywhere, O(#triangles) per query:
about 0.1-0.3 ms of CPU per query for 70k triangles). The fast call's error at
voxel centres off the surface was at most 0.003 in every case tried, so with
the default margin 0.05 a fast answer is kept only 16x that error away from
1/2. Prints one JSON line; exits 1 when there are more than --allow
disagreements. OBJ only (triangles and polygons; `l`/`p` ignored).
"""

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
# ../shared/peers from the main checkout, ../../shared/peers from a worktree under wt/.
PEERS = next((p for p in (ROOT.parent / "shared" / "peers", ROOT.parent.parent / "shared" / "peers")
              if p.exists()), ROOT.parent / "shared" / "peers")
MESHES = {
    "spot": ROOT / "data/meshes/obj/spot.obj",
    "fandisk": ROOT / "data/meshes/obj/fandisk.obj",
    "bunny": ROOT / "data/meshes/obj/stanford-bunny.obj",
}
# voxkit rounds vertices to 1/256 voxel (at most 1/512 per axis), so its
# surface voxels may touch the exact triangles' conservative set within that.
QUANT_GROW = 1.0 / 256


# ---------------------------------------------------------------- meshes


def load_obj(path):
    """(V float64 (n,3), F int64 (m,3)): `v` and `f` records, polygons fanned
    from their first corner, negative indices resolved against the vertices
    read so far (as voxkit's loader does; trimesh 5.2 does not)."""
    V, F = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                V.append([float(x) for x in p[1:4]])
            elif p[0] == "f":
                idx = [int(t.split("/")[0]) for t in p[1:]]
                idx = [i - 1 if i > 0 else len(V) + i for i in idx]
                F.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    return np.array(V, dtype=np.float64), np.array(F, dtype=np.int64).reshape(-1, 3)


def write_obj(path, V, F):
    """Every vertex (used or not, so indices stay), 1-based positive faces."""
    with open(path, "w") as f:
        f.write("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in V.tolist()))
        f.write("".join(f"f {a} {b} {c}\n" for a, b, c in (F + 1).tolist()))


def boundary_halfedges(F):
    """Directed edges (a, b) of faces whose twin (b, a) is in no face."""
    he = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    twins = {(int(b), int(a)) for a, b in he}
    return [(int(a), int(b)) for a, b in he if (int(a), int(b)) not in twins]


def boundary_loops(F):
    """Boundary vertex loops, each in the direction of its faces' edges
    (each boundary vertex must start exactly one boundary edge)."""
    he = boundary_halfedges(F)
    nxt = dict(he)
    if len(nxt) != len(he):
        raise SystemExit("a vertex starts two boundary edges: cannot close the holes by fans")
    loops = []
    while nxt:
        start = next(iter(nxt))
        loop, v = [start], nxt.pop(start)
        while v != start:
            loop.append(v)
            v = nxt.pop(v)
        loops.append(loop)
    return loops


def close_holes(V, F):
    """Fans each boundary loop from its centroid (a new vertex), oriented
    like the faces around it (loop edge a->b gets the triangle b, a, c)."""
    V, F = list(V), [F]
    for loop in boundary_loops(F[0]):
        c = len(V)
        V.append(np.mean([V[i] for i in loop], axis=0))
        F.append(np.array([[b, a, c] for a, b in zip(loop, loop[1:] + loop[:1])], dtype=np.int64))
    return np.array(V), np.concatenate(F)


def closed_mesh(name, strict=True):
    """(V, F) of a named mesh, holes closed, checked watertight. With
    strict=False a mesh whose boundary the fans cannot close (a vertex
    starting two boundary edges, as on the teapot's lid and spout) is
    returned as it is, its own holes kept (a note on stderr)."""
    V0, F0 = load_obj(MESHES.get(name, name))
    nb = len(boundary_halfedges(F0))
    try:
        V, F = close_holes(V0, F0) if nb else (V0, F0)
        left = len(boundary_halfedges(F))
        if left:
            raise SystemExit(f"{name}: {left} boundary edges left after closing holes")
    except SystemExit as e:
        if strict:
            raise
        print(f"{name}: holes kept as they are ({e})", file=sys.stderr)
        V, F = V0, F0
    return V, F, nb


def subdivide(V, F):
    """Every triangle split 1-to-4 at its edge midpoints (shared midpoints
    shared): the same surface with four times the triangles, still closed."""
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, inv = np.unique(edges, axis=0, return_inverse=True)
    mids = len(V) + inv.reshape(3, -1).T  # per triangle: midpoints of edges 01, 12, 20
    V2 = np.concatenate([V, (V[uniq[:, 0]] + V[uniq[:, 1]]) / 2])
    a, b, c = F.T
    ab, bc, ca = mids.T
    F2 = np.concatenate([np.stack(t, axis=1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    return V2, F2


def protected_triangles(V, F):
    """One triangle at each vertex holding a min or max of the bbox of the
    used vertices: keeping them keeps voxkit's fitted lattice."""
    used = np.unique(F)
    keep = set()
    for a in range(3):
        for v in (used[np.argmin(V[used, a])], used[np.argmax(V[used, a])]):
            keep.add(int(np.nonzero((F == v).any(axis=1))[0][0]))
    return np.array(sorted(keep))


def delete_random(F, percent, seed, protect):
    """F without round(percent % of len(F)) triangles, drawn by one seeded
    permutation of the unprotected ones (nested across percentages)."""
    pool = np.setdiff1d(np.arange(len(F)), protect)
    order = np.random.default_rng(seed).permutation(pool)
    k = int(round(len(F) * percent / 100.0))
    gone = np.zeros(len(F), bool)
    gone[order[:k]] = True
    return F[~gone], k


# ---------------------------------------------------------------- lattices


class Lattice:
    """Voxel (i, j, k), 0 <= idx < dims, covers [origin + idx h, origin + (idx+1) h]."""

    def __init__(self, origin, h, dims):
        self.origin = np.asarray(origin, dtype=np.float64)
        self.h = float(h)
        self.dims = tuple(int(d) for d in dims)

    def centres(self, xs=slice(None)):
        """(N, 3) voxel centres, C order over (i, j, k); `xs` picks a slab of i."""
        ax = [self.origin[a] + (np.arange(self.dims[a]) + 0.5) * self.h for a in range(3)]
        ax[0] = ax[0][xs]
        g = np.meshgrid(*ax, indexing="ij")
        return np.stack([x.ravel() for x in g], axis=1)

    def mask(self, idx):
        """Bool array of `dims` with the voxels `idx` (N, 3) that lie in the box."""
        m = np.zeros(self.dims, bool)
        idx = np.asarray(idx, dtype=np.int64).reshape(-1, 3)
        ok = np.all((idx >= 0) & (idx < np.array(self.dims)), axis=1)
        m[tuple(idx[ok].T)] = True
        return m


def trimesh_lattice(V, F, h):
    """trimesh's lattice (centres at n h) over the voxels meeting the bbox of
    the used vertices: n from ceil(lo/h - 1/2) to floor(hi/h + 1/2)."""
    used = V[np.unique(F)]
    n0 = np.ceil(used.min(axis=0) / h - 0.5).astype(np.int64)
    n1 = np.floor(used.max(axis=0) / h + 0.5).astype(np.int64)
    return Lattice((n0 - 0.5) * h, h, n1 - n0 + 1), n0


def conservative(V, F, lat, grow=QUANT_GROW):
    """Voxels whose closed cube (grown by `grow` voxels) meets a triangle."""
    sys.path.insert(0, str(PEERS))
    from conservative_ref import conservative_voxels

    return lat.mask(conservative_voxels((V - lat.origin) / lat.h, F, grow=grow))


# ---------------------------------------------------------------- tools


def run_json(cmd):
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed ({r.returncode}):\n{r.stderr}")
    return json.loads([l for l in r.stdout.splitlines() if l.startswith("{")][-1])


def read_binvox(path):
    """(occupancy bool [x, y, z] of the D^3 cube, translate (3,), scale)."""
    with open(path, "rb") as f:
        assert f.readline().startswith(b"#binvox")
        head = {}
        while True:
            p = f.readline().split()
            if p[0] == b"data":
                break
            head[p[0].decode()] = [float(x) for x in p[1:]]
        runs = np.frombuffer(f.read(), dtype=np.uint8).reshape(-1, 2)
    d = [int(x) for x in head["dim"]]
    flat = np.repeat(runs[:, 0].astype(bool), runs[:, 1])
    # data order: x slowest, then z, y fastest; header dims in that order
    grid = flat.reshape(d[0], d[2], d[1]).transpose(0, 2, 1)
    return grid, np.array(head["translate"]), head["scale"][0]


def voxkit(binary, mesh, res, mode, out):
    """(occupancy on voxkit's lattice, Lattice, the --json record)."""
    j = run_json([binary, "voxelize", mesh, "-r", res, "-o", out, "--mode", mode, "--json", "-q", "--force"])
    grid, translate, scale = read_binvox(out)
    dims = j["dims"]
    lat = Lattice(translate, scale / max(grid.shape), dims)
    return grid[: dims[0], : dims[1], : dims[2]], lat, j


def winding(V, F, Q):
    """libigl's fast winding number (float64 in, float64 out; the 2.6.3 soup
    overload takes no accuracy parameter) and its wall time in ms."""
    import igl

    t = time.perf_counter()
    w = igl.fast_winding_number(V, F, Q)
    return w, (time.perf_counter() - t) * 1e3


def refine_near_half(V, F, Q, w, margin):
    """w with the entries within `margin` of 1/2 recomputed exactly."""
    import igl

    near = np.abs(w - 0.5) < margin
    w = w.copy()
    if near.any():
        w[near] = igl.winding_number(V, F, np.ascontiguousarray(Q[near]))
    return w, int(near.sum())


def trimesh_fill(V, F, h, lat, n0):
    """trimesh `voxelized(h).fill()` as a mask on `lat` (whose voxel 0 is
    trimesh's index n0), its time in ms, and voxels outside `lat`."""
    import trimesh

    m = trimesh.Trimesh(V, F, process=False)
    t = time.perf_counter()
    vg = m.voxelized(h).fill()
    ms = (time.perf_counter() - t) * 1e3
    offset = np.round(np.asarray(vg.transform)[:3, 3] / h).astype(np.int64)
    idx = np.asarray(vg.sparse_indices, dtype=np.int64) + offset - n0
    inside = np.all((idx >= 0) & (idx < np.array(lat.dims)), axis=1)
    return lat.mask(idx), ms, int((~inside).sum())


# ---------------------------------------------------------------- holes mode


def score(cand, ref, scored):
    """Misclassified scored voxels, as % of the scored voxels of the box
    (`wrong_pct`) and as % of the scored voxels inside the reference
    (`wrong_pct_inside`, the denominator of issue 14's table)."""
    wrong = int((cand != ref)[scored].sum())
    n, n_in = int(scored.sum()), int((scored & ref).sum())
    return dict(wrong=wrong, scored=n, scored_inside=n_in, wrong_pct=100.0 * wrong / n,
                wrong_pct_inside=100.0 * wrong / n_in)


def emit(rows, **r):
    rows.append(r)
    print(json.dumps(r), flush=True)


def holes_mesh(name, a, tmp, rows):
    V, Fc, nb = closed_mesh(name)
    label = Path(name).stem if name not in MESHES else name
    closed_path = Path(tmp) / f"{label}_closed.obj"
    write_obj(closed_path, V, Fc)
    out = Path(tmp) / "v.binvox"
    vk_closed, lat, jc = voxkit(a.voxkit, closed_path, a.res, "solid", out)
    Q = lat.centres()
    off = ~conservative(V, Fc, lat)
    ref = (winding(V, Fc, Q)[0] >= 0.5).reshape(lat.dims)
    vk_cons = voxkit(a.voxkit, closed_path, a.res, "conservative", out)[0]
    emit(rows, mesh=label, percent=None, tool="check", res=a.res, triangles=len(Fc), boundary_edges_closed=nb,
         dims=jc["dims"], voxkit_vs_reference=int((vk_closed != ref)[off].sum()), scored=int(off.sum()),
         voxkit_conservative_outside_set=int((vk_cons & off).sum()),
         set_outside_voxkit_conservative=int((~vk_cons & ~off).sum()))

    if not a.no_trimesh:
        tlat, n0 = trimesh_lattice(V, Fc, lat.h)
        tref = (winding(V, Fc, tlat.centres())[0] >= 0.5).reshape(tlat.dims)
        toff = ~conservative(V, Fc, tlat)
    protect = protected_triangles(V, Fc)
    for pct in a.fractions:
        Fh, k = delete_random(Fc, pct, a.seed, protect)
        holed = Path(tmp) / f"{label}_holed{pct:g}.obj"
        write_obj(holed, V, Fh)
        base = dict(mesh=label, percent=pct, removed=k, res=a.res)

        runs = [voxkit(a.voxkit, holed, a.res, "solid", out) for _ in range(a.reps)]
        vk, hlat, _ = runs[-1]
        same = hlat.dims == lat.dims and np.array_equal(hlat.origin, lat.origin) and hlat.h == lat.h
        if not same:
            raise SystemExit(f"{holed}: voxkit lattice {hlat.__dict__} differs from the closed mesh's {lat.__dict__}")
        w_runs = [winding(V, Fh, Q) for _ in range(a.reps)]
        w = w_runs[-1][0]
        igl_in = (w >= 0.5).reshape(lat.dims)
        off_holed = ~conservative(V, Fh, lat)
        dis = (vk != igl_in) & off_holed
        near = (np.abs(w - 0.5) < a.margin).reshape(lat.dims)
        emit(rows, **base, tool="voxkit", ms=statistics.median(r[2]["voxelize_ms"] for r in runs),
             **score(vk, ref, off), disagree_libigl=int(dis.sum()), disagree_near_half=int((dis & near).sum()),
             off_holed_surface=int(off_holed.sum()))
        emit(rows, **base, tool="libigl", ms=statistics.median(r[1] for r in w_runs), **score(igl_in, ref, off))
        if not a.no_trimesh:
            t_runs = [trimesh_fill(V, Fh, lat.h, tlat, n0) for _ in range(a.reps)]
            tm, _, outside = t_runs[-1]
            emit(rows, **base, tool="trimesh fill", ms=statistics.median(r[1] for r in t_runs),
                 **score(tm, tref, toff), outside_box=outside)


def fmt_ms(ms):
    return f"{ms / 1e3:.2f} s" if ms >= 1000 else f"{ms:.0f} ms" if ms >= 10 else f"{ms:.1f} ms"


def holes_table(rows):
    tools = ["voxkit", "libigl", "trimesh fill"]
    meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    cell = {(r["mesh"], r["percent"], r["tool"]): r for r in rows}
    cols = [(m, t) for m in meshes for t in tools if any(k[0] == m and k[2] == t for k in cell)]
    percents = list(dict.fromkeys(r["percent"] for r in rows if r["tool"] != "check"))

    def table(title, text):
        print(f"\n{title}\n")
        print("| triangles removed | " + " | ".join(f"{t}, {m}" for m, t in cols) + " |")
        print("|---|" + "---|" * len(cols))
        for p in percents:
            cs = [cell.get((m, p, t)) for m, t in cols]
            print(f"| {p:g}% | " + " | ".join("–" if r is None else text(r) for r in cs) + " |")

    table("Wrong voxels, % of the closed solid's interior voxels off the closed surface (issue 14's table), "
          "and the tool's time:", lambda r: f"{r['wrong_pct_inside']:.2f}% ({fmt_ms(r['ms'])})")
    table("Wrong voxels, % of all grid-box voxels off the closed surface:", lambda r: f"{r['wrong_pct']:.2f}%")
    print("\nvoxkit solid vs libigl fast winding number on the holed mesh, voxel centres off its surface "
          "(of them within --margin of 1/2):\n")
    print("| triangles removed | " + " | ".join(meshes) + " |")
    print("|---|" + "---|" * len(meshes))
    for p in percents:
        cs = [cell.get((m, p, "voxkit")) for m in meshes]
        print(f"| {p:g}% | " + " | ".join(
            "–" if r is None else f"{r['disagree_libigl']:,} ({r['disagree_near_half']:,})" for r in cs) + " |")


# ---------------------------------------------------------------- speed mode

IGL_CHILD = r"""
import json, sys, time
import numpy as np
import igl
d = np.load(sys.argv[1])
V, F, origin, h, dims = d["V"], d["F"], d["origin"], float(d["h"]), d["dims"]
sample = int(sys.argv[2])
ax = [origin[a] + (np.arange(dims[a]) + 0.5) * h for a in range(3)]
n = int(np.prod(dims))
if sample and n > sample:
    rng = np.random.default_rng(0)
    idx = np.sort(rng.choice(n, sample, replace=False))
    i, j, k = np.unravel_index(idx, tuple(int(x) for x in dims))
    Q = np.stack([ax[0][i], ax[1][j], ax[2][k]], axis=1)
else:
    g = np.meshgrid(*ax, indexing="ij")
    Q = np.stack([x.ravel() for x in g], axis=1)
t = time.perf_counter()
igl.fast_winding_number(V, F, Q)
ms = (time.perf_counter() - t) * 1e3
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM")][0].split()[1]
print(json.dumps(dict(ms=ms * n / len(Q), queries=len(Q), centres=n, estimated=len(Q) < n, peak_mib=int(hwm) / 1024)))
"""


def child_rss(cmd):
    """(JSON record, peak RSS MiB) of one child run: the record's own
    `peak_rss_mib` / `peak_mib` (wait4's ru_maxrss counts the forked
    parent's pages before exec, so it is not used)."""
    import os

    p = subprocess.Popen([str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out = p.stdout.read()
    err = p.stderr.read()
    _, status, ru = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed ({p.returncode}):\n{err}")
    j = json.loads([l for l in out.splitlines() if l.startswith("{")][-1])
    return j, j.get("peak_rss_mib", j.get("peak_mib"))


def speed(a):
    import igl

    tmp = Path(a.keep or tempfile.mkdtemp())
    tmp.mkdir(parents=True, exist_ok=True)
    cases = []
    for name in a.meshes:
        # Speed needs no closed reference: a mesh the fans cannot close
        # keeps its own holes, and the deletions add to them.
        V, Fc, _ = closed_mesh(name, strict=False)
        label = Path(name).stem if name not in MESHES else name
        for _ in range(a.subdivide):
            V, Fc = subdivide(V, Fc)
        if a.subdivide:
            label += f" ×4^{a.subdivide}" if a.subdivide > 1 else " ×4"
        protect = protected_triangles(V, Fc)
        for pct in a.fractions:
            Fh, k = delete_random(Fc, pct, a.seed, protect)
            path = tmp / f"{label}_holed{pct:g}.obj"
            write_obj(path, V, Fh)
            for res in a.res:
                cases.append(dict(mesh=label, damage=f"{pct:g}% removed", res=res, path=path, V=V, F=Fh, igl=True))
        if name == "bunny" and not a.subdivide:
            path = tmp / "bunny_closed.obj"
            write_obj(path, V, Fc)
            cases.append(dict(mesh=name, damage="closed", res=1024, path=path, V=V, F=Fc, igl=False))
    Vs, Fs = load_obj(MESHES["bunny"])
    for res in a.scanned_res:
        cases.append(dict(mesh="bunny", damage="as scanned", res=res, path=MESHES["bunny"], V=Vs, F=Fs, igl=True))
    out = tmp / "v.binvox"
    for c in cases:
        c["vk"], c["igl_runs"] = [], []
        j = run_json([a.voxkit, "voxelize", c["path"], "-r", c["res"], "-o", out, "--mode", "solid", "--json",
                      "-q", "--force"])
        grid, translate, scale = read_binvox(out)
        c["lat"] = Lattice(translate, scale / max(grid.shape), j["dims"])
        c["solid"] = grid[: j["dims"][0], : j["dims"][1], : j["dims"][2]]
        c["npz"] = tmp / f"case{cases.index(c)}.npz"
        np.savez(c["npz"], V=c["V"], F=c["F"], origin=c["lat"].origin, h=c["lat"].h, dims=np.array(c["lat"].dims))
    for r in range(a.rounds):
        for c in cases:
            j, rss = child_rss([a.voxkit, "voxelize", c["path"], "-r", c["res"], "-o", out, "--mode", "solid",
                                "--json", "-q", "--force"])
            c["vk"].append((j["voxelize_ms"], rss, j))
            if a.baseline:
                j, _ = child_rss([a.baseline, "voxelize", c["path"], "-r", c["res"], "-o", out, "--mode", "solid",
                                  "--json", "-q", "--force"])
                c.setdefault("base", []).append(j["voxelize_ms"])
            if c["igl"]:
                j, rss = child_rss([sys.executable, "-c", IGL_CHILD, c["npz"], 4_000_000 if c["res"] > 256 else 0])
                c["igl_runs"].append((j["ms"], rss, j))
        print(f"round {r + 1}/{a.rounds} done", file=sys.stderr, flush=True)
    rows = []
    for c in cases:
        vk_ms = statistics.median(x[0] for x in c["vk"])
        row = dict(mesh=c["mesh"], damage=c["damage"], res=c["res"], dims=c["lat"].dims,
                   voxkit_ms=vk_ms, voxkit_mib=max(x[1] for x in c["vk"]),
                   voxkit_all_ms=[x[0] for x in c["vk"]], json=c["vk"][-1][2])
        if a.baseline:
            row.update(baseline_ms=statistics.median(c["base"]), baseline_all_ms=c["base"],
                       baseline_over_voxkit=statistics.median(c["base"]) / vk_ms)
        if c["igl"]:
            row.update(libigl_ms=statistics.median(x[0] for x in c["igl_runs"]),
                       libigl_mib=max(x[1] for x in c["igl_runs"]),
                       libigl_all_ms=[x[0] for x in c["igl_runs"]],
                       libigl_estimated=c["igl_runs"][-1][2]["estimated"])
            row["ratio"] = row["libigl_ms"] / vk_ms
        print(json.dumps({k: v for k, v in row.items() if k != "json"}), flush=True)
        if c["res"] <= 256 and c["igl"] and not a.no_score:
            lat = c["lat"]
            off = ~conservative(c["V"], c["F"], lat)
            Q = lat.centres()
            wf = winding(c["V"], c["F"], Q)[0]
            w, _ = refine_near_half(c["V"], c["F"], Q, wf, a.margin)
            ref = (w >= 0.5).reshape(lat.dims)
            row["voxkit_wrong"] = int((c["solid"] != ref)[off].sum())
            row["libigl_wrong"] = int(((wf >= 0.5).reshape(lat.dims) != ref)[off].sum())
            row["scored"] = int(off.sum())
            print(json.dumps({k: row[k] for k in ("mesh", "damage", "res", "voxkit_wrong", "libigl_wrong", "scored")}),
                  flush=True)
        rows.append(row)
    print("\n| mesh | damage | -r | voxkit | peak | libigl `fast_winding_number` | peak | libigl / voxkit "
          "| wrong voxkit / libigl |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        lib = "–" if "libigl_ms" not in r else (("est. " if r["libigl_estimated"] else "") + fmt_ms(r["libigl_ms"]))
        print(f"| {r['mesh']} | {r['damage']} | {r['res']} | {fmt_ms(r['voxkit_ms'])} | {r['voxkit_mib']:.0f} MiB "
              f"| {lib} | {r.get('libigl_mib', 0):.0f} MiB | "
              + (f"{r['ratio']:.1f}×" if "ratio" in r else "–") + " | "
              + (f"{r['voxkit_wrong']} / {r['libigl_wrong']} of {r['scored']:,}" if "scored" in r else "not scored")
              + " |")


# ---------------------------------------------------------------- check mode


def check_winding(a):
    """Counts, slab by slab along x (about 8M centres each), the centres off
    the conservative set where voxkit's solid and w >= 1/2 disagree."""
    import igl

    V, F = load_obj(a.check_winding)
    with tempfile.TemporaryDirectory() as tmp:
        solid, lat, j = voxkit(a.voxkit, a.check_winding, a.res, "solid", Path(tmp) / "v.binvox")
    t = time.perf_counter()
    off = ~conservative(V, F, lat)
    n = dict(scored=0, disagreements=0, voxkit_only=0, winding_only=0, near_half=0, exact_queries=0)
    closest = np.inf  # min |w - 1/2| over the disagreements
    farthest = 0.0  # and max: how far from a tie the worst one is
    step = max(1, (1 << 23) // (lat.dims[1] * lat.dims[2]))
    for i0 in range(0, lat.dims[0], step):
        xs = slice(i0, i0 + step)
        m = off[xs]
        Q = lat.centres(xs)[m.ravel()]
        if a.exact:
            w, refined = igl.winding_number(V, F, Q), len(Q)
        else:
            w, refined = refine_near_half(V, F, Q, winding(V, F, Q)[0], a.margin)
        inside, vk = w >= 0.5, solid[xs][m]
        dis = vk != inside
        n["scored"] += len(Q)
        n["disagreements"] += int(dis.sum())
        n["voxkit_only"] += int((vk & ~inside).sum())
        n["winding_only"] += int((~vk & inside).sum())
        n["near_half"] += int((np.abs(w - 0.5) < a.margin).sum())
        n["exact_queries"] += refined
        if dis.any():
            closest = min(closest, float(np.abs(w[dis] - 0.5).min()))
            farthest = max(farthest, float(np.abs(w[dis] - 0.5).max()))
    r = dict(mesh=str(a.check_winding), res=a.res, dims=j["dims"], triangles=len(F),
             voxkit_voxelize_ms=j["voxelize_ms"], **n,
             min_abs_w_minus_half_at_disagreements=None if np.isinf(closest) else closest,
             max_abs_w_minus_half_at_disagreements=None if np.isinf(closest) else farthest,
             reference="exact" if a.exact else f"fast, exact within {a.margin} of 1/2",
             check_s=time.perf_counter() - t)
    print(json.dumps(r))
    return 1 if r["disagreements"] > a.allow else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", nargs="+", default=None,
                    help="names (spot fandisk bunny) or OBJ paths of closed meshes (default: all three; "
                    "speed mode: spot bunny)")
    ap.add_argument("--fractions", nargs="+", type=float, default=[0, 1, 5, 20, 40], help="percent of triangles deleted (0: the closed mesh)")
    ap.add_argument("-r", "--res", type=int, nargs="+", default=None, help="resolution(s) (holes mode: the first; default 128, speed mode 128 256)")
    ap.add_argument("--speed", action="store_true", help="speed mode (see above)")
    ap.add_argument("--rounds", type=int, default=3, help="speed mode: interleaved rounds")
    ap.add_argument("--no-score", action="store_true", help="speed mode: times only, no wrong-voxel count")
    ap.add_argument("--scanned-res", type=int, nargs="*", default=[512, 1024], help="speed mode: the bunny as scanned")
    ap.add_argument("--subdivide", type=int, default=0, help="speed mode: split every triangle of the closed "
                    "meshes 1-to-4 at its edge midpoints this many times first (denser meshes, same shape)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--reps", type=int, default=1, help="timed runs per tool (median)")
    ap.add_argument("--no-trimesh", action="store_true")
    ap.add_argument("--keep", help="write the closed and holed OBJ files here instead of a temporary folder")
    ap.add_argument("--voxkit", default=str(ROOT / "target" / "release" / "voxkit"))
    ap.add_argument("--baseline", metavar="BIN", help="speed mode: another voxkit binary timed in the same "
                    "interleaved rounds (baseline_ms, baseline_over_voxkit in each row's JSON)")
    ap.add_argument("--margin", type=float, default=0.05, help="|w - 1/2| below which w is near 1/2")
    ap.add_argument("--check-winding", metavar="MESH.obj", help="check mode (see above)")
    ap.add_argument("--exact", action="store_true", help="check mode: exact winding number everywhere")
    ap.add_argument("--allow", type=int, default=0, help="check mode: disagreements tolerated before exit 1")
    a = ap.parse_args()
    if not Path(a.voxkit).exists():
        raise SystemExit(f"{a.voxkit} missing: run `cargo build --release` first")
    if a.speed:
        a.meshes = a.meshes or ["spot", "bunny"]
        a.res = a.res or [128, 256]
        if a.fractions == [0, 1, 5, 20, 40]:
            a.fractions = [5, 20, 40]
        return speed(a)
    a.res = (a.res or [128])[0]
    a.meshes = a.meshes or list(MESHES)
    if a.check_winding:
        raise SystemExit(check_winding(a))
    rows = []
    if a.keep:
        Path(a.keep).mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.meshes:
            holes_mesh(name, a, a.keep or tmp, rows)
    holes_table(rows)


if __name__ == "__main__":
    main()
