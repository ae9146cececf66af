"""numpy <-> ROS message conversions at the boundary of every node (DESIGN §4).

Conventions, once for the module:
- Stamps are simulation time ``t`` in seconds (float) <-> ``builtin_interfaces/Time(sec, nanosec)``,
  rounded to the nearest nanosecond. Integer nanoseconds convert exactly both ways; a simulator that
  keeps time as ``k * step_ns`` and passes ``ns / 1e9`` gets exactly ``k * step_ns`` back.
- Quaternions are (x, y, z, w), scalar last, as in ROS and scipy.
- Vectors are anything of length 3 (list, tuple, shape-(3,) array); covariances are 6x6 (or flat 36;
  3x3 or flat 9 in sensor_msgs/Imu), row-major, order (x, y, z, rot x, rot y, rot z) as in ROS.

Every builder validates shape and finiteness on the way INTO a message and raises ``ValueError``
naming the field, so a message with NaN never leaves a node. Every number is stored as a Python
float: with field checks off (the rclpy default) an ``int`` in a float64 field serializes as garbage.

The ``*_to_numpy`` readers return small NamedTuples of fresh arrays; ``t`` (float seconds) comes
first and frame ids, where returned, come last (``t, dv_hill = vector3_stamped_to_numpy(msg)``).
"""

import math
import struct
from typing import NamedTuple

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import (
    InertiaStamped,
    PointStamped,
    PoseStamped,
    QuaternionStamped,
    Vector3Stamped,
    WrenchStamped,
)
from nav_msgs.msg import Odometry, Path
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import String

from flyby_msgs_py.wire import value_text

NS_PER_S = 1_000_000_000
_INT32_MIN, _INT32_MAX = -2 ** 31, 2 ** 31 - 1
_QUAT_NORM_TOL = 1e-3  # |q| farther from 1 than this is a bug, not round-off: rejected

# --------------------------------------------------------------------------------------------------
# Validation helpers (plain floats, no per-call array allocation on the hot path)

_NUMBER_TYPES = (float, int, np.floating, np.integer)
_BOOL_TYPES = (bool, np.bool_)


def _describe(v):
    if isinstance(v, np.ndarray):
        return f'an array of shape {v.shape}'
    if isinstance(v, (list, tuple)):
        return f'a {type(v).__name__} of length {len(v)}'
    return f'{type(v).__name__} {v!r}'


def _scalar(x, field):
    """x as a finite Python float, or ValueError naming the field."""
    if type(x) is not float:
        if not isinstance(x, _NUMBER_TYPES) or isinstance(x, _BOOL_TYPES):
            raise ValueError(f'{field}: must be a number, got {_describe(x)}')
        x = float(x)
    if not math.isfinite(x):
        raise ValueError(f'{field}: must be finite, got {x!r}')
    return x


def _seq(v, n, field):
    """The n elements of a vector-like v (list, tuple or shape-(n,) numeric array)."""
    if isinstance(v, np.ndarray):
        if v.shape != (n,) or v.dtype.kind not in 'fiu':
            raise ValueError(f'{field}: must be a numeric array of shape ({n},), got '
                             f'{"shape " + str(v.shape) if v.shape != (n,) else "dtype " + str(v.dtype)}')
        return v.tolist()
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise ValueError(f'{field}: must be a sequence of {n} numbers, got {_describe(v)}')
    return v


def _vec3(v, field):
    x, y, z = _seq(v, 3, field)
    if type(x) is not float or type(y) is not float or type(z) is not float:
        x, y, z = _scalar(x, field + '[0]'), _scalar(y, field + '[1]'), _scalar(z, field + '[2]')
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise ValueError(f'{field}: must be finite, got [{x!r}, {y!r}, {z!r}]')
    return x, y, z


def _quat(q, field):
    x, y, z, w = _seq(q, 4, field)
    x, y, z, w = (_scalar(x, field + '[0]'), _scalar(y, field + '[1]'), _scalar(z, field + '[2]'),
                  _scalar(w, field + '[3]'))
    n2 = x * x + y * y + z * z + w * w
    if abs(n2 - 1.0) > 1e-12:
        n = math.sqrt(n2)
        if abs(n - 1.0) > _QUAT_NORM_TOL:
            raise ValueError(f'{field}: must be a unit quaternion (x, y, z, w), got norm {n!r}')
        x, y, z, w = x / n, y / n, z / n, w / n
    return x, y, z, w


def _covariance(c, n, field):
    """A finite n x n (or flat n^2) numeric covariance as a flat array, or ValueError naming the field."""
    try:
        a = np.asarray(c, dtype=float) if not isinstance(c, np.ndarray) else c
    except (TypeError, ValueError):
        raise ValueError(f'{field}: must be a {n}x{n} (or flat {n * n}) numeric covariance') from None
    if a.shape not in ((n, n), (n * n,)) or a.dtype.kind not in 'fiu':
        raise ValueError(f'{field}: must be a {n}x{n} (or flat {n * n}) numeric covariance, got shape {a.shape}')
    if not np.isfinite(a).all():
        raise ValueError(f'{field}: must be finite')
    return a.reshape(n * n)


def _frame(frame_id, field='frame_id'):
    if type(frame_id) is not str or not frame_id:
        raise ValueError(f'{field}: must be a non-empty string, got {frame_id!r}')
    return frame_id


def _array(v, cols, field):
    """A finite (N, cols) float array (N >= 0) from v; a fresh copy."""
    try:
        a = np.array(v, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f'{field}: must be an (N, {cols}) numeric array') from None
    if a.ndim != 2 or a.shape[1] != cols:
        if not (a.size == 0 and cols):
            raise ValueError(f'{field}: must have shape (N, {cols}), got {a.shape}')
        a = a.reshape(0, cols)
    if not np.isfinite(a).all():
        raise ValueError(f'{field}: must be finite')
    return a


def _set_xyz(obj, xyz):
    obj.x, obj.y, obj.z = xyz


def _set_xyzw(obj, xyzw):
    obj.x, obj.y, obj.z, obj.w = xyzw


# --------------------------------------------------------------------------------------------------
# Time

def sec_to_ns(t):
    """Simulation time [s] -> integer nanoseconds, rounded to nearest."""
    return round(_scalar(t, 't') * 1e9)


def ns_to_sec(ns):
    """Integer nanoseconds -> seconds (correctly rounded float)."""
    return _ns(ns) / 1e9


def _ns(ns):
    if not isinstance(ns, (int, np.integer)) or isinstance(ns, _BOOL_TYPES):
        raise ValueError(f'ns: must be an integer, got {_describe(ns)}')
    return int(ns)


def _stamp_into(stamp, t):
    """Write simulation time t [s] (or a Time) into an existing Time message."""
    if type(t) is not float and isinstance(t, Time):
        stamp.sec, stamp.nanosec = t.sec, t.nanosec
        return
    stamp.sec, stamp.nanosec = _stamp_parts(t)


def _stamp_parts(t):
    """(sec, nanosec) of builtin_interfaces/Time for simulation time t [s], rounded to the nanosecond."""
    if type(t) is not float:
        t = _scalar(t, 't')
    try:
        sec, nanosec = divmod(round(t * 1e9), NS_PER_S)
    except (ValueError, OverflowError):
        raise ValueError(f't: must be finite, got {t!r}') from None
    if not _INT32_MIN <= sec <= _INT32_MAX:
        raise ValueError(f't: {t!r} s does not fit builtin_interfaces/Time (int32 seconds)')
    return sec, nanosec


def ns_to_stamp(ns):
    """Integer nanoseconds -> Time, exactly (nanosec in [0, 1e9), also for negative times)."""
    sec, nanosec = divmod(_ns(ns), NS_PER_S)
    if not _INT32_MIN <= sec <= _INT32_MAX:
        raise ValueError(f'ns: {ns} does not fit builtin_interfaces/Time (int32 seconds)')
    return Time(sec=sec, nanosec=nanosec)


def stamp_to_ns(stamp):
    """Time -> integer nanoseconds, exactly."""
    return stamp.sec * NS_PER_S + stamp.nanosec


def sec_to_stamp(t):
    """Simulation time [s] -> Time, rounded to the nearest nanosecond."""
    stamp = Time()
    _stamp_into(stamp, t)
    return stamp


def stamp_to_sec(stamp):
    """Time -> seconds (the float nearest the exact nanosecond count)."""
    return (stamp.sec * NS_PER_S + stamp.nanosec) / 1e9


def clock(t, out=None):
    """rosgraph_msgs/Clock at simulation time t [s] (``out``: a message to fill instead)."""
    msg = Clock() if out is None else out
    _stamp_into(msg.clock, t)
    return msg


def clock_to_sec(msg):
    return stamp_to_sec(msg.clock)


# --------------------------------------------------------------------------------------------------
# Odometry

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


# The serialized form (CDR, little endian, as rmw_fastrtps sends it and rosbags stores it). A publisher takes
# these bytes (rclpy Publisher.publish(bytes)) and a raw=True subscription hands them over, which spares the
# Python message objects: on this machine ~25 us to build and serialize an Odometry message and ~85 us to
# deserialize and read one, against ~5 us each way here.
_CDR_LE = b'\x00\x01\x00\x00'
_ZERO_COVARIANCE = bytes(36 * 8)
_ODOMETRY_DOUBLES = 85  # pose (7), its covariance (36), twist (6), its covariance (36)


def _cdr_string(text, offset):
    """CDR of a string field starting at ``offset`` bytes into the payload: padding to 4, length with the NUL,
    the UTF-8 bytes and the NUL."""
    data = text.encode()
    return b'\0' * (-offset % 4) + struct.pack('<I', len(data) + 1) + data + b'\0'


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


def _cdr_string_at(data, offset, field):
    """(text, offset after it) of the CDR string at ``offset`` of the payload (``data`` includes the 4-byte
    encapsulation header)."""
    offset += -offset % 4
    (size,) = struct.unpack_from('<I', data, 4 + offset)
    start = 4 + offset + 4
    if size < 1 or start + size > len(data):
        raise ValueError(f'{field}: malformed CDR string (length {size} at byte {start - 4})')
    return data[start:start + size - 1].decode(), offset + 4 + size


def odometry_cdr_to_numpy(data):
    """The OdometryArrays of a serialized nav_msgs/Odometry (a raw=True subscription's bytes), as
    ``odometry_to_numpy`` of the message. Raises ValueError for anything but little-endian CDR of an Odometry."""
    ns, frame_id, offset = _cdr_header(data, 'Odometry')
    child_frame_id, offset = _cdr_string_at(data, offset, 'child_frame_id')
    a = _doubles_from_cdr(data, offset + (-offset % 8), _ODOMETRY_DOUBLES, 'Odometry')
    return OdometryArrays(ns / 1e9, a[0:3], a[3:7], a[43:46], a[46:49],
                          a[7:43].reshape(6, 6), a[49:85].reshape(6, 6), frame_id, child_frame_id)


def _cdr_stamp_ns(data, typename):
    """The time [ns] of the Time that opens the payload of serialized ``data`` (a Clock's or a Header's stamp);
    ValueError for anything but little-endian CDR that long."""
    if len(data) < 12 or bytes(data[:2]) != _CDR_LE[:2]:
        raise ValueError(f'{typename}: expected little-endian CDR (encapsulation 00 01) of at least 12 bytes, got '
                         f'{bytes(data[:12]).hex()}')
    sec, nanosec = struct.unpack_from('<iI', data, 4)
    return sec * NS_PER_S + nanosec


def _cdr_header(data, typename):
    """(stamp [ns], frame_id, payload offset just after them) of the std_msgs/Header that opens ``data``."""
    ns = _cdr_stamp_ns(data, typename)
    frame_id, offset = _cdr_string_at(data, 8, 'frame_id')
    return ns, frame_id, offset


def clock_cdr_to_ns(data):
    """The time [ns] of a serialized rosgraph_msgs/Clock (a raw=True subscription's bytes)."""
    return _cdr_stamp_ns(data, 'Clock')


def _pad8(payload):
    """``payload`` padded to the 8-byte alignment of the float64 field that follows."""
    return payload + b'\0' * (-len(payload) % 8)


def _header_cdr(t, frame_id):
    """CDR payload of a std_msgs/Header (stamp t [s], frame_id), unpadded."""
    head = struct.pack('<iI', *_stamp_parts(t))
    return head + _cdr_string(_frame(frame_id), len(head))


def _header_from_cdr(data, typename):
    """(t [s], frame_id, payload offset after the header padded to 8) of serialized ``data``."""
    ns, frame_id, offset = _cdr_header(data, typename)
    return ns / 1e9, frame_id, offset + (-offset % 8)


def _doubles_from_cdr(data, offset, n, typename):
    if 4 + offset + 8 * n != len(data):
        raise ValueError(f'{typename}: {len(data)} bytes of CDR, expected {4 + offset + 8 * n}')
    return np.frombuffer(data, '<f8', n, 4 + offset).astype(float)


def header_cdr_to_ns(data):
    """(time [ns], frame_id) of a serialized std_msgs/Header (e.g. a node's progress)."""
    return _cdr_header(data, 'Header')[:2]


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


# --------------------------------------------------------------------------------------------------
# Stamped geometry

class Stamped(NamedTuple):
    """A stamped vector, point or quaternion; the frame is ``msg.header.frame_id``."""
    t: float
    value: np.ndarray   # (3,) vector or point, or (4,) quaternion (x, y, z, w)


class WrenchArrays(NamedTuple):
    t: float
    force: np.ndarray    # (3,) [N]
    torque: np.ndarray   # (3,) [N m]


def _with_header(msg, t, frame_id):
    """``msg`` with its header set: stamp t [s] (sim time) and frame_id."""
    _stamp_into(msg.header.stamp, t)
    msg.header.frame_id = _frame(frame_id)
    return msg


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


def _stamped_cdr(t, frame_id, values):
    return b''.join((_CDR_LE, _pad8(_header_cdr(t, frame_id)), struct.pack(f'<{len(values)}d', *values)))


def _stamped_from_cdr(data, n, typename):
    t, _frame_id, offset = _header_from_cdr(data, typename)
    return t, _doubles_from_cdr(data, offset, n, typename)


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


class ImuArrays(NamedTuple):
    t: float
    orientation_xyzw: np.ndarray   # (4,) frame_id (body) in hill, or None when the message has none
    angular_velocity: np.ndarray   # (3,) [rad/s], body axes
    linear_acceleration: np.ndarray  # (3,) [m/s^2], body axes
    orientation_covariance: np.ndarray  # (3, 3), or None with the orientation
    angular_velocity_covariance: np.ndarray  # (3, 3)
    linear_acceleration_covariance: np.ndarray  # (3, 3)
    frame_id: str


def imu(t, frame_id, orientation_xyzw, angular_velocity, linear_acceleration, orientation_covariance,
        angular_velocity_covariance, linear_acceleration_covariance):
    """sensor_msgs/Imu: orientation of frame_id (the sensor's body) in hill, gyro rate and specific force
    in frame_id axes, each with its covariance. ``orientation_xyzw`` None: a sample without an attitude,
    marked as sensor_msgs says (orientation_covariance[0] = -1, orientation zero)."""
    msg = _with_header(Imu(), t, frame_id)
    if orientation_xyzw is None:
        msg.orientation.x = msg.orientation.y = msg.orientation.z = msg.orientation.w = 0.0
        msg.orientation_covariance = np.array([-1.0] + [0.0] * 8)
    else:
        _set_xyzw(msg.orientation, _quat(orientation_xyzw, 'orientation_xyzw'))
        msg.orientation_covariance = _covariance(orientation_covariance, 3, 'orientation_covariance')
    _set_xyz(msg.angular_velocity, _vec3(angular_velocity, 'angular_velocity'))
    _set_xyz(msg.linear_acceleration, _vec3(linear_acceleration, 'linear_acceleration'))
    msg.angular_velocity_covariance = _covariance(angular_velocity_covariance, 3, 'angular_velocity_covariance')
    msg.linear_acceleration_covariance = _covariance(linear_acceleration_covariance, 3,
                                                     'linear_acceleration_covariance')
    return msg


_NO_ORIENTATION = (0.0, 0.0, 0.0, 0.0, -1.0) + (0.0,) * 8


def imu_cdr(t, frame_id, orientation_xyzw, angular_velocity, linear_acceleration, orientation_covariance,
            angular_velocity_covariance, linear_acceleration_covariance):
    """``imu`` as its CDR bytes (for Publisher.publish; see odometry_cdr)."""
    head = _pad8(_header_cdr(t, frame_id))
    if orientation_xyzw is None:
        orientation = struct.pack('<13d', *_NO_ORIENTATION)
    else:
        orientation = (struct.pack('<4d', *_quat(orientation_xyzw, 'orientation_xyzw'))
                       + _covariance(orientation_covariance, 3, 'orientation_covariance').astype('<f8').tobytes())
    return b''.join((
        _CDR_LE, head, orientation, struct.pack('<3d', *_vec3(angular_velocity, 'angular_velocity')),
        _covariance(angular_velocity_covariance, 3, 'angular_velocity_covariance').astype('<f8').tobytes(),
        struct.pack('<3d', *_vec3(linear_acceleration, 'linear_acceleration')),
        _covariance(linear_acceleration_covariance, 3, 'linear_acceleration_covariance').astype('<f8').tobytes()))


def imu_cdr_to_numpy(data):
    """``imu_to_numpy`` of a serialized sensor_msgs/Imu."""
    t, frame_id, offset = _header_from_cdr(data, 'Imu')
    a = _doubles_from_cdr(data, offset, 37, 'Imu')
    has_orientation = a[4] != -1.0
    return ImuArrays(t, a[0:4] if has_orientation else None, a[13:16], a[25:28],
                     a[4:13].reshape(3, 3) if has_orientation else None, a[16:25].reshape(3, 3),
                     a[28:37].reshape(3, 3), frame_id)


def imu_to_numpy(msg):
    o, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
    has_orientation = msg.orientation_covariance[0] != -1.0
    return ImuArrays(stamp_to_sec(msg.header.stamp),
                     np.array((o.x, o.y, o.z, o.w)) if has_orientation else None,
                     np.array((w.x, w.y, w.z)), np.array((a.x, a.y, a.z)),
                     np.array(msg.orientation_covariance, dtype=float).reshape(3, 3) if has_orientation else None,
                     np.array(msg.angular_velocity_covariance, dtype=float).reshape(3, 3),
                     np.array(msg.linear_acceleration_covariance, dtype=float).reshape(3, 3),
                     msg.header.frame_id)


class JointArrays(NamedTuple):
    t: float
    names: list
    position: np.ndarray  # (N,) or empty
    velocity: np.ndarray  # (N,) or empty
    effort: np.ndarray    # (N,) or empty


def joint_state(t, frame_id, names, velocity=None, effort=None, position=None):
    """sensor_msgs/JointState: e.g. the reaction wheels (velocity = wheel speed relative to the body
    [rad/s], effort = motor torque [N m]), one finite entry per name. A field not given is NaN per joint
    ("not given"): sensor_msgs allows an empty field, but rosbags 0.11.9 misreads a JointState whose empty
    float64 field ends off an 8-byte boundary (its CDR aligns an empty sequence, Fast DDS does not), so every
    field is filled and any reader opens our bags."""
    names = list(names)
    if not all(type(n) is str and n for n in names):
        raise ValueError(f'names: must be non-empty strings, got {names!r}')
    msg = _with_header(JointState(), t, frame_id)
    msg.name = names
    for field, values in (('position', position), ('velocity', velocity), ('effort', effort)):
        if values is None:
            setattr(msg, field, [math.nan] * len(names))
            continue
        values = list(values.tolist() if isinstance(values, np.ndarray) else values)
        if len(values) != len(names):
            raise ValueError(f'{field}: must have one value per name ({len(names)}), got {len(values)}')
        setattr(msg, field, [_scalar(v, f'{field}[{i}]') for i, v in enumerate(values)])
    return msg


_JOINT_NAMES_CDR = {}  # (frame_id, names) -> (CDR of frame_id and names after the stamp, its length); few keys


def _joint_names_cdr(frame_id, names):
    key = (frame_id, names)
    cached = _JOINT_NAMES_CDR.get(key)
    if cached is None:
        if not all(type(n) is str and n for n in names):
            raise ValueError(f'names: must be non-empty strings, got {list(names)!r}')
        part = _cdr_string(_frame(frame_id), 8)
        part += b'\0' * (-(8 + len(part)) % 4) + struct.pack('<I', len(names))
        for name in names:
            part += _cdr_string(name, 8 + len(part))
        cached = _JOINT_NAMES_CDR[key] = (part, 8 + len(part))
    return cached


def _joint_values(field, values, n):
    """The n finite floats of a JointState field (list), or ValueError naming it."""
    if isinstance(values, np.ndarray) and values.shape == (n,) and values.dtype.kind == 'f':
        if not np.isfinite(values).all():
            i = int(np.flatnonzero(~np.isfinite(values))[0])
            raise ValueError(f'{field}[{i}]: must be finite, got {values[i]!r}')
        return values.tolist()
    values = list(values.tolist() if isinstance(values, np.ndarray) else values)
    if len(values) != n:
        raise ValueError(f'{field}: must have one value per name ({n}), got {len(values)}')
    return [_scalar(v, f'{field}[{i}]') for i, v in enumerate(values)]


def joint_state_cdr(t, frame_id, names, velocity=None, effort=None, position=None):
    """``joint_state`` as its CDR bytes (for Publisher.publish; see odometry_cdr)."""
    names_part, size = _joint_names_cdr(frame_id, tuple(names))
    n = len(names)
    parts = [struct.pack('<iI', *_stamp_parts(t)), names_part]
    for field, values in (('position', position), ('velocity', velocity), ('effort', effort)):
        values = [math.nan] * n if values is None else _joint_values(field, values, n)
        count = b'\0' * (-size % 4) + struct.pack('<I', len(values))
        size += len(count)
        pad = b'\0' * (-size % 8) if values else b''
        size += len(pad) + 8 * len(values)
        parts += [count, pad, struct.pack(f'<{len(values)}d', *values)]
    return _CDR_LE + b''.join(parts)


def joint_state_cdr_to_numpy(data):
    """``joint_state_to_numpy`` of a serialized sensor_msgs/JointState."""
    ns, _frame_id, offset = _cdr_header(data, 'JointState')
    offset += -offset % 4
    (count,) = struct.unpack_from('<I', data, 4 + offset)
    offset += 4
    names = []
    for i in range(count):
        name, offset = _cdr_string_at(data, offset, f'name[{i}]')
        names.append(name)
    fields = []
    for field in ('position', 'velocity', 'effort'):
        offset += -offset % 4
        (n,) = struct.unpack_from('<I', data, 4 + offset)
        offset += 4
        if n:
            offset += -offset % 8
        if 4 + offset + 8 * n > len(data):
            raise ValueError(f'JointState: {field} runs past the {len(data)} bytes of CDR')
        fields.append(np.frombuffer(data, '<f8', n, 4 + offset).astype(float))
        offset += 8 * n
    return JointArrays(ns / 1e9, names, *fields)


def joint_state_to_numpy(msg):
    return JointArrays(stamp_to_sec(msg.header.stamp), list(msg.name), np.array(msg.position, dtype=float),
                       np.array(msg.velocity, dtype=float), np.array(msg.effort, dtype=float))


def string(data):
    """std_msgs/String (e.g. /mission/phase)."""
    if type(data) is not str:
        raise ValueError(f'data: must be a string, got {_describe(data)}')
    msg = String()
    msg.data = data
    return msg


def string_to_str(msg):
    return msg.data


# --------------------------------------------------------------------------------------------------
# Path

class PathArrays(NamedTuple):
    t: float
    times: np.ndarray          # (N,) stamps of the poses [s]
    positions: np.ndarray      # (N, 3)
    orientations: np.ndarray   # (N, 4) (x, y, z, w)
    frame_id: str


def path(t, frame_id, times, positions, orientations=None):
    """nav_msgs/Path in frame_id; pose i is stamped times[i]; orientations default to identity."""
    frame_id = _frame(frame_id)
    pos = _array(positions, 3, 'positions')
    try:
        ts = np.array(times, dtype=float).reshape(-1) if np.ndim(times) <= 1 else None
    except (TypeError, ValueError):
        ts = None
    if ts is None or ts.shape[0] != pos.shape[0]:
        raise ValueError(f'times: must be a sequence of {pos.shape[0]} numbers (one per position)')
    if not np.isfinite(ts).all():
        raise ValueError('times: must be finite')
    if orientations is None:
        quats = [(0.0, 0.0, 0.0, 1.0)] * len(pos)
    else:
        quats = _array(orientations, 4, 'orientations')
        if quats.shape[0] != pos.shape[0]:
            raise ValueError(f'orientations: must have {pos.shape[0]} rows (one per position), '
                             f'got {quats.shape[0]}')
        quats = [_quat(q, f'orientations[{i}]') for i, q in enumerate(quats.tolist())]
    msg = Path()
    _stamp_into(msg.header.stamp, t)
    msg.header.frame_id = frame_id
    poses = []
    for ti, p, q in zip(ts.tolist(), pos.tolist(), quats, strict=True):
        ps = PoseStamped()
        _stamp_into(ps.header.stamp, ti)
        ps.header.frame_id = frame_id
        _set_xyz(ps.pose.position, p)
        _set_xyzw(ps.pose.orientation, q)
        poses.append(ps)
    msg.poses = poses
    return msg


def path_to_numpy(msg):
    n = len(msg.poses)
    times = np.empty(n)
    positions = np.empty((n, 3))
    orientations = np.empty((n, 4))
    for i, ps in enumerate(msg.poses):
        p, q = ps.pose.position, ps.pose.orientation
        times[i] = stamp_to_sec(ps.header.stamp)
        positions[i] = (p.x, p.y, p.z)
        orientations[i] = (q.x, q.y, q.z, q.w)
    return PathArrays(stamp_to_sec(msg.header.stamp), times, positions, orientations, msg.header.frame_id)


# --------------------------------------------------------------------------------------------------
# Events on /mission/events

LEVELS = {'OK': DiagnosticStatus.OK, 'WARN': DiagnosticStatus.WARN, 'ERROR': DiagnosticStatus.ERROR,
          'STALE': DiagnosticStatus.STALE}
_LEVEL_NAMES = {v: k for k, v in LEVELS.items()}


def event(t, level, name, message, values=None, source=''):
    """diagnostic_msgs/DiagnosticArray with one status: level 'OK' | 'WARN' | 'ERROR' ('STALE' also
    accepted), ``name`` the event kind (e.g. 'late_maneuver'), ``values`` a dict rendered to KeyValue
    strings, ``source`` (-> hardware_id) the emitting node's name.

    Values are text, so a non-finite number in ``values`` is allowed and written 'nan' / 'inf': an
    ERROR event is how a diverging estimate is reported."""
    if level not in LEVELS:
        raise ValueError(f'level: must be one of {list(LEVELS)}, got {level!r}')
    for field, text in (('name', name), ('message', message), ('source', source)):
        if type(text) is not str:
            raise ValueError(f'{field}: must be a string, got {_describe(text)}')
    status = DiagnosticStatus()
    status.level = LEVELS[level]
    status.name = name
    status.message = message
    status.hardware_id = source
    kvs = []
    for k, v in (values or {}).items():
        kv = KeyValue()
        kv.key = str(k)
        kv.value = value_text(v)
        kvs.append(kv)
    status.values = kvs
    msg = DiagnosticArray()
    _stamp_into(msg.header.stamp, t)
    msg.status = [status]
    return msg


def events_from_msg(msg):
    """A DiagnosticArray -> list of {t, level, name, message, values (dict of str), source}."""
    t = stamp_to_sec(msg.header.stamp)
    out = []
    for s in msg.status:
        level = s.level if isinstance(s.level, bytes) else bytes([s.level])
        out.append({
            't': t,
            'level': _LEVEL_NAMES.get(level, f'LEVEL_{level[0]}'),
            'name': s.name,
            'message': s.message,
            'values': {kv.key: kv.value for kv in s.values},
            'source': s.hardware_id,
        })
    return out


# --------------------------------------------------------------------------------------------------
# Planned trajectory on /planner/trajectory (DESIGN §10)

class MultiDofTrajectoryArrays(NamedTuple):
    t: float                   # header.stamp: the trajectory's start [s]
    times: np.ndarray          # (N,) stamp + time_from_start of each point [s]
    positions: np.ndarray      # (N, 3) translation
    velocities: np.ndarray     # (N, 3) linear velocity
    accelerations: np.ndarray  # (N, 3) linear acceleration
    joint_name: str
    frame_id: str


def multi_dof_trajectory(t, frame_id, times, positions, velocities, accelerations, joint_name='chaser'):
    """trajectory_msgs/MultiDOFJointTrajectory of one joint in frame_id, header.stamp t [s]; point i at times[i] [s]
    (time_from_start = times[i] - t, >= 0) with its translation, linear velocity and linear acceleration (the
    rotation identity, angular terms zero)."""
    from geometry_msgs.msg import Transform, Twist  # here, not at the top: this section is appended as a whole
    from trajectory_msgs.msg import MultiDOFJointTrajectory, MultiDOFJointTrajectoryPoint

    frame_id = _frame(frame_id)
    pos = _array(positions, 3, 'positions')
    vel = _array(velocities, 3, 'velocities')
    acc = _array(accelerations, 3, 'accelerations')
    ts = _array(np.reshape(np.asarray(times, dtype=float), (-1, 1)), 1, 'times')[:, 0]
    if not (len(ts) == len(pos) == len(vel) == len(acc)):
        raise ValueError(f'times, positions, velocities, accelerations: need one row each per point, got '
                         f'{len(ts)}, {len(pos)}, {len(vel)}, {len(acc)}')
    t0_ns = sec_to_ns(t)
    msg = MultiDOFJointTrajectory()
    _stamp_into(msg.header.stamp, t)
    msg.header.frame_id = frame_id
    msg.joint_names = [joint_name]
    points = []
    for i, (ti, p, v, a) in enumerate(zip(ts.tolist(), pos.tolist(), vel.tolist(), acc.tolist(), strict=True)):
        offset_ns = round(ti * 1e9) - t0_ns
        if offset_ns < 0:
            raise ValueError(f'times[{i}]: {ti!r} s is before the stamp {t!r} s')
        point = MultiDOFJointTrajectoryPoint()
        transform, twist, accel = Transform(), Twist(), Twist()
        _set_xyz(transform.translation, p)
        transform.rotation.w = 1.0
        _set_xyz(twist.linear, v)
        _set_xyz(accel.linear, a)
        point.transforms, point.velocities, point.accelerations = [transform], [twist], [accel]
        point.time_from_start.sec, point.time_from_start.nanosec = divmod(offset_ns, NS_PER_S)
        points.append(point)
    msg.points = points
    return msg


def multi_dof_trajectory_to_numpy(msg):
    """MultiDOFJointTrajectory (first joint) -> MultiDofTrajectoryArrays."""
    n = len(msg.points)
    t0_ns = stamp_to_ns(msg.header.stamp)
    times, pos, vel, acc = np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    for i, point in enumerate(msg.points):
        d = point.time_from_start
        times[i] = (t0_ns + d.sec * NS_PER_S + d.nanosec) / 1e9
        tr, tw, ac = point.transforms[0].translation, point.velocities[0].linear, point.accelerations[0].linear
        pos[i], vel[i], acc[i] = (tr.x, tr.y, tr.z), (tw.x, tw.y, tw.z), (ac.x, ac.y, ac.z)
    return MultiDofTrajectoryArrays(stamp_to_sec(msg.header.stamp), times, pos, vel, acc,
                                    msg.joint_names[0] if msg.joint_names else '', msg.header.frame_id)
