"""The mission phase machine of DESIGN §4 (seed 000 §2.2, §4.1; seed 003 §3.1); the capture decision it applies is
flyby_mission.capture_decision's.

Pure Python, no ROS: the supervisor node feeds it what it observes (estimate stamps, events, the plan,
node progress, the clock) and publishes the transitions it returns. Every transition is caused by an
observable condition and carries its reason:

    ESTIMATION        -> PLANNING           target estimate converged and min_observation_s of data
    ESTIMATION | PLANNING -> HOLD           the fault table answers a detection ``hold`` (docs/faults.md): nothing is
                                            planned or flown until every held fault has recovered
    (approach)        -> RETREAT            the fault table answers ``retreat``: the approach given up, the chaser
                                            safed as by an abort (the avoidance burn), up to max_retreats times
    HOLD | RETREAT    -> ESTIMATION         the held faults' ``fault_recovered``: the way to PLANNING as above (a lost
                                            estimator's successor must converge and observe min_observation_s anew)
    HOLD | RETREAT    -> ABORTED            the held faults not all recovered within hold_limit_s
    PLANNING          -> TERMINAL_APPROACH  the planner selected a plan
    PLANNING          -> COMPLETE           the planner refused: no safe plan (outcome NO_SAFE_PLAN, DESIGN
                                            §10; the chaser never left its safe state, nothing is fired)
    TERMINAL_APPROACH -> TRAJECTORY_ADJUST  an estimate at or after the injection time t_i
    TRAJECTORY_ADJUST -> FLYBY              guidance ended thrusting, or the chaser is inside the sphere
    FLYBY             -> CAPTURE | ESCAPE   at the grasp time, from the estimated relative state
    PLANNING          -> OPTIMAL_APPROACH   the planner selected an optimization-based approach (seed 003
                                            section 4, DESIGN §10); a re-plan moves the grasp time
    OPTIMAL_APPROACH  -> CAPTURE | ESCAPE   at the grasp time, as from FLYBY (the end point is the fly-by
                                            target point of eq 20-21 with the plan's offset)
    PLANNING          -> SYNC_APPROACH      the planner selected a synchronized approach (seed 001 section 2, DESIGN
                                            §10); its re-solves move the arrival
    SYNC_APPROACH     -> ATTITUDE_SYNC      guidance reached the station (``station_reached``)
    ATTITUDE_SYNC     -> ORBITING           guidance synchronized the attitude (``attitude_synchronized``)
    ORBITING          -> DOCKING            guidance started docking (``docking_started``, with the grasp time)
    DOCKING           -> CAPTURE | ESCAPE   at the first chaser estimate at or after the grasp time, against the final
                                            point (eq 20-21 with the final range) at that estimate's own stamp: the
                                            chaser holds it under thrust, so no coast carries the estimate
    (start)           -> MASS_ESTIMATION    when the run starts attached (post_capture.start attached, seed 004
                                            §3.1): the chaser holds the target from t = 0
    CAPTURE           -> COMPLETE           after capture_hold_s attached (no post_capture section)
    CAPTURE           -> GRASP              the simulator's ``captured``: the arm's impedance takes the contact
                                            (post_capture, DESIGN §10, seed 000 §2.2 (5))
    GRASP             -> DAMPING            the simulator's ``grasp_damped``: the arm locked, one rigid body
    GRASP             -> ESCAPE             the simulator's ``grasp_released``: beyond the arm's limits
    DAMPING           -> MASS_ESTIMATION    guidance's ``damping_complete`` (seed 000 §2.2 (6), seed 004 §3.2)
    MASS_ESTIMATION   -> COMPLETE           the estimator's ``mass_properties_estimated`` (seed 004 §2.2)
    MASS_ESTIMATION   -> TRANSPORT          the same, with a post_capture.transport section (seed 004 §2.3)
    TRANSPORT         -> COMPLETE           guidance's ``transport_complete`` (the conditions held hold_s, or the run's
                                            end) or ``transport_refused`` (no plan meets them: the body is held)
    ESCAPE            -> COMPLETE           after escape_observation_s of passive escape
    any active phase  -> ABORTED            abort request, the fault table's answer to a node silent for
                                            watchdog_s (the watchdog's node_lost), or a
                                            fault (ERROR event) reported by a watched node, or a
                                            ``node_error`` of any node (its core raised, core_guard), or the
                                            fault table's answer to a ``fault_detected`` (docs/faults.md: the
                                            estimator's monitors', the watchdog's, the estimates' age's), or the
                                            independent monitor's ``cam_fired``

``SupervisorCore`` adds what the node observes and decides around the phase machine (the estimates
by stamp, the capture decision from them, the avoidance burn after an abort, the watchdog of the nodes' heartbeats
and the age of the estimates, flyby_mission.estimate_age); the supervisor node and
the headless driver (flyby_mission.headless) both run it, each building its ``SupervisorParams`` (the record of what
it reads of the scenario, flyby_msgs_py.params) from the scenario.
"""

import dataclasses
import math

import numpy as np

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_mission.abort_escape import AvoidanceBurn, PendingBurns, escape_outputs
from flyby_mission.capture_decision import decide_capture
from flyby_mission.estimate_age import (
    CHASER_ESTIMATE,
    KIND,
    MONITOR,
    TARGET_ESTIMATE,
    EstimateAgeMonitor,
    EstimateAgeParams,
)
from flyby_mission.fault_response import respond
from flyby_mission.fault_table import PHASE_GROUPS, FaultTable
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events, params
from flyby_msgs_py.stamped import StampedBuffer
from flyby_msgs_py.wire import Event
from flyby_msgs_py.wiring import ESTIMATOR
from flyby_planner.flyby.config import PlannerConfig
from flyby_planner.flyby.grasp_search import capture_target_body
from flyby_planner.flyby.keepout import has_spin_axis

# Phases in which a faulty watched node (its ERROR event) aborts the mission (after FLYBY nothing is left to command).
ACTIVE_PHASES = (c.PHASE_ESTIMATION, c.PHASE_PLANNING) + c.WAITING_PHASES + (
    c.PHASE_TERMINAL_APPROACH, c.PHASE_TRAJECTORY_ADJUST, c.PHASE_FLYBY, c.PHASE_OPTIMAL_APPROACH) + c.SYNC_PHASES
# Guidance's events that move the synchronized approach from one stage to the next (seed 001 section 2).
_SYNC_STEPS = {events.STATION_REACHED: (c.PHASE_SYNC_APPROACH, c.PHASE_ATTITUDE_SYNC),
               events.ATTITUDE_SYNCHRONIZED: (c.PHASE_ATTITUDE_SYNC, c.PHASE_ORBITING),
               events.DOCKING_STARTED: (c.PHASE_ORBITING, c.PHASE_DOCKING)}
# After the capture (post_capture): (phase, event) -> the next phase; the events are the simulator's (the arm),
# guidance's (the damping) and the estimator's (the mass properties).
_POST_CAPTURE_STEPS = {(c.PHASE_CAPTURE, events.CAPTURED): c.PHASE_GRASP,
                       (c.PHASE_GRASP, events.GRASP_DAMPED): c.PHASE_DAMPING,
                       (c.PHASE_GRASP, events.GRASP_RELEASED): c.PHASE_ESCAPE,
                       (c.PHASE_DAMPING, events.DAMPING_COMPLETE): c.PHASE_MASS_ESTIMATION,
                       (c.PHASE_MASS_ESTIMATION, events.MASS_PROPERTIES_ESTIMATED): c.PHASE_COMPLETE}
# With a transport (post_capture.transport) these come first: the estimation goes on to TRANSPORT.
_TRANSPORT_STEPS = {(c.PHASE_MASS_ESTIMATION, events.MASS_PROPERTIES_ESTIMATED): c.PHASE_TRANSPORT,
                    (c.PHASE_TRANSPORT, events.TRANSPORT_COMPLETE): c.PHASE_COMPLETE,
                    (c.PHASE_TRANSPORT, events.TRANSPORT_REFUSED): c.PHASE_COMPLETE}
# The phases whose abort or retreat gets the avoidance check (abort_escape): the chaser coasts from its own thrust (in
# the synchronized approach's later stages guidance flies the retreat itself; the fly-by's passive arc needs none).
SAFED_FROM = (c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_HOLD, c.PHASE_TERMINAL_APPROACH,
              c.PHASE_TRAJECTORY_ADJUST, c.PHASE_OPTIMAL_APPROACH, c.PHASE_SYNC_APPROACH)
# The phases the fault table's hold and retreat answer in (fault_table.WAITING_GROUPS).
HOLD_FROM = PHASE_GROUPS['standby']
RETREAT_FROM = PHASE_GROUPS['approach']
# Nodes whose ERROR events abort the mission, watched from the start: they estimate and command.
WATCHED_NODES = ('flyby_estimator', 'flyby_guidance')
# Nodes whose heartbeat (their progress) the watchdog judges, the watched ones from the start, the others once they
# have reported (a node left out of the graph is not lost): silent for watchdog_s is a node_lost the fault table
# answers (docs/faults.md).
HEARTBEAT_NODES = WATCHED_NODES + ('flyby_planner', 'flyby_cam_monitor')
# The reason of a refused plan on the phase_changed event (summary.json end_reason for NO_SAFE_PLAN).
NO_SAFE_PLAN_PREFIX = 'no safe plan: '
_LEVEL_OF = {c.PHASE_ABORTED: 'ERROR', c.PHASE_ESCAPE: 'WARN', c.PHASE_HOLD: 'WARN', c.PHASE_RETREAT: 'WARN'}


def _has_post_capture(scenario):
    return scenario.post_capture is not None


def _starts_attached(scenario):
    return scenario.post_capture is not None and scenario.post_capture.start == 'attached'


def _has_transport(scenario):
    return scenario.post_capture is not None and scenario.post_capture.transport is not None


def _escape_observation_s(scenario):
    return scenario.planner.escape_check_orbits * scenario.orbit_period_s


def _target_boxes(scenario):
    """The target's boxes as (center_m, size_m) body-frame pairs (the docking axis of a synchronized approach)."""
    return [(b.center_m, b.size_m) for b in scenario.target.geometry]


@params.record
class SupervisorParams:
    """What the supervisor reads of the scenario (flyby_msgs_py.params): the phase machine's thresholds and timers,
    the capture tolerances (seed 000 section 4.1), the target's model for the capture decision and what the
    avoidance burn of an abort needs. ``offset_m`` is the preferred fly-by offset, the decision's only where no
    plan has said its own (SupervisorCore._try_decision)."""

    min_observation_s: float = params.key('planner.min_observation_s')
    restriction_sphere_radius_m: float = params.key('planner.restriction_sphere_radius_m')
    sphere_margin_m: float = params.key('guidance.sphere_margin_m')
    command_lead_s: float = params.key('guidance.command_lead_s')
    reach_m: float = params.key('chaser.manipulator.reach_m')
    position_tolerance_m: float = params.key('chaser.manipulator.position_tolerance_m')
    velocity_tolerance_mps: float = params.key('chaser.manipulator.velocity_tolerance_mps')
    capture_hold_s: float = params.key('supervisor.capture_hold_s')
    escape_observation_s: float = params.derived(_escape_observation_s)
    watchdog_s: float = params.key('supervisor.watchdog_s')
    hold_limit_s: float = params.key('supervisor.hold_limit_s')
    max_retreats: int = params.key('supervisor.max_retreats')
    avoidance_delta_v_mps: float = params.key('supervisor.avoidance_delta_v_mps')
    offset_m: float = params.key('planner.offset_m')
    x_grasp_body_m: np.ndarray = params.key('target.grasp_point_body_m', np.array)
    target_boxes: list = params.derived(_target_boxes)  # (center_m, size_m) per box, target_body
    boxes: object = params.key('boxes')  # flyby_sim.scenario.Boxes: the keep-out region the avoidance burn clears
    target_inertia_kg_m2: np.ndarray = params.key('target_inertia')
    n_rad_s: float = params.key('mean_motion_rad_s')
    planner: PlannerConfig = params.sub(PlannerConfig)  # the avoidance burn's passive-safety check
    post_capture: bool = params.derived(_has_post_capture)  # the capture goes on to GRASP
    start_attached: bool = params.derived(_starts_attached)  # the run starts in MASS_ESTIMATION (seed 004 §3.1)
    transport: bool = params.derived(_has_transport)  # the estimation goes on to TRANSPORT
    estimates: EstimateAgeParams = params.sub(EstimateAgeParams)  # the estimates' age (estimate_age)


@dataclasses.dataclass(frozen=True)
class Transition:
    t: float
    phase_from: str
    phase_to: str
    reason: str
    values: dict


class PhaseMachine:
    """The phase logic (module doc). Each input method returns the list of transitions it caused."""

    def __init__(self, params, watched_nodes=WATCHED_NODES):
        """params: SupervisorParams; watched_nodes: the nodes whose faults abort and whose heartbeat the watchdog
        judges from the start (the node's parameter, not the scenario's)."""
        self.params = params
        self.watched_nodes = tuple(watched_nodes)
        self.phase = c.PHASE_MASS_ESTIMATION if params.start_attached else c.PHASE_ESTIMATION
        self.t_first_estimate = None
        self.converged = False
        self.t_i = None
        self.t_grasp = None
        self.offset_m = None  # the plan's fly-by offset delta r [m]
        self.method = None  # the plan's method (DESIGN §10)
        self.t_entered = 0.0
        self.decision = None
        self.held = {}  # (kind, component) -> (the time its wait began, its detector): what HOLD or RETREAT waits on
        self.retreats = 0  # retreats flown

    # -- helpers --------------------------------------------------------------------------------
    def _go(self, t, phase, reason, values=None):
        tr = Transition(t, self.phase, phase, reason, dict(values or {}))
        self.phase = phase
        self.t_entered = t
        return [tr]

    @property
    def active(self):
        return self.phase in ACTIVE_PHASES

    # -- inputs ---------------------------------------------------------------------------------
    def target_estimate(self, t):
        if self.t_first_estimate is None:
            self.t_first_estimate = t
        return self.maybe_plan(t)

    def maybe_plan(self, t):
        """ESTIMATION -> PLANNING where its conditions hold at t (converged, min_observation_s observed)."""
        if self.phase != c.PHASE_ESTIMATION or not self.converged or self.t_first_estimate is None:
            return []
        observed = t - self.t_first_estimate
        if observed < self.params.min_observation_s:
            return []
        return self._go(t, c.PHASE_PLANNING, f'target estimate converged; {observed:.1f} s of attitude data',
                        {'observation_s': observed})

    def event(self, t, level, name, source, values):
        """An event from /mission/events (not our own)."""
        if name == events.TARGET_CONVERGED:
            self.converged = True
            return self.maybe_plan(t)
        if name == events.TARGET_DIVERGED:
            self.converged = False
            return []
        if name == events.PLAN_SELECTED:
            plan = event_payloads.decode_values(name, values)
            if plan.method == 'optimal' and self.phase in (c.PHASE_PLANNING, c.PHASE_OPTIMAL_APPROACH):
                self.t_grasp = plan.t_grasp_s
                self.method, self.offset_m = 'optimal', plan.offset_m
                if self.phase == c.PHASE_OPTIMAL_APPROACH:
                    return []
                return self._go(t, c.PHASE_OPTIMAL_APPROACH, f'optimal approach selected: grasp at t = '
                                                             f'{self.t_grasp:.2f} s', {'t_grasp_s': self.t_grasp})
            if plan.method == 'sync':
                self.method, self.offset_m = 'sync', plan.offset_m
                if self.phase != c.PHASE_PLANNING:
                    return []
                return self._go(t, c.PHASE_SYNC_APPROACH,
                                f'synchronized approach selected: station at t = {plan.t_arrival_s:.2f} s',
                                {'t_arrival_s': plan.t_arrival_s})
        if name in _SYNC_STEPS and self.phase == _SYNC_STEPS[name][0] and source in self.watched_nodes:
            t_grasp_s = getattr(event_payloads.decode_values(name, values), 't_grasp_s', None)
            if t_grasp_s is not None:
                self.t_grasp = t_grasp_s
            return self._go(t, _SYNC_STEPS[name][1], values.get('reason', name),
                            {} if t_grasp_s is None else {'t_grasp_s': t_grasp_s})
        if name == events.PLAN_SELECTED and self.phase == c.PHASE_PLANNING:
            plan = event_payloads.decode_values(name, values)
            self.t_i = plan.t_i_s
            self.t_grasp = plan.t_grasp_s
            self.method = 'flyby' if plan.method is None else plan.method
            self.offset_m = plan.offset_m
            return self._go(t, c.PHASE_TERMINAL_APPROACH, f'plan selected: grasp at t = {self.t_grasp:.2f} s, '
                                                          f'injection at {self.t_i:.2f} s',
                            {'t_grasp_s': self.t_grasp, 't_i_s': self.t_i})
        if name == events.PLAN_REFUSED and self.phase == c.PHASE_PLANNING and self.retreats:  # an approach flown
            return self._go(t, c.PHASE_ABORTED, f'no safe plan after the retreat: {values.get("reason", source)}')
        if name == events.PLAN_REFUSED and self.phase == c.PHASE_PLANNING:
            return self._go(t, c.PHASE_COMPLETE, NO_SAFE_PLAN_PREFIX + values.get('reason', 'the planner refused'),
                            {'no_safe_plan': True})
        refined = event_payloads.decode_values(name, values) if name == events.TARGET_REFINED else None
        if refined is not None and refined.t_grasp_s is not None:
            self.t_grasp = refined.t_grasp_s
            return []
        if name == events.THRUSTING_ENDED and self.phase == c.PHASE_TRAJECTORY_ADJUST:
            return self._go(t, c.PHASE_FLYBY, 'guidance ended thrusting: passive fly-by')
        if self.params.transport and (self.phase, name) in _TRANSPORT_STEPS:
            return self._go(t, _TRANSPORT_STEPS[(self.phase, name)], values.get('reason', name),
                            {k: v for k, v in values.items() if k != 'reason'})
        if self.params.post_capture and (self.phase, name) in _POST_CAPTURE_STEPS:
            return self._go(t, _POST_CAPTURE_STEPS[(self.phase, name)], values.get('reason', name),
                            {k: v for k, v in values.items() if k != 'reason'})
        if name == events.NODE_ERROR and self.phase in ACTIVE_PHASES:  # any node's core raised (core_guard)
            return self._go(t, c.PHASE_ABORTED, f'{name}: {values.get("reason", source)}',
                            {'source': source, 'event': name})
        if level == 'ERROR' and source in self.watched_nodes and self.phase in ACTIVE_PHASES:
            return self._go(t, c.PHASE_ABORTED, f'fault reported by {source}: {name}',
                            {'source': source, 'event': name})
        return []

    def chaser_estimate(self, t, r_hill):
        """Transitions due at a chaser estimate; the capture decision is ``decide`` (it needs the target)."""
        if self.phase == c.PHASE_TERMINAL_APPROACH and t >= self.t_i:
            return self._go(t, c.PHASE_TRAJECTORY_ADJUST, f'injection time t_i = {self.t_i:.2f} s reached')
        if self.phase == c.PHASE_TRAJECTORY_ADJUST and np.linalg.norm(r_hill) < self.params.restriction_sphere_radius_m:
            return self._go(t, c.PHASE_FLYBY, 'inside the restriction sphere: passive fly-by')
        return []

    def wants_decision(self, t):
        """True at the first chaser estimate at or after the grasp time in FLYBY or OPTIMAL_APPROACH."""
        return self.phase in c.DECIDING_PHASES and self.t_grasp is not None and t >= self.t_grasp

    def decide(self, t, decision):
        """Apply a CaptureDecision made at the grasp time."""
        self.decision = decision
        return self._go(t, c.PHASE_CAPTURE if decision.capture else c.PHASE_ESCAPE, decision.reason,
                        {'t_grasp_s': self.t_grasp, **decision.values})

    def clock(self, t):
        """Timers: the limit of a wait for a fault's recovery, the holds before COMPLETE."""
        if self.phase in c.WAITING_PHASES and t - self.t_entered >= self.params.hold_limit_s:
            faults = ', '.join(f'{kind} on {component}' for kind, component in self.held)
            return self._go(t, c.PHASE_ABORTED, f'{self.phase.lower()}: {faults} not recovered within '
                                                f'{self.params.hold_limit_s:g} s', {'hold_s': t - self.t_entered})
        if self.phase == c.PHASE_CAPTURE and not self.params.post_capture and \
                t - self.t_entered >= self.params.capture_hold_s:
            return self._go(t, c.PHASE_COMPLETE, f'attached for {t - self.t_entered:.1f} s')
        if self.phase == c.PHASE_ESCAPE and t - self.t_entered >= self.params.escape_observation_s:
            return self._go(t, c.PHASE_COMPLETE, f'passive escape observed for {t - self.t_entered:.1f} s')
        return []

    def abort(self, t, why):
        if not self.active:
            return []
        return self._go(t, c.PHASE_ABORTED, why)

    def hold(self, t, fault, why, source):
        """The fault table's ``hold`` of ``fault`` (kind, component), detected by ``source``, at t [s]: standby held
        until it recovers (``_wait_for``)."""
        if self.phase not in HOLD_FROM:
            return []
        self._wait_for(t, fault, source)
        if self.phase in c.WAITING_PHASES:
            return []
        return self._go(t, c.PHASE_HOLD, f'hold: {why}', {'kind': fault[0], 'component': fault[1]})

    def retreat(self, t, fault, why, source):
        """The fault table's ``retreat`` of ``fault`` at t [s]: the approach given up (the chaser safed as by an
        abort, SupervisorCore._apply) and planned again once the fault has recovered; beyond max_retreats, an
        abort."""
        if self.phase not in RETREAT_FROM:
            return []
        if self.retreats >= self.params.max_retreats:
            return self._go(t, c.PHASE_ABORTED, f'{why}: the fault table answers retreat, {self.retreats} of '
                                                f'supervisor.max_retreats {self.params.max_retreats} flown')
        self.retreats += 1
        self._wait_for(t, fault, source)
        self.t_i = self.t_grasp = self.offset_m = self.method = None  # the next plan's
        return self._go(t, c.PHASE_RETREAT, f'retreat: {why}', {'kind': fault[0], 'component': fault[1]})

    def _wait_for(self, t, fault, source):
        """Wait for ``fault``, detected by ``source``, to recover. A lost estimator's successor starts a new filter
        (its own convergence and observation are waited for) and new monitors, which never clear their
        predecessor's detections: those are forgotten (the successor detects again what persists)."""
        if fault == ('node_lost', ESTIMATOR):
            self.converged, self.t_first_estimate = False, None
            self.held = {f: held for f, held in self.held.items() if held[1] != ESTIMATOR}
        self.held.setdefault(fault, (t, source))

    def recovered(self, t, fault):
        """A fault_recovered of ``fault`` (kind, component) at t [s]: a hold or a retreat ends with the last fault it
        waits on."""
        held = self.held.pop(fault, None)
        if held is None or self.held or self.phase not in c.WAITING_PHASES:
            return []
        return self._go(t, c.PHASE_ESTIMATION, f'{fault[0]} on {fault[1]} recovered after {t - held[0]:.1f} s: the '
                                               f'{self.phase.lower()} ends', {'hold_s': t - self.t_entered})


class SupervisorCore:
    """What the supervisor node does, without ROS: the phase machine fed with the stamped estimates,
    events, progress and clock, the capture decision at the grasp time and the avoidance burn after
    an abort (module doc). Every input method returns the outputs to publish, in order: Transition
    (mission/phase), Event (mission/events) and guidance.Maneuver-like (t, dv_hill) commands
    (``AvoidanceBurn``, on guidance/maneuver).

    The capture is decided against the offset of the plan flown: the plan_selected event's (a re-plan may pick
    another than the preferred one, and the decision must judge the passage guidance flies), the record's
    preferred ``offset_m`` only while no plan has said one."""

    def __init__(self, params: SupervisorParams, watched_nodes=WATCHED_NODES, name='flyby_supervisor'):
        self.params = params
        self.name = name
        self.machine = PhaseMachine(params, watched_nodes)
        self.dynamics = ErrorStateDynamics(params.target_inertia_kg_m2)
        self.n = params.n_rad_s
        self.targets = StampedBuffer()  # (t, q_hill_from_body, omega_body) of the target estimates
        self.spinning_target = None  # the latest of them with a spin axis (keepout.has_spin_axis): _escape_burn
        self.chaser = None  # (t, r_hill, v_hill) of the latest chaser estimate
        self.pending_burns = PendingBurns()  # guidance's commanded burns: the abort's coast goes through them
        self.decision_at = None  # the chaser estimate the capture decision waits to be made at
        self.t_clock = 0.0
        self.fault_table = FaultTable.load()
        self.cam_fired = False
        self.heartbeats = dict.fromkeys(self.machine.watched_nodes, 0.0)  # node -> the sim time it last reported
        self.lost = set()  # the nodes the watchdog has found silent
        self.estimate_age = EstimateAgeMonitor(params.estimates)
        self.active_faults = {}  # (kind, component) -> its fault_detected, until its fault_recovered

    @property
    def phase(self):
        return self.machine.phase

    def start(self):
        """The outputs at start: the first phase and its event."""
        phase = self.machine.phase
        return [Transition(0.0, '', phase, f'mission starts in {phase}', {}),
                self._event(0.0, 'OK', events.PHASE_CHANGED, f'mission starts in {phase}',
                            event_payloads.encode(event_payloads.PhaseChanged('', phase)))]

    # -- inputs ---------------------------------------------------------------------------------
    def on_target_estimate(self, t, q_hill_from_body, omega_body):
        out = self._estimate_arrived(TARGET_ESTIMATE, t)
        estimate = (t, np.asarray(q_hill_from_body, dtype=float), np.asarray(omega_body, dtype=float))
        self.targets.add(t, estimate)
        if has_spin_axis(self.params.target_inertia_kg_m2, estimate[2]):
            self.spinning_target = estimate
        return out + self._apply(self.machine.target_estimate(t)) + self._try_decision()

    def on_chaser_estimate(self, t, r_hill, v_hill):
        out = self._estimate_arrived(CHASER_ESTIMATE, t)
        self.chaser = (t, np.asarray(r_hill, dtype=float), np.asarray(v_hill, dtype=float))
        out += self._apply(self.machine.chaser_estimate(t, self.chaser[1]))
        if self.decision_at is None and self.machine.wants_decision(t):
            self.decision_at = self.chaser
        return out + self._try_decision()

    def on_event(self, event):
        """An event of mission/events (wire.Event; values as text); our own are ignored."""
        if event.source == self.name:
            return []
        if event.name == events.CAM_FIRED:  # the independent monitor has the thrusters: the mission is over
            self.cam_fired = True
            return self._apply(self.machine.abort(event.t, f'CAM fired by {event.source}'))
        if event.name == events.MANEUVER_COMMANDED:
            burn = event_payloads.decode(event)
            self.pending_burns.add(burn.t_burn_s, burn.dv_hill_mps)
        if event.name in (events.FAULT_DETECTED, events.FAULT_RECOVERED):
            found = event_payloads.decode(event)  # a gap of a sensor's samples explains its estimates' (estimate_age)
            self.estimate_age.on_detection(found.kind, found.component, event.name == events.FAULT_DETECTED)
        if event.name == events.FAULT_DETECTED:
            return self._respond(event)
        if event.name == events.FAULT_RECOVERED:
            found = event_payloads.decode(event)
            return self._recovered(event.t, (found.kind, found.component))
        values = dict(event.values, reason=event.message)
        return self._apply(self.machine.event(event.t, event.level, event.name, event.source, values))

    def _respond(self, event):
        """The fault table's answer to a fault_detected (fault_response): its events and the abort it may cause."""
        found = event_payloads.decode(event)
        if (found.kind, found.component) == ('node_lost', ESTIMATOR):  # its successor detects again what persists
            self.active_faults = {f: e for f, e in self.active_faults.items() if e.source != ESTIMATOR}
        self.active_faults[found.kind, found.component] = event
        reply = respond(self.fault_table, event, self.phase, self.cam_fired)
        out = [self._event(event.t, *a) for a in reply.events]
        if reply.abort is not None and self.machine.active:
            out += self._apply(self.machine.abort(event.t, reply.abort))
        if reply.hold is not None:
            out += self._apply(self.machine.hold(event.t, reply.hold, event.message, event.source))
        if reply.retreat is not None:
            out += self._apply(self.machine.retreat(event.t, reply.retreat, event.message, event.source))
            self.decision_at = None  # a decision the given-up approach waited for is not the next one's
        return out

    def on_progress(self, node, t):
        """A node's heartbeat: the sim time it has got to."""
        if node in HEARTBEAT_NODES:
            self.heartbeats[node] = max(t, self.heartbeats.get(node, -math.inf))
        if node == ESTIMATOR:
            self.estimate_age.on_progress(t)
        return []

    def on_clock(self, t):
        self.t_clock = t
        out = self._watchdog(t)
        lost = ESTIMATOR in self.lost
        out += self._estimate_findings(self.estimate_age.judge(t, self.machine.active and not lost, lost))
        return out + self._apply(self.machine.clock(t))

    def _watchdog(self, t):
        """Each node's heartbeat judged at the clock: silent for watchdog_s, a fault_detected (node_lost, monitor
        watchdog) answered by the fault table; reporting again, a fault_recovered."""
        out = []
        for node, last in self.heartbeats.items():
            silent = t - last > self.params.watchdog_s
            if silent == (node in self.lost):
                continue
            if silent:
                self.lost.add(node)
                out += self._found(t, 'watchdog', 'node_lost', node, True, f'watchdog: {node} silent for '
                                   f'{t - last:.1f} s', {'last_progress_s': last})
            else:
                self.lost.discard(node)
                out += self._found(t, 'watchdog', 'node_lost', node, False, f'watchdog: {node} reports again', {})
        return out

    def _estimate_arrived(self, component, t):
        """An estimate of the stream ``component`` stamped t [s] admitted: its age judged (estimate_age)."""
        judged = self.machine.active and ESTIMATOR not in self.lost
        return self._estimate_findings(self.estimate_age.on_estimate(component, t, self.t_clock, judged))

    def _estimate_findings(self, findings):
        """The estimate-age monitor's findings as detections answered by the fault table, or recoveries."""
        return [o for f in findings for o in self._found(f.t, MONITOR, KIND, f.component, f.detected, f.message,
                                                            f.values)]

    def _found(self, t, monitor, kind, component, detected, message, values):
        """One of the supervisor's own monitors' detection at t [s] (its fault_detected, ERROR, and the fault table's
        answer) or recovery (fault_recovered, OK)."""
        if not detected:
            payload = event_payloads.FaultRecovered(monitor, kind, component, t)
            return [self._event(t, 'OK', events.FAULT_RECOVERED, message, event_payloads.encode(payload))] + \
                self._recovered(t, (kind, component))
        payload = event_payloads.FaultDetected(monitor, kind, component, t, None)
        event = self._event(t, 'ERROR', events.FAULT_DETECTED, message, event_payloads.encode(payload, values))
        return [event] + self._respond(event)

    def _recovered(self, t, fault):
        """A fault's recovery at t [s]. Where it ends a hold or a retreat, the faults still active are answered again
        as in standby before anything is planned (one answered continue in the approach, the CAM monitor's loss
        say, is held there), then ESTIMATION -> PLANNING where its conditions hold."""
        self.active_faults.pop(fault, None)
        ended = self.machine.recovered(t, fault)
        if not ended:
            return []
        out = self._apply(ended)
        for (kind, component), event in list(self.active_faults.items()):
            if self.phase == c.PHASE_ESTIMATION and \
                    self.fault_table.response(kind, component, self.phase).response in ('hold', 'abort'):
                out += self._respond(event._replace(t=t))
        return out + self._apply(self.machine.maybe_plan(t))

    def abort(self, why):
        """(aborted, outputs) for an abort request at the current clock."""
        transitions = self.machine.abort(self.t_clock, why)
        return bool(transitions), self._apply(transitions)

    # -- decisions ------------------------------------------------------------------------------
    def _try_decision(self):
        """Decide at the first chaser estimate at or after t_g, once the target estimates up to its stamp are
        in, with the last target estimate stamped at or before t_g (carried forward to t_g)."""
        if self.decision_at is None or not self.machine.wants_decision(self.decision_at[0]):
            return []
        if self.targets.first_at_or_after(self.decision_at[0]) is None:
            return []
        if self.machine.phase == c.PHASE_DOCKING:  # the final point is held: decided at the estimate's own stamp
            self.machine.t_grasp = self.decision_at[0]
        target = self.targets.last_at_or_before(self.machine.t_grasp) or self.targets.first_at_or_after(
            self.machine.t_grasp)
        p = self.params
        offset_m = self.machine.offset_m if self.machine.offset_m is not None else p.offset_m
        x_target_body = capture_target_body(self.machine.method, p.x_grasp_body_m, offset_m, p.target_boxes)
        decision = decide_capture(self.decision_at, target[1], self.machine.t_grasp, self.dynamics, self.n,
                                  p.x_grasp_body_m, x_target_body, p)
        return self._apply(self.machine.decide(self.decision_at[0], decision))

    def _escape_burn(self, t):
        """After an abort or a retreat outside the sphere: the avoidance check of the coast through guidance's burns
        still to fly, and its burn where the coast is unsafe (flyby_mission.abort_escape.escape_outputs)."""
        latest = self.targets.latest
        return [o if isinstance(o, AvoidanceBurn) else self._event(t, *o) for o in escape_outputs(
            self.params, t, self.chaser, self.pending_burns, self.spinning_target, latest and latest[0])]

    # -- outputs --------------------------------------------------------------------------------
    def _apply(self, transitions):
        out = []
        for tr in transitions:
            out.append(tr)
            out.append(self._event(tr.t, _LEVEL_OF.get(tr.phase_to, 'OK'), events.PHASE_CHANGED,
                                   f'{tr.phase_from} -> {tr.phase_to}: {tr.reason}',
                                   event_payloads.encode(event_payloads.PhaseChanged(tr.phase_from, tr.phase_to),
                                                         tr.values)))
            if tr.phase_to in (c.PHASE_ABORTED, c.PHASE_RETREAT) and tr.phase_from in SAFED_FROM:
                out += self._escape_burn(tr.t)
        return out

    def _event(self, t, level, name, message, values):
        return Event(t, level, name, message, values, self.name)
