"""A ROS 2 node (rclpy, on DDS) that looks at a RoME fleet through
`rome router --ros2` and `rome ros2`, and prints what it saw as one JSON
line. It judges nothing: the test that runs it does.

    python probe.py --seconds 60

What it does, in order:
1. Waits until the graph lists r1's and r2's odometry, r1's sonar, camera
   and ground truth, and r1's cmd_vel, and records their types.
2. Takes two odometry messages of each robot, a sonar scan of r1 and one
   image of r1's upward camera.
3. Publishes cmd_vel to r1 (0.3 m/s) ten times a second for two seconds,
   recording both robots' ground truth before, at the last command, and
   1 s and 2.5 s after it, and r1's odometry at the end.
"""

import argparse
import json
import sys
import time

import rclpy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Image, LaserScan

WANTED = {
    "/r1/odom": "nav_msgs/msg/Odometry",
    "/r2/odom": "nav_msgs/msg/Odometry",
    "/r1/sonar": "sensor_msgs/msg/LaserScan",
    "/r1/ground_truth": "nav_msgs/msg/Odometry",
    "/r2/ground_truth": "nav_msgs/msg/Odometry",
    "/r1/camera/up/image": "sensor_msgs/msg/Image",
    "/r1/cmd_vel": "geometry_msgs/msg/Twist",
}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=60.0)
    args = parser.parse_args()
    deadline = time.monotonic() + args.seconds
    rclpy.init()
    node = rclpy.create_node("rome_probe")
    out = {"graph": {}, "odom": {"r1": [], "r2": []}, "errors": []}
    latest = {}

    def spin_until(done, what):
        while not done():
            if time.monotonic() > deadline:
                out["errors"].append("timed out waiting for " + what)
                return False
            rclpy.spin_once(node, timeout_sec=0.05)
        return True

    def keep(name):
        def cb(msg):
            latest[name] = msg
            if name in ("r1/odom", "r2/odom"):
                robot = name.split("/")[0]
                if len(out["odom"][robot]) < 2:
                    p = msg.pose.pose.position
                    out["odom"][robot].append([p.x, p.y])
        return cb

    def graph_ready():
        topics = dict(node.get_topic_names_and_types())
        for t in WANTED:
            if t in topics:
                out["graph"][t] = topics[t]
        return all(t in out["graph"] for t in WANTED)

    spin_until(graph_ready, "the bridged topics in the graph")

    subs = [
        # ROS 2's default QoS (reliable) for odometry, SensorDataQoS (best
        # effort) for the rest: the bridge's topics serve both.
        node.create_subscription(Odometry, "/r1/odom", keep("r1/odom"), 10),
        node.create_subscription(Odometry, "/r2/odom", keep("r2/odom"), 10),
        node.create_subscription(LaserScan, "/r1/sonar", keep("r1/sonar"), qos_profile_sensor_data),
        node.create_subscription(Odometry, "/r1/ground_truth", keep("r1/truth"), qos_profile_sensor_data),
        node.create_subscription(Odometry, "/r2/ground_truth", keep("r2/truth"), qos_profile_sensor_data),
        node.create_subscription(Image, "/r1/camera/up/image", keep("r1/image"), qos_profile_sensor_data),
    ]
    have = lambda *names: lambda: all(n in latest for n in names)
    spin_until(have("r1/odom", "r2/odom", "r1/sonar", "r1/truth", "r2/truth", "r1/image"),
               "a message on every topic")
    spin_until(lambda: len(out["odom"]["r1"]) >= 2 and len(out["odom"]["r2"]) >= 2,
               "two odometry messages of each robot")
    if "r1/sonar" in latest:
        out["sonar_ranges"] = len(latest["r1/sonar"].ranges)
    if "r1/image" in latest:
        i = latest["r1/image"]
        out["image"] = {"width": i.width, "height": i.height, "encoding": i.encoding,
                        "bytes": len(i.data)}
    node.destroy_subscription(subs[5])

    def truth(robot):
        m = latest.get(robot + "/truth")
        if m is None:
            return None
        p = m.pose.pose.position
        return [p.x, p.y]

    def wait_s(s):
        end = time.monotonic() + s
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.02)

    # Matched before the first command, so none is lost to discovery.
    publisher = node.create_publisher(Twist, "/r1/cmd_vel", 10)
    spin_until(lambda: publisher.get_subscription_count() > 0, "the bridge reading /r1/cmd_vel")
    out["truth_before"] = {"r1": truth("r1"), "r2": truth("r2")}
    twist = Twist()
    twist.linear.x = 0.3
    for _ in range(20):
        publisher.publish(twist)
        wait_s(0.1)
    out["truth_last_command"] = {"r1": truth("r1"), "r2": truth("r2")}
    wait_s(1.0)
    out["truth_1s_after"] = {"r1": truth("r1"), "r2": truth("r2")}
    wait_s(1.5)
    out["truth_2_5s_after"] = {"r1": truth("r1"), "r2": truth("r2")}
    odom = latest.get("r1/odom")
    if odom is not None:
        p = odom.pose.pose.position
        out["odom_after"] = {"r1": [p.x, p.y]}
    print(json.dumps(out), flush=True)
    node.destroy_node()
    rclpy.shutdown()
    return 0 if not out["errors"] else 1


if __name__ == "__main__":
    sys.exit(main())
