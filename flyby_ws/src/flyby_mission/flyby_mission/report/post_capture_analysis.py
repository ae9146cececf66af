"""Seed 004's quantities (Matsunaga et al.) of a run after the capture (docs/post_capture.md, docs/transport.md): the
combined body's motion during MASS_ESTIMATION (Fig 5 (a)-(d)), the target's mass-property estimates against the
truth (Fig 5 (e)-(h)), the arm's contact during GRASP, the angular momentum during DAMPING and the state against
the rendezvous conditions during TRANSPORT (Fig 7). The truth is taken by flyby_mission.summary's functions, so
that the figures show summary.json's numbers."""

from __future__ import annotations

import json
import typing

import numpy as np
from scipy.spatial.transform import Rotation

from flyby_estimation.mass_properties_errors import principal_axis_errors_rad
from flyby_mission.post_capture_figures import (
    angular_momentum_about_com,
    damping_window,
    grasp_contact_series,
    target_mass_properties_truth,
    transport_state,
)
from flyby_mission.report.analysis import chaser_attitude_estimate, continuous_quaternions, sigma3
from flyby_mission.report.loading import Skipped
from flyby_msgs_py import contract as c
from flyby_msgs_py import events
from flyby_msgs_py.convert import inertia_to_numpy
from flyby_msgs_py.wire import STAMP_TOLERANCE_S
from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, quat_to_matrix_many, rotation_vector_from_quat


class CombinedMotion(typing.NamedTuple):
    """Seed 004 Fig 5 (a)-(d) (combined_motion): the combined body's motion during MASS_ESTIMATION."""

    t: np.ndarray                  # (N,) [s] truth stamps of both bodies in the window
    r_com_hill: np.ndarray         # (N, 3) [m] the combined CoM in hill (truth)
    v_com_inertial: np.ndarray     # (N, 3) [m/s] its inertial velocity, hill axes of each instant (truth)
    q_hill_from_body: np.ndarray   # (N, 4) chaser_body (the combined body's axes) in hill (truth)
    omega_body: np.ndarray         # (N, 3) [rad/s] inertial, chaser_body axes (truth)
    t_est: np.ndarray              # (K,) [s] /estimation/chaser/odom stamps with a truth sample, in the window
    q_est: np.ndarray              # (K, 4) the attitude filter's q_hill_from_body, signs as the truth's
    omega_est: np.ndarray          # (K, 3) [rad/s] its rate
    attitude_error_hill: np.ndarray  # (K, 3) [rad] rotation vector of q_est q_true^-1 (hill axes)
    attitude_sigma3_hill: np.ndarray  # (K, 3) [rad] its 3 sigma (the pose covariance's orientation block)
    rate_error_body: np.ndarray    # (K, 3) [rad/s] estimate - truth
    rate_sigma3_body: np.ndarray   # (K, 3) [rad/s] its 3 sigma


def combined_motion(run):
    """Seed 004 Fig 5 (a)-(d) over MASS_ESTIMATION: the combined body's CoM position and velocity from both bodies'
    truth (their grasp.Body, post_capture_figures.post_capture_truth, the masses of the lock), and its
    attitude and rate, which are the chaser's (one rigid body), truth and the estimate the mission publishes: the
    chaser's attitude filter on /estimation/chaser/odom. The mass-property filter's own r, v, q, omega are not
    published: the combined CoM has no estimate (its chaser position stays the capture's, docs/post_capture.md)."""
    t0, t1 = run.phase_window(c.PHASE_MASS_ESTIMATION)
    common, i_c, _, bodies = run.bodies
    ks = np.flatnonzero((common >= t0 - STAMP_TOLERANCE_S) & (common <= t1 + STAMP_TOLERANCE_S))
    if not len(ks):
        raise Skipped('no truth sample in MASS_ESTIMATION')
    r_com, v_com = [], []
    for k in ks:
        pair = bodies(k)
        mass_kg = sum(b.mass_kg for b in pair)
        r_com.append(sum(b.mass_kg * b.r_m for b in pair) / mass_kg)
        v_com.append(sum(b.mass_kg * b.v_mps for b in pair) / mass_kg)
    chaser = run.need(c.SIM_CHASER_ODOM)
    q_true = continuous_quaternions(chaser.orientation_xyzw[i_c[ks]])
    estimate = chaser_attitude_estimate(run)
    if isinstance(estimate, str):
        raise Skipped(estimate)
    e, tr, i, j = estimate
    keep = (e.t[i] >= t0 - STAMP_TOLERANCE_S) & (e.t[i] <= t1 + STAMP_TOLERANCE_S)
    i, j = i[keep], j[keep]
    q_est = e.orientation_xyzw[i]
    q_est = q_est * np.where(np.einsum('ij,ij->i', q_est, tr.orientation_xyzw[j]) < 0.0, -1.0, 1.0)[:, None]
    q_est = q_est * np.where(q_est @ q_true[0] < 0.0, -1.0, 1.0)[:, None]  # the truth's continuous sign
    dtheta = np.array([rotation_vector_from_quat(quat_multiply(a, quat_conjugate(b)))
                       for a, b in zip(e.orientation_xyzw[i], tr.orientation_xyzw[j], strict=True)]).reshape(-1, 3)
    return CombinedMotion(common[ks], np.array(r_com), np.array(v_com), q_true, chaser.angular[i_c[ks]],
                          e.t[i], q_est, e.angular[i], dtheta, sigma3(e.pose_covariance[i], slice(3, 6)),
                          e.angular[i] - tr.angular[j], sigma3(e.twist_covariance[i], slice(3, 6)))


class MassPropertyEstimates(typing.NamedTuple):
    """Seed 004 Fig 5 (e)-(h) (mass_property_estimates): the estimates with their 1-sigma and the truth."""

    t: np.ndarray                       # (K,) [s] stamps of /estimation/target/inertia
    mass_kg: np.ndarray                 # (K,) the message's target mass
    mass_sigma_kg: np.ndarray           # (K,) the event's
    com_body_m: np.ndarray              # (K, 3) the message's X_s: target CoM from the chaser CoM, chaser_body
    com_sigma_m: np.ndarray             # (K, 3)
    true_com_at_estimate_m: np.ndarray  # (K, 3) X_s from both bodies' truth at each estimate's stamp
    moments_kg_m2: np.ndarray           # (K, 3) the event's principal moments, the filter's order (the truth's)
    moments_sigma_kg_m2: np.ndarray     # (K, 3)
    axes_error_rad: np.ndarray          # (K, 3) dphi: q_true^-1 q_est as a rotation vector in principal axes
    axes_sigma_rad: np.ndarray          # (K, 3) the filter's sigma of dphi
    axes_angle_rad: np.ndarray          # (K, 3) angle of each estimated principal axis from the true one
    inertia_body_kg_m2: np.ndarray      # (K, 3, 3) the message's inertia about the target CoM, chaser_body
    true_mass_kg: float                 # the scenario's (the plant's truth)
    true_moments_kg_m2: np.ndarray      # (3,) the scenario's, ascending
    t_truth: np.ndarray                 # (N,) [s] truth stamps in MASS_ESTIMATION
    true_com_body_m: np.ndarray         # (N, 3) X_s from both bodies' truth
    prior: dict | None                  # the estimator's mass_properties_prior values (no sigmas) and its t


def _json_values(event, keys):
    """The event's JSON-array values of keys as float arrays."""
    return {k: np.array(json.loads(event['values'][k]), dtype=float) for k in keys}


def nearest_principal_axes_error(q_body_from_principal_est, q_body_from_principal_true):
    """dphi (3,) [rad], the rotation vector of q_true^-1 q_est (principal axes: the mass-property filter's
    Q = Q_ref exp(dphi), flyby_estimation.mass_properties), of the four sign choices of the true axes that keep them
    right-handed the one nearest the estimate (an axis is a line: its sign is a convention)."""
    c_est = quat_to_matrix_many(np.asarray(q_body_from_principal_est, dtype=float)[None, :])[0]
    c_true = quat_to_matrix_many(np.asarray(q_body_from_principal_true, dtype=float)[None, :])[0]
    candidates = [Rotation.from_matrix((c_true * np.array(signs)).T @ c_est).as_rotvec()
                  for signs in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))]
    return min(candidates, key=np.linalg.norm)


def mass_property_estimates(run):
    """Seed 004 Fig 5 (e)-(h): the target's mass, CoM and inertia as /estimation/target/inertia gives them, their
    1-sigma and principal form from the mass_properties_estimate(d) event of the same stamp (the estimator's
    _mass_outputs), and the truth: mass and principal moments the scenario's, X_s and the principal axes in
    chaser_body from both bodies' truth (post_capture_figures.target_mass_properties_truth, as summary.json's errors).
    The principal axes' error is dphi (nearest_principal_axes_error) against the truth at the estimate's stamp (the
    first truth stamp at or after it, as the summary takes it)."""
    scenario = run.need_scenario()
    messages = run.need(c.EST_TARGET_INERTIA).messages
    t0, t1 = run.phase_window(c.PHASE_MASS_ESTIMATION)
    chaser, target = run.need(c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM)
    common, i_c, i_t, _ = run.bodies
    estimate_events = {round(e['t'], 6): e for e in run.events
                       if e['name'] in (events.MASS_PROPERTIES_ESTIMATE, events.MASS_PROPERTIES_ESTIMATED)}
    rows = []
    for msg in messages:
        t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        event = estimate_events.get(round(t, 6))
        k = int(np.searchsorted(common, t - 1e-9))
        if event is None or k >= len(common):
            continue
        mass_kg, com, inertia = inertia_to_numpy(msg.inertia)
        v = _json_values(event, ('com_sigma_m', 'principal_moments_kg_m2', 'principal_moments_sigma_kg_m2',
                                 'principal_axes_q', 'principal_axes_sigma_rad'))
        x_s, true_moments, q_true = target_mass_properties_truth(chaser, target, i_c[k], i_t[k], scenario)
        rows.append((t, mass_kg, float(event['values']['mass_sigma_kg']), com, v['com_sigma_m'], x_s,
                     v['principal_moments_kg_m2'], v['principal_moments_sigma_kg_m2'],
                     nearest_principal_axes_error(v['principal_axes_q'], q_true), v['principal_axes_sigma_rad'],
                     principal_axis_errors_rad(v['principal_axes_q'], q_true), inertia))
    if not rows:
        raise Skipped(f'no {c.absolute(c.EST_TARGET_INERTIA)} message with its 1-sigma event and a truth sample')
    window = np.flatnonzero((common >= t0 - STAMP_TOLERANCE_S) & (common <= t1 + STAMP_TOLERANCE_S))
    true_com = np.array([target_mass_properties_truth(chaser, target, i_c[k], i_t[k], scenario)[0] for k in window])
    prior = next((e for e in run.events if e['name'] == events.MASS_PROPERTIES_PRIOR), None)
    if prior is not None:
        prior = {'t': float(prior['t']), 'mass_kg': float(prior['values']['mass_kg']),
                 **_json_values(prior, ('com_body_m', 'principal_moments_kg_m2'))}
    columns = [np.array(col) for col in zip(*rows, strict=True)]
    return MassPropertyEstimates(*columns, scenario.target.mass_kg, true_moments, common[window],
                                 true_com.reshape(-1, 3), prior)


def grasp_contact(run):
    """(t (N,) [s], |force| (N,) [N], |torque| (N,) [N m], |stroke| (N,) [m]) of the arm on the target at every truth
    stamp of GRASP: post_capture_figures.grasp_contact_series, the arm's impedance recomputed from both bodies'
    truth (its peak is summary.json's peak_grasp_force_n and peak_grasp_torque_n_m); Skipped without GRASP."""
    common, _, _, bodies = run.bodies
    t, force, torque, stroke = grasp_contact_series(run.events, common, bodies, run.need_scenario())
    if not len(t):
        raise Skipped('no truth sample in GRASP')
    return t, *(np.array([np.linalg.norm(v) for v in series]) for series in (force, torque, stroke))


def damping_momentum(run):
    """(t (N,) [s], |H| (N,) [kg m^2/s]) of the combined body about its CoM (inertial, wheels included:
    post_capture_figures.angular_momentum_about_com of both bodies' truth) at every truth stamp of DAMPING, to the
    sample summary.json's final_angular_momentum_kg_m2_s is taken at (seed 004 §3.2's condition 1)."""
    common, _, _, bodies = run.bodies
    t_damping, t_damped = damping_window(run.events, run.t_end)
    if t_damping is None:
        raise Skipped('no DAMPING phase')
    ks = np.flatnonzero((common >= t_damping - 1e-9) & (common <= t_damped + 1e-9))
    return common[ks], np.array([angular_momentum_about_com(bodies(k)) for k in ks])


TRANSPORT_SAMPLE_S = 0.5  # Fig 7's sample period: a transport is thousands of seconds of 20 Hz truth


def transport_series(run):
    """(t (N,) [s], distance to the goal (N,) [m], speed relative to the goal's circular motion (N,) [m/s], linear
    momentum (N,) [N s], angular momentum about the combined CoM (N,) [kg m^2/s]): flyby_mission.summary's
    transport_state of both bodies' truth every TRANSPORT_SAMPLE_S from TRANSPORT's start to the run's end."""
    common, _, _, bodies = run.bodies
    t_start, _ = run.phase_window(c.PHASE_TRANSPORT)
    ks = np.flatnonzero(common >= t_start - 1e-9)
    if not len(ks):
        raise Skipped('no truth sample in TRANSPORT')
    step = max(1, int(round(TRANSPORT_SAMPLE_S / max(float(np.median(np.diff(common))), 1e-9))))
    ks = np.unique(np.append(ks[::step], ks[-1]))
    tr = run.need_scenario().post_capture.transport
    rows = np.array([transport_state(bodies(k), tr.goal_hill_m, run.need_scenario().mean_motion_rad_s) for k in ks])
    return common[ks], rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]
