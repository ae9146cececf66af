"""A rogue node on the contract's topics: every subscriber refuses and counts what it sends, and the mission flies on.

First a node's gate alone (node_base.AdmissionGate): bytes no reader can read and a NaN never reach the core, each
reported once. Then the graph:
a short fly-by (planning after 20 s of observation, 80 s of sim time) in the graph, every node real and in this
process on its own ROS domain, with one more node that hears the sensors, the estimates, guidance's burns and the
events and sends, now and then, a spoiled copy of what it heard: a NaN, an infinite number, a quaternion twice too
long, a stamp far ahead or before the run, one older than the last, the same message again, a wrong frame_id
(flyby_msgs_py.admission). Each subscriber of each topic reports the first refusal of each kind on mission/events
(``message_rejected``); the mission flies as it flies without the rogue, to the bit: the same as headless.
"""

import collections
import math
import struct

import numpy as np
from rclpy.node import Node
from rclpy.serialization import deserialize_message, serialize_message

from flyby_mission.headless import run_headless
from flyby_msgs_py import admission as a
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, events, qos, wiring
from flyby_msgs_py.bag import read_bag
from flyby_msgs_py.node_base import CoreNode
from flyby_sim.dynamics.rotation import quat_rotate
from flyby_sim.scenario import load_scenario
from flyby_testing import collect, spin_until, write_scenario

ROGUE = 'flyby_rogue'
EVERY = 40  # the rogue spoils one heard message in EVERY of a topic (every burn of guidance's)
T_FIRST_S = 5.0  # and none before (a stamp 0.5 s older is still a time of the run)

# topic -> the spoils the rogue sends of it, each refused for the reason given.
SPOILS = {
    c.SENSOR_RELATIVE_POSITION: ('nan', 'inf', 'future', 'past', 'older', 'again', 'frame'),
    c.SENSOR_TARGET_ATTITUDE: ('non_unit', 'nan', 'again'),
    c.EST_TARGET_ODOM: ('nan', 'non_unit', 'future', 'past', 'older', 'again', 'frame'),
    c.EST_CHASER_ODOM: ('inf', 'older', 'again', 'frame'),
    c.GUIDANCE_MANEUVER: ('nan', 'inf', 'future', 'past', 'again', 'frame'),
    c.MISSION_EVENTS: ('future', 'past', 'frame'),
}
REASONS = {'nan': a.NAN, 'inf': a.INFINITE, 'non_unit': a.NON_UNIT_QUATERNION, 'future': a.FUTURE_STAMP,
           'past': a.PAST_STAMP, 'older': a.OUT_OF_ORDER, 'again': a.DUPLICATE_STAMP, 'frame': a.WRONG_FRAME}


def _numbers(msg):
    """The message's first vector (a position, a point, a burn; a quaternion's x, y, z) and its quaternion."""
    if hasattr(msg, 'pose'):
        return msg.pose.pose.position, msg.pose.pose.orientation
    if hasattr(msg, 'quaternion'):
        return msg.quaternion, msg.quaternion
    return (msg.point if hasattr(msg, 'point') else msg.vector), None


def spoiled(msg, spoil):
    """The message (a fresh copy) spoiled one way; 'again' leaves it as it is."""
    stamp = msg.header.stamp
    if spoil in ('nan', 'inf'):
        _numbers(msg)[0].x = math.nan if spoil == 'nan' else math.inf
    elif spoil == 'non_unit':
        q = _numbers(msg)[1]
        q.x, q.y, q.z, q.w = 2.0 * q.x, 2.0 * q.y, 2.0 * q.z, 2.0 * q.w
    elif spoil == 'future':
        stamp.sec += int(2 * a.PLAN_HORIZON_S)
    elif spoil == 'past':
        stamp.sec = -1000
    elif spoil == 'older':
        msg.header.stamp = convert.ns_to_stamp(convert.stamp_to_ns(stamp) - 500_000_000)
    elif spoil == 'frame':
        msg.header.frame_id = c.FRAME_ECI if msg.header.frame_id else c.FRAME_HILL
    return msg


class RogueNode(Node):
    """Hears the topics of SPOILS and sends spoiled copies (module doc); ``sent``: (topic, spoil) -> how many. What
    it hears of its own sending it ignores (the same bytes). The last one built is ``RogueNode.last``."""

    last = None

    def __init__(self, **kwargs):
        super().__init__(ROGUE, **kwargs)
        RogueNode.last = self
        self.pubs, self.heard = {}, collections.Counter()
        self.sent, self.own = collections.Counter(), collections.Counter()
        for topic in SPOILS:
            cls = c.message_class(c.TOPIC_TYPES[topic])
            self.pubs[topic] = self.create_publisher(cls, topic, qos.qos_for(topic))
            self.create_subscription(cls, topic, lambda data, topic=topic, cls=cls: self.on_message(topic, cls, data),
                                     qos.qos_for(topic), raw=True)

    def on_message(self, topic, cls, data):
        if self.own[data]:
            self.own[data] -= 1
            return
        msg = deserialize_message(data, cls)
        if convert.stamp_to_sec(msg.header.stamp) < T_FIRST_S or (topic == c.MISSION_EVENTS and
                                                                 msg.status[0].hardware_id == ROGUE):
            return
        self.heard[topic] += 1
        if topic != c.GUIDANCE_MANEUVER and self.heard[topic] % EVERY:
            return
        for spoil in SPOILS[topic]:
            if topic == c.MISSION_EVENTS:  # not an echo: a WARN no core acts on, that the summary does not count
                copy = convert.event(convert.stamp_to_sec(msg.header.stamp), 'WARN', events.WAITING_FOR_NODES,
                                     'a rogue event', source=ROGUE)
            else:
                copy = deserialize_message(data, cls)
            out = serialize_message(spoiled(copy, spoil))
            self.own[out] += 1
            self.sent[topic, spoil] += 1
            self.pubs[topic].publish(out)


class EstimateSink(CoreNode):
    """A node whose core only keeps the stamps of the target estimates it is given."""

    def __init__(self, **kwargs):
        super().__init__('estimate_sink', **kwargs)
        self.core, self.stamps = self, []
        self.publisher(c.MISSION_EVENTS)
        self.subscribe_estimates(quat_rotate)

    def on_target_estimate(self, t, q_hill_from_body, omega_body):
        self.stamps.append(t)
        return []

    def publish(self, outputs):
        pass


def test_bytes_no_reader_can_read_and_a_nan_never_reach_the_core(ros_context, executor):
    sink = EstimateSink(context=ros_context)
    probe = Node('probe', context=ros_context)
    pub = probe.create_publisher(c.message_class(c.TOPIC_TYPES[c.EST_TARGET_ODOM]), c.EST_TARGET_ODOM,
                                 qos.qos_for(c.EST_TARGET_ODOM))
    got = collect(probe, c.MISSION_EVENTS)
    for node in (sink, probe):
        executor.add_node(node)
    spin_until(executor, lambda: pub.get_subscription_count() > 0)

    def estimate(t):
        return convert.odometry_cdr(t, c.FRAME_HILL, c.FRAME_TARGET_BODY, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0),
                                    (0.0, 0.0, 0.0), (0.0, 0.0, 0.1))

    spoiled_rate = bytearray(estimate(2.0))
    struct.pack_into('<d', spoiled_rate, len(spoiled_rate) - 37 * 8, math.nan)  # twist.angular.z
    for data in (estimate(1.0), estimate(2.0)[:40], bytes(spoiled_rate), estimate(3.0)):
        pub.publish(data)
    spin_until(executor, lambda: len(sink.stamps) == 2 and len(got) == 2)

    assert sink.stamps == [1.0, 3.0]
    reasons = [e['values']['reason'] for m in got for e in convert.events_from_msg(m)]
    assert reasons == [a.MALFORMED, a.NAN]
    assert sink.admission_gate.admission.rejected == {(c.EST_TARGET_ODOM, a.MALFORMED): 1,
                                                       (c.EST_TARGET_ODOM, a.NAN): 1}


def _reason(topic, spoil):
    """The reason a spoil is refused. A stream's message sent again comes behind newer ones (the simulator publishes
    a few steps between two looks at its messages): out of order, a duplicate only if none came in between."""
    return a.OUT_OF_ORDER if spoil == 'again' and a.RULES[topic].stream else REASONS[spoil]


def _short_flyby(data):
    data['planner']['min_observation_s'] = 20.0
    data['simulation']['duration_s'] = 80.0


def test_a_rogue_publisher_is_refused_by_every_subscriber_and_the_mission_flies_on(tmp_path, monkeypatch):
    from flyby_mission import launcher

    for name in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'FASTRTPS_DEFAULT_PROFILES_FILE'):
        monkeypatch.setenv(name, '')  # the launcher sets them for its run; restored afterwards
    graph_for = launcher.graph_for

    def with_rogue(*args, **kwargs):
        specs = graph_for(*args, **kwargs)  # the simulator last: the rogue before it
        return [*specs[:-1], launcher.NodeSpec(ROGUE, __name__, 'RogueNode', essential=False), specs[-1]]

    monkeypatch.setattr(launcher, 'graph_for', with_rogue)
    scenario_file = write_scenario(tmp_path, edit=_short_flyby)
    out = tmp_path / 'run'
    graph = launcher.run(launcher.LaunchOptions(scenario=str(scenario_file), out=str(out), in_process=True,
                                                quiet=True, wall_timeout=300.0))

    # Safe, and flown as without the rogue: the same truth as the headless driver's to the bit.
    scenario = load_scenario(scenario_file)
    headless = run_headless(scenario).summary
    assert graph['outcome'] == headless['outcome'] == c.OUTCOME_TIME_LIMIT
    assert graph['min_clearance_m'] > 0.0
    for key in ('phase_sequence', 'maneuvers_executed', 'late_maneuvers', 'rejected_maneuvers', 'min_clearance_m',
                'delta_v_total_mps', 'fuel_used_kg', 'thrust_inside_restriction_sphere'):
        assert graph[key] == headless[key], key
    assert c.PHASE_TERMINAL_APPROACH in graph['phase_sequence'] and graph['maneuvers_executed'] >= 1

    # Every subscriber of every spoiled topic refused each spoil and said so once on mission/events.
    data = read_bag(out / 'bag', topics=[c.absolute(t) for t in (c.MISSION_EVENTS, c.EST_TARGET_ODOM,
                                                                 c.EST_CHASER_ODOM)])
    refused = collections.defaultdict(list)  # (node, topic, reason) -> its events: the 1st, 10th ... refusal
    for e in data[c.absolute(c.MISSION_EVENTS)]:
        if e['name'] == events.MESSAGE_REJECTED:
            refused[e['hardware_id'], e['values']['topic'], e['values']['reason']].append(e)
    expected = {(node, topic, _reason(topic, spoil)) for topic, spoils in SPOILS.items()
                for node in wiring.subscribers(topic, scenario) for spoil in spoils}
    replays = {(node, topic, a.DUPLICATE_STAMP) for topic, spoils in SPOILS.items() if 'again' in spoils
               for node in wiring.subscribers(topic, scenario)}
    assert expected <= set(refused) <= expected | replays
    for reports in refused.values():
        assert [e['values']['count'] for e in reports] == ['1', '10'][:len(reports)]
        assert all(e['level'] == 'WARN' for e in reports)

    # The estimator's own estimates stayed finite and unit: every bad one in the bag is one the rogue sent.
    for topic in (c.EST_TARGET_ODOM, c.EST_CHASER_ODOM):
        series = data[c.absolute(topic)]
        numbers = np.concatenate([series.position, series.orientation_xyzw, series.linear, series.angular], axis=1)
        bad = ~np.isfinite(numbers).all(axis=1)
        sent = RogueNode.last.sent
        assert bad.sum() == sent[topic, 'nan'] + sent[topic, 'inf'] > 0, topic
