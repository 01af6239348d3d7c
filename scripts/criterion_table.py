#!/usr/bin/env python3
"""Print criterion results (target/criterion) as a markdown table of element rates.

usage: scripts/criterion_table.py GROUP [GROUP...]
Rate = throughput elements / median time of the latest run.
"""
import json, os, sys

root = os.path.join(os.path.dirname(__file__), "..", "target", "criterion")
print("| group | benchmark | median time | rate (M elements/s) |")
print("|---|---|---|---|")
for group in sys.argv[1:]:
    gdir = os.path.join(root, group)
    if not os.path.isdir(gdir):
        continue
    for dirpath, dirnames, files in sorted(os.walk(gdir)):
        if os.path.basename(dirpath) != "new" or "estimates.json" not in files:
            continue
        est = json.load(open(os.path.join(dirpath, "estimates.json")))
        meta = json.load(open(os.path.join(dirpath, "benchmark.json")))
        t = est["median"]["point_estimate"]  # ns
        thr = meta.get("throughput") or {}
        n = thr.get("Elements") or thr.get("Bytes")
        name = meta.get("full_id", dirpath)
        bench = name.split("/", 1)[1] if "/" in name else name
        rate = f"{n / t * 1e3:.1f}" if n else "—"
        unit = "µs" if t < 1e6 else "ms"
        tv = t / 1e3 if t < 1e6 else t / 1e6
        print(f"| {group} | {bench} | {tv:.3g} {unit} | {rate} |")
