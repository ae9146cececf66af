"""The shell every flyby node is: a core without ROS inside, messages converted at the border.

A node subclasses ``CoreNode``, builds its core (``self.core``), creates its publishers with ``publisher`` and
its subscriptions with ``subscribe_inputs``: every topic flyby_msgs_py.wiring gives it, each to its callback
(contract type and QoS by topic name, relative to the node's namespace), and implements ``publish(outputs)``,
which turns the core's outputs into messages. The inputs several cores share are converted here once: the estimates
(``on_target_estimate(t, q_hill_from_body, omega_body)``, ``on_chaser_estimate(t, r_hill, v_hill)``, with the
six-degree-of-freedom chaser's attitude and rate when asked),
the mission phase (``on_phase(phase)``) and the events of ``mission/events`` (``on_event(wire.Event)``).

Every message of a contract topic passes its admission (flyby_msgs_py.admission, ``AdmissionGate``) before its
callback: one refused (a NaN, a quaternion that is no rotation, a stamp that is no time of the run or goes back on
a stream, a frame the contract does not give the topic) never reaches the core; it is counted, the 1st, 10th,
100th ... refusal of each topic and reason is a WARN ``message_rejected`` on ``mission/events``, and the counts go
to the node's log when it is destroyed. The simulator, which is no CoreNode, takes its commands through the same gate.
Before its admission a message passes the link (flyby_msgs_py.link_faults): where the scenario has a topic fault on
one of a node's topics, the gate hears the simulator's fault events (on the node's own mission/events subscription
where it has one) and the clock (the run loop's, runtime.ProgressReporter), and holds or drops the messages the
fault's window holds, as the headless driver does with the same rule.

Every callback that feeds the core (the subscriptions made here; a node's own subscriptions, services and
timers through ``guard``) runs inside the core's guard (flyby_msgs_py.core_guard): an exception is logged with
its traceback, published once on ``mission/events`` as an ERROR ``node_error`` stamped at the message being
handled, and from then on the node gives its core nothing more, so nothing more is published from it. The node
stays in the graph and keeps reporting its progress (runtime.ProgressReporter): the simulator is not held for it,
and the supervisor takes the mission to ABORTED on the event; on the supervisor's own event guidance idles propulsion
and the run ends in ERROR (docs/runtime.md).
"""

import math
import struct
import traceback

import numpy as np
from rclpy.node import Node

from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, link_faults, qos, wiring
from flyby_msgs_py.admission import MALFORMED, Admission
from flyby_msgs_py.core_guard import CoreGuard
from flyby_msgs_py.runtime import publish_event
from flyby_msgs_py.wire import Event


def _name(topic):
    """The name a node uses for a contract topic: a global one at its root name under a namespace (DESIGN §10)."""
    return c.absolute(topic) if topic in c.GLOBAL_TOPICS else topic


def _stamp_s(args):
    """The sim time [s] of the input a callback was given: a time itself, a message's header stamp, or the stamp
    that opens a raw message's CDR bytes (every raw contract message starts with its header); None without one."""
    for a in reversed(args):
        if isinstance(a, float):
            return a
        if isinstance(a, (bytes, bytearray, memoryview)):
            try:
                return convert.clock_cdr_to_ns(a) / 1e9
            except ValueError:
                return None
        header = getattr(a, 'header', None)
        if header is not None:
            return convert.stamp_to_sec(header.stamp)
    return None


# The numbers of a contract message, for its admission, by type: (reader of a raw subscription's CDR bytes, reader of
# the message); the array fields of what a flyby_msgs_py.convert reader returns, by name. None: no numbers (text).
_READERS = {
    'nav_msgs/msg/Odometry': (convert.odometry_cdr_to_numpy, convert.odometry_to_numpy),
    'geometry_msgs/msg/PointStamped': (convert.point_stamped_cdr_to_numpy, convert.point_stamped_to_numpy),
    'geometry_msgs/msg/QuaternionStamped': (convert.quaternion_stamped_cdr_to_numpy,
                                            convert.quaternion_stamped_to_numpy),
    'geometry_msgs/msg/Vector3Stamped': (None, convert.vector3_stamped_to_numpy),
    'geometry_msgs/msg/WrenchStamped': (convert.wrench_stamped_cdr_to_numpy, convert.wrench_stamped_to_numpy),
    'sensor_msgs/msg/Imu': (convert.imu_cdr_to_numpy, convert.imu_to_numpy),
    'sensor_msgs/msg/JointState': (convert.joint_state_cdr_to_numpy, convert.joint_state_to_numpy),
    'nav_msgs/msg/Path': (None, convert.path_to_numpy),
    'trajectory_msgs/msg/MultiDOFJointTrajectory': (None, convert.multi_dof_trajectory_to_numpy),
    'diagnostic_msgs/msg/DiagnosticArray': (None, None),
}


def _stamp_frame_arrays(type_name, msg, raw):
    """(stamp [s], frame_id, {name: array}) of a contract message, or of its CDR bytes with ``raw``."""
    cdr_reader, msg_reader = _READERS[type_name]
    if raw:
        ns, frame_id = convert.header_cdr_to_ns(msg)
        t, read = ns / 1e9, cdr_reader
    else:
        t, frame_id, read = convert.stamp_to_sec(msg.header.stamp), msg.header.frame_id, msg_reader
    if read is None:
        return t, frame_id, {}
    values = read(msg)
    return t, frame_id, {name: v for name, v in zip(values._fields, values, strict=True) if isinstance(v, np.ndarray)}


class AdmissionGate:
    """The admission of one node's messages (module doc; flyby_msgs_py.admission): ``now_s()`` the node's latest
    known sim time [s] or None, ``report(event)`` publishes an Event on its mission/events; ``label`` names the
    admission in the log (a chaser of the simulator)."""

    def __init__(self, node, now_s, report, label=''):
        self.node = node
        self.now_s = now_s
        self.report = report
        self.label = label
        self.admission = Admission()
        self.link = link_faults.LinkFaults(log=lambda line: node.get_logger().warning(line))
        self.watching = False  # whether the node hears the events for its link (``CoreNode.subscribe_inputs``)
        self._admitted = {}  # topic -> the callback behind its admission, for the messages the link releases

    def admit(self, topic, callback, raw=False):
        """``callback`` of a contract topic behind the link (``link_faults``) and the topic's admission (the callback
        itself for a topic without a rule: mission/phase, a text without a header). A watching node's mission/events
        are heard by the link first, before their admission, as the headless driver's links hear every event."""
        if topic == c.MISSION_EVENTS and self.watching:
            admitted = self._admission(topic, callback, raw)

            def heard(msg):
                self.on_link_events(msg)
                return admitted(msg)
            return heard
        if topic not in self.admission.rules:
            return callback
        admitted = self._admission(topic, callback, raw)
        self._admitted[topic] = admitted

        def received(msg):
            if not self.link.concerns(topic):
                return admitted(msg)
            try:
                t = convert.header_cdr_to_ns(msg)[0] / 1e9 if raw else convert.stamp_to_sec(msg.header.stamp)
            except (ValueError, IndexError, struct.error):  # unreadable: its admission refuses it
                return admitted(msg)
            for item in self.link.arrive(topic, t, msg):
                admitted(item)
            return None
        return received

    def on_link_events(self, msg):
        """mission/events for the link: a topic fault's fault_injected opens its window (one the link cannot read
        as a fault it refuses, in one line of the node's log: link_faults.LinkFaults.on_event)."""
        for e in convert.events_from_msg(msg):
            self.link.on_event(e['name'], e['values'])

    def release(self, now_s):
        """Hand on the messages the link held whose time has come at the receiver's time now_s [s]."""
        for topic, msg in self.link.due(now_s):
            self._admitted[topic](msg)

    def _admission(self, topic, callback, raw):
        """``callback`` behind the topic's admission (module doc)."""
        type_name, admission = c.TOPIC_TYPES[topic], self.admission

        def admitted(msg):
            now_s = self.now_s()
            try:
                t, frame_id, arrays = _stamp_frame_arrays(type_name, msg, raw)
            except (ValueError, IndexError, struct.error):  # bytes no reader of the type can read
                t, reason = math.nan, MALFORMED
                admission.refuse(topic, reason)
            else:
                reason = admission.check(topic, t, frame_id, arrays, now_s)
            if reason is None:
                return callback(msg)
            event = admission.rejection_event(topic, reason, t, now_s)
            if event is not None:
                self.report(event)
            return None
        return admitted

    def log_counts(self):
        """The counts of admitted and refused messages by topic, in the node's log (a warning if any was refused)."""
        line = (f'{self.label}: ' if self.label else '') + self.admission.summary()
        log = self.node.get_logger()
        if self.admission.rejected:  # rclpy refuses one call site logging at varying severities
            log.warning(line)
        else:
            log.info(line)


class CoreNode(Node):
    """A node around a core (module doc)."""

    core = None

    def __init__(self, node_name, **kwargs):
        super().__init__(node_name, **kwargs)
        self.core_guard = CoreGuard(self.get_name())
        self.events_publisher = None  # mission/events, once the node has made its publisher
        self.progress_reporter = None  # the run loop's (runtime.ProgressReporter): the node's last known sim time
        self.admission_gate = AdmissionGate(self, self.known_time_s, self._report)

    def known_time_s(self):
        """The node's latest known sim time [s] (its run loop's /clock or /flyby/tick), None outside a run loop or
        before its first time message (a node started late, a respawn, knows no time yet)."""
        if self.progress_reporter is None or not self.progress_reporter.clock_ns:
            return None
        return self.progress_reporter.clock_ns / 1e9

    def _report(self, event):
        publish_event(self, self.events_publisher or self.publisher(c.MISSION_EVENTS), event)

    def destroy_node(self):
        self.admission_gate.log_counts()
        return super().destroy_node()

    def publish(self, outputs):
        raise NotImplementedError(f'{type(self).__name__} must turn its core outputs into messages')

    def publisher(self, topic):
        """A publisher of a contract topic with its type and QoS (a global topic at its root name, DESIGN §10)."""
        pub = self.create_publisher(c.message_class(c.TOPIC_TYPES[topic]), _name(topic), qos.qos_for(topic))
        if topic == c.MISSION_EVENTS and self.events_publisher is None:
            self.events_publisher = pub
        return pub

    def guard(self, callback, label, service=False):
        """``callback`` run inside the core's guard (module doc); ``label``: the topic, service or timer it handles
        (the event's ``callback``). Once the core has failed the callback is not run; a service then answers, as
        when its callback raises, with the response unchanged but for ``success`` False and why."""
        core_guard = self.core_guard

        def guarded(*args):
            if core_guard.failed is None:
                try:
                    return callback(*args)
                except Exception as err:  # any fault of the core or of turning its outputs into messages
                    self._core_failed(label, err, args)
            return _refused(args[-1], core_guard.failed.message) if service else None
        return guarded

    def _core_failed(self, label, err, args):
        """Log err with its traceback, fence the core off and publish the node_error event, stamped at the input
        being handled (the node's last known sim time for an input without a stamp: a phase, a service call)."""
        t = _stamp_s(args)
        if t is None:
            t = self.known_time_s() or 0.0
        event = self.core_guard.fail(t, label, err)
        self.get_logger().error(f'{label}: the core raised; it is fed no more\n{traceback.format_exc()}')
        self._report(event)

    def subscribe(self, topic, callback, raw=False):
        """A subscription of a contract topic with its type and QoS (a global topic at its root name), its callback
        behind the topic's admission and in the core's guard; ``raw``: the callback takes the message's CDR bytes
        (no Python message is built; convert.*_cdr_to_numpy reads them). A flyby node takes only the topics
        flyby_msgs_py.wiring gives it."""
        name = self.get_name()
        if name in wiring.NODES and all(node != name for node, _ in wiring.SUBSCRIPTIONS.get(topic, ())):
            raise ValueError(f'{name} does not take {topic} (flyby_msgs_py.wiring.SUBSCRIPTIONS)')
        return self.create_subscription(c.message_class(c.TOPIC_TYPES[topic]), _name(topic),
                                        self.admission_gate.admit(topic, self.guard(callback, topic), raw),
                                        qos.qos_for(topic), raw=raw)

    def subscribe_inputs(self, scenario, callbacks):
        """A subscription of every contract topic flyby_msgs_py.wiring gives this node in the scenario, each to its
        callback in ``callbacks`` (topic -> callback, or (callback, raw))."""
        topics = wiring.topics_of(self.get_name(), scenario)
        gate = self.admission_gate
        gate.watching = link_faults.watches(scenario.faults, topics)
        for topic in topics:
            callback, raw = callbacks[topic] if isinstance(callbacks[topic], tuple) else (callbacks[topic], False)
            self.subscribe(topic, callback, raw=raw)
        if not gate.watching:
            return
        # The link's time: the run loop's ProgressReporter then reads /clock, every step, and releases what the link
        # holds from it (runtime), the node's one time subscription.
        self.on_link_clock = gate.release
        if c.MISSION_EVENTS not in topics:  # the link's own: the events open the faults' windows, the core reads none
            self.create_subscription(c.message_class(c.TOPIC_TYPES[c.MISSION_EVENTS]), _name(c.MISSION_EVENTS),
                                     self.guard(gate.on_link_events, 'link faults'), qos.qos_for(c.MISSION_EVENTS))

    def odometry_input(self, core_input, *fields):
        """The raw callback of a contract Odometry into ``core_input(t, *fields)`` (fields of
        convert.OdometryArrays), read from its CDR bytes (convert.odometry_cdr_to_numpy: about 85 us a message less
        than the Python message)."""
        def callback(data):
            o = convert.odometry_cdr_to_numpy(data)
            self.publish(core_input(o.t, *(getattr(o, f) for f in fields)))
        return callback

    def subscribe_estimates(self, rotate, target_covariance=False, chaser_attitude=False):
        """estimation/target/odom and estimation/chaser/odom into the core (``estimate_inputs``)."""
        for topic, (callback, raw) in self.estimate_inputs(rotate, target_covariance, chaser_attitude).items():
            self.subscribe(topic, callback, raw=raw)

    def estimate_inputs(self, rotate, target_covariance=False, chaser_attitude=False):
        """The callbacks of estimation/target/odom and estimation/chaser/odom into the core, by topic, each with
        raw True (it reads the CDR bytes).

        ``rotate(q_hill_from_body, v_body) -> v_hill`` (flyby_sim.dynamics.rotation.quat_rotate, which this
        package cannot import): the chaser's twist is in chaser_body axes (nav_msgs' rule, DESIGN §10), the
        cores take its velocity in hill. With target_covariance the target's attitude covariance about hill
        axes and rate covariance in body axes (the 3x3 angular blocks of the pose and twist covariances)
        follow the rate; with chaser_attitude the chaser's q_hill_from_body and omega_body follow its
        velocity (convert.odometry_cdr_to_numpy: about 85 us a message less than the Python message)."""
        def on_target(data):
            o = convert.odometry_cdr_to_numpy(data)
            blocks = (o.pose_covariance[3:, 3:], o.twist_covariance[3:, 3:]) if target_covariance else ()
            self.publish(self.core.on_target_estimate(o.t, o.orientation_xyzw, o.angular, *blocks))

        def on_chaser(data):
            o = convert.odometry_cdr_to_numpy(data)
            v_hill = rotate(o.orientation_xyzw, o.linear)
            attitude = (o.orientation_xyzw, o.angular) if chaser_attitude else ()
            self.publish(self.core.on_chaser_estimate(o.t, o.position, v_hill, *attitude))
        return {c.EST_TARGET_ODOM: (on_target, True), c.EST_CHASER_ODOM: (on_chaser, True)}

    def on_phase_message(self, msg):
        self.publish(self.core.on_phase(convert.string_to_str(msg)))

    def on_events_message(self, msg):
        for e in convert.events_from_msg(msg):
            self.publish(self.core.on_event(Event(e['t'], e['level'], e['name'], e['message'], e['values'],
                                                  e['source'])))


def _refused(response, why):
    """A service's response once the core has failed: ``success`` False and why, where the type has them."""
    if hasattr(response, 'success'):
        response.success = False
        response.message = why
    return response
