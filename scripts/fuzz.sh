#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (AddressSanitizer + UndefinedBehaviorSanitizer) in
# build-fuzz/ and runs each for a set time, then prints executions and crashes per target.
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]     SECONDS per target (default 30);
#                                             TARGETs: vdb tf cli script (default all four)
#
# The seeds in tests/fuzz/corpus/<target>/ are copied into build-fuzz/fuzz/<target>/corpus,
# which collects what the fuzzer finds from run to run; the seed directory is not modified.
# Reports and inputs that crash land in build-fuzz/fuzz/<target>/ (crash-*, leak-*, oom-*,
# timeout-*); replay one with  build-fuzz/tests/fuzz/fuzz_<target> FILE.
# Without LEAP_FUZZ_FORK a target stops at its first crash; LEAP_FUZZ_FORK=1 keeps fuzzing
# (libFuzzer's fork mode) and counts every crash, OOM and timeout.
# Environment: LEAP_FUZZ_BUILD_DIR (default build-fuzz), LEAP_FUZZ_JOBS (build jobs, default 2).
# Exit status: 0 when no target crashed, 1 otherwise.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${LEAP_FUZZ_BUILD_DIR:-$root/build-fuzz}"
jobs="${LEAP_FUZZ_JOBS:-2}"
seconds="${1:-30}"
[ $# -gt 0 ] && shift
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(vdb tf cli script)
case "$seconds" in ''|*[!0-9]*) echo "fuzz.sh: SECONDS must be a whole number, got '$seconds'" >&2; exit 2 ;; esac
for t in "${targets[@]}"; do
  case "$t" in vdb|tf|cli|script) ;; *) echo "fuzz.sh: unknown target '$t' (vdb, tf, cli, script)" >&2; exit 2 ;; esac
done

cmake -S "$root" -B "$build" -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLEAP_FUZZ=ON >/dev/null
cmake --build "$build" -j"$jobs" --target "${targets[@]/#/fuzz_}"

# The targets write each input to a temporary file: keep those in memory when possible.
scratch="$(mktemp -d "$( [ -d /dev/shm ] && [ -w /dev/shm ] && echo /dev/shm || echo "${TMPDIR:-/tmp}")/leap-fuzz.XXXXXX")"
trap 'rm -rf "$scratch"' EXIT

declare -A summary
status=0
for t in "${targets[@]}"; do
  dir="$build/fuzz/$t"
  mkdir -p "$dir/corpus"
  cp -n "$root/tests/fuzz/corpus/$t/"* "$dir/corpus/" 2>/dev/null || true
  before="$(find "$dir" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'oom-*' -o -name 'timeout-*' \) | wc -l)"
  args=(-max_total_time="$seconds" -print_final_stats=1 -close_fd_mask=3 -timeout=20
        -rss_limit_mb=4096 -malloc_limit_mb=4096 -artifact_prefix="$dir/")
  [ -f "$root/tests/fuzz/corpus/$t.dict" ] && args+=(-dict="$root/tests/fuzz/corpus/$t.dict")
  [ "${LEAP_FUZZ_FORK:-0}" != "0" ] && args+=(-fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1)
  log="$dir/last-run.log"
  echo "fuzz.sh: fuzz_$t for ${seconds}s (log: $log)"
  set +e
  TMPDIR="$scratch" LSAN_OPTIONS="suppressions=$root/tests/fuzz/lsan.supp" \
    UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
    timeout -k 10 $((seconds + 120)) "$build/tests/fuzz/fuzz_$t" "${args[@]}" "$dir/corpus" >"$log" 2>&1
  rc=$?
  set -e
  execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)"
  if [ -z "$execs" ]; then # fork mode: the last status line "#N: cov: ..."
    execs="$(sed -n 's/^#\([0-9][0-9]*\): cov:.*/\1/p' "$log" | tail -1)"
  fi
  after="$(find "$dir" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'oom-*' -o -name 'timeout-*' \) | wc -l)"
  crashes=$((after - before))
  kinds="$(grep -o 'ERROR: [A-Za-z]*Sanitizer: [a-z-]*\|ERROR: libFuzzer: [a-z-]*' "$log" | sort | uniq -c | sed 's/^ *//' | paste -sd';' - || true)"
  summary[$t]="executions ${execs:-?}, crashes $crashes${kinds:+ ($kinds)}"
  if [ "$crashes" -gt 0 ]; then
    status=1
    summary[$t]+=", inputs in $dir/"
  elif [ "$rc" -ne 0 ]; then
    status=1
    summary[$t]+=", but the run failed (exit $rc, see $log)"
  fi
done

echo
echo "fuzz.sh: ${seconds}s per target"
for t in "${targets[@]}"; do printf '  fuzz_%-4s %s\n' "$t" "${summary[$t]}"; done
exit $status
