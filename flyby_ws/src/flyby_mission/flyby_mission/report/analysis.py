"""Quantities of a run (loading.Run) that the figures of every mission draw: range and range rate, the estimation
errors with their 3 sigma at the truth's stamps, the clearances to the target, the chaser's attitude estimate, the
pointing requirement's window and the firings inside the restriction sphere."""

import math

import numpy as np

from flyby_mission.report.loading import match_stamps, velocity_covariance_hill, velocity_hill
from flyby_mission.run_events import grasp_time
from flyby_msgs_py import contract as c
from flyby_sim.dynamics.geometry import clearance
from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, rotation_vector_from_quat


def range_and_rate(series):
    """(range |r| [m], range rate [m/s]) (N,) of an Odometry series, its velocity in hill axes."""
    r = np.linalg.norm(series.position, axis=1)
    return r, np.sum(series.position * velocity_hill(series), axis=1) / np.maximum(r, 1e-9)


def sigma3(covariance, block):
    """3 sigma (N, 3) of the diagonal of a block (slice) of covariances (N, 6, 6)."""
    return 3.0 * np.sqrt(np.maximum(np.diagonal(covariance[:, block, block], axis1=1, axis2=2), 0.0))


def matched_pairs(run, est_topic, truth_topic):
    """(estimate, truth, i_est, i_truth) at the same stamps, or the reason there is none."""
    est, truth = run.get(est_topic), run.get(truth_topic)
    if est is None or truth is None:
        return f'no {c.absolute(est_topic if est is None else truth_topic)}'
    i_est, i_truth = match_stamps(est.t, truth.t)
    if not len(i_est):
        return f'no {c.absolute(est_topic)} stamp matches {c.absolute(truth_topic)}'
    return est, truth, i_est, i_truth


def estimation_errors(run):
    """The four rows of estimation.png: (quantity, unit, t, error (N, 3), 3 sigma (N, 3)), or
    (quantity, reason) for a row the run has no data for.

    Errors are estimate minus truth at the same stamps; the chaser velocity and its covariance in hill
    axes (velocity_hill: the rigid-body chaser's twist is in chaser_body axes). The target attitude
    error is the rotation vector of q_est q_true^-1, i.e. about hill axes like the pose covariance the
    estimator publishes (flyby_estimation.target_motion.PredictedState.covariance_hill); the body-rate
    error and its covariance are in body axes.
    """
    pos, rot = slice(0, 3), slice(3, 6)
    deg = math.degrees(1.0)
    rows = []
    chaser = matched_pairs(run, c.EST_CHASER_ODOM, c.SIM_CHASER_ODOM)
    if isinstance(chaser, str):
        rows += [('chaser position', chaser), ('chaser velocity (hill axes)', chaser)]
    else:
        e, tr, i, j = chaser
        rows.append(('chaser position', 'm', e.t[i], e.position[i] - tr.position[j],
                     sigma3(e.pose_covariance[i], pos)))
        rows.append(('chaser velocity (hill axes)', 'm/s', e.t[i], velocity_hill(e)[i] - velocity_hill(tr)[j],
                     sigma3(velocity_covariance_hill(e)[i], pos)))
    target = matched_pairs(run, c.EST_TARGET_ODOM, c.SIM_TARGET_ODOM)
    if isinstance(target, str):
        rows += [('target attitude', target), ('target body rate', target)]
    else:
        e, tr, i, j = target
        dtheta = np.array([rotation_vector_from_quat(quat_multiply(q_est, quat_conjugate(q_true)))
                           for q_est, q_true in zip(e.orientation_xyzw[i], tr.orientation_xyzw[j], strict=True)])
        rows.append(('target attitude (hill axes)', 'deg', e.t[i], dtheta * deg,
                     sigma3(e.pose_covariance[i], rot) * deg))
        rows.append(('target body rate (body axes)', 'deg/s', e.t[i], (e.angular[i] - tr.angular[j]) * deg,
                     sigma3(e.twist_covariance[i], rot) * deg))
    return rows


def clearances(run):
    """(t, gap to the target's boxes [m], gap to the swept region [m] or None) over the truth."""
    scenario = run.need_scenario()
    chaser, target, i_c, i_t = run.truth_pair()
    t, r = chaser.t[i_c], chaser.position[i_c]
    envelope = scenario.chaser.envelope_radius_m
    boxes = list(zip(scenario.boxes.center_body_m, scenario.boxes.size_m, strict=True))
    actual = clearance(r, target.orientation_xyzw[i_t], boxes, envelope)
    swept = None if run.region is None else run.region.clearance(r, t, scenario.mean_motion_rad_s, envelope)
    return t, actual, swept


def continuous_quaternions(q):
    """Quaternions (N, 4) (x, y, z, w) each multiplied by +-1 so that neighbours agree in sign and the first
    has w >= 0 (q and -q are one attitude): their components then plot as continuous curves."""
    q = np.array(q, dtype=float)
    if not len(q):
        return q
    flips = np.concatenate(([q[0, 3] < 0.0], np.einsum('ij,ij->i', q[1:], q[:-1]) < 0.0))
    return q * np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)[:, None]


def chaser_attitude_estimate(run):
    """(estimate, truth, i_est, i_truth): the chaser estimates that carry an attitude (a nonzero orientation
    covariance) at the truth's stamps, or the reason there are none."""
    matched = matched_pairs(run, c.EST_CHASER_ODOM, c.SIM_CHASER_ODOM)
    if isinstance(matched, str):
        return matched
    e, tr, i, j = matched
    keep = np.any(e.pose_covariance[i, 3:, 3:] != 0.0, axis=(1, 2))
    if not np.any(keep):
        return f'no {c.absolute(c.EST_CHASER_ODOM)} sample carries an attitude (zero orientation covariance)'
    return e, tr, i[keep], j[keep]


def pointing_window(run):
    """(t_start, t_end) [s] of the pointing requirement: the first burn's start to the grasp (else the end of
    the truth), as approach_figures.pointing_figures; None before any burn."""
    if not run.burns:
        return None
    t_g = grasp_time(run.events)
    return min(b.t_start for b in run.burns), (t_g if t_g is not None else run.t_end)


def firing_inside_sphere(run, t, firing):
    """How many of the samples at times t with firing (N,) true fired inside the restriction sphere: the
    truth range below the radius at the sample or at the one before (a sample's thrust acted between
    them), as approach_figures.thrust_figures counts; None without truth or scenario."""
    chaser = run.get(c.SIM_CHASER_ODOM)
    if chaser is None or run.scenario is None or not len(t):
        return None
    inside = np.interp(t, chaser.t, np.linalg.norm(chaser.position, axis=1)) < \
        run.scenario.planner.restriction_sphere_radius_m
    inside[1:] |= inside[:-1]
    return int(np.sum(firing & inside))
