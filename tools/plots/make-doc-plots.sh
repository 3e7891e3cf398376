#!/usr/bin/env bash
# Regenerates the example plots in docs/plots/ from a short recording (Sim 0, 4_infra_2_agent,
# 6 s, seed 1): the evaluator's top view and error over time.
# Needs the host build (v2xloc-sim, v2xloc-eval) and python3-matplotlib.
set -euo pipefail
cd "$(dirname "$0")/../.."
WORK=${V2XLOC_DOC_PLOTS_WORK:-out/doc-plots}
cmake --preset host >/dev/null
cmake --build --preset host -j "$(nproc)" --target v2xloc-sim v2xloc-eval
rm -rf "$WORK"
build/host/bin/v2xloc-sim generate --scenario 0 --perm 4_infra_2_agent --duration 6 --seed 1 --out "$WORK/rec"
build/host/bin/v2xloc-eval "$WORK/rec" --plots "$WORK/plots" --trace "$WORK/trace" --quiet
mkdir -p docs/plots
cp "$WORK/plots/sim0_4_infra_2_agent_topview.png" docs/plots/example_eval_topview.png
cp "$WORK/plots/sim0_4_infra_2_agent_error.png" docs/plots/example_error_over_time.png
echo "docs/plots/: example_eval_topview.png example_error_over_time.png"
