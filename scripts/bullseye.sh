#!/usr/bin/env bash
# Opt-in: the MPEG-7 bullseye score of vorl's matcher (`vorl similarity`, the all-pairs f′
# matrix of 1 400 silhouettes, read in place from ../shared/datasets/mpeg7 or $MPEG7), scored by
# scripts/bullseye.py, with its time. Not part of scripts/test.sh: a user's clone has no
# ../shared.
set -euo pipefail
cd "$(dirname "$0")/.."
MPEG7=${MPEG7:-../shared/datasets/mpeg7}
if [ ! -d "$MPEG7" ]; then
    echo "no MPEG-7 silhouettes at $MPEG7 (set MPEG7=folder); nothing to score" >&2
    exit 2
fi
cargo build --release -q -p vorl-host-sim --bin vorl
OUT=${OUT:-out/bullseye}
mkdir -p "$OUT"
start=$(date +%s.%N)
target/release/vorl similarity "$MPEG7" --format json --out "$OUT/mpeg7.json" "$@" 2>"$OUT/similarity.log"
end=$(date +%s.%N)
python3 scripts/bullseye.py "$OUT/mpeg7.json"
python3 -c "import sys; print(f'vorl similarity: {float(sys.argv[2]) - float(sys.argv[1]):.1f} s for the matrix ({sys.argv[3]} cores)')" "$start" "$end" "$(nproc)"
