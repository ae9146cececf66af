"""What the planner node does, without ROS: when to plan, from which estimates, and what it publishes.

The planner plans when the supervisor turns the mission to PLANNING (its stamped ``phase_changed``
event) or on a replan request, at the first target estimate stamped at or after the request, once
the chaser estimates up to that stamp are in: the plan time is that estimate's stamp, the same at
any pace of the run. The target motion is predicted from that estimate (attitude, body rate, the
scenario's inertia), the chaser state is the last chaser estimate up to the plan time carried to it
along CW (seed 000 eq 22). The planning itself is ``flyby_planner.plan`` (seed 000 §4.3-4.5, 4.7).

When guidance re-aims at a re-solved grasp (its ``target_refined`` event), the grasp and the fly-by
target point the mission now aims at are published again (``AimUpdate``), so the bag holds what was
flown, not only the first plan; so are, when a synchronized approach starts docking (``docking_started``), the
port and the final point at its grasp time (the simulator holds the capture decision at that stamp).

``planner.method`` (DESIGN §10) chooses the method: ``flyby`` plans the fly-by only; ``optimal`` the
optimization-based approach only (seed 003 section 4, ``flyby_planner.optimal.approach``; a rigid-body chaser);
``auto`` the fly-by, and the optimization-based approach when the fly-by finds no safe plan and the chaser is a
rigid body. The choice and its reason are a ``method_chosen`` event; nothing safe from any method tried is a
``plan_refused`` with every method's reason. An optimal plan is published as ``TrajectoryPublished``
(planner/grasp, planner/flyby_target = X_Ft, V_Ft at the grasp, planner/trajectory, planner/path). Guidance's
``replan_requested`` event (the tracking error grew beyond its bound) plans the approach again from the
estimates of its stamp to the same grasp time: the chaser's state at the new start is the estimate moved as the
trajectory flown moves over the lead (guidance flies it until the new one starts). The planner re-aims the same
way: every ``planner.optimal.reaim_interval_s`` it predicts the end point X_Ft at the grasp time from the newest
target estimate, and when that has moved by more than ``reaim_error_m`` from the plan's (a tumbler's motion
predicted 100 s ahead from one estimate misses by centimetres; outside the last ``replan_cutoff_s``) it plans again
to the new end point. A re-aim that finds no safe plan is a WARN ``reaim_refused``: the plan flown stays.

Several chasers (a ``chasers:`` scenario, seed 003 Fig 12) plan in the file's order: a chaser's planner takes
the earlier chasers' (its leaders') plan decisions (``plan_selected``, ``plan_refused`` on
``/<leader>/mission/events``) and trajectories (``/<leader>/planner/trajectory``) and plans at the first target
estimate stamped at or after both its request and each leader's decision (the leader's decision latest at or
before the request, else its first after it): the plan time is a stamp, the same at any pace, and the simulator
cannot run past it by more than its flow-control window while the leader plans. An optimization-based approach
then keeps its envelope off the leaders' planned motion (flyby_planner.optimal.mutual: keep-out planes and mutual
safety in SCP, the dense separation checked before it is flown, at least planner.clearance_margin_m); the
predicted least separation goes on ``plan_selected`` (``separation_m``, ``t_separation_s``, ``separation_from``).
A fly-by plan does not look at the leaders.

The planner node and the headless driver (flyby_mission.headless) both run ``PlannerCore``;
every input method returns the outputs to publish, in order.
"""

import dataclasses
import json
import time

import numpy as np

from flyby_estimation.target_motion import ErrorStateDynamics, covariance_from_published, prediction_from_estimate
from flyby_msgs_py import contract as c
from flyby_msgs_py.stamped import StampedBuffer
from flyby_msgs_py.wire import STAMP_TOLERANCE_S, Event
from flyby_planner.grasp import capture_target_body
from flyby_planner.optimal.approach import approach_settings_from_scenario, plan_approach, prepare_approach
from flyby_planner.optimal.mutual import MovingObstacle, least_separation
from flyby_planner.optimal.problem import GraspTerminal, TargetMotion
from flyby_planner.optimal.scp import ScpSettings
from flyby_planner.plan import plan_capture, planner_config_from_scenario
from flyby_planner.sync.approach import HOLD_CHECK_S, arrival_window, is_category_iv, plan_sync, resolve_due
from flyby_sim.dynamics.orbital import cw_coast

# The request of a re-aim (``_check_aim``): its refusal keeps the plan flown.
REAIM = 're-aim'
# Values of the selected candidate put on its plan_selected event.
_SELECTED_KEYS = ('t_grasp_s', 't_i_s', 't_ti_s', 'dv_total_mps', 'clearance_approach_m', 'clearance_escape_m',
                  'closest', 't_sphere_entry_s', 'x_g_hill_m', 'v_g_hill_mps', 'x_ft_hill_m', 'v_ft_hill_mps',
                  'x_fi_hill_m', 'v_fi_hill_mps', 'unguided_coast_s', 'miss_3sigma_m', 'miss_3sigma_mps',
                  'extended_window')
_CANDIDATE_KEYS = ('t_grasp_s', 'status', 'offset_m', 'flyby_duration_s', 'dv_total_mps', 'clearance_approach_m',
                   'clearance_escape_m', 'closest', 't_i_s', 'convex_value_m2_s2', 'miss_3sigma_m')


@dataclasses.dataclass(frozen=True)
class GraspState:
    """The grasp point at the grasp time t [s]: x_g [m] and v_g [m/s] (relative to hill) in hill, and the
    target's attitude q_hill_from_body and inertial body rate omega_body [rad/s] there."""

    t: float
    x_g: np.ndarray
    v_g: np.ndarray
    q_hill_from_body: np.ndarray
    omega_body: np.ndarray


@dataclasses.dataclass(frozen=True)
class PlanMarkers:
    """What a plan looks like in a 3-D viewer, in hill: restriction-sphere radius, the swept keep-out
    cylinders (centre, unit axis, radius, height), the grasp point, the fly-by
    target and initial points and the path (None where the plan has none)."""

    sphere_radius_m: float
    cylinders: tuple
    grasp_point: np.ndarray = None
    flyby_points: tuple = ()
    path_r_hill: np.ndarray = None


@dataclasses.dataclass(frozen=True)
class PlanPublished:
    """A selected plan: planner/grasp, planner/flyby_target (X_Ft, V_Ft at t_f, eq 20-21),
    planner/flyby_initial (X_Fi, V_Fi at t_i, eq 23), planner/path (stamped t_plan) and its markers."""

    t_plan: float
    grasp: GraspState
    t_f: float
    x_ft: np.ndarray
    v_ft: np.ndarray
    t_i: float
    x_fi: np.ndarray
    v_fi: np.ndarray
    path_t: np.ndarray
    path_r_hill: np.ndarray
    markers: PlanMarkers


@dataclasses.dataclass(frozen=True)
class TrajectoryPublished:
    """An optimal approach: planner/grasp, planner/flyby_target (X_Ft, V_Ft at the grasp time t_f, eq 20-21),
    planner/trajectory (stamp t_start; trajectory = cost.Trajectory: t_s, r_hill, v_hill, a_hill), planner/path
    (stamped t_plan) and its markers."""

    t_plan: float
    grasp: GraspState
    t_f: float
    x_ft: np.ndarray
    v_ft: np.ndarray
    t_start: float
    trajectory: object
    markers: PlanMarkers


@dataclasses.dataclass(frozen=True)
class PlanRefused:
    """A refused plan: only its markers (the keep-out region that defeated it) are published."""

    t_plan: float
    markers: PlanMarkers


@dataclasses.dataclass(frozen=True)
class AimUpdate:
    """The grasp and fly-by target point guidance re-aimed at (planner/grasp, planner/flyby_target)."""

    grasp: GraspState
    x_ft: np.ndarray
    v_ft: np.ndarray


def plan_markers(plan, config):
    """PlanMarkers of a plan: the keep-out cylinders about the spin axis at the grasp (or plan) time."""
    n = config.mean_motion_rad_s
    chosen = plan.selected
    cylinders = []
    if plan.region is not None:
        region = plan.region
        axis = region.axis_hill(chosen.t_grasp if chosen else plan.t_plan, n)
        cylinders = [(0.5 * (lo + hi) * axis, axis, radius, hi - lo)
                     for lo, hi, radius in zip(region.axial_min_m, region.axial_max_m, region.radius_m, strict=True)]
    if chosen is None:
        return PlanMarkers(config.restriction_sphere_radius_m, tuple(cylinders))
    return PlanMarkers(config.restriction_sphere_radius_m, tuple(cylinders), chosen.x_g, (chosen.x_ft, chosen.x_fi),
                       plan.path_r_hill)


def _vector_value(values, key):
    return np.array(json.loads(values[key]), dtype=float)


class PlannerCore:
    """The planner's rules (module doc)."""

    def __init__(self, scenario, name='flyby_planner'):
        self.scenario = scenario
        self.name = name
        self.config = planner_config_from_scenario(scenario)
        self.dynamics = ErrorStateDynamics(scenario.target_inertia)
        self.request = None  # (t_request, why) until the plan is made
        self.targets = StampedBuffer()  # (q_hill_from_body, omega_body, covariance blocks or None) by stamp
        self.chasers = StampedBuffer()  # (r_hill, v_hill) by stamp
        self.plans = 0
        names = scenario.chaser_names
        self.leaders = names[:names.index(scenario.chaser_name)] if names else ()  # chasers that plan before this
        self.leader_decisions = {name: [] for name in self.leaders}  # [(t_plan, t_start or None)] as they came
        self.leader_trajectories = {name: [] for name in self.leaders}  # [(t_s, r_hill, v_hill)]
        self.waiting_for = None  # the leaders a request waits for, once announced
        self.rigid = scenario.chaser.model == 'rigid_body'
        self.approach = approach_settings_from_scenario(scenario)
        if scenario.planner.method == 'optimal' or (scenario.planner.method == 'auto' and self.rigid):
            prepare_approach(scenario, self.approach, obstacles=len(self.leaders))  # compiled now, not at the plan
        self.method_flown = None  # the method of the plan being flown: a re-plan keeps it
        self.flown = None  # the TrajectoryPublished being flown (an optimal or synchronized approach)
        self.sync_arrival = None  # the synchronized approach's ArrivalChoice being flown
        self.aim_checked_t = None  # the time of the last re-aim check of an optimal approach (the plan's first) [s]

    # -- inputs ---------------------------------------------------------------------------------
    def on_event(self, event):
        """The supervisor's stamped transition to PLANNING plans at that time; guidance's re-aim is published."""
        if event.name == 'phase_changed' and event.values.get('to') == c.PHASE_PLANNING:
            self.request = (event.t, 'phase PLANNING')
            return self._try_plan()
        if event.name == 'replan_requested' and self.method_flown == 'optimal':
            self.request = (event.t, f'replan: {event.message}')
            return self._try_plan()
        if event.name == 'target_refined' and 'x_g_hill_m' in event.values:
            v = event.values
            grasp = GraspState(float(v['t_grasp_s']), _vector_value(v, 'x_g_hill_m'), _vector_value(v, 'v_g_hill_mps'),
                               _vector_value(v, 'q_hill_from_body'), _vector_value(v, 'omega_body_rad_s'))
            return [AimUpdate(grasp, _vector_value(v, 'x_ft_hill_m'), _vector_value(v, 'v_ft_hill_mps'))]
        if event.name == 'docking_started' and self.method_flown == 'sync' and 't_grasp_s' in event.values:
            return self._docking_aim(event.t, float(event.values['t_grasp_s']))
        return []

    def _docking_aim(self, t, t_grasp):
        """The synchronized approach's docking (guidance's ``docking_started`` at t): the port and the final point
        at the grasp time t_grasp, predicted from the target estimate stamped last before t, as AimUpdate (the
        simulator holds the capture decision at that stamp)."""
        target = self.targets.last_at_or_before(t - STAMP_TOLERANCE_S)
        if target is None:
            return []
        t_t, (q_hill_from_body, omega_body, _) = target
        prediction = prediction_from_estimate(self.dynamics, self.config.mean_motion_rad_s, t_t, q_hill_from_body,
                                              omega_body, t_grasp)
        sc = self.scenario
        x_final_body = capture_target_body('sync', self.config.x_grasp_body_m, sc.planner.offset_m,
                                           [(b.center_m, b.size_m) for b in sc.target.geometry])
        port = prediction.track(self.config.x_grasp_body_m, (t_grasp,))
        final = prediction.track(x_final_body, (t_grasp,))
        at = prediction.state(t_grasp)
        return [AimUpdate(GraspState(t_grasp, port.r_hill[0], port.v_hill[0], at.q_hill_from_body, at.omega_body),
                          final.r_hill[0], final.v_hill[0])]

    def _end_point(self, target, t_f, offset_m):
        """(the motion predicted from a buffered target estimate (t, (q, omega, blocks)) to t_f, the end point X_Ft,
        V_Ft of the grasp point at offset_m at t_f, eq 20-21)."""
        t, (q_hill_from_body, omega_body, _) = target
        prediction = prediction_from_estimate(self.dynamics, self.config.mean_motion_rad_s, t, q_hill_from_body,
                                              omega_body, t_f)
        return prediction, GraspTerminal(prediction, self.config.x_grasp_body_m, offset_m)(t_f)

    def on_replan(self):
        """Plan again at the next target estimate."""
        self.request = (self.targets.latest_t, 'replan requested')
        return []

    def on_leader_event(self, leader, event):
        """An event of a leader's mission/events: its planner's plan_selected (a trajectory to come unless it is a
        fly-by) or plan_refused is its decision at that stamp."""
        if leader not in self.leader_decisions or event.name not in ('plan_selected', 'plan_refused'):
            return []
        v = event.values
        has_trajectory = event.name == 'plan_selected' and v.get('method', 'flyby') != 'flyby'
        self.leader_decisions[leader].append((event.t, float(v['t_start_s']) if has_trajectory else None))
        return self._try_plan()

    def on_leader_trajectory(self, leader, t_s, r_hill, v_hill):
        """A leader's planner/trajectory: its points' times t_s (K,) [s], r_hill, v_hill (K, 3)."""
        if leader in self.leader_trajectories:
            self.leader_trajectories[leader].append(tuple(np.array(a, dtype=float) for a in (t_s, r_hill, v_hill)))
        return self._try_plan()

    def on_chaser_estimate(self, t, r_hill, v_hill):
        self.chasers.add(t, (np.asarray(r_hill, dtype=float), np.asarray(v_hill, dtype=float)))
        return self._try_plan()

    def on_target_estimate(self, t, q_hill_from_body, omega_body, attitude_covariance_hill=None,
                           rate_covariance_body=None):
        """A target estimate (estimation/target/odom) with, if published, its attitude covariance about hill axes
        and rate covariance in body axes (3x3 each): the fly-by's re-aim check starts from them (plan._ReaimModel)."""
        blocks = (None if attitude_covariance_hill is None or rate_covariance_body is None else
                  (np.asarray(attitude_covariance_hill, dtype=float), np.asarray(rate_covariance_body, dtype=float)))
        self.targets.add(t, (np.asarray(q_hill_from_body, dtype=float), np.asarray(omega_body, dtype=float), blocks))
        if self.method_flown == 'sync' and self.request is None and resolve_due(
                t, self.flown.t_plan, self.sync_arrival.t_arrival, self.scenario.planner.sync):
            self.request = (t, 're-solve of the synchronized approach')  # seed 001 section 2
        if self.method_flown == 'optimal':
            self._check_aim()
        return self._try_plan()

    def _check_aim(self):
        """Request a re-aim when X_Ft predicted from the target estimate has moved from the plan's (module doc). The
        checks fall every reaim_interval_s from the plan time, each on the first target estimate stamped at or after
        its time: the same estimates whenever they arrive."""
        o, flown = self.scenario.planner.optimal, self.flown
        while self.request is None:
            t_check = self.aim_checked_t + o.reaim_interval_s
            target = self.targets.first_at_or_after(t_check)
            if target is None or target[0] >= flown.t_f - o.replan_cutoff_s:
                return
            self.aim_checked_t = t_check
            t = target[0]
            _, (x_ft, _) = self._end_point(target, flown.t_f, self.approach.offset_m)
            moved_m = float(np.linalg.norm(x_ft - flown.x_ft))
            if moved_m > o.reaim_error_m:
                self.request = (t, f'{REAIM}: X_Ft predicted from the target estimate of t = {t:.2f} s is '
                                   f'{moved_m:.3f} m from the plan\'s (reaim_error_m {o.reaim_error_m:g})')

    # -- planning -------------------------------------------------------------------------------
    def _try_plan(self):
        """Plan at the first target estimate stamped at or after the request, once the chaser estimates
        up to that stamp are in (the same estimates at any pace of the run)."""
        if self.request is None:
            return []
        t_request, why = self.request
        waiting, t_leaders = self._leaders_decided(t_request)
        if waiting:
            if self.waiting_for == waiting:
                return []
            self.waiting_for = waiting
            return [self._event(t_request, 'OK', 'waiting_for_leaders',
                                f'planning after the plans of {", ".join(waiting)}', {'leaders': ' '.join(waiting)})]
        target = self.targets.first_at_or_after(max(t_request, t_leaders))
        if target is None or self.chasers.latest_t < target[0]:
            return []
        self.request = None
        q_hill_from_body, omega_body, blocks = target[1]
        covariance_body = None if blocks is None else covariance_from_published(q_hill_from_body, *blocks)
        return self._plan(target[0], q_hill_from_body, omega_body, why, covariance_body)

    def _leader_decision(self, leader, t):
        """The leader's decision (t_plan, its trajectory or None) a plan at t goes by: the latest at or before t,
        else its first; None while it has none (or its trajectory has not come in)."""
        decisions = self.leader_decisions[leader]
        if not decisions:
            return None
        t_plan, t_start = ([d for d in decisions if d[0] <= t] or decisions[:1])[-1]
        if t_start is None:
            return t_plan, None
        for traj in self.leader_trajectories[leader]:
            if abs(traj[0][0] - t_start) < 1e-6:
                return t_plan, traj
        return None

    def _leaders_decided(self, t_request):
        """(the leaders still to decide, the latest plan time of the decided ones (-inf without leaders))."""
        decided = {name: self._leader_decision(name, t_request) for name in self.leaders}
        waiting = tuple(name for name, d in decided.items() if d is None)
        return waiting, max((d[0] for d in decided.values() if d is not None), default=-np.inf)

    def _leader_obstacles(self, t, prediction):
        """The leaders' planned motion a plan at t keeps off (mutual.MovingObstacle, carried with the target after
        their end as a captured robot is), with the joint planner's separation margin."""
        attitude = TargetMotion(prediction, self.scenario.boxes, self.config.mean_motion_rad_s).attitude
        obstacles = []
        for name in self.leaders:
            decision = self._leader_decision(name, t)
            if decision is not None and decision[1] is not None:
                t_s, r_hill, v_hill = decision[1]
                obstacles.append(MovingObstacle(name, t_s, r_hill, v_hill,
                                                self.scenario.for_chaser(name).chaser.envelope_radius_m,
                                                ScpSettings.separation_margin_m, self.config.mean_motion_rad_s,
                                                attitude))
        return obstacles

    def plan_inputs(self, t, q_hill_from_body, omega_body, extended=False):
        """What a plan at the target estimate of time t starts from: the chaser's estimated state carried to t
        (eq 22) and the target motion predicted from the estimate over the grasp window (extended: and the
        extended window, as plan.exhaustive_check needs)."""
        prediction = prediction_from_estimate(self.dynamics, self.config.mean_motion_rad_s, t, q_hill_from_body,
                                              omega_body, t + self.config.prediction_span_s(omega_body, extended))
        return self._chaser_at(t), prediction

    def _chaser_at(self, t):
        """The chaser's estimated state (r_hill, v_hill stacked) carried to t by CW (eq 22)."""
        t_c, (r_c, v_c) = self.chasers.last_at_or_before(t) or self.chasers.first_at_or_after(t)
        return cw_coast(r_c, v_c, t - t_c, self.config.mean_motion_rad_s)

    def _plan(self, t, q_hill_from_body, omega_body, why, covariance_body=None):
        """Plan at the target estimate of time t (the plan time) by the method of planner.method (module doc);
        the outputs to publish. covariance_body: that estimate's 6x6 [dtheta_body, domega_body] covariance, if
        published (the fly-by's re-aim check)."""
        self.plans += 1
        method = self.method_flown or self.scenario.planner.method
        if method == 'optimal':
            reason = 'a re-plan of the approach flown' if self.method_flown else 'planner.method optimal'
            return self._plan_optimal(t, q_hill_from_body, omega_body, why, reason, [])
        if method == 'sync' or (method == 'auto' and self.rigid and is_category_iv(omega_body, self.scenario)):
            reason = ('a re-solve of the approach flown' if self.method_flown else 'planner.method sync'
                      if method == 'sync' else 'auto: category IV (condition (a): the rate is at or above '
                                               f'{self.scenario.estimation.spin_rate_deg_s:g} deg/s)')
            return self._plan_sync(t, q_hill_from_body, omega_body, why, reason)
        out, refused = self._plan_flyby(t, q_hill_from_body, omega_body, why, covariance_body)
        if refused is None:
            return out
        if method == 'auto' and self.rigid:
            return self._plan_optimal(t, q_hill_from_body, omega_body, why, f'auto: no safe fly-by ({refused[0]})',
                                      out, refused[0])
        return out + self._refuse(t, why, *refused)

    def _refuse(self, t, why, reason, markers, planning_time_s):
        """plan_refused and the markers of what refused."""
        return [self._event(t, 'ERROR', 'plan_refused', reason, {'request': why, 'plan': str(self.plans),
                                                                  'planning_time_s': planning_time_s}),
                PlanRefused(t, markers)]

    def _method_chosen(self, t, method, reason):
        self.method_flown = method
        return self._event(t, 'OK', 'method_chosen', f'{method}: {reason}', {'method': method, 'reason': reason})

    def _plan_optimal(self, t, q_hill_from_body, omega_body, why, reason, out, flyby_refused=None):
        """The optimization-based approach (flyby_planner.optimal.approach) at the plan time t; ``out``: what the
        fly-by already gave (its candidates), flyby_refused its reason."""
        settings = self.approach
        chaser_now = self._chaser_at(t)
        prediction = prediction_from_estimate(self.dynamics, self.config.mean_motion_rad_s, t, q_hill_from_body,
                                              omega_body, t + settings.horizon_s)
        start_state = None
        if self.flown is not None:  # a re-plan: to the same grasp, from the estimate moved as the flown trajectory
            settings = dataclasses.replace(settings, approach_time_s=self.flown.t_f - t - settings.start_lead_s)
            traj = self.flown.trajectory
            ref = np.array([[np.interp(s, traj.t_s, x[:, k]) for x in (traj.r_hill, traj.v_hill) for k in range(3)]
                            for s in (t, t + settings.start_lead_s)])
            start_state = chaser_now + ref[1] - ref[0]
        obstacles = self._leader_obstacles(t, prediction)
        started = time.perf_counter()  # measured for the record only; nothing here acts on it
        plan = plan_approach(self.scenario, prediction, chaser_now[:3], chaser_now[3:], t, settings, self.config,
                             start_state=start_state, obstacles=obstacles)
        planning_time_s = time.perf_counter() - started
        separation, mutual_values = None, {}
        if plan.ok and obstacles:  # the dense separation from the leaders' plans, before it is flown
            separation = least_separation(plan.plan, obstacles, self.scenario.chaser.envelope_radius_m)
            mutual_values = {'separation_m': separation.distance_m, 't_separation_s': separation.t_s,
                             'separation_from': separation.name}
            if separation.distance_m < self.config.clearance_margin_m:
                plan = dataclasses.replace(plan, ok=False, reason=(
                    f'optimal approach refused: the envelope comes {separation.distance_m:.3f} m from '
                    f'{separation.name}\'s at t = {separation.t_s:.1f} s '
                    f'(margin {self.config.clearance_margin_m:g} m)'))
        if not plan.ok and why.startswith(REAIM):
            return [self._event(t, 'WARN', 'reaim_refused', f'{why}: {plan.reason}; the plan flown stays',
                                {'request': why, 'plan': str(self.plans), 'planning_time_s': planning_time_s})]
        if not plan.ok:
            refused = plan.reason if flyby_refused is None else f'fly-by: {flyby_refused}; {plan.reason}'
            return out + self._refuse(t, why, refused, PlanMarkers(settings.plume_radius_m, ()), planning_time_s)
        at_grasp = prediction.state(plan.t_grasp_s)
        grasp = GraspState(plan.t_grasp_s, plan.x_g, plan.v_g, at_grasp.q_hill_from_body, at_grasp.omega_body)
        traj, terms = plan.trajectory, plan.terms
        self.flown = TrajectoryPublished(t, grasp, plan.t_grasp_s, plan.x_ft, plan.v_ft, plan.t_start_s, traj,
                                         PlanMarkers(settings.plume_radius_m, (), plan.x_g, (plan.x_ft,), traj.r_hill))
        self.aim_checked_t = t
        return out + [
            self._method_chosen(t, 'optimal', reason),
            self.flown,
            self._event(t, 'OK', 'plan_selected', plan.reason + ('' if separation is None else
                                                                 f', least separation {separation.distance_m:.3f} m '
                                                                 f'from {separation.name}'),
                        {'request': why, 'plan': str(self.plans), 'method': 'optimal', 't_grasp_s': plan.t_grasp_s,
                         't_start_s': plan.t_start_s, 'offset_m': settings.offset_m,
                         'approach_time_s': plan.t_grasp_s - plan.t_start_s, 'dv_total_mps': terms.delta_v_mps,
                         'peak_accel_mps2': terms.peak_accel_mps2, 'eq5_cost': terms.total,
                         'clearance_m': plan.clearance_m, 'x_g_hill_m': plan.x_g, 'v_g_hill_mps': plan.v_g,
                         'x_ft_hill_m': plan.x_ft, 'v_ft_hill_mps': plan.v_ft, 'solver_time_s': plan.solver_time_s,
                         'planning_time_s': planning_time_s, **mutual_values})]

    def _plan_sync(self, t, q_hill_from_body, omega_body, why, reason):
        """Stage 1 of the synchronized approach (flyby_planner.sync.approach) at the plan time t; a re-solve starts
        from the estimate moved as the flown trajectory over its lead (planner.sync.resolve_lead_s; the first plan's
        is maneuver_lead_s), as an optimal re-plan."""
        lead_s = (self.scenario.planner.sync.resolve_lead_s if self.flown is not None
                  else self.scenario.planner.maneuver_lead_s)
        chaser_now = self._chaser_at(t)
        window = arrival_window(self.scenario, t + lead_s, self.sync_arrival)
        prediction = prediction_from_estimate(self.dynamics, self.config.mean_motion_rad_s, t, q_hill_from_body,
                                              omega_body, max(t, window[1]) + 1.0 + HOLD_CHECK_S)
        start = cw_coast(chaser_now[:3], chaser_now[3:], lead_s, self.config.mean_motion_rad_s)
        if self.flown is not None:
            traj = self.flown.trajectory
            ref = np.array([[np.interp(s, traj.t_s, x[:, k]) for x in (traj.r_hill, traj.v_hill) for k in range(3)]
                            for s in (t, t + lead_s)])
            start = chaser_now + ref[1] - ref[0]
        started = time.perf_counter()  # measured for the record only; nothing here acts on it
        plan = plan_sync(self.scenario, prediction, t + lead_s, start[:3], start[3:], self.sync_arrival)
        planning_time_s = time.perf_counter() - started
        if not plan.ok:
            if self.flown is not None:  # a failed re-solve keeps the plan flown
                return [self._event(t, 'WARN', 'plan_kept', plan.reason, {'request': why})]
            return self._refuse(t, why, plan.reason, PlanMarkers(self.config.restriction_sphere_radius_m, ()),
                                planning_time_s)
        arrival, traj = plan.arrival, plan.trajectory
        at = prediction.state(arrival.t_arrival)
        x_port = np.array(self.scenario.target.grasp_point_body_m)
        port = prediction.track(x_port, (arrival.t_arrival,))
        grasp = GraspState(arrival.t_arrival, port.r_hill[0], port.v_hill[0], at.q_hill_from_body, at.omega_body)
        self.sync_arrival = arrival
        self.flown = TrajectoryPublished(t, grasp, arrival.t_arrival, arrival.r_hill, arrival.v_hill, t + lead_s,
                                         traj, PlanMarkers(self.config.restriction_sphere_radius_m, (), grasp.x_g,
                                                           (arrival.r_hill,), traj.r_hill))
        out = [] if self.method_flown == 'sync' else [self._method_chosen(t, 'sync', reason)]
        return out + [
            self.flown,
            self._event(t, 'OK', 'plan_selected', plan.reason,
                        {'request': why, 'plan': str(self.plans), 'method': 'sync', 't_arrival_s': arrival.t_arrival,
                         't_start_s': t + lead_s, 'offset_m': self.scenario.planner.offset_m,
                         'approach_time_s': arrival.t_arrival - t - lead_s, 'dv_total_mps': arrival.delta_v_mps,
                         'peak_accel_mps2': plan.peak_accel_mps2, 'closest_m': arrival.closest_m,
                         'x_station_hill_m': arrival.r_hill, 'v_station_hill_mps': arrival.v_hill,
                         'planning_time_s': planning_time_s})]

    def _plan_flyby(self, t, q_hill_from_body, omega_body, why, covariance_body=None):
        """The fly-by (flyby_planner.plan) at the plan time t: (outputs, None) for a selected plan, (the candidates'
        events, (the refusal's reason, its markers, the planning time [s])) otherwise."""
        cfg = self.config
        chaser_now, prediction = self.plan_inputs(t, q_hill_from_body, omega_body)
        started = time.perf_counter()  # measured for the record only; nothing here acts on it
        plan = plan_capture(prediction, chaser_now[:3], chaser_now[3:], t, cfg, covariance_body)
        planning_time_s = time.perf_counter() - started
        out = []
        for cand in plan.candidates:
            d = cand.to_dict()
            out.append(self._event(t, 'OK' if cand.status != 'rejected' else 'WARN', 'plan_candidate',
                                   f'{cand.status}: ' + ('; '.join(cand.reasons) if cand.reasons else
                                                         'passes every check'),
                                   {k: d[k] for k in _CANDIDATE_KEYS}))
        if not plan.ok:
            return out, (plan.reason, plan_markers(plan, cfg), planning_time_s)
        chosen = plan.selected
        at_grasp = plan.prediction.state(chosen.t_grasp)  # the plan's motion: it reaches an extended window's grasp
        grasp = GraspState(chosen.t_grasp, chosen.x_g, chosen.v_g, at_grasp.q_hill_from_body, at_grasp.omega_body)
        out.append(PlanPublished(t, grasp, chosen.t_grasp, chosen.x_ft, chosen.v_ft, chosen.t_i, chosen.x_fi,
                                 chosen.v_fi, plan.path_t, plan.path_r_hill, plan_markers(plan, cfg)))
        d = chosen.to_dict()
        out.insert(len(out) - 1, self._method_chosen(t, 'flyby', 'a safe fly-by exists' if self.scenario.planner.method
                                                      == 'auto' else 'planner.method flyby'))
        out.append(self._event(t, 'OK', 'plan_selected',
                               f'grasp at t = {chosen.t_grasp:.2f} s, offset {chosen.offset_m:g} m, fly-by '
                               f'{chosen.flyby_duration_s:g} s, transfer delta-v {chosen.dv_total_mps:.4f} m/s, '
                               f'least clearance {chosen.clearance_min_m:.3f} m ({chosen.closest})'
                               + ('' if chosen.miss_3sigma_m is None else
                                  f', predicted 3-sigma miss {chosen.miss_3sigma_m:.3f} m after a '
                                  f'{chosen.unguided_coast_s:.0f} s coast'),
                               {'request': why, 'plan': str(self.plans), **{k: d[k] for k in _SELECTED_KEYS},
                                # exact, not the rounded table values: the supervisor times the phases and
                                # places the fly-by target point by them
                                't_grasp_s': chosen.t_grasp, 't_i_s': chosen.t_i, 'offset_m': chosen.offset_m,
                                'flyby_duration_s': chosen.flyby_duration_s, 'planning_time_s': planning_time_s}))
        return out, None

    def _event(self, t, level, name, message, values):
        return Event(t, level, name, message, values, self.name)
