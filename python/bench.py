"""What `rec.detect` costs from Python against the engine alone, per frame, interleaved.

    python python/bench.py [SET] [--repeat N]

For each repetition and each frame of SET (default examples/plant) it times, each first in
turn, on one recognizer:

- engine: `Engine::detect` inside Rust as `vorl detect` calls it, on an owned copy of the frame
  just written (as `vorl detect` has the frame just decoded), timed in Rust around the call;
- python: `rec.detect(frame)` from Python (`time.perf_counter` around the call: the argument
  checks, the GIL released and taken back, the engine, the parts built as dicts) on a copy of
  the frame just written (as a capture or `cv2.cvtColor` leaves it);
- cold: both again with the copy pushed out of the caches first (each byte of one 32 MB
  scratch array incremented between the copy and the call), as a stored frame read again.

Prints each frame's medians and their ratios to the engine's. On a shared machine, compare the
ratios of one run, not times across runs.
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

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
    eng_cold = {n: [] for n in frames}
    py_cold = {n: [] for n in frames}
    clock = time.perf_counter
    scratch = np.zeros(32 << 20, np.uint8)  # written through before a cold call, by both

    def engine(n, f):
        eng[n].append(_vorl._engine_seconds(rec, f))

    def python(n, f):
        g = f.copy()  # a frame just written, as a capture or cv2.cvtColor leaves it
        t0 = clock()
        rec.detect(g)
        fresh[n].append(clock() - t0)

    def engine_cold(n, f):
        eng_cold[n].append(_vorl._engine_seconds(rec, f, scratch))

    def python_cold(n, f):
        g = f.copy()
        scratch[:] += 1  # written through: the copy leaves the caches
        t0 = clock()
        rec.detect(g)
        py_cold[n].append(clock() - t0)

    order = [engine, python, engine_cold, python_cold]
    for _ in range(5):  # warm-up: planes mapped, branch predictors settled
        for n, f in frames.items():
            for m in order:
                m(n, f)
    for v in (eng, fresh, eng_cold, py_cold):
        for n in v:
            v[n].clear()
    for r in range(args.repeat):
        for k, (n, f) in enumerate(frames.items()):
            turn = (r + k) % len(order)  # each goes first in turn
            for m in order[turn:] + order[:turn]:
                m(n, f)
    print(f"{root}: {len(frames)} frames x {args.repeat} rounds, interleaved; medians, ms")
    print(f"{'frame':<10} {'parts':>5} {'engine':>7} {'python':>7} {'ratio':>6}   {'cold: engine':>12} {'python':>7} {'ratio':>6}")
    ratios, cold_ratios = [], []
    med = statistics.median
    for n, f in frames.items():
        e, p, ec, pc = med(eng[n]), med(fresh[n]), med(eng_cold[n]), med(py_cold[n])
        ratios.append(p / e)
        cold_ratios.append(pc / ec)
        print(f"{n:<10} {len(rec.detect(f)):>5} {e * 1e3:>7.4f} {p * 1e3:>7.4f} {p / e:>6.4f}   {ec * 1e3:>12.4f} {pc * 1e3:>7.4f} {pc / ec:>6.4f}")
    mean = lambda v: sum(med(v[n]) for n in frames) / len(frames)  # noqa: E731
    print(
        f"{'mean':<10} {'':>5} {mean(eng) * 1e3:>7.4f} {mean(fresh) * 1e3:>7.4f} {mean(fresh) / mean(eng):>6.4f}   "
        f"{mean(eng_cold) * 1e3:>12.4f} {mean(py_cold) * 1e3:>7.4f} {mean(py_cold) / mean(eng_cold):>6.4f}"
    )
    print(f"per-frame ratio python/engine: median {med(ratios):.4f}, max {max(ratios):.4f}")
    print(f"the same, cold:                median {med(cold_ratios):.4f}, max {max(cold_ratios):.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
