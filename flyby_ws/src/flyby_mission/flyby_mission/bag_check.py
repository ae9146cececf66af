"""Recompute a run's figures from the truth topics of its bag and check them against summary.json
(scripts/analyze_bag.py is its command line).

Every figure is recomputed here by a different route than flyby_mission.summary takes, from truth alone:

* delta-v and fuel: the total impulse of /sim/chaser/thrust gives the fuel, each step's net impulse over
  the step's mean mass the delta-v (the summary: the rocket equation per step; a whole-run rocket equation with
  the mean share of net to total thrust misses a six-degree-of-freedom chaser's 3 m/s by 1e-4 m/s);
* grasp time: the stamp of the last planner/grasp published before the supervisor's decision (the
  grasp the mission aimed at; the summary reads the supervisor's decision event); the fly-by offset
  delta r from the last planner/flyby_target, |X_Ft| - |x_g| (eq 20; the summary reads the planner's
  plan_selected event); a docking's final range from guidance's docking_started;
* capture errors: the chaser at t_g by cubic Hermite interpolation of truth position and velocity,
  the target attitude by propagating the nearest truth sample with its body rate (the summary
  interpolates linearly and by slerp). Shared with the summary: the target point in body axes
  (flyby_planner.flyby.grasp_search.capture_target_body: eq 20 for a fly-by, the port's outward normal for a
  docking) and
  its hill state at a given attitude (seed 000 eq 8-9), the one physics;
* clearance: every truth sample against the target boxes by a second implementation (scipy rotation,
  closest point by clamping; the summary uses flyby_sim.dynamics.geometry); thrust inside the sphere:
  every thrusting step's end points; counts from the simulator's own events.
* the six-degree-of-freedom chaser: its velocity turned from chaser_body axes by scipy's rotation (the
  summary by flyby_sim.dynamics.rotation); fuel from each thruster's thrust on /sim/chaser/thrusters, a
  firing being any thruster's (a pure torque too); the pointing error of body +x at the target's CoM as
  the angle between scipy's rotated axis and the line of sight, from the first burn's start to t_g.
* t_g: the stamp of the last planner/grasp before the capture decision; for a synchronized approach's docking
  (which holds its final point and is decided at the chaser estimate's own stamp) the first
  /sensors/chaser/imu stamp at or after it.

* after the capture (a post_capture section, docs/post_capture.md): the approach's delta-v and thrust inside the
  sphere up to the capture (the whole run's fuel); the grasp's peak contact force and torque from the two bodies'
  truth by the arm's impedance written out here with scipy's rotations (the summary: flyby_sim.dynamics.grasp), the
  combined body's angular momentum about its CoM at the end of DAMPING as the sum of both bodies' spin, orbital
  momentum about the common CoM and the wheels' (the summary: grasp.momentum about the origin, moved), the chaser's
  mass less the fuel burned up to the arm's lock (the simulator's combined body keeps the lock's CoM); the
  estimates from the last /estimation/target/inertia message (the summary reads the estimator's final event): its
  mass and CoM, and the principal moments and axes of its inertia by eigendecomposition; their errors against the
  truth at that message's stamp; a run that starts attached has only the estimates.
* a transport (post_capture.transport, docs/transport.md): at guidance's transport_complete, the combined CoM's
  distance from the goal and linear momentum relative to hill, and the body's own angular momentum about it (wheels
  excluded) by the same sum of both bodies (the summary: grasp.Body pairs and grasp.momentum); the wheels' momentum
  and the largest share of a wheel's capacity, and whether the three conditions hold with the wheels within their
  share; the settle time from the arrival transport_complete states (the summary: the plan's transport_planned)
  and the bound it states (the last transport_planned's without it); the counts of corrections and terminal firings.

A run of several chasers (a ``chasers:`` scenario, docs/two_robots.md): every figure above per chaser from its
own topics (``/<name>/sim/chaser/odom``, ``/<name>/sim/chaser/thrust``, ``/<name>/mission/events`` ..., the target's
``/sim/target/odom``) against ``summary.json``'s ``chasers: {name: ...}``, rows ``name.figure``; and the least
distance between two chasers' envelopes over the run (``min_separation_m``, ``t_min_separation_s``) with the
second chaser's truth interpolated onto the first's stamps by cubic Hermite (the summary pairs equal stamps).
"""

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.spatial.transform import Rotation

from flyby_mission.approach_figures import least_clearance_index
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.bag import JointSeries, read_bag
from flyby_planner.flyby.grasp_search import capture_target_body, grasp_from_attitude
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2

# figure -> tolerance of the agreement (its unit)
TOLERANCES = {
    't_grasp_s': 1e-3, 'flyby_offset_m': 1e-6, 'capture_position_error_m': 1e-3, 'capture_velocity_error_mps': 1e-4,
    'delta_v_total_mps': 1e-4, 'fuel_used_kg': 1e-6, 'min_clearance_m': 1e-3, 't_min_clearance_s': 1e-3,
    'sim_time_s': 1e-3, 'thrust_inside_restriction_sphere': 0, 'maneuvers_executed': 0, 'late_maneuvers': 0,
    'rejected_maneuvers': 0, 'pointing_error_p95_deg': 1e-6, 'pointing_error_max_deg': 1e-6,
}
# after the capture (post_capture) -> tolerance; a quaternion's is the largest angle between its axes [deg]
POST_CAPTURE_TOLERANCES = {
    'final_angular_momentum_kg_m2_s': 1e-6, 'peak_grasp_force_n': 1e-6, 'peak_grasp_torque_n_m': 1e-6,
    'target_mass_estimate_kg': 1e-6, 'target_com_estimate_m': 1e-9, 'target_principal_moments_estimate_kg_m2': 1e-6,
    'target_principal_axes_estimate_q': 1e-4, 'target_mass_error_pct': 1e-6, 'target_com_error_m': 1e-9,
    'target_principal_moments_error_pct': 1e-6, 'target_principal_axes_error_deg': 1e-4,
}
# a transport (post_capture.transport) -> tolerance
TRANSPORT_TOLERANCES = {
    'transport_final_position_error_m': 1e-6, 'transport_orbital_momentum_error_n_m_s': 1e-6,
    'transport_final_angular_momentum_kg_m2_s': 1e-6, 'transport_wheel_momentum_n_m_s': 1e-6,
    'transport_wheel_momentum_share': 1e-6, 'transport_conditions_met': 0, 'transport_settle_time_s': 1e-3,
    'transport_settle_bound_s': 1e-6, 'transport_replans': 0, 'transport_terminal_firings': 0,
}
# the figures of several chasers together -> tolerance
FLEET_TOLERANCES = {'min_separation_m': 1e-3, 't_min_separation_s': 1e-3, 'min_clearance_m': 1e-3}
RIGID_ONLY = ('pointing_error_p95_deg', 'pointing_error_max_deg')


class TruthError(ValueError):
    """A truth message no figure can be computed from (a non-finite value); the message names topic, time, field."""


# the fields of the series read_bag returns that hold a truth quantity, finite in every message
_TRUTH_FIELDS = ('position', 'orientation_xyzw', 'linear', 'angular', 'vector', 'point', 'quaternion_xyzw',
                 'force', 'torque')


def check_finite(series, topic):
    """``series`` as it is; ``TruthError`` naming the topic, the stamp and the field of its first message with a
    NaN or an infinity (a joint state's NaN means "not given" and is left alone)."""
    if isinstance(series, JointSeries) or not hasattr(series, 't_received'):
        return series
    for name in _TRUTH_FIELDS:
        values = getattr(series, name, None)
        if values is None or not len(values):
            continue
        bad = ~np.isfinite(values.reshape(len(values), -1)).all(axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            raise TruthError(f'{topic}: non-finite {name} {values[k].tolist()} at t = {series.t[k]:.3f} s '
                             f'(message {k + 1} of {len(values)})')
    return series


def read_truth(bag_dir, topics):
    """read_bag's series of ``topics``, each checked by check_finite."""
    return {topic: check_finite(series, topic) for topic, series in read_bag(bag_dir, topics=topics).items()}


def box_clearance(r_hill, q_hill_from_body, centers_body_m, sizes_m, envelope_radius_m):
    """Gap (N,) between the envelope sphere and the nearest box, by the closest point of each box."""
    p_body = Rotation.from_quat(q_hill_from_body).inv().apply(r_hill)
    gaps = []
    for center, size in zip(centers_body_m, sizes_m, strict=True):
        lo, hi = np.asarray(center) - 0.5 * np.asarray(size), np.asarray(center) + 0.5 * np.asarray(size)
        outside = np.linalg.norm(p_body - np.clip(p_body, lo, hi), axis=1)
        depth = np.minimum(p_body - lo, hi - p_body).min(axis=1)  # > 0 inside: distance to the nearest face
        gaps.append(np.where(outside > 0.0, outside, -np.maximum(depth, 0.0)))
    return np.min(gaps, axis=0) - envelope_radius_m


def _last_sent_before_decision(mission_events, series):
    """Index of the last message of series received before the supervisor decided capture or escape, or None."""
    decided = [e['t'] for e in mission_events if e['name'] == events.PHASE_CHANGED
               and e['values'].get('to') in (c.PHASE_CAPTURE, c.PHASE_ESCAPE)]
    if not decided or series is None or not len(series.t):
        return None
    sent = np.flatnonzero(series.t_received <= decided[0])
    return int(sent[-1]) if len(sent) else None


def aimed_grasp_time(mission_events, grasp):
    """The stamp of the last planner/grasp sent before the supervisor decided capture or escape, or None."""
    k = _last_sent_before_decision(mission_events, grasp)
    return None if k is None else float(grasp.t[k])


def aimed_offset(flyby_target, x_grasp_body):
    """Delta r of the last planner/flyby_target: |X_Ft| - |x_g| (eq 20; every re-aim keeps the plan's), or None."""
    if flyby_target is None or not len(flyby_target.t):
        return None
    return float(np.linalg.norm(flyby_target.position[-1]) - np.linalg.norm(x_grasp_body))


def docking_offset(mission_events):
    """The final range [m] from the port of a synchronized approach's docking (guidance's ``docking_started``), or
    None without a docking."""
    docking = [e['values'] for e in mission_events if e['name'] == events.DOCKING_STARTED]
    return event_payloads.decode_values(events.DOCKING_STARTED, docking[-1]).offset_m if docking else None


def first_sample_at_or_after(t_samples, t):
    """A docking holds its final point and is decided at the first chaser estimate (IMU sample) at or after the
    aimed grasp time: that sample's stamp (t itself when none comes after it)."""
    k = int(np.searchsorted(t_samples, t - 1e-9))
    return float(t_samples[k]) if k < len(t_samples) else t


def _chaser_truth(data, topic, rigid):
    """The chaser's truth series of a topic with its velocity in hill (a rigid body's twist is in chaser_body axes)."""
    chaser = data.get(topic)
    if rigid and chaser is not None and len(chaser.t):
        chaser = chaser._replace(linear=Rotation.from_quat(chaser.orientation_xyzw).apply(chaser.linear))
    return chaser


def phase_entered(mission_events, phase):
    """The stamp [s] of the supervisor's first phase_changed to phase, or None."""
    return next((e['t'] for e in mission_events
                 if e['name'] == events.PHASE_CHANGED and e['values'].get('to') == phase), None)


def _inertial(chaser, target, scenario, j, k):
    """(r, inertial velocity, scipy rotation, inertial rate) of the chaser at sample j and the target at sample k, hill
    axes: the velocity relative to hill plus Omega^H x r, the body rate turned into hill."""
    omega_hill = np.array([0.0, -scenario.mean_motion_rad_s, 0.0])
    out = []
    for odom, i, linear_in_body in ((chaser, j, False), (target, k, True)):
        rot = Rotation.from_quat(odom.orientation_xyzw[i])
        r = np.array(odom.position[i])  # copies: the bag's arrays are read-only, scipy's apply wants them writable
        v = rot.apply(np.array(odom.linear[i])) if linear_in_body else np.array(odom.linear[i])
        out.append((r, v + np.cross(omega_hill, r), rot, rot.apply(np.array(odom.angular[i]))))
    return out


def _grasp_peaks(scenario, chaser, target, mission_events, common, i_c, i_t, t_grasp, t_damping):
    """The arm's peak force and torque over GRASP, the impedance written out with scipy's rotations."""
    g = scenario.post_capture.grasp
    r_g = np.array(scenario.target.grasp_point_body_m, dtype=float)  # writable: scipy's apply wants it
    t_end = t_damping if t_damping is not None else (phase_entered(mission_events, c.PHASE_ESCAPE) or common[-1])
    window = np.flatnonzero((common >= t_grasp - 1e-9) & (common <= t_end + 1e-9))
    (r_c, _, rot_c, _), (r_t, _, rot_t, _) = _inertial(chaser, target, scenario, i_c[window[0]], i_t[window[0]])
    r_ee = np.array([np.linalg.norm(r_t + rot_t.apply(r_g) - r_c), 0.0, 0.0])  # along +x to the handle
    handle_in_target = rot_t.inv() * rot_c  # aligned with the end effector at the first contact
    forces, torques = [], []
    for w in window:
        (r_c, v_c, rot_c, w_c), (r_t, v_t, rot_t, w_t) = _inertial(chaser, target, scenario, i_c[w], i_t[w])
        p_g = r_t + rot_t.apply(r_g)
        dv = v_t + np.cross(w_t, rot_t.apply(r_g)) - v_c - np.cross(w_c, p_g - r_c)
        forces.append(-g.stiffness_n_per_m * (p_g - r_c - rot_c.apply(r_ee)) - g.damping_n_s_per_m * dv)
        e = (rot_t * handle_in_target * rot_c.inv()).as_rotvec()
        torques.append(-g.rot_stiffness_n_m_per_rad * e - g.rot_damping_n_m_s_per_rad * (w_t - w_c))
    return {'peak_grasp_force_n': float(np.max(np.linalg.norm(forces, axis=1))),
            'peak_grasp_torque_n_m': float(np.max(np.linalg.norm(torques, axis=1)))}


def _pair_at(bag_dir, scenario, chaser, target, fuel_at, namespace, common, i_c, i_t, k):
    """(the angular momentum about the common CoM [kg m^2/s], hill axes: both bodies' spin and their orbit about the
    common CoM, the wheels' left out; the wheels' momentum, hill axes [N m s], and each wheel's (N,) [N m s]; the
    total mass [kg], the common CoM [m] and its velocity relative to hill [m/s]) at common[k]."""
    (r_c, v_c, rot_c, w_c), (r_t, v_t, rot_t, w_t) = _inertial(chaser, target, scenario, i_c[k], i_t[k])
    m_c, m_t = scenario.chaser.mass_kg - fuel_at(common[k]), scenario.target.mass_kg
    r_cm, v_cm = (m_c * r_c + m_t * r_t) / (m_c + m_t), (m_c * v_c + m_t * v_t) / (m_c + m_t)
    wheels_topic = c.absolute(c.SIM_CHASER_WHEELS, namespace)
    wheels = read_truth(bag_dir, topics=[wheels_topic])[wheels_topic]
    w = scenario.chaser.wheels
    axes = np.asarray(w.axes, dtype=float) / np.linalg.norm(w.axes, axis=1)[:, None]
    speed = wheels.velocity[int(np.argmin(np.abs(wheels.t - common[k])))]
    h_each = w.spin_inertia_kg_m2 * (speed + axes @ chaser.angular[i_c[k]])
    momentum = sum(rot.apply(inertia @ rot.inv().apply(rate)) + mass * np.cross(r - r_cm, v - v_cm)
                   for rot, inertia, rate, mass, r, v in ((rot_c, scenario.chaser_inertia, w_c, m_c, r_c, v_c),
                                                          (rot_t, scenario.target_inertia, w_t, m_t, r_t, v_t)))
    omega_hill = np.array([0.0, -scenario.mean_motion_rad_s, 0.0])
    return momentum, rot_c.apply(h_each @ axes), h_each, m_c + m_t, r_cm, v_cm - np.cross(omega_hill, r_cm)


def transport(bag_dir, scenario, chaser, target, mission_events, fuel_at, namespace=''):
    """The transport figures of TRANSPORT_TOLERANCES at guidance's transport_complete (the bag's end without it), by
    the same second route as the damping's momentum (module doc)."""
    out = dict.fromkeys(TRANSPORT_TOLERANCES)
    if phase_entered(mission_events, c.PHASE_TRANSPORT) is None:
        return out
    common, i_c, i_t = np.intersect1d(chaser.t, target.t, return_indices=True)
    done = [e for e in mission_events if e['name'] == events.TRANSPORT_COMPLETE]
    t_end = done[-1]['t'] if done else common[-1]
    k = max(int(np.searchsorted(common, t_end + 1e-9)) - 1, 0)
    momentum, h_wheels, h_each, mass, r_cm, v_cm = _pair_at(bag_dir, scenario, chaser, target, fuel_at, namespace,
                                                            common, i_c, i_t, k)
    tr = scenario.post_capture.transport
    h, miss = float(np.linalg.norm(momentum)), float(np.linalg.norm(r_cm - np.asarray(tr.goal_hill_m)))
    linear = mass * float(np.linalg.norm(v_cm))
    share = float(np.max(np.abs(h_each) / scenario.chaser.wheels.max_momentum_n_m_s))
    planned = [e['values'] for e in mission_events if e['name'] == events.TRANSPORT_PLANNED]
    stated = done[-1]['values'] if done else planned[-1] if planned else {}  # the arrival and settle bound
    out.update(transport_final_position_error_m=miss, transport_orbital_momentum_error_n_m_s=linear,
               transport_final_angular_momentum_kg_m2_s=h, transport_wheel_momentum_n_m_s=float(np.linalg.norm(
                   h_wheels)), transport_wheel_momentum_share=share,
               transport_conditions_met=bool(done and h < tr.max_angular_momentum_kg_m2_s
                                             and miss < tr.max_position_error_m
                                             and linear < tr.max_momentum_error_n_s
                                             and share <= tr.wheel_momentum_share),
               transport_settle_time_s=done[-1]['t'] - float(stated['t_arrival_s']) if done else None,
               transport_settle_bound_s=float(stated['settle_bound_s']) if 'settle_bound_s' in stated else None,
               transport_replans=sum(1 for e in mission_events if e['name'] == events.TRANSPORT_CORRECTION),
               transport_terminal_firings=sum(1 for e in mission_events if e['name'] == events.TRANSPORT_TERMINAL))
    return out


def post_capture(bag_dir, scenario, chaser, target, mission_events, fuel_at, namespace=''):
    """The post-capture figures of POST_CAPTURE_TOLERANCES by the module doc's second route (a run that starts
    attached has no grasp and no damping: its estimates only)."""
    out = dict.fromkeys(POST_CAPTURE_TOLERANCES)
    t_grasp, t_damping = phase_entered(mission_events, c.PHASE_GRASP), phase_entered(mission_events, c.PHASE_DAMPING)
    if t_grasp is None and scenario.post_capture.start != 'attached':
        return out
    common, i_c, i_t = np.intersect1d(chaser.t, target.t, return_indices=True)
    if t_grasp is not None:
        out.update(_grasp_peaks(scenario, chaser, target, mission_events, common, i_c, i_t, t_grasp, t_damping))
    if t_damping is not None:
        t_damped = phase_entered(mission_events, c.PHASE_MASS_ESTIMATION) or common[-1]
        k = int(np.searchsorted(common, t_damped + 1e-9)) - 1
        momentum, h_wheels = _pair_at(bag_dir, scenario, chaser, target, fuel_at, namespace, common, i_c, i_t, k)[:2]
        out['final_angular_momentum_kg_m2_s'] = float(np.linalg.norm(momentum + h_wheels))
    elif t_grasp is not None:
        return out
    inertia_topic = c.absolute(c.EST_TARGET_INERTIA, namespace)
    messages = read_truth(bag_dir, topics=[inertia_topic])[inertia_topic].messages
    if not messages:
        return out
    last = messages[-1]
    i = last.inertia
    inertia = np.array([[i.ixx, i.ixy, i.ixz], [i.ixy, i.iyy, i.iyz], [i.ixz, i.iyz, i.izz]])
    moments, axes_est = np.linalg.eigh(inertia)
    com = np.array([i.com.x, i.com.y, i.com.z])
    t_est = last.header.stamp.sec + 1e-9 * last.header.stamp.nanosec
    k = int(np.searchsorted(common, t_est - 1e-9))
    (r_c, _, rot_c, _), (r_t, _, rot_t, _) = _inertial(chaser, target, scenario, i_c[k], i_t[k])
    true_moments, true_axes_target = np.linalg.eigh(scenario.target_inertia)
    true_axes = (rot_c.inv() * rot_t).apply(true_axes_target.T).T
    out.update(target_mass_estimate_kg=float(i.m), target_com_estimate_m=com.tolist(),
               target_principal_moments_estimate_kg_m2=moments.tolist(),
               target_principal_axes_estimate_q=axes_est,  # compared by angle (compare)
               target_mass_error_pct=100.0 * abs(i.m / scenario.target.mass_kg - 1.0),
               target_com_error_m=float(np.linalg.norm(com - rot_c.inv().apply(r_t - r_c))),
               target_principal_moments_error_pct=100.0 * float(np.max(np.abs(moments / true_moments - 1.0))),
               # only the axes the true moments define (two equal moments: the third alone, checked here by hand)
               target_principal_axes_error_deg=float(np.degrees(np.max(np.arccos(np.clip(np.abs(np.sum(
                   axes_est * true_axes, axis=0)), 0.0, 1.0))[[
                       min(abs(true_moments[k] - true_moments[j]) for j in range(3) if j != k) > 1e-9 * true_moments[2]
                       for k in range(3)]], initial=0.0))))
    return out


def _propellant(scenario, thrust, thrusters, chaser, mission_events, rigid):
    """Fuel, delta-v up to the capture and thrust inside the restriction sphere (module doc) with the stamps of the
    thrust steps and each step's fuel [kg] (None without two thrust samples): (figures, thrust, fuel_steps)."""
    th = scenario.chaser.thrusters
    v_exhaust = th.isp_s * STANDARD_GRAVITY_M_S2
    m0 = scenario.chaser.mass_kg
    out = {'delta_v_total_mps': 0.0, 'fuel_used_kg': 0.0, 'thrust_inside_restriction_sphere': False}
    if thrust is None or len(thrust.t) <= 1:
        return out, thrust, None
    impulse = np.linalg.norm(thrust.force[1:], axis=1) * np.diff(thrust.t)
    firing = np.concatenate(([False], impulse > 0.0))
    if rigid:  # every thruster's impulse; the net force's share of it gives the delta-v
        n = min(len(thrusters.t), len(thrust.t))
        each = thrusters.effort[1:n] * np.diff(thrusters.t[:n])[:, None]
        fuel_steps, impulse = each.sum(axis=1) / v_exhaust, impulse[:n - 1]
        firing = np.concatenate(([False], (each > 0.0).any(axis=1)))
        thrust = thrust._replace(t=thrust.t[:n])
    else:
        fuel_steps = impulse / v_exhaust
    out['fuel_used_kg'] = float(fuel_steps.sum())
    mass_mean = m0 - np.cumsum(fuel_steps) + 0.5 * fuel_steps  # over each step
    idx = np.searchsorted(chaser.t, thrust.t).clip(0, len(chaser.t) - 1)
    inside = np.linalg.norm(chaser.position[idx], axis=1) < scenario.planner.restriction_sphere_radius_m
    approach = np.ones(len(thrust.t), bool)  # up to the capture when the mission goes on after it
    t_capture = phase_entered(mission_events, c.PHASE_GRASP) if scenario.post_capture is not None else None
    if scenario.post_capture is not None and scenario.post_capture.start == 'attached':
        t_capture = 0.0  # held from the start: no approach
    if t_capture is not None:
        approach = thrust.t <= t_capture + 1e-9
    out['delta_v_total_mps'] = float(np.sum((impulse / mass_mean)[approach[1:]]))
    out['thrust_inside_restriction_sphere'] = bool(np.any(firing & (inside | np.roll(inside, 1)) & approach))
    return out, thrust, fuel_steps


def _grasp_time(bag_dir, mission_events, grasp, rigid, docking_m, namespace):
    """t_g (module doc): the aimed grasp time, for a six-degree-of-freedom chaser's docking the first IMU stamp at
    or after it; None without one."""
    t_g = aimed_grasp_time(mission_events, grasp)
    if t_g is not None and rigid and docking_m is not None:  # the IMU decoded only for a docking: it is large
        imu_topic = c.absolute(c.SENSOR_CHASER_IMU, namespace)
        imu = read_truth(bag_dir, topics=[imu_topic]).get(imu_topic)
        if imu is not None:
            t_g = first_sample_at_or_after(np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
                                                     for m in imu.messages]), t_g)
    return t_g


def _capture_errors(scenario, chaser, target, t_g, x_grasp_body, offset_m, docking):
    """The chaser's position and velocity errors [m, m/s] at t_g against the capture point (module doc)."""
    spline = CubicHermiteSpline(chaser.t, chaser.position, chaser.linear)
    r, v = spline(t_g), np.array([np.interp(t_g, chaser.t, chaser.linear[:, j]) for j in range(3)])
    j = int(np.argmin(np.abs(target.t - t_g)))
    n = scenario.mean_motion_rad_s
    w_body = target.angular[j]
    # Body rotation over dt (body rate about constant over <= 25 ms), then the hill frame's own
    # turn by n dt about -y: q_hb(t_g) = R_y(n dt) q_hb(t_j) exp(w dt).
    dt = t_g - target.t[j]
    q = (Rotation.from_rotvec((0.0, n * dt, 0.0)) * Rotation.from_quat(target.orientation_xyzw[j])
         * Rotation.from_rotvec(w_body * dt)).as_quat()
    x_target_body = capture_target_body('sync' if docking else 'flyby', x_grasp_body, offset_m,
                                        [(b.center_m, b.size_m) for b in scenario.target.geometry])
    x_ft, v_ft = grasp_from_attitude(q, w_body, x_target_body, n)
    return {'capture_position_error_m': float(np.linalg.norm(r - x_ft)),
            'capture_velocity_error_mps': float(np.linalg.norm(v - v_ft))}


def _fuel_at(scenario, thrust, fuel_steps, mission_events):
    """fuel_at(t): the fuel burned [kg] up to t, held at the arm's lock."""
    fuel_t = thrust.t[1:] if thrust is not None and len(thrust.t) > 1 else np.zeros(0)
    fuel_cum = np.cumsum(fuel_steps) if len(fuel_t) else np.zeros(0)
    # The simulator's combined body keeps the CoM and inertia of the arm's lock (its grasp_damped, t = 0 for
    # a start attached) while its propellant burns: the pair's masses stay the lock's after it.
    t_lock = 0.0 if scenario.post_capture.start == 'attached' else next(
        (e['t'] for e in mission_events if e['name'] == events.GRASP_DAMPED), float('inf'))

    def fuel_at(t):
        n = int(np.searchsorted(fuel_t, min(t, t_lock) + 1e-9))
        return float(fuel_cum[n - 1]) if n else 0.0
    return fuel_at


def _relative_figures(bag_dir, scenario, chaser, target, mission_events, grasp, offset_m, rigid, namespace):
    """Clearance, grasp time, offset, capture errors and pointing: the figures of the chaser against the target."""
    out = {}
    x_grasp_body = np.array(scenario.target.grasp_point_body_m)
    common, i_c, i_t = np.intersect1d(chaser.t, target.t, return_indices=True)
    gaps = box_clearance(chaser.position[i_c] - target.position[i_t], target.orientation_xyzw[i_t],
                         scenario.boxes.center_body_m, scenario.boxes.size_m, scenario.chaser.envelope_radius_m)
    k = least_clearance_index(gaps)
    out['min_clearance_m'], out['t_min_clearance_s'] = float(gaps[k]), float(common[k])
    docking_m = docking_offset(mission_events)
    if docking_m is not None:  # the port plus the final range along its outward normal (DESIGN §10)
        offset_m = docking_m
    t_g = _grasp_time(bag_dir, mission_events, grasp, rigid, docking_m, namespace)
    out['t_grasp_s'] = t_g
    out['flyby_offset_m'] = offset_m
    if t_g is not None and chaser.t[0] <= t_g <= chaser.t[-1]:
        out.update(_capture_errors(scenario, chaser, target, t_g, x_grasp_body, offset_m, docking_m is not None))
    if rigid:
        out.update(pointing(chaser, mission_events, t_g))
    return out


def recompute(bag_dir, scenario, namespace=''):
    """Every figure of TOLERANCES (and POST_CAPTURE_TOLERANCES) from the truth topics of the bag (of the chaser under
    ``namespace``)."""
    rigid = scenario.chaser.model == 'rigid_body'
    topics = [c.absolute(t, namespace) for t in (c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM, c.SIM_CHASER_THRUST,
                                                 c.MISSION_EVENTS, c.PLANNER_GRASP, c.PLANNER_FLYBY_TARGET)]
    thrusters_topic = c.absolute(c.SIM_CHASER_THRUSTERS, namespace)
    data = read_truth(bag_dir, topics=topics + ([thrusters_topic] if rigid else []))
    chaser, target = _chaser_truth(data, topics[0], rigid), data.get(topics[1])
    thrust, mission_events, grasp = data.get(topics[2]), data.get(topics[3]) or [], data.get(topics[4])
    offset_m = aimed_offset(data.get(topics[5]), np.array(scenario.target.grasp_point_body_m))
    out = {k: None for k in TOLERANCES if rigid or k not in RIGID_ONLY}
    sim_events = [e for e in mission_events if e.get('hardware_id') == 'flyby_sim']
    for key, name in (('maneuvers_executed', events.BURN_STARTED), ('late_maneuvers', events.LATE_MANEUVER),
                      ('rejected_maneuvers', events.MANEUVER_REJECTED)):
        out[key] = sum(1 for e in sim_events if e['name'] == name)
    if chaser is None or not len(chaser.t):
        return out
    out['sim_time_s'] = float(chaser.t[-1])
    figures, thrust, fuel_steps = _propellant(scenario, thrust, data[thrusters_topic] if rigid else None, chaser,
                                              mission_events, rigid)
    out.update(figures)
    if target is not None and len(target.t):
        out.update(_relative_figures(bag_dir, scenario, chaser, target, mission_events, grasp, offset_m, rigid,
                                     namespace))
        if scenario.post_capture is not None:
            fuel_at = _fuel_at(scenario, thrust, fuel_steps, mission_events)
            out.update(post_capture(bag_dir, scenario, chaser, target, mission_events, fuel_at, namespace))
            if scenario.post_capture.transport is not None:
                out.update(transport(bag_dir, scenario, chaser, target, mission_events, fuel_at, namespace))
    return out


def pointing(chaser, mission_events, t_g):
    """Angle between body +x (scipy's rotation of the truth attitude) and the line of sight to the target's
    CoM, from the first burn's start (or a tracked trajectory's start) to t_g (or the end): 95th percentile and
    largest [deg]."""
    starts = [float(e['values']['t_start']) for e in mission_events
              if e['name'] == events.BURN_STARTED and e.get('hardware_id') == 'flyby_sim']
    starts += [float(e['values']['t_start_s']) for e in mission_events  # an optimal approach's tracking
               if e['name'] == events.GUIDANCE_STARTED and 't_start_s' in e['values']]
    if not starts:
        return {'pointing_error_p95_deg': None, 'pointing_error_max_deg': None}
    window = (chaser.t >= min(starts)) & (chaser.t <= (chaser.t[-1] if t_g is None else t_g))
    axis = Rotation.from_quat(chaser.orientation_xyzw[window]).apply((1.0, 0.0, 0.0))
    sight = -chaser.position[window] / np.linalg.norm(chaser.position[window], axis=1)[:, None]
    angle = np.degrees(np.arctan2(np.linalg.norm(np.cross(axis, sight), axis=1), np.sum(axis * sight, axis=1)))
    return {'pointing_error_p95_deg': float(np.percentile(angle, 95.0)), 'pointing_error_max_deg': float(angle.max())}


def fleet_figures(bag_dir, scenario, per_chaser):
    """The figures of several chasers together (FLEET_TOLERANCES): the least envelope separation of every pair,
    the second's truth interpolated onto the first's stamps (module doc), and the least clearance of any chaser
    (per_chaser: {name: recompute(...)})."""
    truth = {}
    for name in scenario.chaser_names:
        view = scenario.for_chaser(name)
        topic = c.absolute(c.SIM_CHASER_ODOM, f'/{name}')
        series = _chaser_truth(read_truth(bag_dir, topics=[topic]), topic, view.chaser.model == 'rigid_body')
        if series is not None and len(series.t) > 1:
            truth[name] = (series, view.chaser.envelope_radius_m)
    best = (None, None)
    names = list(truth)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            (sa, ra), (sb, rb) = truth[a], truth[b]
            inside = (sa.t >= sb.t[0]) & (sa.t <= sb.t[-1])
            r_b = CubicHermiteSpline(sb.t, sb.position, sb.linear)(sa.t[inside])
            gap = np.linalg.norm(sa.position[inside] - r_b, axis=1) - ra - rb
            k = int(np.argmin(gap))
            if best[0] is None or gap[k] < best[0]:
                best = (float(gap[k]), float(sa.t[inside][k]))
    clearances = [figures['min_clearance_m'] for figures in per_chaser.values()]
    return {'min_separation_m': best[0], 't_min_separation_s': best[1],
            'min_clearance_m': None if None in clearances else min(clearances)}


def axes_angle_deg(q_body_from_principal, axes):
    """The largest angle [deg] between the principal axes of a quaternion (x, y, z, w) and the columns of axes (3, 3),
    in order, signs ignored (an axis is a line)."""
    columns = Rotation.from_quat(q_body_from_principal).as_matrix()
    return float(np.degrees(np.max(np.arccos(np.clip(np.abs(np.sum(columns * np.asarray(axes), axis=0)), 0.0, 1.0)))))


def compare(summary, recomputed, tolerances=TOLERANCES):
    """Rows (figure, summary value, recomputed value, agrees); lists agree element by element, a principal-axes
    quaternion with recomputed axes by their angle (axes_angle_deg), each axis with the recomputed one of its
    moment's rank (the estimator's principal axes keep the filter's order, the eigendecomposition's ascend: two
    nearly equal estimated moments may come in either order), the moments in ascending order."""
    rows = []
    moments = summary.get('target_principal_moments_estimate_kg_m2')
    for key, tol in tolerances.items():
        if key not in recomputed:  # a figure of the six-degree-of-freedom chaser only
            continue
        a, b = summary.get(key), recomputed.get(key)
        if a is not None and key == 'target_principal_moments_estimate_kg_m2':
            a = sorted(a)
        if a is None or b is None:
            agrees = a is None and b is None
        elif key.endswith('_q'):
            angle = axes_angle_deg(a, np.asarray(b)[:, np.argsort(np.argsort(moments))])
            agrees, b = angle <= tol, f'{angle:.3g} deg off'
        elif isinstance(a, list):
            agrees = len(a) == len(b) and float(np.max(np.abs(np.subtract(a, b)))) <= tol
        elif isinstance(a, bool) or tol == 0:
            agrees = a == b
        else:
            agrees = abs(float(a) - float(b)) <= tol
        rows.append((key, a, b, agrees))
    return rows


def recompute_run(bag_dir, scenario):
    """Every figure of a run: recompute's, or for several chasers recompute's of each by name besides
    fleet_figures'."""
    names = scenario.chaser_names
    if not names:
        return recompute(bag_dir, scenario)
    recomputed = {n: recompute(bag_dir, scenario.for_chaser(n), f'/{n}') for n in names}
    recomputed.update(fleet_figures(bag_dir, scenario, dict(recomputed)))
    return recomputed


def compare_run(summary, recomputed, scenario):
    """compare's rows for a run (recompute_run's figures): the tolerances of the scenario's sections, or for several
    chasers each one's rows as ``name.figure`` and then the fleet's."""
    names = scenario.chaser_names
    if names:
        rows = [(f'{n}.{key}', a, b, agrees) for n in names
                for key, a, b, agrees in compare(summary.get('chasers', {}).get(n, {}), recomputed[n])]
        return rows + compare(summary, recomputed, FLEET_TOLERANCES)
    pc = scenario.post_capture
    return compare(summary, recomputed, {**TOLERANCES, **(POST_CAPTURE_TOLERANCES if pc is not None else {}),
                                         **(TRANSPORT_TOLERANCES if pc is not None and pc.transport is not None
                                            else {})})
