#!/usr/bin/env bash
# The main job: build the host preset, generate (or reuse) the 12 recordings (Sim 0-3 x
# 4_infra_2_agent / 4_infra / 2_infra) on every core at once, replay each through the ECU firmware
# (a v2xloc-firmware process fed over emulated CAN + UDP on loopback, lock-step under a simulated
# clock) and print the paper's Table 1 from the firmware's CAN output (pose + diagnostic frames)
# with our numbers beside the paper's. Ends with where the table, the plots and out/index.md are.
#   V2XLOC_RECORDINGS=DIR   where recordings live (default out/recordings; reused if present)
#   V2XLOC_DURATION=S       shorter scenarios for a quick look (default: the scenario's own 20-22 s)
#   V2XLOC_JOBS=N           recordings generated at once (default: nproc)
#   V2XLOC_STEREO=1         also render the disparity maps (the firmware replay does not use them;
#                           only v2xloc-eval --stereo does): ~31 MB more per recording
set -euo pipefail
cd "$(dirname "$0")/.."
REC=${V2XLOC_RECORDINGS:-out/recordings}
OUT=out
JOBS=${V2XLOC_JOBS:-$(nproc)}
START=$(date +%s)

step() { echo "[run-demo $(date +%H:%M:%S)] $*"; }

step "building v2xloc-sim, v2xloc-eval, v2xloc-firmware, v2xloc-replay (preset host)"
cmake --preset host >/dev/null
cmake --build --preset host -j "$(nproc)" --target v2xloc-sim v2xloc-eval v2xloc-firmware v2xloc-replay v2xloc-dataset

# One recording: written to DIR.partial and renamed when complete, so an interrupted run never
# leaves a folder that looks reusable. Without the IMU stream, as the README's table was measured.
generate_one() {
  local sim=$1 perm=$2 dir="$REC/sim$1_$2"
  local args=(--scenario "$sim" --perm "$perm" --out "$dir.partial" --no-imu)
  [ -n "${V2XLOC_DURATION:-}" ] && args+=(--duration "$V2XLOC_DURATION")
  [ "${V2XLOC_STEREO:-0}" = 1 ] || args+=(--no-stereo)
  rm -rf "$dir.partial"
  if ! build/host/bin/v2xloc-sim generate "${args[@]}" >"$dir.summary.txt"; then
    echo "[run-demo] generating $dir failed" >&2
    return 1
  fi
  rm -rf "$dir"
  mv "$dir.partial" "$dir"
  echo "[run-demo $(date +%H:%M:%S)] done: $(cat "$dir.summary.txt")"
  rm -f "$dir.summary.txt"
}
export -f generate_one
export REC

mkdir -p "$REC" "$OUT"
dirs=()
todo=()
for sim in 0 1 2 3; do
  for perm in 4_infra_2_agent 4_infra 2_infra; do
    dir="$REC/sim${sim}_${perm}"
    dirs+=("$dir")
    if [ -f "$dir/manifest.json" ]; then
      step "reusing $dir"
    else
      todo+=("$sim $perm")
    fi
  done
done
if [ ${#todo[@]} -gt 0 ]; then
  step "generating ${#todo[@]} recording(s), $JOBS at a time (a progress line per recording and quarter)"
  t0=$(date +%s)
  printf '%s\n' "${todo[@]}" | xargs -P "$JOBS" -L 1 bash -c 'generate_one "$@"' _
  step "generated ${#todo[@]} recording(s) in $(( $(date +%s) - t0 )) s; $REC holds $(du -sh "$REC" | cut -f1)"
fi

step "Table 1 from the firmware: each recording replayed through build/host/bin/v2xloc-firmware (one line per recording)"
build/host/bin/v2xloc-eval --firmware build/host/bin/v2xloc-firmware "${dirs[@]}" \
  --plots "$OUT/plots" --estimates "$OUT/estimates" | tee "$OUT/table.txt"

# The real drive (DAIR-V2X-C example, kept outside the repository for its licence) when present.
DAIR=${V2XLOC_DAIR_ROOT:-../shared/data/dair_v2x_c_example}
if [ -d "$DAIR" ]; then
  step "real drive: $DAIR as a recording (out/real/sim100_real_1_infra: the table calls it Sim 100), replayed through the firmware"
  rm -rf "$OUT/real/sim100_real_1_infra"
  build/host/bin/v2xloc-dataset dair-v2x-c "$DAIR" --recording "$OUT/real/sim100_real_1_infra"
  build/host/bin/v2xloc-eval --firmware build/host/bin/v2xloc-firmware "$OUT/real/sim100_real_1_infra" \
    --plots "$OUT/plots" --estimates "$OUT/estimates" | tee "$OUT/real_table.txt"
  dirs+=("$OUT/real/sim100_real_1_infra")
else
  step "real drive skipped: $DAIR absent (set V2XLOC_DAIR_ROOT to a DAIR-V2X-C cooperative folder)"
fi

step "writing $OUT/index.md"
{
  echo "# v2xloc demo outputs ($(date -u +%Y-%m-%dT%H:%MZ))"
  echo
  echo "- Table 1 (firmware replay, unaligned and aligned): [table.txt](table.txt)"
  echo "- Fused trajectories from the firmware's CAN frames (TUM): [estimates/](estimates/)"
  echo "- Recordings ($(du -sh "$REC" | cut -f1)): \`$REC\`"
  echo
  echo "| recording | top view | error over time | timing |"
  echo "|---|---|---|---|"
  for dir in "${dirs[@]}"; do
    name=$(basename "$dir")
    cell() { [ -f "$OUT/plots/$1" ] && echo "[$1](plots/$1)" || echo "-"; }
    echo "| $name | $(cell "${name}_topview.png") | $(cell "${name}_error.png") | $(cell "${name}_timing.png") |"
  done
  echo
  echo "Re-draw the plots without re-running: \`/usr/bin/python3 tools/plots/plot_run.py $OUT/plots\`"
} >"$OUT/index.md"

echo
step "finished in $(( $(date +%s) - START )) s"
echo "  table:       $OUT/table.txt"
echo "  plots:       $OUT/plots/ ($(ls "$OUT"/plots/*.png 2>/dev/null | wc -l) PNG files)"
echo "  estimates:   $OUT/estimates/"
echo "  index:       $OUT/index.md"
echo "  (the same table from the in-process localizer: build/host/bin/v2xloc-eval ${REC}/sim*)"
