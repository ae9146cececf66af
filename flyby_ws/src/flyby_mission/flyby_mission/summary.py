"""The figures of a run (DESIGN §7, §10 ``summary.json``), computed from its truth.

Both drivers write the same summary by the same function, ``summarize``: the graph from the truth
topics of its bag (``compute_summary``), the headless driver (flyby_mission.headless) from the
plant's truth samples, stamped as the messages would be. Nothing here trusts what a node claimed
about itself: delta-v and fuel come from the applied thrust (``/sim/chaser/thrust`` is the mean force
over each step, so force x step is the exact impulse), clearance and collision from the truth poses
and the scenario's geometry, the capture errors from the truth at the grasp time. The claims used
are *which* grasp time (the one the supervisor decided at) and the phases the mission went through.
"""

import json
import math
from typing import NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from flyby_estimation.mass_properties import defined_axes, principal_axis_errors_rad
from flyby_estimation.post_capture import principal_axes
from flyby_msgs_py import contract as c
from flyby_msgs_py.bag import read_bag
from flyby_planner.grasp import capture_target_body, grasp_from_attitude
from flyby_planner.transport import missed_conditions
from flyby_sim.dynamics.attitude_control import pointing_error_rad
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2
from flyby_sim.dynamics.geometry import clearance
from flyby_sim.dynamics.grasp import Body, Contact, momentum
from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, quat_rotate, quat_rotate_many

# Process exit code of each outcome: 0 capture, 3 safe without capture, 5 collision, 130 interrupted, 1 error.
EXIT_CODES = {c.OUTCOME_CAPTURE: 0, c.OUTCOME_ESCAPE: 3, c.OUTCOME_NO_SAFE_PLAN: 3, c.OUTCOME_ABORTED: 3,
              c.OUTCOME_TIME_LIMIT: 3, c.OUTCOME_COLLISION: 5, c.OUTCOME_INTERRUPTED: 130, c.OUTCOME_ERROR: 1}
TRUTH_TOPICS = [c.CLOCK, c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM, c.SIM_CHASER_THRUST, c.MISSION_PHASE, c.MISSION_EVENTS]
# The six-degree-of-freedom chaser's, besides.
RIGID_TRUTH_TOPICS = [c.SIM_CHASER_THRUSTERS]
# After the capture (scenario post_capture, DESIGN §10): the keys post_capture_figures adds.
POST_CAPTURE_KEYS = ('final_angular_momentum_kg_m2_s', 'peak_grasp_force_n', 'peak_grasp_torque_n_m',
                     'grasp_damping_time_s', 'grasp_released', 'damping_time_s', 'damping_fuel_kg',
                     'target_mass_estimate_kg', 'target_com_estimate_m', 'target_principal_moments_estimate_kg_m2',
                     'target_principal_axes_estimate_q', 'target_mass_error_pct', 'target_com_error_m',
                     'target_principal_moments_error_pct', 'target_principal_axes_error_deg')
# With a transport (post_capture.transport, DESIGN §10, issue 17): the keys transport_figures adds.
TRANSPORT_KEYS = ('transport_goal_hill_m', 'transport_final_position_error_m', 'transport_orbital_momentum_error_n_m_s',
                  'transport_final_angular_momentum_kg_m2_s', 'transport_conditions_met', 'transport_fuel_kg',
                  'transport_impulses', 'transport_time_s', 'transport_replans')


class ChaserTruth(NamedTuple):
    """Truth of the chaser (the fields of /sim/chaser/odom the summary reads): t (N,) [s], position (N, 3)
    [m] and linear (N, 3) [m/s] in hill; the six-degree-of-freedom chaser's orientation_xyzw (N, 4),
    q_hill_from_chaser_body (None: a point mass), and angular (N, 3), its inertial rate in chaser_body axes
    [rad/s] (None where not read)."""

    t: np.ndarray
    position: np.ndarray
    linear: np.ndarray
    orientation_xyzw: np.ndarray = None
    angular: np.ndarray = None


class TargetTruth(NamedTuple):
    """Truth of the target (/sim/target/odom): t (N,), orientation_xyzw (N, 4) q_hill_from_body, angular
    (N, 3) inertial body rate in body axes [rad/s]; its CoM's position (N, 3) [m] in hill and velocity linear
    (N, 3) [m/s] in target_body axes (off the hill origin after a grasp; None where not read)."""

    t: np.ndarray
    orientation_xyzw: np.ndarray
    angular: np.ndarray
    position: np.ndarray = None
    linear: np.ndarray = None


class ThrustTruth(NamedTuple):
    """Applied thrust (/sim/chaser/thrust): t (N,), force (N, 3) [N] in hill, the mean over the step ending at t;
    the six-degree-of-freedom chaser's torque (N, 3) [N m] about its CoM (/sim/chaser/thrust) and each
    thruster's mean thrust thrusters (N, M) [N] (/sim/chaser/thrusters) on the same stamps (None: a point mass)."""

    t: np.ndarray
    force: np.ndarray
    torque: np.ndarray = None
    thrusters: np.ndarray = None


class WheelTruth(NamedTuple):
    """The reaction wheels' truth (/sim/chaser/wheels): t (N,), velocity (N, M), each wheel's speed relative to the
    body [rad/s]."""

    t: np.ndarray
    velocity: np.ndarray


def chaser_truth_from_odometry(odom):
    """The six-degree-of-freedom chaser's ChaserTruth from its /sim/chaser/odom series, whose twist is in
    chaser_body axes (nav_msgs' rule, DESIGN §10): the velocity turned into hill by the orientation."""
    return ChaserTruth(odom.t, odom.position, quat_rotate_many(odom.orientation_xyzw, odom.linear),
                       odom.orientation_xyzw, odom.angular)


def outcome_of(end_reason, phases, collided=False, refused=False, held=False):
    """Outcome (DESIGN §10) from how the run ended, the phases it went through, whether the truth shows
    a collision before any capture and whether the plan was refused before anything was flown; held: the run
    started with the chaser holding the target (post_capture.start attached), a capture from t = 0."""
    if collided:
        return c.OUTCOME_COLLISION
    if end_reason == 'interrupted':
        return c.OUTCOME_INTERRUPTED
    if end_reason is None or end_reason.startswith('error'):
        return c.OUTCOME_ERROR
    if c.PHASE_ABORTED in phases:
        return c.OUTCOME_ABORTED
    if refused and c.PHASE_TERMINAL_APPROACH not in phases:
        return c.OUTCOME_NO_SAFE_PLAN
    if c.PHASE_ESCAPE in phases:  # a decision to escape, or a grasp that let go (GRASP -> ESCAPE)
        return c.OUTCOME_ESCAPE
    if c.PHASE_CAPTURE in phases or held:
        return c.OUTCOME_CAPTURE
    return c.OUTCOME_TIME_LIMIT


def no_safe_plan_reason(events):
    """The supervisor's reason for ending in NO_SAFE_PLAN ('no safe plan: ...', from its PLANNING -> COMPLETE
    event), or None."""
    for e in events:
        if e['name'] == 'phase_changed' and e['values'].get('no_safe_plan') == 'true':
            return e['message'].split(': ', 1)[-1]
    return None


def thrust_figures(t, force_hill, r_hill, mass0_kg, isp_s, sphere_radius_m, torque=None, thrusters=None):
    """Delta-v [m/s], fuel [kg] and whether any thrust acted inside the restriction sphere.

    With each thruster's thrust (the six-degree-of-freedom chaser) the fuel is every thruster's impulse over
    Isp g0, couples and opposing firings included, and a step fires if any thruster does (a pure torque
    too); the delta-v is the net force's, by the rocket equation with that fuel."""
    if len(t) < 2:
        return 0.0, 0.0, False
    dt = np.diff(t)
    impulse = np.linalg.norm(force_hill[1:], axis=1) * dt
    v_exhaust = isp_s * STANDARD_GRAVITY_M_S2
    firing = impulse > 0.0
    if thrusters is None:
        fuel_steps = impulse / v_exhaust
    else:
        fuel_steps = np.sum(thrusters[1:], axis=1) * dt / v_exhaust
        firing |= fuel_steps > 0.0
    if torque is not None:
        firing |= np.any(torque[1:] != 0.0, axis=1)
    mass_before = mass0_kg - np.concatenate(([0.0], np.cumsum(fuel_steps)[:-1]))
    # Rocket equation per step (thrust magnitude is constant within a step's burn), with the net force's share.
    share = np.divide(impulse / v_exhaust, fuel_steps, out=np.zeros_like(impulse), where=fuel_steps > 0.0)
    dv_steps = share * v_exhaust * np.log(mass_before / (mass_before - fuel_steps))
    # A step's force acted between the previous sample and this one: check both ends.
    inside = (np.linalg.norm(r_hill[1:], axis=1) < sphere_radius_m) | \
             (np.linalg.norm(r_hill[:-1], axis=1) < sphere_radius_m)
    return (float(np.sum(dv_steps)), float(np.sum(fuel_steps)),
            bool(np.any(firing & inside)))


def pointing_figures(chaser, events, t_g):
    """The six-degree-of-freedom chaser's pointing error of body +x at the target's CoM (truth), from the first
    burn's start (the first terminal burn) or the start of a tracked trajectory (an optimal approach) to the grasp
    time (or the end of the truth): 95th percentile and largest [deg] (issue 13); None where neither started."""
    starts = [float(e['values']['t_start']) for e in events if e['name'] == 'burn_started' and 't_start' in e['values']]
    starts += [float(e['values']['t_start_s']) for e in events
               if e['name'] == 'guidance_started' and 't_start_s' in e['values']]
    t_end = t_g if t_g is not None else chaser.t[-1]
    window = (chaser.t >= min(starts, default=math.inf)) & (chaser.t <= t_end)
    if not np.any(window):
        return {'pointing_error_p95_deg': None, 'pointing_error_max_deg': None}
    error_deg = np.degrees(pointing_error_rad(chaser.orientation_xyzw[window], chaser.position[window]))
    return {'pointing_error_p95_deg': float(np.percentile(error_deg, 95.0)),
            'pointing_error_max_deg': float(np.max(error_deg))}


def chosen_method(events):
    """The method of the plan flown (the planner's last method_chosen event, DESIGN §10), or None."""
    chosen = [e['values']['method'] for e in events if e['name'] == 'method_chosen']
    return chosen[-1] if chosen else None


def approach_figures(chaser, thrust, events, scenario):
    """The figures of a thrusting approach (seed 003 Table 1, issue 14), from the truth: the peak thrust acceleration
    [m/s^2] (net force over the mass less the fuel spent), the approach time [s] of the last optimal plan, and what
    fired at the target within planner.optimal.plume_radius_m of its centre of mass: the net force's impulse away
    from the target [N s] (the plume rule's quantity) and, for the rigid-body chaser, the thrusters' impulse
    component toward the target [N s] (each thruster's exhaust direction, nominal, dotted with the line of sight;
    lateral thrusters count by the pointing error)."""
    plans = [e['values'] for e in events if e['name'] == 'plan_selected' and e['values'].get('method') == 'optimal']
    out = {'approach_time_s': float(plans[-1]['approach_time_s']) if plans else None,
           'peak_acceleration_mps2': None, 'plume_radius_m': scenario.planner.optimal.plume_radius_m,
           'plume_impulse_away_n_s': None, 'plume_thruster_impulse_n_s': None}
    if thrust is None or len(thrust.t) < 2:
        return out
    dt = np.diff(thrust.t)
    force = thrust.force[1:]
    v_exhaust = scenario.chaser.thrusters.isp_s * STANDARD_GRAVITY_M_S2
    each = (np.linalg.norm(force, axis=1) if thrust.thrusters is None else np.sum(thrust.thrusters[1:], axis=1)) * dt
    mass = scenario.chaser.mass_kg - np.cumsum(each) / v_exhaust  # after the step: the larger acceleration
    out['peak_acceleration_mps2'] = float(np.max(np.linalg.norm(force, axis=1) / mass))
    idx = np.searchsorted(chaser.t, thrust.t[1:]).clip(0, len(chaser.t) - 1)
    r = chaser.position[idx]
    dist = np.linalg.norm(r, axis=1)
    u = r / np.maximum(dist, 1e-12)[:, None]
    inside = dist < scenario.planner.optimal.plume_radius_m
    away = np.maximum(np.einsum('ij,ij->i', force, u), 0.0)
    out['plume_impulse_away_n_s'] = float(np.sum((away * dt)[inside]))
    if thrust.thrusters is not None and chaser.orientation_xyzw is not None:
        d_hill = np.stack([quat_rotate_many(chaser.orientation_xyzw[idx], np.broadcast_to(d, r.shape))
                           for d in scenario.thruster_layout.force_directions_body], axis=1)  # (N, M, 3)
        at_target = np.maximum(np.einsum('nmj,nj->nm', d_hill, u), 0.0)  # a push away: its exhaust's share at it
        out['plume_thruster_impulse_n_s'] = float(np.sum((thrust.thrusters[1:] * at_target * dt[:, None])[inside]))
    return out


def phase_windows(events, t_end):
    """[(phase, t_from, t_to)] of the supervisor's phase_changed events, the last one to t_end [s]."""
    changes = [(float(e['t']), e['values']['to']) for e in events
               if e['name'] == 'phase_changed' and e['values'].get('to')]
    return [(phase, t0, changes[k + 1][0] if k + 1 < len(changes) else t_end)
            for k, (t0, phase) in enumerate(changes)]


def sync_figures(chaser, target, thrust, events, t_g):
    """The synchronized approach's figures (seed 001, issue 15), from the truth: per phase the peak thrust force [N]
    and the thrusters' peak torque [N m] (each step's mean, the step counted in the phase it ends in), and the
    largest drift [deg] of the chaser's attitude relative to the target's from the start of stage 3 (ORBITING) to
    the grasp time (seed 001 Fig 6: the relative orientation constant there), or None where it did not run."""
    out = {'peak_force_n_by_phase': None, 'peak_thruster_torque_n_m_by_phase': None,
           'relative_attitude_drift_max_deg': None}
    if not any(e['name'] == 'plan_selected' and e['values'].get('method') == 'sync' for e in events):
        return out
    if thrust is not None and len(thrust.t) > 1:
        windows = phase_windows(events, float(thrust.t[-1]))
        t = thrust.t[1:]
        force = np.linalg.norm(thrust.force[1:], axis=1)
        torque = None if thrust.torque is None else np.linalg.norm(thrust.torque[1:], axis=1)
        out['peak_force_n_by_phase'], out['peak_thruster_torque_n_m_by_phase'] = {}, {}
        for phase, t0, t1 in windows:
            inside = (t > t0) & (t <= t1)
            if np.any(inside):
                out['peak_force_n_by_phase'][phase] = float(force[inside].max())
                if torque is not None:
                    out['peak_thruster_torque_n_m_by_phase'][phase] = float(torque[inside].max())
    starts = [float(e['t']) for e in events
              if e['name'] == 'phase_changed' and e['values'].get('to') == c.PHASE_ORBITING]
    if starts and t_g is not None and chaser.orientation_xyzw is not None and target is not None:
        common, i_c, i_t = np.intersect1d(chaser.t, target.t, return_indices=True)
        window = (common >= starts[0] - 1e-9) & (common <= t_g + 1e-9)
        if np.any(window):
            relative = (Rotation.from_quat(target.orientation_xyzw[i_t[window]]).inv()
                        * Rotation.from_quat(chaser.orientation_xyzw[i_c[window]]))
            drift = (relative[0].inv() * relative).magnitude()
            out['relative_attitude_drift_max_deg'] = float(np.degrees(drift.max()))
    return out


def grasp_time(events):
    """The grasp time t_g the supervisor decided at (its FLYBY -> CAPTURE / ESCAPE event), or None."""
    for e in events:
        if e['name'] == 'phase_changed' and e['values'].get('to') in (c.PHASE_CAPTURE, c.PHASE_ESCAPE) \
                and 't_grasp_s' in e['values']:
            return float(e['values']['t_grasp_s'])
    return None


def planned_flyby(events):
    """(offset delta r [m], fly-by duration [s]) of the last plan selected, or (None, None)."""
    selected = [e['values'] for e in events if e['name'] == 'plan_selected' and 'offset_m' in e['values']]
    if not selected:
        return None, None
    duration = selected[-1].get('flyby_duration_s')  # none for an optimal approach
    return float(selected[-1]['offset_m']), None if duration is None else float(duration)


def capture_errors(t_g, chaser, target, x_target_body, n):
    """Truth chaser at t_g against the target point x_target_body (body axes, flyby_planner.grasp.capture_target_body:
    X_Ft, V_Ft of eq 20-21 for a fly-by) recomputed from the true target attitude at t_g (DESIGN §7, §10).

    Truth is sampled every step: the chaser is interpolated linearly (its error is a dt^2 / 8 ~ 1e-7 m),
    the attitude by slerp and the body rate linearly between the samples around t_g.
    Returns (position error [m], velocity error [m/s]), or (None, None) when t_g is outside the truth.
    """
    if t_g is None or not (chaser.t[0] <= t_g <= chaser.t[-1] and target.t[0] <= t_g <= target.t[-1]):
        return None, None
    r = np.array([np.interp(t_g, chaser.t, chaser.position[:, k]) for k in range(3)])
    v = np.array([np.interp(t_g, chaser.t, chaser.linear[:, k]) for k in range(3)])
    i = int(np.clip(np.searchsorted(target.t, t_g), 1, len(target.t) - 1))
    pair = Rotation.from_quat(target.orientation_xyzw[i - 1:i + 1])
    q = Slerp(target.t[i - 1:i + 1], pair)([t_g]).as_quat()[0]
    w = np.array([np.interp(t_g, target.t, target.angular[:, k]) for k in range(3)])
    x_ft, v_ft = grasp_from_attitude(q, w, x_target_body, n)
    return float(np.linalg.norm(r - x_ft)), float(np.linalg.norm(v - v_ft))


def phase_start(events, phase):
    """The time [s] the supervisor entered phase (its first phase_changed to it), or None."""
    return next((float(e['t']) for e in events if e['name'] == 'phase_changed' and e['values'].get('to') == phase),
                None)


def _fuel_steps(thrust, scenario):
    """The fuel [kg] of each truth step of the thrust (the step ending at thrust.t[1:]; each thruster's impulse for
    the rigid body, the net force's for the point mass)."""
    dt = np.diff(thrust.t)
    each = (np.sum(thrust.thrusters[1:], axis=1) if thrust.thrusters is not None
            else np.linalg.norm(thrust.force[1:], axis=1))
    return each * dt / (scenario.chaser.thrusters.isp_s * STANDARD_GRAVITY_M_S2)


def truth_bodies(i_c, i_t, chaser, target, wheels_speed, scenario, chaser_mass_kg):
    """(chaser, target) as grasp.Body from the truth samples i_c, i_t (the same stamp), in the inertial frame whose axes
    are hill's then: velocities relative to hill plus Omega^H x r (Omega^H = [0, -n, 0], seed 000 eq 11), the wheels'
    momentum in chaser_body axes from their speeds (h_i = J (speed_i + a_i . omega))."""
    n = scenario.mean_motion_rad_s
    omega_hill = np.array([0.0, -n, 0.0])
    w = scenario.chaser.wheels
    axes = np.asarray(w.axes, dtype=float)
    axes = axes / np.linalg.norm(axes, axis=1)[:, None]
    omega_c = chaser.angular[i_c]
    h_wheels = axes.T @ (w.spin_inertia_kg_m2 * (np.asarray(wheels_speed) + axes @ omega_c))
    r_c, r_t = chaser.position[i_c], target.position[i_t]
    q_t = target.orientation_xyzw[i_t]
    v_t = quat_rotate(q_t, target.linear[i_t])  # the twist in target_body axes (nav_msgs' rule)
    return (Body(chaser_mass_kg, scenario.chaser_inertia, r_c, chaser.linear[i_c] + np.cross(omega_hill, r_c),
                 chaser.orientation_xyzw[i_c], omega_c, h_wheels),
            Body(scenario.target.mass_kg, scenario.target_inertia, r_t, v_t + np.cross(omega_hill, r_t), q_t,
                 target.angular[i_t]))


def angular_momentum_about_com(bodies):
    """|angular momentum| [kg m^2/s] of free bodies about their common CoM (grasp.momentum, wheels included)."""
    p, h_origin = momentum(bodies)
    mass = sum(b.mass_kg for b in bodies)
    r_cm = sum(b.mass_kg * b.r_m for b in bodies) / mass
    return float(np.linalg.norm(h_origin - np.cross(r_cm, p)))


def lock_time(events, scenario):
    """The stamp [s] the arm locked chaser and target into one rigid body: the simulator's ``grasp_damped``, t = 0 in
    a run that starts attached; None before."""
    if scenario.post_capture is not None and scenario.post_capture.start == 'attached':
        return 0.0
    return next((float(e['t']) for e in events if e['name'] == 'grasp_damped'), None)


def post_capture_truth(chaser, target, wheels, thrust, scenario, t_lock=None):
    """(common (N,) [s], i_c, i_t, bodies): the stamps both bodies' truth shares, their indices in the chaser's and the
    target's series, and bodies(k), the (chaser, target) grasp.Body at common[k] (truth_bodies: the wheels' nearest
    sample at or after it, the chaser's mass less the fuel burned by then, or by t_lock (``lock_time``) after it: the
    plant's combined body keeps the CoM and inertia of the lock, its propellant spent at the CoM
    (``chaser_body.SixDofChaser``'s com_body_m), so the CoM of the pair is the plant's only with the lock's masses)."""
    common, i_c, i_t = np.intersect1d(chaser.t, target.t, return_indices=True)
    i_w = np.searchsorted(wheels.t, common).clip(0, len(wheels.t) - 1)
    fuel = np.concatenate(([0.0], np.cumsum(_fuel_steps(thrust, scenario)))) if thrust is not None and len(
        thrust.t) > 1 else np.zeros(1)
    t_fuel = thrust.t if thrust is not None and len(thrust.t) > 1 else np.zeros(1)

    def bodies(k):
        t = common[k] if t_lock is None else min(common[k], t_lock)
        mass = scenario.chaser.mass_kg - fuel[int(np.searchsorted(t_fuel, t, side='right')) - 1]
        return truth_bodies(i_c[k], i_t[k], chaser, target, wheels.velocity[i_w[k]], scenario, mass)

    return common, i_c, i_t, bodies


def grasp_contact_series(events, common, bodies, scenario):
    """(t (N,) [s], force (N, 3) [N], torque (N, 3) [N m], stroke (N, 3) [m]) of the arm's impedance on the target,
    inertial axes (``grasp.Contact.at_first_contact`` of the truth at GRASP's start), at every truth stamp of common
    from GRASP's start to DAMPING's (else ESCAPE's, else the end); bodies(k) as post_capture_truth's. Empty without
    GRASP or a stamp in it."""
    t_grasp, t_damping = phase_start(events, c.PHASE_GRASP), phase_start(events, c.PHASE_DAMPING)
    empty = np.zeros((0, 3))
    if t_grasp is None:
        return np.zeros(0), empty, empty, empty
    t_grasp_end = t_damping if t_damping is not None else phase_start(events, c.PHASE_ESCAPE) or math.inf
    in_grasp = np.flatnonzero((common >= t_grasp - 1e-9) & (common <= t_grasp_end + 1e-9))
    if not len(in_grasp):
        return common[in_grasp], empty, empty, empty
    contact = Contact.at_first_contact(scenario.arm_impedance, *bodies(in_grasp[0]), scenario.target.grasp_point_body_m)
    wrenches = [contact.wrench(*bodies(k))[:3] for k in in_grasp]
    force, torque, stroke = (np.array([w[j] for w in wrenches]) for j in range(3))
    return common[in_grasp], force, torque, stroke


def damping_window(events, t_end):
    """(t_damping, t_damped) [s]: DAMPING's start and its end (MASS_ESTIMATION's start, else t_end), or (None,
    None) without DAMPING."""
    t_damping, t_mass = phase_start(events, c.PHASE_DAMPING), phase_start(events, c.PHASE_MASS_ESTIMATION)
    if t_damping is None:
        return None, None
    return t_damping, t_mass if t_mass is not None else t_end


def target_mass_properties_truth(chaser, target, i_c, i_t, scenario):
    """The truth of what the estimator estimates (DESIGN §10 /estimation/target/inertia) at the truth samples i_c, i_t
    of one stamp: (X_s (3,) [m], the target's CoM from the chaser's in chaser_body axes; its principal moments (3,)
    [kg m^2], ascending, the scenario's; q_body_from_principal (x, y, z, w), its principal axes in chaser_body)."""
    q_c, q_t = chaser.orientation_xyzw[i_c], target.orientation_xyzw[i_t]
    x_s = quat_rotate(quat_conjugate(q_c), target.position[i_t] - chaser.position[i_c])
    moments, q_target_from_principal = principal_axes(scenario.target_inertia)
    return x_s, moments, quat_multiply(quat_multiply(quat_conjugate(q_c), q_t), q_target_from_principal)


def post_capture_figures(chaser, target, wheels, thrust, events, scenario):
    """After the capture (issue 16, DESIGN §10), from the truth: the grasp's peak contact force and torque (the arm's
    impedance, ``grasp.Contact.at_first_contact`` of the truth at the capture, at every truth sample of GRASP), the
    damping's time and fuel and the combined body's angular momentum about its CoM at its end (inertial, wheels
    included), the estimator's final estimates of the target (its ``mass_properties_estimated``) and their errors
    against the truth at their stamp (target CoM from the chaser CoM and principal axes in chaser_body; principal
    moments and mass the scenario's). None where a phase did not run."""
    out = dict.fromkeys(POST_CAPTURE_KEYS)
    out['grasp_released'] = any(e['name'] == 'grasp_released' for e in events)
    t_grasp = phase_start(events, c.PHASE_GRASP)
    attached = scenario.post_capture.start == 'attached'  # held from t = 0: no grasp, no damping
    if (t_grasp is None and not attached) or chaser is None or target is None or chaser.angular is None \
            or target.position is None:
        return out
    t_end = float(chaser.t[-1])
    common, i_c, i_t, bodies = post_capture_truth(chaser, target, wheels, thrust, scenario,
                                                  lock_time(events, scenario))
    t_contact, force, torque, _ = grasp_contact_series(events, common, bodies, scenario)
    if len(t_contact):
        out['peak_grasp_force_n'] = float(max(np.linalg.norm(f) for f in force))
        out['peak_grasp_torque_n_m'] = float(max(np.linalg.norm(tau) for tau in torque))
    t_damping, t_damped = damping_window(events, t_end)
    if t_damping is None and not attached:
        return out
    if t_damping is not None:
        out['grasp_damping_time_s'] = t_damping - t_grasp
        out['damping_time_s'] = t_damped - t_damping
        k = int(np.searchsorted(common, t_damped + 1e-9)) - 1
        out['final_angular_momentum_kg_m2_s'] = angular_momentum_about_com(bodies(k))
        if thrust is not None and len(thrust.t) > 1:
            steps = _fuel_steps(thrust, scenario)
            t_step = thrust.t[1:]
            out['damping_fuel_kg'] = float(np.sum(steps[(t_step > t_damping) & (t_step <= t_damped + 1e-9)]))
    final = [e for e in events if e['name'] == 'mass_properties_estimated']
    if not final:
        return out
    e = final[-1]
    values = {key: json.loads(e['values'][key]) for key in ('com_body_m', 'principal_moments_kg_m2',
                                                              'principal_axes_q')}
    mass_kg = float(e['values']['mass_kg'])
    out.update(target_mass_estimate_kg=mass_kg, target_com_estimate_m=values['com_body_m'],
               target_principal_moments_estimate_kg_m2=values['principal_moments_kg_m2'],
               target_principal_axes_estimate_q=values['principal_axes_q'])
    k = int(np.searchsorted(common, float(e['t']) - 1e-9))
    if k >= len(common):
        return out
    x_s, moments, q_true = target_mass_properties_truth(chaser, target, i_c[k], i_t[k], scenario)
    out.update(target_mass_error_pct=100.0 * abs(mass_kg / scenario.target.mass_kg - 1.0),
               target_com_error_m=float(np.linalg.norm(np.asarray(values['com_body_m']) - x_s)),
               target_principal_moments_error_pct=100.0 * float(np.max(np.abs(
                   np.asarray(values['principal_moments_kg_m2']) / moments - 1.0))),
               target_principal_axes_error_deg=math.degrees(float(np.max(principal_axis_errors_rad(
                   np.asarray(values['principal_axes_q']), q_true)[defined_axes(moments)], initial=0.0))))
    return out


def transport_state(pair, goal_hill_m, mean_motion_rad_s):
    """Seed 004 §3.2's rendezvous quantities of the combined body, the (chaser, target) grasp.Body pair: the CoM's
    distance from the goal [m], its speed relative to the goal's circular motion (the goal fixed in hill) [m/s], its
    linear momentum (m + M) times that speed [N s], the angular momentum about the CoM, wheels included [kg m^2/s]."""
    mass = sum(b.mass_kg for b in pair)
    r_cm = sum(b.mass_kg * b.r_m for b in pair) / mass
    v_cm = sum(b.mass_kg * b.v_mps for b in pair) / mass - np.cross((0.0, -mean_motion_rad_s, 0.0), r_cm)
    speed = float(np.linalg.norm(v_cm))
    return (float(np.linalg.norm(r_cm - np.asarray(goal_hill_m))), speed, float(mass) * speed,
            angular_momentum_about_com(pair))


def transport_figures(chaser, target, wheels, thrust, events, scenario):
    """TRANSPORT (issue 17, seed 004 §3.2), from the truth at guidance's ``transport_complete`` (the run's end
    without it): the combined CoM's distance from the goal, its linear momentum relative to the goal's circular
    motion (the goal fixed in hill: (m + M) |v_hill| of the CoM) [N s, DESIGN §10's ..._n_m_s key, docs/transport.md],
    the angular momentum about it (wheels included), whether the three rendezvous conditions hold; the fuel, the
    number of impulses (runs of consecutive firing steps) and the time from the start of TRANSPORT to the planned
    arrival; None where TRANSPORT did not run."""
    tr = scenario.post_capture.transport
    out = dict.fromkeys(TRANSPORT_KEYS)
    out['transport_goal_hill_m'] = list(map(float, tr.goal_hill_m))
    t_start = phase_start(events, c.PHASE_TRANSPORT)
    if t_start is None or chaser is None or target is None or chaser.angular is None or target.position is None:
        return out
    done = [e for e in events if e['name'] == 'transport_complete']
    common, i_c, i_t, bodies = post_capture_truth(chaser, target, wheels, thrust, scenario,
                                                  lock_time(events, scenario))
    t_end = float(done[-1]['t']) if done else float(common[-1])
    k = max(int(np.searchsorted(common, t_end + 1e-9)) - 1, 0)
    miss, _, momentum, h = transport_state(bodies(k), tr.goal_hill_m, scenario.mean_motion_rad_s)
    out.update(transport_final_position_error_m=miss, transport_orbital_momentum_error_n_m_s=momentum,
               transport_final_angular_momentum_kg_m2_s=h,
               transport_conditions_met=bool(done and not missed_conditions(
                   {'position_error_m': miss, 'momentum_error_n_s': momentum, 'angular_momentum_kg_m2_s': h}, tr)),
               transport_replans=sum(1 for e in events if e['name'] in ('transport_correction', 'transport_trim')))
    planned = [e for e in events if e['name'] == 'transport_planned']
    if planned:
        out['transport_time_s'] = float(planned[0]['values']['t_arrival_s']) - t_start
    if thrust is not None and len(thrust.t) > 1:
        steps = _fuel_steps(thrust, scenario)
        t_step = thrust.t[1:]
        window = (t_step > t_start + 1e-9) & (t_step <= t_end + 1e-9)
        out['transport_fuel_kg'] = float(np.sum(steps[window]))
        firing = steps[window] > 0.0
        out['transport_impulses'] = int(np.sum(firing[1:] & ~firing[:-1]) + (1 if len(firing) and firing[0] else 0))
    return out


# Clearances within this of the least are a tie: a plateau (the chaser attached after the grasp) has no argmin
# that two routes computing the same gaps to ~1e-12 m agree on.
CLEARANCE_TIE_M = 1e-6


def least_clearance_index(gaps):
    """Index of the first sample whose clearance is within CLEARANCE_TIE_M of the least (t_min_clearance_s)."""
    gaps = np.asarray(gaps, dtype=float)
    return int(np.flatnonzero(gaps <= gaps.min() + CLEARANCE_TIE_M)[0])


def thrust_truth(wrench, thrusters=None):
    """The ThrustTruth of a bag's /sim/chaser/thrust series and, for the six-degree-of-freedom chaser, its
    /sim/chaser/thrusters series (published together each step; a bag cut short may end one message apart: both are
    cut to the shorter); None without thrust. ValueError if the two have different stamps."""
    if thrusters is None:
        return None if wrench is None else ThrustTruth(wrench.t, wrench.force)
    n = min(len(wrench.t), len(thrusters.t))
    if not np.array_equal(thrusters.t[:n], wrench.t[:n]):
        raise ValueError('/sim/chaser/thrusters and /sim/chaser/thrust have different stamps')
    return ThrustTruth(wrench.t[:n], wrench.force[:n], wrench.torque[:n], thrusters.effort[:n])


def compute_summary(bag_dir, scenario, end_reason, final_phase=None, wall_time_s=float('nan'), namespace='',
                    **launcher):
    """The summary dict of a run from its bag; robust to a bag cut short by an interruption. ``launcher``:
    what only the launcher knows (summarize's node_exit_codes, nodes_killed, bag_repair, faults_injected).
    ``namespace``: the chaser's (``/chaser1``) of a ``chasers:`` scenario, whose view ``scenario`` is."""
    rigid = scenario.chaser.model == 'rigid_body'
    wheels_topics = [c.SIM_CHASER_WHEELS] if scenario.post_capture is not None else []
    data = read_bag(bag_dir, topics=[c.absolute(t, namespace) for t in TRUTH_TOPICS + (RIGID_TRUTH_TOPICS if rigid
                                                                                      else []) + wheels_topics])
    if namespace:  # the chaser's topics by their single-chaser names
        data = {(name[len(namespace):] if name.startswith(namespace + '/') else name): v for name, v in data.items()}
    chaser = data.get(c.absolute(c.SIM_CHASER_ODOM))
    if rigid:
        chaser = chaser_truth_from_odometry(chaser)
    target = data.get(c.absolute(c.SIM_TARGET_ODOM))
    try:
        thrust = thrust_truth(data.get(c.absolute(c.SIM_CHASER_THRUST)),
                              data[c.absolute(c.SIM_CHASER_THRUSTERS)] if rigid else None)
    except ValueError as err:
        raise ValueError(f'{bag_dir}: {err}') from None
    phase_msgs = data.get(c.absolute(c.MISSION_PHASE))
    events = data.get(c.absolute(c.MISSION_EVENTS)) or []
    phases = list(phase_msgs.data) if phase_msgs is not None else []
    return summarize(chaser, target, thrust, phases, events, scenario, end_reason, final_phase, wall_time_s,
                     wheels=data.get(c.absolute(c.SIM_CHASER_WHEELS)), **launcher)


def summarize(chaser, target, thrust, phases, events, scenario, end_reason, final_phase=None,
              wall_time_s=float('nan'), node_exit_codes=None, nodes_killed=(), bag_repair=None, faults_injected=None,
              wheels=None):
    """The summary dict of a run from its truth (ChaserTruth, TargetTruth, ThrustTruth or the bag's series
    with the same fields, any of them None), the phases in order and the events (dicts with t, level,
    name, message, values (text), hardware_id). The next four are the launcher's: the nodes' exit codes,
    the nodes it killed, its repair of the bag and the faults it injected (none for the headless driver).
    wheels: the wheels' truth (t (N,), velocity (N, M) [rad/s] relative to the body, /sim/chaser/wheels), read
    with a post_capture section.

    After the capture (post_capture, DESIGN §10) the combined body fires inside the restriction sphere by design:
    delta_v_total_mps and thrust_inside_restriction_sphere are the approach's (up to the capture), fuel_used_kg the
    whole run's."""
    if final_phase is None and phases:
        final_phase = phases[-1]
    has_chaser = chaser is not None and len(chaser.t)
    has_target = target is not None and len(target.t)
    sim_time_s = float(chaser.t[-1]) if has_chaser else 0.0
    sphere_m = scenario.planner.restriction_sphere_radius_m
    held = scenario.post_capture is not None and scenario.post_capture.start == 'attached'
    delta_v = fuel = 0.0
    thrust_inside = False
    approach = thrust  # the thrust up to the capture (docstring)
    t_capture = 0.0 if held else phase_start(events, c.PHASE_GRASP) if scenario.post_capture is not None else None
    if thrust is not None and t_capture is not None:
        approach = ThrustTruth(*(None if a is None else a[:int(np.searchsorted(thrust.t, t_capture + 1e-9))]
                                 for a in thrust))
    if thrust is not None and has_chaser and len(thrust.t):
        r_at_thrust = chaser.position[np.searchsorted(chaser.t, approach.t).clip(0, len(chaser.t) - 1)]
        delta_v, fuel, thrust_inside = thrust_figures(
            approach.t, approach.force, r_at_thrust, scenario.chaser.mass_kg,
            scenario.chaser.thrusters.isp_s, sphere_m, approach.torque, approach.thrusters)
        if approach is not thrust:
            fuel = float(np.sum(_fuel_steps(thrust, scenario))) if len(thrust.t) > 1 else 0.0

    t_g = grasp_time(events)
    offset_m, flyby_duration_s = planned_flyby(events)
    min_clearance = t_min_clearance = None
    collided = False
    e_pos = e_vel = None
    if has_chaser and has_target:
        t_common, i_c, i_t = np.intersect1d(chaser.t, target.t, return_indices=True)
        boxes = [(b.center_m, b.size_m) for b in scenario.target.geometry]
        # The chaser from the target's CoM, off the hill origin after a grasp (zero before).
        r_from_target = chaser.position[i_c] - (0.0 if target.position is None else target.position[i_t])
        gaps = clearance(r_from_target, target.orientation_xyzw[i_t], boxes, scenario.chaser.envelope_radius_m)
        k = least_clearance_index(gaps)
        min_clearance, t_min_clearance = float(gaps[k]), float(t_common[k])
        # A collision is contact before a capture (afterwards the chaser holds the target, DESIGN §10; held from
        # t = 0 in a run that starts attached).
        free = t_common <= t_g if c.PHASE_CAPTURE in phases and t_g is not None else np.full(len(gaps), not held)
        collided = bool(np.any(gaps[free] < 0.0))
        if t_g is not None:
            x_target_body = capture_target_body(chosen_method(events), scenario.target.grasp_point_body_m,
                                                offset_m or scenario.planner.offset_m, boxes)
            e_pos, e_vel = capture_errors(t_g, chaser, target, x_target_body, scenario.mean_motion_rad_s)

    pointing = pointing_figures(chaser, events, t_g) if has_chaser and scenario.chaser.model == 'rigid_body' else {}
    approach_keys = approach_figures(chaser, approach, events, scenario) if has_chaser else {}
    sync = sync_figures(chaser, target if has_target else None, approach, events, t_g) if has_chaser else {}
    post = {} if scenario.post_capture is None else post_capture_figures(
        chaser if has_chaser else None, target if has_target else None, wheels, thrust, events, scenario)
    if scenario.post_capture is not None and scenario.post_capture.transport is not None:
        post.update(transport_figures(chaser if has_chaser else None, target if has_target else None, wheels, thrust,
                                      events, scenario))

    refused = no_safe_plan_reason(events)
    outcome = outcome_of(end_reason, phases, collided, refused is not None, held)
    if outcome == c.OUTCOME_NO_SAFE_PLAN:
        end_reason = refused

    def count(name):
        return sum(1 for e in events if e['name'] == name)

    return {
        'outcome': outcome,
        'final_phase': final_phase,
        'end_reason': end_reason,
        'method': chosen_method(events),
        'phase_sequence': list(phases),
        'scenario': scenario.name,
        'seed': scenario.seed,
        't_grasp_s': t_g,
        'flyby_offset_m': offset_m,
        'flyby_duration_s': flyby_duration_s,
        'capture_position_error_m': e_pos,
        'capture_velocity_error_mps': e_vel,
        'delta_v_total_mps': delta_v,
        'fuel_used_kg': fuel,
        'min_clearance_m': min_clearance,
        't_min_clearance_s': t_min_clearance,
        'restriction_sphere_radius_m': sphere_m,
        'thrust_inside_restriction_sphere': thrust_inside,
        'maneuvers_executed': count('burn_started'),
        'late_maneuvers': count('late_maneuver'),
        'rejected_maneuvers': count('maneuver_rejected'),
        **pointing,
        **approach_keys,
        **sync,
        **post,
        'sim_time_s': sim_time_s,
        'planning_time_s': sum(float(e['values'].get('planning_time_s', 0.0)) for e in events
                               if e['name'] in ('plan_selected', 'plan_refused')),
        'wall_time_s': wall_time_s,
        'real_time_factor': sim_time_s / wall_time_s if wall_time_s > 0 else None,
        'node_exit_codes': node_exit_codes or {},
        'nodes_killed': list(nodes_killed),
        'bag_repair': bag_repair,
        'faults_injected': faults_injected or {'abort_at_s': None, 'kill': None},
    }


def format_summary(summary):
    """A short table of the figures a user reads first."""
    def fmt(value, unit='', digits=4):
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return '-'
        if isinstance(value, float):
            return f'{value:.{digits}g} {unit}'.strip()
        return f'{value} {unit}'.strip()

    rows = [
        ('outcome', fmt(summary['outcome'])),
        ('final phase', fmt(summary['final_phase'])),
        ('end reason', fmt(summary['end_reason'])),
        ('method', fmt(summary.get('method'))),
        ('seed', fmt(summary['seed'])),
        ('grasp time', fmt(summary['t_grasp_s'], 's', 7)),
        ('capture position error', fmt(summary['capture_position_error_m'], 'm')),
        ('capture velocity error', fmt(summary['capture_velocity_error_mps'], 'm/s')),
        ('delta-v total', fmt(summary['delta_v_total_mps'], 'm/s')),
        ('fuel used', fmt(summary['fuel_used_kg'], 'kg')),
        ('min clearance', fmt(summary['min_clearance_m'], 'm')),
        ('thrust inside sphere', fmt(summary['thrust_inside_restriction_sphere'])),
        *([('pointing error p95 / max', f"{fmt(summary['pointing_error_p95_deg'], 'deg')} / "
                                         f"{fmt(summary['pointing_error_max_deg'], 'deg')}")]
          if 'pointing_error_p95_deg' in summary else []),
        *([('relative attitude drift', fmt(summary['relative_attitude_drift_max_deg'], 'deg'))]
          if summary.get('relative_attitude_drift_max_deg') is not None else []),
        *([('approach time', fmt(summary['approach_time_s'], 's')),
           ('peak acceleration', fmt(summary['peak_acceleration_mps2'], 'm/s^2')),
           ('thrust away in plume', f"{fmt(summary['plume_impulse_away_n_s'], 'N s')} net, "
                                    f"{fmt(summary['plume_thruster_impulse_n_s'], 'N s')} of exhaust at the target")]
          if summary.get('approach_time_s') is not None else []),
        *([('peak grasp force / torque', f"{fmt(summary['peak_grasp_force_n'], 'N')} / "
                                          f"{fmt(summary['peak_grasp_torque_n_m'], 'N m')}"
                                          + (' (released)' if summary.get('grasp_released') else '')),
           ('damping', f"{fmt(summary['damping_time_s'], 's')}, {fmt(summary['damping_fuel_kg'], 'kg')}, "
                       f"momentum {fmt(summary['final_angular_momentum_kg_m2_s'], 'kg m^2/s')}"),
           ('target mass error', fmt(summary['target_mass_error_pct'], '%')),
           ('target CoM error', fmt(summary['target_com_error_m'], 'm')),
           ('target moments / axes error', f"{fmt(summary['target_principal_moments_error_pct'], '%')} / "
                                           f"{fmt(summary['target_principal_axes_error_deg'], 'deg')}")]
          if 'peak_grasp_force_n' in summary else []),
        ('late maneuvers', fmt(summary['late_maneuvers'])),
        ('sim time', fmt(summary['sim_time_s'], 's', 6)),
        ('wall time', fmt(summary['wall_time_s'], 's')),
        ('real-time factor', fmt(summary['real_time_factor'], 'x', 3)),
    ]
    width = max(len(k) for k, _ in rows)
    return '\n'.join(f'{k:<{width}}  {v}' for k, v in rows)
