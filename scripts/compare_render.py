#!/usr/bin/env python3
"""Render the same inputs with `voxkit render` and with VTK (through pyvista, headless on the
CPU: ../shared/peers/render_vtk.py) in one run, and print one Markdown table.

usage (from the repository root; the venv comes from scripts/setup_render_peer.sh):

    bash scripts/setup_render_peer.sh
    ~/.cache/voxkit-peers/venv/bin/python scripts/compare_render.py \
        [--quick] [--rounds N] [--reps 5] [--size 1024x1024] [--work target/compare_render] \
        [--out-json FILE.jsonl] [--tools voxkit vtk embree] [--cases bunny256 bunny512 headsq blobs512] \
        [--projections perspective ortho] [--wait-quiet S] [--quiet-share 0.10] [--view iso] [--voxkit PATH]

What was measured with it, and against the README of ../shared/peers: docs/render-peer.md.

Inputs (prepared in --work, default target/compare_render/):
  bunny256, bunny512  data/meshes/obj/stanford-bunny.obj voxelized thin by
                      `voxkit voxelize -r RES --mode thin` (binvox, 0/1 voxels)
  headsq              the CT head data/volumes/headsq_quarter/headsq_quarter.nhdr
                      (64x64x93 int16; falls back to ../shared/data/volumes/...)
  shell512, shell512i16, shell512u8
                      512^3 blobs in a turbulent shell over low noise (scripts/make_volume.py),
                      float32 / int16 / uint8; iso at 0.6 / 16000 / 128
  blobs512            512^3 float32, sum of 12 Gaussian blobs (seeded numpy: centres uniform in
                      the middle 80% of the box, sigma uniform in [12, 40] voxels, amplitude in
                      [0.5, 1]); detached NRRD (.nhdr + little-endian .raw, x fastest, spacing 1)
--quick: bunny256 and headsq only, 1 VTK rep.

What runs, per case and round, alternately (voxkit then VTK, the other way round on even
rounds, so that a slow phase of the shared machine hits both tools):
  voxkit  target/release/voxkit render X -o OUT.png --size WxH --view iso --json
          --reps R (the median of R renders of the frame, as VTK's R timed frames);
          binary grids: --ray 6|26|adaptive|aw, each with and without --no-skip;
          volumes: --volume mip|composite|iso (--iso 1000 for the CT head, 0.3 for the blobs).
          Timing runs are separate from the `--measure` run (round 1 only) that counts the pixels
          whose first hit differs from the 6-ray image, so --measure's extra work is not timed.
  VTK     <venv>/bin/python render_vtk.py --volume X --mode surface|mip|composite --size WxH
          --reps R --msaa 0 --out OUT.png  (binary grids: surface; volumes: mip and composite)

  Embree  (--tools embree; bunny cases) <venv>/bin/python scripts/embree_rays.py MESH --camera JSON
          --size WxH --reps R: the original triangle mesh cast along the pixel rays of voxkit's own
          camera (`camera` in its --json), on one thread; a second table gives voxkit's adaptive
          frame × its threads against Embree's frame (per core).
--projections perspective ortho: every voxkit configuration (and Embree) also with --ortho; VTK's
script has no orthographic view, so those rows have no VTK column.

Reported per row: voxkit `render_ms` (median over rounds), for volumes the memory floor beside it
(`floor_ms`: one parallel pass reading every stored sample, timed by `voxkit render --reps` after
each of its frames, and the frame as a multiple of it: the figure that survives the machine's
drift), `differing_pixels`, VTK frame ms
(render + read-back, median of its R reps, then median over rounds), VTK set-up s (grid, plotter,
actor, camera and the first frame), the ratio VTK/voxkit, and each tool's peak RSS (measured by
/usr/bin/time around each process, see run(); render_vtk.py's own peak_rss_mib is in the JSON).
voxkit's load_ms is shown beside VTK's set-up. The machine is shared: every run records the share
of the CPUs other processes took while it ran (others_cpu_share), the medians use only the runs
below --quiet-share when a row has any (else all, marked *), and --wait-quiet S waits up to S
seconds before each timed run for an idle machine.

If `voxkit render` is not available (the subcommand errors), the VTK rows are still measured and
the voxkit columns say n/a; a single voxkit run that fails is n/a too, with its stderr in the JSON.
Writes every raw run as one JSON line to --out-json (default WORK/results.jsonl; the first line
describes the machine and versions) and the table to WORK/table.md as well as stdout.
Standard library + numpy only.
"""

import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
VOXKIT = ROOT / "target" / "release" / "voxkit"
SHARED = ROOT.parent / "shared"
DEFAULT_VENV = Path(os.environ.get("VOXKIT_PEER_VENV", Path.home() / ".cache" / "voxkit-peers" / "venv"))
RAYS = ["6", "26", "adaptive", "aw"]
VOLUME_MODES = ["mip", "composite", "iso"]
VTK_VOLUME_MODES = ["mip", "composite"]


# -- running a child and taking its own peak RSS ----------------------------------------------
#
# A child's ru_maxrss is not its own peak alone: subprocess starts children with vfork, and at exec
# Linux carries the parent's peak RSS into the child's maxrss (checked: /bin/true started from a
# Python that once held 500 MiB reports 525 MiB; RUSAGE_CHILDREN deltas cannot help either, it is
# a max over all children). So each child runs under GNU time (`/usr/bin/time -f %M`, Debian package
# `time`), whose plain fork starts the command from a ~1 MiB process: the figure is the command's
# own peak within ~1 MiB. Without /usr/bin/time we fork (preexec_fn) instead of vfork, which floors
# the figure at this script's current RSS (about 20-30 MiB with numpy); rss_method says which.

GNU_TIME = Path("/usr/bin/time")
CLK_TCK = os.sysconf("SC_CLK_TCK")


def cpu_busy_s():
    """Busy CPU seconds of the whole machine so far (all cores), from /proc/stat."""
    try:
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
    except OSError:
        return None
    # user nice system idle iowait irq softirq steal (guest time is already inside user)
    return (sum(v[:8]) - v[3] - v[4]) / CLK_TCK


def run(cmd, timeout=None, env=None, cwd=None):
    """Run cmd; return dict(rc, wall_s, maxrss_mib, rss_method, cmd, json[, error, stderr_tail])."""
    cmd = [str(c) for c in cmd]
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err, \
            tempfile.NamedTemporaryFile("r", suffix=".time") as tf:
        if GNU_TIME.exists():
            full, extra = [str(GNU_TIME), "-f", "%M", "-o", tf.name] + cmd, {}
        else:
            full, extra = cmd, dict(preexec_fn=lambda: None)  # plain fork, not vfork
        busy0 = cpu_busy_s()
        t0 = time.perf_counter()
        p = subprocess.Popen(full, stdout=out, stderr=err, env=env, cwd=cwd, start_new_session=True, **extra)
        deadline = None if timeout is None else t0 + timeout
        timed_out = False
        while True:  # os.wait4 rather than p.wait: it gives the child's rusage
            pid, status, ru = os.wait4(p.pid, os.WNOHANG if deadline else 0)
            if pid:
                break
            if time.perf_counter() > deadline:
                timed_out = True
                os.killpg(p.pid, 9)  # the command too, not only /usr/bin/time
                pid, status, ru = os.wait4(p.pid, 0)
                break
            time.sleep(0.01)
        wall = time.perf_counter() - t0
        busy1 = cpu_busy_s()
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        stdout = out.read().decode(errors="replace")
        stderr = err.read().decode(errors="replace")
        if GNU_TIME.exists():
            method, maxrss_kib = "gnu-time", None
            tail = tf.read().strip().splitlines()  # "Command exited with non-zero status N" may come first
            if tail and tail[-1].strip().isdigit():
                maxrss_kib = int(tail[-1])
        else:
            method, maxrss_kib = "fork-wait4", ru.ru_maxrss
    rc = p.returncode
    res = dict(rc=rc, wall_s=round(wall, 4), maxrss_mib=None if maxrss_kib is None else round(maxrss_kib / 1024, 1),
               rss_method=method, cpu_s=round(ru.ru_utime + ru.ru_stime, 3), cmd=cmd, json=None)
    if busy0 is not None and busy1 is not None:
        # CPU time that other processes took from the machine while this one ran, as a share of
        # all cores over the wall time: near 0 on a quiet machine (a 2-thread renderer slows ~2x
        # when someone else's compile takes one of 2 cores)
        others = max(0.0, busy1 - busy0 - res["cpu_s"])
        res["others_cpu_share"] = round(others / (wall * (os.cpu_count() or 1)), 3)
    if timed_out:
        res["error"] = f"timed out after {timeout} s"
    for line in reversed(stdout.splitlines()):
        if line.startswith("{"):
            try:
                res["json"] = json.loads(line)
            except json.JSONDecodeError:
                pass
            break
    if rc != 0 or res["json"] is None:
        errs = stderr.strip().splitlines()
        first = next((l for l in errs if l.lower().startswith("error")), errs[-1] if errs else None)
        res.setdefault("error", (first or f"exit {rc}, no JSON line")[:500])
        res["stderr_tail"] = stderr[-2000:]
    return res


def wait_quiet(max_wait_s, share=0.10, sample_s=1.0):
    """Wait (at most max_wait_s) until other processes use less than `share` of all cores over a
    sample_s window. Returns (seconds waited, last measured share)."""
    t0 = time.perf_counter()
    last = None
    while True:
        b0 = cpu_busy_s()
        if b0 is None:
            return 0.0, None
        time.sleep(sample_s)
        last = (cpu_busy_s() - b0) / (sample_s * (os.cpu_count() or 1))
        if last < share or time.perf_counter() - t0 >= max_wait_s:
            return round(time.perf_counter() - t0, 1), round(last, 3)


def median(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


# -- inputs --------------------------------------------------------------------------------------

def ensure_voxkit():
    if VOXKIT.exists():
        return
    if VOXKIT != ROOT / "target" / "release" / "voxkit":
        raise SystemExit(f"{VOXKIT} missing")
    print(f"[compare_render] {VOXKIT} missing: cargo build --release", file=sys.stderr, flush=True)
    env = {k: v for k, v in os.environ.items() if k != "CARGO_TARGET_DIR"}  # must land in ROOT/target
    subprocess.run(["cargo", "build", "--release"], cwd=ROOT, env=env, check=True)


def voxelize_bunny(res, work, log):
    out = work / f"bunny{res}_thin.binvox"
    r = run([VOXKIT, "voxelize", ROOT / "data/meshes/obj/stanford-bunny.obj", "-r", res, "-o", out,
             "--mode", "thin", "--force", "--json"], cwd=ROOT)
    log(dict(kind="prepare", case=f"bunny{res}", **r))
    if r["rc"] != 0:
        raise SystemExit(f"voxkit voxelize failed: {r.get('error')}")
    return out, (r["json"] or {}).get("voxels")


def ct_head():
    for p in (ROOT / "data/volumes/headsq_quarter/headsq_quarter.nhdr",
              SHARED / "data/volumes/headsq_quarter/headsq_quarter.nhdr"):
        if p.exists():
            return p
    raise SystemExit("CT head headsq_quarter.nhdr not found in data/volumes nor ../shared/data/volumes")


def gaussian_blobs(work, n=512, count=12, seed=42):
    """Sum of `count` Gaussian blobs on an n^3 float32 grid, written as a detached NRRD.
    Each blob is separable (gz ⊗ gy ⊗ gx), so it is added slab by slab without n^3 temporaries."""
    stem = f"blobs{n}_n{count}_seed{seed}"
    nhdr, raw = work / f"{stem}.nhdr", work / f"{stem}.raw"
    if nhdr.exists() and raw.exists() and raw.stat().st_size == n ** 3 * 4:
        return nhdr
    rng = np.random.default_rng(seed)
    centres = rng.uniform(0.1 * n, 0.9 * n, size=(count, 3))  # (x, y, z) in voxel units
    sigmas = rng.uniform(12.0, 40.0, size=count)
    amps = rng.uniform(0.5, 1.0, size=count)
    idx = np.arange(n, dtype=np.float64)
    vol = np.zeros((n, n, n), dtype=np.float32)  # indexed [z, y, x]: x fastest in memory
    slab = 32
    for (cx, cy, cz), s, a in zip(centres, sigmas, amps):
        g = [np.exp(-0.5 * ((idx - c) / s) ** 2) for c in (cx, cy, cz)]
        gyx = (a * np.outer(g[1], g[0])).astype(np.float32)
        for z0 in range(0, n, slab):
            gz = g[2][z0:z0 + slab].astype(np.float32)
            if gz.max() < 1e-12:
                continue
            vol[z0:z0 + slab] += gz[:, None, None] * gyx[None, :, :]
    tmp = raw.with_suffix(".raw.tmp")
    vol.astype("<f4", copy=False).tofile(tmp)
    os.replace(tmp, raw)
    hdr = (
        "NRRD0004\n"
        f"# {count} Gaussian blobs, seed {seed}: centres uniform in the middle 80% of the box,\n"
        "# sigma uniform in [12, 40] voxels, amplitude uniform in [0.5, 1.0], summed\n"
        "type: float\n"
        "dimension: 3\n"
        f"sizes: {n} {n} {n}\n"
        "spacings: 1 1 1\n"
        "endian: little\n"
        "encoding: raw\n"
        f"data file: {raw.name}\n"
    )
    tmp = nhdr.with_suffix(".nhdr.tmp")
    tmp.write_text(hdr)
    os.replace(tmp, nhdr)
    return nhdr


# -- the two tools -------------------------------------------------------------------------------

def voxkit_available():
    if not VOXKIT.exists():
        return False, f"{VOXKIT} missing"
    r = run([VOXKIT, "render", "--help"])
    if r["rc"] != 0:
        return False, r.get("error", f"exit {r['rc']}")
    return True, ""


def voxkit_configs(case, projections=("perspective",), methods=("rays",)):
    out = []
    for proj in projections:
        ortho = proj == "ortho"
        tag, extra = (" (ortho)", ["--ortho"]) if ortho else ("", [])
        if case["binary"]:
            out += [dict(mode=f"ray {ray}{tag}", skip=skip, ortho=ortho,
                         args=["--ray", ray] + ([] if skip else ["--no-skip"]) + extra)
                    for ray in RAYS for skip in (True, False)]
        else:
            for m in VOLUME_MODES:
                args = ["--volume", m] + (["--iso", repr(case["iso"])] if m == "iso" else []) + extra
                out.append(dict(mode=f"{m}{tag}", peer=m, skip=True, ortho=ortho, args=args))
            # Shear-warp (object order, approximate: its difference from the 6-ray image is reported).
            if "shear-warp" in methods:
                for m in ("mip", "composite"):
                    out.append(dict(mode=f"{m} shear-warp{tag}", peer=m, skip=True, ortho=ortho,
                                    args=["--volume", m, "--method", "shear-warp"] + extra))
    return out


def vtk_modes(case):
    return ["surface"] if case["binary"] else VTK_VOLUME_MODES


def main():
    global VOXKIT
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="bunny256 and the CT head only, 1 VTK rep")
    ap.add_argument("--rounds", type=int, default=1, help="interleaved rounds (medians over them)")
    ap.add_argument("--reps", type=int, default=None, help="VTK timed frames per process (default 5, --quick 1)")
    ap.add_argument("--size", default="1024x1024")
    ap.add_argument("--view", default="iso", help="voxkit --view ('' to pass none); VTK uses camera_position='iso'")
    ap.add_argument("--work", default=str(ROOT / "target" / "compare_render"))
    ap.add_argument("--out-json", default=None, help="JSON lines of every raw run (default WORK/results.jsonl)")
    ap.add_argument("--tools", nargs="+", default=["voxkit", "vtk"], choices=["voxkit", "vtk", "embree"],
                    help="embree: the bunny's original mesh cast along voxkit's own pixel rays "
                         "(scripts/embree_rays.py, one thread; needs `pip install embreex` in the peer venv)")
    ap.add_argument("--projections", nargs="+", default=["perspective"], choices=["perspective", "ortho"],
                    help="voxkit and Embree views (VTK's script has no orthographic view: n/a there)")
    ap.add_argument("--methods", nargs="+", default=["rays", "shear-warp"], choices=["rays", "shear-warp"],
                    help="volume methods: exact rays (always) and shear-warp (with its difference from the 6-ray image)")
    ap.add_argument("--cases", nargs="+", default=None, help="subset of bunny256 bunny512 headsq blobs512")
    ap.add_argument("--python", default=None, help="interpreter for render_vtk.py (default: the peer venv's)")
    ap.add_argument("--peer", default=str(SHARED / "peers" / "render_vtk.py"))
    ap.add_argument("--seed", type=int, default=42, help="seed of the Gaussian blobs")
    ap.add_argument("--ct-iso", type=float, default=1000.0)
    ap.add_argument("--blob-iso", type=float, default=0.3)
    ap.add_argument("--voxkit", default=str(VOXKIT), help="voxkit binary (default target/release/voxkit, built if missing)")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per process")
    ap.add_argument("--quiet-share", type=float, default=0.10,
                    help="a timed run is 'quiet' when other processes took less than this share of all cores "
                         "during it; the table uses the quiet runs of a row when it has any (else all, marked *)")
    ap.add_argument("--wait-quiet", type=float, default=0.0, metavar="S",
                    help="before each timed run, wait up to S seconds for the machine to be quiet (default 0: don't)")
    a = ap.parse_args()
    VOXKIT = Path(a.voxkit)
    if a.rounds < 1:
        ap.error("--rounds must be >= 1")
    reps = a.reps or (1 if a.quick else 5)

    work = Path(a.work)
    (work / "png").mkdir(parents=True, exist_ok=True)
    out_json = Path(a.out_json) if a.out_json else work / "results.jsonl"
    out_json.parent.mkdir(parents=True, exist_ok=True)
    jf = open(out_json, "w")

    def log(rec):
        jf.write(json.dumps(rec) + "\n")
        jf.flush()

    def say(msg):
        print(f"[compare_render] {msg}", file=sys.stderr, flush=True)

    py = a.python or str(DEFAULT_VENV / "bin" / "python")
    if {"vtk", "embree"} & set(a.tools) and not Path(py).exists():
        raise SystemExit(f"{py} missing: run `bash scripts/setup_render_peer.sh` first")

    ensure_voxkit()
    have_vk, why = voxkit_available() if "voxkit" in a.tools else (False, "not asked (--tools)")
    if not have_vk:
        say(f"voxkit render not available ({why}): voxkit columns will be n/a")

    # -- machine and versions ----------------------------------------------------------------
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    mem_kib = next((int(l.split()[1]) for l in open("/proc/meminfo") if l.startswith("MemTotal")), 0)
    git = subprocess.run(["git", "-C", ROOT, "describe", "--always", "--dirty"], capture_output=True, text=True)
    log(dict(kind="meta", date=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
             nproc=os.cpu_count(), cpu=cpu, mem_gib=round(mem_kib / 2**20, 1), kernel=platform.release(),
             loadavg_start=os.getloadavg(), voxkit_git=git.stdout.strip(), voxkit_render=have_vk, voxkit_render_error=why or None,
             peer_python=py, size=a.size, reps=reps, rounds=a.rounds, view=a.view, argv=sys.argv[1:]))

    # -- inputs --------------------------------------------------------------------------------
    names = a.cases or (["bunny256", "headsq"] if a.quick else ["bunny256", "bunny512", "headsq", "blobs512"])
    cases = []
    for name in names:
        if name.startswith("bunny"):
            res = int(name[5:])
            path, voxels = voxelize_bunny(res, work, log)
            cases.append(dict(name=name, label=f"bunny thin {res}³ ({voxels:,} voxels)" if voxels else f"bunny thin {res}³",
                              path=path, binary=True, mesh=ROOT / "data/meshes/obj/stanford-bunny.obj"))
        elif name == "headsq":
            cases.append(dict(name=name, label="CT head 64×64×93 int16", path=ct_head(), binary=False, iso=a.ct_iso))
        elif name.startswith("blobs"):
            n = int(name[5:])
            say(f"the {n}³ Gaussian blobs: {work} (written once, then reused)")
            path = gaussian_blobs(work, n=n, seed=a.seed)
            cases.append(dict(name=name, label=f"12 Gaussian blobs {n}³ float32", path=path, binary=False, iso=a.blob_iso))
        elif name.startswith("shell"):
            # shell512 (float32), shell512i16, shell512u8: scripts/make_volume.py, written once.
            spec = name[5:]
            digits = "".join(ch for ch in spec.split("i")[0].split("u")[0] if ch.isdigit())
            n = int(digits or 512)
            dtype = "int16" if spec.endswith("i16") else "uint8" if spec.endswith("u8") else "float32"
            path = work / f"shell{n}_{dtype}.nhdr"
            if not path.exists():
                say(f"the {n}³ {dtype} blobs in a turbulent shell: {path} (written once, then reused)")
                subprocess.run([sys.executable, ROOT / "scripts/make_volume.py", path, "--n", str(n), "--dtype", dtype],
                               check=True)
            iso = {"float32": 0.6, "int16": 16000.0, "uint8": 128.0}[dtype]
            cases.append(dict(name=name, label=f"blobs in a turbulent shell {n}³ {dtype}", path=path, binary=False, iso=iso))
        else:
            ap.error(f"unknown case {name}")

    # -- interleaved rounds ------------------------------------------------------------------
    vk = {}   # (case, mode, skip) -> list of runs
    vt = {}   # (case, mode) -> list of runs
    measured = {}  # (case, mode, skip) -> differing_pixels

    def run_voxkit(case, rnd):
        for c in voxkit_configs(case, a.projections, a.methods):
            key = (case["name"], c["mode"], c["skip"])
            png = work / "png" / f"{case['name']}_voxkit_{c['mode'].replace(' ', '')}{'' if c['skip'] else '_noskip'}.png"
            base = [VOXKIT, "render", case["path"], "-o", png, "--size", a.size, "--json", "--force"] + c["args"]
            if a.view:
                base += ["--view", a.view]
            if rnd == 1:
                m = run(base + ["--measure"], timeout=a.timeout, cwd=ROOT)
                log(dict(kind="run", tool="voxkit", purpose="measure", case=case["name"], mode=c["mode"],
                         skip=c["skip"], round=rnd, **m))
                if m["json"] is not None:
                    d = m["json"].get("difference")
                    measured[key] = (m["json"].get("differing_pixels") if d is None else
                                     f"mean {d['mean_levels']:.2f}, p99 {d['p99_levels']}, max {d['max_levels']} levels")
            waited = wait_quiet(a.wait_quiet, a.quiet_share) if a.wait_quiet > 0 else (0.0, None)
            # Warm frames, as VTK's: the median of `reps` renders in one process.
            r = run(base + ["--reps", str(reps)], timeout=a.timeout, cwd=ROOT)
            r["waited_quiet_s"], r["share_before"] = waited
            log(dict(kind="run", tool="voxkit", purpose="time", case=case["name"], mode=c["mode"],
                     skip=c["skip"], round=rnd, **r))
            vk.setdefault(key, []).append(r)
            if r["json"] is None:
                say(f"voxkit {case['name']} {c['mode']} skip={c['skip']}: {r.get('error')}")

    def run_vtk(case, rnd):
        for mode in vtk_modes(case):
            png = work / "png" / f"{case['name']}_vtk_{mode}.png"
            waited = wait_quiet(a.wait_quiet, a.quiet_share) if a.wait_quiet > 0 else (0.0, None)
            r = run([py, a.peer, "--volume", case["path"], "--mode", mode, "--size", a.size, "--reps", reps,
                     "--msaa", "0", "--out", png, "--label", case["name"]], timeout=a.timeout, cwd=ROOT)
            r["waited_quiet_s"], r["share_before"] = waited
            log(dict(kind="run", tool="vtk", case=case["name"], mode=mode, round=rnd, **r))
            vt.setdefault((case["name"], mode), []).append(r)
            j = r["json"]
            if j is None:
                say(f"VTK {case['name']} {mode}: {r.get('error')}")
            else:
                say(f"VTK {case['name']} {mode} round {rnd}: {j['frame_ms_median']} ms/frame, set-up {j['setup_s']} s, "
                    f"{r['maxrss_mib']} MiB, others took {100 * (r.get('others_cpu_share') or 0):.0f}% of the CPUs")

    em = {}  # (case, projection) -> list of Embree runs

    def run_embree(case, rnd):
        """The case's original mesh cast by Embree along the rays of voxkit's own camera (from the
        JSON of its adaptive timing run this round, or of a run made for it)."""
        if not case.get("mesh"):
            return
        for proj in a.projections:
            tag = " (ortho)" if proj == "ortho" else ""
            runs = vk.get((case["name"], f"ray adaptive{tag}", True)) or []
            cam = next((r["json"].get("camera") for r in reversed(runs) if r["json"]), None)
            if cam is None:
                png = work / "png" / f"{case['name']}_camera.png"
                c = run([VOXKIT, "render", case["path"], "-o", png, "--size", a.size, "--json", "--force"]
                        + (["--ortho"] if proj == "ortho" else []) + (["--view", a.view] if a.view else []),
                        timeout=a.timeout, cwd=ROOT)
                cam = (c["json"] or {}).get("camera")
            if cam is None:
                say(f"Embree {case['name']} {proj}: no camera from voxkit")
                continue
            waited = wait_quiet(a.wait_quiet, a.quiet_share) if a.wait_quiet > 0 else (0.0, None)
            r = run([py, ROOT / "scripts/embree_rays.py", case["mesh"], "--camera", json.dumps(cam),
                     "--size", a.size, "--reps", reps], timeout=a.timeout, cwd=ROOT)
            r["waited_quiet_s"], r["share_before"] = waited
            log(dict(kind="run", tool="embree", case=case["name"], projection=proj, round=rnd, **r))
            em.setdefault((case["name"], proj), []).append(r)
            j = r["json"]
            if j is None:
                say(f"Embree {case['name']} {proj}: {r.get('error')}")
            else:
                say(f"Embree {case['name']} {proj} round {rnd}: {j['frame_ms_median']:.1f} ms/frame (1 thread), "
                    f"hits {100 * j['hit_fraction']:.1f}%")

    for rnd in range(1, a.rounds + 1):
        for case in cases:
            order = [run_voxkit, run_vtk] if rnd % 2 == 1 else [run_vtk, run_voxkit]
            for f in order:
                if f is run_voxkit and not have_vk:
                    continue
                if f is run_vtk and "vtk" not in a.tools:
                    continue
                f(case, rnd)
            if "embree" in a.tools:
                run_embree(case, rnd)

    # -- table ---------------------------------------------------------------------------------
    def quiet(runs):
        """The runs during which other processes took < --quiet-share of the CPUs, if any."""
        q = [r for r in runs if (r.get("others_cpu_share") or 0.0) < a.quiet_share]
        return (q, False) if q else (runs, True)

    def vtk_summary(case, mode):
        runs = [r for r in vt.get((case["name"], mode), []) if r["json"] is not None]
        if not runs:
            return None
        n_all = len(runs)
        runs, disturbed = quiet(runs)
        return dict(n=len(runs), n_all=n_all, disturbed=disturbed,ms=median(r["json"]["frame_ms_median"] for r in runs),
                    ms_lo=min(r["json"]["frame_ms_median"] for r in runs),
                    ms_hi=max(r["json"]["frame_ms_median"] for r in runs),
                    setup_s=median(r["json"]["setup_s"] for r in runs),
                    rss=median(r["maxrss_mib"] for r in runs),
                    mapper=runs[-1]["json"].get("mapper"), nonbg=runs[-1]["json"].get("nonbg_frac"),
                    cells=runs[-1]["json"].get("cells"))

    def vk_summary(case, c):
        key = (case["name"], c["mode"], c["skip"])
        runs = [r for r in vk.get(key, []) if r["json"] is not None]
        if not runs:
            return None
        n_all = len(runs)
        runs, disturbed = quiet(runs)
        get = lambda k: median(r["json"].get(k) for r in runs)
        return dict(n=len(runs), n_all=n_all, disturbed=disturbed, ms=get("render_ms"), load_ms=get("load_ms"), rss=median(r["maxrss_mib"] for r in runs),
                    differing=measured.get(key), rays=runs[-1]["json"].get("rays"),
                    voxels_visited=runs[-1]["json"].get("voxels_visited"),
                    bricks_skipped=runs[-1]["json"].get("bricks_skipped"),
                    memory_bytes=runs[-1]["json"].get("memory_bytes"),
                    floor_ms=get("floor_ms") if all("floor_ms" in r["json"] for r in runs) else None,
                    over_floor=get("frame_over_floor") if all("frame_over_floor" in r["json"] for r in runs)
                    else None)

    rows = []
    for case in cases:
        vtk_of = {m: vtk_summary(case, m) for m in vtk_modes(case)}
        if have_vk:
            for c in voxkit_configs(case, a.projections, a.methods):
                v = vk_summary(case, c)
                peer_mode = "surface" if case["binary"] else c["peer"]
                rows.append(dict(case=case["name"], input=case["label"],
                                 mode=f"surface / {c['mode']}" if case["binary"] else c["mode"],
                                 skip="yes" if c["skip"] else "no", voxkit=v,
                                 vtk=None if c["ortho"] else vtk_of.get(peer_mode)))
        else:
            for m, s in vtk_of.items():
                rows.append(dict(case=case["name"], input=case["label"], mode=m, skip="–", voxkit=None, vtk=s))

    na = "n/a"
    f1 = lambda x, fmt: na if x is None else format(x, fmt)
    lines = [
        f"Frame {a.size}, VTK: render_vtk.py --msaa 0, median of {reps} frames per process after one warm-up; "
        f"{a.rounds} interleaved round(s), medians over the quiet rounds (other processes took "
        f"< {100 * a.quiet_share:.0f}% of the CPUs), range in brackets; * = no quiet round, median over all.",
        "",
        "| input | mode/ray | skip | voxkit ms/frame | floor ms | frame / floor | differing px | VTK ms/frame "
        "| VTK set-up s | ratio VTK/voxkit | voxkit load ms | voxkit peak RSS MiB | VTK peak RSS MiB |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        v, t = r["voxkit"], r["vtk"]
        vms = v["ms"] if v else None
        tms = t["ms"] if t else None
        tms_s = na if tms is None else (f"{tms:.0f}" if t["ms_lo"] == t["ms_hi"] else f"{tms:.0f} ({t['ms_lo']:.0f}–{t['ms_hi']:.0f})")
        if t and t["disturbed"]:
            tms_s += "*"
        vms_s = f1(vms, ".1f") + ("*" if v and v["disturbed"] else "")
        if t is None and not r["mode"].startswith("surface") and r["mode"] not in VTK_VOLUME_MODES:
            tms_s = "–"  # no VTK counterpart (iso)
        if t is None and "(ortho)" in r["mode"]:
            tms_s = "–"  # render_vtk.py has no orthographic view
        ratio = f"{tms / vms:.2f}×" if (vms and tms) else na
        diff = v["differing"] if v and v["differing"] is not None else None
        lines.append(
            f"| {r['input']} | {r['mode']} | {r['skip']} | {vms_s} | "
            f"{'–' if not v or v['floor_ms'] is None else format(v['floor_ms'], '.1f')} | "
            f"{'–' if not v or v['over_floor'] is None else format(v['over_floor'], '.1f') + '×'} | "
            f"{na if diff is None else (diff if isinstance(diff, str) else f'{diff:,}')} | "
            f"{tms_s} | {f1(t['setup_s'] if t else None, '.2f')} | {ratio} | {f1(v['load_ms'] if v else None, '.1f')} | "
            f"{f1(v['rss'] if v else None, '.0f')} | {f1(t['rss'] if t else None, '.0f')} |")
        log(dict(kind="row", **{k: (str(x) if isinstance(x, Path) else x) for k, x in r.items()}))
    if em:
        threads = os.cpu_count()
        lines += ["", f"Embree (scripts/embree_rays.py: the original mesh, voxkit's own pixel rays, one thread) against "
                      f"voxkit's adaptive frame with skipping on {threads} threads; per core = voxkit ms × {threads} "
                      f"against Embree's single-thread ms (issue 21 asks ≤ 1×).", "",
                  "| input | projection | voxkit adaptive ms/frame | × threads | Embree ms/frame (1 thread) | Embree hits "
                  "| voxkit per core / Embree |",
                  "|---|---|---|---|---|---|---|"]
        for case in cases:
            for proj in a.projections:
                runs = [r for r in em.get((case["name"], proj), []) if r["json"] is not None]
                if not runs:
                    continue
                runs, disturbed = quiet(runs)
                ems = median(r["json"]["frame_ms_median"] for r in runs)
                tag = " (ortho)" if proj == "ortho" else ""
                v = vk_summary(case, dict(mode=f"ray adaptive{tag}", skip=True))
                vms = v["ms"] if v else None
                per_core = vms * threads if vms else None
                lines.append(f"| {case['label']} | {proj} | {f1(vms, '.1f')} | {f1(per_core, '.1f')} | "
                             f"{ems:.1f}{'*' if disturbed else ''} | {100 * runs[-1]['json']['hit_fraction']:.1f}% | "
                             f"{f'{per_core / ems:.2f}×' if per_core else na} |")
                log(dict(kind="embree_row", case=case["name"], projection=proj, voxkit_ms=vms, threads=threads,
                         embree_ms=ems))
    notes = []
    for tool, store in (("voxkit", vk), ("VTK", vt), ("Embree", em)):
        shares = [r.get("others_cpu_share") for runs in store.values() for r in runs]
        shares = [x for x in shares if x is not None]
        if shares:
            busy = sum(x > 0.10 for x in shares)
            notes.append(f"{tool} {len(shares)} runs: median {100 * statistics.median(shares):.0f}%, "
                         f"max {100 * max(shares):.0f}%, {busy} above 10%")
    if notes:
        lines += ["", "CPU time other processes took during the timed runs (share of all cores): " + "; ".join(notes) + "."]
    load_end = os.getloadavg()
    log(dict(kind="meta_end", date=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
             loadavg_end=load_end))
    lines[0] += f" Load average (1/5/15 min) at the end: {load_end[0]:.2f} / {load_end[1]:.2f} / {load_end[2]:.2f}."
    table = "\n".join(lines) + "\n"
    (work / "table.md").write_text(table)
    print(table, end="")
    say(f"raw results: {out_json}; table: {work / 'table.md'}")
    jf.close()


if __name__ == "__main__":
    main()
