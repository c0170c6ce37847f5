#!/usr/bin/env bash
# One command from a fresh Debian 12 machine to a rendered image: installs the Debian
# packages, builds leap (Release) in build/, and renders a shipped volume.
# Idempotent: re-running only rebuilds what changed.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${LEAP_BUILD_DIR:-$root/build}"
bash "$root/scripts/setup-deps.sh"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j"$(nproc)"
"$build/leap" render "$root/volumes/tubes.vdb" -o "$build/tubes.png" --stats "$build/tubes.json"
echo "setup: rendered $build/tubes.png (stats in $build/tubes.json)"
