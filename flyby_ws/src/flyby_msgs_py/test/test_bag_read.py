"""Tests of flyby_msgs_py.bag: the raw writer and the numpy readers (every contract topic, round trip).

Messages are serialized with rclpy (real CDR bytes as a raw subscription delivers them); every bag
lives in ``tmp_path``. Throughput is measured by ``scripts/bench/benchmark_bag.py``, not here. Durability,
salvage and repair: test_bag_repair.py.
"""


import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PointStamped, PoseStamped, QuaternionStamped, Vector3Stamped, WrenchStamped
from hypothesis import given, settings
from hypothesis import strategies as st
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as PathMsg
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader
from rosbags.interfaces import QosDurability, QosReliability
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
    m.name = ['wheel_0', 'wheel_1', 'wheel_2']  # position not given: empty, as sensor_msgs says
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

def _check_odometry(got, rows, msgs, t_log, t_hdr):
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


def _check_vector3(got, rows, msgs, t_log, t_hdr):
    np.testing.assert_array_equal(got.t, t_hdr)
    np.testing.assert_array_equal(got.vector, [vec(m.vector) for m in msgs])
    assert got.frame_id == 'hill'


def _check_point(got, rows, msgs, t_log, t_hdr):
    np.testing.assert_array_equal(got.t, t_hdr)
    np.testing.assert_array_equal(got.point, [vec(m.point) for m in msgs])


def _check_quaternion(got, rows, msgs, t_log, t_hdr):
    np.testing.assert_array_equal(got.t, t_hdr)
    np.testing.assert_array_equal(got.quaternion_xyzw, [quat(m.quaternion) for m in msgs])


def _check_wrench(got, rows, msgs, t_log, t_hdr):
    np.testing.assert_array_equal(got.t, t_hdr)
    np.testing.assert_array_equal(got.force, [vec(m.wrench.force) for m in msgs])
    np.testing.assert_array_equal(got.torque, [vec(m.wrench.torque) for m in msgs])


def _check_clock(got, rows, msgs, t_log, t_hdr):
    np.testing.assert_array_equal(got.t, t_hdr)
    np.testing.assert_array_equal(got.t_received, t_log)


def _check_string(got, rows, msgs, t_log, t_hdr):
    assert got.data == [m.data for m in msgs]
    assert got.t_received == list(t_log)


def _check_diagnostics(got, rows, msgs, t_log, t_hdr):
    names = {bytes(DiagnosticStatus.OK): 'OK', bytes(DiagnosticStatus.WARN): 'WARN',
             bytes(DiagnosticStatus.ERROR): 'ERROR'}
    assert got == [{'t': stamp_s(r[1]), 't_received': r[0] * 1e-9,
                    'level': names[bytes(r[2].status[0].level)], 'name': 'supervisor',
                    'message': f'event at {r[1]}', 'hardware_id': 'chaser',
                    'values': {'t_ns': str(r[1]), 'x': '1.5'}} for r in rows]


def _check_path(got, rows, msgs, t_log, t_hdr):
    last = msgs[-1]
    assert got.count == len(msgs)
    assert got.t == stamp_s(rows[-1][1])
    np.testing.assert_array_equal(
        got.times, [p.header.stamp.sec + p.header.stamp.nanosec * 1e-9 for p in last.poses])
    np.testing.assert_array_equal(got.positions, [vec(p.pose.position) for p in last.poses])
    assert got.frame_id == 'hill'


def _check_markers(got, rows, msgs, t_log, t_hdr):
    assert got.count == len(msgs)
    np.testing.assert_array_equal(got.t_received, t_log)


def _check_joints(got, rows, msgs, t_log, t_hdr):
    np.testing.assert_array_equal(got.t_received, t_log)
    np.testing.assert_array_equal(got.t, [stamp_s(r[1]) for r in rows])
    assert got.names == ['wheel_0', 'wheel_1', 'wheel_2'] and got.frame_id == 'chaser_body'
    np.testing.assert_array_equal(got.velocity, [m.velocity for m in msgs])
    np.testing.assert_array_equal(got.effort, [m.effort for m in msgs])
    assert got.position.shape == (len(msgs), 0)


def _check_inertia(got, rows, msgs, t_log, t_hdr):
    np.testing.assert_array_equal(got.t_received, t_log)
    for g, m in zip(got.messages, msgs, strict=True):
        for a, b in zip(convert.inertia_to_numpy(g.inertia), convert.inertia_to_numpy(m.inertia), strict=True):
            np.testing.assert_array_equal(a, b)


def _check_imu(got, rows, msgs, t_log, t_hdr):
    np.testing.assert_array_equal(got.t_received, t_log)
    assert [vec(g.angular_velocity) for g in got.messages] == [vec(m.angular_velocity) for m in msgs]


def _check_trajectory(got, rows, msgs, t_log, t_hdr):
    np.testing.assert_array_equal(got.t_received, t_log)
    assert [[vec(p.transforms[0].translation) for p in g.points] for g in got.messages] == \
        [[vec(p.transforms[0].translation) for p in m.points] for m in msgs]
    assert isinstance(msgs[0], MultiDOFJointTrajectory)


CHECKS = {  # type name -> check(got, rows, msgs, t_log, t_hdr) of what read_bag returns for a topic
    'nav_msgs/msg/Odometry': _check_odometry,
    'geometry_msgs/msg/Vector3Stamped': _check_vector3,
    'geometry_msgs/msg/PointStamped': _check_point,
    'geometry_msgs/msg/QuaternionStamped': _check_quaternion,
    'geometry_msgs/msg/WrenchStamped': _check_wrench,
    'rosgraph_msgs/msg/Clock': _check_clock,
    'std_msgs/msg/String': _check_string,
    'diagnostic_msgs/msg/DiagnosticArray': _check_diagnostics,
    'nav_msgs/msg/Path': _check_path,
    'visualization_msgs/msg/MarkerArray': _check_markers,
    'sensor_msgs/msg/JointState': _check_joints,
    'geometry_msgs/msg/InertiaStamped': _check_inertia,
    'sensor_msgs/msg/Imu': _check_imu,
    'trajectory_msgs/msg/MultiDOFJointTrajectory': _check_trajectory,
}


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
        if type_name not in CHECKS:
            pytest.fail(f'no check for {type_name}')
        CHECKS[type_name](data[topic], rows, msgs, t_log, t_hdr)




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
