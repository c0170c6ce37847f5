#!/usr/bin/env bash
# The skipping benchmark: leap bench on the shipped volumes, real MRI scans converted from
# Debian's mricron-data (ch2bet, ch2, and the aal label atlas) and a fragmented 1024^3 box of
# 2000 balls (scripts/make-rain.py), at 512x512 and 1024x1024, steps 1 and 0.5, 8 orbit views,
# with the scan ramp (opacity 0 below 2 % of the range) and with each volume's preset.
#   scripts/bench-skipping.sh OUT_DIR [BASELINE_LEAP]
# Writes OUT_DIR/scan-ramp and OUT_DIR/presets (results.csv, report.md, plots) and
# OUT_DIR/comparison.md (scripts/compare-bench.py). BASELINE_LEAP, another build's leap
# binary, is benchmarked first on the scan ramp in the same run (OUT_DIR/baseline) and shown
# as "before". LEAP_BENCH_ARGS adds options (e.g. "--repeats 3"). Do not run anything else
# meanwhile: builds and tests compete for the cores. LEAP_BENCH_DATA: where the converted
# inputs go (default OUT_DIR/data).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${1:?usage: scripts/bench-skipping.sh OUT_DIR [BASELINE_LEAP]}"
base="${2:-}"
leap="$root/build/leap"
data="${LEAP_BENCH_DATA:-$out/data}" # converted scans and the rain box
mkdir -p "$out" "$data"
templates=/usr/share/mricron/templates
for scan in ch2bet ch2 aal; do
  [ -f "$data/$scan.vdb" ] || "$leap" convert "$templates/$scan.nii.gz" -o "$data/$scan.vdb" -q
done
[ -f "$data/rain.vdb" ] || /usr/bin/python3 "$root/scripts/make-rain.py" "$data/rain.vdb" 1024 2000 3
volumes=("$root"/volumes/*.vdb "$data/ch2bet.vdb" "$data/ch2.vdb" "$data/aal.vdb" "$data/rain.vdb")
common=(--sizes 512x512,1024x1024 --steps 1,0.5 --views 8 --warmup 1 --repeats 1 --no-reference)
# shellcheck disable=SC2206
extra=(${LEAP_BENCH_ARGS:-})
ramp="$root/scripts/tf-scan-ramp.json"
if [ -n "$base" ]; then
  "$base" bench "${volumes[@]}" -o "$out/baseline" --tf "$ramp" "${common[@]}" "${extra[@]}"
fi
"$leap" bench "${volumes[@]}" -o "$out/scan-ramp" --tf "$ramp" "${common[@]}" "${extra[@]}"
"$leap" bench "${volumes[@]}" -o "$out/presets" "${common[@]}" "${extra[@]}"
before=()
[ -n "$base" ] && before=(--before "scan ramp=$out/baseline")
python3 "$root/scripts/compare-bench.py" "scan ramp=$out/scan-ramp" "presets=$out/presets" "${before[@]}" \
  > "$out/comparison.md"
echo "wrote $out/comparison.md"
