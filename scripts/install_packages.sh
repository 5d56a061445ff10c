#!/usr/bin/env bash
# Installs the Debian 12 packages Denoise Arena needs that are missing (apt-get, as root or through
# sudo), plus any given as arguments or in $ARENA_EXTRA_PACKAGES (scripts/fuzz.sh adds clang's).
#   bash scripts/install_packages.sh [package...]
set -euo pipefail
cd "$(dirname "$0")/.."

# python3-numpy: the Python example denoiser (examples/external/python_temporal), run by the tests.
# libassimp-dev: asset import (OBJ+MTL, glTF 2.0); assimp-testmodels: glTF files the tests load.
# ninja-build: the build runs each library's compiles as soon as their headers allow, where make
# waits for the libraries upstream to be archived (setup.sh).
# sweethome3d-furniture: the CC-0 furniture models of living_room and foliage_window (setup.sh
# extracts them into cache/assets/).
packages=(build-essential cmake ninja-build libembree-dev libopenexr-dev libopencv-dev libbenchmark-dev libglm-dev
          nlohmann-json3-dev libtbb-dev libgtest-dev libcli11-dev libsqlite3-dev libtinyobjloader-dev
          openexr embree-tools python3-numpy libassimp-dev assimp-testmodels sweethome3d-furniture
          ${ARENA_EXTRA_PACKAGES:-} "$@")
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
