#!/usr/bin/env python3
"""OpenCV peer of vorl: what a practitioner would write with OpenCV to find the parts of a fixture set.

    bench/.venv/bin/python bench/opencv_peer.py SET --out PRED.json [--threshold T] [--reject R]

Per frame: absdiff to the background (background.png, or the mean of it and backgrounds/*.png),
a fixed binary threshold, a 3×3 opening and closing, external contours (findContours), contours
smaller than --min-area dropped, matchShapes (Hu moments) against the outer contour of each
template (templates/*.png); the closest template names the part unless its distance is above
--reject (then the part is unknown, class null). Position: centroid from the contour's moments.
Angle: principal axis of the contour's second central moments, part minus template, converted to
the contract's convention (degrees counter-clockwise on screen, the rotation that maps the
template at reference pose onto the part). The principal axis has no head or tail, so the angle is
known only modulo 180°: it is reported in [0, 180). For parts with 3-fold or higher symmetry the
second moments are isotropic and the axis is noise.

Timing: every PNG is decoded first; time.perf_counter() is read around each frame's work only
(absdiff to the detections list), like `vorl eval`, which times its core and not PNG decoding.
Single-threaded: OpenCV's thread pool set to 1 thread, OMP/OPENBLAS/MKL threads to 1.

The predictions are written in the contract's shape (DESIGN.md, "Contracts"):
{"frames": {"<name>.png": [{"class", "x", "y", "angle_deg", "score", ...}]}}, score = the
matchShapes distance to the closest template (lower is closer). Parts whose bounding box touches
the frame's edge carry "partial": true, as vorl's predictions do.
"""

import os

# Single-threaded, before numpy and OpenCV are loaded.
for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import glob  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

cv2.setNumThreads(1)

# Defaults. THRESHOLD and MIN_AREA were set a priori from the platform's noise (σ ≈ 1.9 grey
# levels per capture) and the weakest part contrast the generator makes (40 grey levels, parts of
# 35 px and more), not tuned on any truth. REJECT and the matchShapes distance were tuned once, by
# bench/tune_peer.py, on a default set of seed 1 (`vorl gen SET --seed 1 --frames 60`), never on
# the seed-5 set the figures in bench/README.md come from.
THRESHOLD = 20  # |frame − background| above this is part, grey levels
MIN_AREA = 150.0  # contours enclosing less are dropped, px²
REJECT = 0.0083  # matchShapes distance above this: unknown part

METHODS = {"i1": cv2.CONTOURS_MATCH_I1, "i2": cv2.CONTOURS_MATCH_I2, "i3": cv2.CONTOURS_MATCH_I3}


def load_gray(path):
    img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise SystemExit(f"error: {path}: cannot be read as an image")
    return img


def principal_axis_deg(m):
    """Angle of the major principal axis from the central second moments, degrees, measured in
    image coordinates (x right, y down): from +x towards +y, i.e. clockwise as seen on screen."""
    return 0.5 * math.degrees(math.atan2(2.0 * m["mu11"], m["mu20"] - m["mu02"]))


class Template:
    def __init__(self, name, path):
        img = load_gray(path)
        _, mask = cv2.threshold(img, 127, 255, cv2.THRESH_BINARY)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        if not contours:
            raise SystemExit(f"error: {path}: no part in the template")
        self.name = name
        self.contour = max(contours, key=cv2.contourArea)
        self.axis_deg = principal_axis_deg(cv2.moments(self.contour))


def load_set(root):
    bg_paths = [os.path.join(root, "background.png")] + sorted(
        glob.glob(os.path.join(root, "backgrounds", "*.png")))
    bgs = [load_gray(p).astype(np.float32) for p in bg_paths]
    if any(b.shape != bgs[0].shape for b in bgs):
        raise SystemExit("error: the background captures differ in size")
    background = np.clip(np.rint(np.mean(bgs, axis=0)), 0, 255).astype(np.uint8)
    tpl_paths = sorted(glob.glob(os.path.join(root, "templates", "*.png")))
    if not tpl_paths:
        raise SystemExit(f"error: {root}/templates: no templates")
    templates = [Template(os.path.splitext(os.path.basename(p))[0], p) for p in tpl_paths]
    frame_paths = sorted(glob.glob(os.path.join(root, "frames", "*.png")))
    if not frame_paths:
        raise SystemExit(f"error: {root}/frames: no frames")
    return background, len(bg_paths), templates, frame_paths


def detect(frame, background, templates, kernel, threshold, min_area, reject, method):
    """The parts in one frame, as prediction dicts."""
    h, w = frame.shape
    diff = cv2.absdiff(frame, background)
    _, mask = cv2.threshold(diff, threshold, 255, cv2.THRESH_BINARY)
    mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
    mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    out = []
    for c in contours:
        m = cv2.moments(c)
        if m["m00"] < min_area:
            continue
        dists = [cv2.matchShapes(c, t.contour, method, 0.0) for t in templates]
        best = int(np.argmin(dists))
        t = templates[best]
        # Counter-clockwise on screen is minus the image-coordinate axis angle, so the rotation
        # from template to part, CCW, is (template axis − part axis), taken modulo 180.
        angle = (t.axis_deg - principal_axis_deg(m)) % 180.0
        x0, y0, bw, bh = cv2.boundingRect(c)
        p = {
            "class": t.name if dists[best] <= reject else None,
            "x": m["m10"] / m["m00"],
            "y": m["m01"] / m["m00"],
            "angle_deg": angle,
            "score": dists[best],
            "best_class": t.name,
        }
        if x0 == 0 or y0 == 0 or x0 + bw >= w or y0 + bh >= h:
            p["partial"] = True
        out.append(p)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("set", help="fixture set folder (background.png, templates/, frames/)")
    ap.add_argument("--out", required=True, help="write the predictions JSON here")
    ap.add_argument("--threshold", type=float, default=THRESHOLD,
                    help=f"binary threshold on |frame − background|, grey levels (default {THRESHOLD})")
    ap.add_argument("--min-area", type=float, default=MIN_AREA,
                    help=f"drop contours enclosing less, px² (default {MIN_AREA:g})")
    ap.add_argument("--reject", type=float, default=REJECT,
                    help=f"matchShapes distance above which a part is unknown (default {REJECT:g})")
    ap.add_argument("--method", choices=sorted(METHODS), default="i1",
                    help="matchShapes distance: CONTOURS_MATCH_I1, I2 or I3 (default i1)")
    ap.add_argument("--json-timing", metavar="FILE", help="also write {\"ms_per_frame\", ...} here")
    a = ap.parse_args()

    background, n_bg, templates, frame_paths = load_set(a.set)
    # Decode every frame before the clock starts.
    frames = []
    for p in frame_paths:
        f = load_gray(p)
        if f.shape != background.shape:
            raise SystemExit(f"error: {p}: frame is {f.shape[1]}×{f.shape[0]} but the background is "
                             f"{background.shape[1]}×{background.shape[0]}")
        frames.append((os.path.basename(p), f))
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
    method = METHODS[a.method]

    pred = {}
    seconds = 0.0
    for name, f in frames:
        t0 = time.perf_counter()
        parts = detect(f, background, templates, kernel, a.threshold, a.min_area, a.reject, method)
        seconds += time.perf_counter() - t0
        pred[name] = parts
    ms = 1e3 * seconds / len(frames)

    with open(a.out, "w") as fh:
        json.dump({"frames": pred}, fh, indent=1)
    info = {
        "set": a.set, "frames": len(frames), "ms_per_frame": ms, "threads": cv2.getNumThreads(),
        "opencv": cv2.__version__, "numpy": np.__version__, "backgrounds": n_bg,
        "threshold": a.threshold, "min_area": a.min_area, "reject": a.reject, "method": a.method,
    }
    if a.json_timing:
        with open(a.json_timing, "w") as fh:
            json.dump(info, fh, indent=1)
    print(f"opencv peer {a.set}: {len(frames)} frames, {sum(len(v) for v in pred.values())} parts found, "
          f"{ms:.3f} ms/frame (per-frame work, decoding excluded, {cv2.getNumThreads()} thread, "
          f"OpenCV {cv2.__version__}); predictions in {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
