#!/usr/bin/env bash
# Installs the Debian 12 packages Denoise Arena needs (only those missing), then configures and
# builds it (Release) into build/. Safe to run repeatedly: a second run only rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(build-essential cmake libembree-dev libopenexr-dev libopencv-dev libbenchmark-dev libglm-dev
          nlohmann-json3-dev libtbb-dev libgtest-dev libcli11-dev libsqlite3-dev libtinyobjloader-dev
          openexr embree-tools ${ARENA_EXTRA_PACKAGES:-})
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

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
