"""The admission of messages (flyby_msgs_py.admission): one refusal per reason, what is admitted, the counts and the
message_rejected event."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_msgs_py import admission as a
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events, wiring
from flyby_msgs_py.wire import wire_event

_Q = np.array([0.0, 0.0, np.sqrt(0.5), np.sqrt(0.5)])
_ODOM = {'position': np.zeros(3), 'orientation_xyzw': _Q, 'linear': np.zeros(3), 'angular': np.array([0.0, 0.0, 0.1]),
         'pose_covariance': np.eye(6), 'twist_covariance': np.eye(6)}


def _check(admission, t, frame_id=c.FRAME_HILL, now_s=100.0, topic=c.EST_TARGET_ODOM, **changed):
    return admission.check(topic, t, frame_id, {**_ODOM, **changed}, now_s)


def test_a_nominal_stream_of_messages_is_admitted_and_counted():
    admission = a.Admission()
    assert [_check(admission, 100.0 + 0.1 * k) for k in range(5)] == [None] * 5
    assert admission.admitted[c.EST_TARGET_ODOM] == 5 and not admission.rejected
    assert admission.summary() == f'messages: {c.EST_TARGET_ODOM}: 5 admitted'


def test_a_nan_is_refused():
    assert _check(a.Admission(), 100.0, linear=np.array([0.0, math.nan, 0.0])) == a.NAN


def test_an_infinite_number_is_refused():
    assert _check(a.Admission(), 100.0, pose_covariance=np.full((6, 6), math.inf)) == a.INFINITE


def test_a_quaternion_that_is_not_a_rotation_is_refused():
    admission = a.Admission()
    assert _check(admission, 100.0, orientation_xyzw=2.0 * _Q) == a.NON_UNIT_QUATERNION
    assert _check(admission, 100.0, orientation_xyzw=np.zeros(4)) == a.NON_UNIT_QUATERNION
    # Within the tolerance of the message builders, which normalize what they send.
    assert _check(admission, 100.0, orientation_xyzw=(1.0 + 0.5 * a.QUATERNION_NORM_TOLERANCE) * _Q) is None


def test_every_pose_of_a_path_is_a_rotation():
    orientations = np.tile([0.0, 0.0, 0.0, 1.0], (3, 1))
    orientations[1] *= 1.1
    refused = a.Admission().check(c.PLANNER_PATH, 100.0, c.FRAME_HILL, {'orientations': orientations}, 100.0)
    assert refused == a.NON_UNIT_QUATERNION


def test_a_stamp_ahead_of_the_node_s_time_is_refused():
    admission = a.Admission()
    assert _check(admission, 100.0 + a.MAX_LEAD_S + 0.05) == a.FUTURE_STAMP
    # A message before the /clock of its time, or an attitude command one control period ahead, is in.
    assert _check(admission, 100.0 + a.MAX_LEAD_S) is None


def test_a_planned_time_may_be_ahead_by_the_plan_horizon_only():
    admission = a.Admission()
    burn = {'value': np.array([0.01, 0.0, 0.0])}
    assert admission.check(c.GUIDANCE_MANEUVER, 100.0 + 600.0, c.FRAME_HILL, burn, 100.0) is None
    assert admission.check(c.GUIDANCE_MANEUVER, 100.0 + a.PLAN_HORIZON_S + 1.0, c.FRAME_HILL, burn,
                           100.0) == a.FUTURE_STAMP


def test_a_stamp_far_in_the_past_is_refused():
    admission = a.Admission()
    assert _check(admission, 100.0 - a.MAX_AGE_S - 0.05) == a.PAST_STAMP
    assert _check(admission, -1.0, now_s=None) == a.PAST_STAMP  # before the run's first step
    # Events and plans too, whatever their order.
    assert admission.check(c.MISSION_EVENTS, 10.0, '', {}, 100.0) == a.PAST_STAMP


def test_a_stamp_older_than_the_last_admitted_on_a_stream_is_refused():
    admission = a.Admission()
    assert _check(admission, 100.0) is None
    assert _check(admission, 99.95) == a.OUT_OF_ORDER
    assert _check(admission, 100.05) is None  # the refused one did not move the stream's last stamp


def test_a_duplicated_stamp_on_a_stream_is_refused():
    admission = a.Admission()
    assert _check(admission, 100.0) is None
    assert _check(admission, 100.0) == a.DUPLICATE_STAMP


def test_events_and_plans_may_repeat_their_stamps_and_come_in_any_order():
    admission = a.Admission()
    stamps = (100.0, 100.0, 105.0, 100.0, 99.5)
    assert [admission.check(c.MISSION_EVENTS, t, '', {}, 100.0) for t in stamps] == [None] * 5
    target = {'position': np.zeros(3), 'orientation_xyzw': np.array([0.0, 0.0, 0.0, 1.0])}
    grasp_times = (750.0, 749.99, 749.99)  # a re-aim moves the grasp time back
    assert [admission.check(c.PLANNER_FLYBY_TARGET, t, c.FRAME_HILL, target, 100.0) for t in grasp_times] == [None] * 3


def test_a_burn_sent_again_is_a_duplicate_but_another_burn_of_the_same_stamp_is_not():
    admission = a.Admission()
    burn, avoidance = {'value': np.array([0.01, 0.0, 0.0])}, {'value': np.array([0.0, 0.0, -0.05])}
    assert admission.check(c.GUIDANCE_MANEUVER, 130.0, c.FRAME_HILL, burn, 125.0) is None
    assert admission.check(c.GUIDANCE_MANEUVER, 130.0, c.FRAME_HILL, avoidance, 125.0) is None
    assert admission.check(c.GUIDANCE_MANEUVER, 130.0, c.FRAME_HILL, dict(burn), 126.0) == a.DUPLICATE_STAMP


def test_a_wrong_frame_id_is_refused():
    admission = a.Admission()
    assert _check(admission, 100.0, frame_id=c.FRAME_ECI) == a.WRONG_FRAME
    assert admission.check(c.MISSION_EVENTS, 100.0, c.FRAME_HILL, {}, 100.0) == a.WRONG_FRAME


def test_a_joint_state_field_the_command_does_not_fill_may_be_nan():
    wheels = {'position': np.full(4, math.nan), 'velocity': np.array([]), 'effort': np.full(4, 0.01)}
    admission = a.Admission()
    assert admission.check(c.GUIDANCE_WHEELS, 100.1, c.FRAME_CHASER_BODY, wheels, 100.0) is None
    wheels['effort'][2] = math.nan
    assert admission.check(c.GUIDANCE_WHEELS, 100.2, c.FRAME_CHASER_BODY, wheels, 100.0) == a.NAN


def test_a_non_finite_stamp_is_refused():
    assert _check(a.Admission(), math.nan) == a.NAN
    assert _check(a.Admission(), math.inf, now_s=None) == a.INFINITE


def test_without_a_known_time_only_the_topic_s_own_past_bounds_a_stamp():
    admission = a.Admission()
    assert _check(admission, 1e6, now_s=None) is None
    assert _check(admission, 10.0, now_s=None) == a.OUT_OF_ORDER


def test_a_topic_without_a_rule_is_admitted():
    assert a.Admission().check(c.MISSION_PHASE, math.nan, '', {}, 0.0) is None


def test_every_topic_a_node_takes_has_a_rule_but_the_phase():
    assert set(wiring.SUBSCRIPTIONS) - set(a.RULES) == {c.MISSION_PHASE}


def test_the_rejection_event_names_the_topic_and_reason_at_powers_of_ten():
    admission = a.Admission()
    published = []
    for k in range(120):
        reason = _check(admission, 101.0 + a.MAX_LEAD_S + k)
        assert reason == a.FUTURE_STAMP
        event = admission.rejection_event(c.EST_TARGET_ODOM, reason, 101.0 + a.MAX_LEAD_S + k, 100.0)
        if event is not None:
            published.append(event)
    assert [e.values['count'] for e in published] == [1, 10, 100]
    first = wire_event(published[0])
    assert first.name == events.MESSAGE_REJECTED and first.level == 'WARN' and first.t == 100.0
    assert event_payloads.decode(first) == event_payloads.MessageRejected(
        topic=c.EST_TARGET_ODOM, reason=a.FUTURE_STAMP, count=1, t_stamp_s=101.0 + a.MAX_LEAD_S)
    assert admission.summary() == f'messages: {c.EST_TARGET_ODOM}: 0 admitted, refused {a.FUTURE_STAMP} 120'


def test_a_malformed_message_is_counted():
    admission = a.Admission()
    admission.refuse(c.SENSOR_CHASER_IMU, a.MALFORMED)
    assert admission.rejected == {(c.SENSOR_CHASER_IMU, a.MALFORMED): 1}


_UNIT_QUATERNIONS = st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(
    lambda q: np.linalg.norm(q) > 1e-3).map(lambda q: np.array(q) / np.linalg.norm(q))
_FINITE = st.floats(-1e12, 1e12)


@settings(max_examples=60, deadline=None)
@given(steps=st.lists(st.floats(1e-6, 5.0), min_size=1, max_size=30), q=_UNIT_QUATERNIONS,
       values=st.lists(_FINITE, min_size=9, max_size=9),
       lag=st.floats(-a.MAX_LEAD_S + 1e-6, a.MAX_AGE_S - 1e-6))
def test_a_finite_unit_message_with_increasing_stamps_is_always_admitted(steps, q, values, lag):
    """Stamps that increase, each less than MAX_AGE_S behind the node's time or MAX_LEAD_S ahead of it."""
    admission = a.Admission()
    t = 0.0
    for dt in steps:
        t += dt
        arrays = {'position': np.array(values[:3]), 'orientation_xyzw': q, 'linear': np.array(values[3:6]),
                  'angular': np.array(values[6:]), 'pose_covariance': np.eye(6), 'twist_covariance': np.eye(6)}
        assert admission.check(c.EST_CHASER_ODOM, t, c.FRAME_HILL, arrays, now_s=t + lag) is None
    assert admission.admitted[c.EST_CHASER_ODOM] == len(steps)


def _nominal_messages(t):
    """A message of every topic with a rule as our nodes build it (raw: its CDR bytes), at stamp t."""
    from flyby_msgs_py import convert

    q, z3 = (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0)
    odometry = convert.odometry_cdr(t, c.FRAME_HILL, c.FRAME_TARGET_BODY, z3, _Q, z3, z3, np.eye(6), np.eye(6))
    eye3 = np.eye(3)
    return {
        c.SENSOR_RELATIVE_POSITION: (convert.point_stamped_cdr(t, c.FRAME_HILL, (50.0, 0.0, 0.0)), True),
        c.SENSOR_TARGET_ATTITUDE: (convert.quaternion_stamped_cdr(t, c.FRAME_HILL, _Q), True),
        c.SENSOR_CHASER_IMU: (convert.imu_cdr(t, c.FRAME_CHASER_BODY, q, z3, z3, eye3, eye3, eye3), True),
        c.SENSOR_CHASER_WHEELS: (convert.joint_state_cdr(t, c.FRAME_CHASER_BODY, ['w0', 'w1'], velocity=[1.0, -2.0]),
                                  True),
        c.EST_TARGET_ODOM: (odometry, True),
        c.EST_CHASER_ODOM: (odometry, True),
        c.PLANNER_FLYBY_TARGET: (convert.odometry(t, c.FRAME_HILL, 'flyby_target', z3, q, z3, z3), False),
        c.PLANNER_FLYBY_INITIAL: (convert.odometry(t, c.FRAME_HILL, 'flyby_initial', z3, q, z3, z3), False),
        c.PLANNER_GRASP: (convert.odometry(t, c.FRAME_HILL, 'grasp_point', z3, _Q, z3, z3), False),
        c.PLANNER_PATH: (convert.path(t, c.FRAME_HILL, [t, t + 1.0], [z3, (1.0, 0.0, 0.0)]), False),
        c.PLANNER_TRAJECTORY: (convert.multi_dof_trajectory(t, c.FRAME_HILL, [t, t + 1.0], [z3, z3], [z3, z3],
                                                            [z3, z3]), False),
        c.GUIDANCE_MANEUVER: (convert.vector3_stamped(t, c.FRAME_HILL, (0.01, 0.0, 0.0)), False),
        c.SAFETY_CAM: (convert.vector3_stamped(t, c.FRAME_HILL, (0.3, 0.0, 0.0)), False),
        c.GUIDANCE_WHEELS: (convert.joint_state_cdr(t, c.FRAME_CHASER_BODY, ['w0', 'w1'], effort=[0.1, 0.0]), True),
        c.GUIDANCE_WRENCH: (convert.wrench_stamped_cdr(t, c.FRAME_CHASER_BODY, z3, (0.0, 0.1, 0.0)), True),
        c.EST_TARGET_INERTIA: (convert.inertia_stamped(t, c.FRAME_CHASER_BODY, 1500.0, z3, np.eye(3)), False),
        c.MISSION_EVENTS: (convert.event(t, 'OK', events.SIM_STARTED, 'started', {'x': math.nan}), False),
    }


def test_every_message_our_nodes_build_is_admitted_as_the_node_reads_it():
    """The node's reader (node_base) gives the rules the arrays by the names they expect, from the message or from
    its CDR bytes; two messages a step apart are admitted, the second again is a duplicate on a stream (and a burn)."""
    from flyby_msgs_py.node_base import _READERS, _stamp_frame_arrays

    admission = a.Admission()
    first, second = _nominal_messages(100.0), _nominal_messages(100.05)
    assert set(first) == set(a.RULES)
    for topic in sorted(a.RULES):
        if c.TOPIC_TYPES[topic] not in _READERS:
            continue  # recorded, taken by no node
        for messages in (first, second):
            msg, raw = messages[topic]
            t, frame_id, arrays = _stamp_frame_arrays(c.TOPIC_TYPES[topic], msg, raw)
            assert admission.check(topic, t, frame_id, arrays, 100.0) is None, topic
        again = admission.check(topic, t, frame_id, arrays, 100.0)
        assert again == (a.DUPLICATE_STAMP if a.RULES[topic].stream or a.RULES[topic].unique else None), topic
        for name in a.RULES[topic].quaternions:
            assert name in arrays, (topic, name)
