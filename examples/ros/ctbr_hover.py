#!/usr/bin/python3
"""A controller node for dronetwin_ros: hover at a setpoint with collective thrust + body rates.

It is written as for the real vehicle: it reads the measured odometry, answers each message with
a command stamped like it (which is what the bridge's lockstep waits for), and knows the airframe
only by the mass the bridge puts on the parameter server. Started by config/ros/hover_ctbr.launch,
or by hand next to a running bridge:

    ROS_NAMESPACE=dronetwin /usr/bin/python3 examples/ros/ctbr_hover.py _setpoint:="0 0 1"

The law: a PD on position gives the wanted acceleration a = -kp e_p - kd e_v + g e3; the thrust is
its component along the body z axis times the mass, the wanted attitude points z along a (yaw 0),
and the body rates are proportional to the attitude error e_R = vee(Rd^T R - R^T Rd) / 2.
Parameters: ~setpoint "x y z" (m), ~kp, ~kd (1/s^2, 1/s), ~k_attitude (1/s).
"""

import sys

import numpy as np
import rospy
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry


def rotation(q):
    """Rotation matrix of the unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


class CtbrHover:
    def __init__(self):
        self.setpoint = np.array([float(v) for v in rospy.get_param("~setpoint", "0 0 1").split()])
        if self.setpoint.shape != (3,) or not np.all(np.isfinite(self.setpoint)):
            raise SystemExit(f"ctbr_hover: ~setpoint: expected 'x y z', got {self.setpoint}")
        self.kp = float(rospy.get_param("~kp", 6.0))
        self.kd = float(rospy.get_param("~kd", 4.0))
        self.k_attitude = float(rospy.get_param("~k_attitude", 6.0))
        # The bridge sets its parameters when it starts; wait for them (it may start after us).
        for _ in range(600):
            if rospy.has_param("bridge/mass_kg"):
                break
            rospy.rostime.wallsleep(0.05)
        else:
            raise SystemExit("ctbr_hover: no bridge/mass_kg parameter after 30 s: is "
                             "dronetwin_ros running in this namespace?")
        self.mass_kg = float(rospy.get_param("bridge/mass_kg"))
        self.g = float(rospy.get_param("bridge/gravity_m_s2"))
        # A deep queue: a recorder that falls behind gets every command late rather than not at all.
        self.pub = rospy.Publisher("cmd/ctbr", TwistStamped, queue_size=1000, tcp_nodelay=True)
        rospy.Subscriber("odometry_measured", Odometry, self.on_odometry, queue_size=10,
                         tcp_nodelay=True)

    def on_odometry(self, msg):
        p = msg.pose.pose.position
        o = msg.pose.pose.orientation
        R = rotation((o.w, o.x, o.y, o.z))
        v_B = msg.twist.twist.linear
        v_W = R @ np.array([v_B.x, v_B.y, v_B.z])  # odometry twist is in the body frame
        e_p = np.array([p.x, p.y, p.z]) - self.setpoint
        a = -self.kp * e_p - self.kd * v_W + np.array([0.0, 0.0, self.g])
        thrust_N = max(0.0, self.mass_kg * float(a @ R[:, 2]))
        b3 = a / np.linalg.norm(a)
        b2 = np.cross(b3, [1.0, 0.0, 0.0])
        b2 /= np.linalg.norm(b2)
        Rd = np.column_stack([np.cross(b2, b3), b2, b3])
        E = 0.5 * (Rd.T @ R - R.T @ Rd)
        e_R = np.array([E[2, 1], E[0, 2], E[1, 0]])
        rates = -self.k_attitude * e_R
        cmd = TwistStamped()
        cmd.header.stamp = msg.header.stamp  # the lockstep answer to this state
        cmd.header.frame_id = msg.child_frame_id
        cmd.twist.linear.z = thrust_N
        cmd.twist.angular.x, cmd.twist.angular.y, cmd.twist.angular.z = rates
        self.pub.publish(cmd)


def main():
    rospy.init_node("ctbr_hover")
    CtbrHover()
    rospy.spin()
    return 0


if __name__ == "__main__":
    sys.exit(main())
