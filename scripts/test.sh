#!/usr/bin/env bash
# Runs the whole test suite: the Release build, then the same suite under AddressSanitizer
# and UndefinedBehaviorSanitizer (LEAP_SANITIZE=0 skips the second pass). Builds what is
# missing first, so it works on a fresh clone once scripts/setup-deps.sh has run.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${LEAP_BUILD_DIR:-$root/build}"
jobs="$(nproc)"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j"$jobs"
ctest --test-dir "$build" --output-on-failure
if [ "${LEAP_SANITIZE:-1}" != "0" ]; then
  asan="$build-asan"
  cmake -S "$root" -B "$asan" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLEAP_SANITIZE=ON >/dev/null
  cmake --build "$asan" -j"$jobs"
  # Leak checking stays on for our code; the suppressions cover driver and TBB internals.
  ASAN_OPTIONS="detect_leaks=1" LSAN_OPTIONS="suppressions=$root/tests/lsan.supp" \
  UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
    ctest --test-dir "$asan" --output-on-failure
fi
