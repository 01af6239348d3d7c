#!/usr/bin/env bash
# Runs one fuzz target with the project's libFuzzer flags (docs/fuzzing.md).
# usage: fuzz/run.sh TARGET [SECONDS=600] [MAX_LEN=65536] [extra libFuzzer flags...]
# Only the stable toolchain is installed: RUSTC_BOOTSTRAP=1 lets cargo-fuzz
# pass its -Z flags (sanitizer, coverage) to it.
set -euo pipefail
cd "$(dirname "$0")"
target=$1; secs=${2:-600}; max_len=${3:-65536}; shift $(( $# < 3 ? $# : 3 ))
mkdir -p "corpus/$target"
[ -n "$(ls -A "corpus/$target")" ] || python3 seeds/make_seeds.py
RUSTC_BOOTSTRAP=1 exec cargo fuzz run -O "$target" "corpus/$target" -- \
  -max_total_time="$secs" -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=10 \
  -max_len="$max_len" -print_final_stats=1 "$@"
