#!/usr/bin/env python3
"""Writes the upper floors of the EB3 tower (maps/data/tower.bldg): the
third floor's plan again, with each floor's own room numbers (350 on the
third floor is 450 on the fourth, A350 is A450). The elevators keep their
numbers, which is what joins the floors.

    python3 maps/tools/tower.py 4 > maps/data/tower-4.stk
    python3 maps/tools/tower.py 5 > maps/data/tower-5.stk
"""
import pathlib
import re
import sys

EB3 = pathlib.Path(__file__).resolve().parent.parent / "data" / "eb3.stk"
# A room number of the third floor: 350, 303.second, A350.
ROOM = re.compile(r"^(A?)3(\d\d.*)$")


def renumber(label, floor):
    m = ROOM.match(label)
    return f"{m.group(1)}{floor}{m.group(2)}" if m else label


def floor_text(floor):
    out = [f"# Floor {floor} of the EB3 tower: written by maps/tools/tower.py from",
           "# eb3.stk, the third floor's plan with this floor's room numbers.",
           ""]
    for line in EB3.read_text().splitlines():
        if line.startswith("#"):
            continue
        if line.startswith("map "):
            out.append(f"map EB3 tower, floor {floor}")
            continue
        words = line.split(" ")
        for i, w in enumerate(words[:-1]):
            if w in ("number", "plate"):
                words[i + 1] = renumber(words[i + 1], floor)
        out.append(" ".join(words))
    return "\n".join(out).strip("\n") + "\n"


if __name__ == "__main__":
    if len(sys.argv) != 2 or not sys.argv[1].isdigit() or sys.argv[1] == "3":
        sys.exit("usage: tower.py FLOOR   (4 or higher: floor 3 is eb3.stk itself)")
    sys.stdout.write(floor_text(sys.argv[1]))
