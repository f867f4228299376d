"""A RoME data-server client in Python that knows nothing but docs/keys.md.

Usage: python keys_check.py PORT   (a data server listening on 127.0.0.1:PORT)
Prints one line per check and a closing 'N passed, M failed'.
"""

import json
import sys
import time

from checks import Tally, first_reply, session

z = session(int(sys.argv[1]), "peer")
tally = Tally()
check = tally.check


def ask(selector, payload=None):
    """The first reply: ('ok', json) or ('err', json)."""
    kind, body = first_reply(z, selector, payload)
    if kind == "ok":
        return kind, json.loads(body.payload.to_string())
    return kind, body


# The server is there when its liveliness token is.
alive = z.liveliness().declare_subscriber("rome/alive/server/data/*", history=True)
check("data server token seen", alive.recv() is not None)

watch = z.declare_subscriber("rome/data/watch/PosX")
# A query answered over the same link proves the subscription reached the server.
ask("rome/data/var/**")

for v in (4, 5, 6):
    z.put("rome/data/var/PosX", str(v))
check("get after put", ask("rome/data/var/PosX") == ("ok", 6))
check("get back=2", ask("rome/data/var/PosX?back=2") == ("ok", 4))
commits = [json.loads(watch.recv().payload.to_string()) for _ in range(3)]
check("watch sees each commit in order", [c["seq"] for c in commits] == [1, 2, 3]
      and [c["value"] for c in commits] == [4, 5, 6], commits)

status, reply = ask("rome/data/set/Pose?op=py.1", '{"x_mm":1200,"y_mm":-350}')
check("acknowledged set", (status, reply) == ("ok", {"name": "Pose", "seq": 1}), reply)
status, reply = ask("rome/data/set/Pose?op=py.1", '{"x_mm":1200,"y_mm":-350}')
check("repeated op id is not committed twice", reply == {"name": "Pose", "seq": 1}, reply)
status, reply = ask("rome/data/history/PosX?len=2")
check("set history", reply == {"name": "PosX", "len": 2, "stored": 2, "seq": 3}, reply)
names = sorted(str(r.ok.key_expr) for r in z.get("rome/data/var/**") if r.ok is not None)
check("list variables", names == ["rome/data/var/PosX", "rome/data/var/Pose"], names)

status, reply = ask("rome/data/history/PosX?len=-3")
check("negative history is refused", status == "err" and reply["code"] == "out_of_range", reply)
status, reply = ask("rome/data/set/PosX", "{not json")
check("bad JSON is refused", status == "err" and reply["code"] == "bad_json", reply)

check("create semaphore", ask("rome/data/create/GoalData?value=0")[1]
      == {"name": "GoalData", "created": True, "value": 0})
status, reply = ask("rome/data/try-wait/GoalData?op=py.2")
check("try-wait on 0", reply["acquired"] is False, reply)
status, reply = ask("rome/data/wait/GoalData?hold_ms=200")
check("anonymous wait times out", reply["status"] == "timed_out", reply)
check("signal", ask("rome/data/signal/GoalData?op=py.3")[1]["value"] == 1)
status, reply = ask("rome/data/wait/GoalData?hold_ms=2000")
check("wait granted", reply["status"] == "granted", reply)
z.put("rome/data/signal/GoalData", "")
status, reply = ask("rome/data/sem/GoalData")
check("put-signal then read", reply == {"name": "GoalData", "value": 1, "waiters": 0, "held": 0}, reply)
status, reply = ask("rome/data/signal/Nope")
check("unknown semaphore is refused", status == "err" and reply["code"] == "unknown_semaphore", reply)

tokens = [str(r.ok.key_expr) for r in z.liveliness().get("rome/alive/**") if r.ok is not None]
check("liveliness lists the data server", any(t.startswith("rome/alive/server/data/") for t in tokens), tokens)

tally.finish(z, "python client: ")
