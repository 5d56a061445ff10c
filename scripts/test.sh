#!/usr/bin/env bash
# The test command: install what is missing, build, run every test under ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
# The browser test (browser_report) needs Debian's Chromium; setup.sh installs it when missing.
export ARENA_EXTRA_PACKAGES="${ARENA_EXTRA_PACKAGES:-} chromium blender"
bash scripts/setup.sh
cd build
ctest --output-on-failure -j"$(nproc)" "$@"
