"""The frames for viewers (flyby_msgs_py.frames): TFMessage bytes rosbags reads, the transforms of the truth, and
/tf, /tf_static in a mission's bag equal to the truth they are made from."""

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.interfaces import QosDurability
from rosbags.typesys import Stores, get_typestore

from flyby_mission.live_view import static_transforms
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, frames
from flyby_msgs_py.bag import contract_qos, read_bag
from flyby_sim.scenario import load_scenario
from flyby_testing import SCENARIOS

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


@pytest.mark.parametrize('parent,child', [('hill', 'target_body'), ('h', 'chaser1/chaser_body'),
                                          ('target_body', 'ab'), ('abc', 'chaser12/grasp_point')])
@pytest.mark.parametrize('count', [0, 1, 3])
def test_tf_message_cdr_is_what_rosbags_reads_and_writes(parent, child, count):
    """Every frame-name length (string padding) and count: rosbags reads each transform and writes the same bytes
    back."""
    rng = np.random.default_rng(count)
    tfs = [frames.Transform(1_234_567_890_123 + k, parent, child, tuple(rng.normal(size=3)),
                            tuple(rng.normal(size=4))) for k in range(count)]
    raw = frames.tf_message_cdr(tfs)
    msg = TYPESTORE.deserialize_cdr(raw, frames.TF_TYPE)
    assert bytes(TYPESTORE.serialize_cdr(msg, frames.TF_TYPE)) == raw
    for got, tf in zip(msg.transforms, tfs, strict=True):
        assert (got.header.frame_id, got.child_frame_id) == (parent, child)
        assert got.header.stamp.sec * 10**9 + got.header.stamp.nanosec == tf.t_ns
        t, q = got.transform.translation, got.transform.rotation
        assert (t.x, t.y, t.z) == tf.translation_m and (q.x, q.y, q.z, q.w) == tf.rotation_xyzw


def test_tf_message_refuses_a_non_finite_number_or_an_empty_frame():
    with pytest.raises(ValueError, match=r'^transform hill -> target_body: translation \(3\) and rotation \(4\) '
                                         r'must be finite'):
        frames.tf_message_cdr([frames.Transform(0, 'hill', 'target_body', (0.0, np.nan, 0.0), (0, 0, 0, 1.0))])
    with pytest.raises(ValueError, match=r"^transform 'hill' -> '': frame names must not be empty"):
        frames.tf_message_cdr([frames.Transform(0, 'hill', '', (0.0, 0.0, 0.0), (0, 0, 0, 1.0))])


@pytest.mark.parametrize('namespace,child,expected', [('', c.FRAME_CHASER_BODY, 'chaser_body'),
                                                      ('/chaser1', c.FRAME_CHASER_BODY, 'chaser1/chaser_body'),
                                                      ('/chaser1', c.FRAME_TARGET_BODY, 'target_body')])
def test_transform_of_an_odometry_is_its_pose_child_frame_namespaced(namespace, child, expected):
    """The pose of an Odometry is its child frame in its frame: the transform as it is, the chaser's frame under
    its namespace, the target's the same for every chaser."""
    q = np.array([0.1, -0.2, 0.3, 0.9]) / np.linalg.norm([0.1, -0.2, 0.3, 0.9])
    raw = convert.odometry_cdr(12.345678901, c.FRAME_HILL, child, (1.0, -2.0, 3.5), q, (0.1, 0.2, 0.3),
                               (0.01, 0.02, 0.03))
    tf = frames.transform_from_odometry_cdr(raw, namespace)
    assert tf == frames.Transform(12_345_678_901, c.FRAME_HILL, expected, (1.0, -2.0, 3.5), tuple(q.tolist()))


def test_truth_topics_are_the_target_and_every_chaser():
    assert frames.truth_topics(['/chaser1', '/chaser2']) == {
        '/sim/target/odom': '', '/chaser1/sim/chaser/odom': '/chaser1', '/chaser2/sim/chaser/odom': '/chaser2'}


def test_static_transforms_are_each_chasers_grasp_point():
    one = load_scenario(SCENARIOS / 'paper_flyby_6dof.yaml')
    assert static_transforms(one) == [frames.Transform(0, 'target_body', 'grasp_point',
                                                       tuple(one.target.grasp_point_body_m), (0.0, 0.0, 0.0, 1.0))]
    two = load_scenario(SCENARIOS / 'jacobsen_two_robots.yaml')
    assert [(t.child, t.translation_m) for t in static_transforms(two)] == [
        ('chaser1/grasp_point', (1.5, 0.0, 1.5)), ('chaser2/grasp_point', (-1.5, 0.0, -1.5))]


def test_static_transform_line_round_trips_and_a_bad_one_is_refused():
    tf = frames.Transform(0, 'target_body', 'grasp_point', (1.5, 0.1, -0.3), (0.0, 0.0, 0.0, 1.0))
    assert frames.parse_static(frames.format_static(tf)) == tf
    with pytest.raises(ValueError, match=r'^static transform \'target_body grasp_point 1 2\': expected '
                                         r'"PARENT CHILD X Y Z QX QY QZ QW"$'):
        frames.parse_static('target_body grasp_point 1 2')
    with pytest.raises(ValueError, match='^static transform'):
        frames.parse_static('a b 1 2 3 x 0 0 1')


def test_tf_static_is_latched_and_tf_is_not():
    (static,), (tf,) = contract_qos('/tf_static'), contract_qos('/tf')
    assert static.durability == QosDurability.TRANSIENT_LOCAL and static.depth == 1
    assert tf.durability == QosDurability.VOLATILE


@pytest.mark.slow
def test_mission_bag_has_the_truths_frames(sixdof_short_run):
    """/tf holds hill -> target_body and hill -> chaser_body at every truth odometry's stamp, equal to its pose;
    /tf_static the grasp point once, latched."""
    bag = sixdof_short_run / 'bag'
    truth = read_bag(bag, [c.absolute(c.SIM_TARGET_ODOM), c.absolute(c.SIM_CHASER_ODOM)])
    by_child = {}
    with AnyReader([bag], default_typestore=TYPESTORE) as reader:
        qos = {x.topic: x.ext.offered_qos_profiles for x in reader.connections}
        conns = [x for x in reader.connections if x.topic in (frames.TF_TOPIC, frames.TF_STATIC_TOPIC)]
        statics = []
        for conn, _t_log, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            for t in msg.transforms:
                row = (t.header.stamp.sec + 1e-9 * t.header.stamp.nanosec, t.transform.translation.x,
                       t.transform.translation.y, t.transform.translation.z, t.transform.rotation.x,
                       t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w)
                if conn.topic == frames.TF_STATIC_TOPIC:
                    statics.append((t.header.frame_id, t.child_frame_id, row[1:4]))
                else:
                    assert t.header.frame_id == c.FRAME_HILL
                    by_child.setdefault(t.child_frame_id, []).append(row)
    assert qos[frames.TF_STATIC_TOPIC][0].durability == QosDurability.TRANSIENT_LOCAL
    scenario = load_scenario(SCENARIOS / 'paper_flyby_6dof.yaml')
    assert statics == [('target_body', 'grasp_point', tuple(scenario.target.grasp_point_body_m))]
    assert sorted(by_child) == ['chaser_body', 'target_body']
    for child, topic in (('target_body', c.SIM_TARGET_ODOM), ('chaser_body', c.SIM_CHASER_ODOM)):
        odom, rows = truth[c.absolute(topic)], np.array(by_child[child])
        assert len(rows) == len(odom.t) > 100
        np.testing.assert_array_equal(rows[:, 0], odom.t)
        np.testing.assert_array_equal(rows[:, 1:4], odom.position)
        np.testing.assert_array_equal(rows[:, 4:8], odom.orientation_xyzw)


def test_truth_without_a_transform_gives_no_tf():
    """A malformed or non-finite truth message is recorded, with no /tf (the recorder never stops on it)."""
    good = convert.odometry_cdr(1.0, c.FRAME_HILL, c.FRAME_CHASER_BODY, (1.0, 2.0, 3.0), (0, 0, 0, 1.0),
                                (0, 0, 0), (0, 0, 0))
    assert frames.tf_of_truth(good) == frames.tf_message_cdr([frames.transform_from_odometry_cdr(good)])
    assert frames.tf_of_truth(good[:60]) is None
    nan_pose = bytearray(good)
    nan_pose[-8 * 85:-8 * 84] = np.float64(np.nan).tobytes()
    assert frames.tf_of_truth(bytes(nan_pose)) is None
