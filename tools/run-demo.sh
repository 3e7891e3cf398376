#!/usr/bin/env bash
# The main job: build the host preset, generate (or reuse) the 12 recordings (Sim 0-3 x
# 4_infra_2_agent / 4_infra / 2_infra), replay each through the ECU firmware (a v2xloc-firmware
# process fed over emulated CAN + UDP on loopback, lock-step under a simulated clock) and print the
# paper's Table 1 from the firmware's CAN output (pose + diagnostic frames) with our numbers beside
# the paper's. Plots and TUM estimates land in out/.
#   V2XLOC_RECORDINGS=DIR   where recordings live (default out/recordings; reused if present)
#   V2XLOC_DURATION=S       shorter scenarios for a quick look (default: the scenario's own 20-22 s)
set -euo pipefail
cd "$(dirname "$0")/.."
REC=${V2XLOC_RECORDINGS:-out/recordings}
OUT=out

cmake --preset host >/dev/null
cmake --build --preset host -j "$(nproc)" --target v2xloc-sim v2xloc-eval v2xloc-firmware v2xloc-replay

duration_args=()
[ -n "${V2XLOC_DURATION:-}" ] && duration_args=(--duration "$V2XLOC_DURATION")
dirs=()
for sim in 0 1 2 3; do
  for perm in 4_infra_2_agent 4_infra 2_infra; do
    dir="$REC/sim${sim}_${perm}"
    if [ ! -f "$dir/manifest.json" ]; then
      echo "generating $dir"
      build/host/bin/v2xloc-sim generate --scenario "$sim" --perm "$perm" --out "$dir" "${duration_args[@]}"
    else
      echo "reusing $dir"
    fi
    dirs+=("$dir")
  done
done

mkdir -p "$OUT"
echo
echo "Table 1 from the firmware: each recording replayed through build/host/bin/v2xloc-firmware"
build/host/bin/v2xloc-eval --firmware build/host/bin/v2xloc-firmware "${dirs[@]}" \
  --plots "$OUT/plots" --estimates "$OUT/estimates" | tee "$OUT/table.txt"
echo "table: $OUT/table.txt   plots: $OUT/plots   estimates (TUM, fused pose from the CAN frames): $OUT/estimates"
echo "(the same table from the in-process localizer: build/host/bin/v2xloc-eval ${REC}/sim*)"
