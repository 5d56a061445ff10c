#!/usr/bin/env bash
# The main job: install what is missing, build, then run the default study.
set -euo pipefail
cd "$(dirname "$0")/.."
ARENA_TARGETS=arena bash scripts/setup.sh
exec build/arena study "$@"
