"""The capture methods as PlannerCore flies them, each behind one small protocol (``CaptureMethod``), and the choice
among them (``choose``, planner.method of DESIGN §10, ``auto`` included) in one place.

A method plans at a plan time from the estimates and returns its outputs and, when it finds no safe plan, a
``Refusal`` with its reason; while its plan is flown it follows it up (``follow_up``: the optimization-based
approach's re-aim, the synchronized approach's re-solve of stage 1) and takes the events that concern it
(``on_event``: guidance's replan request, the docking's start).

* ``FlybyMethod``: the fly-by (flyby_planner.flyby, seed 000 §4.3-4.5, 4.7).
* ``OptimalMethod``: the optimization-based approach (flyby_planner.optimal.approach, seed 003 section 4).
* ``SyncMethod``: the synchronized approach (flyby_planner.sync.approach, seed 001 section 2).
"""

import dataclasses
import time
from typing import NamedTuple, Protocol

import numpy as np

from flyby_estimation.target_motion import prediction_from_estimate
from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.wire import STAMP_TOLERANCE_S
from flyby_planner.flyby.grasp_search import capture_target_body
from flyby_planner.flyby.search import plan_capture
from flyby_planner.optimal.approach import plan_approach, prepare_approach
from flyby_planner.optimal.mutual import least_separation
from flyby_planner.optimal.problem import GraspTerminal
from flyby_planner.plan_outputs import (
    AimUpdate,
    GraspState,
    PlanMarkers,
    PlanPublished,
    TrajectoryPublished,
    plan_markers,
)
from flyby_planner.sync.approach import HOLD_CHECK_S, arrival_window, is_category_iv, plan_sync, resolve_due
from flyby_sim.dynamics.orbital import cw_coast

# The request of a re-aim (``OptimalMethod.follow_up``): its refusal keeps the plan flown.
REAIM = 're-aim'
# Values of the selected candidate put on its plan_selected event.
_SELECTED_KEYS = ('t_grasp_s', 't_i_s', 't_ti_s', 'dv_total_mps', 'clearance_approach_m', 'clearance_escape_m',
                  'closest', 't_sphere_entry_s', 'x_g_hill_m', 'v_g_hill_mps', 'x_ft_hill_m', 'v_ft_hill_mps',
                  'x_fi_hill_m', 'v_fi_hill_mps', 'unguided_coast_s', 'miss_3sigma_m', 'miss_3sigma_mps',
                  'extended_window')
_CANDIDATE_KEYS = ('t_grasp_s', 'status', 'offset_m', 'flyby_duration_s', 'dv_total_mps', 'clearance_approach_m',
                   'clearance_escape_m', 'closest', 't_i_s', 'convex_value_m2_s2', 'miss_3sigma_m')


class Refusal(NamedTuple):
    """A method's refusal: why, the markers of what refused it, the planning time [s]."""

    reason: str
    markers: PlanMarkers
    planning_time_s: float


class CaptureMethod(Protocol):
    """What PlannerCore asks of a capture method (``core``: the PlannerCore, its estimates, leaders and events)."""

    name: str

    def plan(self, core, t, q_hill_from_body, omega_body, why, covariance_body, reason):
        """Plan at the target estimate of time t, chosen for ``reason``: (outputs, None) for a plan selected (or the
        plan flown kept), (outputs, Refusal) when it finds no safe plan."""

    def follow_up(self, core, t):
        """At the target estimate of time t while its plan is flown: set core.request to re-aim or re-solve."""

    def on_event(self, core, event):
        """The outputs of a mission event that concerns the plan flown, or None."""

    def forget(self):
        """Drop the plan flown (the supervisor's HOLD or RETREAT gave it up): the next plan is a first one."""


def may_plan_optimal(params):
    """Whether PlannerParams' planner.method may fly the optimization-based approach (its program is compiled at
    the planner's start): ``optimal``, or ``auto`` with a rigid-body chaser."""
    return params.method == 'optimal' or (params.method == 'auto' and params.chaser_model == 'rigid_body')


def choose(core, omega_body):
    """(the method of a plan, why, the method tried when it finds no safe plan or None), for a target estimate of
    body rate omega_body [rad/s]: the method flown (a re-plan keeps it), else planner.method. ``auto``: the
    synchronized approach for a category IV target, else the fly-by and, when it finds no safe plan, the
    optimization-based approach; both only with a rigid-body chaser."""
    method = core.method_flown or core.params.method
    if method == 'optimal':
        return 'optimal', 'a re-plan of the approach flown' if core.method_flown else 'planner.method optimal', None
    spin_rate_deg_s = core.params.sync.spin_rate_deg_s
    if method == 'sync' or (method == 'auto' and core.rigid and is_category_iv(omega_body, spin_rate_deg_s)):
        reason = ('a re-solve of the approach flown' if core.method_flown else 'planner.method sync'
                  if method == 'sync' else 'auto: category IV (condition (a): the rate is at or above '
                                           f'{spin_rate_deg_s:g} deg/s)')
        return 'sync', reason, None
    reason = 'a safe fly-by exists' if core.params.method == 'auto' else 'planner.method flyby'
    return 'flyby', reason, 'optimal' if method == 'auto' and core.rigid else None


class FlybyMethod:
    """The fly-by: plan_capture from the estimates; nothing to follow up (guidance re-aims it)."""

    name = 'flyby'

    def forget(self):
        """Nothing kept: guidance re-aims the fly-by."""

    def plan(self, core, t, q_hill_from_body, omega_body, why, covariance_body, reason):
        """The fly-by at the plan time t: the candidates' events, and the selected plan or the Refusal."""
        cfg = core.params.flyby
        chaser_now, prediction = core.plan_inputs(t, q_hill_from_body, omega_body)
        started = time.perf_counter()  # measured for the record only; nothing here acts on it
        plan = plan_capture(prediction, chaser_now[:3], chaser_now[3:], t, cfg, covariance_body)
        planning_time_s = time.perf_counter() - started
        out = []
        for cand in plan.candidates:
            d = cand.to_dict()
            out.append(core.event(t, 'OK' if cand.status != 'rejected' else 'WARN', events.PLAN_CANDIDATE,
                                  f'{cand.status}: ' + ('; '.join(cand.reasons) if cand.reasons else
                                                        'passes every check'),
                                  {k: d[k] for k in _CANDIDATE_KEYS}))
        if not plan.ok:
            return out, Refusal(plan.reason, plan_markers(plan, cfg), planning_time_s)
        chosen = plan.selected
        at_grasp = plan.prediction.state(chosen.t_grasp)  # the plan's motion: it reaches an extended window's grasp
        grasp = GraspState(chosen.t_grasp, chosen.x_g, chosen.v_g, at_grasp.q_hill_from_body, at_grasp.omega_body)
        out.append(PlanPublished(t, grasp, chosen.t_grasp, chosen.x_ft, chosen.v_ft, chosen.t_i, chosen.x_fi,
                                 chosen.v_fi, plan.path_t, plan.path_r_hill, plan_markers(plan, cfg)))
        d = chosen.to_dict()
        out.insert(len(out) - 1, core.method_chosen(t, 'flyby', reason))
        out.append(core.event(t, 'OK', events.PLAN_SELECTED,
                              f'grasp at t = {chosen.t_grasp:.2f} s, offset {chosen.offset_m:g} m, fly-by '
                              f'{chosen.flyby_duration_s:g} s, transfer delta-v {chosen.dv_total_mps:.4f} m/s, '
                              f'least clearance {chosen.clearance_min_m:.3f} m ({chosen.closest})'
                              + ('' if chosen.miss_3sigma_m is None else
                                 f', predicted 3-sigma miss {chosen.miss_3sigma_m:.3f} m after a '
                                 f'{chosen.unguided_coast_s:.0f} s coast'),
                              # exact times, not the rounded table values: the supervisor times the phases and
                              # places the fly-by target point by them
                              event_payloads.encode(
                                  event_payloads.PlanSelected(why, str(core.plans), t_grasp_s=chosen.t_grasp,
                                                              t_i_s=chosen.t_i, offset_m=chosen.offset_m),
                                  {**{k: d[k] for k in _SELECTED_KEYS if k not in ('t_grasp_s', 't_i_s')},
                                   'flyby_duration_s': chosen.flyby_duration_s, 'planning_time_s': planning_time_s})))
        return out, None

    def follow_up(self, core, t):
        """Nothing: guidance re-aims a fly-by (its target_refined events)."""

    def on_event(self, core, event):
        return None


class OptimalMethod:
    """The optimization-based approach: plan_approach from the estimates, re-planned on guidance's request and
    re-aimed when the end point X_Ft predicted from a newer estimate has moved (PlannerCore's module doc)."""

    name = 'optimal'

    def __init__(self, params, obstacles):
        self.settings = params.optimal
        if may_plan_optimal(params):
            prepare_approach(self.settings, obstacles=obstacles)  # compiled now, not at the plan
        self.flown = None  # the TrajectoryPublished being flown
        self.aim_checked_t = None  # the time of the last re-aim check (the plan's first) [s]

    def forget(self):
        self.flown = self.aim_checked_t = None

    def plan(self, core, t, q_hill_from_body, omega_body, why, covariance_body, reason):
        """The approach at the plan time t (a re-plan: to the same grasp, from the estimate moved as the flown
        trajectory); a re-aim that finds no safe plan keeps the plan flown (a WARN reaim_refused)."""
        settings = self.settings
        chaser_now = core.chaser_at(t)
        prediction = prediction_from_estimate(core.dynamics, core.params.flyby.mean_motion_rad_s, t, q_hill_from_body,
                                              omega_body, t + settings.horizon_s)
        start_state = None
        if self.flown is not None:  # a re-plan: to the same grasp, from the estimate moved as the flown trajectory
            settings = dataclasses.replace(settings, approach_time_s=self.flown.t_f - t - settings.start_lead_s)
            traj = self.flown.trajectory
            ref = np.array([[np.interp(s, traj.t_s, x[:, k]) for x in (traj.r_hill, traj.v_hill) for k in range(3)]
                            for s in (t, t + settings.start_lead_s)])
            start_state = chaser_now + ref[1] - ref[0]
        obstacles = core.leader_obstacles(t, prediction)
        started = time.perf_counter()  # measured for the record only; nothing here acts on it
        plan = plan_approach(prediction, chaser_now[:3], chaser_now[3:], t, settings, core.params.flyby,
                             start_state=start_state, obstacles=obstacles)
        planning_time_s = time.perf_counter() - started
        separation, mutual_values = None, {}
        if plan.ok and obstacles:  # the dense separation from the leaders' plans, before it is flown
            separation = least_separation(plan.plan, obstacles, core.params.flyby.envelope_radius_m)
            mutual_values = {'separation_m': separation.distance_m, 't_separation_s': separation.t_s,
                             'separation_from': separation.name}
            if separation.distance_m < core.params.flyby.clearance_margin_m:
                plan = dataclasses.replace(plan, ok=False, reason=(
                    f'optimal approach refused: the envelope comes {separation.distance_m:.3f} m from '
                    f'{separation.name}\'s at t = {separation.t_s:.1f} s '
                    f'(margin {core.params.flyby.clearance_margin_m:g} m)'))
        if not plan.ok and why.startswith(REAIM):
            return [core.event(t, 'WARN', events.REAIM_REFUSED, f'{why}: {plan.reason}; the plan flown stays',
                               {'request': why, 'plan': str(core.plans), 'planning_time_s': planning_time_s})], None
        if not plan.ok:
            return [], Refusal(plan.reason, PlanMarkers(settings.plume_radius_m, ()), planning_time_s)
        at_grasp = prediction.state(plan.t_grasp_s)
        grasp = GraspState(plan.t_grasp_s, plan.x_g, plan.v_g, at_grasp.q_hill_from_body, at_grasp.omega_body)
        traj, terms = plan.trajectory, plan.terms
        self.flown = TrajectoryPublished(t, grasp, plan.t_grasp_s, plan.x_ft, plan.v_ft, plan.t_start_s, traj,
                                         PlanMarkers(settings.plume_radius_m, (), plan.x_g, (plan.x_ft,), traj.r_hill))
        self.aim_checked_t = t
        message = plan.reason + ('' if separation is None else
                                 f', least separation {separation.distance_m:.3f} m from {separation.name}')
        return [
            core.method_chosen(t, 'optimal', reason),
            self.flown,
            core.event(t, 'OK', events.PLAN_SELECTED, message,
                       event_payloads.encode(event_payloads.PlanSelected(
                           why, str(core.plans), 'optimal', t_grasp_s=plan.t_grasp_s, t_start_s=plan.t_start_s,
                           offset_m=settings.offset_m), {
                        'approach_time_s': plan.t_grasp_s - plan.t_start_s, 'dv_total_mps': terms.delta_v_mps,
                        'peak_accel_mps2': terms.peak_accel_mps2, 'eq5_cost': terms.total,
                        'clearance_m': plan.clearance_m, 'x_g_hill_m': plan.x_g, 'v_g_hill_mps': plan.v_g,
                        'x_ft_hill_m': plan.x_ft, 'v_ft_hill_mps': plan.v_ft, 'solver_time_s': plan.solver_time_s,
                        'planning_time_s': planning_time_s, **mutual_values}))], None

    def follow_up(self, core, t):
        """Request a re-aim when X_Ft predicted from the target estimate has moved from the plan's. The checks fall
        every reaim_interval_s from the plan time, each on the first target estimate stamped at or after its time:
        the same estimates whenever they arrive."""
        o, flown = self.settings, self.flown
        while core.request is None:
            t_check = self.aim_checked_t + o.reaim_interval_s
            target = core.targets.first_at_or_after(t_check)
            if target is None or target[0] >= flown.t_f - o.replan_cutoff_s:
                return
            self.aim_checked_t = t_check
            t = target[0]
            _, (x_ft, _) = self._end_point(core, target, flown.t_f, self.settings.offset_m)
            moved_m = float(np.linalg.norm(x_ft - flown.x_ft))
            if moved_m > o.reaim_error_m:
                core.request = (t, f'{REAIM}: X_Ft predicted from the target estimate of t = {t:.2f} s is '
                                   f'{moved_m:.3f} m from the plan\'s (reaim_error_m {o.reaim_error_m:g})')

    @staticmethod
    def _end_point(core, target, t_f, offset_m):
        """(the motion predicted from a buffered target estimate (t, (q, omega, blocks)) to t_f, the end point X_Ft,
        V_Ft of the grasp point at offset_m at t_f, eq 20-21)."""
        t, (q_hill_from_body, omega_body, _) = target
        prediction = prediction_from_estimate(core.dynamics, core.params.flyby.mean_motion_rad_s, t, q_hill_from_body,
                                              omega_body, t_f)
        return prediction, GraspTerminal(prediction, core.params.flyby.x_grasp_body_m, offset_m)(t_f)

    def on_event(self, core, event):
        """Guidance's replan_requested (the tracking error grew beyond its bound): plan again."""
        if event.name == events.REPLAN_REQUESTED:
            core.request = (event.t, f'replan: {event.message}')
            return core.try_plan()
        return None


class SyncMethod:
    """The synchronized approach: stage 1 planned from the estimates and re-solved as the arrival nears; the docking
    aimed at the port (PlannerCore's module doc)."""

    name = 'sync'

    def __init__(self):
        self.flown = None  # the TrajectoryPublished being flown
        self.arrival = None  # the ArrivalChoice being flown

    def forget(self):
        self.flown = self.arrival = None

    def plan(self, core, t, q_hill_from_body, omega_body, why, covariance_body, reason):
        """Stage 1 at the plan time t; a re-solve starts from the estimate moved as the flown trajectory over its
        lead (planner.sync.resolve_lead_s; the first plan's is maneuver_lead_s), as an optimal re-plan, and when it
        fails keeps the plan flown (a WARN plan_kept)."""
        sync = core.params.sync
        lead_s = sync.resolve_lead_s if self.flown is not None else sync.maneuver_lead_s
        chaser_now = core.chaser_at(t)
        window = arrival_window(sync, t + lead_s, self.arrival)
        prediction = prediction_from_estimate(core.dynamics, core.params.flyby.mean_motion_rad_s, t, q_hill_from_body,
                                              omega_body, max(t, window[1]) + 1.0 + HOLD_CHECK_S)
        start = cw_coast(chaser_now[:3], chaser_now[3:], lead_s, core.params.flyby.mean_motion_rad_s)
        if self.flown is not None:
            traj = self.flown.trajectory
            ref = np.array([[np.interp(s, traj.t_s, x[:, k]) for x in (traj.r_hill, traj.v_hill) for k in range(3)]
                            for s in (t, t + lead_s)])
            start = chaser_now + ref[1] - ref[0]
        started = time.perf_counter()  # measured for the record only; nothing here acts on it
        plan = plan_sync(sync, prediction, t + lead_s, start[:3], start[3:], self.arrival)
        planning_time_s = time.perf_counter() - started
        if not plan.ok:
            if self.flown is not None:  # a failed re-solve keeps the plan flown
                return [core.event(t, 'WARN', events.PLAN_KEPT, plan.reason, {'request': why})], None
            return [], Refusal(plan.reason, PlanMarkers(core.params.flyby.restriction_sphere_radius_m, ()),
                               planning_time_s)
        arrival, traj = plan.arrival, plan.trajectory
        at = prediction.state(arrival.t_arrival)
        x_port = np.array(sync.x_port_body_m)
        port = prediction.track(x_port, (arrival.t_arrival,))
        grasp = GraspState(arrival.t_arrival, port.r_hill[0], port.v_hill[0], at.q_hill_from_body, at.omega_body)
        self.arrival = arrival
        self.flown = TrajectoryPublished(t, grasp, arrival.t_arrival, arrival.r_hill, arrival.v_hill, t + lead_s,
                                         traj, PlanMarkers(core.params.flyby.restriction_sphere_radius_m, (), grasp.x_g,
                                                           (arrival.r_hill,), traj.r_hill))
        out = [] if core.method_flown == 'sync' else [core.method_chosen(t, 'sync', reason)]
        return out + [
            self.flown,
            core.event(t, 'OK', events.PLAN_SELECTED, plan.reason,
                       event_payloads.encode(event_payloads.PlanSelected(
                           why, str(core.plans), 'sync', t_arrival_s=arrival.t_arrival, t_start_s=t + lead_s,
                           offset_m=sync.offset_m), {
                        'approach_time_s': arrival.t_arrival - t - lead_s, 'dv_total_mps': arrival.delta_v_mps,
                        'peak_accel_mps2': plan.peak_accel_mps2, 'closest_m': arrival.closest_m,
                        'x_station_hill_m': arrival.r_hill, 'v_station_hill_mps': arrival.v_hill,
                        'planning_time_s': planning_time_s}))], None

    def follow_up(self, core, t):
        """Request a re-solve of stage 1 when the target estimate of t is due (seed 001 section 2)."""
        if core.request is None and resolve_due(t, self.flown.t_plan, self.arrival.t_arrival,
                                                core.params.sync):
            core.request = (t, 're-solve of the synchronized approach')  # seed 001 section 2

    def on_event(self, core, event):
        """Guidance's docking_started: the port and the final point at its grasp time."""
        docking = event_payloads.decode(event) if event.name == events.DOCKING_STARTED else None
        if docking is not None and docking.t_grasp_s is not None:
            return self._docking_aim(core, event.t, docking.t_grasp_s)
        return None

    @staticmethod
    def _docking_aim(core, t, t_grasp):
        """The docking (guidance's ``docking_started`` at t): the port and the final point at the grasp time
        t_grasp, predicted from the target estimate stamped last before t, as AimUpdate (the simulator holds the
        capture decision at that stamp)."""
        target = core.targets.last_at_or_before(t - STAMP_TOLERANCE_S)
        if target is None:
            return []
        t_t, (q_hill_from_body, omega_body, _) = target
        prediction = prediction_from_estimate(core.dynamics, core.params.flyby.mean_motion_rad_s, t_t, q_hill_from_body,
                                              omega_body, t_grasp)
        sync = core.params.sync
        x_final_body = capture_target_body('sync', core.params.flyby.x_grasp_body_m, sync.offset_m, sync.boxes_body)
        port = prediction.track(core.params.flyby.x_grasp_body_m, (t_grasp,))
        final = prediction.track(x_final_body, (t_grasp,))
        at = prediction.state(t_grasp)
        return [AimUpdate(GraspState(t_grasp, port.r_hill[0], port.v_hill[0], at.q_hill_from_body, at.omega_body),
                          final.r_hill[0], final.v_hill[0])]
