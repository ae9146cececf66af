"""batch.py: the batch maximum-likelihood fit of the torque-free attitude motion (seed 000 eq 4)."""

import math

import numpy as np
import pytest
from scipy.stats import chi2

from flyby_estimation.batch import _rotation_vectors, error_between, fit_attitude_motion
from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.orbital import q_hill_from_body
from flyby_sim.dynamics.rotation import (
    quat_from_axis_angle,
    quat_multiply,
    quat_normalize,
    rotation_vector_from_quat,
)

DEG = math.radians(1.0)
N_RAD_S = 1.1e-3
INERTIA = np.diag([1000.0, 1500.0, 2200.0])  # no axis of symmetry: a real tumble


def tumble(times, q0=(0.1, -0.3, 0.2, 0.9), omega0=(0.05, 0.2, -0.1)):
    """True q_eci_from_body and omega_body at times [s] (flyby_sim's DOP853 integrator) and the
    matching noise-free q_hill_from_body measurements."""
    prop = AttitudePropagator(quat_normalize(q0), omega0, INERTIA)
    states = [prop.state_at(t) for t in times]
    return states, np.array([q_hill_from_body(t, N_RAD_S, q) for t, (q, _) in zip(times, states, strict=True)])


def test_noise_free_tumble_is_recovered_from_a_distant_start():
    times = np.arange(1, 201) * 0.1
    states, z = tumble(times)
    q_end, omega_end = states[-1]
    q_guess = quat_multiply(q_end, quat_from_axis_angle([0.0, 1.0, 1.0], 3.0 * DEG))
    fit = fit_attitude_motion(times, z, N_RAD_S, INERTIA, DEG, q_guess, omega_end + 0.5 * DEG)
    gap = error_between(fit.q_eci_from_body, fit.omega_body, q_end, omega_end)
    assert np.abs(gap).max() < 1e-8
    assert fit.chi2 < 1e-9 and fit.t == times[-1] and fit.samples == 200
    # The bound of 20 s of 1 deg data: attitude near sigma / sqrt(N), rate finite and positive definite
    assert np.linalg.eigvalsh(fit.covariance).min() > 0.0
    assert 0.01 * DEG < math.sqrt(fit.covariance[0, 0]) < 0.3 * DEG


def test_fit_errors_over_seeds_have_the_spread_of_the_bound():
    """Gaussian body-frame noise (the plant's sensor model): the NEES of the fit error against the
    Cramer-Rao bound, averaged over 40 seeds, is that of a 6-dof Gaussian."""
    times = np.arange(1, 151) * 0.1
    states, z = tumble(times)
    q_end, omega_end = states[-1]
    sigma = 0.5 * DEG
    errors, bound = [], None
    for seed in range(40):
        rng = np.random.default_rng(seed)
        noisy = [quat_multiply(q, quat_from_axis_angle(v, np.linalg.norm(v)))
                 for q, v in zip(z, sigma * rng.standard_normal((times.size, 3)), strict=True)]
        fit = fit_attitude_motion(times, noisy, N_RAD_S, INERTIA, sigma, q_end, omega_end)
        errors.append(error_between(fit.q_eci_from_body, fit.omega_body, q_end, omega_end))
        bound = fit.covariance
    errors = np.array(errors)
    nees = np.einsum('ki,ij,kj->k', errors, np.linalg.inv(bound), errors)
    lo, hi = chi2.ppf([0.0005, 0.9995], 6 * 40) / 40
    assert lo < nees.mean() < hi, (lo, nees.mean(), hi)


@pytest.mark.parametrize('times, z, match', [
    ([0.0, 0.1], [[0, 0, 0, 1]] * 2, 'times_s'),
    ([0.0, 0.2, 0.1], [[0, 0, 0, 1]] * 3, 'times_s'),
    ([0.0, 0.1, 0.2], [[0, 0, 0, 1]] * 2, 'q_hill_from_body_meas'),
    ([0.0, 0.1, 0.2], [[0, 0, 0, 1], [0, 0, 0, 1], [0, 0, math.nan, 1]], 'q_hill_from_body_meas'),
])
def test_malformed_window_is_refused_naming_the_argument(times, z, match):
    with pytest.raises(ValueError, match=match):
        fit_attitude_motion(times, z, N_RAD_S, INERTIA, DEG, [0, 0, 0, 1], [0, 0, 0.1])
    with pytest.raises(ValueError, match='attitude_sigma_rad'):
        fit_attitude_motion([0.0, 0.1, 0.2], [[0, 0, 0, 1]] * 3, N_RAD_S, INERTIA, 0.0, [0, 0, 0, 1], [0, 0, 0.1])


def test_vectorized_log_map_is_rotation_vector_from_quat():
    """The residuals' log map on stacked quaternions equals flyby_sim's one-at-a-time map: non-unit
    quaternions, negative w (the short way round), angles under its 1e-6 rad series threshold, and pi."""
    rng = np.random.default_rng(11)
    q = list(rng.standard_normal((20, 4)) * 1.7)
    q += [quat_from_axis_angle([1.0, 2.0, -1.0], angle) for angle in (0.0, 3e-7, 2e-6, 0.1, math.pi)]
    q += [-quat_from_axis_angle([0.3, -1.0, 0.2], 1e-7), [0.0, 0.0, 1.0, 0.0]]
    expected = np.array([rotation_vector_from_quat(qk) for qk in q])
    np.testing.assert_allclose(_rotation_vectors(np.array(q).T).T, expected, rtol=1e-14, atol=1e-22)
