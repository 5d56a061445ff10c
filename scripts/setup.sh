#!/usr/bin/env bash
# Installs the Debian 12 packages Denoise Arena needs (only those missing), then configures and
# builds it (Release) into build/. Safe to run repeatedly: a second run only rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

# python3-numpy: the Python example denoiser (examples/external/python_temporal), run by the tests.
# libassimp-dev: asset import (OBJ+MTL, glTF 2.0); assimp-testmodels: glTF files the tests load.
packages=(build-essential cmake libembree-dev libopenexr-dev libopencv-dev libbenchmark-dev libglm-dev
          nlohmann-json3-dev libtbb-dev libgtest-dev libcli11-dev libsqlite3-dev libtinyobjloader-dev
          openexr embree-tools python3-numpy libassimp-dev assimp-testmodels
          ${ARENA_EXTRA_PACKAGES:-})
# `arena report` copies Vega's browser builds from reports/node_modules, installed with npm.
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# The report's npm packages (Vega, Vega-Lite, vega-embed; playwright-core for the browser test),
# exactly as locked; again only when package-lock.json is newer than the installed tree.
if [ ! -d reports/node_modules ] || [ reports/package-lock.json -nt reports/node_modules ]; then
  echo "setup: npm ci in reports/"
  (cd reports && npm ci --no-audit --no-fund)
  touch reports/node_modules
fi

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
# ARENA_TARGETS narrows the build (the study needs only `arena`; the tests need everything).
cmake --build build -j"$(nproc)" --target ${ARENA_TARGETS:-all}
