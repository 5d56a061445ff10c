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

# The study's list as scripts/study.sh installs it: without the extra packages the test command
# adds (scripts/test.sh exports chromium and blender, which ctest passes on).
mapfile -t study < <(env -u ARENA_EXTRA_PACKAGES bash "$src/scripts/install_packages.sh" --study --list |
  grep -vxF -f <(tr ' ' '\n' <<< "${ARENA_STUDY_PACKAGES_OMIT:-}" | grep . || true) || true)
[ ${#study[@]} -gt 0 ] || { echo "FAIL: install_packages.sh --study --list printed no package"; exit 1; }
# The closure follows every alternative and every provider of a virtual package, so it may allow a
# package apt would not install: a generous bound, which catches a package nothing in the list
# pulls in.
apt-cache depends --recurse --no-recommends --no-suggests --no-conflicts --no-breaks --no-replaces \
  --no-enhances "${study[@]}" | grep -v '^ ' | sed 's/:.*//' > "$tmp/allowed"
dpkg-query -W -f='${Package} ${Priority}\n' | awk '$2 == "required" { print $1 }' >> "$tmp/allowed"
sort -u -o "$tmp/allowed" "$tmp/allowed"

# What the build read from outside the source and build trees (the build's own source tree is
# CMakeCache.txt's).
home=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt")
home=$(realpath "${home:-$src}")
objects=$(cd "$build" && ninja -t inputs arena 2> /dev/null | grep '\.o$' || true)
if [ -z "$objects" ]; then
  echo "FAIL: $build: Ninja names no object file of arena (is it built?)"
  exit 1
fi
(
  cd "$build"
  # shellcheck disable=SC2086
  ninja -t deps $objects | grep '^    /' || true
  ninja -t commands arena | tail -n 1 | tr ' ' '\n' | grep '^/' || true
  # Files the configure step found, and the configuration file of each CMake package it read.
  sed -n 's/^[A-Za-z0-9_]*:\(FILEPATH\|INTERNAL\)=\(\/.*\)$/\2/p' CMakeCache.txt
  for dir in $(sed -n 's/^[A-Za-z0-9_]*_DIR:PATH=\(\/.*\/cmake\/.*\)$/\1/p' CMakeCache.txt); do
    find "$dir" -maxdepth 1 -type f \( -name '*Config.cmake' -o -name '*-config.cmake' \)
  done
) | sed 's/^ *//' | sort -u > "$tmp/candidates"
# Each file under its own name (a package may own only the link: libfoo.so in libfoo-dev) and
# under the file it resolves to (libfoo.so.1.2 in libfoo1); the first is checked only where a
# package owns it (update-alternatives' links, /usr/bin/c++, belong to none).
: > "$tmp/links"
: > "$tmp/files"
while read -r f; do
  case $f in "$home"/* | "$build"/*) continue ;; esac
  [ -f "$f" ] || continue
  realpath -s "$f" >> "$tmp/links"
  realpath "$f" >> "$tmp/files"
done < "$tmp/candidates"
sort -u -o "$tmp/files" "$tmp/files"
sort -u "$tmp/links" | comm -23 - "$tmp/files" > "$tmp/links_only"
count=$(wc -l < "$tmp/files")
if [ "$count" -le 100 ]; then
  echo "FAIL: only $count files found outside the repository; the build's record looks empty"
  exit 1
fi

# Each file's owners, as "path<TAB>package package...". dpkg-query -S prints "pkg[:arch][, pkg2
# [:arch]]: path" and, for a diverted file, a "diversion by" line too. Debian 12 merges /lib into
# /usr/lib, and a package may have registered a file under either name: a /usr/... path nobody
# owns is asked again without /usr.
owners() {
  xargs -r -d '\n' dpkg-query -S 2> /dev/null < "$1" | grep -v -e '^diversion by' -e '^local diversion' |
    awk '{ i = index($0, ": /"); if (i == 0) next
           path = substr($0, i + 2); n = split(substr($0, 1, i - 1), p, ", ")
           for (k = 1; k <= n; ++k) { sub(/:.*/, "", p[k]); owned[path] = owned[path] " " p[k] } }
         END { for (f in owned) print f "\t" owned[f] }' || true
}
owners "$tmp/files" > "$tmp/owned"
cut -f1 "$tmp/owned" | sort -u | comm -23 "$tmp/files" - > "$tmp/unowned"
grep '^/usr/' "$tmp/unowned" | sed 's#^/usr/#/#' > "$tmp/unowned_short" || true
owners "$tmp/unowned_short" | sed 's#^#/usr#' >> "$tmp/owned"
cut -f1 "$tmp/owned" | sort -u | comm -23 "$tmp/files" - > "$tmp/orphans"
owners "$tmp/links_only" >> "$tmp/owned"

status=0
if [ -s "$tmp/orphans" ]; then
  echo "FAIL: files the build read that no Debian package owns (a fresh machine may not have them):"
  sed 's/^/  /' "$tmp/orphans"
  status=1
fi
# A file passes when any of its owners is allowed; otherwise its owners are named, once each.
awk -F '\t' 'NR == FNR { allowed[$1] = 1; next }
             { n = split($2, p, " "); ok = 0
               for (k = 1; k <= n; ++k) if (p[k] in allowed) ok = 1
               if (!ok) for (k = 1; k <= n; ++k) if (!(p[k] in shown)) { shown[p[k]] = 1
                 print "  " p[k] ", for example " $1 } }' "$tmp/allowed" "$tmp/owned" | sort > "$tmp/missing"
if [ -s "$tmp/missing" ]; then
  echo "FAIL: the build of arena read files of packages that install_packages.sh --study does not pull in:"
  cat "$tmp/missing"
  status=1
fi
packages=$(cut -f2 "$tmp/owned" | tr ' ' '\n' | grep . | sort -u | wc -l)
[ $status -eq 0 ] && echo "ok: $count files from $packages packages, all within the closure of the study's ${#study[@]} packages"
exit $status
