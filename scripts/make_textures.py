#!/usr/bin/env python3
"""Generates the worlds' textures (run once; the PNGs are committed).

Photometric mapping needs image gradients at every scale, so each texture mixes tileable
multi-octave value noise with a structure a person recognises (planks, bricks, plaster, weave).
Pure Python (zlib + struct), fixed seeds: the same bytes on every run.
"""
import math
import pathlib
import random
import struct
import zlib

SIZE = 256
OUT = pathlib.Path(__file__).resolve().parent.parent / "worlds" / "assets"


def write_png(path, pixels, size=SIZE):
    raw = b"".join(b"\x00" + bytes(v for px in pixels[y * size:(y + 1) * size] for v in px)
                   for y in range(size))
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    path.write_bytes(png)


def noise(seed, octaves=5, base=4):
    """Tileable fractal value noise in [0, 1], as a SIZE x SIZE list."""
    rng = random.Random(seed)
    total = [0.0] * (SIZE * SIZE)
    amplitude, norm = 1.0, 0.0
    for o in range(octaves):
        cells = base << o
        lattice = [[rng.random() for _ in range(cells)] for _ in range(cells)]
        step = SIZE / cells
        for y in range(SIZE):
            gy = y / step
            y0 = int(gy) % cells
            y1 = (y0 + 1) % cells
            fy = gy - int(gy)
            fy = fy * fy * (3 - 2 * fy)
            row0, row1 = lattice[y0], lattice[y1]
            for x in range(SIZE):
                gx = x / step
                x0 = int(gx) % cells
                x1 = (x0 + 1) % cells
                fx = gx - int(gx)
                fx = fx * fx * (3 - 2 * fx)
                top = row0[x0] + (row0[x1] - row0[x0]) * fx
                bottom = row1[x0] + (row1[x1] - row1[x0]) * fx
                total[y * SIZE + x] += amplitude * (top + (bottom - top) * fy)
        norm += amplitude
        amplitude *= 0.55
    return [t / norm for t in total]


def mix(a, b, t):
    return tuple(max(0, min(255, int(round(a[i] + (b[i] - a[i]) * t)))) for i in range(3))


def plaster(seed, light, dark):
    n = noise(seed, octaves=6, base=4)
    rng = random.Random(seed + 1)
    px = [mix(dark, light, 0.2 + 0.8 * v) for v in n]
    for _ in range(900):  # speckles: sharp features for the optimiser to lock onto
        x, y = rng.randrange(SIZE), rng.randrange(SIZE)
        px[y * SIZE + x] = mix(px[y * SIZE + x], (20, 20, 25), 0.6)
    return px


def planks(seed, light, dark):
    n = noise(seed, octaves=5, base=8)
    px = []
    for y in range(SIZE):
        for x in range(SIZE):
            plank = y // 32
            grain = 0.5 + 0.5 * math.sin((x + 37 * plank) * 0.15 + 6 * n[y * SIZE + x])
            seam = 0.35 if y % 32 in (0, 1) or (x + 97 * plank) % 128 in (0, 1) else 1.0
            px.append(mix(dark, light, (0.35 + 0.45 * grain + 0.2 * n[y * SIZE + x]) * seam))
    return px


def bricks(seed, brick, mortar):
    n = noise(seed, octaves=5, base=8)
    rng = random.Random(seed)
    shade = [rng.uniform(0.7, 1.15) for _ in range(64 * 64)]
    px = []
    for y in range(SIZE):
        row = y // 16
        for x in range(SIZE):
            xs = x + (16 if row % 2 else 0)
            joint = y % 16 < 2 or xs % 32 < 2
            if joint:
                px.append(mix(mortar, (60, 60, 60), 0.4 * n[y * SIZE + x]))
            else:
                s = shade[(row * 17 + xs // 32) % len(shade)]
                base = tuple(min(255, c * s) for c in brick)
                px.append(mix(base, (40, 20, 15), 0.5 * n[y * SIZE + x]))
    return px


def weave(seed, a, b):
    n = noise(seed, octaves=4, base=8)
    px = []
    for y in range(SIZE):
        for x in range(SIZE):
            over = ((x // 4) + (y // 4)) % 2
            px.append(mix(a if over else b, (245, 240, 230), 0.35 * n[y * SIZE + x] ** 2))
    return px


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    write_png(OUT / "floor_wood.png", planks(1, (196, 150, 100), (95, 60, 35)))
    write_png(OUT / "wall_plaster.png", plaster(2, (225, 222, 210), (150, 150, 160)))
    write_png(OUT / "wall_blue.png", plaster(3, (170, 190, 215), (70, 95, 130)))
    write_png(OUT / "wall_brick.png", bricks(4, (165, 80, 55), (200, 195, 185)))
    write_png(OUT / "fabric.png", weave(5, (60, 90, 150), (40, 60, 110)))
    write_png(OUT / "wood_dark.png", planks(6, (130, 85, 50), (55, 30, 18)))
    write_png(OUT / "tiles.png", plaster(7, (235, 235, 235), (170, 175, 180)))


if __name__ == "__main__":
    main()
