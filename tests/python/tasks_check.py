"""Fleet tasks from Python, knowing nothing but docs/tasks.md and
docs/keys.md: a task added with a plain put, a robot played by hand through
its duty, a cancellation, and a task that is not one.

Usage: python tasks_check.py PORT   (a data server and `rome dispatcher`
reachable on 127.0.0.1:PORT). Prints one line per check and a closing
'N passed, M failed'.
"""

import json
import sys
import time

from checks import Tally, first_reply, session

z = session(int(sys.argv[1]), "peer")
tally = Tally()
check = tally.check


def get(name):
    """A variable's value, or None when it has none."""
    kind, sample = first_reply(z, f"rome/data/var/{name}")
    return json.loads(sample.payload.to_string()) if kind == "ok" else None


def set_(name, value):
    """An acknowledged write: committed when the reply comes."""
    kind, reply = first_reply(z, f"rome/data/set/{name}", json.dumps(value))
    return kind == "ok"


def until(what, read, ok, within=20.0):
    """Reads until `ok(value)`, at most `within` seconds; the last value."""
    end = time.monotonic() + within
    value = read()
    while not ok(value) and time.monotonic() < end:
        time.sleep(0.1)
        value = read()
    check(what, ok(value), value)
    return value


# A robot "py1" standing at 350R, taking tasks. Its Planner's liveliness is
# what tells the dispatcher the robot's crew is there.
owner = "py-planner-1"
token = z.liveliness().declare_token(f"rome/alive/client/planner/{owner}")
duty = {"at": "350R", "at_mm": None, "state": "idle", "task": None,
        "owner": owner, "last": None}
check("duty written", set_("nav/py1/Duty", duty))

# A task, added with a plain put (as a REST PUT would).
z.put("rome/data/var/fleet/task/py-1", json.dumps({"to": "356R"}))
task = until("the dispatcher hands py-1 to py1",
             lambda: get("nav/py1/Task"),
             lambda v: v is not None and v.get("task") == "py-1")
check("the assignment says where to go", task == {"task": "py-1", "to": "356R", "via": []}, task)
status = get("fleet/status/py-1")
check("status: assigned to py1", status is not None and status["state"] == "assigned"
      and status["robot"] == "py1" and status["tried"] == ["py1"], status)

# The robot drives there and says so.
set_("nav/py1/Duty", dict(duty, state="busy", task="py-1"))
set_("nav/py1/Duty", dict(duty, at="356R", last={"task": "py-1", "ok": True, "why": None}))
first_reply(z, "rome/data/signal/fleet/wake")
status = until("status: done", lambda: get("fleet/status/py-1"),
               lambda v: v is not None and v["state"] == "done")
check("done has an end time", status.get("ended_ms") is not None, status)

# A task only a robot that does not exist may do waits; cancelled, it ends.
z.put("rome/data/var/fleet/task/py-2", json.dumps({"to": "372L", "robot": "nobody", "priority": 3}))
until("status: py-2 queued", lambda: get("fleet/status/py-2"),
      lambda v: v is not None and v["state"] == "queued" and v["priority"] == 3)
z.put("rome/data/var/fleet/cancel/py-2", json.dumps({"why": "not needed"}))
status = until("status: py-2 cancelled", lambda: get("fleet/status/py-2"),
               lambda v: v is not None and v["state"] == "cancelled")
check("cancel gives its reason", status["why"] == ["cancelled: not needed"], status)

# A task that is not one fails with the reason, and the dispatcher goes on.
z.put("rome/data/var/fleet/task/py-bad", json.dumps({"to": 5}))
status = until("status: py-bad failed", lambda: get("fleet/status/py-bad"),
               lambda v: v is not None and v["state"] == "failed")
check("failure names the value", any("invalid type" in w for w in status["why"]), status)
z.put("rome/data/var/fleet/task/py-3", json.dumps({"to": "nowhere"}))
status = until("status: py-3 failed", lambda: get("fleet/status/py-3"),
               lambda v: v is not None and v["state"] == "failed")
check("an unknown position is named", any("nowhere" in w for w in status["why"]), status)

# The robot's crew goes: a task handed to it goes back to the queue.
z.put("rome/data/var/fleet/task/py-4", json.dumps({"to": "372L"}))
until("py-4 handed to py1", lambda: get("nav/py1/Task"),
      lambda v: v is not None and v.get("task") == "py-4")
token.undeclare()
status = until("py-4 back in the queue when py1's Planner is gone",
               lambda: get("fleet/status/py-4"),
               lambda v: v is not None and v["state"] == "queued" and v["why"])
check("and says why", "gone" in status["why"][0], status)

tally.finish(z, "tasks: ")
