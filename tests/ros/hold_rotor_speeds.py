#!/usr/bin/python3
"""Test helper node: answers every state of dronetwin_ros with the same rotor speed command.

    hold_rotor_speeds.py _speeds:="w0 w1 w2 w3"      (in the bridge's namespace)
"""

import rospy
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState


def main():
    rospy.init_node("hold_rotor_speeds")
    speeds = [float(v) for v in rospy.get_param("~speeds").split()]
    pub = rospy.Publisher("cmd/rotor_speeds", JointState, queue_size=1000, tcp_nodelay=True)

    def answer(state):
        cmd = JointState()
        cmd.header.stamp = state.header.stamp  # the lockstep answer to this state
        cmd.name = [f"rotor_{i}" for i in range(len(speeds))]
        cmd.velocity = speeds
        pub.publish(cmd)

    rospy.Subscriber("odometry_measured", Odometry, answer, queue_size=10, tcp_nodelay=True)
    rospy.spin()


if __name__ == "__main__":
    main()
