"""Stamped geometry: vectors, points, quaternions, wrenches and the inertia (geometry_msgs), message, CDR bytes
and arrays."""

from typing import NamedTuple

import numpy as np
from geometry_msgs.msg import InertiaStamped, PointStamped, QuaternionStamped, Vector3Stamped, WrenchStamped

from flyby_msgs_py.convert.cdr import _stamped_cdr, _stamped_from_cdr
from flyby_msgs_py.convert.fields import _array, _quat, _scalar, _set_xyz, _set_xyzw, _vec3
from flyby_msgs_py.convert.stamps import _with_header, stamp_to_sec


class Stamped(NamedTuple):
    """A stamped vector, point or quaternion; the frame is ``msg.header.frame_id``."""
    t: float
    value: np.ndarray   # (3,) vector or point, or (4,) quaternion (x, y, z, w)


class WrenchArrays(NamedTuple):
    t: float
    force: np.ndarray    # (3,) [N]
    torque: np.ndarray   # (3,) [N m]


def vector3_stamped(t, frame_id, vector):
    """geometry_msgs/Vector3Stamped (e.g. /guidance/maneuver: dv in hill [m/s], stamp = burn start)."""
    xyz = _vec3(vector, 'vector')
    msg = _with_header(Vector3Stamped(), t, frame_id)
    _set_xyz(msg.vector, xyz)
    return msg


def inertia_stamped(t, frame_id, mass_kg, com_m, inertia_kg_m2):
    """geometry_msgs/InertiaStamped (/estimation/target/inertia, DESIGN §10): mass [kg], centre of mass [m] and the
    inertia about it [kg m^2, symmetric 3x3] in frame_id's axes."""
    msg = _with_header(InertiaStamped(), t, frame_id)
    msg.inertia.m = _scalar(mass_kg, 'mass_kg')
    _set_xyz(msg.inertia.com, _vec3(com_m, 'com_m'))
    i = _array(inertia_kg_m2, 3, 'inertia_kg_m2')
    if i.shape != (3, 3):
        raise ValueError(f'inertia_kg_m2 must be 3x3, got shape {i.shape}')
    inertia = msg.inertia
    inertia.ixx, inertia.ixy, inertia.ixz = (float(x) for x in i[0])
    inertia.iyy, inertia.iyz, inertia.izz = float(i[1, 1]), float(i[1, 2]), float(i[2, 2])
    return msg


def inertia_to_numpy(inertia):
    """(mass [kg], com (3,) [m], inertia (3, 3) [kg m^2]) of a geometry_msgs/Inertia (rclpy's or rosbags')."""
    i = inertia
    return (float(i.m), np.array([i.com.x, i.com.y, i.com.z]),
            np.array([[i.ixx, i.ixy, i.ixz], [i.ixy, i.iyy, i.iyz], [i.ixz, i.iyz, i.izz]]))


def vector3_stamped_to_numpy(msg):
    v = msg.vector
    return Stamped(stamp_to_sec(msg.header.stamp), np.array((v.x, v.y, v.z)))


def point_stamped(t, frame_id, point):
    """geometry_msgs/PointStamped (e.g. the relative-position measurement in hill [m])."""
    xyz = _vec3(point, 'point')
    msg = _with_header(PointStamped(), t, frame_id)
    _set_xyz(msg.point, xyz)
    return msg


def point_stamped_cdr(t, frame_id, point):
    """``point_stamped`` as its CDR bytes (for Publisher.publish; see odometry_cdr)."""
    return _stamped_cdr(t, frame_id, _vec3(point, 'point'))


def point_stamped_cdr_to_numpy(data):
    return Stamped(*_stamped_from_cdr(data, 3, 'PointStamped'))


def point_stamped_to_numpy(msg):
    p = msg.point
    return Stamped(stamp_to_sec(msg.header.stamp), np.array((p.x, p.y, p.z)))


def quaternion_stamped(t, frame_id, quaternion_xyzw):
    """geometry_msgs/QuaternionStamped (e.g. the vision attitude of target_body in hill)."""
    xyzw = _quat(quaternion_xyzw, 'quaternion_xyzw')
    msg = _with_header(QuaternionStamped(), t, frame_id)
    _set_xyzw(msg.quaternion, xyzw)
    return msg


def quaternion_stamped_cdr(t, frame_id, quaternion_xyzw):
    """``quaternion_stamped`` as its CDR bytes (for Publisher.publish; see odometry_cdr)."""
    return _stamped_cdr(t, frame_id, _quat(quaternion_xyzw, 'quaternion_xyzw'))


def quaternion_stamped_cdr_to_numpy(data):
    return Stamped(*_stamped_from_cdr(data, 4, 'QuaternionStamped'))


def quaternion_stamped_to_numpy(msg):
    q = msg.quaternion
    return Stamped(stamp_to_sec(msg.header.stamp), np.array((q.x, q.y, q.z, q.w)))


def wrench_stamped(t, frame_id, force, torque=(0.0, 0.0, 0.0), out=None):
    """geometry_msgs/WrenchStamped: force [N] and torque [N m] in frame_id axes (``out``: a message
    to fill instead)."""
    f = _vec3(force, 'force')
    tq = _vec3(torque, 'torque')
    msg = _with_header(WrenchStamped() if out is None else out, t, frame_id)
    _set_xyz(msg.wrench.force, f)
    _set_xyz(msg.wrench.torque, tq)
    return msg


def wrench_stamped_cdr(t, frame_id, force, torque=(0.0, 0.0, 0.0)):
    """``wrench_stamped`` as its CDR bytes (for Publisher.publish; see odometry_cdr)."""
    return _stamped_cdr(t, frame_id, _vec3(force, 'force') + _vec3(torque, 'torque'))


def wrench_stamped_cdr_to_numpy(data):
    t, a = _stamped_from_cdr(data, 6, 'WrenchStamped')
    return WrenchArrays(t, a[:3], a[3:])


def wrench_stamped_to_numpy(msg):
    f, tq = msg.wrench.force, msg.wrench.torque
    return WrenchArrays(stamp_to_sec(msg.header.stamp), np.array((f.x, f.y, f.z)), np.array((tq.x, tq.y, tq.z)))
