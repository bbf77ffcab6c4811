#!/usr/bin/env python3
"""Side-by-side table of a bench/compare.sh run: vorl against the OpenCV peer.

    python3 bench/table.py RUN_DIR [--markdown]

RUN_DIR holds what compare.sh wrote: vorl_eval_<k>.json (`vorl eval --json`, one per timing run),
vorl_scores.json, peer_timing_<k>.json, peer_scores.json and peer_noreject_scores.json (bench/score.py
--json); and, when present, vorl_paper_eval_<k>.json and vorl_paper_scores.json (vorl on the paper's
path, a column of its own). ms/frame is the median over the timing runs, the fastest run in brackets.
"× the peer's time" pairs each timing run with the peer's run of the same round (run one right after
the other), so that a machine whose speed drifts between rounds (a shared host) does not bias the
comparison: the median of those per-round ratios, their range in brackets.
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
    paper_evals = runs_of("vorl_paper_eval")
    paper_path = os.path.join(run, "vorl_paper_scores.json")
    paper = load(paper_path) if paper_evals and os.path.exists(paper_path) else None

    def ms(xs):
        return f"{statistics.median(xs):.2f}"

    def runs(xs):
        return " / ".join(f"{x:.2f}" for x in xs)

    def sp(s, key):
        d = s[key]
        return "- (no parts)" if d["count"] == 0 else f"{d['median']:.3f} / {d['p95']:.3f}"

    def frac(s, a, b):
        return f"{pct(s[a] / s[b] if s[b] else None)} ({s[a]}/{s[b]})"

    def paired(ms_runs):
        """Each timing run over the peer's of the same round: median (lowest – highest)."""
        if ms_runs is p_ms:
            return "1 (the reference)"
        ratios = [v / p for v, p in zip(ms_runs, p_ms) if p > 0]
        if not ratios:
            return "-"
        return f"{statistics.median(ratios):.2f} ({min(ratios):.2f} – {max(ratios):.2f})"

    def cells(s, ms_runs):
        """The column of one method: its timing runs (None: not timed) and its scores."""
        timing = ("-", "-", "-") if ms_runs is None else (
            f"{ms(ms_runs)} ({min(ms_runs):.2f})",
            runs(ms_runs),
            paired(ms_runs),
        )
        return [
            *timing,
            frac(s, "detected", "truth_parts"),
            frac(s, "true_predictions", "predictions"),
            frac(s, "known_correct", "known"),
            frac(s, "unknown_rejected", "unknown"),
            sp(s, "angle"),
            sp(s, "angle_mod180"),
            str(s["angle"]["count"]),
            sp(s, "angle_mod180_axis"),
            str(s["angle_mod180_axis"]["count"]),
            sp(s, "position"),
        ]

    labels = [
        "ms/frame, median (fastest) of runs",
        "  each run",
        "× the peer's time, same round: median (range)",
        "detection recall",
        "detection precision",
        "classification (known parts)",
        "unknown rejection",
        "angle err mod 360/sym, med / p95 °",
        "angle err mod 180, med / p95 °",
        "  … parts (right class, sym ≠ 0)",
        "angle err mod 180, sym 1-2 only °",
        "  … parts (right class, sym 1-2)",
        "position err, med / p95 px",
    ]
    columns = [cells(vorl, v_ms)]
    head = ["", "vorl"]
    if paper is not None:
        columns.append(cells(paper, [e["ms_per_frame"] for e in paper_evals]))
        head.append("vorl, paper's path")
    columns += [cells(peer, p_ms), cells(peer0, None)]
    head += [f"OpenCV peer (reject {t0['reject']:g})", "OpenCV peer, no rejection"]
    rows = [tuple([label] + [c[i] for c in columns]) for i, label in enumerate(labels)]
    head = tuple(head)
    if markdown:
        print("| " + " | ".join(head) + " |")
        print("|" + "---|" * len(head))
        for r in rows:
            print("| " + " | ".join(r) + " |")
    else:
        w = [max(len(r[i]) for r in rows + [head]) for i in range(len(head))]
        line = lambda r: "  ".join(c.ljust(w[i]) if i == 0 else c.rjust(w[i]) for i, c in enumerate(r))  # noqa: E731
        print(line(head))
        print("  ".join("-" * x for x in w))
        for r in rows:
            print(line(r))
    print()
    print(f"set: {evals[0]['set']}, {vorl['frames']} frames, {vorl['truth_parts']} parts")
    if paper is not None:
        print("vorl, paper's path: --refine off --position polygon (the DP's decision f' < ε, its angle and the "
              "polygon centroid; no alignment, verification or partial-volume centroid)")
    print(f"timing: {len(v_ms)} run(s) each, one after the other; vorl: `vorl eval` core time per frame "
          f"(release build); peer: perf_counter around each frame's work after decoding, "
          f"{t0['threads']} OpenCV thread, OpenCV {t0['opencv']}, numpy {t0['numpy']}")
    print(f"peer: threshold {t0['threshold']:g}, min area {t0['min_area']:g} px², matchShapes "
          f"{t0['method'].upper()}, reject above {t0['reject']:g} (tuned on seed 1, not on this set); its angle is "
          "known only modulo 180°: compare vorl's mod 360/sym with the peer's mod 180")
    return 0


if __name__ == "__main__":
    sys.exit(main())
