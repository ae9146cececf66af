"""A whole fly-by approach in one process, no ROS: plant, filters, planner and guidance in a loop.

The same cores the nodes run (flyby_sim.plant, flyby_estimation, flyby_planner.plan,
flyby_guidance.guidance), wired the way the node graph wires them: the planner and guidance see only
the estimates, the plant executes the commanded maneuvers with its thruster errors, and every
figure of the result is measured from the plant's truth. For Monte Carlo studies and for the
acceptance figures of the guidance (scripts/closed_loop.py).

Timeline: estimation until the target estimate has converged and ``planner.min_observation_s`` of
attitude data are in; plan (seed 000 section 4.4); guidance (terminal transfer, injection,
trajectory adjusting with the grasp re-solved from the latest estimate before each adjusting burn);
coast past the grasp and on for ``escape_s`` of fly-by escape.
"""

import copy
import dataclasses
import math

import numpy as np

from flyby_estimation.filters import filters_from_scenario
from flyby_estimation.target_filter import MeasurementRejected
from flyby_guidance.guidance import FlybyGuidance, FlybyTarget, guidance_config_from_scenario, refined_flyby_target
from flyby_msgs_py.scenario import scenario_from_dict
from flyby_planner.grasp import flyby_target_from_attitude
from flyby_planner.plan import plan_capture, planner_config_from_scenario, truth_prediction
from flyby_planner.transfer import terminal_impulses
from flyby_sim.dynamics.geometry import clearance
from flyby_sim.dynamics.orbital import cw_transition_matrix
from flyby_sim.plant import Plant, plant_config_from_scenario

# Truth samples kept for the clearance, every this many plant steps away from the passage.
_CLEARANCE_STRIDE = 20


@dataclasses.dataclass
class ClosedLoopResult:
    """Truth-measured figures of one closed-loop fly-by (SI units; None where the run never got there)."""

    seed: int
    t_plan: float = None
    plan_ok: bool = False
    plan_reason: str = ''
    t_grasp: float = None
    miss_position_m: float = None
    miss_velocity_mps: float = None
    dv_commanded_mps: float = 0.0
    dv_ideal_mps: float = None
    fuel_used_kg: float = None
    min_clearance_m: float = None
    thrust_inside_sphere: bool = False
    burns: list = dataclasses.field(default_factory=list)
    events: list = dataclasses.field(default_factory=list)  # GuidanceEvent
    plant_events: list = dataclasses.field(default_factory=list)  # flyby_sim.plant.Event, WARN and ERROR

    def to_dict(self):
        return {k: v for k, v in dataclasses.asdict(self).items() if k not in ('events', 'plant_events')}


def scaled_navigation_noise(scenario, factor):
    """The scenario with its relative-position sensor noise multiplied by factor (filter and plant alike)."""
    d = copy.deepcopy(scenario.to_dict())
    d['sensors']['relative_position']['noise_sigma_m'] *= factor
    return scenario_from_dict(d, name=f'{scenario.name} (navigation noise x{factor:g})')


def run_closed_loop(scenario, escape_s=300.0):
    """Fly scenario (with its seed) through estimation, planning, guidance and the fly-by; ClosedLoopResult."""
    plant = Plant(plant_config_from_scenario(scenario))
    target_filter, nav, convergence, _ = filters_from_scenario(scenario)
    planner_cfg = planner_config_from_scenario(scenario)
    guidance = FlybyGuidance(guidance_config_from_scenario(scenario))
    n = scenario.mean_motion_rad_s
    x_grasp_body = np.array(scenario.target.grasp_point_body_m)
    offset = scenario.planner.offset_m
    refine = scenario.guidance.refine_target
    boxes = list(zip(scenario.boxes.center_body_m, scenario.boxes.size_m))
    envelope = scenario.chaser.envelope_radius_m
    result = ClosedLoopResult(seed=scenario.seed)
    t_first_attitude = None
    t_end = scenario.simulation.duration_s
    t_stop = math.inf
    plan = None
    before = after = None  # truth samples around the grasp time
    gaps = []
    steps = 0
    # The true attitude at any t (the plant's torque-free motion; its own samples are 0.05 s apart).
    true_motion = truth_prediction(scenario, t_end)

    while plant.t < min(t_end, t_stop) - 1e-9:
        truth = plant.step()
        steps += 1
        for m in plant.measurements():
            if m.kind == 'target_attitude':
                t_first_attitude = m.t if t_first_attitude is None else t_first_attitude
                try:
                    target_filter.update(m.t, m.value)
                except MeasurementRejected:
                    pass
            else:
                nav.update(m.t, m.value)
                if plan is None and t_first_attitude is not None \
                        and m.t - t_first_attitude >= scenario.planner.min_observation_s \
                        and target_filter.convergence(convergence):
                    plan = _plan(target_filter, nav, planner_cfg, result)
                    if not plan.ok:
                        return result
                    c = plan.selected
                    guidance.set_target(FlybyTarget(c.t_ti, c.t_i, c.x_fi, c.v_fi, c.t_grasp, c.x_ft, c.v_ft))
                    result.dv_ideal_mps = _ideal_delta_v(plant, c, n)
                if plan is not None and guidance.next_burn_time is not None:
                    _guide(guidance, nav, target_filter, plant, result, refine, x_grasp_body, offset, n)
        result.plant_events += [e for e in plant.drain_events() if e.level != 'OK']
        if plan is not None:
            t_g = guidance.target.t_f
            if truth.t < t_g:
                before = truth
            elif after is None:
                after = truth
                t_stop = t_g + escape_s
            if truth.t >= plan.selected.t_i:
                near = abs(truth.t - t_g) < 60.0
                if near or steps % _CLEARANCE_STRIDE == 0:
                    q = true_motion.state(truth.t).q_hill_from_body
                    gaps.append(float(clearance(truth.r_hill, q, boxes, envelope)[0]))

    result.thrust_inside_sphere = any(e.name == 'thrust_inside_restriction_sphere' for e in result.plant_events)
    result.fuel_used_kg = plant.truth().fuel_used_kg
    if gaps:
        result.min_clearance_m = min(gaps)
    if before is not None and after is not None:
        _grasp_miss(true_motion, guidance.target.t_f, before, after, x_grasp_body, offset, n, result)
    return result


def _plan(target_filter, nav, planner_cfg, result):
    chaser = nav.state()
    t = chaser.t
    prediction = target_filter.prediction(t + planner_cfg.search_window[1], with_covariance=False)
    plan = plan_capture(prediction, chaser.r_hill, chaser.v_hill, t, planner_cfg)
    result.t_plan, result.plan_ok, result.plan_reason = t, plan.ok, plan.reason
    return plan


def _ideal_delta_v(plant, chosen, n):
    """Eq 28-29 impulses of the same transfer (to the plan's X_Fi at t_i) from the TRUE chaser state at t_Ti."""
    truth = plant.truth()
    state = cw_transition_matrix(n, chosen.t_ti - truth.t) @ np.concatenate((truth.r_hill, truth.v_hill))
    dv1, dv2 = terminal_impulses(state[:3], state[3:], chosen.x_fi, chosen.v_fi, chosen.t_i - chosen.t_ti, n)
    return float(np.linalg.norm(dv1) + np.linalg.norm(dv2))


def _guide(guidance, nav, target_filter, plant, result, refine, x_grasp_body, offset, n):
    """One guidance step at the latest navigation estimate; re-aims before an adjusting burn."""
    est = nav.state()
    if refine and guidance.wants_refined_target(est.t):
        t_f = guidance.target.t_f
        aim = refined_flyby_target(target_filter.prediction(t_f + 60.0, with_covariance=False), x_grasp_body, t_f,
                                   offset, n)
        if aim is not None:
            guidance.retarget(*aim)
    maneuvers, events = guidance.step(est.t, est.r_hill, est.v_hill)
    result.events += events
    for mv in maneuvers:
        plant.command_maneuver(mv.t, mv.dv_hill)
        nav.add_maneuver(mv.t, mv.dv_hill)
        result.dv_commanded_mps += float(np.linalg.norm(mv.dv_hill))
        result.burns.append({'t': mv.t, 'kind': mv.kind, 'dv_mps': float(np.linalg.norm(mv.dv_hill)), **mv.values})


def _grasp_miss(true_motion, t_g, before, after, x_grasp_body, offset, n, result):
    """Truth chaser at t_g (linear between the steps around it) against X_Ft from the true attitude at t_g."""
    w = (t_g - before.t) / (after.t - before.t)
    r = (1.0 - w) * before.r_hill + w * after.r_hill
    v = (1.0 - w) * before.v_hill + w * after.v_hill
    s = true_motion.state(t_g)
    x_ft, v_ft = flyby_target_from_attitude(s.q_hill_from_body, s.omega_body, x_grasp_body, offset, n)
    result.t_grasp = t_g
    result.miss_position_m = float(np.linalg.norm(r - x_ft))
    result.miss_velocity_mps = float(np.linalg.norm(v - v_ft))
