"""Tests of flyby_msgs_py.bag: raw durable writer, salvage and repair of cut-off bags, numpy readers.

Messages are serialized with rclpy (real CDR bytes as a raw subscription delivers them); every bag
lives in ``tmp_path``. Throughput is measured by ``scripts/benchmark_bag.py``, not here.
"""

import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PointStamped, PoseStamped, QuaternionStamped, Vector3Stamped, WrenchStamped
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as PathMsg
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader
from rosbags.interfaces import QosDurability, QosReliability
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.rosbag2.storage_mcap import McapWriter
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import String
from trajectory_msgs.msg import MultiDOFJointTrajectory
from visualization_msgs.msg import Marker, MarkerArray

from flyby_msgs_py import bag as fb
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert
from flyby_msgs_py.bag import reader as bag_reader

S_NS = 1_000_000_000
ALL_TOPICS = {c.absolute(t): type_name for t, type_name in c.TOPIC_TYPES.items()}
ODOM = c.absolute(c.SIM_CHASER_ODOM)


def stamp(t_ns):
    return Time(sec=t_ns // S_NS, nanosec=t_ns % S_NS)


def stamp_s(t_ns):
    """Seconds the way a reader computes them from a stamp (sec + nanosec * 1e-9)."""
    return t_ns // S_NS + (t_ns % S_NS) * 1e-9


def odometry(t_ns, rng, frame='hill', child='chaser_body'):
    m = Odometry()
    m.header.stamp, m.header.frame_id, m.child_frame_id = stamp(t_ns), frame, child
    p, q, lin, ang = rng.normal(size=3), rng.normal(size=4), rng.normal(size=3), rng.normal(size=3)
    m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z = p
    o = m.pose.pose.orientation
    o.x, o.y, o.z, o.w = q
    m.twist.twist.linear.x, m.twist.twist.linear.y, m.twist.twist.linear.z = lin
    m.twist.twist.angular.x, m.twist.twist.angular.y, m.twist.twist.angular.z = ang
    m.pose.covariance = rng.normal(size=36)
    m.twist.covariance = rng.normal(size=36)
    return m


def vector3(t_ns, rng):
    m = Vector3Stamped()
    m.header.stamp, m.header.frame_id = stamp(t_ns), 'hill'
    m.vector.x, m.vector.y, m.vector.z = rng.normal(size=3)
    return m


def point(t_ns, rng):
    m = PointStamped()
    m.header.stamp, m.header.frame_id = stamp(t_ns), 'hill'
    m.point.x, m.point.y, m.point.z = rng.normal(size=3)
    return m


def quaternion(t_ns, rng):
    m = QuaternionStamped()
    m.header.stamp, m.header.frame_id = stamp(t_ns), 'hill'
    m.quaternion.x, m.quaternion.y, m.quaternion.z, m.quaternion.w = rng.normal(size=4)
    return m


def wrench(t_ns, rng):
    m = WrenchStamped()
    m.header.stamp, m.header.frame_id = stamp(t_ns), 'hill'
    m.wrench.force.x, m.wrench.force.y, m.wrench.force.z = rng.normal(size=3)
    m.wrench.torque.x, m.wrench.torque.y, m.wrench.torque.z = rng.normal(size=3)
    return m


def clock(t_ns, rng):
    return Clock(clock=stamp(t_ns))


def joints(t_ns, rng):
    m = JointState()
    m.header.stamp, m.header.frame_id = stamp(t_ns), 'chaser_body'
    m.name = ['wheel_0', 'wheel_1', 'wheel_2']  # names rosbags 0.11.9 misreads with an empty position field
    m.position = [float('nan')] * 3  # not given (convert.joint_state fills every field)
    m.velocity, m.effort = rng.normal(size=3).tolist(), rng.normal(size=3).tolist()
    return m


def imu(t_ns, rng):
    m = Imu()
    m.header.stamp, m.header.frame_id = stamp(t_ns), 'chaser_body'
    m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w = rng.normal(size=4)
    m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z = rng.normal(size=3)
    return m


PHASES = [c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH, c.PHASE_FLYBY]
LEVELS = [DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR]


def string(t_ns, rng):
    return String(data=PHASES[int(rng.integers(len(PHASES)))])


def diagnostics(t_ns, rng):
    m = DiagnosticArray()
    m.header.stamp = stamp(t_ns)
    level = LEVELS[int(rng.integers(3))]
    m.status = [DiagnosticStatus(level=level, name='supervisor', message=f'event at {t_ns}',
                                 hardware_id='chaser',
                                 values=[KeyValue(key='t_ns', value=str(t_ns)),
                                         KeyValue(key='x', value='1.5')])]
    return m


def path(t_ns, rng):
    m = PathMsg()
    m.header.stamp, m.header.frame_id = stamp(t_ns), 'hill'
    for j in range(5):
        p = PoseStamped()
        p.header.stamp, p.header.frame_id = stamp(t_ns + j * S_NS), 'hill'
        p.pose.position.x, p.pose.position.y, p.pose.position.z = rng.normal(size=3)
        m.poses.append(p)
    return m


def markers(t_ns, rng):
    m = MarkerArray()
    for j in range(3):
        mk = Marker()
        mk.header.stamp, mk.header.frame_id, mk.id = stamp(t_ns), 'hill', j
        m.markers.append(mk)
    return m


def trajectory(t_ns, rng):
    return convert.multi_dof_trajectory(t_ns * 1e-9, 'hill', t_ns * 1e-9 + np.arange(4) * 0.5, rng.normal(size=(4, 3)),
                                        rng.normal(size=(4, 3)), rng.normal(size=(4, 3)))


def inertia(t_ns, rng):
    a = rng.normal(size=(3, 3))
    return convert.inertia_stamped(t_ns * 1e-9, 'chaser_body', float(rng.uniform(1.0, 2.0)), rng.normal(size=3),
                                   a @ a.T + np.eye(3))


BUILDERS = {
    'geometry_msgs/msg/InertiaStamped': inertia,
    'nav_msgs/msg/Odometry': odometry,
    'geometry_msgs/msg/Vector3Stamped': vector3,
    'geometry_msgs/msg/PointStamped': point,
    'geometry_msgs/msg/QuaternionStamped': quaternion,
    'geometry_msgs/msg/WrenchStamped': wrench,
    'rosgraph_msgs/msg/Clock': clock,
    'sensor_msgs/msg/JointState': joints,
    'sensor_msgs/msg/Imu': imu,
    'std_msgs/msg/String': string,
    'diagnostic_msgs/msg/DiagnosticArray': diagnostics,
    'nav_msgs/msg/Path': path,
    'visualization_msgs/msg/MarkerArray': markers,
    'trajectory_msgs/msg/MultiDOFJointTrajectory': trajectory,
}


def write_all_topics(bag_dir, n=40, period_ns=50_000_000, flush_period_ns=2 * S_NS, seed=7):
    """Write ``n`` messages on every contract topic; return {topic: [(log ns, stamp ns, msg, raw)]}.

    Header stamps lag the log time by 3 ms so that the two are told apart.
    """
    rng = np.random.default_rng(seed)
    written = {t: [] for t in ALL_TOPICS}
    with fb.BagWriter(bag_dir, ALL_TOPICS, flush_period_ns) as writer:
        for k in range(n):
            for topic, type_name in ALL_TOPICS.items():
                t_log = 1_000 * S_NS + k * period_ns
                t_stamp = t_log - 3_000_000
                msg = BUILDERS[type_name](t_stamp, rng)
                raw = serialize_message(msg)
                writer.write(topic, t_log, raw)
                written[topic].append((t_log, t_stamp, msg, raw))
        assert writer.counts == {t: n for t in ALL_TOPICS}
    return written


def vec(v):
    return [v.x, v.y, v.z]


def quat(q):
    return [q.x, q.y, q.z, q.w]


# --------------------------------------------------------------------------------------------
# Round trip
# --------------------------------------------------------------------------------------------

def test_round_trip_every_contract_topic_read_bag(tmp_path):
    bag_dir = tmp_path / 'bag'
    written = write_all_topics(bag_dir)
    data = fb.read_bag(bag_dir)
    assert set(data) == set(ALL_TOPICS)
    for topic, type_name in ALL_TOPICS.items():
        rows = written[topic]
        msgs = [m for _, _, m, _ in rows]
        t_log = np.array([r[0] for r in rows]) * 1e-9
        t_hdr = np.array([stamp_s(r[1]) for r in rows])
        got = data[topic]
        if type_name == 'nav_msgs/msg/Odometry':
            np.testing.assert_array_equal(got.t, t_hdr)
            np.testing.assert_array_equal(got.t_received, t_log)
            np.testing.assert_array_equal(got.position, [vec(m.pose.pose.position) for m in msgs])
            np.testing.assert_array_equal(got.orientation_xyzw,
                                          [quat(m.pose.pose.orientation) for m in msgs])
            np.testing.assert_array_equal(got.linear, [vec(m.twist.twist.linear) for m in msgs])
            np.testing.assert_array_equal(got.angular, [vec(m.twist.twist.angular) for m in msgs])
            np.testing.assert_array_equal(got.pose_covariance,
                                          [np.reshape(m.pose.covariance, (6, 6)) for m in msgs])
            np.testing.assert_array_equal(got.twist_covariance,
                                          [np.reshape(m.twist.covariance, (6, 6)) for m in msgs])
            assert (got.frame_id, got.child_frame_id) == ('hill', 'chaser_body')
        elif type_name == 'geometry_msgs/msg/Vector3Stamped':
            np.testing.assert_array_equal(got.t, t_hdr)
            np.testing.assert_array_equal(got.vector, [vec(m.vector) for m in msgs])
            assert got.frame_id == 'hill'
        elif type_name == 'geometry_msgs/msg/PointStamped':
            np.testing.assert_array_equal(got.t, t_hdr)
            np.testing.assert_array_equal(got.point, [vec(m.point) for m in msgs])
        elif type_name == 'geometry_msgs/msg/QuaternionStamped':
            np.testing.assert_array_equal(got.t, t_hdr)
            np.testing.assert_array_equal(got.quaternion_xyzw, [quat(m.quaternion) for m in msgs])
        elif type_name == 'geometry_msgs/msg/WrenchStamped':
            np.testing.assert_array_equal(got.t, t_hdr)
            np.testing.assert_array_equal(got.force, [vec(m.wrench.force) for m in msgs])
            np.testing.assert_array_equal(got.torque, [vec(m.wrench.torque) for m in msgs])
        elif type_name == 'rosgraph_msgs/msg/Clock':
            np.testing.assert_array_equal(got.t, t_hdr)
            np.testing.assert_array_equal(got.t_received, t_log)
        elif type_name == 'std_msgs/msg/String':
            assert got.data == [m.data for m in msgs]
            assert got.t_received == list(t_log)
        elif type_name == 'diagnostic_msgs/msg/DiagnosticArray':
            names = {bytes(DiagnosticStatus.OK): 'OK', bytes(DiagnosticStatus.WARN): 'WARN',
                     bytes(DiagnosticStatus.ERROR): 'ERROR'}
            assert got == [{'t': stamp_s(r[1]), 't_received': r[0] * 1e-9,
                            'level': names[bytes(r[2].status[0].level)], 'name': 'supervisor',
                            'message': f'event at {r[1]}', 'hardware_id': 'chaser',
                            'values': {'t_ns': str(r[1]), 'x': '1.5'}} for r in rows]
        elif type_name == 'nav_msgs/msg/Path':
            last = msgs[-1]
            assert got.count == len(msgs)
            assert got.t == stamp_s(rows[-1][1])
            np.testing.assert_array_equal(
                got.times, [p.header.stamp.sec + p.header.stamp.nanosec * 1e-9 for p in last.poses])
            np.testing.assert_array_equal(got.positions, [vec(p.pose.position) for p in last.poses])
            assert got.frame_id == 'hill'
        elif type_name == 'visualization_msgs/msg/MarkerArray':
            assert got.count == len(msgs)
            np.testing.assert_array_equal(got.t_received, t_log)
        elif type_name == 'sensor_msgs/msg/JointState':
            np.testing.assert_array_equal(got.t_received, t_log)
            np.testing.assert_array_equal(got.t, [stamp_s(r[1]) for r in rows])
            assert got.names == ['wheel_0', 'wheel_1', 'wheel_2'] and got.frame_id == 'chaser_body'
            np.testing.assert_array_equal(got.velocity, [m.velocity for m in msgs])
            np.testing.assert_array_equal(got.effort, [m.effort for m in msgs])
            assert np.isnan(got.position).all() and got.position.shape == (len(msgs), 3)
        elif type_name == 'geometry_msgs/msg/InertiaStamped':
            np.testing.assert_array_equal(got.t_received, t_log)
            for g, m in zip(got.messages, msgs, strict=True):
                for a, b in zip(convert.inertia_to_numpy(g.inertia), convert.inertia_to_numpy(m.inertia), strict=True):
                    np.testing.assert_array_equal(a, b)
        elif type_name == 'sensor_msgs/msg/Imu':
            np.testing.assert_array_equal(got.t_received, t_log)
            assert [vec(g.angular_velocity) for g in got.messages] == [vec(m.angular_velocity) for m in msgs]
        elif type_name == 'trajectory_msgs/msg/MultiDOFJointTrajectory':
            np.testing.assert_array_equal(got.t_received, t_log)
            assert [[vec(p.transforms[0].translation) for p in g.points] for g in got.messages] == \
                [[vec(p.transforms[0].translation) for p in m.points] for m in msgs]
            assert isinstance(msgs[0], MultiDOFJointTrajectory)
        else:
            pytest.fail(f'no check for {type_name}')


def test_round_trip_plain_anyreader_bytes_untouched(tmp_path):
    bag_dir = tmp_path / 'bag'
    written = write_all_topics(bag_dir, n=12)
    typestore = get_typestore(Stores.ROS2_JAZZY)
    with AnyReader([bag_dir], default_typestore=typestore) as reader:
        assert {x.topic: (x.msgtype, x.msgcount) for x in reader.connections} == {
            t: (ALL_TOPICS[t], 12) for t in ALL_TOPICS}
        got = {t: [] for t in ALL_TOPICS}
        for conn, t_log, raw in reader.messages():
            got[conn.topic].append((t_log, bytes(raw)))
            if conn.msgtype == 'nav_msgs/msg/Odometry':
                msg = reader.deserialize(raw, conn.msgtype)
                assert msg.header.frame_id == 'hill'
        qos = {x.topic: x.ext.offered_qos_profiles for x in reader.connections}
    for topic, rows in written.items():
        # The bytes are stored as they were handed over: no deserialize/serialize round trip.
        assert got[topic] == [(r[0], bytes(r[3])) for r in rows], topic
    phase = qos[c.absolute(c.MISSION_PHASE)][0]
    assert (phase.reliability, phase.durability) == (QosReliability.RELIABLE,
                                                      QosDurability.TRANSIENT_LOCAL)
    odom = qos[ODOM][0]
    assert (odom.reliability, odom.durability) == (QosReliability.RELIABLE, QosDurability.VOLATILE)
    assert fb.bag_topics(bag_dir) == {t: (ALL_TOPICS[t], 12) for t in ALL_TOPICS}
    assert fb.bag_time_range(bag_dir) == (1_000 * S_NS, 1_000 * S_NS + 11 * 50_000_000)


@settings(max_examples=40, deadline=None)
@given(frame=st.text(max_size=13), child=st.text(max_size=13),
       seed=st.integers(0, 2**32 - 1), t_ns=st.integers(0, 2**40))
def test_vectorized_decode_equals_rosbags_deserializer(frame, child, seed, t_ns):
    """The array fast path of read_bag gives what rosbags' deserializer gives, for any string
    lengths (CDR alignment of the float64 block after the frame ids)."""
    frame, child = frame.replace('\0', ''), child.replace('\0', '')
    rng = np.random.default_rng(seed)
    typestore = get_typestore(Stores.ROS2_JAZZY)
    raws = [serialize_message(odometry(t_ns + k, rng, frame, child)) for k in range(3)]
    t, values, frames = bag_reader._decode_fixed(raws, 2, 85)
    assert frames == [frame, child]
    for k, raw in enumerate(raws):
        m = typestore.deserialize_cdr(raw, 'nav_msgs/msg/Odometry')
        assert t[k] == m.header.stamp.sec + m.header.stamp.nanosec * 1e-9
        expected = np.concatenate([vec(m.pose.pose.position), quat(m.pose.pose.orientation),
                                   m.pose.covariance, vec(m.twist.twist.linear),
                                   vec(m.twist.twist.angular), m.twist.covariance])
        np.testing.assert_array_equal(values[k], expected)


def test_big_endian_messages_fall_back_to_deserializer(tmp_path):
    """CDR in big endian (legal, never produced by rclpy here) is decoded one by one."""
    typestore = get_typestore(Stores.ROS2_JAZZY)
    rng = np.random.default_rng(3)
    msgs = [typestore.deserialize_cdr(serialize_message(vector3(k * S_NS, rng)),
                                      'geometry_msgs/msg/Vector3Stamped') for k in range(4)]
    topic = c.absolute(c.GUIDANCE_MANEUVER)
    with fb.BagWriter(tmp_path / 'bag', {topic: 'geometry_msgs/msg/Vector3Stamped'}, S_NS) as w:
        for k, m in enumerate(msgs):
            raw = typestore.serialize_cdr(m, 'geometry_msgs/msg/Vector3Stamped',
                                          little_endian=False)
            assert raw[1] == 0
            w.write(topic, k * S_NS, raw)
    got = fb.read_bag(tmp_path / 'bag', [topic])[topic]
    np.testing.assert_array_equal(got.t, np.arange(4.0))
    np.testing.assert_array_equal(got.vector, [vec(m.vector) for m in msgs])


def test_empty_topics_give_empty_arrays(tmp_path):
    with fb.BagWriter(tmp_path / 'bag', ALL_TOPICS, S_NS):
        pass
    data = fb.read_bag(tmp_path / 'bag')
    assert data[ODOM].position.shape == (0, 3)
    assert data[ODOM].pose_covariance.shape == (0, 6, 6)
    assert data[c.absolute(c.MISSION_EVENTS)] == []
    assert data[c.absolute(c.PLANNER_PATH)].count == 0
    assert fb.bag_time_range(tmp_path / 'bag') is None


def test_errors_name_the_input(tmp_path):
    with pytest.raises(ValueError, match='flush_period_ns'):
        fb.BagWriter(tmp_path / 'a', ALL_TOPICS, 0)
    with pytest.raises(ValueError, match="'sim/chaser/odom'"):
        fb.BagWriter(tmp_path / 'b', {'sim/chaser/odom': 'nav_msgs/msg/Odometry'}, S_NS)
    with pytest.raises(ValueError, match='no_pkg/msg/Nothing'):
        fb.BagWriter(tmp_path / 'c', {'/x': 'no_pkg/msg/Nothing'}, S_NS)
    with fb.BagWriter(tmp_path / 'd', {ODOM: 'nav_msgs/msg/Odometry'}, S_NS) as w:
        with pytest.raises(ValueError, match='/not/declared'):
            w.write('/not/declared', 0, b'')
    with pytest.raises(fb.BagError, match='/sim/nothing'):
        fb.read_bag(tmp_path / 'd', ['/sim/nothing'])
    with pytest.raises(fb.BagError, match=str(tmp_path / 'missing')):
        fb.read_bag(tmp_path / 'missing')
    with pytest.raises(fb.BagError, match=str(tmp_path / 'missing')):
        fb.repair_bag(tmp_path / 'missing')


# --------------------------------------------------------------------------------------------
# Durability and repair
# --------------------------------------------------------------------------------------------

def mcap_of(bag_dir):
    (path,) = Path(bag_dir).glob('*.mcap')
    return path


def test_internals_flush_forces_chunk_to_disk(tmp_path):
    """Guard on the rosbags 0.11.9 internals BagWriter relies on (McapWriter.close_chunk, bio).

    If this fails after a rosbags upgrade, ``_force_pending_chunk_to_disk`` must be rewritten.
    """
    assert callable(getattr(McapWriter, 'close_chunk', None)), 'rosbags McapWriter.close_chunk gone'
    bag_dir = tmp_path / 'bag'
    rng = np.random.default_rng(1)
    writer = fb.BagWriter(bag_dir, {ODOM: 'nav_msgs/msg/Odometry'}, 1000 * S_NS)
    mcap = mcap_of(bag_dir)
    assert writer._writer.storage.bio.fileno() >= 0
    raws = [serialize_message(odometry(k * S_NS, rng)) for k in range(10)]
    for k, raw in enumerate(raws):
        writer.write(ODOM, k * S_NS, raw)
    size_before = mcap.stat().st_size
    assert writer.flush_count == 0
    writer.flush()
    assert writer.flush_count == 1
    size_after = mcap.stat().st_size
    assert size_after >= size_before + sum(len(r) for r in raws), (size_before, size_after)
    # What is on disk now (the writer still open) is enough to rebuild every message.
    copy = tmp_path / 'copy'
    copy.mkdir()
    shutil.copyfile(mcap, copy / 'copy.mcap')
    report = fb.repair_bag(copy)
    assert report['messages'] == {ODOM: 10}
    with AnyReader([copy], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        assert [bytes(raw) for _, _, raw in reader.messages()] == [bytes(r) for r in raws]
    # Nothing pending: flush writes no (empty) chunk.
    writer.flush()
    assert (writer.flush_count, mcap.stat().st_size) == (1, size_after)
    writer.close()
    assert (bag_dir / 'metadata.yaml').is_file()
    writer.close()  # twice is fine


def test_flush_period_is_message_time(tmp_path):
    topic = c.absolute(c.CLOCK)
    raw = serialize_message(Clock())
    with fb.BagWriter(tmp_path / 'bag', {topic: 'rosgraph_msgs/msg/Clock'}, 2 * S_NS,
                      fsync=False) as writer:
        for k in range(101):  # 10 s of message time at 10 Hz
            writer.write(topic, k * S_NS // 10, raw)
        assert writer.flush_count == 5  # at t = 2, 4, 6, 8, 10 s
        writer.write(topic, 3 * S_NS, raw)  # time jumped back (simulation restarted)
        assert writer.flush_count == 6
        writer.write(topic, 4 * S_NS, raw)
        assert writer.flush_count == 6


CHILD = textwrap.dedent('''
    import sys, time
    import numpy as np
    from rclpy.serialization import serialize_message
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import String
    from builtin_interfaces.msg import Time
    from flyby_msgs_py.bag import BagWriter

    STEP_NS = 50_000_000
    topics = {'/clock': 'rosgraph_msgs/msg/Clock', '/sim/chaser/odom': 'nav_msgs/msg/Odometry',
              '/mission/phase': 'std_msgs/msg/String'}
    writer = BagWriter(sys.argv[1], topics, 2_000_000_000)
    writer.write('/mission/phase', 0, serialize_message(String(data='ESTIMATION')))
    odom = Odometry()
    k = 0
    while True:
        t = k * STEP_NS
        stamp = Time(sec=t // 10**9, nanosec=t % 10**9)
        writer.write('/clock', t, serialize_message(Clock(clock=stamp)))
        odom.header.stamp = stamp
        odom.pose.pose.position.x = float(k)
        writer.write('/sim/chaser/odom', t, serialize_message(odom))
        print(f'WROTE {t} {k}', flush=True)
        k += 1
        if k % 20 == 0:
            time.sleep(0.002)
''')


KILL_AFTER_NS = 31_350_000_000


def test_sigkill_loses_at_most_one_flush_period(tmp_path):
    """A writer killed with SIGKILL mid-stream; the repaired bag reaches within one flush period
    (2 s) plus one message of the last message the child reported writing."""
    script = tmp_path / 'child.py'
    script.write_text(CHILD)
    bag_dir = tmp_path / 'bag'
    proc = subprocess.Popen([sys.executable, str(script), str(bag_dir)], stdout=subprocess.PIPE,
                            text=True)
    line = ''
    try:
        deadline = time.monotonic() + 20.0
        for line in proc.stdout:
            # Kill off the flush grid (flushes at 2, 4, ... s): 1.35 s after the last flush.
            if int(line.split()[1]) >= KILL_AFTER_NS or time.monotonic() > deadline:
                break
        os.kill(proc.pid, signal.SIGKILL)
        rest = proc.stdout.read().split('\n')
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    reported = [x for x in [line] + rest if x.startswith('WROTE')]
    assert reported, 'the child wrote nothing (see its stderr above)'
    last_line = reported[-1]
    t_reported, k_reported = map(int, last_line.split()[1:])
    assert t_reported >= KILL_AFTER_NS, 'child too slow to reach 31.35 s of message time'

    assert not (bag_dir / 'metadata.yaml').exists()
    with pytest.raises(Exception, match='metadata'):
        with AnyReader([bag_dir], default_typestore=get_typestore(Stores.ROS2_JAZZY)):
            pass
    with pytest.raises(fb.BagError, match='repair'):
        fb.read_bag(bag_dir)

    report = fb.repair_bag(bag_dir)
    assert report['status'] == 'repaired'
    data = fb.read_bag(bag_dir)
    odom = data['/sim/chaser/odom']
    step_ns, period_ns = 50_000_000, 2 * S_NS
    print(f'\nSIGKILL: reported {t_reported * 1e-9:.2f} s, salvaged up to '
          f'{report["last_timestamp_ns"] * 1e-9:.2f} s, {report["message_count"]} messages; '
          f'{report["bytes_salvaged"]} of {report["bytes_total"]} bytes')
    assert report['last_timestamp_ns'] >= t_reported - period_ns - step_ns
    assert odom.t[-1] * S_NS >= t_reported - period_ns - step_ns - 1
    # What was salvaged is an unbroken prefix of what was written.
    np.testing.assert_array_equal(odom.position[:, 0], np.arange(len(odom.t)))
    # A flush falls between the clock and the odometry of one step: one clock more at most.
    clock_t = data['/clock'].t
    assert len(clock_t) - len(odom.t) in (0, 1)
    np.testing.assert_array_equal(clock_t[:len(odom.t)], odom.t)
    assert data['/mission/phase'].data == ['ESTIMATION']
    assert report['messages']['/sim/chaser/odom'] == len(odom.t) <= k_reported + 1
    # The damaged original is kept; a second repair finds a valid bag.
    assert Path(report['damaged_file']).is_file()
    assert Path(report['damaged_file']).name.endswith('.mcap.damaged')
    again = fb.repair_bag(bag_dir)
    assert (again['status'], again['messages']) == ('valid', report['messages'])


@pytest.fixture(scope='module')
def flushed_bag(tmp_path_factory):
    """A closed bag with many chunks and the (file size, messages written) after each flush."""
    bag_dir = tmp_path_factory.mktemp('good') / 'bag'
    rng = np.random.default_rng(11)
    topic = ODOM
    marks = []
    raws = [serialize_message(odometry(k * 100_000_000, rng)) for k in range(200)]
    writer = fb.BagWriter(bag_dir, {topic: 'nav_msgs/msg/Odometry'}, S_NS, fsync=False)
    mcap = mcap_of(bag_dir)
    for k, raw in enumerate(raws):
        flushes = writer.flush_count
        writer.write(topic, k * 100_000_000, raw)
        if writer.flush_count != flushes:
            marks.append((mcap.stat().st_size, k + 1))
    writer.close()
    return bag_dir, marks, raws


def cut_copy(bag_dir, offset, dest):
    dest.mkdir()
    src = mcap_of(bag_dir)
    with src.open('rb') as f:
        (dest / src.name).write_bytes(f.read(offset))
    return dest


def salvaged_raws(bag_dir):
    with AnyReader([bag_dir], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        return [bytes(raw) for _, _, raw in reader.messages()]


def test_cut_at_chosen_offsets_repairs_to_complete_prefix(tmp_path, flushed_bag):
    bag_dir, marks, raws = flushed_bag
    assert len(marks) >= 15
    full = mcap_of(bag_dir).stat().st_size
    (s1, n1), s2, (s9, n9) = marks[0], marks[1][0], marks[8]
    cases = {
        0: 0, 5: 0, 8: 0, 30: 0,             # nothing, half magic, magic, inside the header
        s1 - 1: n1,                          # chunk 1 complete, its message index cut
        s1: n1, (s1 + s2) // 2: n1,          # chunk 2 half-written
        s9: n9, s9 + 9: n9, s9 + 10: n9,     # a next record's head / first byte of its body
        full - 1: len(raws),                 # only the closing magic cut
        full: len(raws),                     # complete file, metadata.yaml missing
    }
    for i, (offset, expected) in enumerate(sorted(cases.items())):
        cut = cut_copy(bag_dir, offset, tmp_path / f'cut{i}')
        report = fb.repair_bag(cut)
        assert report['message_count'] == expected, (offset, report)
        assert salvaged_raws(cut) == [bytes(r) for r in raws[:expected]], offset
        assert (cut / 'metadata.yaml').is_file()
        damaged = Path(report['damaged_file'])
        assert damaged.stat().st_size == offset  # the original is kept byte for byte
        if expected:
            assert report['last_timestamp_ns'] == (expected - 1) * 100_000_000
            assert fb.read_bag(cut)[ODOM].position.shape == (expected, 3)
        else:
            assert report['last_timestamp_ns'] is None
            assert fb.read_bag(cut) == {}


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fraction=st.floats(0.0, 1.0))
def test_cut_anywhere_repairs_to_a_prefix(flushed_bag, fraction):
    bag_dir, marks, raws = flushed_bag
    offset = int(fraction * mcap_of(bag_dir).stat().st_size)
    with tempfile.TemporaryDirectory() as tmp:
        cut = cut_copy(bag_dir, offset, Path(tmp) / 'cut')
        report = fb.repair_bag(cut)
        n = report['message_count']
        assert n in {0, len(raws)} | {m for _, m in marks}
        # Every chunk that reached the file before the cut is salvaged.
        assert n >= max([m for size, m in marks if size <= offset], default=0)
        assert salvaged_raws(cut) == [bytes(r) for r in raws[:n]]


OP_FOOTER, OP_CHUNK, OP_MESSAGE_INDEX = 0x02, 0x06, 0x07


def record_spans(data):
    """``(opcode, start, end)`` of the top-level records of a closed MCAP file up to its footer, walked
    by their 9-byte heads (opcode uint8, body length uint64; https://mcap.dev/spec#records)."""
    spans, pos = [], len(fb.MCAP_MAGIC)
    while True:
        op, length = struct.unpack_from('<BQ', data, pos)
        spans.append((op, pos, pos + 9 + length))
        if op == OP_FOOTER:
            return spans
        pos += 9 + length


def test_salvage_cut_inside_last_chunk_and_record_heads(tmp_path, flushed_bag):
    """A file cut inside its last chunk (its head, its fixed fields, its records) or inside the head
    of a record is salvaged without exception: every message of the chunks before the cut, and the
    salvage stops where the cut record starts."""
    bag_dir, marks, raws = flushed_bag
    data = mcap_of(bag_dir).read_bytes()
    spans = record_spans(data)
    chunks = [(start, end) for op, start, end in spans if op == OP_CHUNK]
    # One chunk per flush, each on disk when the flush returned, then the one close() wrote.
    assert len(chunks) == len(marks) + 1
    assert all(end <= size for (_, end), (size, _) in zip(chunks[:-1], marks, strict=True))
    first_start = chunks[0][0]
    last_start, last_end = chunks[-1]
    index_start = next(start for op, start, _ in spans if op == OP_MESSAGE_INDEX and start >= last_end)
    # rosbags 0.11.9 writes chunks uncompressed: the compression string (body offset 28) is empty,
    # so the records length is at body offset 32 and the records start at 40.
    assert data[last_start + 9 + 28:last_start + 9 + 32] == b'\0\0\0\0'
    n_before = marks[-1][1]
    cases = [  # (cut offset, start of the record cut, messages salvaged)
        *[(last_start + k, last_start, n_before) for k in (1, 4, 8)],        # in the last chunk's head
        *[(last_start + 9 + k, last_start, n_before)                        # in its body: empty, times,
          for k in (0, 5, 24, 30, 36, 40, 41)],                            # crc, compression, length, records
        ((last_start + last_end) // 2, last_start, n_before),               # halfway through its records
        (last_end - 1, last_start, n_before),                               # all but its last byte
        *[(index_start + k, index_start, len(raws)) for k in (1, 8)],       # in the next record's head
        *[(first_start + k, first_start, 0) for k in (1, 8)],               # in the first chunk's head
    ]
    for i, (offset, cut_record, n) in enumerate(cases):
        cut = cut_copy(bag_dir, offset, tmp_path / f'cut{i}')
        found = fb.salvage_mcap(mcap_of(cut))
        assert [bytes(raw) for _, _, raw in found.messages] == [bytes(r) for r in raws[:n]], offset
        assert [t for _, t, _ in found.messages] == [k * 100_000_000 for k in range(n)], offset
        assert found.complete_until == cut_record, (offset, found.stop_reason)
        assert found.stop_reason == f'record after byte {cut_record} cut off', offset
        assert [topic for _, topic, _, _ in found.channels.values()] == ([ODOM] if n else []), offset
        report = fb.repair_bag(cut)
        assert (report['message_count'], report['bytes_salvaged']) == (n, cut_record), offset
        assert salvaged_raws(cut) == [bytes(r) for r in raws[:n]], offset


def test_salvage_zstd_chunks(tmp_path):
    """Chunks compressed with zstd (rosbags' storage compression; BagWriter writes none) are salvaged
    the same way: every complete chunk, nothing of the one cut."""
    rng = np.random.default_rng(5)
    raws = [serialize_message(odometry(k * S_NS, rng)) for k in range(12)]
    writer = Writer(tmp_path / 'bag', version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    writer.open()
    connection = writer.add_connection(ODOM, 'nav_msgs/msg/Odometry', typestore=get_typestore(Stores.ROS2_JAZZY))
    for k, raw in enumerate(raws):
        writer.write(connection, k * S_NS, raw)
        if k in (3, 7):
            writer.storage.close_chunk()  # the rosbags 0.11.9 internal BagWriter.flush uses
    writer.close()
    data = mcap_of(tmp_path / 'bag').read_bytes()
    chunks = [(start, end) for op, start, end in record_spans(data) if op == OP_CHUNK]
    assert len(chunks) == 3
    assert data[chunks[0][0] + 9 + 28:chunks[0][0] + 9 + 36] == b'\4\0\0\0zstd'
    for offset, n in [(chunks[1][0] + 20, 4), ((chunks[2][0] + chunks[2][1]) // 2, 8), (len(data) - 1, 12)]:
        path = tmp_path / f'cut{offset}.mcap'
        path.write_bytes(data[:offset])
        found = fb.salvage_mcap(path)
        assert [bytes(raw) for _, _, raw in found.messages] == [bytes(r) for r in raws[:n]], offset


def test_interrupted_repair_resumes_from_damaged_file(tmp_path, flushed_bag):
    bag_dir, marks, raws = flushed_bag
    size, n = marks[3]
    cut = cut_copy(bag_dir, size + 100, tmp_path / 'cut')
    # A repair that died after renaming the original, before writing the new bag.
    mcap = mcap_of(cut)
    mcap.rename(mcap.with_name(mcap.name + '.damaged'))
    report = fb.repair_bag(cut)
    assert report['messages'] == {ODOM: n}
    assert salvaged_raws(cut) == [bytes(r) for r in raws[:n]]


def test_valid_bag_is_left_alone(tmp_path, flushed_bag):
    bag_dir, _, raws = flushed_bag
    before = sorted((p.name, p.stat().st_mtime_ns) for p in bag_dir.iterdir())
    report = fb.repair_bag(bag_dir)
    assert (report['status'], report['repaired'], report['message_count']) == (
        'valid', False, len(raws))
    assert sorted((p.name, p.stat().st_mtime_ns) for p in bag_dir.iterdir()) == before


def test_command_line(tmp_path, flushed_bag):
    bag_dir, marks, raws = flushed_bag
    cmd = [sys.executable, '-m', 'flyby_msgs_py.bag']
    info = subprocess.run(cmd + ['info', str(bag_dir)], capture_output=True, text=True, check=True)
    assert ODOM in info.stdout and 'nav_msgs/msg/Odometry' in info.stdout
    assert str(len(raws)) in info.stdout and '19.900 s' in info.stdout

    cut = cut_copy(bag_dir, marks[2][0] + 50, tmp_path / 'cut')
    failed = subprocess.run(cmd + ['info', str(cut)], capture_output=True, text=True)
    assert failed.returncode == 1 and str(cut) in failed.stderr and 'repair' in failed.stderr
    repaired = subprocess.run(cmd + ['repair', str(cut)], capture_output=True, text=True,
                              check=True)
    assert f'{marks[2][1]} messages salvaged' in repaired.stdout
    again = subprocess.run(cmd + ['repair', str(cut)], capture_output=True, text=True, check=True)
    assert 'valid' in again.stdout
    missing = subprocess.run(cmd + ['repair', str(tmp_path / 'nope')], capture_output=True,
                             text=True)
    assert missing.returncode == 1 and str(tmp_path / 'nope') in missing.stderr
