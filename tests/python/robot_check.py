"""A RoME hardware-server client in Python that knows nothing but docs/keys.md.

Usage: python robot_check.py PORT   (rome sim, robot r1, on 127.0.0.1:PORT)
Prints one line per check and a closing 'N passed, M failed'.
"""

import json
import sys

from checks import Tally, first_reply, session

z = session(int(sys.argv[1]), "client")
tally = Tally()
check = tally.check


def ask(selector, payload=None):
    """The first reply: ('ok', sample) or ('err', error object)."""
    return first_reply(z, selector, payload)


def js(selector, payload=None):
    kind, body = ask(selector, payload)
    if kind != "ok":
        raise RuntimeError(f"{selector}: {kind} {body}")
    return json.loads(body.payload.to_string())


base = "rome/robot/r1/base"
js(f"{base}/set-pose", '{"x_mm":0,"y_mm":0,"heading_deg":0}')
pose = js(f"{base}/pose")
check("pose reads what set-pose set", pose["x_mm"] == 0 and pose["y_mm"] == 0, pose)
done = js(f"{base}/move", '{"distance_mm":500,"velocity_mm_s":400}')
check("move answers with point_go", done["mode"] == "point_go", done)
check("mode", js(f"{base}/mode")["mode"] in ("point_go", "go"))
check("bumper status is an integer", isinstance(js(f"{base}/bumper")["status"], int))

sonar = js("rome/robot/r1/proximity/sonar")["sonar_mm"]
check("24 sonar ranges in mm", len(sonar) == 24 and all(0 < r <= 10000 for r in sonar), sonar)
ir = js("rome/robot/r1/proximity/ir")["ir"]
check("24 infrared values", len(ir) == 24 and set(ir) <= {0, 1}, ir)

size = js("rome/robot/r1/camera/up/size")
kind, rows = ask("rome/robot/r1/camera/up/rows?rows=120,241,360")
enc = str(rows.encoding)
check("three rows in one reply", len(rows.payload.to_bytes()) == 3 * size["width"], enc)
check("rows encoding says gray8 and the rows", "gray8" in enc and "rows=120,241,360" in enc, enc)

grant = js(f"{base}/lock?owner=py;ttl_ms=5000")
fence = grant["fence"]
check("lock grants a fence", isinstance(fence, int), grant)
js(f"{base}/stop?fence={fence}")
kind, err = ask(f"{base}/stop?wait_ms=300")
check("others wait behind the lock, then time out", kind == "err" and err["code"] == "timed_out", err)
check("unlock", js(f"{base}/unlock?fence={fence}")["released"] is True)
kind, err = ask(f"{base}/stop?fence={fence}")
check("a stale fence is refused", kind == "err" and err["code"] == "stale_fence", err)
kind, err = ask(f"{base}/go", '{"velocity_mm_s":"fast"}')
check("wrong type named", kind == "err" and err["code"] == "wrong_type" and "velocity_mm_s" in err["message"], err)

got = []
sub = z.declare_subscriber("rome/robot/r1/proximity/scan", lambda s: got.append(json.loads(s.payload.to_string())))
import time

deadline = time.time() + 5
while len(got) < 3 and time.time() < deadline:
    time.sleep(0.05)
check("scan stream", len(got) >= 3 and got[-1]["seq"] > got[0]["seq"], len(got))

tally.finish(z, "")
