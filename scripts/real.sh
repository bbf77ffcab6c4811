#!/usr/bin/env bash
# Opt-in check on real photographs, through the integrator's flow: for every fixture set under
# ../shared/datasets/real (or $REAL) that has a teach.json, each class is taught with
# `vorl teach FRAME --at X,Y --name CLASS` from its teach photo into a fresh templates/ folder,
# and `vorl eval` then runs with nothing else set (no vorl.toml of the set's, no flags but those
# given to this script). Overlays and the estimated platform and mask of every frame go into
# out/real/<set>/.
#
# The photos are read in place: the taught set out/real/<set>/ holds symbolic links to the
# set's frames/ and truth.json, its own templates/ and whatever teach writes (vorl.toml).
# Nothing of the photos is copied into the repository. Not part of scripts/test.sh: a user's
# clone has no ../shared.
#
#   bash scripts/real.sh                 # every set, integrator's flow
#   PROVIDED=1 bash scripts/real.sh      # the sets' provided templates and vorl.toml instead
#   bash scripts/real.sh --threshold 20  # extra flags go to teach and eval alike
set -euo pipefail
cd "$(dirname "$0")/.."
REAL=${REAL:-../shared/datasets/real}
if [ ! -d "$REAL" ]; then
    echo "no real photo sets at $REAL (set REAL=folder); nothing to check" >&2
    exit 2
fi
cargo build --release -q -p vorl-host-sim --bin vorl
VORL=$PWD/target/release/vorl
OUT=${OUT:-out/real}
status=0
for set in "$REAL"/*/; do
    set=${set%/}
    [ -d "$set/frames" ] || continue
    name=$(basename "$set")
    src=$(cd "$set" && pwd)
    dst="$OUT/$name"
    rm -rf "$dst"
    mkdir -p "$dst"
    if [ "${PROVIDED:-0}" = "1" ] || [ ! -f "$set/teach.json" ]; then
        echo "### $name (provided templates)"
        target=$src
    else
        echo "### $name (taught: vorl teach --at from teach.json, then vorl eval with defaults)"
        target=$dst/set
        mkdir -p "$target"
        ln -s "$src/frames" "$target/frames"
        ln -s "$src/truth.json" "$target/truth.json"
        # One line per class: name, teach frame, x, y (or part number).
        python3 - "$set/teach.json" >"$dst/teach.tsv" <<'EOF'
import json, sys
for cls, t in json.load(open(sys.argv[1])).items():
    at = f"{t['x']},{t['y']}" if "x" in t else ""
    print(cls, t["frame"], at, t.get("part", ""), sep="\t")
EOF
        while IFS=$'\t' read -r cls frame at part; do
            if [ -n "$at" ]; then
                "$VORL" teach "$src/$frame" --at "$at" --name "$cls" --out "$target/templates" "$@" || status=1
            else
                "$VORL" teach "$src/$frame" --part "$part" --name "$cls" --out "$target/templates" "$@" || status=1
            fi
        done <"$dst/teach.tsv"
    fi
    "$VORL" eval "$target" "$@" || status=1
    "$VORL" detect "$target" --json --overlay "$dst/overlays" --debug "$dst/debug" "$@" >"$dst/detect.json" || status=1
done
echo "overlays and platform estimates: $OUT/<set>/overlays, $OUT/<set>/debug"
exit $status
