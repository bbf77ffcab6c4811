#!/usr/bin/env bash
# Regenerates the plots of docs/performance.md (docs/images/perf_dp.svg, perf_frame.svg): runs
# the cyclic-DP bench (group `cyclic_dp`) and the frame sweep (group `frame`) with short
# measurement times, then plots criterion's medians with host-sim/examples/perf_plot.rs.
# Takes a few minutes on 2 cores. WARM_UP and MEASURE (seconds) override the criterion times;
# OUT overrides the output folder.
set -euo pipefail
cd "$(dirname "$0")/.."
WARM_UP=${WARM_UP:-1}
MEASURE=${MEASURE:-2}
OUT=${OUT:-docs/images}
TIMES=(--warm-up-time "$WARM_UP" --measurement-time "$MEASURE")
echo "### cargo bench -p vorl-core --bench dp -- cyclic_dp ${TIMES[*]}"
cargo bench -p vorl-core --bench dp -- cyclic_dp "${TIMES[@]}"
echo "### cargo bench -p vorl-core --bench pipeline -- frame ${TIMES[*]}"
cargo bench -p vorl-core --bench pipeline -- frame "${TIMES[@]}"
CRITERION="${CARGO_TARGET_DIR:-target}/criterion"
echo "### cargo run --release -p vorl-host-sim --example perf_plot -- $CRITERION $OUT"
cargo run --release -q -p vorl-host-sim --example perf_plot -- "$CRITERION" "$OUT"
[[ $OUT = /* ]] || OUT="$(pwd)/$OUT"
echo "plots: $OUT/perf_dp.svg and $OUT/perf_frame.svg"
