"""The simulator node: owns the truth and the clock.

It advances the plant (``flyby_sim.plant``) in fixed steps, publishes ``/clock``, the truth topics,
the sensor samples and the target markers, and executes the time-tagged maneuvers it receives on
``guidance/maneuver``; when ``mission/phase`` turns to CAPTURE the chaser is attached to the target.
The pace is bounded by ``rtf`` (0 = as fast as the graph keeps up): every
``flow_control_period_s`` of simulated time it waits until each node named in ``keep_up_with`` has
reported (``flyby_msgs_py.runtime.ProgressReporter``) that it handled everything up to one such
period ago, so no node (the recorder, the estimator) is outrun; and it ends only once they all
have handled the last step. A node that leaves the graph is no longer waited for (and reported).

With the six-degree-of-freedom chaser (``chaser.model: rigid_body``, DESIGN §10) it also publishes the
chaser's attitude (``sim/chaser/odom``: twist in chaser_body axes), the thrusters' torque
(``sim/chaser/thrust``), the wheels and the thrusters (``sim/chaser/wheels``, ``sim/chaser/thrusters``,
sensor_msgs/JointState), the IMU (``sensors/chaser/imu``) and the chaser's markers, and takes guidance's
continuous commands (``guidance/wheels``, ``guidance/wrench``, zero-order hold). Guidance commands every
chaser estimate, and the estimator gives one at every IMU sample, one control period (the IMU's sample
period) after its stamp: so every IMU sample of stamp t announces a command of stamp t + period, and the
simulator does not step past that stamp before the command is in (on both topics), until the mission
phase stops the attitude control (CAPTURE, COMPLETE) or the guidance or estimator node leaves the graph (its
respawned successor, which the supervisor may hold standby for, is waited for again from its first commands).
That is what makes the truth the same at any pace (DESIGN §5, §10). It waits for commands only when both are in
``keep_up_with`` (a graph without them, e.g. the simulator and recorder alone, has nobody to command). With a
post_capture section the attitude control comes back when the arm locks (the plant's combined body,
``grasp_damped``, at a step the plant decides): from that step's IMU sample on, every sample announces its command
again (guidance damps and excites the combined body), until COMPLETE; ``/sim/target/odom`` then carries the
target's CoM off the hill origin (pose position, twist linear in target_body axes).

The capture decision is held for the same way: the supervisor decides at the first chaser estimate at or after the
grasp time (``planner/flyby_target``'s stamp; a synchronized approach's docking publishes it again) once the
target's estimate of that stamp is in, and the chaser is attached at that step, as in the headless loop. So once the
chaser's measurement (the IMU's with the rigid-body chaser, else the relative position) of a stamp at or after the
grasp time is out in a phase that decides (``contract.DECIDING_PHASES``), and the target's attitude of that stamp,
the simulator steps no further while the phase is still one that decides and the
supervisor is in ``keep_up_with``; after SLOW_NODE_WARNING_S without a decision (an estimate the estimator
rejected) it goes on, with a WARN ``waiting_for_decision``.

Several chasers (a ``chasers:`` scenario, DESIGN §10): one plant per chaser (``_Chaser``), each the scenario's view
of that chaser with its own seed; the target's truth is the same in every one of them (a function of the scenario
alone, tested) and is published once. Every chaser-specific topic, truth included, is under ``/<name>/``, commands
are taken there, and the command chain each waits for is that chaser's estimator and guidance (``<name>/...``);
``/clock``, ``/sim/target/odom`` and ``/visualization/markers`` stay global; the simulator's own events go on every
chaser's ``mission/events``.
"""

import collections
import json
import math
import time

from rclpy.exceptions import ParameterUninitializedException
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Header, String

from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, event_payloads, events, qos, wiring
from flyby_msgs_py.core_guard import failed_node
from flyby_msgs_py.markers import chaser_markers, marker_array, target_box_markers
from flyby_msgs_py.node_base import AdmissionGate
from flyby_msgs_py.runtime import PROGRESS_PERIOD_NS, PROGRESS_TOPIC, READY_TOPIC, TICK_TOPIC, main_for, publish_event
from flyby_msgs_py.wire import Event, wire_time
from flyby_sim.dynamics.propulsion import ManeuverRejected
from flyby_sim.dynamics.rotation import quat_conjugate, quat_rotate
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import scenario_of

STARTUP_TIMEOUT_S = 30.0
SLOW_NODE_WARNING_S = 5.0
# The chain whose commands the simulator waits for (rigid-body chaser): IMU -> estimator -> guidance.
COMMAND_CHAIN = ('flyby_estimator', 'flyby_guidance')
SUPERVISOR = 'flyby_supervisor'
# Phases from which guidance commands no attitude (flyby_guidance.guidance_core.ATTITUDE_QUIET_PHASES).
ATTITUDE_QUIET_PHASES = (c.PHASE_CAPTURE, c.PHASE_COMPLETE)
# A command stamp this close to the one announced is that command (stamps are whole nanoseconds).
COMMAND_STAMP_TOLERANCE_NS = 1000


class _Wait:
    """A hold's wall time: ``overdue()`` is True once every SLOW_NODE_WARNING_S of it."""

    def __init__(self):
        self.since = None

    def reset(self):
        self.since = None

    def overdue(self):
        now = time.monotonic()
        if self.since is None:
            self.since = now
        elif now - self.since > SLOW_NODE_WARNING_S:
            self.since = now
            return True
        return False


class _Chaser:
    """One chaser of the simulator: its scenario view, plant, publishers and continuous-command bookkeeping
    (announced stamps [ns] not yet passed, and per topic the latest stamp received [ns])."""

    def __init__(self, name, scenario):
        self.name = name
        self.scenario = scenario
        self.plant = Plant(PlantConfig.from_scenario(scenario))
        self.rigid = scenario.chaser.model == 'rigid_body'
        self.pubs = {}
        self.announced_ns = collections.deque()
        self.commanded_ns = {c.GUIDANCE_WHEELS: -1, c.GUIDANCE_WRENCH: -1}
        self.attitude_quiet = False
        self.chain_failed = False  # a command-chain node's core failed: never waited for again
        self.chain_left_ns = None  # a command-chain node left the graph at this stamp: waited for again (module doc)
        self.supervisor_failed = False  # the supervisor's core failed: no capture decision waited for again
        self.locked = False  # the plant's combined body after a grasp: commanded again (module doc)
        self.command_wait = _Wait()
        self.chain = tuple(node if name is None else f'{name}/{node}' for node in COMMAND_CHAIN)
        self.supervisor = SUPERVISOR if name is None else f'{name}/{SUPERVISOR}'
        self.phase = None
        self.t_grasp = None  # planner/flyby_target's stamp [s]
        self.decision_stamp = None  # the first chaser measurement's stamp at or after it [s]
        self.target_stamp = -math.inf  # the last target attitude measurement's [s]
        self.decision_wait = _Wait()

    def quiet_phase(self):
        """The phase stops guidance's attitude control (CAPTURE but once the arm has locked, COMPLETE)."""
        return self.phase in ATTITUDE_QUIET_PHASES and not (self.locked and self.phase == c.PHASE_CAPTURE)

    def topic(self, topic):
        """The chaser's name of a contract topic: relative for the single chaser, under /<name>/ otherwise."""
        return topic if self.name is None else c.absolute(topic, f'/{self.name}')


class SimNode(Node):
    """Plant simulator; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_sim', **kwargs)
        self.declare_parameter('rtf', 0.0)
        self.declare_parameter('flow_control_period_s', 5.0)
        self.declare_parameter('command_poll_period_s', 0.25)
        self.rtf = float(self.get_parameter('rtf').value)
        if self.rtf < 0.0:
            raise ValueError(f'parameter rtf: must be >= 0 (0 = as fast as possible), got {self.rtf}')
        self.scenario = scenario_of(self)
        sc = self.scenario
        self.chasers = ([_Chaser(name, sc.for_chaser(name)) for name in sc.chaser_names] if sc.chaser_names
                        else [_Chaser(None, sc)])
        self.plant = self.chasers[0].plant  # its time and target are every chaser's
        self.step_s = self.scenario.simulation.step_s
        self.duration_s = self.scenario.simulation.duration_s
        self.flow_every = max(1, round(self.get_parameter('flow_control_period_s').value / self.step_s))
        # At full speed several steps run between two looks at incoming messages: a maneuver must
        # arrive this much sim time before its stamp to start on time (else it is flagged late).
        self.steps_per_tick = max(1, round(self.get_parameter('command_poll_period_s').value
                                           / self.step_s))
        self.wait_for_nodes = self.declare_node_list('wait_for_nodes')
        self.keep_up_with = tuple(self.declare_node_list('keep_up_with'))
        self.progress_s = dict.fromkeys(self.keep_up_with, 0.0)  # a node that left the graph is dropped from it
        self.create_subscription(Header, PROGRESS_TOPIC, self.on_progress, qos.QOS_STREAM, raw=True)
        self.subscriptions_of = {}  # node name -> the topics it subscribes, as it announced them
        self.publications_of = {}  # node name -> {topic: subscriptions its publisher has matched}
        self.subscribed_of = {}  # node name -> {topic: publishers its subscription has matched}
        self.create_subscription(String, READY_TOPIC, self.on_ready, qos.QOS_EVENTS)

        fleet = self.chasers[0].name is not None
        pubs = {}
        for topic in (c.CLOCK, c.SIM_TARGET_ODOM, c.MARKERS) + (() if fleet else (c.MISSION_EVENTS,)):
            name = '/clock' if topic == c.CLOCK else topic
            pubs[topic] = self.create_publisher(c.message_class(c.TOPIC_TYPES[topic]), name, qos.qos_for(topic))
        pubs[TICK_TOPIC] = self.create_publisher(c.message_class(c.TOPIC_TYPES[c.CLOCK]), TICK_TOPIC,
                                                 qos.qos_for(c.CLOCK))
        self.tick_every = max(1, round(PROGRESS_PERIOD_NS * 1e-9 / self.step_s))
        self.pubs = pubs
        # Reused for every step (publishing serializes it); the Odometry goes out as CDR (convert.odometry_cdr).
        self.msgs = {c.CLOCK: c.message_class(c.TOPIC_TYPES[c.CLOCK])()}
        for ch in self.chasers:
            self._wire(ch, pubs if not fleet else {})

        self.started = False
        self.ending = False  # reached the duration, waiting for the others to catch up
        self.finished = False
        self.steps = 0
        self.wall_start = None
        self.waiting_since = time.monotonic()
        self.startup_deadline = time.monotonic() + STARTUP_TIMEOUT_S

    def _wire(self, ch, pubs):
        """The publishers (into ``pubs``) and subscriptions of one chaser."""
        ch.pubs = pubs
        rigid_topics = (c.SIM_CHASER_WHEELS, c.SIM_CHASER_THRUSTERS, c.SENSOR_CHASER_IMU, c.SENSOR_CHASER_WHEELS)
        for topic in (c.SIM_CHASER_ODOM, c.SIM_CHASER_THRUST, c.SENSOR_RELATIVE_POSITION, c.SENSOR_TARGET_ATTITUDE,
                      c.MISSION_EVENTS) + (rigid_topics if ch.rigid else ()):
            pubs[topic] = self.create_publisher(c.message_class(c.TOPIC_TYPES[topic]), ch.topic(topic),
                                                qos.qos_for(topic))
        ch.commands_expected = ch.rigid and all(name in self.progress_s for name in ch.chain)
        if ch.rigid:
            sc = ch.scenario
            ch.command_period_s = 1.0 / sc.sensors.chaser_imu.rate_hz
            ch.wheel_names = c.wheel_names(len(sc.chaser.wheels.axes))
            ch.thruster_names = c.thruster_names(len(ch.plant.truth().thruster_thrust_n))
            ch.imu_covariances = self._imu_covariances(sc)
        # The continuous commands go as CDR bytes (convert.*_cdr: no Python messages); the topics are the table's, each
        # behind its admission (flyby_msgs_py.node_base.AdmissionGate) at the plant's time.
        ch.gate = AdmissionGate(self, lambda: self.plant.t,
                                lambda event: publish_event(self, ch.pubs[c.MISSION_EVENTS], event), ch.name or '')
        inputs = {c.GUIDANCE_MANEUVER: (lambda msg: self.on_maneuver(ch, msg), False),
                  c.SAFETY_CAM: (lambda msg: self.on_cam(ch, msg), False),
                  c.GUIDANCE_WHEELS: (lambda data: self.on_wheels(ch, data), True),
                  c.GUIDANCE_WRENCH: (lambda data: self.on_wrench(ch, data), True),
                  c.MISSION_PHASE: (lambda msg: self.on_phase(ch, msg), False),
                  c.MISSION_EVENTS: (lambda msg: self.on_events(ch, msg), False),
                  c.PLANNER_FLYBY_TARGET: (lambda msg: self.on_flyby_target(ch, msg), False)}
        for topic in wiring.topics_of(wiring.SIM, ch.scenario):
            callback, raw = inputs[topic]
            self.create_subscription(c.message_class(c.TOPIC_TYPES[topic]), ch.topic(topic),
                                     ch.gate.admit(topic, callback, raw), qos.qos_for(topic), raw=raw)

    def destroy_node(self):
        for ch in self.chasers:
            ch.gate.log_counts()
        return super().destroy_node()

    def declare_node_list(self, name):
        """A string-array parameter of node names, empty when not given."""
        self.declare_parameter(name, Parameter.Type.STRING_ARRAY)
        try:
            return list(self.get_parameter(name).value)
        except ParameterUninitializedException:
            return []

    # -- the loop -------------------------------------------------------------------------
    def tick(self):
        """Advance one step when due; return how long the caller may wait (wall seconds)."""
        if not self.started:
            if not self.graph_ready():
                return 0.02
            self.start()
        if self.ending or self.steps % self.flow_every == 0:
            if not self.others_caught_up():
                return 0.002
            if self.ending:
                self.finished = True
                return 0.0
        if self.rtf > 0.0:
            due = self.wall_start + self.steps * self.step_s / self.rtf
            ahead = due - time.monotonic()
            if ahead > 0.0:
                return ahead
            if self.command_due():
                return 0.002
            self.advance()
            return 0.0
        for _ in range(self.steps_per_tick):
            if self.command_due():
                return 0.002
            self.advance()
            if self.ending or self.steps % self.flow_every == 0:
                break
        return 0.0

    def command_due(self):
        """True while a command announced for a stamp within the next step, or a capture decision, has not come
        in (module doc)."""
        return any([self._command_due(ch) or self._decision_due(ch) for ch in self.chasers])

    def _decision_due(self, ch):
        """True while the supervisor's capture decision of a step already out has not come in (module doc)."""
        if (ch.decision_stamp is None or ch.target_stamp < ch.decision_stamp - 1e-9 or ch.supervisor_failed
                or ch.phase not in c.DECIDING_PHASES or ch.supervisor not in self.progress_s):
            ch.decision_wait.reset()
            return False
        if ch.decision_wait.overdue():
            self.emit('WARN', events.WAITING_FOR_DECISION, f'no capture decision for the grasp time '
                      f'{ch.t_grasp:.2f} s after {SLOW_NODE_WARNING_S} s; going on',
                      {'t_grasp_s': repr(ch.t_grasp), 't_estimate_s': repr(ch.decision_stamp)}, ch)
            ch.decision_stamp = ch.t_grasp = None  # not held for again (a new plan's grasp time is)
            return False
        return True

    def _command_due(self, ch):
        """command_due of one chaser."""
        announced = ch.announced_ns
        if not announced:
            return False
        if ch.attitude_quiet:
            announced.clear()
            return False
        received_ns = min(ch.commanded_ns.values()) + COMMAND_STAMP_TOLERANCE_NS
        while announced and announced[0] <= received_ns:
            announced.popleft()
        if not announced or announced[0] > convert.sec_to_ns(self.plant.t + self.step_s) + COMMAND_STAMP_TOLERANCE_NS:
            ch.command_wait.reset()
            return False
        if ch.command_wait.overdue():
            present = self._present_nodes()
            gone = [name for name in ch.chain if name not in present]
            if gone:
                ch.attitude_quiet = True
                ch.chain_left_ns = convert.sec_to_ns(self.plant.t)
                announced.clear()
                self.emit('WARN', events.NODE_LOST, f'{", ".join(gone)} left the graph; no longer waiting for '
                          'attitude commands', {'nodes': ','.join(gone)}, ch)
                return False
            self.emit('WARN', events.WAITING_FOR_COMMAND, f'holding time at {self.plant.t:.2f} s for the attitude '
                      f'command of t = {announced[0] * 1e-9:.2f} s',
                      {'t_command_s': repr(announced[0] * 1e-9), 'received_s': repr(received_ns * 1e-9)}, ch)
        return True

    def _present_nodes(self):
        """Labels (runtime.node_label) of the nodes in the graph now."""
        return {f'{ns.strip("/")}/{name}' if ns.strip('/') else name
                for name, ns in self.get_node_names_and_namespaces()}

    def on_ready(self, msg):
        announced = json.loads(msg.data)
        self.subscriptions_of[announced['node']] = announced['subscriptions']
        self.publications_of[announced['node']] = announced.get('publications', {})
        self.subscribed_of[announced['node']] = announced.get('subscribed', {})

    def graph_ready(self):
        """True once every expected node has announced its subscriptions, every publisher of the
        graph (ours and theirs) has matched each announced subscription of its topic, and every
        announced subscription has matched each publisher of its topic in the other nodes (ours and the
        announced ones)."""
        missing = [n for n in self.wait_for_nodes if n not in self.subscriptions_of]
        if time.monotonic() > self.startup_deadline:
            self.emit('WARN', events.STARTUP_TIMEOUT,
                      f'starting without a complete graph after {STARTUP_TIMEOUT_S} s',
                      {'waiting_for': ','.join(missing)})
            return True
        if missing:
            return False
        def expected(topic, publisher_node):
            return sum(topics.count(topic) for node, topics in self.subscriptions_of.items()
                       if node != publisher_node)
        for pub in self.publisher_handles():
            if pub.get_subscription_count() < expected(pub.topic_name, self.get_name()):
                return False
        if not all(count >= expected(topic, node) for node in self.wait_for_nodes
                   for topic, count in self.publications_of.get(node, {}).items()):
            return False
        publishers = {**self.publications_of,  # node -> its topics, ours as our run loop announces them
                      self.get_name(): {pub.topic_name: 0 for pub in self.publisher_handles()}}
        return all(count >= sum(topic in topics for other, topics in publishers.items() if other != node)
                   for node in self.wait_for_nodes for topic, count in self.subscribed_of.get(node, {}).items())

    def publisher_handles(self):
        """Our publishers, the chasers' included."""
        return [*self.pubs.values(), *(p for ch in self.chasers if ch.pubs is not self.pubs for p in ch.pubs.values())]

    def start(self):
        self.started = True
        self.wall_start = time.monotonic()
        sc = self.scenario
        self.emit('OK', events.SIM_STARTED, f'scenario {sc.name}, seed {sc.seed}',
                  {'scenario': sc.name, 'seed': str(sc.seed), 'dynamics': sc.simulation.dynamics,
                   'step_s': repr(self.step_s), 'duration_s': repr(self.duration_s),
                   'rtf': repr(self.rtf)})
        self.publish_truth([ch.plant.truth() for ch in self.chasers])
        self.publish_tick()

    def advance(self):
        samples = [ch.plant.step() for ch in self.chasers]
        sample = samples[0]
        self.steps += 1
        for ch in self.chasers:
            if not ch.locked and ch.plant.mode == 'combined':
                ch.locked, ch.attitude_quiet = True, ch.chain_failed
        # The measurements first, the target's attitude last: the chaser's estimate (and with the rigid-body
        # chaser the command chain it starts) is worked on while the rest goes out. (The estimator's outputs
        # do not depend on the order of the two chains; a node that has handled the clock of t has handled
        # every measurement of t.)
        for ch in self.chasers:
            for m in sorted(ch.plant.measurements(), key=lambda m: m.kind == 'target_attitude'):
                self.publish_measurement(ch, m)
        self.publish_truth(samples)
        self.publish_plant_events()
        if sample.t >= self.duration_s - 0.5 * self.step_s:
            self.emit('OK', events.TIME_LIMIT, f'simulation reached its duration {self.duration_s} s',
                      {'t': repr(sample.t)})
            self.ending = True
        self.publish_tick()

    def publish_tick(self):
        """The time on runtime.TICK_TOPIC every PROGRESS_PERIOD_NS, at the start and at the last step, after
        everything of its step: a node that has handled it has handled all that came before."""
        if self.steps % self.tick_every == 0 or self.ending:
            self.pubs[TICK_TOPIC].publish(self.msgs[c.CLOCK])

    def on_progress(self, data):
        """A node's progress; one that left the graph and reports again (a respawn) is kept up with again."""
        ns, name = convert.header_cdr_to_ns(data)
        if name in self.keep_up_with:
            self.progress_s[name] = ns / 1e9

    def others_caught_up(self):
        """True when every node we keep up with is close enough behind (all the way at the end)."""
        lag_s = 0.0 if self.ending else self.flow_every * self.step_s
        behind = [n for n, t in self.progress_s.items() if t < self.plant.t - lag_s - 1e-9]
        if not behind:
            self.waiting_since = time.monotonic()
            return True
        gone = set(behind) - self._present_nodes()
        for name in gone:
            del self.progress_s[name]
            self.emit('WARN', events.NODE_LOST, f'{name} left the graph; no longer waiting for it',
                      {'node': name})
        waiting = set(behind) - gone
        now = time.monotonic()
        if waiting and now - self.waiting_since > SLOW_NODE_WARNING_S:
            self.waiting_since = now
            self.emit('WARN', events.WAITING_FOR_NODES, f'holding time at {self.plant.t:.2f} s for '
                      f'{", ".join(sorted(waiting))}',
                      {name: f'{self.progress_s[name]:.3f}' for name in waiting})
        return not waiting

    # -- publishing -----------------------------------------------------------------------
    def publish_truth(self, samples):
        """/clock, every chaser's truth and the target's (the same in every chaser's plant), markers."""
        s = samples[0]
        msgs = self.msgs
        self.pubs[c.CLOCK].publish(convert.clock(s.t, out=msgs[c.CLOCK]))
        for ch, sc in zip(self.chasers, samples, strict=True):
            self._publish_chaser_truth(ch, sc)
        if s.r_target_hill is None:
            r_target, v_target_body = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        else:  # after a grasp: off the hill origin, the twist in target_body axes (nav_msgs' rule)
            r_target, v_target_body = s.r_target_hill, quat_rotate(quat_conjugate(s.q_hill_from_body), s.v_target_hill)
        self.pubs[c.SIM_TARGET_ODOM].publish(convert.odometry_cdr(
            s.t, c.FRAME_HILL, c.FRAME_TARGET_BODY, r_target, s.q_hill_from_body, v_target_body, s.omega_body))
        if self.steps % max(1, round(1.0 / self.step_s)) == 0:
            boxes = self.scenario.boxes
            markers = target_box_markers(s.t, s.q_hill_from_body, boxes.centers_hill_m(s.q_hill_from_body),
                                         boxes.size_m, boxes.names)
            for ch, sc in zip(self.chasers, samples, strict=True):
                if ch.rigid:
                    markers += chaser_markers(sc.t, sc.r_hill, sc.q_hill_from_chaser_body,
                                              ch.scenario.chaser.envelope_radius_m)
            self.pubs[c.MARKERS].publish(marker_array(markers))

    def _publish_chaser_truth(self, ch, s):
        pubs = ch.pubs
        if ch.rigid:
            q_chaser = s.q_hill_from_chaser_body
            pubs[c.SIM_CHASER_ODOM].publish(convert.odometry_cdr(
                s.t, c.FRAME_HILL, c.FRAME_CHASER_BODY, s.r_hill, q_chaser,
                quat_rotate(quat_conjugate(q_chaser), s.v_hill), s.omega_chaser_body))
            pubs[c.SIM_CHASER_THRUST].publish(convert.wrench_stamped_cdr(
                s.t, c.FRAME_HILL, s.force_hill, s.torque_hill_n_m))
            pubs[c.SIM_CHASER_WHEELS].publish(convert.joint_state_cdr(
                s.t, c.FRAME_CHASER_BODY, ch.wheel_names, velocity=s.wheel_speed_rad_s, effort=s.wheel_torque_n_m))
            pubs[c.SIM_CHASER_THRUSTERS].publish(convert.joint_state_cdr(
                s.t, c.FRAME_CHASER_BODY, ch.thruster_names, effort=s.thruster_thrust_n))
        else:
            pubs[c.SIM_CHASER_ODOM].publish(convert.odometry_cdr(
                s.t, c.FRAME_HILL, c.FRAME_CHASER_BODY, s.r_hill, (0.0, 0.0, 0.0, 1.0), s.v_hill,
                (0.0, 0.0, 0.0)))
            pubs[c.SIM_CHASER_THRUST].publish(convert.wrench_stamped_cdr(s.t, c.FRAME_HILL, s.force_hill))

    def publish_measurement(self, ch, m):
        if m.kind == 'target_attitude':
            ch.target_stamp = m.t
        elif (m.kind == 'chaser_imu') == ch.rigid and ch.decision_stamp is None and ch.t_grasp is not None \
                and m.t >= ch.t_grasp - 1e-9 and ch.phase in c.DECIDING_PHASES:
            ch.decision_stamp = m.t
        if m.kind == 'relative_position':
            ch.pubs[c.SENSOR_RELATIVE_POSITION].publish(
                convert.point_stamped_cdr(m.t, c.FRAME_HILL, m.value))
        elif m.kind == 'target_attitude':
            ch.pubs[c.SENSOR_TARGET_ATTITUDE].publish(
                convert.quaternion_stamped_cdr(m.t, c.FRAME_HILL, m.value))
        elif m.kind == 'wheel_speeds':
            ch.pubs[c.SENSOR_CHASER_WHEELS].publish(
                convert.joint_state_cdr(m.t, c.FRAME_CHASER_BODY, ch.wheel_names, velocity=m.value))
        else:  # chaser_imu: announces the attitude command of its estimate (module doc)
            imu = m.value
            orientation_cov, rate_cov, accel_cov = ch.imu_covariances
            ch.pubs[c.SENSOR_CHASER_IMU].publish(convert.imu_cdr(
                m.t, c.FRAME_CHASER_BODY, imu.q_hill_from_body, imu.omega_body_meas, imu.specific_force_body,
                None if imu.q_hill_from_body is None else orientation_cov, rate_cov, accel_cov))
            if ch.commands_expected and not ch.attitude_quiet:
                ch.announced_ns.append(convert.sec_to_ns(wire_time(m.t) + ch.command_period_s))

    @staticmethod
    def _imu_covariances(scenario):
        """The IMU's noise covariances (star-tracker attitude, gyro rate, specific force), diagonal."""
        imu = scenario.sensors.chaser_imu
        return tuple([[s * s if i == j else 0.0 for j in range(3)] for i in range(3)]
                     for s in (math.radians(imu.star_tracker_sigma_deg), imu.gyro_noise_sigma_rad_s,
                               imu.accel_noise_sigma_mps2))

    def emit(self, level, name, message, values, ch=None):
        """An event of the simulator on a chaser's mission/events (every chaser's when ch is None)."""
        for each in self.chasers if ch is None else (ch,):
            publish_event(self, each.pubs[c.MISSION_EVENTS], Event(self.plant.t, level, name, message, values),
                          log_ok=each is self.chasers[0] or ch is not None)

    def publish_plant_events(self):
        for ch in self.chasers:
            for event in ch.plant.drain_events():
                publish_event(self, ch.pubs[c.MISSION_EVENTS], event, log_ok=True)

    # -- commands -------------------------------------------------------------------------
    def on_phase(self, ch, msg):
        """CAPTURE: the manipulator has grasped; the chaser moves with the target from now on."""
        phase = convert.string_to_str(msg)
        ch.phase = phase
        if ch.quiet_phase():
            ch.attitude_quiet = True
        if phase == c.PHASE_CAPTURE:
            ch.plant.capture()
            self.publish_plant_events()
        if phase == c.PHASE_TRANSPORT:  # before any transport firing: guidance holds its first for a plan
            ch.plant.start_transport()
            self.publish_plant_events()

    def on_events(self, ch, msg):
        """A node of the command chain whose core failed (flyby_msgs_py.core_guard) commands no more: time is not held
        for its announced commands, as for a node that left the graph; nor, once the supervisor's core failed, for its
        capture decision (the headless driver holds for neither). The supervisor's ``thrusters_isolated``: their
        valves closed. A phase change: the injected faults that start with it, from its stamp (``Plant.on_phase``)."""
        for e in convert.events_from_msg(msg):
            if e['name'] == events.PHASE_CHANGED:
                ch.plant.on_phase(event_payloads.decode_values(e['name'], e['values']).to_phase, e['t'])
                continue
            if e['name'] == events.THRUSTERS_ISOLATED:  # the supervisor's fault response (docs/faults.md)
                ch.plant.isolate_thrusters(event_payloads.decode_values(e['name'], e['values']).thrusters)
                self.publish_plant_events()
                continue
            node = failed_node(e['name'], e['values'])
            if node == SUPERVISOR:
                ch.supervisor_failed = True
            if node in COMMAND_CHAIN and not ch.chain_failed:
                ch.attitude_quiet = ch.chain_failed = True
                ch.announced_ns.clear()
                self.emit('WARN', events.NODE_LOST, f'{node} failed ({e["message"]}); no longer waiting for attitude '
                          'commands', {'nodes': node}, ch)

    def on_flyby_target(self, ch, msg):
        """The grasp time of the plan (a re-plan moves it): the capture decision is held for there."""
        t_grasp = convert.stamp_to_sec(msg.header.stamp)
        if t_grasp != ch.t_grasp:
            ch.t_grasp = t_grasp
            ch.decision_stamp = None

    def on_wheels(self, ch, data):
        wheels = convert.joint_state_cdr_to_numpy(data)
        t_stamp, torques = self._command_stamp(ch, c.GUIDANCE_WHEELS, wheels.t), wheels.effort.tolist()
        if len(torques) != len(ch.wheel_names):
            self.emit('ERROR', events.COMMAND_REJECTED, f'guidance/wheels: {len(torques)} efforts for '
                      f'{len(ch.wheel_names)} wheels', {'t_stamp': repr(t_stamp)}, ch)
            return
        try:
            ch.plant.command_wheels(t_stamp, torques)
        except ValueError as err:
            self.emit('ERROR', events.COMMAND_REJECTED, f'guidance/wheels: {err}', {'t_stamp': repr(t_stamp)}, ch)
        self.publish_plant_events()

    def on_wrench(self, ch, data):
        w = convert.wrench_stamped_cdr_to_numpy(data)
        t_stamp = self._command_stamp(ch, c.GUIDANCE_WRENCH, w.t)
        try:
            ch.plant.command_wrench(t_stamp, w.force, w.torque, hold_s=ch.command_period_s)
        except ValueError as err:
            self.emit('ERROR', events.COMMAND_REJECTED, f'guidance/wrench: {err}', {'t_stamp': repr(t_stamp)}, ch)
        self.publish_plant_events()

    def _command_stamp(self, ch, topic, t):
        ch.commanded_ns[topic] = max(ch.commanded_ns[topic], convert.sec_to_ns(t))
        if ch.chain_left_ns is not None and min(ch.commanded_ns.values()) > ch.chain_left_ns:
            self._wait_again(ch)
        return t

    def _wait_again(self, ch):
        """The chain commands again after a node of it left (its successor's first commands are in): waited for from
        the next IMU sample on, as the phase and the lock would have it (on_phase, advance) and no core failed."""
        ch.chain_left_ns = None
        ch.attitude_quiet = ch.chain_failed or ch.quiet_phase()
        if not ch.attitude_quiet:
            self.emit('OK', events.COMMANDS_WAITED_AGAIN, 'the command chain commands again: waited for', {}, ch)

    def on_maneuver(self, ch, msg):
        t_stamp, dv_hill = convert.vector3_stamped_to_numpy(msg)
        try:
            ch.plant.command_maneuver(t_stamp, dv_hill)
        except ManeuverRejected:
            pass  # the plant recorded why; reported below, never applied
        self.publish_plant_events()


    def on_cam(self, ch, msg):
        """The independent monitor's CAM: the plant's thrusters take it ahead of everything (``Plant.command_cam``)."""
        ch.plant.command_cam(*convert.vector3_stamped_to_numpy(msg))
        self.publish_plant_events()


def main(args=None):
    main_for(SimNode, args)


if __name__ == '__main__':
    main()
