#!/usr/bin/env bash
# Paired timing of two voxkit binaries on this noisy VM: the two alternate,
# each run a fresh process, so a slow minute hits both; prints the medians
# (and min) of voxelize_ms and its parts, peak RSS, load_ms and write_ms.
#
# usage: scripts/paired_voxelize.sh N BIN_A BIN_B [voxelize args...]
#   e.g. scripts/paired_voxelize.sh 30 before/voxkit target/release/voxkit -r 1024
# The mesh is the bunny unless MESH=path is set; output goes to a temporary
# binvox.
set -euo pipefail
N=$1; A=$2; B=$3; shift 3
MESH=${MESH:-data/meshes/obj/stanford-bunny.obj}
OUT=$(mktemp --suffix=.binvox)
trap 'rm -f "$OUT"' EXIT
for _ in $(seq "$N"); do
  for bin in "$A" "$B"; do
    "$bin" voxelize "$MESH" -o "$OUT" --force --json -q "$@" | python3 -c "
import json, sys
d = json.load(sys.stdin)
print('$bin', d['voxelize_ms'], d['kernel_ms'], d['quantize_ms'], d['peak_rss_mib'], d['load_ms'], d['write_ms'])"
  done
done | python3 -c "
import sys, statistics as st
rows = {}
for line in sys.stdin:
    b, *v = line.split()
    rows.setdefault(b, []).append([float(x) for x in v])
for b, r in rows.items():
    c = list(zip(*r))
    print(b, 'n=%d' % len(r), 'voxelize %.1f (min %.1f)' % (st.median(c[0]), min(c[0])),
          'kernel %.1f' % st.median(c[1]), 'quantize %.1f' % st.median(c[2]),
          'rss %.1f' % st.median(c[3]), 'load %.1f' % st.median(c[4]), 'write %.1f' % st.median(c[5]))
"
