#!/usr/bin/env bash
# The study installs only `scripts/install_packages.sh --study`'s packages (scripts/study.sh), the
# tests all of them, so a build that needs one of the tests' packages would pass CI and fail on a
# fresh machine's study. This checks the study's set against what the build of `arena` in BUILD_DIR
# read from outside the repository: every header its objects include (Ninja's record), every file
# its link line names, and every file and CMake package the configure step found (CMakeCache.txt)
# must belong to a package that the study's packages pull in (apt-cache's dependency closure) or
# to the base system (priority "required"). Exit 77 (skipped) off Debian or without a Ninja build.
# ARENA_STUDY_PACKAGES_OMIT drops packages from the study's list (the suite's check that a missing
# package is caught: tests/CMakeLists.txt).
#   tests/study_packages.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
if [ $# -ne 2 ]; then
  echo "usage: $0 SOURCE_DIR BUILD_DIR" >&2
  exit 2
fi
src=$(realpath "$1") build=$(realpath "$2")
if ! command -v dpkg-query >/dev/null || ! command -v apt-cache >/dev/null; then
  echo "skipped: no dpkg-query or apt-cache (not a Debian system)"
  exit 77
fi
if [ ! -f "$build/build.ninja" ] || [ ! -f "$build/CMakeCache.txt" ]; then
  echo "skipped: $build is not a configured Ninja build"
  exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

mapfile -t study < <(bash "$src/scripts/install_packages.sh" --study --list |
  grep -vxF -f <(tr ' ' '\n' <<< "${ARENA_STUDY_PACKAGES_OMIT:-}" | grep .) || true)
[ ${#study[@]} -gt 0 ] || { echo "FAIL: install_packages.sh --study --list printed no package"; exit 1; }
apt-cache depends --recurse --no-recommends --no-suggests --no-conflicts --no-breaks --no-replaces \
  --no-enhances "${study[@]}" | grep -v '^ ' | sed 's/:.*//' > "$tmp/allowed"
dpkg-query -W -f='${Package} ${Priority}\n' | awk '$2 == "required" { print $1 }' >> "$tmp/allowed"
sort -u -o "$tmp/allowed" "$tmp/allowed"

# What the build read from outside the source and build trees (the build's own source tree is
# CMakeCache.txt's).
home=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt")
home=$(realpath "${home:-$src}")
(
  cd "$build"
  objects=$(ninja -t inputs arena | grep '\.o$')
  [ -n "$objects" ] || { echo "FAIL: ninja names no object of arena" >&2; exit 1; }
  # shellcheck disable=SC2086
  ninja -t deps $objects | grep '^    /'
  ninja -t commands arena | tail -n 1 | tr ' ' '\n' | grep '^/'
  # Files the configure step found, and the configuration file of each CMake package it read.
  sed -n 's/^[A-Za-z0-9_]*:\(FILEPATH\|INTERNAL\)=\(\/.*\)$/\2/p' CMakeCache.txt
  for dir in $(sed -n 's/^[A-Za-z0-9_]*_DIR:PATH=\(\/.*\/cmake\/.*\)$/\1/p' CMakeCache.txt); do
    find "$dir" -maxdepth 1 -type f \( -name '*Config.cmake' -o -name '*-config.cmake' \)
  done
) | sed 's/^ *//' | sort -u > "$tmp/candidates"
: > "$tmp/files"
while read -r f; do
  case $f in "$src"/* | "$home"/* | "$build"/*) continue ;; esac
  [ -f "$f" ] && realpath "$f" >> "$tmp/files"
done < "$tmp/candidates"
sort -u -o "$tmp/files" "$tmp/files"
count=$(wc -l < "$tmp/files")
[ "$count" -gt 100 ] || { echo "FAIL: only $count files found outside the repository; the build record looks empty"; exit 1; }

# Each file's package. Debian 12 merges /lib into /usr/lib, and a package may have registered a
# file under either name.
xargs -d '\n' dpkg-query -S < "$tmp/files" > "$tmp/owned" 2> /dev/null || true
sed 's/^[^:]*\(:[a-z0-9]*\)\?: //' "$tmp/owned" | sort -u > "$tmp/found"
comm -23 "$tmp/files" "$tmp/found" > "$tmp/unowned"
: > "$tmp/owned2"
if [ -s "$tmp/unowned" ]; then
  sed 's#^/usr/#/#' "$tmp/unowned" | xargs -d '\n' dpkg-query -S > "$tmp/owned2" 2> /dev/null || true
fi
sed 's/^[^:]*\(:[a-z0-9]*\)\?: //' "$tmp/owned2" | sed 's#^/#/usr/#' | sort -u > "$tmp/found2"
comm -23 "$tmp/unowned" "$tmp/found2" > "$tmp/orphans"

status=0
if [ -s "$tmp/orphans" ]; then
  echo "FAIL: files the build read that no Debian package owns (a fresh machine may not have them):"
  sed 's/^/  /' "$tmp/orphans"
  status=1
fi
cat "$tmp/owned" "$tmp/owned2" | sed 's/:.*//' | tr -d ' ' | tr ',' '\n' | sed 's/:.*//' | sort -u > "$tmp/packages"
missing=$(comm -23 "$tmp/packages" "$tmp/allowed")
if [ -n "$missing" ]; then
  echo "FAIL: the build of arena read files of packages that install_packages.sh --study does not pull in:"
  for p in $missing; do
    echo "  $p, for example $(grep -m1 -E "^([^:]*, )?$p(:[a-z0-9]+)?(,|:)" "$tmp/owned" "$tmp/owned2" -h | sed 's/^[^ ]* //')"
  done
  status=1
fi
[ $status -eq 0 ] && echo "ok: $count files from $(wc -l < "$tmp/packages") packages, all within the study's ${#study[@]} packages' closure"
exit $status
