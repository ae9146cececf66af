"""Quaternions on Python floats, for the target filter's measurement update and ``target_motion.make_state``.

flyby_sim.dynamics.rotation and orbital compute these element-wise on floats and return one numpy array each; the
filter chains five of them per measurement, where those arrays cost more than the arithmetic. These are their
expressions in the same order, on tuples, hence the same bits (test_quaternion_floats_are_rotations_to_the_bit).
Quaternions (x, y, z, w), scalar last, as ``flyby_sim.dynamics.rotation``.
"""

import math

import numpy as np

from flyby_sim.dynamics.orbital import hill_axes_in_eci
from flyby_sim.dynamics.rotation import quat_from_matrix


def float_list(v):
    """A vector's components as a list of Python floats."""
    return v.tolist() if type(v) is np.ndarray and v.dtype == np.float64 else [float(a) for a in v]


_Q_ECI_FROM_HILL_T0 = tuple(quat_from_matrix(hill_axes_in_eci(0.0, 1.0)).tolist())  # orbital's q_eci_from_hill at t = 0
_SMALL_ANGLE_RAD = 1e-6  # rotation's switch to the exp/log maps' Taylor series
_eci_from_hill_at = [None, None]  # (t, n) and q_eci_from_hill there: the update and the state after it share it


def quat_product_floats(q1, q2):
    """rotation.quat_multiply (the Hamilton product q1 * q2) of two float sequences, as a tuple."""
    x1, y1, z1, w1 = q1
    x2, y2, z2, w2 = q2
    return (w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2)


def q_eci_from_hill_floats(t, n):
    """orbital.quat_eci_from_hill(t, n) as a tuple: the t = 0 attitude turned by n t about ECI +z."""
    key, q = _eci_from_hill_at
    if key != (t, n):
        half = 0.5 * n * t
        q = quat_product_floats((0.0, 0.0, math.sin(half), math.cos(half)), _Q_ECI_FROM_HILL_T0)
        _eci_from_hill_at[:] = (t, n), q
    return q


def quat_normalize_floats(q):
    """rotation.quat_normalize as a tuple; ValueError for a zero or non-finite q."""
    x, y, z, w = q
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(norm) or norm == 0.0:
        raise ValueError(f'quaternion {list(q)} cannot be normalized (norm {norm})')
    return x / norm, y / norm, z / norm, w / norm


def rotation_vector_floats(q):
    """rotation.rotation_vector_from_quat (the logarithmic map, angle in [0, pi]) as a tuple [rad]."""
    x, y, z, w = quat_normalize_floats(q)
    if w < 0.0:  # q and -q are the same rotation; take the short way round
        x, y, z, w = -x, -y, -z, -w
    sin_half = math.sqrt(x * x + y * y + z * z)
    angle = 2.0 * math.atan2(sin_half, w)
    k = 2.0 / w if angle < _SMALL_ANGLE_RAD else angle / sin_half
    return k * x, k * y, k * z


def quat_exp_floats(r):
    """rotation.quat_from_rotation_vector (the exponential map) of the rotation vector r [rad], as a tuple."""
    rx, ry, rz = r
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    if not math.isfinite(angle):
        raise ValueError(f'rotation vector {list(r)} is not finite')
    k = 0.5 - angle * angle / 48.0 if angle < _SMALL_ANGLE_RAD else math.sin(0.5 * angle) / angle  # sin(a/2)/a
    return k * rx, k * ry, k * rz, math.cos(0.5 * angle)
