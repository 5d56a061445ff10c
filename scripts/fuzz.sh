#!/usr/bin/env bash
# A parser under libFuzzer (+ASan/UBSan): installs what is missing (the project's packages, clang
# with its fuzzer runtime, ccache), builds build-fuzz/ with clang and fuzzes TARGET for SECONDS
# (default 600):
#   scene  the scene parser, seeded from scenes/*.json, with tests/fuzz/scene.dict;
#   asset  the asset importers (OBJ + MTL, glTF, .glb through assimp; mesh OBJ through
#          tinyobjloader), seeded from tests/fuzz/asset_seeds/ (tests/fuzz/asset_fuzz_target.hpp);
#   capture  the capture importer (capture.json, frame, reference, gradient and output EXRs, then
#          validation), seeded from a capture the fuzzer writes itself (capture_fuzz_target.hpp).
# The corpus grows in build-fuzz/corpus-TARGET (kept between runs); a crashing input is written to
# build-fuzz/artifacts/ and the script exits non-zero. Extra arguments go to libFuzzer (e.g.
# -runs=1000000).
#   bash scripts/fuzz.sh [scene|asset|capture] [SECONDS] [libFuzzer flags...]
set -euo pipefail
cd "$(dirname "$0")/.."
target=scene
case "${1:-}" in scene | asset | capture) target="$1"; shift ;; esac
seconds="${1:-600}"
shift || true
# Debian 12's clang is 14; its libFuzzer and sanitizer runtimes are in libclang-rt-14-dev.
bash scripts/install_packages.sh clang libclang-rt-14-dev ccache
# File by file, without unity batches: a fuzzer compiles its own instrumented copy of the files it
# fuzzes and takes the rest from the libraries, whose unity objects would bring those files again
# (every symbol defined twice at link).
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DARENA_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DARENA_UNITY_BUILD=OFF -DARENA_PCH=OFF -DCMAKE_CXX_COMPILER_LAUNCHER=ccache > /dev/null
nice -n 19 cmake --build build-fuzz -j2 --target "${target}_fuzzer"
mkdir -p "build-fuzz/corpus-$target" build-fuzz/artifacts build-fuzz/seeds-capture
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# Third-party leaks, each justified in the file (assimp's OBJ importer on malformed input).
export LSAN_OPTIONS="suppressions=$(pwd)/tests/sanitizer/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
if [ "$target" = scene ]; then
  flags=(-dict=tests/fuzz/scene.dict)
  seeds=scenes
elif [ "$target" = asset ]; then
  flags=()
  seeds=tests/fuzz/asset_seeds
else
  flags=()
  seeds=build-fuzz/seeds-capture  # one input per file kind, written by the fuzzer at start
  export ARENA_CAPTURE_SEEDS="$(pwd)/$seeds"
fi
# -timeout: a unit slower than 10 s is a finding (the parsers' work is bounded by their limits).
nice -n 19 "build-fuzz/tests/${target}_fuzzer" -max_total_time="$seconds" -timeout=10 \
  "${flags[@]}" -artifact_prefix=build-fuzz/artifacts/ -print_final_stats=1 \
  "$@" "build-fuzz/corpus-$target" "$seeds"
