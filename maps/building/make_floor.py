#!/usr/bin/env python3
"""Draws `floor.pgm` + `floor.yaml`: a synthetic office floor (42 m x 30 m) in ROS map_server
format at 0.15 m per pixel -- a resolution that does not divide madenet's 1 m robot cell, so
loading it exercises the resampling by the paper's rule. Drawn by us (no third-party map).

    python3 maps/building/make_floor.py   # rewrites the two files next to this script
"""
import pathlib

RES = 0.15                     # metres per pixel
W_M, H_M = 42.0, 30.0          # floor size in metres
WALL = 0.3                     # wall thickness in metres
W, H = round(W_M / RES), round(H_M / RES)
FREE, OCC = 254, 0

img = [[FREE] * W for _ in range(H)]


def px(m):
    return int(round(m / RES))


def block(x0, y0, x1, y1, v=OCC):
    """Fills the rectangle [x0, x1) x [y0, y1) in metres (y down from the top)."""
    for r in range(max(0, px(y0)), min(H, px(y1))):
        for c in range(max(0, px(x0)), min(W, px(x1))):
            img[r][c] = v


# Outer walls.
block(0, 0, W_M, WALL)
block(0, H_M - WALL, W_M, H_M)
block(0, 0, WALL, H_M)
block(W_M - WALL, 0, W_M, H_M)
# A corridor 3 m wide across the middle (y 13.5..16.5): walls above and below it, with doors.
CORR_TOP, CORR_BOT = 13.5, 16.5
block(0, CORR_TOP - WALL, W_M, CORR_TOP)
block(0, CORR_BOT, W_M, CORR_BOT + WALL)
ROOM = 7.0
for k in range(6):
    x = k * ROOM
    if k > 0:
        # Walls between rooms, both sides of the corridor (the lobby, bottom-left, stays open).
        block(x, 0, x + WALL, CORR_TOP)
        if k > 1:
            block(x, CORR_BOT, x + WALL, H_M)
    # A door 1.2 m wide into each room from the corridor.
    door = x + 2.5 + (k % 3) * 1.0
    block(door, CORR_TOP - WALL, door + 1.2, CORR_TOP, FREE)
    block(door, CORR_BOT, door + 1.2, CORR_BOT + WALL, FREE)
# Furniture: a table (1.6 m x 0.8 m) in each upper room, two desks in each lower one, a
# reception counter in the lobby.
for k in range(6):
    x = k * ROOM
    block(x + 2.0, 4.0 + (k % 2) * 3.0, x + 3.6, 4.8 + (k % 2) * 3.0)
    if k > 1:
        block(x + 1.0, 24.0, x + 2.6, 24.8)
        block(x + 4.0, 20.5 + (k % 2) * 2.0, x + 5.6, 21.3 + (k % 2) * 2.0)
block(4.0, 21.0, 9.0, 21.8)
# Pillars along the corridor.
for k in range(1, 6):
    block(k * ROOM - 0.3, 14.7, k * ROOM + 0.3, 15.3)

here = pathlib.Path(__file__).resolve().parent
with open(here / "floor.pgm", "wb") as f:
    f.write(f"P5\n{W} {H}\n255\n".encode())
    f.write(bytes(v for row in img for v in row))
(here / "floor.yaml").write_text(
    "image: floor.pgm\n"
    f"resolution: {RES}\n"
    "origin: [0.0, 0.0, 0.0]\n"
    "negate: 0\n"
    "occupied_thresh: 0.65\n"
    "free_thresh: 0.196\n"
)
print(f"wrote {W} x {H} pixels ({W_M} m x {H_M} m at {RES} m/pixel)")
