"""Readers of a bag into numpy series for analysis: ``read_bag``, ``bag_topics``, ``bag_time_range``.

Time stamps in the bag are integer nanoseconds of simulation time; the arrays returned are float64
seconds. Quaternions are returned in ROS order (x, y, z, w). The types with a fixed layout (Clock,
the ``*Stamped`` geometry types, Odometry) are decoded straight from their CDR bytes into arrays
(``_decode_fixed``), JointState by ``convert.joint_state_cdr_to_numpy``; the others through rosbags' deserializer.
"""

import struct
from pathlib import Path
from typing import NamedTuple

import numpy as np
from rosbags.highlevel import AnyReader

from flyby_msgs_py.bag.common import BagError, jazzy_typestore
from flyby_msgs_py.convert.cdr import header_cdr_to_ns
from flyby_msgs_py.convert.sensors import joint_state_cdr_to_numpy

DIAGNOSTIC_LEVELS = {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}

_U32 = struct.Struct('<I')


class OdometrySeries(NamedTuple):
    t: np.ndarray                 # (N,) header stamp [s]
    position: np.ndarray          # (N, 3) pose.pose.position [m]
    orientation_xyzw: np.ndarray  # (N, 4) pose.pose.orientation
    linear: np.ndarray            # (N, 3) twist.twist.linear [m/s]
    angular: np.ndarray           # (N, 3) twist.twist.angular [rad/s]
    pose_covariance: np.ndarray   # (N, 6, 6)
    twist_covariance: np.ndarray  # (N, 6, 6)
    frame_id: str                 # of the first message ('' if none)
    child_frame_id: str
    t_received: np.ndarray        # (N,) bag log time [s]


class Vector3Series(NamedTuple):
    t: np.ndarray
    vector: np.ndarray            # (N, 3)
    frame_id: str
    t_received: np.ndarray


class PointSeries(NamedTuple):
    t: np.ndarray
    point: np.ndarray             # (N, 3)
    frame_id: str
    t_received: np.ndarray


class QuaternionSeries(NamedTuple):
    t: np.ndarray
    quaternion_xyzw: np.ndarray   # (N, 4)
    frame_id: str
    t_received: np.ndarray


class WrenchSeries(NamedTuple):
    t: np.ndarray
    force: np.ndarray             # (N, 3) [N]
    torque: np.ndarray            # (N, 3) [N m]
    frame_id: str
    t_received: np.ndarray


class JointSeries(NamedTuple):
    t: np.ndarray
    names: list                   # of the first message
    position: np.ndarray          # (N, M), (N, 0) where the field is not given (empty, as sensor_msgs says)
    velocity: np.ndarray          # (N, M) or (N, 0)
    effort: np.ndarray            # (N, M) or (N, 0)
    frame_id: str
    t_received: np.ndarray


class ClockSeries(NamedTuple):
    t: np.ndarray                 # (N,) clock value [s]
    t_received: np.ndarray


class StringSeries(NamedTuple):
    t_received: list              # bag log time [s] per message
    data: list


class PathLatest(NamedTuple):
    t: float | None               # header stamp of the latest path [s], None if no path
    times: np.ndarray             # (M,) pose stamps of the latest path [s]
    positions: np.ndarray         # (M, 3)
    frame_id: str
    count: int                    # number of path messages in the bag


class MarkerArrayCount(NamedTuple):
    count: int
    t_received: np.ndarray


class MessageList(NamedTuple):
    """Any other type: decoded rosbags messages with their log times [s]."""
    t_received: np.ndarray
    messages: list


def _stamp_s(stamp):
    return stamp.sec + stamp.nanosec * 1e-9


def _vec(v):
    return (v.x, v.y, v.z)


def _arr(rows, width):
    return np.array(rows, dtype=np.float64).reshape(-1, width)


_STAMP_DTYPE = np.dtype([('sec', '<i4'), ('nanosec', '<u4')])


def _decode_fixed(datas, n_strings, n_doubles):
    """Vectorized decode of CDR messages laid out as: Time, ``n_strings`` strings, float64 block.

    That layout covers Clock, the ``*Stamped`` geometry types and Odometry (header, child frame,
    then only float64 fields). CDR (little endian) aligns each primitive to its size, counted from
    the end of the 4-byte encapsulation header: a string is a uint32 length (with the NUL) and the
    bytes; the float64 block starts at the next multiple of 8.

    Returns ``(t [s] (N,), values (N, n_doubles), strings of the first message)``, or None if a
    message does not fit (big endian, too short): the caller then deserializes them one by one.
    """
    size = 8 * n_doubles
    stamps, blocks, first_strings = [], [], None
    for data in datas:
        if len(data) < 12 or data[1] != 1:
            return None
        pos, strings = 8, []
        for _ in range(n_strings):
            pos = (pos + 3) & ~3
            (length,) = _U32.unpack_from(data, 4 + pos)
            if first_strings is None:
                strings.append(bytes(data[8 + pos:8 + pos + length]).rstrip(b'\0').decode())
            pos += 4 + length
        start = 4 + ((pos + 7) & ~7)
        if len(data) < start + size:
            return None
        if first_strings is None:
            first_strings = strings
        stamps.append(data[4:12])
        blocks.append(data[start:start + size])
    stamp = np.frombuffer(b''.join(stamps), dtype=_STAMP_DTYPE)
    values = np.frombuffer(b''.join(blocks), dtype='<f8').reshape(len(datas), n_doubles)
    return (stamp['sec'] + stamp['nanosec'] * 1e-9, values.astype(np.float64),
            first_strings or [''] * n_strings)


def _odometry(datas, t_rx, deserialize):
    fixed = _decode_fixed(datas, 2, 85)
    if fixed is None:
        msgs = [deserialize(d) for d in datas]
        t = np.array([_stamp_s(m.header.stamp) for m in msgs], dtype=np.float64)
        values = _arr([np.concatenate((
            _vec(m.pose.pose.position), _quat(m.pose.pose.orientation), m.pose.covariance,
            _vec(m.twist.twist.linear), _vec(m.twist.twist.angular), m.twist.covariance))
            for m in msgs], 85)
        frames = [msgs[0].header.frame_id, msgs[0].child_frame_id] if msgs else ['', '']
    else:
        t, values, frames = fixed
    # Field order of the float64 block: position 3, orientation 4, pose covariance 36,
    # linear 3, angular 3, twist covariance 36.
    return OdometrySeries(
        t=t, position=values[:, 0:3], orientation_xyzw=values[:, 3:7],
        pose_covariance=values[:, 7:43].reshape(-1, 6, 6), linear=values[:, 43:46],
        angular=values[:, 46:49], twist_covariance=values[:, 49:85].reshape(-1, 6, 6),
        frame_id=frames[0], child_frame_id=frames[1], t_received=t_rx)


def _quat(q):
    return (q.x, q.y, q.z, q.w)


def _stamped(series, n_doubles, fields):
    """Converter of a Header + float64-block type; ``fields`` extracts the block from a message."""
    def convert(datas, t_rx, deserialize):
        fixed = _decode_fixed(datas, 1, n_doubles)
        if fixed is None:
            msgs = [deserialize(d) for d in datas]
            fixed = (np.array([_stamp_s(m.header.stamp) for m in msgs], dtype=np.float64),
                     _arr([fields(m) for m in msgs], n_doubles),
                     [msgs[0].header.frame_id if msgs else ''])
        t, values, (frame,) = fixed
        if series is WrenchSeries:
            return WrenchSeries(t, values[:, 0:3], values[:, 3:6], frame, t_rx)
        return series(t, values, frame, t_rx)
    return convert


def _clock(datas, t_rx, deserialize):
    fixed = _decode_fixed(datas, 0, 0)
    if fixed is None:
        t = np.array([_stamp_s(deserialize(d).clock) for d in datas], dtype=np.float64)
    else:
        t = fixed[0]
    return ClockSeries(t, t_rx)


def _joint_states(datas, t_rx, deserialize):
    """Decoded from the CDR bytes (``convert.joint_state_cdr_to_numpy``): rosbags refuses the bytes of rclpy's
    ``serialize_message`` for a JointState with an empty field (they end in 8 bytes past the message)."""
    joints = [joint_state_cdr_to_numpy(d) for d in datas]
    names = joints[0].names if joints else []
    if any(j.names != names for j in joints):
        raise BagError(f'JointState: the joint names change within the topic (first {names})')

    def field(name):
        widths = {len(getattr(j, name)) for j in joints}
        if len(widths) > 1:
            raise BagError(f'JointState: {name} is given in some messages and not in others')
        width = widths.pop() if widths else 0
        return _arr([getattr(j, name) for j in joints], width) if width else np.zeros((len(joints), 0))
    frame_id = header_cdr_to_ns(datas[0])[1] if datas else ''
    stamp = np.frombuffer(b''.join(bytes(d[4:12]) for d in datas), dtype=_STAMP_DTYPE)
    return JointSeries(stamp['sec'] + stamp['nanosec'] * 1e-9, names,  # as every other series' stamps
                       field('position'), field('velocity'), field('effort'), frame_id, t_rx)


def _level_name(level):
    if isinstance(level, (bytes, bytearray)):
        level = level[0] if level else 0
    return DIAGNOSTIC_LEVELS.get(int(level), str(int(level)))


def _events(datas, t_rx, deserialize):
    events = []
    for data, t_received in zip(datas, t_rx, strict=True):
        m = deserialize(data)
        t = _stamp_s(m.header.stamp)
        for s in m.status:
            events.append({'t': t, 't_received': float(t_received), 'level': _level_name(s.level),
                           'name': s.name, 'message': s.message, 'hardware_id': s.hardware_id,
                           'values': {kv.key: kv.value for kv in s.values}})
    return events


def _path(datas, t_rx, deserialize):
    if not datas:
        return PathLatest(None, np.zeros(0), np.zeros((0, 3)), '', 0)
    m = deserialize(datas[-1])
    return PathLatest(_stamp_s(m.header.stamp),
                      np.array([_stamp_s(p.header.stamp) for p in m.poses], dtype=np.float64),
                      _arr([_vec(p.pose.position) for p in m.poses], 3),
                      m.header.frame_id, len(datas))


def _strings(datas, t_rx, deserialize):
    return StringSeries([float(t) for t in t_rx], [deserialize(d).data for d in datas])


def _marker_count(datas, t_rx, deserialize):
    return MarkerArrayCount(len(datas), t_rx)


# type name -> converter(raw CDR list, log times [s], deserialize) -> series
_CONVERTERS = {
    'nav_msgs/msg/Odometry': _odometry,
    'geometry_msgs/msg/Vector3Stamped': _stamped(Vector3Series, 3, lambda m: _vec(m.vector)),
    'geometry_msgs/msg/PointStamped': _stamped(PointSeries, 3, lambda m: _vec(m.point)),
    'geometry_msgs/msg/QuaternionStamped': _stamped(
        QuaternionSeries, 4, lambda m: _quat(m.quaternion)),
    'geometry_msgs/msg/WrenchStamped': _stamped(
        WrenchSeries, 6, lambda m: _vec(m.wrench.force) + _vec(m.wrench.torque)),
    'sensor_msgs/msg/JointState': _joint_states,
    'rosgraph_msgs/msg/Clock': _clock,
    'std_msgs/msg/String': _strings,
    'diagnostic_msgs/msg/DiagnosticArray': _events,
    'nav_msgs/msg/Path': _path,
    'visualization_msgs/msg/MarkerArray': _marker_count,
}


def _open_reader(bag_dir):
    bag_dir = Path(bag_dir)
    if not bag_dir.is_dir():
        raise BagError(f'{bag_dir}: no such bag directory')
    if not (bag_dir / 'metadata.yaml').is_file():
        raise BagError(f'{bag_dir}: no metadata.yaml (was the recorder killed? run '
                       f'"python -m flyby_msgs_py.bag repair {bag_dir}")')
    reader = AnyReader([bag_dir], default_typestore=jazzy_typestore())
    try:
        reader.open()
    except Exception as err:
        raise BagError(f'{bag_dir}: cannot open bag: {err}') from err
    return reader


def bag_topics(bag_dir):
    """``{topic: (type name, message count)}`` of a bag."""
    reader = _open_reader(bag_dir)
    try:
        out = {}
        for c in reader.connections:
            _, n = out.get(c.topic, (c.msgtype, 0))
            out[c.topic] = (c.msgtype, n + c.msgcount)
        return out
    finally:
        reader.close()


def bag_time_range(bag_dir):
    """``(first, last)`` message log time [ns] of a bag, or None if it holds no message."""
    reader = _open_reader(bag_dir)
    try:
        if reader.message_count == 0:
            return None
        return reader.start_time, reader.end_time - 1  # rosbags' end_time is exclusive
    finally:
        reader.close()


def read_bag(bag_dir, topics=None):
    """Decode a bag's topics into numpy arrays for analysis.

    Returns ``{topic: series}``; the series type depends on the message type: ``OdometrySeries``,
    ``Vector3Series``, ``PointSeries``, ``QuaternionSeries``, ``WrenchSeries``, ``ClockSeries``,
    ``JointSeries``, ``StringSeries``, a list of event dicts (DiagnosticArray: ``t``, ``level`` 'OK'/'WARN'/'ERROR'/
    'STALE', ``name``, ``message``, ``hardware_id``, ``values``), ``PathLatest`` (the last path),
    ``MarkerArrayCount``, else ``MessageList``. Times in seconds; ``t`` is the header stamp and
    ``t_received`` the bag log time. ``topics`` restricts the result; a topic missing from the
    bag is an error.
    """
    reader = _open_reader(bag_dir)
    try:
        present = {c.topic: c.msgtype for c in reader.connections}
        wanted = list(present) if topics is None else list(topics)
        missing = [t for t in wanted if t not in present]
        if missing:
            raise BagError(f'{bag_dir}: no topic {", ".join(missing)} in the bag '
                           f'(it has {", ".join(sorted(present))})')
        raw = {t: ([], []) for t in wanted}
        conns = [c for c in reader.connections if c.topic in raw]
        for conn, timestamp, data in reader.messages(connections=conns):
            datas, stamps = raw[conn.topic]
            datas.append(data)
            stamps.append(timestamp)
        out = {}
        for topic in wanted:
            datas, stamps = raw[topic]
            t_rx = np.array(stamps, dtype=np.float64) * 1e-9
            type_name = present[topic]

            def deserialize(data, type_name=type_name):
                return reader.typestore.deserialize_cdr(data, type_name)

            convert = _CONVERTERS.get(type_name)
            out[topic] = (convert(datas, t_rx, deserialize) if convert
                          else MessageList(t_rx, [deserialize(d) for d in datas]))
        return out
    finally:
        reader.close()
