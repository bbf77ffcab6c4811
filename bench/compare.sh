#!/usr/bin/env bash
# vorl against the OpenCV peer on one fixture set, in one run, scored by one scorer.
#
#   bash bench/compare.sh [SET]
#
# SET: a fixture set with truth.json. Without it, a 30-frame default set of seed 5 is generated
# into out/bench_set (the peer's rejection threshold was tuned on seed 1, not on this one).
#
# Steps: build vorl (release); `vorl eval SET --json` REPEAT times (ms/frame: core time per
# frame), with the defaults and on the paper's path (`--refine off --position polygon`: the DP's
# decision, angle and polygon centroid, no alignment, verification or partial-volume centroid);
# `vorl detect SET --json` (both ways) scored by bench/score.py, which must reproduce vorl eval's
# figures (else this script fails); the peer REPEAT times (ms/frame: per-frame work after
# decoding, single-threaded) and once more with rejection off; every prediction scored by
# bench/score.py; a side-by-side table. The runs are one after another, never at the same time.
# All files go to $OUT (default out/bench_run, relative to the repository's root); REPEAT
# (default 5) sets the number of timing runs. NOSHOT=1 runs vorl on a copy of the set without
# background.png and backgrounds/ (its platform estimated from the frames; the peer keeps the
# empty shot, which it cannot do without).
#
# Needs: bash scripts/setup.sh and bash bench/setup_peer.sh (the venv bench/.venv).
set -euo pipefail

SET_ARG=""
if [ $# -ge 1 ]; then
    if [ ! -d "$1" ]; then
        echo "[compare] error: $1: no such folder" >&2
        exit 1
    fi
    SET_ARG=$(cd "$1" && pwd) # absolute: the script runs from the repository's root
fi
cd "$(dirname "$0")/.."
ROOT=$(pwd)
OUT=${OUT:-out/bench_run}
REPEAT=${REPEAT:-5}
PY="$ROOT/bench/.venv/bin/python"
VORL="${CARGO_TARGET_DIR:-$ROOT/target}/release/vorl"

say() { printf '[compare] %s\n' "$*" >&2; }

if [ ! -x "$PY" ]; then
    echo "[compare] error: bench/.venv is missing; run: bash bench/setup_peer.sh" >&2
    exit 1
fi
if ! "$PY" -c 'import cv2, numpy' 2>/dev/null; then
    echo "[compare] error: bench/.venv cannot import cv2 and numpy; run: bash bench/setup_peer.sh" >&2
    exit 1
fi
case "$REPEAT" in '' | *[!0-9]* | 0) echo "[compare] error: REPEAT must be a positive integer" >&2; exit 2 ;; esac

say "building vorl (release)"
cargo build --release -q -p vorl-host-sim --bin vorl

if [ -n "$SET_ARG" ]; then
    SET=$SET_ARG
else
    SET=out/bench_set
    rm -rf "$SET"
    say "generating the default set: seed 5, 30 frames, into $SET"
    "$VORL" gen "$SET" --seed 5 --frames 30 >&2
fi
if [ -f "$SET/camera.json" ]; then
    echo "[compare] error: $SET is a stereo set (camera.json); the peer and bench/score.py take mono sets" >&2
    exit 1
fi
if [ ! -f "$SET/truth.json" ]; then
    echo "[compare] error: $SET/truth.json: no such file (the comparison needs the set's truth)" >&2
    exit 1
fi

mkdir -p "$OUT"
VSET=$SET
if [ "${NOSHOT:-0}" = 1 ]; then
    VSET="$OUT/noshot_set"
    rm -rf "$VSET"
    mkdir -p "$VSET"
    cp -r "$SET/frames" "$SET/templates" "$SET/truth.json" "$VSET/"
    [ -f "$SET/vorl.toml" ] && cp "$SET/vorl.toml" "$VSET/"
    say "vorl runs without the empty shot: $VSET (the platform estimated from the frames)"
fi
# Runs of an earlier call (table.py reads them all).
rm -f "$OUT"/vorl_eval_*.json "$OUT"/vorl_paper_eval_*.json "$OUT"/peer_timing_*.json
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1

PAPER=(--refine off --position polygon)
say "vorl: detect --json, scored by bench/score.py and held against vorl eval --json"
"$VORL" detect "$VSET" --json >"$OUT/vorl_pred.json"
"$VORL" detect "$VSET" --json "${PAPER[@]}" >"$OUT/vorl_paper_pred.json"
for k in $(seq 1 "$REPEAT"); do
    say "timing run $k/$REPEAT: vorl eval"
    "$VORL" eval "$VSET" --json >"$OUT/vorl_eval_$k.json"
    say "timing run $k/$REPEAT: vorl eval ${PAPER[*]}"
    "$VORL" eval "$VSET" --json "${PAPER[@]}" >"$OUT/vorl_paper_eval_$k.json"
    say "timing run $k/$REPEAT: OpenCV peer"
    "$PY" bench/opencv_peer.py "$SET" --out "$OUT/peer_pred.json" --json-timing "$OUT/peer_timing_$k.json" >&2
done
"$PY" bench/score.py "$SET/truth.json" "$OUT/vorl_pred.json" --json \
    --agree-with "$OUT/vorl_eval_1.json" >"$OUT/vorl_scores.json"
"$PY" bench/score.py "$SET/truth.json" "$OUT/vorl_paper_pred.json" --json \
    --agree-with "$OUT/vorl_paper_eval_1.json" >"$OUT/vorl_paper_scores.json"
"$PY" bench/score.py "$SET/truth.json" "$OUT/peer_pred.json" --json >"$OUT/peer_scores.json"

say "OpenCV peer with rejection off"
"$PY" bench/opencv_peer.py "$SET" --out "$OUT/peer_noreject_pred.json" --reject inf >&2
"$PY" bench/score.py "$SET/truth.json" "$OUT/peer_noreject_pred.json" --json >"$OUT/peer_noreject_scores.json"

echo
"$PY" bench/table.py "$OUT"
"$PY" bench/table.py "$OUT" --markdown >"$OUT/table.md"
if [ "$VSET" != "$SET" ]; then
    echo "vorl: without the empty shot (the platform estimated from the frames, an estimate kept while frames fit it); the peer: with it"
fi
say "files in $OUT (predictions, scores, the table as Markdown in table.md)"
