#!/usr/bin/env python3
"""Score a predictions JSON against a fixture set's truth.json, by vorl's own rules.

    python3 bench/score.py TRUTH.json PRED.json [--json] [--agree-with EVAL.json] [--label NAME]

The rules are those of host-sim/src/eval.rs (`vorl eval`), written again here so that vorl's
predictions (`vorl detect SET --json`) and any peer's are held against truth by one scorer:

- per frame, truth parts and predictions are paired greedily by centroid distance, closest pair
  first, at most 15 px apart;
- recall: paired truth parts (not partial) / truth parts (not partial); precision: paired
  predictions / predictions, where a prediction marked "partial" (touching the frame's edge) that
  pairs with nothing is left out;
- classification: paired known truth parts (not partial) whose class is right;
- unknown rejection: paired truth parts with class null that were predicted null;
- angle error: correctly classified known parts, modulo 360/symmetry (symmetry 0, a round part,
  has no angle and is left out); the same for "angle_paper_deg" where predictions carry it;
- position error: every paired truth part not cut by the border;
- spreads: median and p95 by nearest rank, max.

Beyond vorl eval, one more angle figure, for a method that knows the angle only modulo 180° (the
principal axis of the second moments has no head or tail): "angle_mod180", the error over the same
parts taken modulo 360/lcm(2, symmetry) — the 180° flip forgiven on top of the part's own symmetry
(period 180° for symmetry 1 and 2, 90° for 4, 60° for 6, 36° for 5 and 10, 30° for 12).
It is also given over the parts whose symmetry is 1 or 2 only ("angle_mod180_axis"): for those the
principal axis is defined; a part with 3-fold or higher symmetry has isotropic second moments.

Frames of the truth that are missing from the predictions count as frames with no detection (as
in eval.rs's score()). Mono sets: the stereo figures of vorl eval (disparity, depth) are not
scored here. Standard library only, so it runs with any python3.
"""

import argparse
import json
import math
import sys

MATCH_RADIUS_PX = 15.0


def spread(values):
    """Median, p95 (nearest rank) and max of the finite values, as eval.rs's Spread::of."""
    v = sorted(x for x in values if math.isfinite(x))
    if not v:
        return {"count": 0, "median": 0.0, "p95": 0.0, "max": 0.0}

    def rank(q):
        k = min(max(math.ceil(q * len(v)), 1), len(v))
        return v[k - 1]

    return {"count": len(v), "median": rank(0.5), "p95": rank(0.95), "max": v[-1]}


def angle_error_period(pred, truth, period):
    """|pred - truth| modulo period, in [0, period/2]."""
    d = math.fmod(pred - truth, period)
    if d < 0:
        d += period
    if d >= period:  # fmod of a tiny negative value plus period can round up to period
        d -= period
    return min(d, period - d)


def angle_error(pred, truth, symmetry):
    """Modulo 360/symmetry (symmetry 1 or missing: 360), as eval.rs's angle_error."""
    return angle_error_period(pred, truth, 360.0 / max(symmetry, 1))


def angle_error_mod180(pred, truth, symmetry):
    """Modulo 360/lcm(2, symmetry): the head/tail flip forgiven as well."""
    s = max(symmetry, 1)
    return angle_error_period(pred, truth, 360.0 / (s * 2 // math.gcd(s, 2)))


def pair(truth, pred):
    """Greedy pairing by distance, closest first: [(truth index, prediction index)]."""
    cands = []
    for ti, t in enumerate(truth):
        for pi, p in enumerate(pred):
            d = math.sqrt((t["x"] - p["x"]) ** 2 + (t["y"] - p["y"]) ** 2)
            if d <= MATCH_RADIUS_PX:
                cands.append((d, ti, pi))
    cands.sort(key=lambda c: c[0])  # stable, like Rust's sort_by
    tu, pu = [False] * len(truth), [False] * len(pred)
    out = []
    for _, ti, pi in cands:
        if not tu[ti] and not pu[pi]:
            tu[ti] = pu[pi] = True
            out.append((ti, pi))
    return out


def ratio(a, b):
    return None if b == 0 else a / b  # NaN in Rust, null in its JSON


def score(truth, pred):
    """The scores of pred against truth (both {"frames": {name: [part]}})."""
    s = dict(frames=0, truth_parts=0, predictions=0, detected=0, true_predictions=0,
             known=0, known_correct=0, unknown=0, unknown_rejected=0)
    angle, angle_paper, angle180, angle180_axis, position = [], [], [], [], []
    confusions = {}
    pframes = pred.get("frames", {})
    for name, truth_parts in truth["frames"].items():
        preds = pframes.get(name, [])
        s["frames"] += 1
        pairs = pair(truth_parts, preds)
        paired_preds = {pi for _, pi in pairs}
        s["predictions"] += sum(
            1 for pi, p in enumerate(preds) if p.get("partial") is not True or pi in paired_preds)
        s["truth_parts"] += sum(1 for t in truth_parts if t.get("partial") is not True)
        for ti, pi in pairs:
            t, p = truth_parts[ti], preds[pi]
            s["true_predictions"] += 1
            if t.get("partial") is True:
                continue
            s["detected"] += 1
            position.append(math.sqrt((t["x"] - p["x"]) ** 2 + (t["y"] - p["y"]) ** 2))
            tc, pc = t.get("class"), p.get("class")
            if tc is not None:
                s["known"] += 1
                if pc == tc:
                    s["known_correct"] += 1
                    sym = t.get("symmetry")
                    sym = 1 if sym is None else sym
                    if sym != 0:
                        angle.append(angle_error(p["angle_deg"], t["angle_deg"], sym))
                        e180 = angle_error_mod180(p["angle_deg"], t["angle_deg"], sym)
                        angle180.append(e180)
                        if sym <= 2:
                            angle180_axis.append(e180)
                        a = p.get("angle_paper_deg")
                        if isinstance(a, (int, float)) and not isinstance(a, bool):
                            angle_paper.append(angle_error(a, t["angle_deg"], sym))
                else:
                    key = (tc, "unknown" if pc is None else pc)
                    confusions[key] = confusions.get(key, 0) + 1
            else:
                s["unknown"] += 1
                if pc is None:
                    s["unknown_rejected"] += 1
                else:
                    key = ("(not a template)", pc)
                    confusions[key] = confusions.get(key, 0) + 1
    s["angle"] = spread(angle)
    s["angle_paper"] = spread(angle_paper)
    s["position"] = spread(position)
    s["confusions"] = [[a, b, n] for (a, b), n in sorted(confusions.items())]
    s["recall"] = ratio(s["detected"], s["truth_parts"])
    s["precision"] = ratio(s["true_predictions"], s["predictions"])
    s["classification"] = ratio(s["known_correct"], s["known"])
    s["unknown_rejection"] = ratio(s["unknown_rejected"], s["unknown"])
    s["angle_mod180"] = spread(angle180)
    s["angle_mod180_axis"] = spread(angle180_axis)
    missing = [k for k in truth["frames"] if k not in pframes]
    extra = [k for k in pframes if k not in truth["frames"]]
    return s, missing, extra


# Fields held against `vorl eval --json`: counts and confusions exactly, ratios and spreads within
# TOL. vorl eval scores the same 6-decimal values that `vorl detect --json` prints, so the two agree
# to rounding of the arithmetic (measured: 4e-16); TOL only keeps the check from hanging on that.
COUNT_FIELDS = ["frames", "truth_parts", "predictions", "detected", "true_predictions",
                "known", "known_correct", "unknown", "unknown_rejected"]
RATIO_FIELDS = ["recall", "precision", "classification", "unknown_rejection"]
SPREAD_FIELDS = ["angle", "angle_paper", "position"]
TOL = 1e-5


def disagreements(mine, theirs):
    """Every figure of `vorl eval --json` (theirs) that this scorer (mine) does not reproduce."""
    out = []
    for f in COUNT_FIELDS:
        if mine[f] != theirs.get(f):
            out.append(f"{f}: {mine[f]} here, {theirs.get(f)} in vorl eval")
    for f in RATIO_FIELDS:
        a, b = mine[f], theirs.get(f)
        if (a is None) != (b is None) or (a is not None and abs(a - b) > TOL):
            out.append(f"{f}: {a} here, {b} in vorl eval")
    for f in SPREAD_FIELDS:
        for k in ["count", "median", "p95", "max"]:
            a, b = mine[f][k], theirs.get(f, {}).get(k)
            if b is None or abs(a - b) > (0 if k == "count" else TOL):
                out.append(f"{f}.{k}: {a} here, {b} in vorl eval")
    if [list(c) for c in mine["confusions"]] != [list(c) for c in theirs.get("confusions", [])]:
        out.append(f"confusions: {mine['confusions']} here, {theirs.get('confusions')} in vorl eval")
    return out


def pct(v):
    return "n/a" if v is None else f"{100 * v:.1f}%"


def sp(d, unit):
    return f"median {d['median']:.3f}{unit}  p95 {d['p95']:.3f}{unit}  max {d['max']:.3f}{unit}  ({d['count']} parts)"


def print_table(label, s):
    print(f"score {label}: {s['frames']} frames, {s['truth_parts']} parts")
    print(f"  detection recall        {pct(s['recall']):>8}   ({s['detected']}/{s['truth_parts']})")
    print(f"  detection precision     {pct(s['precision']):>8}   ({s['true_predictions']}/{s['predictions']})")
    print(f"  classification          {pct(s['classification']):>8}   ({s['known_correct']}/{s['known']} known parts)")
    print(f"  unknown rejection       {pct(s['unknown_rejection']):>8}   "
          f"({s['unknown_rejected']}/{s['unknown']} parts not taught)")
    print(f"  angle error  mod 360/sym    {sp(s['angle'], '°')}")
    if s["angle_paper"]["count"]:
        print(f"  angle error  (paper 6.4)    {sp(s['angle_paper'], '°')}")
    print(f"  angle error  mod 180 (all)  {sp(s['angle_mod180'], '°')}")
    print(f"  angle error  mod 180 (sym 1-2) {sp(s['angle_mod180_axis'], '°')}")
    print(f"  position error              {sp(s['position'], ' px')}")
    if s["confusions"]:
        print("  confusions (truth → predicted):")
        for t, p, n in s["confusions"]:
            print(f"    {t} → {p}: {n}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("truth", help="truth.json of a fixture set")
    ap.add_argument("pred", help="predictions JSON ({\"frames\": {name: [part]}})")
    ap.add_argument("--json", action="store_true", help="print the scores as JSON")
    ap.add_argument("--label", default=None, help="name printed in the table (default: PRED)")
    ap.add_argument("--agree-with", metavar="EVAL_JSON",
                    help="output of `vorl eval SET --json` on the same set: exit 1 unless this "
                         "scorer reproduces its figures (counts exactly, the rest within 1e-5)")
    a = ap.parse_args()
    try:
        with open(a.truth) as f:
            truth = json.load(f)
        with open(a.pred) as f:
            pred = json.load(f)
    except (OSError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    s, missing, extra = score(truth, pred)
    if missing:
        print(f"warning: {len(missing)} truth frame(s) have no predictions (first: {missing[0]}); "
              "scored as frames with no detection", file=sys.stderr)
    if extra:
        print(f"warning: {len(extra)} predicted frame(s) are not in the truth (first: {extra[0]}); ignored",
              file=sys.stderr)
    if a.json:
        print(json.dumps(s, indent=2))
    else:
        print_table(a.label or a.pred, s)
    if a.agree_with:
        with open(a.agree_with) as f:
            theirs = json.load(f)
        bad = disagreements(s, theirs)
        if bad:
            print(f"error: score.py disagrees with {a.agree_with}:", file=sys.stderr)
            for b in bad:
                print(f"  {b}", file=sys.stderr)
            return 1
        print(f"score.py agrees with {a.agree_with} (counts exact, figures within {TOL:g})", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
