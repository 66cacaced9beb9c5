#!/usr/bin/env python3
"""Draws the Avatar Studio icon (a figure on a turntable ring) as PNGs in the usual
hicolor sizes, with nothing but the standard library: a signed-distance rasteriser with 4x4
supersampling and a PNG writer. Run: python3 packaging/icons/make_icons.py"""
import math, os, struct, zlib

HERE = os.path.dirname(os.path.abspath(__file__))
SIZES = [16, 24, 32, 48, 64, 128, 256, 512]
BG = (38, 44, 56)        # the studio's panel colour
ACCENT = (90, 160, 255)  # the studio's accent
SKIN = (224, 178, 150)   # the default material (sRGB of the linear 0.80 0.58 0.47)

def rounded_box(x, y, cx, cy, hw, hh, r):
    qx, qy = abs(x - cx) - hw + r, abs(y - cy) - hh + r
    return math.hypot(max(qx, 0), max(qy, 0)) + min(max(qx, qy), 0) - r

def capsule(x, y, ax, ay, bx, by, r):
    px, py, dx, dy = x - ax, y - ay, bx - ax, by - ay
    h = max(0.0, min(1.0, (px * dx + py * dy) / (dx * dx + dy * dy)))
    return math.hypot(px - dx * h, py - dy * h) - r

def shade(x, y):
    """Colour (r, g, b, a) at (x, y) in the unit square, y down."""
    if rounded_box(x, y, 0.5, 0.5, 0.46, 0.46, 0.12) > 0:
        return (0, 0, 0, 0)
    figure = min(
        math.hypot(x - 0.5, y - 0.25) - 0.095,                # head
        rounded_box(x, y, 0.5, 0.50, 0.12, 0.15, 0.06),       # torso
        capsule(x, y, 0.40, 0.41, 0.27, 0.58, 0.045),         # arms
        capsule(x, y, 0.60, 0.41, 0.73, 0.58, 0.045),
        capsule(x, y, 0.45, 0.62, 0.43, 0.84, 0.055),         # legs
        capsule(x, y, 0.55, 0.62, 0.57, 0.84, 0.055),
    )
    if figure < 0:
        # Lit from the upper left, as in the viewport.
        light = 0.82 + 0.18 * (1 - (x + y))
        return tuple(min(255, int(c * light)) for c in SKIN) + (255,)
    ring = abs(math.hypot((x - 0.5) / 1.0, (y - 0.86) / 0.28) - 0.30) - 0.018
    if ring < 0 and y > 0.80:
        return ACCENT + (255,)
    return BG + (255,)

def render(n, ss=4):
    rows = []
    for j in range(n):
        row = bytearray()
        for i in range(n):
            acc = [0, 0, 0, 0]
            for sj in range(ss):
                for si in range(ss):
                    c = shade((i + (si + 0.5) / ss) / n, (j + (sj + 0.5) / ss) / n)
                    a = c[3]
                    for k in range(3):
                        acc[k] += c[k] * a
                    acc[3] += a
            a = acc[3]
            row += bytes([int(acc[k] / a) if a else 0 for k in range(3)] + [a // (ss * ss)])
        rows.append(bytes(row))
    return rows

def write_png(path, rows, n):
    raw = b"".join(b"\x00" + r for r in rows)
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", n, n, 8, 6, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)

for n in SIZES:
    d = os.path.join(HERE, f"{n}x{n}")
    os.makedirs(d, exist_ok=True)
    write_png(os.path.join(d, "avatar-studio.png"), render(n), n)
    print(f"{n}x{n}")
