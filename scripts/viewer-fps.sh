#!/usr/bin/env bash
# Frames per second of `leap view` under Xvfb, per volume x window size x mode: still (whole
# full-resolution frames of one view), orbit at full resolution (--no-adaptive, a new view
# 5 degrees on every frame) and orbit with the default adaptive resolution.
#
#   scripts/viewer-fps.sh [VOLUME.vdb ...]    default: volumes/blobs.vdb volumes/sphere.vdb
#
# Environment: LEAP_EXE (default build/leap), LEAP_FPS_SIZES (default "512x512 1024x768").
# Prints a Markdown table on stdout; progress on stderr.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
exe="${LEAP_EXE:-$root/build/leap}"
sizes="${LEAP_FPS_SIZES:-512x512 1024x768}"
volumes=("$@")
[ ${#volumes[@]} -eq 0 ] && volumes=("$root/volumes/blobs.vdb" "$root/volumes/sphere.vdb")
[ -x "$exe" ] || { echo "viewer-fps.sh: $exe not found: build first (scripts/setup.sh)" >&2; exit 1; }
command -v xvfb-run >/dev/null || { echo "viewer-fps.sh: xvfb-run not found (apt-get install xvfb xauth)" >&2; exit 1; }

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cat >"$work/still.txt" <<'EOF'
wait 400
frames 1
mark warm-up
frames 3
mark still
EOF
cat >"$work/orbit.txt" <<'EOF'
frames 1
mark warm-up
repeat 6 rotate 5 0
mark orbit
EOF
cat >"$work/adaptive.txt" <<'EOF'
frames 1
mark warm-up
repeat 20 rotate 5 0
mark orbit
EOF

# fps of the mark named $2 in the output file $1
fps() { sed -n "s/^leap view: mark $2: .*: \([0-9.]*\) fps.*/\1/p" "$1" | tail -1; }

run() { # volume size mode script extra-args...
  local vol="$1" size="$2" mode="$3" script="$4"
  shift 4
  local out="$work/out.txt"
  if ! xvfb-run -a -s "-screen 0 1280x1024x24" "$exe" view "$vol" --size "$size" --mode "$mode" \
      --script "$script" "$@" >"$out" 2>&1; then
    echo "viewer-fps.sh: leap view failed on $vol ($size, $mode):" >&2
    cat "$out" >&2
    exit 1
  fi
  cp "$out" "$work/last.txt"
}

echo "| volume, size | mode | still | orbit, full res | orbit, adaptive |"
echo "| --- | --- | ---: | ---: | ---: |"
for vol in "${volumes[@]}"; do
  for size in $sizes; do
    first=1
    for mode in naive bbox octree sparseleap; do
      echo "viewer-fps.sh: $(basename "$vol") $size $mode" >&2
      run "$vol" "$size" "$mode" "$work/still.txt" --no-adaptive
      still="$(fps "$work/last.txt" still)"
      run "$vol" "$size" "$mode" "$work/orbit.txt" --no-adaptive
      orbit="$(fps "$work/last.txt" orbit)"
      run "$vol" "$size" "$mode" "$work/adaptive.txt"
      adaptive="$(fps "$work/last.txt" orbit)"
      label=""
      [ $first -eq 1 ] && label="$(basename "$vol"), $size"
      first=0
      echo "| $label | $mode | $still | $orbit | $adaptive |"
    done
  done
done
