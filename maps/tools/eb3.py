#!/usr/bin/env python3
"""Writes maps/data/eb3.stk, the reconstruction of the third floor of the
MSU Engineering Building (Appendix A, Figure 6.1, Tables 6.1-6.3).

The thesis does not give the floor plan. This script lays the corridors out
by their centre lines and places every door by coordinates chosen so that the
routes of Tables 6.1-6.2 come out near their published lengths; see
docs/eb3.md for how near. Edit the layout here and run

    python3 maps/tools/eb3.py > maps/data/eb3.stk

Units here are metres; the map file is in millimetres.
"""

OLD = 1.83  # half the old wing's corridor width (3.66 m, §5.6)
NEW = 1.22  # half the narrower new wing's corridor width (2.44 m)

# Corridor centre lines.
Y_A = 104.0  # corridor A (north)
Y_M = 55.5  # corridor M (between the wings)
Y_P = 6.5  # corridor P (new wing, south)
X_B = 8.0  # corridor B (old wing, west); corridor G continues it south
X_C = 128.0  # corridor C (old wing, east)
X_N = 60.0  # corridor N (new wing, middle)
X_J = 112.0  # corridor J (new wing, east)


def door(number, a, b, kind="door", plate=True, **tags):
    """A door between the axis coordinates a and b (either order)."""
    return {"kind": kind, "a": min(a, b), "b": max(a, b), "number": number, "plate": plate, "tags": tags}


def jamb(number, first, width, toward, **kw):
    """A door whose jamb `first` is at a coordinate; the other is `width`
    further in direction `toward` (+1 or -1)."""
    return door(number, first, first + toward * width, **kw)


def rooms(numbers, lo, hi, width=0.9, **kw):
    """Doors spread evenly between lo and hi (centres), in the given order."""
    out = []
    n = len(numbers)
    for i, num in enumerate(numbers):
        c = lo + (hi - lo) * (i + 0.5) / n
        out.append(door(num, c - width / 2, c + width / 2, **kw))
    return out


def feature(kind, a, b, **tags):
    return {"kind": kind, "a": min(a, b), "b": max(a, b), "number": None, "plate": False, "tags": tags}


def island(west, east, south, north):
    """The corners of a block of rooms, traced anticlockwise from its
    north-east corner (the wall on the left, walking in the corridor)."""
    return [
        ("NE", east, north, True),
        ("NW", west, north, True),
        ("SW", west, south, True),
        ("SE", east, south, True),
    ]


def lights(lo, hi, step):
    n = int((hi - lo) // step)
    return [lo + i * step for i in range(n + 1)]


# Rings: vertices in tracing order (wall on the left), each side's axis
# features and lights. A side runs from vertex i to vertex i+1.
#   vertex: (name, x, y, corner)
#   side: dict(lights=[axis coords], lateral=m, features=[...], tags={})

outer = {
    "name": "outer",
    "vertices": [
        ("NW", X_B - OLD, Y_A + OLD, True),
        ("NE", X_C + OLD, Y_A + OLD, True),
        ("SE", X_C + OLD, Y_M - OLD, True),
        ("MJ", X_J + NEW, Y_M - OLD, True),
        ("JP", X_J + NEW, Y_P - NEW, True),
        ("SW", X_B - NEW, Y_P - NEW, True),
        ("GB", X_B - NEW, Y_M - OLD, False),
        ("BG", X_B - OLD, Y_M - OLD, False),
    ],
    "sides": [
        # North wall of corridor A, traced West to East: odd rooms.
        {
            "lateral": OLD,
            "lights": [-(X_B)] + lights(14.0, 122.0, 6.0),
            "features": [
                jamb("NW.men's", 9.17, 0.9, +1),
            ]
            + rooms([str(n) for n in range(389, 381, -2)], 12.0, 30.5)
            + [jamb("381", 31.196, 0.9, +1)]
            + rooms([str(n) for n in range(379, 345, -2) if n != 365], 33.5, 99.8)
            + [
                jamb("345", 101.521, 0.9, -1),
                jamb("343", 105.059, 0.9, -1),
                jamb("341", 106.5, 0.9, +1),
                jamb("339", 110.0, 0.9, +1),
                jamb("acs.lab", 116.0, 1.8, +1),
                jamb("NE.men", 124.45, 0.9, -1),
            ],
        },
        # East wall of corridor C, North to South: even rooms. The first
        # edge closes corridor A's east end: the glass door of the ACS
        # laboratory, which sonar does not see (Table 6.1, note a).
        {
            "lateral": OLD,
            "lights": lights(98.0, 62.0, -6.0),
            "features": [door("acs.lab.glass", Y_A + OLD, Y_A - OLD, kind="glass", plate=False)]
            + rooms(["340.cmptr.room", "332", "326", "320", "314", "308"], 98.0, 60.0, width=1.2),
        },
        # South wall of corridor M east of J (old wing side of the junction).
        {
            "lateral": OLD,
            "lights": [],
            "features": [],
        },
        # East wall of corridor J, North to South: two lights only.
        {
            "lateral": NEW,
            "lights": [44.0, 20.0],
            "features": rooms(["A302", "A304", "A306"], 50.0, 10.0),
        },
        # South wall of corridor P, East to West.
        {
            "lateral": NEW,
            "lights": lights(104.0, 12.0, -6.0),
            "features": rooms(["A388", "A390"], 100.0, 70.0)
            + [jamb("A392", 60.198, 0.898, -1)]
            + rooms(["A394", "A396", "A398"], 50.0, 14.0),
        },
        # West wall of corridor G, South to North: two lights only, and the
        # glass bricks that fool the plate finder (Table 6.3).
        {
            "lateral": NEW,
            "lights": [18.0, 42.0],
            "features": [
                jamb("A365", 16.385, 0.9, +1),
                jamb("A367", 19.5, 0.9, +1),
                jamb("A371", 22.5, 0.9, +1),
                feature("window", 24.5, 29.0, bricks="yes"),
                jamb("A377", 30.0, 0.9, +1),
                jamb("A381", 33.0, 0.9, +1),
                jamb("A385", 38.0, 0.9, -1),
                jamb("A391", 41.0, 0.9, +1),
                jamb("A395", 45.0, 0.9, +1),
                jamb("A397", 49.0, 0.9, +1),
            ],
        },
        # The step where the narrow corridor G meets the wide corridor B.
        {"lateral": OLD, "lights": [], "features": []},
        # West wall of corridor B, South to North.
        {
            "lateral": OLD,
            "lights": lights(62.0, 98.0, 6.0) + [-Y_A],
            "features": rooms(["NW.women", "390", "392"], 62.0, 98.0),
        },
    ],
}

island_a = {
    "name": "A",
    "vertices": island(X_B + OLD, X_C - OLD, Y_M + OLD, Y_A - OLD),
    "sides": [
        # South wall of corridor A, East to West: even rooms, elevators.
        {
            "lateral": OLD,
            "lights": [],
            "features": [
                jamb("acs.elev", 123.0, 2.0, -1, kind="elevator", marker="010"),
                jamb("346", 119.5, 0.9, -1),
                jamb("350.1", 116.4, 0.9, -1),
                jamb("350.2", 114.9, 0.9, -1),
                jamb("350", 112.858, 1.829, -1),
            ]
            + rooms(["352", "354", "356", "358", "360"], 110.0, 80.0)
            + [
                jamb("364.double", 78.5, 1.8, -1),
                feature("wall", 74.0, 75.5, poster="750"),
                jamb("364", 72.0, 0.9, -1),
                jamb("368", 66.0, 0.9, -1),
                jamb("old.elevator", 61.0, 2.0, -1, kind="elevator", marker="101"),
                jamb("372", 51.289, 0.9, -1),
                jamb("376", 32.848, 0.9, -1),
            ]
            + rooms(["380", "382", "384"], 31.0, 14.0)
            + [jamb("388", 12.45, 0.9, -1)],
        },
        # East wall of corridor B, North to South.
        {"lateral": OLD, "lights": [], "features": rooms(["391", "393"], 98.0, 62.0)},
        # North wall of corridor M, West to East: 301, 302, 303.
        {
            "lateral": OLD,
            "lights": lights(14.0, 122.0, 6.0),
            "features": rooms(["399", "397", "395"], 12.0, 36.0)
            + [jamb("301", 38.785, 0.9, -1)]
            + rooms(["301.second"], 45.0, 56.0)
            + [jamb("302", 58.5, 0.9, +1)]
            + rooms(["305", "307"], 62.0, 80.0)
            + [jamb("303", 82.0, 0.9, +1), jamb("303.second", 86.487, 0.915, -1)]
            + rooms(["309"], 90.0, 106.0)
            + [feature("wall", 109.22, 114.78, floor="metal")]
            + rooms(["310"], 116.0, 125.0),
        },
        # West wall of corridor C, South to North: odd rooms.
        {
            "lateral": OLD,
            "lights": [],
            "features": [
                jamb("317.2", 57.9, 0.9, +1),
                jamb("317.1", 59.5, 0.9, +1),
                jamb("323", 61.0, 0.9, +1),
            ]
            + rooms(["325", "327", "329", "331", "333", "335"], 64.0, 96.0)
            + [jamb("NE.women", 98.5, 0.9, +1)],
        },
    ],
}

island_b = {
    "name": "B",
    "vertices": island(X_B + NEW, X_N - NEW, Y_P + NEW, Y_M - OLD),
    "sides": [
        # South wall of corridor M, East to West.
        {"lateral": OLD, "lights": [], "features": rooms(["A318", "A316", "A312"], 56.0, 12.0)},
        # East wall of corridor G, North to South.
        {"lateral": NEW, "lights": [], "features": rooms(["A399", "A389", "A383", "A379", "A373", "A369"], 50.0, 12.0)},
        # North wall of corridor P, West to East.
        {"lateral": NEW, "lights": [], "features": rooms(["A360", "A358", "A356", "A352"], 12.0, 56.0)},
        # East wall of corridor N, South to North: two lights only.
        {
            "lateral": NEW,
            "lights": [18.0, 40.0],
            "features": [
                jamb("A342", 14.0, 0.9, +1),
                jamb("A340", 21.415, 0.915, -1),
                jamb("A338", 25.5, 0.9, +1),
                jamb("A336", 29.5, 0.9, +1),
                jamb("A334", 33.5, 0.9, +1),
                jamb("A332", 37.5, 0.9, +1),
                jamb("A330", 41.5, 0.9, +1),
                jamb("A328", 45.5, 0.9, +1),
                jamb("A326", 49.0, 0.9, +1),
                jamb("A323", 52.633, 0.9, -1),
            ],
        },
    ],
}

island_c = {
    "name": "C",
    "vertices": island(X_N + NEW, X_J - NEW, Y_P + NEW, Y_M - OLD),
    "sides": [
        # South wall of corridor M, East to West: 311, 311.double, A313, A314.
        {
            "lateral": OLD,
            "lights": [],
            "features": [
                jamb("311", 108.034, 1.829, -1),
                jamb("A313", 104.921, 0.921, -1),
                jamb("A314", 101.075, 0.9, +1),
                jamb("311.double", 99.093, 1.828, -1),
            ]
            + rooms(["A319", "A321", "A322"], 94.0, 64.0),
        },
        # West wall of corridor N, North to South.
        {
            "lateral": NEW,
            "lights": [],
            "features": [
                jamb("A325", 52.0, 0.9, -1),
                jamb("A331", 39.0, 0.9, -1),
                jamb("A335", 32.0, 0.9, -1),
                jamb("A339", 27.5, 0.9, -1),
                jamb("A347", 24.0, 0.9, -1),
                jamb("A349", 12.0, 0.9, -1),
            ],
        },
        # North wall of corridor P, West to East.
        {"lateral": NEW, "lights": [], "features": rooms(["A351", "A353", "A355", "A357"], 64.0, 108.0)},
        # West wall of corridor J, South to North.
        {"lateral": NEW, "lights": [], "features": rooms(["A301", "A303", "A305"], 12.0, 50.0)},
    ],
}

LINKS = [
    ("outer.NW", "A.NW"),
    ("outer.NE", "A.NE"),
    ("outer.SE", "A.SE"),
    ("A.SW", "B.NW"),
    ("outer.MJ", "C.NE"),
    ("B.NE", "C.NW"),
    ("outer.SW", "B.SW"),
    ("B.SE", "C.SW"),
    ("outer.JP", "C.SE"),
]


def heading(dx, dy):
    import math

    return math.degrees(math.atan2(-dx, dy))


def norm(a):
    while a <= -180:
        a += 360
    while a > 180:
        a -= 360
    return a


def mm(v):
    return int(round(v * 1000))


def emit_ring(ring, out):
    vs = ring["vertices"]
    n = len(vs)
    # Each side: list of (kind, length, options, end-node name).
    headings = []
    for i in range(n):
        (_, x0, y0, _), (_, x1, y1, _) = vs[i], vs[(i + 1) % n]
        headings.append(heading(x1 - x0, y1 - y0))
    x0, y0 = vs[0][1], vs[0][2]
    out.append(f"ring {ring['name']} at {mm(x0)} {mm(y0)} heading {norm(headings[0]):.0f}")
    for i, side in enumerate(ring["sides"]):
        name, x0, y0, corner = vs[i]
        _, x1, y1, _ = vs[(i + 1) % n]
        horizontal = abs(y1 - y0) < 1e-9
        a0, a1 = (x0, x1) if horizontal else (y0, y1)
        sign = 1 if a1 > a0 else -1
        turn = norm(headings[i] - headings[i - 1])
        angle = 180 - turn
        out.append(f"  node {name} {-angle if corner else angle:.0f}")

        def along(v):  # axis coordinate -> distance from the side's start
            return (v - a0) * sign

        feats = sorted(side["features"], key=lambda f: along(f["a"] if sign > 0 else f["b"]))
        cursor = 0.0
        pieces = []  # (kind, start, end, feature)
        for f in feats:
            s, e = sorted((along(f["a"]), along(f["b"])))
            if s < cursor - 1e-6 or e > abs(a1 - a0) + 1e-6:
                raise SystemExit(f"ring {ring['name']} side {i}: {f.get('number') or f['kind']} overlaps or leaves the wall")
            if s > cursor + 1e-6:
                pieces.append(("wall", cursor, s, None))
            pieces.append((f["kind"], s, e, f))
            cursor = e
        if cursor < abs(a1 - a0) - 1e-6:
            pieces.append(("wall", cursor, abs(a1 - a0), None))
        # Lights: positive axis coords, or negative = turning-space pair.
        light_at = []
        for l in side["lights"]:
            if l < 0:
                light_at.append((along(-l), True))
            else:
                light_at.append((along(l), False))
        # Plates go on the wall piece just before each numbered door.
        for k, (kind, s, e, f) in enumerate(pieces):
            opts = []
            mine = [(d, neg) for d, neg in light_at if s + 1e-6 < d <= e + 1e-6]
            if mine:
                opts.append("lights " + " ".join(str(-mm(d - s) if neg else mm(d - s)) for d, neg in mine))
            if abs(side["lateral"] - 1.83) > 1e-6:
                opts.append(f"lateral {mm(side['lateral'])}")
            if f and f["number"]:
                opts.append(f"number {f['number']}")
            nxt = pieces[k + 1][3] if k + 1 < len(pieces) else None
            if kind == "wall" and nxt and nxt["number"] and nxt["plate"] and e - s > 0.35:
                opts.append(f"plate {nxt['number']} {mm(e - s - 0.3)}")
            tags = dict(side.get("tags", {}))
            if f:
                tags.update(f.get("tags", {}))
            if "poster" in tags:
                tags["poster"] = str(min(int(tags["poster"]), mm(e - s) - 300))
            opts.extend(f"{key}={val}" for key, val in sorted(tags.items()))
            out.append(f"  {kind} {mm(e - s)}" + ("  " + " ".join(opts) if opts else ""))
            if k + 1 < len(pieces):
                node = nxt["number"] if nxt and nxt["number"] else None
                if f and f["number"]:
                    out.append(f"  node {f['number']}.b 180")
                elif node:
                    out.append(f"  node {node}.a 180")
                else:
                    out.append(f"  node {name}.{k + 1} 180")
    out.append("end")
    out.append("")


def main():
    out = [
        "# The third floor of the MSU Engineering Building, reconstructed",
        "# (Appendix A: four rings, the outer one enclosing regions A, B and C).",
        "#",
        "# The thesis does not give the floor plan; this layout is made up to be",
        "# plausible and to keep the routes of Tables 6.1-6.2 near their published",
        "# lengths (docs/eb3.md says how near). Generated by maps/tools/eb3.py:",
        "# edit the layout there.",
        "#",
        "# Old wing: corridors A (north), B (west), C (east) and M (between the",
        "# wings), 3.66 m wide. New wing: corridors G, N and J (2.44 m wide, two",
        "# ceiling lights each: the trouble spots of §6.1) and P (south).",
        "# Odd rooms line the north wall of A, even rooms its south wall.",
        "",
        "map MSU Engineering Building, third floor (reconstruction)",
        "tolerance 50",
        "lateral 1830",
        "",
    ]
    for ring in (outer, island_a, island_b, island_c):
        emit_ring(ring, out)
    out.append("# Where paths cross between rings: corners facing each other across")
    out.append("# the turning spaces.")
    for a, b in LINKS:
        out.append(f"link {a} {b}")
    print("\n".join(out))


main()
