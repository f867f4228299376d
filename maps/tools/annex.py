#!/usr/bin/env python3
"""Writes maps/data/annex.stk: a building of the project's own making, to
run the experiments on a floor nothing was tuned to.

It differs from EB3 on purpose: four corridors of four widths (2.0, 2.4,
3.0 and 3.6 m) round one block of rooms, lights at other spacings on each
(4 m, 5 m and 7 m), a west corridor with no lights at all, and a dead-end
corridor off the north one with a door at its end. Edit here and run

    python3 maps/tools/annex.py > maps/data/annex.stk

With a floor number it writes that floor of the Twin (maps/data/twin.bldg):
the same plan, the floor's digit before each door number (201 is 1201 on
floor 1), and two elevators, one off the 2.4 m north corridor and one off
the 3.6 m south corridor:

    python3 maps/tools/annex.py 1 > maps/data/twin-1.stk
    python3 maps/tools/annex.py 2 > maps/data/twin-2.stk

Units here are millimetres.
"""

import sys

from stk import run

FLOOR = sys.argv[1] if len(sys.argv) > 1 else None
if FLOOR is not None and not FLOOR.isdigit():
    sys.exit("usage: annex.py [FLOOR]   (a floor number: a floor of the Twin)")


def num(n):
    """A door number as this floor has it."""
    return n if FLOOR is None else f"{FLOOR}{n}"


def lift(start, name):
    """An elevator door 2 m wide, on the Twin's floors only."""
    return [] if FLOOR is None else [(start, 2000, name, "elevator")]

W, H = 60000, 30000  # outer walls: x 0..W, y 0..H
WEST, NORTH, EAST, SOUTH = 2000, 2400, 3000, 3600  # corridor widths
SPUR_X, SPUR_W, SPUR_L = 24000, 2000, 12000  # dead end off the north corridor

out = []


def emit(s=""):
    out.append(s)


def spaced(length, every, first):
    return list(range(first, length, every))


emit("# A building of the project's own making (maps/tools/annex.py writes it):")
emit("# one block of rooms inside a 60 m x 30 m floor, four corridors of four")
emit("# widths with lights at other spacings than EB3's, a west corridor with")
emit("# no lights, and a dead end off the north corridor with a door at its end.")
emit()
if FLOOR is None:
    emit("map Annex: a building of the project's own making")
else:
    emit(f"map The Twin, floor {FLOOR}: the Annex's plan with two elevators")
emit("tolerance 50")
emit("lateral 1500")
emit()

# Outer ring, clockwise from the north-west corner, heading East.
emit("ring outer at 0 30000 heading -90")
emit("  node A -270")
north_lat = NORTH // 2
out += run(SPUR_X, [(4000, 900, num("201")), (12000, 900, num("203")), (19000, 900, num("205"))],
           spaced(SPUR_X, 4000, 2000), north_lat)
emit("  node S1 -90")
# The dead end: its west wall, its end wall with door 299, its east wall.
spur_lat = SPUR_W // 2
out += run(SPUR_L, [(5000, 900, num("291"))], [], spur_lat)
emit("  node S2 -270")
out += run(SPUR_W, [(550, 900, num("299"))], [], spur_lat)
emit("  node S3 -270")
out += run(SPUR_L, [(6000, 900, num("292"))], [], spur_lat)
emit("  node S4 -90")
rest = W - SPUR_X - SPUR_W
out += run(rest, [(6000, 900, num("207")), (16000, 900, num("209")), (26000, 900, num("211"))],
           spaced(rest, 4000, 2000), north_lat)
emit("  node B -270")
east_lat = EAST // 2
out += run(H, [(8000, 900, num("213")), (20000, 900, num("215"))], spaced(H, 5000, 5000), east_lat)
emit("  node C -270")
south_lat = SOUTH // 2
out += run(W, [(10000, 900, num("217")), (30000, 900, num("219")), (48000, 900, num("221"))]
           + lift(39000, "south.lift"), spaced(W, 7000, 5000), south_lat)
emit("  node D -270")
west_lat = WEST // 2
out += run(H, [(12000, 900, num("223"))], [], west_lat)
emit("end")
emit()

# The block of rooms, anticlockwise from its north-east corner, heading West.
bx0, bx1, by0, by1 = WEST, W - EAST, SOUTH, H - NORTH
emit(f"ring block at {bx1} {by1} heading 90")
emit("  node P -90")
out += run(bx1 - bx0, [(6000, 900, num("102")), (20000, 900, num("104")), (36000, 900, num("106")), (48000, 900, num("108"))]
           + lift(27000, "north.lift"), [], north_lat)
emit("  node Q -90")
out += run(by1 - by0, [(9000, 900, num("110"))], [], west_lat)
emit("  node R -90")
out += run(bx1 - bx0, [(8000, 900, num("112")), (27000, 900, num("114")), (44000, 900, num("116"))], [], south_lat)
emit("  node S -90")
out += run(by1 - by0, [(11000, 900, num("118"))], [], east_lat)
emit("end")
emit()
emit("# Across the four turning spaces.")
emit("link outer.A block.Q")
emit("link outer.B block.P")
emit("link outer.C block.S")
emit("link outer.D block.R")

print("\n".join(out))
