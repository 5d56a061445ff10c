#!/usr/bin/env bash
# The rank-agreement benchmark (docs/performance.md): the same scenes, every denoiser, at the quick
# preset's resolution and at a larger one (default 640x360, 2.5x the study's 256x144), then
# `arena bench rank-agreement`: per scene Kendall's tau between the two rankings and the resolved
# pairs that flip. Opt-in and slow: the larger run renders its own references (about 6x the pixels).
#   bash scripts/bench_rank_agreement.sh [SCENES] [WIDTHxHEIGHT] [more `arena run` options...]
set -euo pipefail
cd "$(dirname "$0")/.."
scenes="${1:-moving_object,thin_grid,cornell_static}"
large="${2:-640x360}"
shift 2 || shift $#
ARENA_TARGETS=arena bash scripts/setup.sh
# The bench replaces its JSON only where it wrote it (an older build's has no mark): said before
# the two runs, not after them.
json="runs/rank-agreement-$large.json"
if [ -e "$json" ] && ! grep -q '"arenaBench": "bench rank-agreement"' "$json"; then
  echo "$json exists and is not a file \`arena bench rank-agreement\` wrote; remove it to replace it" >&2
  exit 2
fi
build/arena run --scenes "$scenes" --denoisers all --flip none --keep-frames none --out runs/rank-quick "$@"
build/arena run --scenes "$scenes" --denoisers all --flip none --keep-frames none --resolution "$large" \
  --out "runs/rank-$large" "$@"
build/arena bench rank-agreement runs/rank-quick "runs/rank-$large" --json "$json"
