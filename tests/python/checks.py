"""What the Python checks share: a Zenoh session on loopback, the tally of
checks, and one query's first reply. Nothing here knows RoME: the checks
themselves follow docs/keys.md alone.
"""

import json
import sys

import zenoh


def session(port, mode):
    """A Zenoh session in `mode` joined to 127.0.0.1:`port`, scouting off."""
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps(mode))
    conf.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    if mode == "peer":
        conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(conf)


class Tally:
    """Prints one line per check; `finish` prints 'N passed, M failed' and exits."""

    def __init__(self):
        self.passed, self.failed = 0, 0

    def check(self, what, ok, detail=""):
        if ok:
            self.passed += 1
            print(f"ok    {what}")
        else:
            self.failed += 1
            print(f"FAIL  {what} {detail}")

    def finish(self, z, label):
        z.close()
        print(f"{label}{self.passed} passed, {self.failed} failed")
        sys.exit(1 if self.failed else 0)


def first_reply(z, selector, payload=None):
    """The first reply: ('ok', sample), ('err', error object) or ('none', None)."""
    for reply in z.get(selector, payload=payload, timeout=10.0):
        if reply.ok is not None:
            return "ok", reply.ok
        return "err", json.loads(reply.err.payload.to_string())
    return "none", None
