#!/usr/bin/env python3
"""Writes maps/data/annex.stk: a building of the project's own making, to
run the experiments on a floor nothing was tuned to.

It differs from EB3 on purpose: four corridors of four widths (2.0, 2.4,
3.0 and 3.6 m) round one block of rooms, lights at other spacings on each
(4 m, 5 m and 7 m), a west corridor with no lights at all, and a dead-end
corridor off the north one with a door at its end. Edit here and run

    python3 maps/tools/annex.py > maps/data/annex.stk

Units here are millimetres.
"""

from stk import run

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
emit("map Annex: a building of the project's own making")
emit("tolerance 50")
emit("lateral 1500")
emit()

# Outer ring, clockwise from the north-west corner, heading East.
emit("ring outer at 0 30000 heading -90")
emit("  node A -270")
north_lat = NORTH // 2
out += run(SPUR_X, [(4000, 900, "201"), (12000, 900, "203"), (19000, 900, "205")],
           spaced(SPUR_X, 4000, 2000), north_lat)
emit("  node S1 -90")
# The dead end: its west wall, its end wall with door 299, its east wall.
spur_lat = SPUR_W // 2
out += run(SPUR_L, [(5000, 900, "291")], [], spur_lat)
emit("  node S2 -270")
out += run(SPUR_W, [(550, 900, "299")], [], spur_lat)
emit("  node S3 -270")
out += run(SPUR_L, [(6000, 900, "292")], [], spur_lat)
emit("  node S4 -90")
rest = W - SPUR_X - SPUR_W
out += run(rest, [(6000, 900, "207"), (16000, 900, "209"), (26000, 900, "211")],
           spaced(rest, 4000, 2000), north_lat)
emit("  node B -270")
east_lat = EAST // 2
out += run(H, [(8000, 900, "213"), (20000, 900, "215")], spaced(H, 5000, 5000), east_lat)
emit("  node C -270")
south_lat = SOUTH // 2
out += run(W, [(10000, 900, "217"), (30000, 900, "219"), (48000, 900, "221")],
           spaced(W, 7000, 5000), south_lat)
emit("  node D -270")
west_lat = WEST // 2
out += run(H, [(12000, 900, "223")], [], west_lat)
emit("end")
emit()

# The block of rooms, anticlockwise from its north-east corner, heading West.
bx0, bx1, by0, by1 = WEST, W - EAST, SOUTH, H - NORTH
emit(f"ring block at {bx1} {by1} heading 90")
emit("  node P -90")
out += run(bx1 - bx0, [(6000, 900, "102"), (20000, 900, "104"), (36000, 900, "106"), (48000, 900, "108")],
           [], north_lat)
emit("  node Q -90")
out += run(by1 - by0, [(9000, 900, "110")], [], west_lat)
emit("  node R -90")
out += run(bx1 - bx0, [(8000, 900, "112"), (27000, 900, "114"), (44000, 900, "116")], [], south_lat)
emit("  node S -90")
out += run(by1 - by0, [(11000, 900, "118")], [], east_lat)
emit("end")
emit()
emit("# Across the four turning spaces.")
emit("link outer.A block.Q")
emit("link outer.B block.P")
emit("link outer.C block.S")
emit("link outer.D block.R")

print("\n".join(out))
