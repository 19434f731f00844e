"""A free hub's messages: its state (`/sail/hub_state`, Odometry) and back, and its
wrench command (`sail/hub_wrench_cmd`, WrenchStamped)."""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry

from sail_ros.topics import FRAME_ID, INERTIAL_FRAME_ID, stamp


def hub_state(
    stamp_ns_: int, hub, frame_id: str = FRAME_ID, inertial_frame_id: str = INERTIAL_FRAME_ID
) -> Odometry:
    """`/sail/hub_state`: a free hub's pose and twist, `hub` = (z_h [m], theta_x, theta_y
    [rad], zd_h [m/s], thd_x, thd_y [rad/s]) (model.md §13.9): header frame
    `inertial_frame_id`, child `frame_id`; position (0, 0, z_h); orientation the unit
    quaternion of the rotation vector (theta_x, theta_y, 0); twist in the child frame,
    linear (0, 0, zd_h), angular (thd_x, thd_y, 0); covariances zero (the state is
    exact)."""
    z, theta_x, theta_y, zd, thd_x, thd_y = (float(v) for v in hub)
    message = Odometry(child_frame_id=frame_id)
    message.header.stamp = stamp(stamp_ns_)
    message.header.frame_id = inertial_frame_id
    message.pose.pose.position.z = z
    angle = math.hypot(theta_x, theta_y)
    half = math.sin(0.5 * angle) / angle if angle > 0 else 0.5  # sin(r/2)/r -> 1/2
    orientation = message.pose.pose.orientation
    orientation.x, orientation.y = half * theta_x, half * theta_y
    orientation.z, orientation.w = 0.0, math.cos(0.5 * angle)
    message.twist.twist.linear.z = zd
    message.twist.twist.angular.x, message.twist.twist.angular.y = thd_x, thd_y
    return message


def hub_from_odometry(message: Odometry) -> np.ndarray:
    """The inverse of `hub_state`: `(z_h, theta_x, theta_y, zd_h, thd_x, thd_y)` from a
    `/sail/hub_state`, the tilts the rotation vector of its orientation."""
    orientation = message.pose.pose.orientation
    sine = math.hypot(orientation.x, orientation.y)  # sin(r/2); z is 0
    angle = 2.0 * math.atan2(sine, orientation.w)
    scale = angle / sine if sine > 0 else 2.0  # r / sin(r/2) -> 2
    twist = message.twist.twist
    return np.array(
        [
            message.pose.pose.position.z,
            scale * orientation.x,
            scale * orientation.y,
            twist.linear.z,
            twist.angular.x,
            twist.angular.y,
        ]
    )


def hub_wrench_command(
    force_z: float, torque_x: float, torque_y: float, frame_id: str = ""
) -> WrenchStamped:
    """A `sail/hub_wrench_cmd`: force along z [N], torques about x and y [N m] on the hub."""
    message = WrenchStamped()
    message.header.frame_id = frame_id
    message.wrench.force.z = float(force_z)
    message.wrench.torque.x, message.wrench.torque.y = float(torque_x), float(torque_y)
    return message
