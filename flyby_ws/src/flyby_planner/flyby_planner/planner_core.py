"""What the planner node does, without ROS: when to plan, from which estimates, and what it publishes.

The planner plans when the supervisor turns the mission to PLANNING (its stamped ``phase_changed``
event) or on a replan request, at the first target estimate stamped at or after the request, once
the chaser estimates up to that stamp are in: the plan time is that estimate's stamp, the same at
any pace of the run. The target motion is predicted from that estimate (attitude, body rate, the
scenario's inertia), the chaser state is the last chaser estimate up to the plan time carried to it
along CW (seed 000 eq 22). The planning itself is ``flyby_planner.plan`` (seed 000 §4.3-4.5, 4.7).

When guidance re-aims at a re-solved grasp (its ``target_refined`` event), the grasp and the fly-by
target point the mission now aims at are published again (``AimUpdate``), so the bag holds what was
flown, not only the first plan.

The planner node and the headless driver (flyby_guidance.closed_loop) both run ``PlannerCore``;
every input method returns the outputs to publish, in order.
"""

import dataclasses
import json
import time

import numpy as np

from flyby_estimation.target_motion import ErrorStateDynamics, prediction_from_estimate
from flyby_msgs_py import contract as c
from flyby_msgs_py.stamped import StampedBuffer
from flyby_msgs_py.wire import Event
from flyby_planner.plan import plan_capture, planner_config_from_scenario
from flyby_sim.dynamics.orbital import cw_coast

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
        self.targets = StampedBuffer()  # (q_hill_from_body, omega_body) by stamp
        self.chasers = StampedBuffer()  # (r_hill, v_hill) by stamp
        self.plans = 0

    # -- inputs ---------------------------------------------------------------------------------
    def on_event(self, event):
        """The supervisor's stamped transition to PLANNING plans at that time; guidance's re-aim is published."""
        if event.name == 'phase_changed' and event.values.get('to') == c.PHASE_PLANNING:
            self.request = (event.t, 'phase PLANNING')
            return self._try_plan()
        if event.name == 'target_refined' and 'x_g_hill_m' in event.values:
            v = event.values
            grasp = GraspState(float(v['t_grasp_s']), _vector_value(v, 'x_g_hill_m'), _vector_value(v, 'v_g_hill_mps'),
                               _vector_value(v, 'q_hill_from_body'), _vector_value(v, 'omega_body_rad_s'))
            return [AimUpdate(grasp, _vector_value(v, 'x_ft_hill_m'), _vector_value(v, 'v_ft_hill_mps'))]
        return []

    def on_replan(self):
        """Plan again at the next target estimate."""
        self.request = (self.targets.latest_t, 'replan requested')
        return []

    def on_chaser_estimate(self, t, r_hill, v_hill):
        self.chasers.add(t, (np.asarray(r_hill, dtype=float), np.asarray(v_hill, dtype=float)))
        return self._try_plan()

    def on_target_estimate(self, t, q_hill_from_body, omega_body):
        self.targets.add(t, (np.asarray(q_hill_from_body, dtype=float), np.asarray(omega_body, dtype=float)))
        return self._try_plan()

    # -- planning -------------------------------------------------------------------------------
    def _try_plan(self):
        """Plan at the first target estimate stamped at or after the request, once the chaser estimates
        up to that stamp are in (the same estimates at any pace of the run)."""
        if self.request is None:
            return []
        t_request, why = self.request
        target = self.targets.first_at_or_after(t_request)
        if target is None or self.chasers.latest_t < target[0]:
            return []
        self.request = None
        return self._plan(target[0], *target[1], why)

    def _plan(self, t, q_hill_from_body, omega_body, why):
        """Plan at the target estimate of time t (the plan time); the outputs to publish."""
        cfg = self.config
        n = cfg.mean_motion_rad_s
        t_c, (r_c, v_c) = self.chasers.last_at_or_before(t) or self.chasers.first_at_or_after(t)
        chaser_now = cw_coast(r_c, v_c, t - t_c, n)  # eq 22
        prediction = prediction_from_estimate(self.dynamics, n, t, q_hill_from_body, omega_body,
                                              t + cfg.prediction_span_s(omega_body))
        started = time.perf_counter()  # measured for the record only; nothing here acts on it
        plan = plan_capture(prediction, chaser_now[:3], chaser_now[3:], t, cfg)
        planning_time_s = time.perf_counter() - started
        self.plans += 1
        out = []
        for cand in plan.candidates:
            d = cand.to_dict()
            out.append(self._event(t, 'OK' if cand.status != 'rejected' else 'WARN', 'plan_candidate',
                                   f'{cand.status}: ' + ('; '.join(cand.reasons) if cand.reasons else
                                                         'passes every check'),
                                   {k: d[k] for k in _CANDIDATE_KEYS}))
        if not plan.ok:
            out.append(self._event(t, 'ERROR', 'plan_refused', plan.reason, {'request': why, 'plan': str(self.plans),
                                                                              'planning_time_s': planning_time_s}))
            out.append(PlanRefused(t, plan_markers(plan, cfg)))
            return out
        chosen = plan.selected
        at_grasp = plan.prediction.state(chosen.t_grasp)  # the plan's motion: it reaches an extended window's grasp
        grasp = GraspState(chosen.t_grasp, chosen.x_g, chosen.v_g, at_grasp.q_hill_from_body, at_grasp.omega_body)
        out.append(PlanPublished(t, grasp, chosen.t_grasp, chosen.x_ft, chosen.v_ft, chosen.t_i, chosen.x_fi,
                                 chosen.v_fi, plan.path_t, plan.path_r_hill, plan_markers(plan, cfg)))
        d = chosen.to_dict()
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
        return out

    def _event(self, t, level, name, message, values):
        return Event(t, level, name, message, values, self.name)
