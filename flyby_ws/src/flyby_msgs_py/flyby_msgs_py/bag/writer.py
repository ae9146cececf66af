"""Raw, durable rosbag2 (MCAP) writer: ``BagWriter`` and the QoS it records per topic.

``BagWriter`` writes serialized CDR bytes as they are (no deserialize/serialize round trip) and
forces the pending chunk to disk every ``flush_period_ns`` of message time (chunks, data section and
summary carry CRCs: ``integrity.write_crcs_with``), so a recorder killed
with SIGKILL loses at most the last flush period (plus the message in flight); ``repair.repair_bag``
rebuilds such a bag. Bags are rosbag2 version 9 with MCAP storage
(``Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)``), time stamps integer nanoseconds.

The contract module (which imports ``rclpy.qos``) is imported lazily, only to choose the QoS
profiles a writer records.
"""

import os
from pathlib import Path

import numpy as np
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer

from flyby_msgs_py.bag.common import BagError, jazzy_typestore
from flyby_msgs_py.bag.integrity import write_crcs_with


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


def _tf_qos(durability, depth):
    """The QoS tf2 offers on /tf (volatile, depth 100) and /tf_static (transient local, depth 1: latched)."""
    zero = QosTime(0, 0)
    return Qos(history=QosHistory.KEEP_LAST, depth=depth, reliability=QosReliability.RELIABLE,
               durability=durability, deadline=zero, lifespan=zero, liveliness=QosLiveliness.AUTOMATIC,
               liveliness_lease_duration=zero, avoid_ros_namespace_conventions=False)


def contract_qos(topic):
    """Offered QoS (rosbags ``Qos`` list) of an absolute contract topic or of /tf, /tf_static (tf2's profiles),
    ``[]`` if none of them.

    ``/chaser1/mission/phase`` matches the contract topic ``mission/phase``.
    """
    from flyby_msgs_py import contract, qos

    if topic == '/' + contract.TF:
        return [_tf_qos(QosDurability.VOLATILE, 100)]
    if topic == '/' + contract.TF_STATIC:
        return [_tf_qos(QosDurability.TRANSIENT_LOCAL, 1)]
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
            write_crcs_with(self._writer)
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
