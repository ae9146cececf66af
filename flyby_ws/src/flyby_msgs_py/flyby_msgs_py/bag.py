"""Bag I/O with rosbags: a durable raw writer, repair of a cut-off MCAP, readers into numpy arrays.

Bags are rosbag2 version 9 with MCAP storage, written by rosbags
(``Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)``). Time stamps are integer
nanoseconds of simulation time; the arrays returned by ``read_bag`` are float64 seconds.
Quaternions are returned in ROS order (x, y, z, w).

- ``BagWriter`` writes serialized CDR bytes as they are (no deserialize/serialize round trip) and
  forces the pending chunk to disk every ``flush_period_ns`` of message time, so a recorder killed
  with SIGKILL loses at most the last flush period (plus the message in flight).
- ``repair_bag`` rebuilds such a bag (no summary, no ``metadata.yaml``, maybe a half-written last
  record) from every complete record, keeping the damaged file as ``*.mcap.damaged``.
- ``read_bag``, ``bag_topics``, ``bag_time_range`` read for analysis.
- ``python -m flyby_msgs_py.bag info DIR`` / ``repair DIR`` on the command line.

This module works on bytes and rosbags only; it creates no ROS node. The contract module (which
imports ``rclpy.qos``) is imported lazily, only to choose the QoS profiles a writer records.
"""

from __future__ import annotations

import argparse
import mmap
import os
import shutil
import struct
import sys
import zlib
from pathlib import Path
from typing import NamedTuple

import numpy as np
from rosbags.highlevel import AnyReader
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.metadata import parse_qos
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

MCAP_MAGIC = b'\x89MCAP0\r\n'
DAMAGED_SUFFIX = '.damaged'
_REPAIR_TMP = '.repair-tmp'

# MCAP opcodes (https://mcap.dev/spec#records).
_OP_HEADER = 0x01
_OP_FOOTER = 0x02
_OP_SCHEMA = 0x03
_OP_CHANNEL = 0x04
_OP_MESSAGE = 0x05
_OP_CHUNK = 0x06
_OP_DATA_END = 0x0F
_OP_LAST_KNOWN = 0x10  # opcodes 0x11..0x7f are reserved: meeting one means garbage, stop there
_OP_FIRST_USER = 0x80  # 0x80..0xff are user-defined, skipped

_U16 = struct.Struct('<H')
_U32 = struct.Struct('<I')
_U64 = struct.Struct('<Q')
_RECORD_HEAD = struct.Struct('<BQ')          # opcode, body length
_MESSAGE_HEAD = struct.Struct('<HIQQ')       # channel id, sequence, log time, publish time
_CHUNK_HEAD = struct.Struct('<QQQI')         # start time, end time, uncompressed size, crc

DIAGNOSTIC_LEVELS = {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}


class BagError(Exception):
    """A bag that cannot be written, read or repaired; the message names the path."""


def jazzy_typestore():
    """A fresh rosbags typestore with the ROS 2 Jazzy message types."""
    return get_typestore(Stores.ROS2_JAZZY)


# ---------------------------------------------------------------------------------------------
# Writing
# ---------------------------------------------------------------------------------------------

def _force_pending_chunk_to_disk(writer, fsync=True):
    """Write the pending MCAP chunk of a rosbags ``Writer`` to the file, flush it and fsync it.

    INTERNAL API of rosbags 0.11.9 (pinned in requirements.txt): ``Writer.storage`` is an
    ``McapWriter`` whose ``close_chunk()`` appends the buffered chunk (and its message indexes) to
    the file object ``bio``. Nothing public does this. ``test_bag.py::
    test_internals_flush_forces_chunk_to_disk`` fails loudly if a rosbags upgrade changes it.
    Call only when at least one message was written since the last call (an empty chunk would be
    written with start time > end time).
    """
    storage = writer.storage
    storage.close_chunk()
    storage.bio.flush()
    if fsync:
        os.fsync(storage.bio.fileno())


def _check_writer_internals(writer, path):
    storage = writer.storage
    if not (callable(getattr(storage, 'close_chunk', None))
            and callable(getattr(getattr(storage, 'bio', None), 'fileno', None))):
        raise BagError(f'{path}: the installed rosbags has no McapWriter.close_chunk()/bio; '
                       'BagWriter relies on the internals of rosbags 0.11.9 to flush chunks')


def _rosbags_qos(profile):
    """rosbags ``Qos`` of an rclpy ``QoSProfile`` (matched by policy name)."""
    zero = QosTime(0, 0)

    def _enum(enum, policy):
        return enum.__members__.get(policy.name, enum.UNKNOWN)

    return Qos(history=_enum(QosHistory, profile.history), depth=int(profile.depth),
               reliability=_enum(QosReliability, profile.reliability),
               durability=_enum(QosDurability, profile.durability), deadline=zero, lifespan=zero,
               liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=zero,
               avoid_ros_namespace_conventions=False)


def contract_qos(topic):
    """Offered QoS (rosbags ``Qos`` list) of an absolute contract topic, ``[]`` if not a contract one.

    ``/chaser1/mission/phase`` matches the contract topic ``mission/phase``.
    """
    from flyby_msgs_py import contract, qos

    for relative in contract.TOPIC_TYPES:
        if topic.rstrip('/').endswith('/' + relative):
            return [_rosbags_qos(qos.qos_for(relative))]
    return []


class BagWriter:
    """Raw, durable rosbag2 (MCAP) writer.

    Args:
        bag_dir: directory of the bag to create (must not exist).
        topics: absolute topic name -> type name (``'nav_msgs/msg/Odometry'``); one connection
            per topic is created up front, so an empty topic still appears in the bag.
        flush_period_ns: message time [ns] between two forced writes of the pending chunk to disk.
            A process killed with SIGKILL loses at most the messages of the last period.
        qos: absolute topic name -> list of rosbags ``Qos`` offered; default: the contract's
            profile for contract topics (``contract_qos``), none for others.
        fsync: also ``os.fsync`` on each flush (survives a machine crash, not only a process kill).

    ``write(topic, timestamp_ns, raw)`` stores the CDR bytes as they are. ``close()`` writes the
    summary and ``metadata.yaml``; it is safe to call twice. Also a context manager.
    """

    def __init__(self, bag_dir, topics, flush_period_ns, *, qos=None, fsync=True):
        self.path = Path(bag_dir)
        if not isinstance(flush_period_ns, (int, np.integer)) or flush_period_ns <= 0:
            raise ValueError(f'flush_period_ns: must be a positive integer [ns], '
                             f'got {flush_period_ns!r} (bag {self.path})')
        if not topics:
            raise ValueError(f'topics: no topic to record in bag {self.path}')
        for topic in topics:
            if not topic.startswith('/'):
                raise ValueError(f'topic {topic!r}: must be absolute (bag {self.path})')
        self.flush_period_ns = int(flush_period_ns)
        self.fsync = fsync
        typestore = jazzy_typestore()
        unknown = sorted(f'{t} ({n})' for n, t in topics.items() if t not in typestore.fielddefs)
        if unknown:
            raise ValueError(f'unknown message types for bag {self.path}: {", ".join(unknown)}')

        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        try:
            _check_writer_internals(self._writer, self.path)
            self._connections = {}
            for topic, type_name in topics.items():
                offered = (qos or {}).get(topic) if qos is not None else contract_qos(topic)
                self._connections[topic] = self._writer.add_connection(
                    topic, type_name, typestore=typestore, offered_qos_profiles=offered or ())
        except BaseException:
            self._writer.abort()
            raise
        self._counts = dict.fromkeys(topics, 0)
        self._flushed_at_ns = None
        self._pending = 0
        self.flush_count = 0
        self.first_timestamp_ns = None
        self.last_timestamp_ns = None
        self.closed = False

    def write(self, topic, timestamp_ns, raw):
        """Store the serialized message ``raw`` (CDR bytes) on ``topic`` at ``timestamp_ns``."""
        try:
            connection = self._connections[topic]
        except KeyError:
            raise ValueError(f'topic {topic!r}: not declared for bag {self.path}') from None
        if self.closed:
            raise BagError(f'{self.path}: write to topic {topic!r} after close()')
        self._writer.write(connection, timestamp_ns, raw)
        self._counts[topic] += 1
        self._pending += 1
        if self.first_timestamp_ns is None:
            self.first_timestamp_ns = self._flushed_at_ns = timestamp_ns
        self.last_timestamp_ns = timestamp_ns
        # Flush once message time moved a period away from the last flush (either way: a
        # simulation restarted at an earlier time must not postpone flushing).
        if abs(timestamp_ns - self._flushed_at_ns) >= self.flush_period_ns:
            self.flush()

    def flush(self):
        """Force every message written so far to disk (the pending chunk, then flush and fsync)."""
        if self.closed:
            return
        if self._pending:
            _force_pending_chunk_to_disk(self._writer, self.fsync)
            self._pending = 0
            self.flush_count += 1
        self._flushed_at_ns = self.last_timestamp_ns

    @property
    def counts(self):
        """Messages written per topic."""
        return dict(self._counts)

    @property
    def message_count(self):
        return sum(self._counts.values())

    def close(self):
        """Close cleanly: last chunk, summary, footer and ``metadata.yaml``. Safe to call twice."""
        if self.closed:
            return
        self.closed = True
        self._writer.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


# ---------------------------------------------------------------------------------------------
# Repair
# ---------------------------------------------------------------------------------------------

class _Salvage(NamedTuple):
    schemas: dict        # schema id -> (name, encoding, data str)
    channels: dict       # channel id -> (schema id, topic, message encoding, metadata dict)
    messages: list       # (channel id, log time ns, memoryview of the data)
    complete_until: int  # file offset just after the last complete record
    stop_reason: str


def _string(buf, pos):
    (n,) = _U32.unpack_from(buf, pos)
    end = pos + 4 + n
    if end > len(buf):
        raise ValueError('string beyond record')
    return bytes(buf[pos + 4:end]).decode(), end


def _parse_records(buf, pos, end, out, in_chunk):
    """Parse MCAP records of ``buf[pos:end]`` into ``out``; return (offset reached, stop reason).

    Stops at the first record that is cut off or not a valid record.
    """
    while pos < end:
        if pos + 9 > end:
            return pos, 'record header cut off'
        op, length = _RECORD_HEAD.unpack_from(buf, pos)
        body, after = pos + 9, pos + 9 + length
        if after > end:
            return pos, f'record 0x{op:02x} cut off'
        if op == 0 or _OP_LAST_KNOWN < op < _OP_FIRST_USER:
            return pos, f'invalid opcode 0x{op:02x}'
        try:
            if op == _OP_SCHEMA:
                (sid,) = _U16.unpack_from(buf, body)
                name, p = _string(buf, body + 2)
                encoding, p = _string(buf, p)
                (n,) = _U32.unpack_from(buf, p)
                out.schemas[sid] = (name, encoding, bytes(buf[p + 4:p + 4 + n]).decode())
            elif op == _OP_CHANNEL:
                cid, sid = struct.unpack_from('<HH', buf, body)
                topic, p = _string(buf, body + 4)
                encoding, p = _string(buf, p)
                (n,) = _U32.unpack_from(buf, p)
                p, meta_end, metadata = p + 4, p + 4 + n, {}
                while p < meta_end:
                    key, p = _string(buf, p)
                    metadata[key], p = _string(buf, p)
                out.channels[cid] = (sid, topic, encoding, metadata)
            elif op == _OP_MESSAGE:
                cid, _, log_time, _ = _MESSAGE_HEAD.unpack_from(buf, body)
                out.messages.append((cid, log_time, buf[body + _MESSAGE_HEAD.size:after]))
            elif op == _OP_CHUNK and not in_chunk:
                _, _, size, crc = _CHUNK_HEAD.unpack_from(buf, body)
                compression, p = _string(buf, body + 28)
                (n,) = _U64.unpack_from(buf, p)
                records = buf[p + 8:p + 8 + n]
                if compression:
                    from rosbags.rosbag2.storage_mcap import DECOMPRESSORS
                    if compression not in DECOMPRESSORS:
                        return pos, f'chunk compression {compression!r} not supported'
                    try:
                        records = memoryview(DECOMPRESSORS[compression](bytes(records), size))
                    except Exception as err:  # noqa: BLE001 - corrupt compressed data
                        return pos, f'chunk does not decompress: {err}'
                if len(records) != size:
                    return pos, 'chunk size mismatch'
                if crc and zlib.crc32(records) != crc:
                    return pos, 'chunk CRC mismatch'
                # Parse into a scratch copy so that a bad chunk contributes nothing.
                scratch = _Salvage(dict(out.schemas), dict(out.channels), [], 0, '')
                reached, reason = _parse_records(records, 0, len(records), scratch, True)
                if reached != len(records):
                    return pos, f'bad chunk ({reason})'
                out.schemas.update(scratch.schemas)
                out.channels.update(scratch.channels)
                out.messages.extend(scratch.messages)
            elif op in (_OP_FOOTER, _OP_DATA_END) and not in_chunk:
                return after, 'end of data section'
        except (struct.error, ValueError, UnicodeDecodeError, KeyError) as err:
            return pos, f'bad record 0x{op:02x}: {err}'
        pos = after
    return pos, 'end of file'


def salvage_mcap(mcap_path):
    """Every complete record of a (possibly cut-off) MCAP file: schemas, channels, messages."""
    path = Path(mcap_path)
    with path.open('rb') as f:
        size = os.fstat(f.fileno()).st_size
        if size < len(MCAP_MAGIC):
            data = memoryview(f.read())
        else:
            data = memoryview(mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ))
    out = _Salvage({}, {}, [], len(MCAP_MAGIC), '')
    if bytes(data[:len(MCAP_MAGIC)]) != MCAP_MAGIC:
        return out._replace(complete_until=0, stop_reason='no MCAP magic')
    reached, reason = _parse_records(data, len(MCAP_MAGIC), len(data), out, False)
    return out._replace(complete_until=reached, stop_reason=reason)


def _mcap_files(bag_dir):
    return sorted(p for p in bag_dir.glob('*.mcap') if p.is_file())


def _bag_is_valid(bag_dir):
    if not (bag_dir / 'metadata.yaml').is_file():
        return False
    try:
        with AnyReader([bag_dir], default_typestore=jazzy_typestore()):
            return True
    except Exception:  # noqa: BLE001 - any failure to open means "needs repair"
        return False


def _rihs01(schema_name, encoding, text):
    """Type hash of a schema, computed the way ``AnyReader`` checks it."""
    if encoding == 'ros2msg':
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(text, schema_name))
        return store.hash_rihs01(schema_name)
    return jazzy_typestore().hash_rihs01(schema_name)


def repair_bag(bag_dir):
    """Rebuild a bag whose recorder died: salvage every complete record into a valid bag.

    A bag that opens (``metadata.yaml`` present, MCAP readable) is left alone. Otherwise the MCAP
    (or a ``*.mcap.damaged`` left by an interrupted repair) is parsed linearly up to the first
    cut-off record; complete chunks give schemas, channels and messages, which are copied as raw
    bytes into a fresh bag built in a temporary directory. Then the damaged file is renamed to
    ``*.mcap.damaged``, the new MCAP moved in and ``metadata.yaml`` written last.

    Returns a JSON-able report: ``status`` ('valid' or 'repaired'), ``repaired``, ``messages``
    (topic -> count), ``message_count``, ``first_timestamp_ns``, ``last_timestamp_ns`` and, when
    repaired, ``damaged_file``, ``bytes_total``, ``bytes_salvaged``, ``stop_reason``,
    ``orphan_messages`` (messages of an unknown channel, dropped).
    """
    bag_dir = Path(bag_dir)
    if not bag_dir.is_dir():
        raise BagError(f'{bag_dir}: no such bag directory')
    if _bag_is_valid(bag_dir):
        topics = bag_topics(bag_dir)
        start, end = bag_time_range(bag_dir) or (None, None)
        return {'bag_dir': str(bag_dir), 'status': 'valid', 'repaired': False,
                'messages': {t: n for t, (_, n) in topics.items()},
                'message_count': sum(n for _, n in topics.values()),
                'first_timestamp_ns': start, 'last_timestamp_ns': end}

    mcaps = _mcap_files(bag_dir)
    if len(mcaps) > 1:
        raise BagError(f'{bag_dir}: {len(mcaps)} MCAP files, repair handles one: '
                       f'{", ".join(p.name for p in mcaps)}')
    if mcaps:
        source = mcaps[0]
        damaged = _free_name(source.with_name(source.name + DAMAGED_SUFFIX))
    else:
        leftovers = sorted(bag_dir.glob('*.mcap' + DAMAGED_SUFFIX + '*'))
        if not leftovers:
            raise BagError(f'{bag_dir}: no MCAP file to repair')
        source = damaged = leftovers[-1]

    found = salvage_mcap(source)
    tmp_root = bag_dir / _REPAIR_TMP
    if tmp_root.exists():
        shutil.rmtree(tmp_root)
    tmp_root.mkdir()
    new_bag = tmp_root / bag_dir.name
    counts, orphans, first, last = {}, 0, None, None
    try:
        writer = Writer(new_bag, version=9, storage_plugin=StoragePlugin.MCAP)
        writer.open()
        connections = {}
        for cid, (sid, topic, encoding, metadata) in sorted(found.channels.items()):
            schema = found.schemas.get(sid)
            if schema is None:
                continue
            name, schema_encoding, text = schema
            connections[cid] = writer.add_connection(
                topic, name, msgdef=text, rihs01=_rihs01(name, schema_encoding, text),
                serialization_format=encoding,
                offered_qos_profiles=parse_qos(metadata.get('offered_qos_profiles', '')))
            counts.setdefault(topic, 0)
        for cid, log_time, data in found.messages:
            connection = connections.get(cid)
            if connection is None:
                orphans += 1
                continue
            writer.write(connection, log_time, data)
            counts[connection.topic] += 1
            first = log_time if first is None else min(first, log_time)
            last = log_time if last is None else max(last, log_time)
        writer.close()
        new_mcap = new_bag / f'{new_bag.name}.mcap'
        if source != damaged:
            source.rename(damaged)
        final_mcap = _free_name(bag_dir / new_mcap.name)
        if final_mcap.name != new_mcap.name:
            raise BagError(f'{bag_dir}: {new_mcap.name} exists and is not the damaged file')
        new_mcap.rename(final_mcap)
        (new_bag / 'metadata.yaml').rename(bag_dir / 'metadata.yaml')
    finally:
        shutil.rmtree(tmp_root, ignore_errors=True)
    return {'bag_dir': str(bag_dir), 'status': 'repaired', 'repaired': True,
            'messages': counts, 'message_count': sum(counts.values()),
            'first_timestamp_ns': first, 'last_timestamp_ns': last,
            'damaged_file': str(damaged), 'bytes_total': damaged.stat().st_size,
            'bytes_salvaged': found.complete_until, 'stop_reason': found.stop_reason,
            'orphan_messages': orphans}


def _free_name(path):
    """``path`` if free, else ``path.1``, ``path.2`` ..."""
    candidate, n = path, 0
    while candidate.exists():
        n += 1
        candidate = path.with_name(f'{path.name}.{n}')
    return candidate


# ---------------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------------

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


def _level_name(level):
    if isinstance(level, (bytes, bytearray)):
        level = level[0] if level else 0
    return DIAGNOSTIC_LEVELS.get(int(level), str(int(level)))


def _events(datas, t_rx, deserialize):
    events = []
    for data, t_received in zip(datas, t_rx):
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
    ``StringSeries``, a list of event dicts (DiagnosticArray: ``t``, ``level`` 'OK'/'WARN'/'ERROR'/
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


# ---------------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------------

def _info(bag_dir):
    topics = bag_topics(bag_dir)
    span = bag_time_range(bag_dir)
    width = max([len(t) for t in topics] + [5])
    lines = [f'bag: {bag_dir}']
    if span is None:
        lines.append('time range: (no messages)')
    else:
        lines.append(f'time range: {span[0] * 1e-9:.3f} s .. {span[1] * 1e-9:.3f} s '
                     f'({(span[1] - span[0]) * 1e-9:.3f} s)')
    lines.append(f'messages: {sum(n for _, n in topics.values())}')
    lines.append(f'{"topic":<{width}}  {"count":>8}  type')
    for topic, (type_name, count) in sorted(topics.items()):
        lines.append(f'{topic:<{width}}  {count:>8}  {type_name}')
    return '\n'.join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(prog='python -m flyby_msgs_py.bag',
                                     description='Inspect or repair a flyby rosbag2 (MCAP) bag.')
    sub = parser.add_subparsers(dest='command', required=True)
    sub.add_parser('info', help='topics, types, counts, time range').add_argument('bag_dir')
    sub.add_parser('repair', help='rebuild a bag whose recorder was killed').add_argument('bag_dir')
    args = parser.parse_args(argv)
    try:
        if args.command == 'info':
            print(_info(args.bag_dir))
        else:
            report = repair_bag(args.bag_dir)
            if report['repaired']:
                print(f'{args.bag_dir}: repaired, {report["message_count"]} messages salvaged '
                      f'({report["bytes_salvaged"]} of {report["bytes_total"]} bytes; '
                      f'stopped at: {report["stop_reason"]}); original kept as '
                      f'{report["damaged_file"]}')
                last = report['last_timestamp_ns']
                if last is not None:
                    print(f'last message at {last * 1e-9:.3f} s')
                for topic, n in sorted(report['messages'].items()):
                    print(f'  {topic}: {n}')
            else:
                print(f'{args.bag_dir}: bag is valid, nothing to repair')
    except (BagError, OSError) as err:
        print(f'flyby_msgs_py.bag: error: {err}', file=sys.stderr)
        return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())
