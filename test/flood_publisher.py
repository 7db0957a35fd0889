"""A flooding publisher for test_flood.py, run as its own process (``sys.executable flood_publisher.py``).

It waits until its publisher has matched a subscription, prints ``ready`` on stdout, publishes
WrenchStamped messages at ``--rate`` Hz on an absolute schedule for ``--duration`` seconds,
then prints one JSON line ``{"published": n, "seconds": t}`` and exits. Modes:

``wrench``/``impulse``
    The same valid message every time: force (or linear impulse) ``--force`` in ``--frame``.
``hostile``
    A rotating mix of messages the node must drop: NaN, ±Inf, 1e300, unknown and 100 kB
    frame_ids.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import rclpy
from geometry_msgs.msg import WrenchStamped
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node


def hostile_messages(frame: str) -> list[WrenchStamped]:
    out = []
    for frame_id, values in [
        (frame, (math.nan, 0.0, 0.0, 0.0, 0.0, 0.0)),
        (frame, (0.0, math.inf, 0.0, 0.0, 0.0, -math.inf)),
        (frame, (1e300, 0.0, 0.0, 0.0, 0.0, 0.0)),
        ("map", (1.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
        ("x" * 100_000, (1.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ]:
        msg = WrenchStamped()
        msg.header.frame_id = frame_id
        f, t = msg.wrench.force, msg.wrench.torque
        f.x, f.y, f.z, t.x, t.y, t.z = values
        out.append(msg)
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--topic", required=True)
    parser.add_argument("--frame", required=True)
    parser.add_argument("--mode", choices=("wrench", "impulse", "hostile"), default="wrench")
    parser.add_argument("--force", type=float, nargs=3, default=(1.0, 0.0, 0.0))
    parser.add_argument("--rate", type=float, required=True, help="messages per second")
    parser.add_argument("--duration", type=float, required=True, help="seconds of flooding")
    args = parser.parse_args()

    context = Context()
    rclpy.init(context=context)
    node = Node("flood_publisher", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        pub = node.create_publisher(WrenchStamped, args.topic, 10)
        deadline = time.monotonic() + 30.0
        while pub.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                print(json.dumps({"error": f"no subscription on {args.topic} after 30 s"}), flush=True)
                return 1
            executor.spin_once(timeout_sec=0.01)
        if args.mode == "hostile":
            messages = hostile_messages(args.frame)
        else:
            msg = WrenchStamped()
            msg.header.frame_id = args.frame
            msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = args.force
            messages = [msg]
        print("ready", flush=True)
        period = 1.0 / args.rate
        start = time.monotonic()
        end = start + args.duration
        published = 0
        next_time = start
        while True:
            now = time.monotonic()
            if now >= end:
                break
            if now < next_time:
                time.sleep(next_time - now)
                continue
            pub.publish(messages[published % len(messages)])
            published += 1
            next_time = start + published * period  # absolute schedule: no drift
        print(json.dumps({"published": published, "seconds": time.monotonic() - start}), flush=True)
        return 0
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)


if __name__ == "__main__":
    sys.exit(main())
