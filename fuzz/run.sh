#!/usr/bin/env bash
# Runs one fuzz target with the project's libFuzzer flags (docs/fuzzing.md).
# usage: fuzz/run.sh TARGET [SECONDS=600] [MAX_LEN=65536] [extra libFuzzer flags...]
# Builds the target first (set NO_BUILD=1 to run the binary already built),
# then runs the binary directly, so that editing the library while a fuzzer
# runs does not rebuild under it. Only the stable toolchain is installed:
# RUSTC_BOOTSTRAP=1 lets cargo-fuzz pass its -Z flags (AddressSanitizer,
# coverage) to it.
set -euo pipefail
cd "$(dirname "$0")"
target=$1; secs=${2:-600}; max_len=${3:-65536}; shift $(( $# < 3 ? $# : 3 ))
if [ -z "${NO_BUILD:-}" ]; then
  RUSTC_BOOTSTRAP=1 cargo fuzz build -O --codegen-units 4 "$target"
fi
mkdir -p "corpus/$target" "artifacts/$target"
[ -n "$(ls -A "corpus/$target")" ] || python3 seeds/make_seeds.py
dict=()
[ -f "dicts/$target.dict" ] && dict=(-dict="dicts/$target.dict")
# The renderer's rows run on rayon: one thread, so that two fuzzers share two cores.
export RAYON_NUM_THREADS=1
exec "target/x86_64-unknown-linux-gnu/release/$target" "corpus/$target" \
  -artifact_prefix="artifacts/$target/" -max_total_time="$secs" -rss_limit_mb=2048 \
  -malloc_limit_mb=1024 -timeout=10 -max_len="$max_len" -print_final_stats=1 \
  ${dict[@]+"${dict[@]}"} "$@"
