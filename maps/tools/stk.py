"""What the map writers in maps/tools share: the edges of one straight
wall of a StickRep ring (docs/stickrep.md). Units are millimetres."""


def run(length, doors, lights, lateral, plates=True):
    """Edges along one straight wall of `length`: doors (start offset,
    width, number, and optionally a kind other than "door", such as
    "elevator"), lights at offsets from the run's start; every edge
    carries `lateral`. Yields the text of the edges and jamb nodes. Only
    doors get a plate beside them."""
    cuts = []
    pos = 0
    for start, width, number, *kind in sorted(doors):
        cuts.append(("wall", pos, start, None))
        cuts.append((kind[0] if kind else "door", start, start + width, number))
        pos = start + width
    cuts.append(("wall", pos, length, None))
    lines = []
    for i, (kind, a, b, number) in enumerate(cuts):
        opts = [f"lateral {lateral}"]
        here = [l - a for l in lights if a < l <= b]
        if here:
            opts.append("lights " + " ".join(str(x) for x in here))
        if number is not None:
            opts.append(f"number {number}")
        elif plates and i + 1 < len(cuts):
            # The plate beside the next door, 300 mm before it.
            nxt = cuts[i + 1][3]
            if nxt is not None and cuts[i + 1][0] == "door" and b - a > 600:
                opts.append(f"plate {nxt} {b - a - 300}")
        lines.append(f"  {kind} {b - a} " + " ".join(opts))
        if i + 1 < len(cuts):
            jamb = f"{cuts[i + 1][3] or number}{'a' if kind == 'wall' else 'b'}"
            lines.append(f"  node {jamb} 180")
    return lines
