#!/usr/bin/env bash
# Regenerates the figures of docs/accuracy.md: generates the synthetic sets (deterministic) and
# runs `vorl eval` on each with each option. Takes a few minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p vorl-host-sim --bin vorl
VORL=target/release/vorl
OUT=${OUT:-out/accuracy}
mkdir -p "$OUT"
"$VORL" gen "$OUT/default" --seed 1 --frames 60 >/dev/null
"$VORL" gen "$OUT/noisy" --seed 2 --frames 60 --variant noisy >/dev/null
"$VORL" gen "$OUT/small" --seed 2 --frames 60 --variant small >/dev/null
"$VORL" gen "$OUT/border" --seed 2 --frames 60 --variant border >/dev/null
for set in default noisy small border; do
    echo "### $set (defaults)"
    "$VORL" eval "$OUT/$set"
done
echo "### default: the paper's path (--refine off --position polygon)"
"$VORL" eval "$OUT/default" --refine off --position polygon
echo "### default: the paper's path with its own angle estimator (--refine off --angle paper --position polygon)"
"$VORL" eval "$OUT/default" --refine off --angle paper --position polygon
echo "### default: pose aligned, paper's decision (--refine pose)"
"$VORL" eval "$OUT/default" --refine pose
echo "### default: position through the aligned pose (--position pose)"
"$VORL" eval "$OUT/default" --position pose
echo "### default: one candidate verified (--candidates 1)"
"$VORL" eval "$OUT/default" --candidates 1
