#!/usr/bin/env bash
# Installs the Debian 12 packages Denoise Arena needs (only those missing), then configures and
# builds it (Release) into build/. Safe to run repeatedly: a second run only rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

# Each phase's wall time goes to stderr at the end (the study's breakdown, docs/performance.md).
phase_start=$SECONDS
phases=""
phase() { phases="$phases $1 $((SECONDS - phase_start))s,"; phase_start=$SECONDS; }

# The study (ARENA_TARGETS=arena) installs only what it needs; everything else, the tests' too.
if [ "${ARENA_TARGETS:-all}" = arena ]; then
  bash scripts/install_packages.sh --study
else
  bash scripts/install_packages.sh
fi
phase packages

# The report's npm packages (Vega, Vega-Lite, vega-embed; playwright-core for the browser test),
# exactly as locked; again only when package-lock.json is newer than the installed tree.
if [ ! -d reports/node_modules ] || [ reports/package-lock.json -nt reports/node_modules ]; then
  echo "setup: npm ci in reports/"
  (cd reports && npm ci --no-audit --no-fund)
  touch reports/node_modules
fi
phase npm

# The furniture models the scenes name ("assets:sweethome3d/<model>/..."), extracted from the
# package's CC-0 archive into cache/assets/ (or $ARENA_ASSET_DIR); a no-op once they are there.
python3 scripts/extract_assets.py
phase assets

# Ninja: two cores stay busy across libraries (make builds a library only after the libraries it
# links are archived). A build/ configured for another generator by an earlier version of this
# script is reconfigured from scratch (its objects are rebuilt once).
# Options given to that configure by hand (-D...) are not carried over.
if [ -f build/CMakeCache.txt ] && ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' build/CMakeCache.txt; then
  old=$(sed -n 's/^CMAKE_GENERATOR:INTERNAL=//p' build/CMakeCache.txt)
  echo "setup: build/ was configured for '${old:-an unknown generator}'; reconfiguring it for Ninja from scratch"
  rm -rf build/CMakeCache.txt build/CMakeFiles build/Makefile build/cmake_install.cmake
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
phase configure
# ARENA_TARGETS narrows the build (the study needs only `arena`; the tests need everything).
cmake --build build -j"$(nproc)" --target ${ARENA_TARGETS:-all}
phase build
echo "setup:${phases%,}" >&2
