"""What `rec.detect` costs from Python against the engine alone, per frame, interleaved.

    python python/bench.py [SET] [--repeat N]

For each repetition and each frame of SET (default examples/plant) it times, each first in
turn, on one recognizer:

- engine: `Engine::detect` inside Rust as `vorl detect` calls it, on an owned copy of the frame
  just written (as `vorl detect` has the frame just decoded), timed in Rust around the call;
- python: `rec.detect(frame)` from Python (`time.perf_counter` around the call: the argument
  checks, the GIL released and taken back, the engine, the parts built as dicts) on a copy of
  the frame just written (as a capture or `cv2.cvtColor` leaves it);
- stored: the same on the stored array, last read a round ago (out of the cache).

Prints each frame's medians and their ratios to the engine's. On a shared machine, compare the
ratios of one run, not times across runs.
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

import vorl
from vorl import _vorl


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("set", nargs="?", default=str(Path(__file__).resolve().parents[1] / "examples" / "plant"))
    ap.add_argument("--repeat", type=int, default=300, help="rounds over the frames (default 300)")
    args = ap.parse_args()
    root = Path(args.set)
    rec = vorl.Recognizer.from_set(root)
    frames = {p.name: vorl.imread(p) for p in sorted((root / "frames").glob("*.png"))}
    if not frames:
        print(f"{root}: no frames", file=sys.stderr)
        return 1
    eng = {n: [] for n in frames}
    fresh = {n: [] for n in frames}
    stored = {n: [] for n in frames}
    clock = time.perf_counter

    def engine(n, f):
        eng[n].append(_vorl._engine_seconds(rec, f))

    def python_fresh(n, f):
        g = f.copy()  # a frame just written, as a capture or cv2.cvtColor leaves it
        t0 = clock()
        rec.detect(g)
        fresh[n].append(clock() - t0)

    def python_stored(n, f):
        t0 = clock()
        rec.detect(f)
        stored[n].append(clock() - t0)

    order = [engine, python_fresh, python_stored]
    for _ in range(10):  # warm-up: planes mapped, caches and branch predictors settled
        for n, f in frames.items():
            for m in order:
                m(n, f)
    for v in (eng, fresh, stored):
        for n in v:
            v[n].clear()
    for r in range(args.repeat):
        for k, (n, f) in enumerate(frames.items()):
            turn = (r + k) % 3  # each of the three goes first in turn
            for m in order[turn:] + order[:turn]:
                m(n, f)
    print(f"{root}: {len(frames)} frames x {args.repeat} rounds, interleaved; medians, ms")
    print(f"{'frame':<12} {'parts':>5} {'engine':>8} {'python':>8} {'ratio':>7} {'stored':>8} {'ratio':>7}")
    ratios = []
    med = statistics.median
    for n, f in frames.items():
        e, p, s = med(eng[n]), med(fresh[n]), med(stored[n])
        ratios.append(p / e)
        print(f"{n:<12} {len(rec.detect(f)):>5} {e * 1e3:>8.4f} {p * 1e3:>8.4f} {p / e:>7.4f} {s * 1e3:>8.4f} {s / e:>7.4f}")
    e_all = sum(med(eng[n]) for n in frames) / len(frames)
    p_all = sum(med(fresh[n]) for n in frames) / len(frames)
    s_all = sum(med(stored[n]) for n in frames) / len(frames)
    print(f"{'mean':<12} {'':>5} {e_all * 1e3:>8.4f} {p_all * 1e3:>8.4f} {p_all / e_all:>7.4f} {s_all * 1e3:>8.4f} {s_all / e_all:>7.4f}")
    print(f"per-frame ratio (python/engine): median {med(ratios):.4f}, max {max(ratios):.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
