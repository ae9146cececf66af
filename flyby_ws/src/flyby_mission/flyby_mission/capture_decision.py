"""The capture decision at the grasp time (Matsumoto et al., *Fly-by approach and guidance for uncontrolled rotating
satellite capture*, the code's "seed 000", section 4.1; Jacobsen et al.'s optimization-based approach ends at the same
fly-by target point, seed 003 section 3.1): capture if the manipulator can absorb the estimated error, else escape.
The supervisor (flyby_mission.supervisor) decides with it from its estimates carried to the grasp time."""

import dataclasses

import numpy as np

from flyby_estimation.target_motion import prediction_from_estimate
from flyby_planner.flyby.grasp_search import grasp_from_attitude
from flyby_sim.dynamics.orbital import cw_coast


@dataclasses.dataclass(frozen=True)
class CaptureDecision:
    capture: bool
    reason: str
    values: dict


def capture_decision(r_hill, v_hill, x_g, x_ft, v_ft, tolerances):
    """Capture if the manipulator can absorb the estimated error (seed 000 section 4.1).

    The chaser, estimated at (r, v) at the grasp time, must be within position_tolerance_m and
    velocity_tolerance_mps of the fly-by target point (X_Ft, V_Ft: where it should be, moving as the
    grasp point's offset does, eq 20-21) and the grasp point x_g within reach_m (``tolerances``: SupervisorParams).
    Otherwise escape.
    """
    e_pos = float(np.linalg.norm(np.asarray(r_hill) - x_ft))
    e_vel = float(np.linalg.norm(np.asarray(v_hill) - v_ft))
    reach = float(np.linalg.norm(np.asarray(x_g) - r_hill))
    values = {'position_error_m': e_pos, 'velocity_error_mps': e_vel, 'grasp_distance_m': reach}
    problems = []
    if e_pos > tolerances.position_tolerance_m:
        problems.append(f'position error {e_pos:.3f} m > {tolerances.position_tolerance_m:g} m')
    if e_vel > tolerances.velocity_tolerance_mps:
        problems.append(f'velocity error {e_vel * 1e3:.1f} mm/s > {tolerances.velocity_tolerance_mps * 1e3:g} mm/s')
    if reach > tolerances.reach_m:
        problems.append(f'grasp point {reach:.3f} m away > reach {tolerances.reach_m:g} m')
    if problems:
        return CaptureDecision(False, 'escape: ' + '; '.join(problems), values)
    return CaptureDecision(True, f'capture: position error {e_pos * 100:.1f} cm, velocity error '
                                 f'{e_vel * 1e3:.2f} mm/s, grasp point {reach:.2f} m away', values)


def decide_capture(chaser, target, t_grasp, dynamics, n, x_grasp_body, x_target_body, tolerances):
    """The capture decision at the grasp time t_grasp from a chaser estimate (t, r_hill, v_hill) and a
    target estimate (t, q_hill_from_body, omega_body), both carried to t_g: the chaser along CW (eq 22),
    the target by its torque-free motion (eq 4); the target point is the body point x_target_body
    (flyby_planner.flyby.grasp_search.capture_target_body: eq 20-21 for a fly-by) in hill by eq 8-9."""
    t_c, r, v = chaser
    state = cw_coast(r, v, t_grasp - t_c, n)
    t_t, q_hb, omega_body = target
    t_at = max(t_grasp, t_t)  # an estimate newer than t_g (none older was kept): its own time
    s = prediction_from_estimate(dynamics, n, t_t, q_hb, omega_body, t_at).state(t_at)
    x_g, _ = grasp_from_attitude(s.q_hill_from_body, s.omega_body, x_grasp_body, n)
    x_ft, v_ft = grasp_from_attitude(s.q_hill_from_body, s.omega_body, x_target_body, n)
    return capture_decision(state[:3], state[3:], x_g, x_ft, v_ft, tolerances)
