"""The chaser's IMU (sensor_msgs/Imu) and its wheels (sensor_msgs/JointState): message, CDR bytes and arrays."""

import struct
from typing import NamedTuple

import numpy as np
from sensor_msgs.msg import Imu, JointState

from flyby_msgs_py.convert.cdr import (
    _CDR_LE,
    _cdr_header,
    _cdr_string,
    _cdr_string_at,
    _doubles_from_cdr,
    _header_cdr,
    _header_from_cdr,
    _pad8,
)
from flyby_msgs_py.convert.fields import _covariance, _frame, _quat, _scalar, _set_xyz, _set_xyzw, _vec3
from flyby_msgs_py.convert.stamps import _stamp_parts, _with_header, stamp_to_sec


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
    position: np.ndarray  # (N,), or empty when not given
    velocity: np.ndarray  # (N,), or empty when not given
    effort: np.ndarray    # (N,), or empty when not given


def joint_state(t, frame_id, names, velocity=None, effort=None, position=None):
    """sensor_msgs/JointState: e.g. the reaction wheels (velocity = wheel speed relative to the body
    [rad/s], effort = motor torque [N m]), one finite entry per name. A field not given is empty, as
    sensor_msgs/JointState says of a field a source does not fill (Foxglove, PlotJuggler and rosbags read it so;
    ``test_convert`` checks every combination against rosbags and rclpy)."""
    names = list(names)
    if not all(type(n) is str and n for n in names):
        raise ValueError(f'names: must be non-empty strings, got {names!r}')
    msg = _with_header(JointState(), t, frame_id)
    msg.name = names
    for field, values in (('position', position), ('velocity', velocity), ('effort', effort)):
        if values is None:
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
        values = [] if values is None else _joint_values(field, values, n)
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
