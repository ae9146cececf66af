"""numpy <-> message conversions: round trips through CDR, rejection of NaN and bad shapes, stamps."""

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PointStamped, QuaternionStamped, WrenchStamped
from hypothesis import given, settings
from hypothesis import strategies as st
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.typesys import Stores, get_typestore
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import Header

from flyby_msgs_py import convert as cv
from flyby_msgs_py.contract import FRAME_CHASER_BODY, FRAME_HILL, FRAME_TARGET_BODY

RNG = np.random.default_rng(20240601)


def cdr(msg):
    """The message after a serialize/deserialize round trip (what a subscriber or a bag sees)."""
    return deserialize_message(serialize_message(msg), type(msg))


def unit_quat():
    q = RNG.normal(size=4)
    return q / np.linalg.norm(q)


# ------------------------------------------------------------------------------------------------
# Stamps

@given(st.integers(min_value=-2 ** 31 * cv.NS_PER_S, max_value=(2 ** 31 - 1) * cv.NS_PER_S + cv.NS_PER_S - 1))
def test_ns_stamp_round_trip_is_exact(ns):
    stamp = cv.ns_to_stamp(ns)
    assert 0 <= stamp.nanosec < cv.NS_PER_S
    assert cv.stamp_to_ns(stamp) == ns
    assert cv.stamp_to_ns(cdr(stamp)) == ns


@given(st.integers(min_value=0, max_value=2 ** 50))  # 2**50 ns = 13 days of simulation time
def test_ns_sec_round_trip_is_exact(ns):
    t = cv.ns_to_sec(ns)
    assert cv.sec_to_ns(t) == ns
    assert cv.stamp_to_ns(cv.sec_to_stamp(t)) == ns
    assert cv.stamp_to_sec(cv.ns_to_stamp(ns)) == t


@given(st.floats(min_value=-1e6, max_value=1e6))
def test_sec_to_stamp_rounds_to_nearest_ns(t):
    ns = cv.stamp_to_ns(cv.sec_to_stamp(t))
    assert abs(ns - t * 1e9) <= 0.5 + abs(t) * 1e9 * 2 ** -52


def test_stamp_examples():
    assert (cv.sec_to_stamp(1500.05).sec, cv.sec_to_stamp(1500.05).nanosec) == (1500, 50_000_000)
    s = cv.sec_to_stamp(-0.25)
    assert (s.sec, s.nanosec) == (-1, 750_000_000)
    assert cv.sec_to_stamp(1e-10).nanosec == 0 and cv.sec_to_stamp(6e-10).nanosec == 1
    # Simulator time kept as integer steps: k * 0.05 s comes back as exactly k * 50 ms.
    for k in (1, 3, 7, 29_999, 123_457):
        assert cv.stamp_to_ns(cv.sec_to_stamp(cv.ns_to_sec(k * 50_000_000))) == k * 50_000_000
        assert cv.stamp_to_ns(cv.sec_to_stamp(k * 0.05)) == k * 50_000_000
    assert cv.stamp_to_sec(cv.clock(12.5).clock) == 12.5
    assert cv.clock_to_sec(cdr(cv.clock(12.5))) == 12.5


@pytest.mark.parametrize('t', [math.nan, math.inf, -math.inf, 2.0 ** 31, '1.0', None, True])
def test_bad_time_rejected(t):
    with pytest.raises(ValueError, match='^t: '):
        cv.sec_to_stamp(t)


def test_bad_ns_rejected():
    with pytest.raises(ValueError, match='^ns: must be an integer'):
        cv.ns_to_stamp(1.0)
    with pytest.raises(ValueError, match='^ns: .* does not fit'):
        cv.ns_to_stamp(2 ** 31 * cv.NS_PER_S)


# ------------------------------------------------------------------------------------------------
# Odometry

def test_odometry_round_trip_through_cdr():
    p, v, w = RNG.normal(size=3), RNG.normal(size=3), RNG.normal(size=3)
    q = unit_quat()
    a = RNG.normal(size=(6, 6))
    pc, tc = a @ a.T, a.T @ a + np.eye(6)
    msg = cv.odometry(12.35, FRAME_HILL, FRAME_CHASER_BODY, p, q, v, w, pc, tc)
    for m in (msg, cdr(msg)):
        o = cv.odometry_to_numpy(m)
        assert o.t == 12.35
        assert (o.frame_id, o.child_frame_id) == (FRAME_HILL, FRAME_CHASER_BODY)
        np.testing.assert_array_equal(o.position, p)
        np.testing.assert_allclose(o.orientation_xyzw, q, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(o.linear, v)
        np.testing.assert_array_equal(o.angular, w)
        np.testing.assert_array_equal(o.pose_covariance, pc)
        np.testing.assert_array_equal(o.twist_covariance, tc)


def test_odometry_accepts_lists_and_ints_and_stores_python_floats():
    m = cv.odometry(1, FRAME_HILL, FRAME_TARGET_BODY, [0, 0, 0], [0, 0, 0, 1], (1, 2, 3), [0.0, 0.0, 0.1],
                    pose_covariance=np.eye(6).reshape(36).tolist())
    assert type(m.pose.pose.position.x) is float and type(m.twist.twist.linear.x) is float
    o = cv.odometry_to_numpy(cdr(m))
    np.testing.assert_array_equal(o.linear, [1.0, 2.0, 3.0])  # an int written raw would serialize as garbage
    np.testing.assert_array_equal(o.pose_covariance, np.eye(6))
    np.testing.assert_array_equal(o.twist_covariance, np.zeros((6, 6)))


def test_odometry_does_not_alias_the_callers_covariance():
    c = np.eye(6)
    m = cv.odometry(0.0, FRAME_HILL, FRAME_CHASER_BODY, np.zeros(3), [0, 0, 0, 1], np.zeros(3), np.zeros(3), c)
    c[0, 0] = 7.0
    assert m.pose.covariance[0] == 1.0


def test_odometry_normalizes_nearly_unit_quaternions_and_rejects_others():
    q = np.array([0.0, 0.0, 0.0, 1.0 + 1e-6])
    m = cv.odometry(0.0, FRAME_HILL, FRAME_TARGET_BODY, np.zeros(3), q, np.zeros(3), np.zeros(3))
    assert m.pose.pose.orientation.w == 1.0
    for bad in ([0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 1.0]):
        with pytest.raises(ValueError, match='^orientation_xyzw: must be a unit quaternion'):
            cv.odometry(0.0, FRAME_HILL, FRAME_TARGET_BODY, np.zeros(3), bad, np.zeros(3), np.zeros(3))


GOOD = dict(t=0.0, frame_id=FRAME_HILL, child_frame_id=FRAME_CHASER_BODY, position=np.zeros(3),
            orientation_xyzw=np.array([0.0, 0.0, 0.0, 1.0]), linear=np.zeros(3), angular=np.zeros(3))


@pytest.mark.parametrize('field,value,match', [
    ('position', np.array([0.0, math.nan, 0.0]), r'^position: must be finite'),
    ('position', [0.0, 0.0, math.inf], r'^position(\[2\])?: must be finite'),
    ('linear', np.zeros(4), r'^linear: must be a numeric array of shape \(3,\), got shape \(4,\)'),
    ('linear', np.zeros((3, 1)), r'^linear: must be a numeric array of shape \(3,\)'),
    ('angular', [0.0, 0.0], r'^angular: must be a sequence of 3 numbers, got a list of length 2'),
    ('angular', [0.0, '1', 0.0], r'^angular\[1\]: must be a number'),
    ('angular', 5.0, r'^angular: must be a sequence of 3 numbers'),
    ('orientation_xyzw', [0.0, 0.0, math.nan, 1.0], r'^orientation_xyzw\[2\]: must be finite'),
    ('orientation_xyzw', np.zeros(3), r'^orientation_xyzw: must be a numeric array of shape \(4,\)'),
    ('pose_covariance', np.eye(5), r'^pose_covariance: must be a 6x6'),
    ('twist_covariance', np.full((6, 6), math.nan), r'^twist_covariance: must be finite'),
    ('frame_id', '', r'^frame_id: must be a non-empty string'),
    ('child_frame_id', None, r'^child_frame_id: must be a non-empty string'),
    ('t', math.nan, r'^t: must be finite'),
])
@pytest.mark.parametrize('build', [cv.odometry, cv.odometry_cdr])
def test_odometry_rejects_bad_input(build, field, value, match):
    kwargs = dict(GOOD)
    kwargs[field] = value
    with pytest.raises(ValueError, match=match):
        build(**kwargs)


_frame_ids = st.text(st.characters(codec='utf-8', exclude_characters='\x00'), min_size=1, max_size=20)
_finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=200, deadline=None)
@given(t=st.floats(min_value=-1e6, max_value=1e6), frame_id=_frame_ids, child_frame_id=_frame_ids,
       values=st.lists(_finite, min_size=9, max_size=9), covariances=st.booleans())
def test_odometry_cdr_is_the_messages_serialization(t, frame_id, child_frame_id, values, covariances):
    """odometry_cdr's bytes deserialize (rclpy) to odometry()'s message, and odometry_cdr_to_numpy reads rclpy's
    serialization of it as odometry_to_numpy reads the message: field by field, to the bit."""
    kwargs = dict(t=t, frame_id=frame_id, child_frame_id=child_frame_id, position=values[0:3],
                  orientation_xyzw=unit_quat(), linear=values[3:6], angular=values[6:9])
    if covariances:
        kwargs.update(pose_covariance=RNG.normal(size=(6, 6)), twist_covariance=RNG.normal(size=36))
    msg = cv.odometry(**kwargs)
    data = cv.odometry_cdr(**kwargs)
    assert deserialize_message(data, Odometry) == msg
    rclpy_data = serialize_message(msg)
    assert len(rclpy_data) == len(data)
    for ours, theirs in zip(cv.odometry_cdr_to_numpy(rclpy_data), cv.odometry_to_numpy(msg), strict=True):
        if isinstance(theirs, np.ndarray):
            assert ours.shape == theirs.shape and ours.tobytes() == theirs.tobytes()
        else:
            assert ours == theirs


def test_odometry_cdr_to_numpy_rejects_other_bytes():
    data = cv.odometry_cdr(**GOOD)
    with pytest.raises(ValueError, match='expected little-endian CDR'):
        cv.odometry_cdr_to_numpy(b'\x00\x00' + data[2:])
    with pytest.raises(ValueError, match='bytes of CDR, expected'):
        cv.odometry_cdr_to_numpy(data[:-8])
    with pytest.raises(ValueError, match='malformed CDR string'):
        cv.odometry_cdr_to_numpy(data[:12] + b'\xff' * 4 + data[16:])


def _same_arrays(ours, theirs):
    for a, b in zip(ours, theirs, strict=True):
        if isinstance(b, np.ndarray):
            assert a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
        else:
            assert a == b


_V3, _Q = RNG.normal(size=3), unit_quat()
CDR_CODECS = [  # builder, its CDR twin, reader, its CDR twin, message type, arguments after (t, frame_id)
    (cv.point_stamped, cv.point_stamped_cdr, cv.point_stamped_to_numpy, cv.point_stamped_cdr_to_numpy,
     PointStamped, (_V3,)),
    (cv.quaternion_stamped, cv.quaternion_stamped_cdr, cv.quaternion_stamped_to_numpy,
     cv.quaternion_stamped_cdr_to_numpy, QuaternionStamped, (_Q,)),
    (cv.wrench_stamped, cv.wrench_stamped_cdr, cv.wrench_stamped_to_numpy, cv.wrench_stamped_cdr_to_numpy,
     WrenchStamped, (_V3, 2.0 * _V3)),
    (cv.imu, cv.imu_cdr, cv.imu_to_numpy, cv.imu_cdr_to_numpy, Imu,
     (_Q, _V3, 3.0 * _V3, np.eye(3), 2.0 * np.eye(3), RNG.normal(size=9))),
    (cv.imu, cv.imu_cdr, cv.imu_to_numpy, cv.imu_cdr_to_numpy, Imu,
     (None, _V3, 3.0 * _V3, None, 2.0 * np.eye(3), RNG.normal(size=9))),
]


@pytest.mark.parametrize('build,build_cdr,read,read_cdr,msg_type,args', CDR_CODECS)
@pytest.mark.parametrize('frame_id', ['h', 'hill', 'chaser_body', 'grasp_point_hill'])
def test_stamped_cdr_is_the_messages_serialization(build, build_cdr, read, read_cdr, msg_type, args, frame_id):
    """Each *_cdr builder's bytes deserialize (rclpy) to its builder's message, and each *_cdr_to_numpy reads
    rclpy's serialization as the message reader reads the message (every frame length: string padding)."""
    msg = build(123.456789, frame_id, *args)
    assert deserialize_message(build_cdr(123.456789, frame_id, *args), msg_type) == msg
    _same_arrays(read_cdr(serialize_message(msg)), read(msg))


@pytest.mark.parametrize('names', [['w'], ['wheel_0', 'wheel_1', 'wheel_2'], [f'thruster_{i}' for i in range(12)]])
@pytest.mark.parametrize('fields', [dict(velocity=[1.0, -2.0], effort=[0.5, 0.25]), dict(effort=[3.0, 4.0]), {}])
def test_joint_state_cdr_is_the_messages_serialization(names, fields):
    fields = {k: (v * len(names))[:len(names)] for k, v in fields.items()}
    msg = cv.joint_state(7.25, FRAME_CHASER_BODY, names, **fields)
    data = cv.joint_state_cdr(7.25, FRAME_CHASER_BODY, names, **fields)
    _same_arrays(cv.joint_state_to_numpy(deserialize_message(data, JointState)), cv.joint_state_to_numpy(msg))
    _same_arrays(cv.joint_state_cdr_to_numpy(serialize_message(msg)), cv.joint_state_to_numpy(msg))


def test_header_cdr_to_ns_reads_stamp_and_frame():
    header = Header(frame_id='chaser1/flyby_sim')
    header.stamp.sec, header.stamp.nanosec = 5, 7
    assert cv.header_cdr_to_ns(serialize_message(header)) == (5_000_000_007, 'chaser1/flyby_sim')


@given(st.integers(min_value=0, max_value=2 ** 50))
def test_clock_cdr_to_ns_reads_the_clock(ns):
    assert cv.clock_cdr_to_ns(serialize_message(cv.clock(cv.ns_to_sec(ns)))) == ns


# ------------------------------------------------------------------------------------------------
# Stamped geometry, Clock, String

def test_stamped_round_trips_through_cdr():
    v, q = RNG.normal(size=3), unit_quat()
    for build, read, value in ((cv.vector3_stamped, cv.vector3_stamped_to_numpy, v),
                               (cv.point_stamped, cv.point_stamped_to_numpy, v),
                               (cv.quaternion_stamped, cv.quaternion_stamped_to_numpy, q)):
        msg = cdr(build(3.25, FRAME_HILL, value))
        t, out = read(msg)
        assert t == 3.25 and msg.header.frame_id == FRAME_HILL
        np.testing.assert_allclose(out, value, rtol=0, atol=1e-15)


def test_wrench_round_trip_through_cdr():
    f, tq = RNG.normal(size=3), RNG.normal(size=3)
    out = cv.wrench_stamped_to_numpy(cdr(cv.wrench_stamped(0.05, FRAME_HILL, f, tq)))
    assert out.t == 0.05
    np.testing.assert_array_equal(out.force, f)
    np.testing.assert_array_equal(out.torque, tq)
    np.testing.assert_array_equal(cv.wrench_stamped_to_numpy(cv.wrench_stamped(0.0, FRAME_HILL, f)).torque, 0.0)


def test_imu_round_trip_through_cdr_with_and_without_attitude():
    q, w, a = unit_quat(), RNG.normal(size=3), RNG.normal(size=3)
    cov_q, cov_w, cov_a = (np.diag(RNG.uniform(1e-12, 1e-6, 3)) for _ in range(3))
    out = cv.imu_to_numpy(cdr(cv.imu(1.5, FRAME_CHASER_BODY, q, w, a, cov_q, cov_w, cov_a)))
    assert out.t == 1.5 and out.frame_id == FRAME_CHASER_BODY
    np.testing.assert_allclose(out.orientation_xyzw, q, rtol=0, atol=1e-15)
    for got, want in ((out.angular_velocity, w), (out.linear_acceleration, a), (out.orientation_covariance, cov_q),
                      (out.angular_velocity_covariance, cov_w), (out.linear_acceleration_covariance, cov_a)):
        np.testing.assert_array_equal(got, want)
    bare = cdr(cv.imu(1.6, FRAME_CHASER_BODY, None, w, a, None, cov_w, cov_a))
    assert bare.orientation_covariance[0] == -1.0  # sensor_msgs: no orientation in this sample
    out = cv.imu_to_numpy(bare)
    assert out.orientation_xyzw is None and out.orientation_covariance is None
    with pytest.raises(ValueError, match='^angular_velocity: must be finite'):
        cv.imu(0.0, FRAME_CHASER_BODY, q, [0.0, math.nan, 0.0], a, cov_q, cov_w, cov_a)
    with pytest.raises(ValueError, match=r'^orientation_covariance: must be a 3x3 \(or flat 9\) numeric covariance, '
                                         r'got shape \(2, 2\)$'):
        cv.imu(0.0, FRAME_CHASER_BODY, q, w, a, np.eye(2), cov_w, cov_a)


def test_joint_state_round_trip_through_cdr():
    speed, torque = RNG.normal(size=3), RNG.normal(size=3)
    out = cv.joint_state_to_numpy(cdr(cv.joint_state(2.0, FRAME_CHASER_BODY, ['w0', 'w1', 'w2'], speed, torque)))
    assert out.t == 2.0 and out.names == ['w0', 'w1', 'w2'] and out.position.shape == (0,)  # not given: empty
    np.testing.assert_array_equal(out.velocity, speed)
    np.testing.assert_array_equal(out.effort, torque)
    with pytest.raises(ValueError, match=r'^effort: must have one value per name \(3\), got 2'):
        cv.joint_state(0.0, FRAME_CHASER_BODY, ['w0', 'w1', 'w2'], speed, torque[:2])
    with pytest.raises(ValueError, match=r'^velocity\[1\]: must be finite'):
        cv.joint_state(0.0, FRAME_CHASER_BODY, ['w0', 'w1', 'w2'], [0.0, math.inf, 0.0])


@pytest.mark.parametrize('names', [['w0', 'w1', 'w2'], ['wheel_0', 'wheel_1', 'wheel_2'], [f't{i}' for i in range(12)]])
@pytest.mark.parametrize('given', [('velocity', 'effort'), ('effort',), ('velocity',), ()])
def test_joint_state_opens_in_rosbags_whatever_fields_are_given(names, given):
    """The bytes a node publishes (joint_state_cdr, as Fast DDS delivers them) read in rosbags, a field not given
    empty, and rosbags writes the same bytes back."""
    values = {field: RNG.normal(size=len(names)) for field in given}
    raw = cv.joint_state_cdr(1.0, FRAME_CHASER_BODY, names, **values)
    typestore = get_typestore(Stores.ROS2_JAZZY)
    msg = typestore.deserialize_cdr(raw, 'sensor_msgs/msg/JointState')
    assert list(msg.name) == names
    for field in ('position', 'velocity', 'effort'):
        np.testing.assert_array_equal(getattr(msg, field), values.get(field, np.zeros(0)))
    assert bytes(typestore.serialize_cdr(msg, 'sensor_msgs/msg/JointState')) == raw


def test_string_round_trip_through_cdr():
    assert cv.string_to_str(cdr(cv.string('TERMINAL_APPROACH'))) == 'TERMINAL_APPROACH'
    with pytest.raises(ValueError, match='^data: must be a string'):
        cv.string(3)


@pytest.mark.parametrize('build,field', [(cv.vector3_stamped, 'vector'), (cv.point_stamped, 'point')])
def test_stamped_rejects_nan_and_shape(build, field):
    with pytest.raises(ValueError, match=f'^{field}: must be finite'):
        build(0.0, FRAME_HILL, np.array([0.0, 0.0, math.nan]))
    with pytest.raises(ValueError, match=f'^{field}: must be a numeric array of shape'):
        build(0.0, FRAME_HILL, np.zeros(2))
    with pytest.raises(ValueError, match=f'^{field}: must be a numeric array of shape'):
        build(0.0, FRAME_HILL, np.array(['a', 'b', 'c']))


def test_wrench_and_quaternion_reject_nan():
    with pytest.raises(ValueError, match=r'^torque(\[0\])?: must be finite'):
        cv.wrench_stamped(0.0, FRAME_HILL, np.zeros(3), [math.nan, 0.0, 0.0])
    with pytest.raises(ValueError, match=r'^quaternion_xyzw\[3\]: must be finite'):
        cv.quaternion_stamped(0.0, FRAME_HILL, [0.0, 0.0, 0.0, math.nan])


# ------------------------------------------------------------------------------------------------
# Path

def test_path_round_trip_through_cdr():
    times = np.linspace(10.0, 20.0, 7)
    positions = RNG.normal(size=(7, 3))
    quats = np.array([unit_quat() for _ in range(7)])
    out = cv.path_to_numpy(cdr(cv.path(9.5, FRAME_HILL, times, positions, quats)))
    assert out.t == 9.5 and out.frame_id == FRAME_HILL
    np.testing.assert_allclose(out.times, times, rtol=0, atol=0.5e-9)  # stamps are whole nanoseconds
    np.testing.assert_array_equal(out.positions, positions)
    np.testing.assert_allclose(out.orientations, quats, rtol=0, atol=1e-15)
    plain = cv.path_to_numpy(cv.path(0.0, FRAME_HILL, times[:2], positions[:2]))
    np.testing.assert_array_equal(plain.orientations, [[0, 0, 0, 1], [0, 0, 0, 1]])
    empty = cv.path_to_numpy(cdr(cv.path(0.0, FRAME_HILL, [], np.zeros((0, 3)))))
    assert empty.positions.shape == (0, 3) and empty.times.shape == (0,)


def test_path_rejects_bad_input():
    with pytest.raises(ValueError, match=r'^positions: must have shape \(N, 3\)'):
        cv.path(0.0, FRAME_HILL, [0.0, 1.0], np.zeros((2, 2)))
    with pytest.raises(ValueError, match='^positions: must be finite'):
        cv.path(0.0, FRAME_HILL, [0.0, 1.0], [[0, 0, 0], [0, math.nan, 0]])
    with pytest.raises(ValueError, match='^times: must be a sequence of 2 numbers'):
        cv.path(0.0, FRAME_HILL, [0.0], np.zeros((2, 3)))
    with pytest.raises(ValueError, match='^times: must be finite'):
        cv.path(0.0, FRAME_HILL, [0.0, math.inf], np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r'^orientations: must have 2 rows'):
        cv.path(0.0, FRAME_HILL, [0.0, 1.0], np.zeros((2, 3)), [[0, 0, 0, 1]])
    with pytest.raises(ValueError, match=r'^orientations\[1\]: must be a unit quaternion'):
        cv.path(0.0, FRAME_HILL, [0.0, 1.0], np.zeros((2, 3)), [[0, 0, 0, 1], [0, 0, 0, 0]])


# ------------------------------------------------------------------------------------------------
# Events

def test_event_round_trip_through_cdr():
    values = {'dv_mps': 0.125, 'late_by_s': np.float64(0.05), 'count': 3, 'ok': True, 'dv_hill': [0.1, 0.0, -0.2],
              'phase': 'FLYBY', 'sigma': math.nan}
    msg = cv.event(101.5, 'WARN', 'late_maneuver', 'maneuver executed 0.05 s late', values, source='flyby_sim')
    assert msg.status[0].level == DiagnosticStatus.WARN and msg.status[0].hardware_id == 'flyby_sim'
    (ev,) = cv.events_from_msg(cdr(msg))
    assert ev == {'t': 101.5, 'level': 'WARN', 'name': 'late_maneuver', 'message': 'maneuver executed 0.05 s late',
                  'values': {'dv_mps': '0.125', 'late_by_s': '0.05', 'count': '3', 'ok': 'true',
                             'dv_hill': '[0.1, 0.0, -0.2]', 'phase': 'FLYBY', 'sigma': 'nan'},
                  'source': 'flyby_sim'}
    assert float(ev['values']['dv_mps']) == 0.125
    for level in ('OK', 'ERROR', 'STALE'):
        assert cv.events_from_msg(cdr(cv.event(0.0, level, 'n', 'm')))[0]['level'] == level


def test_event_rejects_bad_input():
    with pytest.raises(ValueError, match=r"^level: must be one of \['OK', 'WARN', 'ERROR', 'STALE'\], got 'INFO'"):
        cv.event(0.0, 'INFO', 'n', 'm')
    with pytest.raises(ValueError, match='^message: must be a string'):
        cv.event(0.0, 'OK', 'n', None)
    with pytest.raises(ValueError, match='^t: must be finite'):
        cv.event(math.nan, 'OK', 'n', 'm')


def test_time_message_passes_through():
    stamp = Time(sec=5, nanosec=7)
    assert cv.stamp_to_ns(cv.point_stamped(stamp, FRAME_HILL, [0.0, 0.0, 0.0]).header.stamp) == 5 * cv.NS_PER_S + 7


@settings(max_examples=50)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64), min_size=3, max_size=3))
def test_vector_round_trip_is_exact_for_any_finite_value(v):
    out = cv.vector3_stamped_to_numpy(cdr(cv.vector3_stamped(0.0, FRAME_HILL, v)))
    assert out.value.tolist() == [float(x) for x in v]
