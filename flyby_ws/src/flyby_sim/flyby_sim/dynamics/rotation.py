"""Quaternion helpers for single rotations, written element-wise on plain floats.

Quaternions are (x, y, z, w), scalar last (ROS and scipy order). ``q_a_from_b`` rotates b-frame
vectors into frame a: ``v_a = quat_rotate(q_a_from_b, v_b)``, and composes as
``q_a_from_c = quat_multiply(q_a_from_b, q_b_from_c)`` (Hamilton product). Rotation matrices
follow the same naming: ``C_a_from_b @ v_b = v_a``.

The functions take any length-4 / length-3 sequence and return new numpy arrays. They avoid
vectorized numpy calls because, for 3- and 4-element arrays, numpy's per-call overhead costs more
than the arithmetic; the simulator calls them every step.
"""

import math

import numpy as np

# Below this rotation angle [rad] the exp/log maps switch to their Taylor series (sin(x)/x etc.).
_SMALL_ANGLE_RAD = 1e-6
_NDARRAY = np.ndarray


def _floats(v):
    """The components of one numpy vector as Python floats (the same IEEE arithmetic, several times
    cheaper per operation than numpy scalars); anything else as given (sequences, or the (4, N)
    columns of a vectorized call). The quaternion products, rotations and skew, called some 10^5 times
    a run, write this test out in place of the call (a sixth of their cost)."""
    return v.tolist() if type(v) is _NDARRAY and v.ndim == 1 else v


def quat_multiply(q1, q2):
    """Hamilton product q1 * q2 of two (x, y, z, w) quaternions."""
    x1, y1, z1, w1 = q1.tolist() if type(q1) is _NDARRAY and q1.ndim == 1 else q1
    x2, y2, z2, w2 = q2.tolist() if type(q2) is _NDARRAY and q2.ndim == 1 else q2
    return np.array((
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
    ))


def quat_conjugate(q):
    """Conjugate (the inverse of a unit quaternion): q_b_from_a from q_a_from_b."""
    x, y, z, w = q.tolist() if type(q) is _NDARRAY and q.ndim == 1 else q
    return np.array((-x, -y, -z, w))


def quat_normalize(q):
    """Unit quaternion along q; raises ValueError for a zero or non-finite q."""
    x, y, z, w = q.tolist() if type(q) is _NDARRAY and q.ndim == 1 else q
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(norm) or norm == 0.0:
        raise ValueError(f'quaternion {list(q)} cannot be normalized (norm {norm})')
    return np.array((x / norm, y / norm, z / norm, w / norm))


def quat_to_matrix(q):
    """Rotation matrix C_a_from_b of q_a_from_b (q need not be exactly unit)."""
    x, y, z, w = q.tolist() if type(q) is _NDARRAY and q.ndim == 1 else q
    s = 2.0 / (x * x + y * y + z * z + w * w)
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    return np.array((
        (1.0 - yy - zz, xy - wz, xz + wy),
        (xy + wz, 1.0 - xx - zz, yz - wx),
        (xz - wy, yz + wx, 1.0 - xx - yy),
    ))


def quat_to_matrix_many(q):
    """Rotation matrices (N, 3, 3) of N quaternions q (N, 4), none need be exactly unit.

    The vectorized ``quat_to_matrix``: its arithmetic is element-wise, so it takes the four components
    as (N,) columns and returns (3, 3, N).
    """
    return np.moveaxis(quat_to_matrix(np.atleast_2d(np.asarray(q, dtype=float)).T), -1, 0)


def quat_from_matrix(c_a_from_b):
    """Unit quaternion q_a_from_b (w >= 0) of a rotation matrix, by Shepperd's method."""
    c = np.asarray(c_a_from_b, dtype=float)
    if c.shape != (3, 3) or not np.all(np.isfinite(c)):
        raise ValueError(f'rotation matrix must be a finite 3x3 array, got {c!r}')
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = c.tolist()
    trace = m00 + m11 + m22
    # Pick the largest of w, x, y, z to divide by, which keeps the result accurate for any angle.
    if trace >= max(m00, m11, m22):
        s = 2.0 * math.sqrt(1.0 + trace)
        q = ((m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s)
    elif m00 >= m11 and m00 >= m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        q = (0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s)
    elif m11 >= m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        q = ((m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        q = ((m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s)
    q = quat_normalize(q)
    return -q if q[3] < 0.0 else q


def quat_rotate(q, v):
    """v_a = q_a_from_b applied to v_b, for a unit quaternion q."""
    x, y, z, w = q.tolist() if type(q) is _NDARRAY and q.ndim == 1 else q
    vx, vy, vz = v.tolist() if type(v) is _NDARRAY and v.ndim == 1 else v
    # t = 2 (u x v); v' = v + w t + u x t
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return np.array((
        vx + w * tx + y * tz - z * ty,
        vy + w * ty + z * tx - x * tz,
        vz + w * tz + x * ty - y * tx,
    ))


def quat_rotate_many(q, v):
    """Vectors v (N, 3) rotated by unit quaternions q: one (4,) for all, or one per vector (N, 4).

    The vectorized ``quat_rotate`` for arrays of samples (N >= 1); returns (N, 3).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    v = np.atleast_2d(np.asarray(v, dtype=float))
    u = q[:, :3]
    w = q[:, 3:4]
    t = 2.0 * np.cross(u, v)  # t = 2 (u x v); v' = v + w t + u x t
    return v + w * t + np.cross(u, t)


def skew(v):
    """[v x], the 3x3 matrix with skew(v) @ u = cross(v, u)."""
    x, y, z = v.tolist() if type(v) is _NDARRAY and v.ndim == 1 else v
    return np.array(((0.0, -z, y), (z, 0.0, -x), (-y, x, 0.0)))


def quat_shortest_arc(u_from, u_to):
    """Unit quaternion of the smallest rotation taking direction u_from onto direction u_to.

    Both directions need not be unit, must be nonzero. Opposite directions: a half turn about the
    axis perpendicular to u_from nearest the basis vector least aligned with it.
    """
    a = np.asarray(u_from, dtype=float)
    b = np.asarray(u_to, dtype=float)
    na, nb = math.sqrt(float(a @ a)), math.sqrt(float(b @ b))
    if not (math.isfinite(na) and math.isfinite(nb) and na > 0.0 and nb > 0.0):
        raise ValueError(f'directions {a.tolist()} and {b.tolist()} must be finite and nonzero')
    a, b = a / na, b / nb
    axis = np.cross(a, b)
    s, c = math.sqrt(float(axis @ axis)), float(a @ b)
    if s < 1e-12:
        if c > 0.0:
            return np.array((0.0, 0.0, 0.0, 1.0))
        axis = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        return quat_from_axis_angle(axis, math.pi)
    return quat_from_rotation_vector(axis / s * math.atan2(s, c))


def quat_from_rotation_vector(rotvec):
    """Unit quaternion of the rotation by |rotvec| [rad] about rotvec (the exponential map)."""
    rx, ry, rz = _floats(rotvec)
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    if not math.isfinite(angle):
        raise ValueError(f'rotation vector {list(rotvec)} is not finite')
    if angle < _SMALL_ANGLE_RAD:
        k = 0.5 - angle * angle / 48.0  # sin(a/2)/a
    else:
        k = math.sin(0.5 * angle) / angle
    return np.array((k * rx, k * ry, k * rz, math.cos(0.5 * angle)))


def quat_from_axis_angle(axis, angle_rad):
    """Unit quaternion of a rotation by angle_rad about axis (any nonzero length)."""
    ax, ay, az = _floats(axis)
    norm = math.sqrt(ax * ax + ay * ay + az * az)
    if not math.isfinite(norm) or norm == 0.0:
        raise ValueError(f'rotation axis {list(axis)} must be finite and nonzero')
    k = angle_rad / norm
    return quat_from_rotation_vector((k * ax, k * ay, k * az))


def rotation_vector_from_quat(q):
    """Rotation vector [rad] of q (the logarithmic map), angle in [0, pi]."""
    x, y, z, w = quat_normalize(q).tolist()
    if w < 0.0:  # q and -q are the same rotation; take the short way round
        x, y, z, w = -x, -y, -z, -w
    sin_half = math.sqrt(x * x + y * y + z * z)
    angle = 2.0 * math.atan2(sin_half, w)
    k = 2.0 / w if angle < _SMALL_ANGLE_RAD else angle / sin_half
    return np.array((k * x, k * y, k * z))


def rotation_angle_many(q):
    """Rotation angles [rad] in [0, pi] of quaternions q (N, 4), none need be exactly unit.

    The angle of ``rotation_vector_from_quat`` for arrays: 2 atan2(|(x, y, z)|, |w|).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    return 2.0 * np.arctan2(np.sqrt(np.einsum('ij,ij->i', q[:, :3], q[:, :3])), np.abs(q[:, 3]))


def random_small_rotation(rng, sigma_rad):
    """Unit quaternion whose rotation vector is Gaussian, N(0, sigma_rad^2) per axis.

    Always draws three standard normals from rng, so the stream advances the same way for any
    sigma (including zero).
    """
    return quat_from_rotation_vector(sigma_rad * rng.standard_normal(3))
