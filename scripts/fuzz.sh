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
# Environment: LEAP_FUZZ_BUILD_DIR (default build-fuzz), LEAP_FUZZ_JOBS (build jobs, default 2),
# LEAP_FUZZ_PARALLEL (targets fuzzed at once, default one per processor).
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

# One target's run; its summary line goes to $dir/summary, and its exit status is 1 when it
# crashed or failed.
fuzz_target() {
  local t="$1" dir="$build/fuzz/$1"
  mkdir -p "$dir/corpus"
  rm -f "$dir/summary"
  cp -n "$root/tests/fuzz/corpus/$t/"* "$dir/corpus/" 2>/dev/null || true
  local before after execs kinds crashes rc line status=0
  before="$(find "$dir" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'oom-*' -o -name 'timeout-*' \) | wc -l)"
  local args=(-max_total_time="$seconds" -print_final_stats=1 -close_fd_mask=3 -timeout=20
              -rss_limit_mb=4096 -malloc_limit_mb=4096 -artifact_prefix="$dir/")
  [ -f "$root/tests/fuzz/corpus/$t.dict" ] && args+=(-dict="$root/tests/fuzz/corpus/$t.dict")
  [ "${LEAP_FUZZ_FORK:-0}" != "0" ] && args+=(-fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1)
  local log="$dir/last-run.log"
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
  line="executions ${execs:-?}, crashes $crashes${kinds:+ ($kinds)}"
  if [ "$crashes" -gt 0 ]; then
    status=1
    line+=", inputs in $dir/"
  elif [ "$rc" -ne 0 ]; then
    status=1
    line+=", but the run failed (exit $rc, see $log)"
  fi
  echo "$line" >"$dir/summary"
  return $status
}

# The targets run side by side, one per processor (LEAP_FUZZ_PARALLEL): each fuzzer is one
# thread, so every target still gets its whole time.
parallel="${LEAP_FUZZ_PARALLEL:-$(nproc)}"
case "$parallel" in ''|*[!0-9]*|0) echo "fuzz.sh: LEAP_FUZZ_PARALLEL must be a positive whole number, got '$parallel'" >&2; exit 2 ;; esac
status=0
running=()
for t in "${targets[@]}"; do
  fuzz_target "$t" &
  running+=($!)
  if [ ${#running[@]} -ge "$parallel" ]; then
    wait "${running[0]}" || status=1
    running=("${running[@]:1}")
  fi
done
for pid in "${running[@]}"; do wait "$pid" || status=1; done

echo
echo "fuzz.sh: ${seconds}s per target"
for t in "${targets[@]}"; do
  printf '  fuzz_%-4s %s\n' "$t" "$(cat "$build/fuzz/$t/summary" 2>/dev/null || echo 'no result: its run stopped early')"
done
exit $status
