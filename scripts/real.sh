#!/usr/bin/env bash
# Opt-in check on real photographs: runs `vorl eval` on every fixture set under
# ../shared/datasets/real (or $REAL), with each set's own templates and vorl.toml, and writes
# the overlays and the estimated platform and mask of every frame into out/real/<set>/.
# The photos are read in place; nothing of them is copied into the repository. Not part of
# scripts/test.sh: a user's clone has no ../shared.
set -euo pipefail
cd "$(dirname "$0")/.."
REAL=${REAL:-../shared/datasets/real}
if [ ! -d "$REAL" ]; then
    echo "no real photo sets at $REAL (set REAL=folder); nothing to check" >&2
    exit 2
fi
cargo build --release -q -p vorl-host-sim --bin vorl
VORL=target/release/vorl
OUT=${OUT:-out/real}
status=0
for set in "$REAL"/*/; do
    [ -d "$set/frames" ] || continue
    name=$(basename "$set")
    echo "### $name"
    mkdir -p "$OUT/$name"
    "$VORL" eval "$set" "$@" || status=1
    "$VORL" detect "$set" --overlay "$OUT/$name/overlays" --debug "$OUT/$name/debug" "$@" >"$OUT/$name/detect.txt" || status=1
done
echo "overlays and platform estimates: $OUT/<set>/overlays, $OUT/<set>/debug"
exit $status
