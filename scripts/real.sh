#!/usr/bin/env bash
# Opt-in check on real photographs, through the integrator's flow: for every fixture set under
# ../shared/datasets/real (or $REAL) that has a teach.json, each class is taught with
# `vorl teach FRAME --at X,Y --name CLASS` from its teach photo into a fresh templates/ folder,
# and `vorl eval` then runs with nothing else set (no vorl.toml of the set's, no flags but those
# given to this script). Overlays and the estimated platform and mask of every frame go into
# out/real/<set>/.
#
# The photos are read in place: the taught set out/real/<set>/ holds a symbolic link to the
# set's frames/, its truth.json with each class's angles taken relative to its teach photo's part
# (a taught template's angle 0 is that pose), its own templates/ and whatever teach writes
# (vorl.toml). Nothing of the photos is copied into the repository. Not part of scripts/test.sh: a user's
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
        # The truth as the taught templates see it: a template taught from a photo has that
        # photo's pose as its angle 0 (and its side as unflipped), so each class's angles are
        # taken relative to its teach photo's part where the truth lists that part (the class's
        # part nearest the teach point, within 60 px); other classes keep the set's truth.
        python3 - "$src/truth.json" "$set/teach.json" >"$target/truth.json" <<'EOF'
import json, math, sys
truth = json.load(open(sys.argv[1]))
teach = json.load(open(sys.argv[2]))
ref = {}
for cls, t in teach.items():
    if "x" not in t:
        continue
    frame = t["frame"].split("/")[-1]
    # The teach point lies on the part, not always at its centre (a U's centre is off it).
    near = sorted((math.hypot(p["x"] - t["x"], p["y"] - t["y"]), i) for i, p in
                  enumerate(truth["frames"].get(frame, [])) if p.get("class") == cls)
    if near and near[0][0] <= 60.0:
        p = truth["frames"][frame][near[0][1]]
        ref[cls] = (p["angle_deg"], bool(p.get("flipped", False)))
for parts in truth["frames"].values():
    for p in parts:
        if p.get("class") not in ref:
            continue
        a0, f0 = ref[p["class"]]
        flipped = bool(p.get("flipped", False))
        # Mirroring reverses a turn: a part on the other side from the taught one is the
        # template mirrored, then turned by angle + a0; one on the same side by angle - a0.
        a = p["angle_deg"] + a0 if flipped != f0 else p["angle_deg"] - a0
        p["angle_deg"] = a % 360.0
        if f0:
            p["flipped"] = not flipped
json.dump(truth, sys.stdout)
EOF
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
