#!/usr/bin/python3
"""Test helper node: records topics into a bag without ever dropping a message.

`rosbag record` subscribes with a queue of 100 per topic and drops messages when a lockstep
flight outruns it; this recorder's rospy subscriptions have no queue limit, and it writes the bag
(with python3-rosbag) when it is shut down (SIGINT).

    record_topics.py OUT.bag TOPIC:TYPE ...      (TYPE as package/Message)
"""

import importlib
import os
import sys

import rosbag
import rospy


def main():
    out, specs = sys.argv[1], [a for a in sys.argv[2:] if ":=" not in a]
    rospy.init_node("record_topics", anonymous=True)
    received = []
    for spec in specs:
        topic, kind = spec.rsplit(":", 1)
        package, name = kind.split("/")
        cls = getattr(importlib.import_module(f"{package}.msg"), name)
        rospy.Subscriber(topic, cls, lambda m, t=topic: received.append((t, m)), queue_size=None,
                         tcp_nodelay=True)

    def write():
        with rosbag.Bag(out + ".partial", "w") as bag:
            for i, (topic, msg) in enumerate(received):
                bag.write(topic, msg, t=rospy.Time(0, i + 1))  # receive order
        os.replace(out + ".partial", out)

    rospy.on_shutdown(write)
    rospy.spin()


if __name__ == "__main__":
    main()
