#!/usr/bin/env python3
"""Writes the seed corpus of vorl's fuzz targets into fuzz/seeds/<target>/ (committed).

Each seed is laid out the way its target's decoder reads it (fuzz/src/lib.rs: little-endian
reads from the front, a selector byte before every number): a few small, valid inputs per
target (a part on a platform, a template library, descriptor arrays, a disc for the partial
volume, a stereo pair, exact calibration pairs) from which libFuzzer mutates towards the edges.
Deterministic: running it again writes the same bytes.

    python3 scripts/fuzz-seeds.py
"""
import math
import os
import struct
import zlib

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "fuzz", "seeds")


def write(target, name, data):
    d = os.path.join(ROOT, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(bytes(data))


def u16(v):
    return struct.pack("<H", v)


def u32(v):
    return struct.pack("<I", v)


def f32(v):
    return struct.pack("<f", v)


def small(v):
    """Input::num for a small integer: selector 64, then the i8."""
    return bytes([64, v & 0xFF])


def count(v):
    """Input::count for a value below 256: selector 6, then the byte."""
    return bytes([6, v])


DEFAULT_PARAMS = bytes(15)  # every selector below 160: Params::DEFAULT


def rotated_rect(w, h, cx, cy, rw, rh, deg, inside, outside):
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    px = bytearray()
    for y in range(h):
        for x in range(w):
            dx, dy = x - cx, y - cy
            u, v = dx * c + dy * s, -dx * s + dy * c
            px.append(inside if abs(u) <= rw / 2 and abs(v) <= rh / 2 else outside)
    return px


def recognizer():
    w, h = 64, 48
    bg = bytes([100]) * (w * h)
    frame = bytearray(bg)
    for y in range(17, 31):
        for x in range(20, 44):
            frame[y * w + x] = 30
    rect = bytes([20, 17, 24, 14])
    head = bytes([w - 1, h - 1, 0]) + DEFAULT_PARAMS
    write("recognizer", "rect_on_platform", head + bg + bytes(frame) + rect)
    # The same part turned by 30°, the template taught at 0°; background learned, a stride.
    turned = rotated_rect(w, h, 31.5, 23.5, 24, 14, 30, 30, 100)
    head = bytes([w - 1, h - 1, 4 | 16]) + DEFAULT_PARAMS
    write("recognizer", "turned_learned_strided", head + bg + bytes(turned) + rect)
    # α = 0.5 (selector 160, then 0.5 as (u16 − 32768) / 128), Otsu, the paper's path.
    params = bytearray(DEFAULT_PARAMS)
    alpha = bytes([160, 128]) + u16(32768 + 64)
    otsu = bytes([160, 0])
    rest = bytearray(13)
    rest[8] = 170  # refine selector: Off
    head = bytes([w - 1, h - 1, 1]) + alpha + otsu + bytes(rest)
    write("recognizer", "alpha_otsu_paper", head + bg + bytes(turned) + rect)
    # A tiny frame: 1×1.
    write("recognizer", "one_pixel", bytes([0, 0, 0]) + DEFAULT_PARAMS + b"\x64\x1e")


def mask_bits(w, h, on):
    bits = bytearray((w * h + 7) // 8)
    for y in range(h):
        for x in range(w):
            if on(x, y):
                i = y * w + x
                bits[i // 8] |= 1 << (i % 8)
    return bytes(bits)


def borders():
    def ring(x, y):
        r = math.hypot(x - 16, y - 12)
        return 4 <= r <= 9

    def nested(x, y):
        return (2 <= x <= 29 and 2 <= y <= 21 and not (5 <= x <= 26 and 5 <= y <= 18)) or (
            9 <= x <= 22 and 8 <= y <= 15 and not (12 <= x <= 19 and 10 <= y <= 13)
        )

    for name, (w, h, on, choice) in {
        "ring": (32, 24, ring, 0),
        "nested": (32, 24, nested, 0),
        "checkerboard_small_store": (40, 16, lambda x, y: (x + y) % 2 == 0, 2),
        "wide_bar": (200, 6, lambda x, y: 1 <= y <= 4 and 3 <= x <= 190, 0),
    }.items():
        write("borders", name, bytes([w - 1, h - 1, choice, 0, 0]) + mask_bits(w, h, on))
    # Raw label values (any byte).
    write("borders", "raw_labels", bytes([15, 7, 1, 0, 0]) + bytes(range(0, 256, 2)))


def library_bytes(n, m, k, omega, templates):
    """A template library, format version 1 (core/src/library/mod.rs)."""
    payload = u16(n) + u16(m) + u16(k) + u16(len(templates)) + f32(omega)
    for name, points, desc, edge, normals in templates:
        nb = name.encode()
        rec = bytes([len(nb)]) + nb + bytes(31 - len(nb))
        cx = sum(p[0] for p in points) / m
        cy = sum(p[1] for p in points) / m
        rec += f32(cx) + f32(cy) + f32(cx) + f32(cy) + f32(100.0) + f32(0.0) + f32(0.0)
        rec += b"".join(f32(p[0]) + f32(p[1]) for p in points)
        rec += b"".join(f32(v) for v in desc)
        rec += b"".join(f32(e[0]) + f32(e[1]) for e in edge)
        rec += b"".join(f32(v[0]) + f32(v[1]) for v in normals)
        payload += rec
    header = b"VRLT" + u16(1) + u16(0) + u32(len(payload)) + u32(zlib.crc32(payload) & 0xFFFFFFFF)
    return header + payload


def circle_template(name, m, r, wobble):
    pts, desc, edge, normals = [], [], [], []
    for j in range(m):
        a = 2 * math.pi * j / m
        rr = r + wobble * math.cos(3 * a)
        pts.append((20 + rr * math.cos(a), 20 + rr * math.sin(a)))
        desc.append(1.0 + 0.1 * math.cos(3 * a))
        edge.append((rr * math.cos(a), rr * math.sin(a)))
        normals.append((math.cos(a), math.sin(a)))
    return (name, pts, desc, edge, normals)


def library():
    one = library_bytes(12, 16, 2, 0.5, [circle_template("disc", 16, 8.0, 0.0)])
    write("library", "one_template", bytes([0]) + one)
    two = library_bytes(12, 16, 2, 0.5, [circle_template("disc", 16, 8.0, 0.0), circle_template("trefoil", 16, 8.0, 2.0)])
    write("library", "two_templates", bytes([0]) + two)
    # Header repaired by the mode bits, body cut short.
    write("library", "repaired_truncated", bytes([7]) + two[: len(two) // 2])
    write("library", "empty", bytes([0]))


def matching():
    def case(n, m, values, bound_inf=True):
        data = bytes([0]) + u16(n - 1) + u16(m - n) + bytes([1 if bound_inf else 0, 0])
        return data + b"".join(values)

    n, m = 8, 12
    write("matching", "distinct", case(n, m, [small(v) for v in [3, 1, 4, 1, 5, 9, 2, 6]] + [small(v) for v in range(12)]))
    write("matching", "all_equal", case(n, m, [small(7)] * (n + m)))
    nan = bytes([0, 0])  # SPECIAL[0] = NaN
    inf = bytes([0, 1])  # SPECIAL[1] = +inf
    write("matching", "nan_inf", case(n, m, [small(1), nan, small(2), inf] * 5))
    write("matching", "equal_counts", case(16, 16, [small(v % 5) for v in range(32)]))


def partial_volume():
    w, h = 40, 30
    frame = bytearray()
    for y in range(h):
        for x in range(w):
            r = math.hypot(x - 19.3, y - 14.6)
            frame.append(int(50 + 100 * min(1.0, max(0.0, 9.0 - r))))
    bg = bytes([50]) * (w * h)
    # α 1, threshold mask (choice 0x20: full background), τ 20, the mask's own box.
    head = bytes([w - 1, h - 1, 0, 0x20, 20, 0]) + count(0) * 6
    write("partial_volume", "disc", head + bytes(frame) + bg)
    # Any box and seed around the disc, α = 0.5.
    head = bytes([w - 1, h - 1, 224, 0x20, 20, 200]) + count(8) + count(5) + count(31) + count(25) + count(19) + count(14)
    write("partial_volume", "given_box_alpha", head + bytes(frame) + bg)
    # A box wider than the bit-row path takes (the per-pixel path).
    w2, h2 = 180, 12
    frame2 = bytearray(bytes([50]) * (w2 * h2))
    for y in range(3, 9):
        for x in range(4, 176):
            frame2[y * w2 + x] = 160
    head = bytes([w2 - 1, h2 - 1, 0, 0x20, 20, 0]) + count(0) * 6
    write("partial_volume", "wide_bar", head + bytes(frame2) + bytes([50]) * (w2 * h2))


def geometry():
    def border_bytes(points):
        return u16(len(points)) + b"".join(bytes([x, y]) for x, y in points)

    square = [(10, y) for y in range(10, 22)] + [(x, 22) for x in range(10, 30)]
    square += [(30, y) for y in range(22, 10, -1)] + [(x, 10) for x in range(30, 10, -1)]
    tail = u16(0) + bytes([1]) + u16(63) + count(4) + bytes([0, 1])
    write("geometry", "square", border_bytes(square) + tail)
    circle = []
    for j in range(60):
        a = 2 * math.pi * j / 60
        p = (int(round(40 + 20 * math.cos(a))), int(round(40 + 20 * math.sin(a))))
        if not circle or circle[-1] != p:
            circle.append(p)
    hole = [(38, 38), (38, 42), (42, 42), (42, 38)]
    write("geometry", "circle_hole", border_bytes(circle) + border_bytes(hole) + bytes([1]) + u16(95) + count(6) + bytes([0, 1]))
    write("geometry", "degenerate", border_bytes([(5, 5)] * 7) + tail)


def stereo():
    rig = bytes(4) + small(10) + small(5) + small(3)
    pair_rules = bytes(2)
    left = [(1, 120, 3), (2, 60, 5), (0, 200, 1)]
    right = [(1, 100, 3), (2, 45, 5), (0, 150, 1), (3, 10, 2)]

    def parts(ps):
        return b"".join(bytes([c, x, y, 0, 0]) + small(0) for c, x, y in ps)

    counts = u16(len(left)) + bytes([1]) + u16(len(right))
    fit = bytes(11) + bytes([6]) + bytes(1)  # defaults; shift 3 px; seed selector default
    outline = u16(72)
    write("stereo", "three_pairs", rig + pair_rules + counts + parts(left) + parts(right) + bytes([200]) + fit + outline)
    write("stereo", "no_right", rig + pair_rules + u16(2) + bytes([1]) + u16(0) + parts(left[:2]) + bytes([0]) + fit + u16(30))


def calibration():
    def pairs(k, seed):
        out = b""
        for i in range(k):
            x = (seed * 97 + i * 131) % 640
            y = (seed * 53 + i * 71) % 480
            out += bytes([0]) + u16(x) + u16(y)
        return out

    head = bytes([0]) + u16(8) + bytes([40, 3, 10, 20, 2, 254])
    rigid = bytes([12]) + bytes(3) + u16(6) + b"".join(bytes([0, 10 * i, 7 * i % 50, 3 * i]) for i in range(6))
    write("calibration", "exact_pairs", head + pairs(8, 1) + bytes(9) + rigid)
    # Collinear and coincident pixels.
    coll = bytes([0]) + u16(5) + bytes(6) + b"".join(bytes([0]) + u16(10 * i) + u16(10 * i) for i in range(5))
    write("calibration", "collinear", coll + bytes(9) + bytes([0]) + bytes(3) + u16(3) + bytes([0, 1, 1, 1]) * 3)
    write("calibration", "too_few", bytes([0]) + u16(3) + bytes(6) + pairs(3, 2))


if __name__ == "__main__":
    recognizer()
    borders()
    library()
    matching()
    partial_volume()
    geometry()
    stereo()
    calibration()
    total = 0
    for d, _, files in os.walk(ROOT):
        for f in files:
            total += os.path.getsize(os.path.join(d, f))
    print(f"seeds written to {os.path.normpath(ROOT)} ({total} bytes)")
