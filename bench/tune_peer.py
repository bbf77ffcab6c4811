#!/usr/bin/env python3
"""Tune the OpenCV peer's unknown-part rejection threshold (and matchShapes distance) on one set.

    bench/.venv/bin/python bench/tune_peer.py TUNING_SET [--out-dir DIR]

Runs the peer once per matchShapes distance (I1, I2, I3) with rejection off, then sweeps the
rejection threshold over the distances it saw and scores each choice with bench/score.py. The
criterion is the mean of classification and unknown rejection (both count equally; a threshold
that rejects everything or nothing scores at most 50 %). Prints the best threshold per method.

Run it on a set made with a different seed than the one the figures are reported on; the
defaults of opencv_peer.py came from `vorl gen SET --seed 1 --frames 30` (see bench/README.md).
"""

import argparse
import copy
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import score  # noqa: E402


def with_threshold(pred, r):
    out = copy.deepcopy(pred)
    for parts in out["frames"].values():
        for p in parts:
            p["class"] = p["best_class"] if p["score"] <= r else None
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("set", help="tuning fixture set (with truth.json)")
    ap.add_argument("--out-dir", default=None, help="keep the raw predictions here")
    a = ap.parse_args()
    with open(os.path.join(a.set, "truth.json")) as f:
        truth = json.load(f)
    out_dir = a.out_dir or tempfile.mkdtemp(prefix="vorl_tune_")
    os.makedirs(out_dir, exist_ok=True)
    for method in ("i1", "i2", "i3"):
        path = os.path.join(out_dir, f"peer_{method}_noreject.json")
        subprocess.run([sys.executable, os.path.join(HERE, "opencv_peer.py"), a.set, "--out", path,
                        "--reject", "1e30", "--method", method], check=True, stdout=subprocess.DEVNULL)
        with open(path) as f:
            pred = json.load(f)
        dists = sorted({p["score"] for parts in pred["frames"].values() for p in parts})
        # Candidate thresholds: midway between neighbouring observed distances, and both ends.
        cands = [0.0] + [(u + v) / 2 for u, v in zip(dists, dists[1:])] + [dists[-1] + 1.0]
        rows = []
        for r in cands:
            s, _, _ = score.score(truth, with_threshold(pred, r))
            c = s["classification"] or 0.0
            u = s["unknown_rejection"] or 0.0
            rows.append(((c + u) / 2, c, u, r))
        best = max(rows, key=lambda t: (t[0], -t[3]))
        # The plateau of thresholds reaching the best criterion.
        plateau = [t[3] for t in rows if t[0] == best[0]]
        print(f"{method}: best mean {100 * best[0]:.1f}% (classification {100 * best[1]:.1f}%, "
              f"unknown rejection {100 * best[2]:.1f}%) for reject in [{min(plateau):.4f}, {max(plateau):.4f}]")
        for crit, c, u, r in rows[:: max(1, len(rows) // 15)]:
            print(f"    reject {r:9.4f}: classification {100 * c:5.1f}%  unknown rejection {100 * u:5.1f}%")
    print(f"raw predictions in {out_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
