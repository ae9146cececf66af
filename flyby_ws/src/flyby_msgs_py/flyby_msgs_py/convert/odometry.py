"""nav_msgs/Odometry: message, CDR bytes and arrays."""

import struct
from typing import NamedTuple

import numpy as np
from nav_msgs.msg import Odometry

from flyby_msgs_py.convert.cdr import (
    _CDR_LE,
    _cdr_header,
    _cdr_string,
    _cdr_string_at,
    _doubles_from_cdr,
    _header_cdr,
    _pad8,
)
from flyby_msgs_py.convert.fields import _covariance, _frame, _quat, _set_xyz, _set_xyzw, _vec3
from flyby_msgs_py.convert.stamps import _stamp_into, stamp_to_sec

_ZERO_COVARIANCE = bytes(36 * 8)

_ODOMETRY_DOUBLES = 85  # pose (7), its covariance (36), twist (6), its covariance (36)


class OdometryArrays(NamedTuple):
    t: float
    position: np.ndarray           # (3,) pose.pose.position, in frame_id
    orientation_xyzw: np.ndarray   # (4,) pose.pose.orientation: child_frame_id in frame_id
    linear: np.ndarray             # (3,) twist.twist.linear
    angular: np.ndarray            # (3,) twist.twist.angular
    pose_covariance: np.ndarray    # (6, 6)
    twist_covariance: np.ndarray   # (6, 6)
    frame_id: str
    child_frame_id: str


def odometry(t, frame_id, child_frame_id, position, orientation_xyzw, linear, angular,
             pose_covariance=None, twist_covariance=None, out=None):
    """nav_msgs/Odometry. What position/linear/angular mean per topic is fixed by DESIGN §4
    (e.g. /sim/target/odom: angular = inertial angular velocity in target_body axes).
    Covariances default to zeros (the message default). ``out``: a message to fill instead of a
    new one (publishing serializes it, so a publisher may reuse one; saves ~11 us a message)."""
    p = _vec3(position, 'position')
    q = _quat(orientation_xyzw, 'orientation_xyzw')
    v = _vec3(linear, 'linear')
    w = _vec3(angular, 'angular')
    msg = Odometry() if out is None else out
    header = msg.header
    _stamp_into(header.stamp, t)
    header.frame_id = _frame(frame_id)
    msg.child_frame_id = _frame(child_frame_id, 'child_frame_id')
    pose = msg.pose.pose
    _set_xyz(pose.position, p)
    _set_xyzw(pose.orientation, q)
    twist = msg.twist.twist
    _set_xyz(twist.linear, v)
    _set_xyz(twist.angular, w)
    if pose_covariance is not None:
        msg.pose.covariance = _covariance(pose_covariance, 6, 'pose_covariance')
    if twist_covariance is not None:
        msg.twist.covariance = _covariance(twist_covariance, 6, 'twist_covariance')
    return msg


def odometry_cdr(t, frame_id, child_frame_id, position, orientation_xyzw, linear, angular,
                 pose_covariance=None, twist_covariance=None):
    """nav_msgs/Odometry as its CDR bytes: what publishing ``odometry(...)`` of the same arguments sends (the same
    validation; byte for byte but the alignment padding, zero here, which Fast CDR leaves as it finds it); a
    publisher of Odometry publishes them as they are."""
    p = _vec3(position, 'position')
    q = _quat(orientation_xyzw, 'orientation_xyzw')
    v = _vec3(linear, 'linear')
    w = _vec3(angular, 'angular')
    head = _header_cdr(t, frame_id)
    head = _pad8(head + _cdr_string(_frame(child_frame_id, 'child_frame_id'), len(head)))
    pose_cov = (_ZERO_COVARIANCE if pose_covariance is None else
                _covariance(pose_covariance, 6, 'pose_covariance').astype('<f8', copy=False).tobytes())
    twist_cov = (_ZERO_COVARIANCE if twist_covariance is None else
                 _covariance(twist_covariance, 6, 'twist_covariance').astype('<f8', copy=False).tobytes())
    return b''.join((_CDR_LE, head, struct.pack('<7d', *p, *q), pose_cov, struct.pack('<6d', *v, *w), twist_cov))


def odometry_cdr_to_numpy(data):
    """The OdometryArrays of a serialized nav_msgs/Odometry (a raw=True subscription's bytes), as
    ``odometry_to_numpy`` of the message. Raises ValueError for anything but little-endian CDR of an Odometry."""
    ns, frame_id, offset = _cdr_header(data, 'Odometry')
    child_frame_id, offset = _cdr_string_at(data, offset, 'child_frame_id')
    a = _doubles_from_cdr(data, offset + (-offset % 8), _ODOMETRY_DOUBLES, 'Odometry')
    return OdometryArrays(ns / 1e9, a[0:3], a[3:7], a[43:46], a[46:49],
                          a[7:43].reshape(6, 6), a[49:85].reshape(6, 6), frame_id, child_frame_id)


def odometry_to_numpy(msg):
    pose, twist = msg.pose.pose, msg.twist.twist
    p, q, v, w = pose.position, pose.orientation, twist.linear, twist.angular
    return OdometryArrays(
        stamp_to_sec(msg.header.stamp),
        np.array((p.x, p.y, p.z)),
        np.array((q.x, q.y, q.z, q.w)),
        np.array((v.x, v.y, v.z)),
        np.array((w.x, w.y, w.z)),
        np.array(msg.pose.covariance, dtype=float).reshape(6, 6),
        np.array(msg.twist.covariance, dtype=float).reshape(6, 6),
        msg.header.frame_id,
        msg.child_frame_id,
    )
