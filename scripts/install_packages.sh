#!/usr/bin/env bash
# Installs the Debian 12 packages Denoise Arena needs that are missing (apt-get, as root or through
# sudo), plus any given as arguments or in $ARENA_EXTRA_PACKAGES (scripts/fuzz.sh adds clang's).
# --study: only what building `arena` and running the study need (scripts/study.sh); without it,
# the tests' and benches' packages too. --list: print the packages, one a line, and install nothing
# (tests/study_packages.sh checks that the study's are enough to build `arena`).
#   bash scripts/install_packages.sh [--study] [--list] [package...]
set -euo pipefail
cd "$(dirname "$0")/.."

study=false list=false
while [ $# -gt 0 ]; do
  case $1 in
    --study) study=true ;;
    --list) list=true ;;
    *) break ;;
  esac
  shift
done
# What the build of `arena` and the study need.
# libopencv-{core,imgproc,imgcodecs}-dev: the three OpenCV modules the code calls, not Debian's
# libopencv-dev, which pulls all of OpenCV's modules and their dependencies (CMakeLists.txt).
# libassimp-dev: asset import (OBJ+MTL, glTF 2.0). libgtest-dev: the configure step finds it.
# ninja-build: the build runs each library's compiles as soon as their headers allow, where make
# waits for the libraries upstream to be archived (setup.sh).
# python3, sweethome3d-furniture: the CC-0 furniture models of living_room and foliage_window
# (setup.sh extracts them into cache/assets/ with a Python script).
packages=(build-essential cmake ninja-build libembree-dev libopenexr-dev libopencv-core-dev
          libopencv-imgproc-dev libopencv-imgcodecs-dev libbenchmark-dev libglm-dev nlohmann-json3-dev
          libtbb-dev libgtest-dev libcli11-dev libsqlite3-dev libtinyobjloader-dev libassimp-dev
          python3 sweethome3d-furniture)
# What only the tests and benches use: OpenEXR's tools (a test reads a cached frame with
# exrheader), Embree's pathtracer tutorial (`arena bench tracer --embree`), NumPy for the Python
# example denoiser (examples/external/python_temporal), glTF files the asset tests load, and git (a
# test builds a repository to check the commit a run records; the build records none without it).
$study || packages+=(openexr embree-tools python3-numpy assimp-testmodels git)
packages+=(${ARENA_EXTRA_PACKAGES:-} "$@")
# `arena report` copies Vega's browser builds from reports/node_modules, installed with npm.
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)
if $list; then
  printf '%s\n' "${packages[@]}"
  exit 0
fi
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
