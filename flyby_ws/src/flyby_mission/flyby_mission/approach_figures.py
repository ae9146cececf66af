"""The approach's and the capture's figures of a run (DESIGN §7, §10 ``summary.json``), from the truth: delta-v,
fuel and thrust inside the restriction sphere, the six-degree-of-freedom chaser's pointing, a thrusting approach's
(seed 003) and a synchronized approach's (seed 001) figures, the capture errors at the grasp time and the least
clearance's sample."""

import math

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from flyby_mission.run_events import phase_windows
from flyby_msgs_py import contract as c
from flyby_msgs_py import events as ev
from flyby_planner.flyby.grasp_search import grasp_from_attitude
from flyby_sim.dynamics.attitude_control import pointing_error_rad
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2
from flyby_sim.dynamics.rotation import quat_rotate_many


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
    time (or the end of the truth): 95th percentile and largest [deg]; None where neither started."""
    starts = [float(e['values']['t_start']) for e in events
              if e['name'] == ev.BURN_STARTED and 't_start' in e['values']]
    starts += [float(e['values']['t_start_s']) for e in events
               if e['name'] == ev.GUIDANCE_STARTED and 't_start_s' in e['values']]
    t_end = t_g if t_g is not None else chaser.t[-1]
    window = (chaser.t >= min(starts, default=math.inf)) & (chaser.t <= t_end)
    if not np.any(window):
        return {'pointing_error_p95_deg': None, 'pointing_error_max_deg': None}
    error_deg = np.degrees(pointing_error_rad(chaser.orientation_xyzw[window], chaser.position[window]))
    return {'pointing_error_p95_deg': float(np.percentile(error_deg, 95.0)),
            'pointing_error_max_deg': float(np.max(error_deg))}


def approach_figures(chaser, thrust, events, scenario):
    """The figures of a thrusting approach (seed 003 Table 1), from the truth: the peak thrust acceleration
    [m/s^2] (net force over the mass less the fuel spent), the approach time [s] of the last optimal plan, and what
    fired at the target within planner.optimal.plume_radius_m of its centre of mass: the net force's impulse away
    from the target [N s] (the plume rule's quantity) and, for the rigid-body chaser, the thrusters' impulse
    component toward the target [N s] (each thruster's exhaust direction, nominal, dotted with the line of sight;
    lateral thrusters count by the pointing error)."""
    plans = [e['values'] for e in events if e['name'] == ev.PLAN_SELECTED and e['values'].get('method') == 'optimal']
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


def sync_figures(chaser, target, thrust, events, t_g):
    """The synchronized approach's figures (seed 001), from the truth: per phase the peak thrust force [N]
    and the thrusters' peak torque [N m] (each step's mean, the step counted in the phase it ends in), and the
    largest drift [deg] of the chaser's attitude relative to the target's from the start of stage 3 (ORBITING) to
    the grasp time (seed 001 Fig 6: the relative orientation constant there), or None where it did not run."""
    out = {'peak_force_n_by_phase': None, 'peak_thruster_torque_n_m_by_phase': None,
           'relative_attitude_drift_max_deg': None}
    if not any(e['name'] == ev.PLAN_SELECTED and e['values'].get('method') == 'sync' for e in events):
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
              if e['name'] == ev.PHASE_CHANGED and e['values'].get('to') == c.PHASE_ORBITING]
    if starts and t_g is not None and chaser.orientation_xyzw is not None and target is not None:
        common, i_c, i_t = np.intersect1d(chaser.t, target.t, return_indices=True)
        window = (common >= starts[0] - 1e-9) & (common <= t_g + 1e-9)
        if np.any(window):
            relative = (Rotation.from_quat(target.orientation_xyzw[i_t[window]]).inv()
                        * Rotation.from_quat(chaser.orientation_xyzw[i_c[window]]))
            drift = (relative[0].inv() * relative).magnitude()
            out['relative_attitude_drift_max_deg'] = float(np.degrees(drift.max()))
    return out


def capture_errors(t_g, chaser, target, x_target_body, n):
    """Truth chaser at t_g against the target point x_target_body (body axes,
    flyby_planner.flyby.grasp_search.capture_target_body: X_Ft, V_Ft of eq 20-21 for a fly-by) recomputed from the
    true target attitude at t_g (DESIGN §7, §10).

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


# Clearances within this of the least are a tie: a plateau (the chaser attached after the grasp) has no argmin
# that two routes computing the same gaps to ~1e-12 m agree on.
CLEARANCE_TIE_M = 1e-6


def least_clearance_index(gaps):
    """Index of the first sample whose clearance is within CLEARANCE_TIE_M of the least (t_min_clearance_s)."""
    gaps = np.asarray(gaps, dtype=float)
    return int(np.flatnonzero(gaps <= gaps.min() + CLEARANCE_TIE_M)[0])
