"""chaser_attitude_filter.py: the chaser's attitude and gyro-bias MEKF against a truth of its own.

The truth is a torque-free rigid body (``flyby_sim.dynamics.attitude.AttitudePropagator``, seed 001's
servicer) sampled at the IMU rate; the measurements are drawn here from the plant's sensor model with a
seeded Generator (``simulate_imu``), not by ``flyby_sim.sensors``, so the filter is checked against the
model it was written for, independently of the plant's implementation.
scripts/bench/benchmark_chaser_attitude.py imports ``simulate_imu``, ``run_filter`` and ``campaign`` from here.
"""

import dataclasses
import math
import types
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from flyby_estimation.chaser_attitude_filter import (
    ChaserAttitudeFilter,
    ChaserAttitudeFilterConfig,
    error_transition,
    gyro_process_noise,
    steady_state,
    step_rotation_vector,
)
from flyby_estimation.filter_interface import UPDATE_KINDS, EstimationFilter, kalman_update_first_three
from flyby_estimation.params import ChaserAttitudeFilterParams
from flyby_sim.dynamics.attitude import AttitudePropagator, quaternion_rate
from flyby_sim.dynamics.orbital import mean_motion_rad_s, q_hill_from_body, q_hill_from_body_many
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_axis_angle,
    quat_from_rotation_vector,
    quat_multiply,
    quat_normalize,
    quat_to_matrix,
    random_small_rotation,
    rotation_vector_from_quat,
    skew,
)
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
SERVICER_INERTIA = np.diag([13.0, 38.0, 35.0])  # seed 001 Table 1 [kg m^2]
N_RAD_S = mean_motion_rad_s(7.0e6)  # paper_flyby's orbit (radius 7000 km)
# The scenario schema's sensor defaults (paper_flyby leaves sensors.chaser_imu out).
CONFIG = ChaserAttitudeFilterParams.from_scenario(load_scenario(SCENARIOS / 'paper_flyby.yaml')).config(
    mean_motion_rad_s=N_RAD_S)
TUMBLE_RATE_RAD_S = 0.05  # about 2.9 deg/s, the slew rate limit of docs/chaser_6dof.md
NEES_RUNS = 50
NEES_DURATION_S = 300.0
STEADY_WINDOW_S = (200.0, 300.0)  # the steady-state window of the campaign (bias converged by ~150 s)


# -- the truth and the sensor model ---------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, eq=False)
class ImuRun:
    """One simulated run: truth and IMU samples at t (N,).

    q_eci_from_body (N, 4), omega_body (N, 3) [rad/s] and bias_rad_s (N, 3): the truth at each sample;
    omega_meas (N, 3): the gyro samples; star: {sample index: q_hill_from_body measured}.
    """

    t: np.ndarray
    q_eci_from_body: np.ndarray
    omega_body: np.ndarray
    bias_rad_s: np.ndarray
    omega_meas: np.ndarray
    star: dict


def simulate_imu(rng, config, duration_s, q_eci_from_body0, omega_body0, inertia=SERVICER_INERTIA):
    """The chaser IMU model (docs/chaser_6dof.md) on a torque-free body from t = 0 to duration_s, every 1/rate_hz.

    gyro: omega_meas_k = omega_body(t_k) + b_k + sigma_g n_k, b_0 ~ N(0, sigma_b0^2 I),
    b_k = b_(k-1) + sigma_bw sqrt(dt) m_k; star tracker every rate_hz / star_tracker_rate_hz samples
    from the first: q_hill_from_body(t_k) * exp(sigma_st N(0, I3)) (rotation.random_small_rotation).
    Draws, in this order: b_0 (3), m (N, 3; m_0 unused), n (N, 3), then 3 per star-tracker sample.
    """
    rate = config.rate_hz
    count = int(round(duration_s * rate)) + 1
    t = np.arange(count) / rate
    q_eci, omega = AttitudePropagator(q_eci_from_body0, omega_body0, inertia).states_at(t)
    b0 = config.gyro_bias_sigma_rad_s * rng.standard_normal(3)
    walk = config.gyro_bias_walk_rad_s_sqrt_s * math.sqrt(1.0 / rate) * rng.standard_normal((count, 3))
    walk[0] = 0.0
    bias = b0 + np.cumsum(walk, axis=0)
    omega_meas = omega + bias + config.gyro_noise_sigma_rad_s * rng.standard_normal((count, 3))
    every = int(round(rate / config.star_tracker_rate_hz))
    index = np.arange(0, count, every)
    q_hill = q_hill_from_body_many(t[index], config.mean_motion_rad_s, q_eci[index])
    star = {int(k): quat_multiply(q, random_small_rotation(rng, config.star_tracker_sigma_rad))
            for k, q in zip(index, q_hill, strict=True)}
    return ImuRun(t, q_eci, omega, bias, omega_meas, star)


def tumble_run(seed, config=CONFIG, duration_s=NEES_DURATION_S, rate_rad_s=TUMBLE_RATE_RAD_S):
    """simulate_imu of the servicer tumbling at rate_rad_s about a random axis from a random attitude,
    everything drawn from default_rng([13, seed])."""
    rng = np.random.default_rng([13, seed])
    q0 = Rotation.random(random_state=rng).as_quat()
    axis = rng.standard_normal(3)
    return simulate_imu(rng, config, duration_s, q0, rate_rad_s * axis / np.linalg.norm(axis))


def rotation_vectors(q):
    """log of each quaternion (N, 4) (x, y, z, w) as a rotation vector (N, 3) [rad], the short way."""
    q = np.where(q[:, 3:] < 0.0, -q, q)
    s = np.linalg.norm(q[:, :3], axis=1)
    angle = 2.0 * np.arctan2(s, q[:, 3])
    k = np.where(s > 1e-12, angle / np.maximum(s, 1e-300), 2.0 / q[:, 3])
    return q[:, :3] * k[:, None]


@dataclasses.dataclass(frozen=True, eq=False)
class FilterRun:
    """A filter over one ImuRun: error [dtheta_body, dbias] of the truth from the estimate (N, 6), the
    filter's covariance (N, 6, 6), NEES (N,), the star-tracker results and the filter."""

    error: np.ndarray
    covariance: np.ndarray
    nees: np.ndarray
    results: list
    filt: ChaserAttitudeFilter


def run_filter(run, config=CONFIG, star=None):
    """Feed every IMU sample of run to a new filter (on_imu) and compare each estimate with the truth."""
    star = run.star if star is None else star
    f = ChaserAttitudeFilter(config)
    count = run.t.size
    q_est, bias_est, cov = np.empty((count, 4)), np.empty((count, 3)), np.empty((count, 6, 6))
    results = []
    for k in range(count):
        _, result = f.on_imu(run.t[k], run.omega_meas[k], star.get(k))
        if result is not None:
            results.append(result)
        e = f.estimate()
        q_est[k], bias_est[k], cov[k] = e.q_eci_from_body, e.bias_rad_s, e.covariance
    error = np.hstack((rotation_vectors(quat_multiply(quat_conjugate(q_est.T), run.q_eci_from_body.T).T),
                       run.bias_rad_s - bias_est))
    nees = np.einsum('ni,ni->n', error, np.linalg.solve(cov, error[:, :, None])[:, :, 0])
    return FilterRun(error, cov, nees, results, f)


def campaign(runs=NEES_RUNS, duration_s=NEES_DURATION_S, config=CONFIG):
    """run_filter over tumble_run(0 .. runs-1): (t, [FilterRun])."""
    out = [run_filter(tumble_run(i, config, duration_s), config) for i in range(runs)]
    return np.arange(out[0].nees.size) / config.rate_hz, out


@pytest.fixture(scope='module')
def nees_campaign():
    return campaign()


# -- consistency and accuracy ---------------------------------------------------------------------------
def test_nees_over_50_tumbling_runs_is_inside_the_95_percent_band(nees_campaign):
    """The 6-state NEES averaged over 50 seeded runs (300 s each, 2.9 deg/s tumble)
    lies in the two-sided 95 % chi-square band of 50 x 6 dof at >= 95 % of the sampled times (every
    second from 5 s), and its mean over all samples is near 6."""
    t, runs = nees_campaign
    mean_nees = np.mean([r.nees for r in runs], axis=0)
    low, high = chi2.ppf(0.025, 6 * NEES_RUNS) / NEES_RUNS, chi2.ppf(0.975, 6 * NEES_RUNS) / NEES_RUNS
    sampled = mean_nees[(t >= 5.0) & (np.round(t * CONFIG.rate_hz) % CONFIG.rate_hz == 0)]
    inside = np.mean((sampled >= low) & (sampled <= high))
    assert inside >= 0.95, f'{inside:.3f} of the times inside [{low:.2f}, {high:.2f}]; mean {sampled.mean():.2f}'
    assert 5.7 < mean_nees[t >= 5.0].mean() < 6.3
    # The gate at 0.9999 rejects about 1 in 10^4 genuine samples: at most a few of the 30,050
    outliers = sum(r.kind == 'outlier' for run in runs for r in run.results)
    assert outliers <= 10 and not any(r.kind == 'reset' for run in runs for r in run.results)


def test_bias_converges_and_its_error_is_the_filters_sigma(nees_campaign):
    """From sigma_b0 = 1e-4 rad/s to its steady state (~8e-7 rad/s) within 150 s; the bias error's spread
    over the runs is the filter's own sigma (3 axes x 50 runs: within 25 %)."""
    t, runs = nees_campaign
    sigma_ss = steady_state(CONFIG).bias_sigma_rad_s
    k150 = int(np.searchsorted(t, 150.0))
    sigma_150 = np.array([np.sqrt(np.diag(r.covariance[k150])[3:]) for r in runs])
    assert np.all(sigma_150 < 1.5 * sigma_ss)
    for k in (k150, t.size - 1):
        error = np.array([r.error[k, 3:] for r in runs])
        sigma = np.array([np.sqrt(np.diag(r.covariance[k])[3:]) for r in runs])
        ratio = np.sqrt(np.mean((error / sigma) ** 2))
        assert 0.75 < ratio < 1.25, (t[k], ratio)
    assert np.sqrt(np.mean([r.error[-1, 3:] ** 2 for r in runs])) < 0.02 * CONFIG.gyro_bias_sigma_rad_s


def test_steady_state_attitude_error_is_a_sixth_of_the_star_trackers(nees_campaign):
    """Accuracy against the star tracker's noise: over 200-300 s of the 50 runs the rms attitude error per
    body axis, every IMU sample, is the steady state of the filter's model (discrete Riccati equation,
    ``steady_state``: 0.154 sigma_st for an inertially fixed body, 0.143-0.149 sigma_st turning at 2.9
    deg/s, so the bound below is the fixed body's with 15 % for the 50-run statistics), far below
    sigma_st: the gyro averages about 40 star-tracker samples."""
    t, runs = nees_campaign
    window = (t >= STEADY_WINDOW_S[0]) & (t <= STEADY_WINDOW_S[1])
    error = np.concatenate([r.error[window, :3] for r in runs])
    rms = np.sqrt(np.mean(error ** 2, axis=0))
    bound = steady_state(CONFIG).attitude_sigma_rad
    sigma_filter = np.sqrt(np.mean(np.concatenate([np.diagonal(r.covariance[window], axis1=1, axis2=2)[:, :3]
                                                   for r in runs]), axis=0))
    assert np.all(rms < 1.15 * bound), (rms / CONFIG.star_tracker_sigma_rad, bound / CONFIG.star_tracker_sigma_rad)
    assert np.all(rms > 0.8 * 0.143 * CONFIG.star_tracker_sigma_rad)
    assert np.all(rms < 0.2 * CONFIG.star_tracker_sigma_rad)
    np.testing.assert_allclose(rms / sigma_filter, 1.0, atol=0.15)  # the filter's sigma is the error's


def test_filter_covariance_settles_on_the_riccati_steady_state():
    """An inertially fixed body, 600 s: the filter's P just after a star-tracker sample is steady_state's
    posterior (the filter's step loop and the Riccati equation of its model agree), and the Riccati
    solution is the fixed point of the recursion iterated by hand."""
    run = simulate_imu(np.random.default_rng(5), CONFIG, 600.0, (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    fr = run_filter(run)
    ss = steady_state(CONFIG)
    np.testing.assert_allclose(fr.covariance[-1], ss.posterior, rtol=2e-3, atol=1e-3 * ss.posterior[5, 5])
    # The Riccati recursion by hand: update, then five gyro steps
    phi = error_transition((0.0, 0.0, 0.0), 0.1)
    qd = gyro_process_noise(CONFIG.gyro_noise_sigma_rad_s ** 2 / CONFIG.rate_hz,
                            CONFIG.gyro_bias_walk_rad_s_sqrt_s ** 2, 0.1)
    p = ss.prior
    r = CONFIG.star_tracker_sigma_rad ** 2 * np.eye(3)
    _, _, p = kalman_update_first_three(np.zeros((6, 1)), p, np.zeros(3), r)
    for _ in range(5):
        p = phi @ p @ phi.T + qd
    np.testing.assert_allclose(p, ss.prior, rtol=1e-9, atol=1e-12 * ss.prior[0, 0])


# -- the time update ----------------------------------------------------------------------------------
def test_step_rotation_vector_is_the_integral_of_a_linear_rate():
    """theta = h/2 (w_a + w_b) + h^2/12 w_a x w_b against DOP853 of seed 000 eq 4 with the rate going
    linearly from w_a to w_b: the coning term's sign and size (the trapezoid alone is off by all of it,
    the opposite sign by twice), and a third-order error (8x smaller at half the step)."""
    w_a, w_b = np.array([0.3, -0.1, 0.2]), np.array([-0.1, 0.4, 0.05])  # rad/s
    errors = []
    for h in (1.0, 0.5):
        sol = solve_ivp(lambda t, q, h=h: quaternion_rate(q, w_a + (w_b - w_a) * t / h), (0.0, h),
                        [0.0, 0.0, 0.0, 1.0], method='DOP853', rtol=1e-13, atol=1e-15)
        theta_true = rotation_vector_from_quat(sol.y[:, -1])
        theta = np.array(step_rotation_vector(w_a, w_b, h))
        coning = h * h / 12.0 * np.cross(w_a, w_b)
        errors.append(np.linalg.norm(theta - theta_true))
        assert errors[-1] < 0.05 * np.linalg.norm(coning)
        assert np.linalg.norm(theta - coning - theta_true) > 0.95 * np.linalg.norm(coning)
    assert errors[0] / errors[1] > 7.5


@given(st.lists(st.floats(-0.5, 0.5), min_size=3, max_size=3), st.floats(0.01, 2.0))
@settings(max_examples=25)
@example([0.0, 0.0, 1e-4], 1.0)  # the largest angle that once lost 1e-8 relative to 1 - cos a
@example([0.0, 0.006, 0.008], 1.0)  # the switch to the Taylor series at 0.01 rad
@example([0.0, 0.0, 0.0], 0.1)
def test_error_transition_is_the_matrix_exponential_and_composes(theta, h):
    """Phi = expm(F h) with F = [[-[w x], -I], [0, 0]], w = theta / h (M&C §6.2), and at a constant rate
    Phi(h) = Phi(h/2) Phi(h/2)."""
    theta = np.array(theta)
    f = np.zeros((6, 6))
    f[:3, :3] = -skew(theta / h)
    f[:3, 3:] = -np.eye(3)
    phi = error_transition(theta, h)
    np.testing.assert_allclose(phi, expm(f * h), rtol=0, atol=1e-13 * max(1.0, h))
    half = error_transition(theta / 2.0, h / 2.0)
    np.testing.assert_allclose(half @ half, phi, rtol=0, atol=1e-13 * max(1.0, h))


def test_process_noise_is_van_loans_for_a_body_at_rest_and_close_while_turning():
    """Qd of Farrenkopf's model against Van Loan's integral of Phi G Qc G' Phi': the same at zero rate, and
    at 2.9 deg/s over 0.1 s within 1e-6 of the attitude variance and 1 % of the bias-walk blocks (the
    rotation inside a step, left out of those)."""
    sv2, su2, h = 1e-11, 1e-14, 0.1
    qd = gyro_process_noise(sv2, su2, h)
    for w, tol_attitude, tol_bias in ((np.zeros(3), 1e-12, 1e-9), (np.array([0.03, -0.02, 0.035]), 1e-6, 1e-2)):
        f = np.zeros((6, 6))
        f[:3, :3] = -skew(w)
        f[:3, 3:] = -np.eye(3)
        gqg = np.diag([sv2] * 3 + [su2] * 3)  # d(dtheta) = ... - eta_v, d(dbias) = eta_u: G = diag(-I, I)
        m = expm(np.block([[-f, gqg], [np.zeros((6, 6)), f.T]]) * h)
        van_loan = m[6:, 6:].T @ m[:6, 6:]
        np.testing.assert_allclose(qd[:3, :3], van_loan[:3, :3], rtol=0, atol=tol_attitude * sv2 * h)
        np.testing.assert_allclose(qd[:3, 3:], van_loan[:3, 3:], rtol=0, atol=tol_bias * su2 * h * h / 2.0)
        np.testing.assert_allclose(qd[3:, 3:], van_loan[3:, 3:], rtol=0, atol=tol_bias * su2 * h)


def test_noise_free_gyro_carries_the_attitude_and_holding_samples_does_not():
    """Perfect gyro, no bias, one star-tracker sample at t = 0: after 60 s of a 2.9 deg/s tumble the
    linear interpolation (the default) is within 2e-6 rad of the truth (third order per step, a tenth of
    the 2.4e-5 rad random walk the gyro noise alone gives over 60 s); holding each sample ('hold') lags
    the rate by half a sample and is a hundred times further off (why the default is linear)."""
    config = dataclasses.replace(CONFIG, gyro_noise_sigma_rad_s=0.0, gyro_bias_walk_rad_s_sqrt_s=0.0)
    run = tumble_run(3, config, duration_s=60.0)
    omega_meas = run.omega_body  # no noise, no bias
    errors = {}
    for mode in ('linear', 'hold'):
        f = ChaserAttitudeFilter(dataclasses.replace(config, gyro_interpolation=mode))
        f.on_imu(0.0, omega_meas[0], q_hill_from_body(0.0, N_RAD_S, run.q_eci_from_body[0]))
        for k in range(1, run.t.size):
            f.on_gyro(run.t[k], omega_meas[k])
        q = f.estimate().q_eci_from_body
        errors[mode] = np.linalg.norm(rotation_vector_from_quat(quat_multiply(quat_conjugate(q),
                                                                              run.q_eci_from_body[-1])))
    assert errors['linear'] < 2e-6
    assert errors['hold'] > 100.0 * errors['linear'], errors


def test_star_tracker_between_gyro_samples_splits_the_step():
    """A star-tracker stamp between two gyro samples: the filter holds the earlier sample to it, then the
    next gyro sample continues from the linear interpolant there, turning also through what the hold
    left out. Without the update in between, 100 such split steps (0.06 s held, 0.04 s interpolated) of a
    2.9 deg/s tumble land within 1e-6 rad of the unsplit steps (1.1e-4 rad without the make-up turn, the
    hold's lag), and P within 1e-4 of the sigmas' products (correlations differ by < 1e-4)."""
    run = tumble_run(4, duration_s=10.0)
    direct, split = ChaserAttitudeFilter(CONFIG), ChaserAttitudeFilter(CONFIG)
    for f in (direct, split):
        f.on_imu(0.0, run.omega_meas[0], run.star[0])
    for k in range(1, run.t.size):
        direct.on_gyro(run.t[k], run.omega_meas[k])
        split.propagate_to(run.t[k] - 0.04)  # the stamp a star tracker would have
        split.on_gyro(run.t[k], run.omega_meas[k])
    a, b = direct.estimate(), split.estimate()
    assert np.linalg.norm(rotation_vector_from_quat(quat_multiply(quat_conjugate(a.q_eci_from_body),
                                                                  b.q_eci_from_body))) < 1e-6
    sigma = np.sqrt(np.diag(a.covariance))
    assert np.max(np.abs(b.covariance - a.covariance) / np.outer(sigma, sigma)) < 1e-4


def test_predict_leaves_the_filter_unchanged_and_equals_propagate_to():
    run = tumble_run(5, duration_s=5.0)
    f = ChaserAttitudeFilter(CONFIG)
    for k in range(run.t.size):
        f.on_imu(run.t[k], run.omega_meas[k], run.star.get(k))
    before = f.estimate()
    predicted = f.predict(f.t + 2.0)
    after = f.estimate()
    np.testing.assert_array_equal(after.q_eci_from_body, before.q_eci_from_body)
    np.testing.assert_array_equal(after.covariance, before.covariance)
    f.propagate_to(f.t + 2.0)
    np.testing.assert_array_equal(f.estimate().q_eci_from_body, predicted.q_eci_from_body)
    np.testing.assert_array_equal(f.estimate().covariance, predicted.covariance)
    assert predicted.t == f.t and np.all(np.linalg.eigvalsh(predicted.covariance) > 0.0)


# -- frames ---------------------------------------------------------------------------------------------
def test_inertially_fixed_body_has_constant_q_eci_and_the_filter_follows_q_hill_turning_at_n():
    """A body held inertially (omega = 0): its q_eci_from_body is constant while its q_hill_from_body turns
    at n (the hill frame turns at n about ECI +z); the filter's q_eci stays at the truth and its
    q_hill_from_body follows the turning one, within 4 sigma at every sample of 300 s (19 deg of hill turn)."""
    q0 = quat_normalize([0.2, -0.4, 0.1, 0.9])
    run = simulate_imu(np.random.default_rng(11), CONFIG, 300.0, q0, (0.0, 0.0, 0.0))
    np.testing.assert_allclose(run.q_eci_from_body, np.tile(q0, (run.t.size, 1)), atol=1e-14)
    f = ChaserAttitudeFilter(CONFIG)
    worst = 0.0
    for k in range(run.t.size):
        f.on_imu(run.t[k], run.omega_meas[k], run.star.get(k))
        e = f.estimate()
        q_hill_true = q_hill_from_body(run.t[k], N_RAD_S, q0)
        d_hill = rotation_vector_from_quat(quat_multiply(quat_conjugate(e.q_hill_from_body), q_hill_true))
        d_eci = rotation_vector_from_quat(quat_multiply(quat_conjugate(e.q_eci_from_body), q0))
        np.testing.assert_allclose(d_hill, d_eci, atol=1e-12)  # the same body-frame error in both frames
        worst = max(worst, float(np.max(np.abs(d_eci) / e.attitude_sigma_rad)))
    assert worst < 4.5
    turned = rotation_vector_from_quat(quat_multiply(quat_conjugate(q_hill_from_body(0.0, N_RAD_S, q0)),
                                                     f.estimate().q_hill_from_body))
    # seen from the body, hill turns at n about hill -y: the body's hill attitude turns by n t about +y of hill
    c = quat_to_matrix(q_hill_from_body(0.0, N_RAD_S, q0))
    np.testing.assert_allclose(c @ turned, [0.0, N_RAD_S * 300.0, 0.0], atol=1e-3 * N_RAD_S * 300.0)
    # the attitude covariance about hill axes is the body one turned by C_hill_from_body
    e = f.estimate()
    c = quat_to_matrix(e.q_hill_from_body)
    np.testing.assert_allclose(e.attitude_covariance_hill, c @ e.covariance[:3, :3] @ c.T)
    np.testing.assert_allclose(np.linalg.eigvalsh(e.attitude_covariance_hill), np.linalg.eigvalsh(e.covariance[:3, :3]))


# -- outliers, reset, bad input -----------------------------------------------------------------------
def test_a_5_deg_star_tracker_spike_is_gated_and_leaves_the_state_as_without_it():
    run = tumble_run(6, duration_s=60.0)
    k_spike = 300  # t = 30 s, a star-tracker sample
    spiked = dict(run.star)
    spiked[k_spike] = quat_multiply(run.star[k_spike], quat_from_axis_angle([1.0, 2.0, -1.0], math.radians(5.0)))
    without = dict(run.star)
    del without[k_spike]
    a, b = run_filter(run, star=spiked), run_filter(run, star=without)
    outlier = next(r for r in a.results if r.t == 30.0)
    assert outlier.kind == 'outlier' and not outlier.accepted and outlier.nis > a.filt.gate_threshold
    assert 4.9 < math.degrees(np.linalg.norm(outlier.innovation)) < 5.1 and 'd2' in outlier.reason
    assert a.filt.counts['outlier'] == 1 and a.filt.counts['accepted'] == len(run.star) - 2
    np.testing.assert_array_equal(a.error, b.error)  # every estimate of the run, to the bit
    np.testing.assert_array_equal(a.covariance, b.covariance)


def test_consecutive_outliers_reset_the_attitude_and_keep_the_bias():
    """One gyro sample at 30 s reads 0.5 rad/s too much about x (a glitch): the attitude is thrown 2.9 deg
    off (half of it by the glitch's own stamp: the two steps it bounds share it), the star tracker's
    samples are outliers, and the attitude is reset on the 20th of those that agree with each other (kind
    'reset', the reason says so: filter_interface's restart rule), the 21st in a row since the first, at
    the glitch's stamp, is off by half the step only; the bias estimate is kept with at least sigma_b0, and
    the samples that follow are accepted."""
    run = tumble_run(7, duration_s=60.0)
    omega_meas = run.omega_meas.copy()
    omega_meas[300, 0] += 0.5
    f = ChaserAttitudeFilter(CONFIG)
    after, bias_before = [], None
    for k in range(run.t.size):
        if k == 300:
            bias_before = f.estimate().bias_rad_s
        _, result = f.on_imu(run.t[k], omega_meas[k], run.star.get(k))
        if result is not None and k >= 300:
            after.append(result)
        if result is not None and result.kind == 'reset':
            np.testing.assert_array_equal(f.estimate().bias_rad_s, bias_before)
            assert np.all(np.diag(f.covariance)[3:] >= CONFIG.gyro_bias_sigma_rad_s ** 2)
            assert np.all(f.covariance[:3, 3:] == 0.0)
    angles = [math.degrees(np.linalg.norm(r.innovation)) for r in after[:2]]
    assert 1.4 < angles[0] < 1.45 and 2.8 < angles[1] < 2.9
    assert [r.kind for r in after[:21]] == ['outlier'] * 20 + ['reset']
    assert '20 consecutive star-tracker outliers agreeing' in after[20].reason and 'bias kept' in after[20].reason
    assert all(r.kind == 'accepted' for r in after[21:]) and len(after) > 40
    assert f.counts['reset'] == 1 and f.counts['outlier'] == 20
    e = f.estimate()
    error = rotation_vector_from_quat(quat_multiply(quat_conjugate(e.q_eci_from_body), run.q_eci_from_body[-1]))
    assert np.all(np.abs(error) < 4.0 * e.attitude_sigma_rad)


def _through_a_gap(run, gap):
    """The filter over run with the IMU's samples (gyro and star tracker) at the indices gap left out: the filter,
    the star tracker's results after the gap, the bias estimate before the gap and just after the first of them."""
    f = ChaserAttitudeFilter(CONFIG)
    after, bias = [], []
    for k in range(run.t.size):
        if k == gap[0]:
            bias.append(f.estimate().bias_rad_s)
        if k in gap:
            continue
        _, result = f.on_imu(run.t[k], run.omega_meas[k], run.star.get(k))
        if result is not None and k > gap[-1]:
            after.append(result)
            if len(after) == 1:
                bias.append(f.estimate().bias_rad_s)
    return f, after, bias


def test_a_gyro_gap_beyond_staleness_sets_the_attitude_again_from_the_star_tracker():
    """The IMU silent for 30 s while the body tumbles at 0.05 rad/s: the turn over the gap is unmeasured, so the
    first star-tracker sample after it sets the attitude (kind 'initialized', the reason naming the gap), the bias
    estimate kept; every later sample is accepted and the estimate ends within 4 sigma of the truth. A gap of three
    sample periods (within the monitor's staleness) is carried by the gyro's interpolant as before: no restart."""
    run = tumble_run(9, duration_s=90.0)
    f, after, (bias_before, bias_restarted) = _through_a_gap(run, range(300, 600))
    assert after[0].kind == 'initialized' and 'gyro gap of 30' in after[0].reason and 'bias kept' in after[0].reason
    np.testing.assert_array_equal(bias_restarted, bias_before)
    assert all(r.kind == 'accepted' for r in after[1:]) and len(after) > 20
    e = f.estimate()
    error = rotation_vector_from_quat(quat_multiply(quat_conjugate(e.q_eci_from_body), run.q_eci_from_body[-1]))
    assert np.all(np.abs(error) < 4.0 * e.attitude_sigma_rad)
    _, after_short, _ = _through_a_gap(run, range(300, 303))
    assert all(r.kind == 'accepted' for r in after_short)
    first_star = ChaserAttitudeFilter(CONFIG)  # a star-tracker sample before any gyro sample: no gap to measure
    assert first_star.on_star_tracker(0.0, run.star[0]).kind == 'initialized'
    assert first_star.on_gyro(0.1, run.omega_meas[1]).kind == 'accepted'


def test_a_wrong_first_star_tracker_sample_does_not_lock_the_filter_out():
    run = tumble_run(8, duration_s=20.0)
    star = dict(run.star)
    star[0] = quat_multiply(star[0], quat_from_axis_angle([0.0, 1.0, 0.0], math.radians(5.0)))
    fr = run_filter(run, star=star)
    assert [r.kind for r in fr.results[:21]] == ['initialized'] + ['outlier'] * 19 + ['reset']
    assert all(r.kind == 'accepted' for r in fr.results[21:])
    assert np.all(np.abs(fr.error[-1, :3]) < 4.0 * np.sqrt(np.diag(fr.covariance[-1])[:3]))


def _rejection_leaves_the_filter_as_it_was(reject):
    """A filter initialized at 0 s and propagated to 1 s by the gyro; reject(f) -> UpdateResult must leave
    its estimate as it was, to the bit. Returns the result and the filter."""
    f = ChaserAttitudeFilter(CONFIG)
    f.on_imu(0.0, [0.01, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0])
    f.on_gyro(1.0, [0.01, 0.0, 0.0])
    before = f.estimate()
    result = reject(f)
    assert not result.accepted
    after = f.estimate()
    assert after.t == before.t
    for name in ('q_eci_from_body', 'omega_body', 'bias_rad_s', 'covariance'):
        np.testing.assert_array_equal(getattr(after, name), getattr(before, name))
    return result, f


@pytest.mark.parametrize('t, q, kind, named', [
    (1.0, [math.nan, 0.0, 0.0, 1.0], 'non_finite', 'nan'),
    (1.0, [math.inf, 0.0, 0.0, 1.0], 'non_finite', 'inf'),
    (1.0, [0.0, 0.0, 1.0], 'non_finite', '[0.0, 0.0, 1.0]'),
    (1.0, 'q', 'non_finite', "'q'"),
    (math.nan, [0.0, 0.0, 0.0, 1.0], 'non_finite', 'nan'),
    (1.0, [0.0, 0.0, 0.0, 1.01], 'non_unit', 'norm 1.01'),
    (0.5, [0.0, 0.0, 0.0, 1.0], 'stale', 't = 0.5 s is before the filter time 1.0 s'),
])
def test_bad_star_tracker_samples_are_rejected_by_kind_and_change_nothing(t, q, kind, named):
    result, f = _rejection_leaves_the_filter_as_it_was(lambda f: f.on_star_tracker(t, q))
    assert result.kind == kind and named in result.reason
    assert 'star-tracker attitude' in result.reason and f.counts[kind] == 1


@pytest.mark.parametrize('t, w, kind, named', [
    (1.0, [math.nan, 0.0, 0.0], 'non_finite', 'nan'),
    (1.0, [0.0, 0.0], 'non_finite', '[0.0, 0.0]'),
    (math.inf, [0.0, 0.0, 0.0], 'non_finite', 'inf'),
    (None, [0.0, 0.0, 0.0], 'non_finite', 'None'),
    (0.5, [0.0, 0.0, 0.0], 'stale', 't = 0.5 s is before the filter time 1.0 s'),
])
def test_bad_gyro_samples_are_rejected_by_kind_and_change_nothing(t, w, kind, named):
    result, f = _rejection_leaves_the_filter_as_it_was(lambda f: f.on_gyro(t, w))
    assert result.kind == kind and named in result.reason and 'gyro sample' in result.reason
    assert f.gyro_counts[kind] == 1 and sum(f.counts.values()) == 1  # counted as a gyro sample only


def test_first_star_tracker_sample_initializes_and_the_interface_is_the_filters():
    f = ChaserAttitudeFilter(CONFIG)
    assert isinstance(f, EstimationFilter) and set(f.counts) == set(UPDATE_KINDS) == set(f.gyro_counts)
    assert not f.initialized and not f.ready and f.t is None
    with pytest.raises(RuntimeError, match='no star-tracker sample yet'):
        f.estimate()
    assert f.on_gyro(0.0, [0.0, 0.01, 0.0]).kind == 'accepted' and f.t is None  # kept, nothing to propagate
    q = quat_from_rotation_vector([0.1, 0.2, 0.3])
    assert f.on_star_tracker(0.0, q).kind == 'initialized' and f.ready and f.t == 0.0
    e = f.estimate()
    np.testing.assert_allclose(e.q_hill_from_body, q, atol=1e-15)
    np.testing.assert_array_equal(e.bias_rad_s, np.zeros(3))
    np.testing.assert_allclose(e.covariance, np.diag([CONFIG.star_tracker_sigma_rad ** 2] * 3
                                                     + [CONFIG.gyro_bias_sigma_rad_s ** 2] * 3))
    rate_variance = CONFIG.gyro_noise_sigma_rad_s ** 2 + CONFIG.gyro_bias_sigma_rad_s ** 2  # sigma_g^2 + P_bias
    np.testing.assert_allclose(e.rate_covariance, rate_variance * np.eye(3))
    np.testing.assert_array_equal(e.omega_body, [0.0, 0.01, 0.0])
    assert f.update(0.1, q).kind == 'accepted' and f.t == 0.1  # the EstimationFilter verb: the star tracker


def test_config_from_scenario_keys_and_validation():
    """The scenario's sensors.chaser_imu keys (degrees converted) and gate, the schema's defaults where paper_flyby
    leaves them out; a bad value raises naming the field."""
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    c = ChaserAttitudeFilterParams.from_scenario(sc).config()
    assert c.mean_motion_rad_s == sc.mean_motion_rad_s
    assert (c.rate_hz, c.star_tracker_rate_hz, c.star_tracker_sigma_rad, c.gyro_noise_sigma_rad_s,
            c.gyro_bias_sigma_rad_s, c.gyro_bias_walk_rad_s_sqrt_s, c.gate_probability) == (
        10.0, 2.0, math.radians(0.01), 1e-5, 1e-4, 1e-7, 0.9999)
    imu = types.SimpleNamespace(rate_hz=20.0, star_tracker_rate_hz=4.0, star_tracker_sigma_deg=0.02,  # the plant's keys
                                gyro_noise_sigma_rad_s=2e-5, gyro_bias_sigma_rad_s=3e-4,
                                gyro_bias_walk_rad_s_sqrt_s=5e-7)
    scenario = types.SimpleNamespace(sensors=types.SimpleNamespace(chaser_imu=imu), mean_motion_rad_s=N_RAD_S,
                                     estimation=types.SimpleNamespace(gate_probability=0.999))
    c = ChaserAttitudeFilterParams.from_scenario(scenario).config(max_consecutive_outliers=10)
    assert c == ChaserAttitudeFilterConfig(mean_motion_rad_s=N_RAD_S, rate_hz=20.0, star_tracker_rate_hz=4.0,
                                           star_tracker_sigma_rad=math.radians(0.02), gyro_noise_sigma_rad_s=2e-5,
                                           gyro_bias_sigma_rad_s=3e-4, gyro_bias_walk_rad_s_sqrt_s=5e-7,
                                           gate_probability=0.999, max_consecutive_outliers=10)
    assert c.attitude_sigma0_rad == c.star_tracker_sigma_rad
    for field, value in (('star_tracker_sigma_rad', 0.0), ('rate_hz', -1.0), ('gate_probability', 1.0),
                         ('max_consecutive_outliers', 0), ('gyro_interpolation', 'cubic'),
                         ('gyro_noise_sigma_rad_s', math.nan), ('initial_attitude_sigma_rad', 0.0)):
        with pytest.raises(ValueError, match=field):
            dataclasses.replace(CONFIG, **{field: value})
