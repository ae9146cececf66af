"""Bag I/O with rosbags: a durable raw writer, repair of a cut-off MCAP, readers into numpy arrays.

Bags are rosbag2 version 9 with MCAP storage, written by rosbags
(``Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)``). Time stamps are integer
nanoseconds of simulation time; the arrays returned by ``read_bag`` are float64 seconds.
Quaternions are returned in ROS order (x, y, z, w).

- ``writer``: ``BagWriter`` writes serialized CDR bytes as they are (no deserialize/serialize round
  trip) and forces the pending chunk to disk every ``flush_period_ns`` of message time, so a
  recorder killed with SIGKILL loses at most the last flush period (plus the message in flight).
- ``repair``: ``repair_bag`` rebuilds such a bag (no summary, no ``metadata.yaml``, maybe a
  half-written last record) from every complete record, read with the ``mcap`` package's
  ``StreamReader`` (``salvage_mcap``), keeping the damaged file as ``*.mcap.damaged``.
- ``integrity``: the CRCs the writers put in every chunk, the data section and the summary, and
  ``verify_bag``, which checks them.
- ``reader``: ``read_bag``, ``bag_topics``, ``bag_time_range`` read for analysis.
- ``__main__``: ``python -m flyby_msgs_py.bag info DIR`` / ``repair DIR`` on the command line.

The package works on bytes, rosbags and mcap only; it creates no ROS node. The names below are
re-exported so that ``from flyby_msgs_py.bag import read_bag`` and the like keep working.
"""

from flyby_msgs_py.bag.common import BagError, jazzy_typestore
from flyby_msgs_py.bag.integrity import verify_bag
from flyby_msgs_py.bag.reader import (
    DIAGNOSTIC_LEVELS,
    ClockSeries,
    JointSeries,
    MarkerArrayCount,
    MessageList,
    OdometrySeries,
    PathLatest,
    PointSeries,
    QuaternionSeries,
    StringSeries,
    Vector3Series,
    WrenchSeries,
    bag_time_range,
    bag_topics,
    read_bag,
)
from flyby_msgs_py.bag.repair import DAMAGED_SUFFIX, MCAP_MAGIC, repair_bag, salvage_mcap
from flyby_msgs_py.bag.writer import BagWriter, contract_qos

__all__ = [
    'DAMAGED_SUFFIX', 'DIAGNOSTIC_LEVELS', 'MCAP_MAGIC', 'BagError', 'BagWriter', 'ClockSeries', 'JointSeries',
    'MarkerArrayCount',
    'MessageList', 'OdometrySeries', 'PathLatest', 'PointSeries', 'QuaternionSeries', 'StringSeries', 'Vector3Series',
    'WrenchSeries', 'bag_time_range', 'bag_topics', 'contract_qos', 'jazzy_typestore', 'read_bag', 'repair_bag',
    'salvage_mcap', 'verify_bag',
]
