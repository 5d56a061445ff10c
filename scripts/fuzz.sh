#!/usr/bin/env bash
# The scene parser under libFuzzer (+ASan/UBSan): builds build-fuzz/ with clang and fuzzes for
# SECONDS (default 600), seeded from scenes/*.json, with tests/fuzz/scene.dict. The corpus grows
# in build-fuzz/corpus (kept between runs); a crashing input is written to build-fuzz/artifacts/
# and the script exits non-zero. Extra arguments go to libFuzzer (e.g. -runs=100000).
#   bash scripts/fuzz.sh [SECONDS] [libFuzzer flags...]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-600}"
shift || true
if [ ! -f build-fuzz/CMakeCache.txt ]; then
  CC=clang CXX=clang++ cmake -S . -B build-fuzz -DARENA_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_COMPILER_LAUNCHER=ccache
fi
nice -n 19 cmake --build build-fuzz -j2 --target scene_fuzzer
mkdir -p build-fuzz/corpus build-fuzz/artifacts
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# -timeout: a unit slower than 10 s is a finding (the parser's work is bounded by its limits).
nice -n 19 build-fuzz/tests/scene_fuzzer -max_total_time="$seconds" -timeout=10 \
  -dict=tests/fuzz/scene.dict -artifact_prefix=build-fuzz/artifacts/ -print_final_stats=1 \
  "$@" build-fuzz/corpus scenes
