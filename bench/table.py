#!/usr/bin/env python3
"""Side-by-side table of a bench/compare.sh run: vorl against the OpenCV peer.

    python3 bench/table.py RUN_DIR [--markdown]

RUN_DIR holds what compare.sh wrote: vorl_eval_<k>.json (`vorl eval --json`, one per timing run),
vorl_scores.json, peer_timing_<k>.json, peer_scores.json and peer_noreject_scores.json (bench/score.py
--json). ms/frame is the median over the timing runs, the fastest run in brackets.
"""

import glob
import json
import os
import statistics
import sys


def load(path):
    with open(path) as f:
        return json.load(f)


def pct(v):
    return "n/a" if v is None else f"{100 * v:.1f}%"


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    markdown = "--markdown" in sys.argv[1:]
    if len(args) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    run = args[0]
    def runs_of(prefix):
        paths = glob.glob(os.path.join(run, prefix + "_*.json"))
        paths.sort(key=lambda p: int(os.path.basename(p)[len(prefix) + 1:-5]))
        return [load(p) for p in paths]

    evals = runs_of("vorl_eval")
    ptimes = runs_of("peer_timing")
    if not evals or not ptimes:
        print(f"error: {run}: no vorl_eval_<k>.json or peer_timing_<k>.json (run bench/compare.sh)", file=sys.stderr)
        return 2
    vorl = load(os.path.join(run, "vorl_scores.json"))
    peer = load(os.path.join(run, "peer_scores.json"))
    peer0 = load(os.path.join(run, "peer_noreject_scores.json"))
    v_ms = [e["ms_per_frame"] for e in evals]
    p_ms = [t["ms_per_frame"] for t in ptimes]
    t0 = ptimes[0]

    def ms(xs):
        return f"{statistics.median(xs):.2f}"

    def runs(xs):
        return " / ".join(f"{x:.2f}" for x in xs)

    def sp(s, key):
        d = s[key]
        return "- (no parts)" if d["count"] == 0 else f"{d['median']:.3f} / {d['p95']:.3f}"

    def frac(s, a, b):
        return f"{pct(s[a] / s[b] if s[b] else None)} ({s[a]}/{s[b]})"

    rows = [
        ("ms/frame, median (fastest) of runs", f"{ms(v_ms)} ({min(v_ms):.2f})", f"{ms(p_ms)} ({min(p_ms):.2f})", "-"),
        ("  each run", runs(v_ms), runs(p_ms), "-"),
        ("detection recall", frac(vorl, "detected", "truth_parts"), frac(peer, "detected", "truth_parts"),
         frac(peer0, "detected", "truth_parts")),
        ("detection precision", frac(vorl, "true_predictions", "predictions"),
         frac(peer, "true_predictions", "predictions"), frac(peer0, "true_predictions", "predictions")),
        ("classification (known parts)", frac(vorl, "known_correct", "known"), frac(peer, "known_correct", "known"),
         frac(peer0, "known_correct", "known")),
        ("unknown rejection", frac(vorl, "unknown_rejected", "unknown"), frac(peer, "unknown_rejected", "unknown"),
         frac(peer0, "unknown_rejected", "unknown")),
        ("angle err mod 360/sym, med / p95 °", sp(vorl, "angle"), sp(peer, "angle"), sp(peer0, "angle")),
        ("angle err mod 180, med / p95 °", sp(vorl, "angle_mod180"), sp(peer, "angle_mod180"),
         sp(peer0, "angle_mod180")),
        ("  … parts (right class, sym ≠ 0)", str(vorl["angle"]["count"]), str(peer["angle"]["count"]),
         str(peer0["angle"]["count"])),
        ("angle err mod 180, sym 1-2 only °", sp(vorl, "angle_mod180_axis"), sp(peer, "angle_mod180_axis"),
         sp(peer0, "angle_mod180_axis")),
        ("  … parts (right class, sym 1-2)", str(vorl["angle_mod180_axis"]["count"]),
         str(peer["angle_mod180_axis"]["count"]), str(peer0["angle_mod180_axis"]["count"])),
        ("position err, med / p95 px", sp(vorl, "position"), sp(peer, "position"), sp(peer0, "position")),
    ]
    head = ("", "vorl", f"OpenCV peer (reject {t0['reject']:g})", "OpenCV peer, no rejection")
    if markdown:
        print("| " + " | ".join(head) + " |")
        print("|" + "---|" * len(head))
        for r in rows:
            print("| " + " | ".join(r) + " |")
    else:
        w = [max(len(r[i]) for r in rows + [head]) for i in range(4)]
        line = lambda r: "  ".join(c.ljust(w[i]) if i == 0 else c.rjust(w[i]) for i, c in enumerate(r))  # noqa: E731
        print(line(head))
        print("  ".join("-" * x for x in w))
        for r in rows:
            print(line(r))
    print()
    print(f"set: {evals[0]['set']}, {vorl['frames']} frames, {vorl['truth_parts']} parts")
    print(f"timing: {len(v_ms)} run(s) each, one after the other; vorl: `vorl eval` core time per frame "
          f"(release build); peer: perf_counter around each frame's work after decoding, "
          f"{t0['threads']} OpenCV thread, OpenCV {t0['opencv']}, numpy {t0['numpy']}")
    print(f"peer: threshold {t0['threshold']:g}, min area {t0['min_area']:g} px², matchShapes "
          f"{t0['method'].upper()}, reject above {t0['reject']:g} (tuned on seed 1, not on this set); its angle is "
          "known only modulo 180°: compare vorl's mod 360/sym with the peer's mod 180")
    return 0


if __name__ == "__main__":
    sys.exit(main())
