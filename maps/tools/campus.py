#!/usr/bin/env python3
"""Writes maps/data/campus.stk: a large floor of the project's own making,
for fleets and for turns at junctions.

A grid of blocks of rooms inside one outer wall. The corridors between the
blocks cross each other (crossroads) and meet the corridor along the outer
wall (T-junctions), so a robot can go round a block either way: every block
is a loop. Three corridor widths: 3.0 m along the outer wall, 2.8 m between
rows of blocks, 2.4 m between columns. Lights every 4 m along every
corridor, none in the junctions. Edit here and run

    python3 maps/tools/campus.py > maps/data/campus.stk

Units here are millimetres. Door numbers: block k (1 … 24, row by row from
the south-west) has doors k01 … k12; the outer wall has 3001 onwards.
"""

from stk import run

COLS, ROWS = 6, 4  # blocks
BW, BH = 14000, 9000  # a block's size
P, V, HZ = 3000, 2400, 2800  # corridor widths: perimeter, between columns, between rows
W = COLS * BW + (COLS - 1) * V + 2 * P
H = ROWS * BH + (ROWS - 1) * HZ + 2 * P
LIGHTS_EVERY, LIGHTS_FIRST = 4000, 2000
LONG_DOORS = [2000, 5200, 8400, 11600]  # along a block's 14 m sides
SHORT_DOORS = [2500, 5600]  # along its 9 m sides
DOOR = 900

out = []


def emit(s=""):
    out.append(s)


def spaced(length):
    return list(range(LIGHTS_FIRST, length, LIGHTS_EVERY))


def doors_every(length, first, every, numbers):
    return [(s, DOOR, next(numbers)) for s in range(first, length - first, every)]


emit("# A large floor of the project's own making (maps/tools/campus.py writes it):")
emit(f"# {COLS} x {ROWS} blocks of rooms inside a {W / 1000:g} m x {H / 1000:g} m floor; the")
emit("# corridors between them cross (crossroads) and meet the one along the outer")
emit("# wall (T-junctions), so every block is a loop. Lights every 4 m.")
emit()
emit("map Campus: a large floor of the project's own making")
emit("tolerance 50")
emit(f"lateral {P // 2}")
emit()

# Outer wall, clockwise from the north-west corner, heading East. Every
# corridor along it has its lights on it.
outer = iter(range(3001, 4000))
emit(f"ring outer at 0 {H} heading -90")
for corner, length in (("NW", W), ("NE", H), ("SE", W), ("SW", H)):
    emit(f"  node {corner} -270")
    out += run(length, doors_every(length, 4000, 6000, outer), spaced(length), P // 2)
emit("end")

# Each block anticlockwise from its north-east corner, heading West: its
# north, west, south and east sides. A corridor between two rows has its
# lights on the north side of the block south of it, one between two
# columns on the east side of the block west of it.
for r in range(ROWS):
    for c in range(COLS):
        k = r * COLS + c + 1
        numbers = iter(range(k * 100 + 1, k * 100 + 100))
        x0 = P + c * (BW + V)
        y0 = P + r * (BH + HZ)
        north = P // 2 if r == ROWS - 1 else HZ // 2
        south = P // 2 if r == 0 else HZ // 2
        west = P // 2 if c == 0 else V // 2
        east = P // 2 if c == COLS - 1 else V // 2
        emit()
        emit(f"ring b{k} at {x0 + BW} {y0 + BH} heading 90")
        emit("  node NE -90")
        doors = [(s, DOOR, next(numbers)) for s in LONG_DOORS]
        out += run(BW, doors, spaced(BW) if r < ROWS - 1 else [], north)
        emit("  node NW -90")
        doors = [(s, DOOR, next(numbers)) for s in SHORT_DOORS]
        out += run(BH, doors, [], west)
        emit("  node SW -90")
        doors = [(s, DOOR, next(numbers)) for s in LONG_DOORS]
        out += run(BW, doors, [], south)
        emit("  node SE -90")
        doors = [(s, DOOR, next(numbers)) for s in SHORT_DOORS]
        out += run(BH, doors, spaced(BH) if c < COLS - 1 else [], east)
        emit("end")

print("\n".join(out))
