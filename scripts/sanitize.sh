#!/usr/bin/env bash
# The whole test suite under AddressSanitizer + UBSan (+LeakSanitizer): configures and builds
# build-asan/ (RelWithDebInfo, -DARENA_SANITIZE=ON), then runs ctest there. Any sanitizer report
# aborts the process that made it, so the test that caused it fails. Third-party suppressions
# (each justified), when any are needed, are in tests/sanitizer/{lsan,asan,ubsan}.supp. Extra
# arguments go to ctest (e.g. -R Contract).
#   bash scripts/sanitize.sh [ctest args...]
set -euo pipefail
cd "$(dirname "$0")/.."
root="$(pwd)"
bash scripts/install_packages.sh ccache
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DARENA_SANITIZE=ON -DARENA_PCH=OFF -DARENA_UNITY_BUILD=OFF \
  -DCMAKE_CXX_COMPILER_LAUNCHER=ccache
nice -n 19 cmake --build build-asan -j"$(nproc)"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
for tool in lsan asan ubsan; do  # third-party suppressions, each justified in its file
  supp="$root/tests/sanitizer/$tool.supp"
  var="$(echo "$tool" | tr a-z A-Z)_OPTIONS"
  if [ -f "$supp" ]; then export "$var=suppressions=$supp${!var:+:${!var}}"; fi
done
cd build-asan
nice -n 19 ctest --output-on-failure -j"$(nproc)" "$@"
