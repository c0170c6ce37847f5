#!/usr/bin/env bash
# Builds leap_make_volumes (Release) if needed and writes the demo volumes into volumes/.
# usage: scripts/make-volumes.sh [BUILD_DIR]   (default: build, relative to the repository)
set -euo pipefail

case "${1:-}" in
  -h|--help)
    sed -n '2,3s/^# \{0,1\}//p' "$0"
    exit 0
    ;;
esac

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-build}"
case "$build" in
  /*) ;;
  *) build="$repo/$build" ;;
esac

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$repo" -B "$build" -DCMAKE_BUILD_TYPE=Release
fi
# cmake --build is a no-op when the tool is up to date.
cmake --build "$build" --target leap_make_volumes -j"$(nproc)"

"$build/leap_make_volumes" "$repo/volumes"
du -ch "$repo"/volumes/*.vdb | tail -n 1
