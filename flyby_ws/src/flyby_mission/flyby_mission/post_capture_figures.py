"""The figures of a run after the capture (DESIGN §10 ``summary.json``, scenario post_capture), from the truth: the
grasp's contact, the damping, the estimator's final estimate of the target's mass properties against the truth, and
the transport's rendezvous quantities (seed 004 §3.2)."""

import math

import numpy as np

from flyby_estimation.mass_estimation_run import principal_axes
from flyby_estimation.mass_properties_errors import defined_axes, principal_axis_errors_rad
from flyby_mission.run_events import lock_time, phase_start
from flyby_mission.run_truth import fuel_steps
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads
from flyby_msgs_py import events as ev
from flyby_planner.transport.model import missed_conditions
from flyby_sim.dynamics.grasp import Body, Contact, momentum
from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, quat_rotate

# After the capture (scenario post_capture, DESIGN §10): the keys post_capture_figures adds.
POST_CAPTURE_KEYS = ('final_angular_momentum_kg_m2_s', 'peak_grasp_force_n', 'peak_grasp_torque_n_m',
                     'grasp_damping_time_s', 'grasp_released', 'damping_time_s', 'damping_fuel_kg',
                     'target_mass_estimate_kg', 'target_com_estimate_m', 'target_principal_moments_estimate_kg_m2',
                     'target_principal_axes_estimate_q', 'target_mass_error_pct', 'target_com_error_m',
                     'target_principal_moments_error_pct', 'target_principal_axes_error_deg')
# With a transport (post_capture.transport, DESIGN §10): the keys transport_figures adds.
TRANSPORT_KEYS = ('transport_goal_hill_m', 'transport_final_position_error_m', 'transport_orbital_momentum_error_n_m_s',
                  'transport_final_angular_momentum_kg_m2_s', 'transport_wheel_momentum_n_m_s',
                  'transport_wheel_momentum_share', 'transport_conditions_met', 'transport_fuel_kg',
                  'transport_impulses', 'transport_time_s', 'transport_settle_time_s', 'transport_settle_bound_s',
                  'transport_replans', 'transport_terminal_firings')


def wheel_momenta(scenario, wheels_speed_rad_s, omega_body_rad_s):
    """(axes (N, 3), h (N,) [N m s]): the wheels' unit spin axes in chaser_body and each one's axial angular momentum
    from its speed relative to the body, h_i = J (speed_i + a_i . omega) (flyby_sim.dynamics.rigid_body's h)."""
    w = scenario.chaser.wheels
    axes = np.asarray(w.axes, dtype=float)
    axes = axes / np.linalg.norm(axes, axis=1)[:, None]
    return axes, w.spin_inertia_kg_m2 * (np.asarray(wheels_speed_rad_s, dtype=float) + axes @ omega_body_rad_s)


def wheel_momentum_share(scenario, h_n_m_s):
    """The largest share of a wheel's capacity its momentum takes, max_i |h_i| / max_momentum_n_m_s_i."""
    capacity = np.broadcast_to(np.asarray(scenario.chaser.wheels.max_momentum_n_m_s, dtype=float), np.shape(h_n_m_s))
    return float(np.max(np.abs(h_n_m_s) / capacity))


def wheels_at(wheels, t):
    """The index of the wheels' truth sample at or after t (the last one after the end)."""
    return np.searchsorted(wheels.t, t).clip(0, len(wheels.t) - 1)


def truth_bodies(i_c, i_t, chaser, target, wheels_speed, scenario, chaser_mass_kg):
    """(chaser, target) as grasp.Body from the truth samples i_c, i_t (the same stamp), in the inertial frame whose axes
    are hill's then: velocities relative to hill plus Omega^H x r (Omega^H = [0, -n, 0], seed 000 eq 11), the wheels'
    momentum in chaser_body axes from their speeds (h_i = J (speed_i + a_i . omega))."""
    omega_hill = np.array([0.0, -scenario.mean_motion_rad_s, 0.0])
    omega_c = chaser.angular[i_c]
    axes, h_each = wheel_momenta(scenario, wheels_speed, omega_c)
    h_wheels = axes.T @ h_each
    r_c, r_t = chaser.position[i_c], target.position[i_t]
    q_t = target.orientation_xyzw[i_t]
    v_t = quat_rotate(q_t, target.linear[i_t])  # the twist in target_body axes (nav_msgs' rule)
    return (Body(chaser_mass_kg, scenario.chaser_inertia, r_c, chaser.linear[i_c] + np.cross(omega_hill, r_c),
                 chaser.orientation_xyzw[i_c], omega_c, h_wheels),
            Body(scenario.target.mass_kg, scenario.target_inertia, r_t, v_t + np.cross(omega_hill, r_t), q_t,
                 target.angular[i_t]))


def momentum_about_com(bodies):
    """The angular momentum (3,) [kg m^2/s] of free bodies about their common CoM, inertial axes (grasp.momentum about
    the origin, moved), their wheels' included."""
    p, h_origin = momentum(bodies)
    mass = sum(b.mass_kg for b in bodies)
    r_cm = sum(b.mass_kg * b.r_m for b in bodies) / mass
    return h_origin - np.cross(r_cm, p)


def angular_momentum_about_com(bodies):
    """|angular momentum| [kg m^2/s] of free bodies about their common CoM (momentum_about_com, wheels included)."""
    return float(np.linalg.norm(momentum_about_com(bodies)))


def body_angular_momentum(bodies):
    """|angular momentum| [kg m^2/s] of the bodies' own motion about their common CoM, the wheels' left out: of the
    held pair, which turns as one rigid body, the combined body's I omega about its CoM (seed 004 §3.2's condition 1
    on the body; the wheels' momentum is what they hold for it)."""
    return float(np.linalg.norm(momentum_about_com([b._replace(h_wheels_body_n_m_s=(0.0, 0.0, 0.0))
                                                    for b in bodies])))


def post_capture_truth(chaser, target, wheels, thrust, scenario, t_lock=None):
    """(common (N,) [s], i_c, i_t, bodies): the stamps both bodies' truth shares, their indices in the chaser's and the
    target's series, and bodies(k), the (chaser, target) grasp.Body at common[k] (truth_bodies: the wheels' nearest
    sample at or after it, the chaser's mass less the fuel burned by then, or by t_lock (``lock_time``) after it: the
    plant's combined body keeps the CoM and inertia of the lock, its propellant spent at the CoM
    (``chaser_body.SixDofChaser``'s com_body_m), so the CoM of the pair is the plant's only with the lock's masses)."""
    common, i_c, i_t = np.intersect1d(chaser.t, target.t, return_indices=True)
    i_w = wheels_at(wheels, common)
    fuel = np.concatenate(([0.0], np.cumsum(fuel_steps(thrust, scenario)))) if thrust is not None and len(
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
    """After the capture (DESIGN §10), from the truth: the grasp's peak contact force and torque (the arm's
    impedance, ``grasp.Contact.at_first_contact`` of the truth at the capture, at every truth sample of GRASP), the
    damping's time and fuel and the combined body's angular momentum about its CoM at its end (inertial, wheels
    included), the estimator's final estimates of the target (its ``mass_properties_estimated``) and their errors
    against the truth at their stamp (target CoM from the chaser CoM and principal axes in chaser_body; principal
    moments and mass the scenario's). None where a phase did not run."""
    out = dict.fromkeys(POST_CAPTURE_KEYS)
    out['grasp_released'] = any(e['name'] == ev.GRASP_RELEASED for e in events)
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
            steps = fuel_steps(thrust, scenario)
            t_step = thrust.t[1:]
            out['damping_fuel_kg'] = float(np.sum(steps[(t_step > t_damping) & (t_step <= t_damped + 1e-9)]))
    final = [e for e in events if e['name'] == ev.MASS_PROPERTIES_ESTIMATED]
    if not final:
        return out
    e = final[-1]
    estimate = event_payloads.decode_values(ev.MASS_PROPERTIES_ESTIMATED, e['values'])
    mass_kg = estimate.mass_kg
    out.update(target_mass_estimate_kg=mass_kg, target_com_estimate_m=list(estimate.com_body_m),
               target_principal_moments_estimate_kg_m2=list(estimate.principal_moments_kg_m2),
               target_principal_axes_estimate_q=list(estimate.principal_axes_q))
    k = int(np.searchsorted(common, float(e['t']) - 1e-9))
    if k >= len(common):
        return out
    x_s, moments, q_true = target_mass_properties_truth(chaser, target, i_c[k], i_t[k], scenario)
    out.update(target_mass_error_pct=100.0 * abs(mass_kg / scenario.target.mass_kg - 1.0),
               target_com_error_m=float(np.linalg.norm(np.asarray(estimate.com_body_m) - x_s)),
               target_principal_moments_error_pct=100.0 * float(np.max(np.abs(
                   np.asarray(estimate.principal_moments_kg_m2) / moments - 1.0))),
               target_principal_axes_error_deg=math.degrees(float(np.max(principal_axis_errors_rad(
                   np.asarray(estimate.principal_axes_q), q_true)[defined_axes(moments)], initial=0.0))))
    return out


def transport_state(pair, goal_hill_m, mean_motion_rad_s):
    """Seed 004 §3.2's rendezvous quantities of the combined body, the (chaser, target) grasp.Body pair: the CoM's
    distance from the goal [m], its speed relative to the goal's circular motion (the goal fixed in hill) [m/s], its
    linear momentum (m + M) times that speed [N s], the body's own angular momentum about the CoM, wheels excluded
    (body_angular_momentum) [kg m^2/s]."""
    mass = sum(b.mass_kg for b in pair)
    r_cm = sum(b.mass_kg * b.r_m for b in pair) / mass
    v_cm = sum(b.mass_kg * b.v_mps for b in pair) / mass - np.cross((0.0, -mean_motion_rad_s, 0.0), r_cm)
    speed = float(np.linalg.norm(v_cm))
    return (float(np.linalg.norm(r_cm - np.asarray(goal_hill_m))), speed, float(mass) * speed,
            body_angular_momentum(pair))


def transport_figures(chaser, target, wheels, thrust, events, scenario):
    """TRANSPORT (seed 004 §3.2), from the truth at guidance's ``transport_complete`` (the run's end without it): the
    combined CoM's distance from the goal, its linear momentum relative to the goal's circular motion (the goal fixed
    in hill: (m + M) |v_hill| of the CoM) [N s, DESIGN §10's ..._n_m_s key, docs/transport.md], the body's own
    angular momentum about it (wheels excluded), the wheels' momentum |A h| [N m s] and the largest share of a
    wheel's capacity it takes; whether the three rendezvous conditions hold with the wheels within their share
    (post_capture.transport.wheel_momentum_share); the fuel, the number of impulses (runs of consecutive firing
    steps), the events' figures (transport_event_figures). None where TRANSPORT did not run."""
    tr = scenario.post_capture.transport
    out = dict.fromkeys(TRANSPORT_KEYS)
    out['transport_goal_hill_m'] = list(map(float, tr.goal_hill_m))
    t_start = phase_start(events, c.PHASE_TRANSPORT)
    if t_start is None or chaser is None or target is None or chaser.angular is None or target.position is None:
        return out
    done = [e for e in events if e['name'] == ev.TRANSPORT_COMPLETE]
    common, i_c, i_t, bodies = post_capture_truth(chaser, target, wheels, thrust, scenario,
                                                  lock_time(events, scenario))
    t_end = float(done[-1]['t']) if done else float(common[-1])
    k = max(int(np.searchsorted(common, t_end + 1e-9)) - 1, 0)
    pair = bodies(k)
    miss, _, momentum, h = transport_state(pair, tr.goal_hill_m, scenario.mean_motion_rad_s)
    _, h_each = wheel_momenta(scenario, wheels.velocity[wheels_at(wheels, common[k])], chaser.angular[i_c[k]])
    share = wheel_momentum_share(scenario, h_each)
    out.update(transport_final_position_error_m=miss, transport_orbital_momentum_error_n_m_s=momentum,
               transport_final_angular_momentum_kg_m2_s=h,
               transport_wheel_momentum_n_m_s=float(np.linalg.norm(pair[0].h_wheels_body_n_m_s)),
               transport_wheel_momentum_share=share,
               transport_conditions_met=bool(done and share <= tr.wheel_momentum_share and not missed_conditions(
                   {'position_error_m': miss, 'momentum_error_n_s': momentum, 'angular_momentum_kg_m2_s': h}, tr)),
               **transport_event_figures(events, t_start, t_end if done else None))
    if thrust is not None and len(thrust.t) > 1:
        steps = fuel_steps(thrust, scenario)
        t_step = thrust.t[1:]
        window = (t_step > t_start + 1e-9) & (t_step <= t_end + 1e-9)
        out['transport_fuel_kg'] = float(np.sum(steps[window]))
        firing = steps[window] > 0.0
        out['transport_impulses'] = int(np.sum(firing[1:] & ~firing[:-1]) + (1 if len(firing) and firing[0] else 0))
    return out


def transport_event_figures(events, t_start, t_complete):
    """From guidance's events: the time from TRANSPORT's start (t_start) to the first plan's arrival, the time from
    the arrival of the plan flown (the last ``transport_planned``) to ``transport_complete`` at t_complete (None
    without it) and the bound the plan stated for it, the mid-course corrections and the terminal firings."""
    planned = [e for e in events if e['name'] == ev.TRANSPORT_PLANNED]
    out = {'transport_replans': sum(1 for e in events if e['name'] == ev.TRANSPORT_CORRECTION),
           'transport_terminal_firings': sum(1 for e in events if e['name'] == ev.TRANSPORT_TERMINAL)}
    if not planned:
        return out
    out['transport_time_s'] = event_payloads.decode_values(ev.TRANSPORT_PLANNED, planned[0]['values']).t_arrival_s \
        - t_start
    plan = event_payloads.decode_values(ev.TRANSPORT_PLANNED, planned[-1]['values'])
    out['transport_settle_bound_s'] = plan.settle_bound_s
    if t_complete is not None:
        out['transport_settle_time_s'] = t_complete - plan.t_arrival_s
    return out
