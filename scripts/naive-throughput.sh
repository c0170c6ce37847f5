#!/usr/bin/env bash
# Naive marching throughput on the shipped volumes: nanoseconds per sample (`leap render
# --stats` ns_per_sample = composite GPU time / samples taken), 512x512, as the minimum and
# median of REPEATS renders per case (run-to-run noise on a shared machine is ~10 %).
#
#   scripts/naive-throughput.sh [REPEATS]     default 6
#
# Environment: LEAP_EXE (default build/leap). Prints a Markdown table on stdout; progress on
# stderr. The cases: dense fog seen close up at three steps, the same with a TF whose opacity
# is corrected per sample, the default framing (shorter rays), and two sparse volumes.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
exe="${LEAP_EXE:-$root/build/leap}"
repeats="${1:-6}"
[[ "$repeats" =~ ^[1-9][0-9]*$ ]] || { echo "usage: naive-throughput.sh [REPEATS]  (REPEATS: a positive integer)" >&2; exit 2; }
[ -x "$exe" ] || { echo "naive-throughput.sh: $exe not found: build first (scripts/setup.sh)" >&2; exit 1; }

cases=(
  "sphere.vdb --step 0.1 --orbit 30,20,1.05"
  "sphere.vdb --step 0.25 --orbit 30,20,1.05"
  "sphere.vdb --step 0.5 --orbit 30,20,1.05"
  "sphere.vdb --step 0.1 --orbit 30,20,1.05 --tf grey"
  "sphere.vdb --step 0.1"
  "sphere.vdb --step 0.5"
  "blobs.vdb --step 0.5"
  "shell.vdb --step 0.1 --orbit 30,20,1.05"
)

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

echo "| case | samples/pixel | opacity correction | ns/sample min | ns/sample median |"
echo "| --- | ---: | --- | ---: | ---: |"
for c in "${cases[@]}"; do
  echo "naive-throughput.sh: $c" >&2
  read -r -a args <<<"$c"
  : >"$work/ns.txt"
  for ((i = 0; i < repeats; ++i)); do
    if ! "$exe" render "$root/volumes/${args[0]}" "${args[@]:1}" --mode naive --size 512x512 \
        -o "$work/frame.exr" --stats "$work/stats.json" -q 2>"$work/err.txt"; then
      echo "naive-throughput.sh: leap render failed on $c:" >&2
      cat "$work/err.txt" >&2
      exit 1
    fi
    python3 - "$work/stats.json" >>"$work/ns.txt" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
print(d["ns_per_sample"], d["samples_per_pixel"]["mean"], d["opacity_correction"])
EOF
  done
  python3 - "$c" "$work/ns.txt" <<'EOF'
import statistics, sys
rows = [line.split() for line in open(sys.argv[2])]
ns = [float(r[0]) for r in rows]
print("| `%s` | %.0f | %s | %.2f | %.2f |" % (sys.argv[1], float(rows[0][1]), rows[0][2], min(ns), statistics.median(ns)))
EOF
done
