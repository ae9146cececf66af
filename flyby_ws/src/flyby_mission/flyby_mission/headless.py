"""The headless driver: the whole mission in one process, no ROS, by the same rules as the node graph.

The plant (flyby_sim.plant) and the cores the nodes run — EstimatorCore, PlannerCore, GuidanceCore,
SupervisorCore — are wired as the graph wires them: each output goes to the cores that subscribe to
its topic, in the order it was made, and arrives as the message would deliver it (``flyby_msgs_py.wire``:
stamps in whole nanoseconds, event values as text). The plant executes the commanded maneuvers with
its thruster errors (with the six-degree-of-freedom chaser also guidance's attitude commands, the wheels'
torques and the thrusters' torque, each from its stamp) and attaches the chaser when the phase turns to
CAPTURE; the run ends as the launcher ends it (at COMPLETE, abort_observation_s after ABORTED, or at
simulation.duration_s), and its summary is ``flyby_mission.summary.summarize`` of the plant's truth,
stamped as the truth topics are: the same keys, outcome classes and figures as the graph's summary.json,
so a Monte Carlo row is a statement about the graph. A topic fault acts on each receiving node's link by the
graph's rule (``flyby_msgs_py.link_faults``): learnt from the simulator's events, its held messages released at the
plant's time after the step's samples, as /clock follows them in the graph. The six-degree-of-freedom chaser's
velocities, truth and estimate, travel in chaser_body axes as its Odometry twists do (DESIGN §10), turned there and
back by the same functions as the nodes and the bag's reader turn them.

It flies one chaser: a ``chasers:`` scenario (or one chaser's view of it) is refused with a ScenarioError naming
the file and the key ``chasers`` (``require_one_chaser``); the graph (scripts/run_mission.py) flies several.
"""

import collections
import copy
import dataclasses
import logging
import time
from typing import NamedTuple

import numpy as np

from flyby_estimation.estimator_core import ChaserEstimate, EstimatorCore, TargetEstimate
from flyby_estimation.health import Diagnostics
from flyby_estimation.mass_estimation_run import TargetInertiaEstimate
from flyby_estimation.params import EstimatorParams
from flyby_guidance.guidance import Maneuver
from flyby_guidance.guidance_core import GuidanceCore
from flyby_guidance.modes.flyby import flyby_target_of_plan
from flyby_guidance.modes.interface import AttitudeCommandStamped
from flyby_guidance.params import GuidanceParams
from flyby_mission.abort_escape import AvoidanceBurn
from flyby_mission.cam_monitor import CamBurn, CamMonitor, CamParams
from flyby_mission.run_truth import ChaserTruth, TargetTruth, ThrustTruth, WheelTruth, chaser_truth_from_odometry
from flyby_mission.summary import summarize
from flyby_mission.supervisor import (
    HEARTBEAT_NODES,
    WATCHED_NODES,
    SupervisorCore,
    SupervisorParams,
    Transition,
)
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events, link_faults, wiring
from flyby_msgs_py.admission import RULES, Admission
from flyby_msgs_py.core_guard import CoreGuard
from flyby_msgs_py.link_faults import LinkFaults
from flyby_msgs_py.schema import ScenarioError
from flyby_msgs_py.wire import Event, wire_event, wire_time
from flyby_planner.params import PlannerParams
from flyby_planner.plan_outputs import AimUpdate, PlanPublished, PlanRefused, TrajectoryPublished
from flyby_planner.planner_core import PlannerCore
from flyby_planner.transfer import terminal_impulses
from flyby_sim.dynamics.orbital import cw_coast
from flyby_sim.dynamics.propulsion import ManeuverRejected
from flyby_sim.dynamics.rotation import quat_conjugate, quat_rotate
from flyby_sim.faults import node_crash_event
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import scenario_from_dict

SIM_NODE = 'flyby_sim'
# The cores a node_crash may take down and the launcher respawns (flyby_sim.faults.NODES): node -> (attribute, build).
RESPAWNABLE = {wiring.ESTIMATOR: ('estimator', lambda sc: EstimatorCore(EstimatorParams.from_scenario(sc))),
               wiring.PLANNER: ('planner', lambda sc: PlannerCore(PlannerParams.from_scenario(sc))),
               wiring.GUIDANCE: ('guidance', lambda sc: GuidanceCore(GuidanceParams.from_scenario(sc))),
               wiring.CAM: ('cam', lambda sc: CamMonitor(CamParams.from_scenario(sc)))}


@dataclasses.dataclass
class HeadlessRun:
    """One headless mission: ``summary`` (the summary.json dict) and what only this driver sees: the
    delta-v commanded, the ideal one (eq 28-29 of the planned transfer from the TRUE chaser state),
    every commanded burn and every event of mission/events (dicts as read from a bag)."""

    summary: dict
    dv_commanded_mps: float = 0.0
    dv_ideal_mps: float = None
    burns: list = dataclasses.field(default_factory=list)
    events: list = dataclasses.field(default_factory=list)


class _Truth:
    """The truth topics as the recorder would keep them (stamps in whole nanoseconds)."""

    def __init__(self):
        self.t, self.r, self.v, self.q, self.w, self.f = [], [], [], [], [], []
        self.q_chaser, self.torque, self.thrusters = [], [], []  # the six-degree-of-freedom chaser's
        self.w_chaser, self.wheels, self.r_target, self.v_target = [], [], [], []

    def add(self, s):
        self.t.append(wire_time(s.t))
        self.r.append(s.r_hill)
        self.q.append(s.q_hill_from_body)
        self.w.append(s.omega_body)
        self.f.append(s.force_hill)
        # /sim/target/odom: the CoM off the hill origin after a grasp, its twist in target_body axes
        self.r_target.append(np.zeros(3) if s.r_target_hill is None else s.r_target_hill)
        self.v_target.append(np.zeros(3) if s.v_target_hill is None else quat_rotate(
            quat_conjugate(s.q_hill_from_body), s.v_target_hill))
        if s.q_hill_from_chaser_body is None:
            self.v.append(s.v_hill)
        else:  # the twist of /sim/chaser/odom: chaser_body axes, as the sim node publishes it
            self.v.append(quat_rotate(quat_conjugate(s.q_hill_from_chaser_body), s.v_hill))
            self.q_chaser.append(s.q_hill_from_chaser_body)
            self.torque.append(s.torque_hill_n_m)
            self.thrusters.append(s.thruster_thrust_n)
            self.w_chaser.append(s.omega_chaser_body)
            self.wheels.append(s.wheel_speed_rad_s)

    def series(self):
        """(ChaserTruth, TargetTruth, ThrustTruth, the wheels' (t, velocity) or None) as the bag's topics give them."""
        t = np.array(self.t)
        rigid = len(self.q_chaser) == len(t)
        chaser = ChaserTruth(t, np.array(self.r), np.array(self.v), np.array(self.q_chaser) if rigid else None,
                             np.array(self.w_chaser) if rigid else None)
        return (chaser_truth_from_odometry(chaser) if rigid else chaser,
                TargetTruth(t, np.array(self.q), np.array(self.w), np.array(self.r_target), np.array(self.v_target)),
                ThrustTruth(t, np.array(self.f), np.array(self.torque) if rigid else None,
                            np.array(self.thrusters) if rigid else None),
                WheelTruth(t, np.array(self.wheels)) if rigid else None)


def _node_log(node):
    """Where a node's link logs a refused event headless (link_faults): this module's Python log, naming the node as
    its own log does in the graph."""
    log = logging.getLogger(__name__)
    return lambda line: log.warning('%s: %s', node, line)


def require_one_chaser(scenario):
    """Raise ScenarioError (file, key ``chasers``) for a scenario of several chasers (module doc)."""
    if scenario.chaser_names:
        names = ', '.join(scenario.chaser_names)
        raise ScenarioError(scenario.path or scenario.name, 'chasers',
                            f'the headless loop flies one chaser, this scenario has {len(scenario.chaser_names)} '
                            f'({names}): fly it in the graph, scripts/run_mission.py --scenario FILE')


class HeadlessGraph:
    """The plant and the four cores, connected as the topics connect the nodes (module doc): each output is turned
    into the messages its node publishes, and each message goes to the nodes ``flyby_msgs_py.wiring`` gives its
    topic, in the table's order. Every core call runs inside that node's guard (flyby_msgs_py.core_guard), as in
    the graph: an exception becomes its node_error event and the core is fed nothing more (the supervisor's own:
    guidance idles propulsion on it, the run goes on to its duration and ends in ERROR, docs/runtime.md)."""

    def __init__(self, scenario):
        require_one_chaser(scenario)
        self.scenario = scenario
        self.plant = Plant(PlantConfig.from_scenario(scenario))
        self.supervisor = SupervisorCore(SupervisorParams.from_scenario(scenario), WATCHED_NODES)
        self.guards = {wiring.SUPERVISOR: CoreGuard(wiring.SUPERVISOR)}
        for node in RESPAWNABLE:
            self._build(node)
        self.down = collections.Counter()  # node -> the node_crash faults holding it down (flyby_sim.faults)
        self.latched = {}  # topic -> its last message, for a respawned node (transient local in the graph)
        self.events_kept = collections.defaultdict(lambda: collections.deque(maxlen=c.EVENTS_HISTORY))  # by source
        self.subscribers = {topic: wiring.subscribers(topic, scenario) for topic in wiring.SUBSCRIPTIONS}
        self.admissions = {node: Admission() for node in wiring.NODES}
        self.links = {node: LinkFaults(log=_node_log(node)) for node in wiring.NODES}  # each receiver's (link_faults)
        # The receivers that hear the simulator's events for their links, as in the graph (link_faults.watches).
        self.watching = [node for node in wiring.NODES
                         if link_faults.watches(scenario.faults, wiring.topics_of(node, scenario))]
        self.phases = []
        self.truth = _Truth()
        self.run = HeadlessRun(summary={})
        self.events = self.run.events  # as read from the bag: dicts of t, level, name, message, values, hardware_id
        self._queue = collections.deque()

    @property
    def phase(self):
        return self.phases[-1] if self.phases else None

    def _build(self, node):
        """A fresh core of the node, in its guard (at the start, and as the launcher respawns it)."""
        attribute, make = RESPAWNABLE[node]
        setattr(self, attribute, make(self.scenario))
        self.guards[node] = CoreGuard(node)

    def _node_fault(self, event):
        """A node_crash's start (its core fed nothing more, its progress stopped) or end (a fresh core fed the
        latched topics' last messages and the events so far, as a respawned node joins the graph)."""
        crash = node_crash_event(event.name, event.values)
        if crash is None:
            return
        node, down = crash
        self.down[node] += 1 if down else -1
        if down or self.down[node] > 0:  # overlapping crashes: up after the last
            return
        self._build(node)
        self.admissions[node] = Admission()  # a new node's: the history it gets passes it as in the graph
        self.links[node].held.clear()  # what the old node's link held died with it; the faults' windows stay known
        topics = wiring.topics_of(node, self.scenario)
        history = [self.latched[t] for t in topics if t in self.latched and t != c.MISSION_EVENTS]
        if c.MISSION_EVENTS in topics:
            history += sorted((m for kept in self.events_kept.values() for m in kept), key=lambda m: m.t)
        for message in history:
            if self._admitted(node, message):
                self._queue.extend(self._guarded(node, message.topic, message.t, CORE_INPUTS[node, message.topic],
                                                 self, message))

    def start(self):
        self.truth.add(self.plant.truth())
        self._publish(self._guarded(wiring.SUPERVISOR, 'start', 0.0, self.supervisor.start))

    def step(self):
        """One plant step and everything it causes, as the nodes would handle it."""
        s = self.plant.step()
        self.truth.add(s)
        t = wire_time(s.t)
        for node in HEARTBEAT_NODES:
            if not self.down[node]:
                self._publish(self._guarded(wiring.SUPERVISOR, 'on_progress', t, self.supervisor.on_progress, node, t))
        self._publish(self._guarded(wiring.SUPERVISOR, 'on_clock', t, self.supervisor.on_clock, t))
        for m in self.plant.measurements():
            self._publish([_Message(MEASUREMENT_TOPICS[m.kind], wire_time(m.t), m.value)])
        self._release(t)
        self._publish_plant_events()
        return s

    # -- the topics -----------------------------------------------------------------------------
    def _publish(self, outputs):
        self._queue.extend(outputs)
        while self._queue:
            self._deliver(self._queue.popleft())

    def _publish_plant_events(self):
        out = [Event(e.t, e.level, e.name, e.message, e.values, SIM_NODE) for e in self.plant.drain_events()]
        for event in out:
            self._node_fault(event)
            for node in self.watching:
                self.links[node].on_event(event.name, event.values)
        self._publish(out)

    def _guarded(self, node, callback, t, fn, *args):
        """fn(*args) of a node's core inside its guard: its outputs, or its node_error event once (module doc)."""
        guard = self.guards[node]
        if guard.failed is not None:
            return []
        try:
            return fn(*args) or []
        except Exception as err:  # any fault of the core, as the node's guard catches it
            return [guard.fail(t, callback, err)]

    def _deliver(self, out):
        """One output: its messages to their subscribers (flyby_msgs_py.wiring), and what only this driver keeps: the
        events and phases as the bag has them (before anything they cause), the burns and the ideal delta-v."""
        if isinstance(out, Event):
            e = wire_event(out)
            self.events.append({'t': e.t, 'level': e.level, 'name': e.name, 'message': e.message,
                                'values': e.values, 'hardware_id': e.source})
        elif isinstance(out, Transition):
            self.phases.append(out.phase_to)
        for message in _messages(out):
            self._latch(message)
            for node in self.subscribers.get(message.topic, ()):  # /diagnostics: recorded only
                if not self.down[node]:
                    for item in self.links[node].arrive(message.topic, message.t, message):
                        self._take(node, item)
        if isinstance(out, (Maneuver, AvoidanceBurn)):
            dv_hill = np.asarray(out.dv_hill, dtype=float)
            self.run.dv_commanded_mps += float(np.linalg.norm(dv_hill))
            self.run.burns.append({'t': wire_time(out.t), 'kind': getattr(out, 'kind', 'avoidance'),
                                   'dv_mps': float(np.linalg.norm(dv_hill))})
        elif isinstance(out, PlanPublished):
            self._ideal_delta_v(out)

    def _take(self, node, message):
        """A message that reached the node: past its admission, to the plant or the node's core."""
        if not self._admitted(node, message):
            return
        if node == wiring.SIM:
            self._to_plant(message)
        else:
            handler = CORE_INPUTS[node, message.topic]
            self._queue.extend(self._guarded(node, message.topic, message.t, handler, self, message))

    def _release(self, t):
        """The messages each link held whose time has come at t [s] (the graph releases them at /clock, which the
        simulator sends after the step's samples), to their nodes and what they cause."""
        for node, link in self.links.items():
            for _topic, message in link.due(t):
                if not self.down[node]:
                    self._take(node, message)
        self._publish([])

    def _latch(self, message):
        """What a node joining later gets: a latched topic's last message, each writer's events' history."""
        if message.topic == c.MISSION_EVENTS:
            self.events_kept[message.value.source].append(message)
        elif message.topic in c.LATCHED_TOPICS:
            self.latched[message.topic] = message

    def _admitted(self, node, message):
        """Whether the node admits the message's stamp (flyby_msgs_py.admission) at the plant's time, as its node
        would; a refusal is counted and reported as the node reports it. Only the stamp: the numbers and frames are
        the cores' own here (in the graph the message builders refuse a NaN or a non-unit quaternion at the
        publisher), and checking them would cost the loop about a fifth of its time (docs/runtime.md)."""
        rule = RULES.get(message.topic)
        if rule is None:
            return True
        admission = self.admissions[node]
        reason = admission.check(message.topic, message.t, rule.frame_id, None, self.plant.t)
        if reason is None:
            return True
        event = admission.rejection_event(message.topic, reason, message.t, self.plant.t)
        if event is not None:
            self._queue.append(event._replace(source=node))
        return False

    def _to_plant(self, message):
        """A message the simulator takes: commands from their stamps, the phase's capture and transport."""
        topic, t, value = message
        if topic == c.MISSION_PHASE:
            self.plant.on_phase(value, t)
        if topic == c.GUIDANCE_WHEELS:
            self.plant.command_wheels(t, value.wheel_torque_n_m)
            return
        if topic == c.GUIDANCE_WRENCH:
            self.plant.command_wrench(t, value.force_body_n, value.thruster_torque_body_n_m, hold_s=value.hold_s)
        elif topic == c.GUIDANCE_MANEUVER:
            try:
                self.plant.command_maneuver(t, value)
            except ManeuverRejected:
                pass  # the plant recorded why (an ERROR event); never applied
        elif topic == c.MISSION_PHASE and value == c.PHASE_CAPTURE:
            self.plant.capture()
        elif topic == c.MISSION_PHASE and value == c.PHASE_TRANSPORT:
            self.plant.start_transport()
        elif topic == c.SAFETY_CAM:
            self.plant.command_cam(t, value)
        elif topic == c.MISSION_EVENTS and value.name == events.THRUSTERS_ISOLATED:
            self.plant.isolate_thrusters(event_payloads.decode(value).thrusters)
        else:  # the grasp time it holds its pace for, a node's failure it holds time for no more: graph pacing only
            return
        self._publish_plant_events()

    def _ideal_delta_v(self, plan):
        """Eq 28-29 impulses of the planned transfer (to X_Fi at t_i) from the TRUE chaser state at t_Ti."""
        n = self.scenario.mean_motion_rad_s
        target = flyby_target_of_plan(plan.t_plan, plan.t_i, plan.x_fi, plan.v_fi, plan.t_f, plan.x_ft, plan.v_ft,
                                      self.scenario.planner.maneuver_lead_s)
        truth = self.plant.truth()
        state = cw_coast(truth.r_hill, truth.v_hill, target.t_ti - truth.t, n)
        dv1, dv2 = terminal_impulses(state[:3], state[3:], target.x_fi, target.v_fi, target.t_i - target.t_ti, n)
        self.run.dv_ideal_mps = float(np.linalg.norm(dv1) + np.linalg.norm(dv2))


class _Message(NamedTuple):
    """A message of a contract topic as the subscribers' nodes read it: its stamp [s] and what they convert it to."""

    topic: str
    t: float
    value: object


MEASUREMENT_TOPICS = {'relative_position': c.SENSOR_RELATIVE_POSITION, 'target_attitude': c.SENSOR_TARGET_ATTITUDE,
                      'chaser_imu': c.SENSOR_CHASER_IMU, 'wheel_speeds': c.SENSOR_CHASER_WHEELS}


def _chaser_message(out):
    """estimation/chaser/odom: the six-degree-of-freedom chaser's twist in chaser_body axes and back (the nodes'
    turns)."""
    v_hill = out.v_hill
    if out.q_hill_from_body is not None:
        v_hill = quat_rotate(out.q_hill_from_body, quat_rotate(quat_conjugate(out.q_hill_from_body), v_hill))
    t = wire_time(out.t)
    return _Message(c.EST_CHASER_ODOM, t, ((t, out.r_hill, v_hill), (out.q_hill_from_body, out.omega_body)))


def _messages(out):
    """The messages the node that made ``out`` publishes for it, in the order it publishes them (a plant's
    measurement is its message already)."""
    if isinstance(out, _Message):
        return [out]
    if isinstance(out, Event):
        e = wire_event(out)
        return [_Message(c.MISSION_EVENTS, e.t, e)]
    if isinstance(out, Transition):
        return [_Message(c.MISSION_PHASE, wire_time(out.t), out.phase_to)]
    if isinstance(out, TargetEstimate):
        t = wire_time(out.t)
        return [_Message(c.EST_TARGET_ODOM, t, ((t, out.q_hill_from_body, out.omega_body),
                                                (out.attitude_covariance_hill, out.rate_covariance_body)))]
    if isinstance(out, ChaserEstimate):
        return [_chaser_message(out)]
    if isinstance(out, Diagnostics):
        return [_Message(c.DIAGNOSTICS, wire_time(out.t), out)]
    if isinstance(out, CamBurn):
        return [_Message(c.SAFETY_CAM, wire_time(out.t), np.asarray(out.dv_hill, dtype=float))]
    if isinstance(out, AttitudeCommandStamped):
        t = wire_time(out.t)
        return [_Message(c.GUIDANCE_WHEELS, t, out), _Message(c.GUIDANCE_WRENCH, t, out)]
    if isinstance(out, (Maneuver, AvoidanceBurn)):
        return [_Message(c.GUIDANCE_MANEUVER, wire_time(out.t), np.asarray(out.dv_hill, dtype=float))]
    if isinstance(out, PlanPublished):
        return [_Message(c.PLANNER_FLYBY_TARGET, wire_time(out.t_f), (out.x_ft, out.v_ft)),
                _Message(c.PLANNER_FLYBY_INITIAL, wire_time(out.t_i), (out.x_fi, out.v_fi)),
                _Message(c.PLANNER_PATH, wire_time(out.t_plan), None)]
    if isinstance(out, TrajectoryPublished):
        traj = out.trajectory
        return [_Message(c.PLANNER_TRAJECTORY, wire_time(traj.t_s[0]), traj)]
    if isinstance(out, AimUpdate):
        return [_Message(c.PLANNER_FLYBY_TARGET, wire_time(out.grasp.t), (out.x_ft, out.v_ft))]
    if isinstance(out, TargetInertiaEstimate):
        return [_Message(c.EST_TARGET_INERTIA, wire_time(out.t), out)]
    if isinstance(out, PlanRefused):  # its event says it all; markers are for the viewers
        return []
    raise TypeError(f'no topic for the output {out!r}')


def _imu(g, m):
    v = m.value
    return g.estimator.on_imu(m.t, v.q_hill_from_body, v.omega_body_meas, v.specific_force_body)


def _trajectory(g, m):
    traj = m.value
    return g.guidance.on_trajectory([wire_time(t) for t in traj.t_s], traj.r_hill, traj.v_hill, traj.a_hill)


# (node, topic) -> what the node's core does with a message of the topic (its node's callback, without ROS).
CORE_INPUTS = {
    (wiring.ESTIMATOR, c.SENSOR_RELATIVE_POSITION): lambda g, m: g.estimator.on_position(m.t, m.value),
    (wiring.ESTIMATOR, c.SENSOR_TARGET_ATTITUDE): lambda g, m: g.estimator.on_attitude(m.t, m.value),
    (wiring.ESTIMATOR, c.SENSOR_CHASER_IMU): _imu,
    (wiring.ESTIMATOR, c.SENSOR_CHASER_WHEELS): lambda g, m: g.estimator.on_wheel_speeds(m.t, m.value),
    (wiring.ESTIMATOR, c.GUIDANCE_WHEELS): lambda g, m: g.estimator.on_wheels(m.t, m.value.wheel_torque_n_m),
    (wiring.ESTIMATOR, c.GUIDANCE_MANEUVER): lambda g, m: g.estimator.on_maneuver(m.t, m.value),
    (wiring.ESTIMATOR, c.SAFETY_CAM): lambda g, m: g.estimator.on_cam(m.t),
    (wiring.ESTIMATOR, c.GUIDANCE_WRENCH): lambda g, m: g.estimator.on_wrench(
        m.t, m.value.force_body_n, m.value.thruster_torque_body_n_m),
    (wiring.ESTIMATOR, c.MISSION_PHASE): lambda g, m: g.estimator.on_phase(m.value),
    (wiring.ESTIMATOR, c.MISSION_EVENTS): lambda g, m: g.estimator.on_event(m.value),
    (wiring.SUPERVISOR, c.EST_TARGET_ODOM): lambda g, m: g.supervisor.on_target_estimate(*m.value[0]),
    (wiring.SUPERVISOR, c.EST_CHASER_ODOM): lambda g, m: g.supervisor.on_chaser_estimate(*m.value[0]),
    (wiring.SUPERVISOR, c.MISSION_EVENTS): lambda g, m: g.supervisor.on_event(m.value),
    (wiring.PLANNER, c.EST_TARGET_ODOM): lambda g, m: g.planner.on_target_estimate(*m.value[0], *m.value[1]),
    (wiring.PLANNER, c.EST_CHASER_ODOM): lambda g, m: g.planner.on_chaser_estimate(*m.value[0]),
    (wiring.PLANNER, c.MISSION_EVENTS): lambda g, m: g.planner.on_event(m.value),
    (wiring.PLANNER, c.MISSION_PHASE): lambda g, m: g.planner.on_phase(m.value),
    (wiring.GUIDANCE, c.EST_TARGET_ODOM): lambda g, m: g.guidance.on_target_estimate(*m.value[0], *m.value[1]),
    (wiring.GUIDANCE, c.EST_CHASER_ODOM): lambda g, m: g.guidance.on_chaser_estimate(*m.value[0], *m.value[1]),
    (wiring.GUIDANCE, c.PLANNER_FLYBY_TARGET): lambda g, m: g.guidance.on_flyby_target(m.t, *m.value),
    (wiring.GUIDANCE, c.PLANNER_FLYBY_INITIAL): lambda g, m: g.guidance.on_flyby_initial(m.t, *m.value),
    (wiring.GUIDANCE, c.PLANNER_PATH): lambda g, m: g.guidance.on_path(m.t),
    (wiring.GUIDANCE, c.PLANNER_TRAJECTORY): _trajectory,
    (wiring.GUIDANCE, c.MISSION_PHASE): lambda g, m: g.guidance.on_phase(m.value),
    (wiring.GUIDANCE, c.MISSION_EVENTS): lambda g, m: g.guidance.on_event(m.value),
    (wiring.CAM, c.SENSOR_RELATIVE_POSITION): lambda g, m: g.cam.on_position(m.t, m.value),
    (wiring.CAM, c.SENSOR_TARGET_ATTITUDE): lambda g, m: g.cam.on_attitude(m.t, m.value),
    (wiring.CAM, c.SENSOR_CHASER_IMU): lambda g, m: g.cam.on_imu(m.t, m.value.q_hill_from_body,
                                                                 m.value.specific_force_body),
    (wiring.CAM, c.MISSION_PHASE): lambda g, m: g.cam.on_phase(m.value),
}


def scaled_navigation_noise(scenario, factor):
    """The scenario with its relative-position sensor noise multiplied by factor (filter and plant alike)."""
    d = copy.deepcopy(scenario.to_dict())
    d['sensors']['relative_position']['noise_sigma_m'] *= factor
    return scenario_from_dict(d, name=f'{scenario.name} (navigation noise x{factor:g})')


def run_headless(scenario, graph=None):
    """Fly the scenario (with its seed) through every phase the graph would; a HeadlessRun. ``graph``: the
    HeadlessGraph of the scenario to fly instead of a new one (a test may give one of its cores another model)."""
    wall_start = time.monotonic()
    graph = HeadlessGraph(scenario) if graph is None else graph
    graph.start()
    hold_s = scenario.supervisor.abort_observation_s
    duration_s = scenario.simulation.duration_s
    step_s = scenario.simulation.step_s
    t_terminal = None
    end_reason = events.TIME_LIMIT  # the simulator's event: the run reached its duration
    while graph.plant.t < duration_s - 0.5 * step_s:
        s = graph.step()
        if graph.phase in c.TERMINAL_PHASES and t_terminal is None:
            t_terminal = s.t
        if t_terminal is not None and s.t >= t_terminal + (hold_s if graph.phase == c.PHASE_ABORTED else 0.0):
            end_reason = f'phase {graph.phase}'
            break
    chaser, target, thrust, wheels = graph.truth.series()
    graph.run.summary = summarize(chaser, target, thrust, graph.phases, graph.events, scenario, end_reason,
                                  graph.phase, time.monotonic() - wall_start, wheels=wheels)
    return graph.run
