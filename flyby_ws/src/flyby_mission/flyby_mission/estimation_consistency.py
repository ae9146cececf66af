"""Seeded runs of the target attitude filter on the pure Plant: NEES, accuracy and efficiency against truth
(scripts/estimation_consistency.py is the Monte Carlo over seeds and its statistics).

A run feeds the Plant's vision attitude measurements (10 Hz) to a fresh TargetAttitudeFilter for ``duration_s``
after the first measurement and records, once per second, the 6-dof error e = [dtheta_body, domega_body] (true
relative to estimated) and its NEES e' P^-1 e. At ``accuracy_time_s`` after the first measurement: the attitude and
rate errors, the error of the grasp point predicted ``horizon_s`` past that time (seed 000 eq 8) against the true
attitude integrated by flyby_sim.dynamics.attitude.AttitudePropagator from the Plant's initial state, and the filter
against the batch maximum-likelihood fit of the same measurements (flyby_estimation.batch).
"""

import math

import numpy as np

from flyby_estimation.batch import error_between
from flyby_estimation.filter_interface import REJECTION_KINDS
from flyby_estimation.params import TargetFilterParams
from flyby_estimation.target_filter import ConvergenceThresholds, TargetAttitudeFilter
from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.orbital import q_eci_from_body, q_hill_from_body
from flyby_sim.dynamics.rotation import quat_to_matrix
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario


def run_one(path, seed, duration_s, horizon_s, accuracy_time_s=60.0):
    """One seeded run: (times, NEES per time, accuracy dict, rejected counts)."""
    sc = load_scenario(path, seed=seed)
    config = PlantConfig.from_scenario(sc)
    plant = Plant(config)
    n = plant.mean_motion_rad_s
    filt = TargetAttitudeFilter(TargetFilterParams.from_scenario(sc).config())
    times, nees = [], []
    accuracy = None
    t_first = None
    next_sample = None
    while t_first is None or plant.t < t_first + duration_s - 1e-9:
        truth = plant.step()
        for m in plant.measurements():
            if m.kind != 'target_attitude':
                continue
            filt.update(m.t, m.value)  # a rejection is counted by the filter
        if not filt.initialized:
            continue
        if t_first is None:
            t_first, next_sample = filt.t, filt.t + 1.0
        if truth.t >= next_sample - 1e-9 and filt.t == truth.t:
            next_sample += 1.0
            state = filt.state()
            q_eci_true = q_eci_from_body(truth.t, n, truth.q_hill_from_body)
            e = error_between(state.q_eci_from_body, state.omega_body, q_eci_true, truth.omega_body)
            times.append(truth.t - t_first)
            nees.append(float(e @ np.linalg.solve(state.covariance, e)))
            if accuracy is None and truth.t - t_first >= accuracy_time_s - 1e-9:
                accuracy = accuracy_at(sc, config, filt, state, e, n, horizon_s)
                accuracy.update(efficiency_at(filt, (q_eci_true, truth.omega_body)))
    return np.array(times), np.array(nees), accuracy, {kind: filt.counts[kind] for kind in REJECTION_KINDS}


def accuracy_at(sc, config, filt, state, e, n, horizon_s):
    """Attitude and rate errors [deg, deg/s] of e, and the grasp point predicted horizon_s ahead against truth."""
    x_body = np.array(sc.target.grasp_point_body_m)
    t_pred = filt.t + horizon_s
    predicted = filt.body_point_in_hill(x_body, t_pred)
    q_eci0 = q_eci_from_body(0.0, n, config.q_hill_from_body0)
    q_eci_true, _ = AttitudePropagator(q_eci0, config.omega_body0, config.target_inertia).state_at(t_pred)
    q_hill_true = q_hill_from_body(t_pred, n, q_eci_true)
    r_err = predicted.r_hill - quat_to_matrix(q_hill_true) @ x_body
    # spin-axis component of the rate error: along the estimated angular velocity
    axis = state.omega_body / np.linalg.norm(state.omega_body)
    return dict(attitude_deg=math.degrees(np.linalg.norm(e[:3])), rate_deg_s=math.degrees(np.linalg.norm(e[3:])),
                rate_along_spin_deg_s=math.degrees(abs(float(e[3:] @ axis))),
                grasp_err_m=float(np.linalg.norm(r_err)),
                grasp_sigma_m=math.sqrt(float(np.trace(predicted.covariance[:3, :3]))),
                converged=filt.convergence(ConvergenceThresholds.from_scenario(sc)))


def efficiency_at(filt, truth):
    """The filter against the batch maximum-likelihood fit of the same measurements (module doc)."""
    check = filt.batch_check()
    fit = check.fit
    e_fit = error_between(fit.q_eci_from_body, fit.omega_body, *truth)
    return dict(gap_sigma=check.gap_sigma, ratio_min=check.ratio_min, ratio_max=check.ratio_max,
                fit_rate_deg_s=math.degrees(np.linalg.norm(e_fit[3:])),
                crb_rate_deg_s=math.degrees(math.sqrt(np.trace(fit.covariance[3:, 3:]))),
                crb_rate_cov=fit.covariance[3:, 3:])
