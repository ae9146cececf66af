"""target_motion.py: error dynamics against finite differences, seed 000 eq 6-9, categories I-IV."""

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from flyby_estimation.target_motion import (
    ErrorStateDynamics,
    MotionPrediction,
    MotionThresholds,
    body_point_in_hill,
    classify_motion,
    covariance_from_published,
    covariance_in_hill,
    dop853_reference,
    make_state,
    orbit_rate_hill,
    perturbed_predictions,
    prediction_from_estimate,
)
from flyby_sim.dynamics.attitude import AttitudePropagator, euler_rate, quaternion_rate
from flyby_sim.dynamics.orbital import mean_motion_rad_s, q_hill_from_body, rk4_step, rk4_step_floats
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    quat_normalize,
    quat_to_matrix,
    rotation_vector_from_quat,
)

N = mean_motion_rad_s(7.0e6)
# Seed 001 Table 1: the tumbler, and seed 000 section 5: the stable spinner.
INERTIA_TUMBLER = np.diag([4069.0, 12030.0, 11029.0])
OMEGA_TUMBLER = np.array([0.3, 0.2, 0.1])
INERTIA_PAPER = np.diag([1200.0, 1000.0, 2000.0])
Q0 = quat_normalize([0.1, -0.2, 0.3, 0.9])


def perturbed(q, omega, dx):
    """The state whose error relative to (q, omega) is dx = [dtheta_body, domega_body]."""
    return quat_multiply(q, quat_from_rotation_vector(dx[:3])), omega + dx[3:]


def error_between(q_ref, omega_ref, q, omega):
    return np.concatenate((rotation_vector_from_quat(quat_multiply(quat_conjugate(q_ref), q)), omega - omega_ref))


def test_transition_matrix_matches_finite_differences_of_the_nonlinear_flow():
    """Phi from dPhi/dt = F Phi (analytic Jacobian of seed 000 eq 4) against perturbed integrations."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER)
    dt = 5.0
    q1, w1, phi, _ = dyn.propagate(Q0, OMEGA_TUMBLER, dt, max_step_angle_rad=0.002)
    eps = 1e-6
    numeric = np.empty((6, 6))
    for k in range(6):
        columns = []
        for sign in (1.0, -1.0):
            dx = np.zeros(6)
            dx[k] = sign * eps
            q, w = perturbed(Q0, OMEGA_TUMBLER, dx)
            qk, wk, _, _ = dyn.propagate(q, w, dt, max_step_angle_rad=0.002)
            columns.append(error_between(q1, w1, qk, wk))
        numeric[:, k] = (columns[0] - columns[1]) / (2 * eps)
    np.testing.assert_allclose(phi, numeric, atol=2e-6 * np.abs(phi).max())


def test_process_noise_matches_integral_of_phi_g_qc_g_phi():
    """Qd integrated as dQd/dt = F Qd + Qd F' + GQcG' equals int_0^dt Phi(dt, s) GQcG' Phi(dt, s)' ds."""
    dyn = ErrorStateDynamics(INERTIA_PAPER, torque_psd=1e-4)
    omega = np.array([0.01, -0.02, math.radians(5.0)])
    dt, steps = 2.0, 200
    _, _, _, qd = dyn.propagate(Q0, omega, dt, max_step_angle_rad=1e-3)
    h = dt / steps
    # Riemann sum with Phi(dt, s) from integrating from s to dt along the same reference
    states = [(Q0, omega)]
    for _ in range(steps):
        q, w, _, _ = dyn.propagate(*states[-1], h)
        states.append((q, w))
    total = np.zeros((6, 6))
    for k in range(steps):
        s_mid = (k + 0.5) * h
        q, w, _, _ = dyn.propagate(*states[k], 0.5 * h)
        _, _, phi, _ = dyn.propagate(q, w, dt - s_mid, max_step_angle_rad=1e-3)
        total += phi @ dyn.noise_density @ phi.T * h
    np.testing.assert_allclose(qd, total, rtol=1e-3, atol=1e-6 * np.abs(total).max())


def test_prediction_matches_flyby_sim_propagator_over_600_s():
    """MotionPrediction (DOP853 on state + Phi + Qd) against flyby_sim.dynamics.attitude at tight tolerance."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER)
    prediction = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, np.eye(6) * 1e-8, 610.0)
    reference = AttitudePropagator(Q0, OMEGA_TUMBLER, INERTIA_TUMBLER, t0=10.0, rtol=1e-13, atol=1e-15)
    for t in (10.0, 123.4, 610.0):
        s = prediction.state(t)
        q_ref, w_ref = reference.state_at(t)
        assert np.linalg.norm(error_between(s.q_eci_from_body, s.omega_body, q_ref, w_ref)) < 1e-7
    with pytest.raises(ValueError, match='outside'):
        prediction.state(611.0)


def test_track_and_reference_only_prediction_agree_with_the_full_one():
    """track() (vectorized eq 8-9) equals body_point_in_hill; with_covariance=False keeps the motion."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER)
    full = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, np.eye(6) * 1e-8, 400.0)
    bare = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, None, 400.0, with_covariance=False)
    x_b = np.array((1.0, -0.5, 2.0))
    times = np.array((10.0, 77.7, 250.0, 400.0))
    track = full.track(x_b, times)
    for k, t in enumerate(times):
        p = full.body_point_in_hill(x_b, t)
        np.testing.assert_allclose(track.r_hill[k], p.r_hill, atol=1e-12)
        np.testing.assert_allclose(track.v_hill[k], p.v_hill, atol=1e-12)
        np.testing.assert_allclose(track.omega_hill[k], full.state(t).omega_hill, atol=1e-12)
        b = bare.state(t)
        assert b.covariance is None and bare.body_point_in_hill(x_b, t).covariance is None
        assert np.linalg.norm(error_between(b.q_eci_from_body, b.omega_body, full.state(t).q_eci_from_body,
                                            full.state(t).omega_body)) < 1e-7
    with pytest.raises(ValueError, match='leave the predicted interval'):
        full.track(x_b, (5.0, 20.0))
    still = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, None, 10.0, with_covariance=False)
    np.testing.assert_allclose(still.track(x_b, (10.0,)).r_hill[0], still.body_point_in_hill(x_b, 10.0).r_hill)


def rk4_of_augmented_state(dyn, q, omega, dt, steps):
    """(q, omega, Phi, Qd) by RK4 of all 79 states of augmented_rate (the filter's time update before the
    closed form): the route ErrorStateDynamics.propagate must agree with."""
    y = np.concatenate((q, omega, np.eye(6).ravel(), np.zeros(36)))
    for _ in range(steps):
        y = rk4_step(dyn.augmented_rate, 0.0, y, dt / steps)
    return quat_normalize(y[:4]), y[4:7], y[7:43].reshape(6, 6), y[43:].reshape(6, 6)


@pytest.mark.parametrize('inertia, omega_deg_s', [(INERTIA_PAPER, (0.0, 0.0, 5.0)), (INERTIA_PAPER, (3.0, -12.0, 8.0)),
                                                  (INERTIA_TUMBLER, np.degrees(OMEGA_TUMBLER))])
def test_closed_form_time_update_matches_rk4_of_phi_and_qd(inertia, omega_deg_s):
    """propagate's Magnus Phi and series Qd against RK4 of dPhi/dt = F Phi, dQd/dt = F Qd + Qd F' + GQcG'
    on the same substeps (the 0.1 s filter step; one and two substeps, the 21 deg/s tumbler three):
    the reference state to the bit, Phi to 1e-10 (both are fourth order: their difference is the size
    of either's error against a 100x finer RK4), Qd to 2e-5 of its largest entry (its series stops at h^4)."""
    dyn = ErrorStateDynamics(inertia, torque_psd=1e-6)
    omega = np.radians(omega_deg_s)
    steps = max(1, math.ceil(np.linalg.norm(omega) * 0.1 / 0.02))
    q, w, phi, qd = dyn.propagate(Q0, omega, 0.1)
    q_rk4, w_rk4, phi_rk4, qd_rk4 = rk4_of_augmented_state(dyn, Q0, omega, 0.1, steps)
    np.testing.assert_array_equal(q, q_rk4)
    np.testing.assert_array_equal(w, w_rk4)
    np.testing.assert_allclose(phi, phi_rk4, rtol=0.0, atol=1e-10)
    np.testing.assert_allclose(qd, qd_rk4, rtol=0.0, atol=2e-5 * np.abs(qd_rk4).max())
    _, _, phi_fine, _ = rk4_of_augmented_state(dyn, Q0, omega, 0.1, 100 * steps)
    assert np.abs(phi - phi_fine).max() < 2.0 * np.abs(phi_rk4 - phi_fine).max() + 1e-13


def test_closed_form_time_update_is_the_exponential_for_a_steady_spin():
    """About a principal axis omega is constant, so Phi = expm(F dt) and Qd is Van Loan's
    (Van Loan 1978: expm([[-F, GQcG'], [0, F']] dt) = [[., Phi^-1 Qd], [0, Phi']])."""
    dyn = ErrorStateDynamics(INERTIA_PAPER, torque_psd=1e-6)
    omega = np.radians((0.0, 0.0, 15.0))
    f = dyn.jacobian(omega)
    for dt in (0.05, 0.1):
        q, w, phi, qd = dyn.propagate(Q0, omega, dt)
        block = np.zeros((12, 12))
        block[:6, :6], block[:6, 6:], block[6:, 6:] = -f, dyn.noise_density, f.T
        van_loan = scipy.linalg.expm(block * dt)
        phi_exact = van_loan[6:, 6:].T
        np.testing.assert_array_equal(w, omega)
        np.testing.assert_allclose(phi, scipy.linalg.expm(f * dt), rtol=0.0, atol=3e-11)
        np.testing.assert_allclose(phi_exact, scipy.linalg.expm(f * dt), rtol=0.0, atol=1e-14)
        np.testing.assert_allclose(qd, phi_exact @ van_loan[:6, 6:], rtol=1e-5, atol=1e-5 * np.abs(qd).max())
        np.testing.assert_allclose(qd[:3, :3], (phi_exact @ van_loan[:6, 6:])[:3, :3], rtol=5e-5)


def test_rk4_time_update_matches_dense_prediction():
    """The filter's time update (0.02 rad substeps) and a prediction (0.15 rad substeps, longer series):
    the same motion, and the same covariance to 1e-6 of its largest entry (measured 1.3e-7, nearly
    all of it the prediction's, against DOP853 of the augmented state at rtol 1e-13)."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER, torque_psd=1e-6)
    p0 = np.diag([1e-4, 2e-4, 3e-4, 1e-6, 2e-6, 3e-6])
    q, w, phi, qd = dyn.propagate(Q0, OMEGA_TUMBLER, 3.0)
    s = MotionPrediction(dyn, N, 0.0, Q0, OMEGA_TUMBLER, p0, 3.0).state(3.0)
    assert np.linalg.norm(error_between(s.q_eci_from_body, s.omega_body, q, w)) < 1e-9
    np.testing.assert_allclose(phi @ p0 @ phi.T + qd, s.covariance, rtol=0.0, atol=1e-6 * np.abs(s.covariance).max())


def test_lazy_covariance_matches_dop853_of_the_augmented_state():
    """MotionPrediction's covariance (closed-form substeps of 0.15 rad chained, Hermite between them) against
    DOP853 of the 79 states of augmented_rate (dPhi/dt = F Phi, dQd/dt = F Qd + Qd F' + GQcG'), the way it was
    computed before: 600 s of the 21 deg/s seed 001 tumbler with torque noise and a correlated P0. The
    attitude sigma to 1e-4 relative (measured 3e-5), P to 1e-4 of its largest entry; the motion itself is
    that of the prediction without covariance, to the bit."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER, torque_psd=1e-6)
    a = np.random.default_rng(1).standard_normal((6, 6))
    p0 = a @ a.T * 1e-6
    prediction = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, p0, 610.0)
    y0 = np.concatenate((Q0, OMEGA_TUMBLER, np.eye(6).ravel(), np.zeros(36)))
    augmented = solve_ivp(dyn.augmented_rate, (10.0, 610.0), y0, method='DOP853', rtol=1e-10, atol=1e-13,
                          dense_output=True).sol
    times = np.linspace(10.0, 610.0, 1201)
    expected = []
    for t in times:
        y = augmented(t)
        phi = y[7:43].reshape(6, 6)
        expected.append(phi @ p0 @ phi.T + y[43:].reshape(6, 6))
    expected = np.array(expected)
    sigma_expected = np.sqrt(np.linalg.eigvalsh(expected[:, :3, :3])[:, -1])
    np.testing.assert_allclose(prediction.attitude_sigma_rad(times), sigma_expected, rtol=1e-4)
    for k in (0, 1, 333, 777, 1200):
        p = prediction.state(times[k]).covariance
        np.testing.assert_allclose(p, expected[k], rtol=0.0, atol=1e-4 * np.abs(expected[k]).max())
    bare = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, None, 610.0, with_covariance=False)
    x_b = np.array((1.0, -0.5, 2.0))
    np.testing.assert_array_equal(prediction.track(x_b, times).r_hill, bare.track(x_b, times).r_hill)
    still = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, p0, 10.0)
    np.testing.assert_array_equal(still.state(10.0).covariance, 0.5 * (p0 + p0.T))
    np.testing.assert_allclose(still.attitude_sigma_rad([10.0, 10.0]), np.sqrt(np.linalg.eigvalsh(p0[:3, :3])[-1]))


@settings(max_examples=50, deadline=None)
@given(st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1),
       st.tuples(*[st.floats(-0.5, 0.5)] * 3), st.floats(1e-3, 0.5))
def test_float_rk4_step_is_rk4_step_to_the_bit(q, omega, h):
    """reference_rk4_step on Python floats is flyby_sim's rk4_step of reference_rate on the numpy vector, to the bit."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER)
    y = np.concatenate((quat_normalize(q), omega))
    expected = rk4_step(dyn.reference_rate, 0.0, y, h)
    np.testing.assert_array_equal(np.array(dyn.reference_rk4_step(y.tolist(), h)), expected)


@settings(max_examples=20, deadline=None)
@given(st.floats(0.1, 20.0), st.floats(0.1, 20.0), st.tuples(*[st.floats(-0.4, 0.4)] * 3))
def test_property_transition_matrix_composes(dt1, dt2, omega):
    """Phi(t0 + dt1 + dt2, t0) = Phi(t0 + dt1 + dt2, t0 + dt1) Phi(t0 + dt1, t0) along one reference."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER)
    q1, w1, phi1, _ = dyn.propagate(Q0, np.array(omega), dt1)
    _, _, phi2, _ = dyn.propagate(q1, w1, dt2)
    _, _, phi12, _ = dyn.propagate(Q0, np.array(omega), dt1 + dt2)
    np.testing.assert_allclose(phi2 @ phi1, phi12, atol=1e-6 * max(1.0, np.abs(phi12).max()))


def test_seed000_eq9_sign_by_numerical_derivative():
    """v_g^H must be d/dt of x_g^H (eq 8): the orbital-rate term of eq 9 enters with a minus sign.

    The printed '+' sign is off by 2 Omega^H x x_g^H; with our (large) test orbit rate the difference
    is far above the derivative's error, so this settles the sign of flyby_sim.dynamics.attitude.body_point_state,
    which both body_point_in_hill and the vectorized track() use.
    """
    n_fast = 0.05  # exaggerated orbit rate [rad/s] so that the Omega term is large
    dyn = ErrorStateDynamics(INERTIA_TUMBLER)
    prediction = MotionPrediction(dyn, n_fast, 0.0, Q0, OMEGA_TUMBLER, np.eye(6) * 1e-8, 100.0)
    x_body = np.array([1.5, 0.0, 1.5])
    h = 1e-3
    for t in (20.0, 55.5, 80.0):
        v = prediction.body_point_in_hill(x_body, t).v_hill
        numeric = (prediction.body_point_in_hill(x_body, t + h).r_hill
                   - prediction.body_point_in_hill(x_body, t - h).r_hill) / (2 * h)
        np.testing.assert_allclose(v, numeric, atol=1e-7)
        track = prediction.track(x_body, (t - h, t, t + h))
        np.testing.assert_allclose(track.v_hill[1], (track.r_hill[2] - track.r_hill[0]) / (2 * h), atol=1e-7)
        s = prediction.state(t)
        r = quat_to_matrix(s.q_hill_from_body) @ x_body
        printed = (quat_to_matrix(s.q_hill_from_body) @ np.cross(s.omega_body, x_body)
                   + np.cross(orbit_rate_hill(n_fast), r))
        assert np.linalg.norm(printed - numeric) > 1e3 * np.linalg.norm(v - numeric)
        # equivalent form: (omega^H - Omega^H) x x_g^H with omega^H of eq 6
        np.testing.assert_allclose(v, np.cross(s.omega_hill - orbit_rate_hill(n_fast), r), atol=1e-12)


def test_seed000_section5_grasp_values():
    """|x_g| = 2.1213 m and |v_g| = 0.131 m/s for a 5 deg/s spin about body z, grasp point [1.5, 0, 1.5]."""
    c = quat_to_matrix(quat_normalize([0.2, 0.3, -0.1, 0.9]))
    r, v, _ = body_point_in_hill(c, [0.0, 0.0, math.radians(5.0)], [1.5, 0.0, 1.5], N)
    assert np.linalg.norm(r) == pytest.approx(2.1213, abs=1e-4)
    assert np.linalg.norm(v) == pytest.approx(0.131, abs=2e-3)  # the orbit-rate term is ~1e-3 m/s


def test_body_point_jacobian_matches_finite_differences():
    rng = np.random.default_rng(3)
    q = quat_normalize(rng.normal(size=4))
    omega = rng.normal(size=3) * 0.2
    x_body = np.array([1.0, -0.5, 2.0])
    _, _, jac = body_point_in_hill(quat_to_matrix(q), omega, x_body, N)
    eps = 1e-7
    numeric = np.empty((6, 6))
    for k in range(6):
        dx = np.zeros(6)
        dx[k] = eps
        qp, wp = perturbed(q, omega, dx)
        qm, wm = perturbed(q, omega, -dx)
        rp, vp, _ = body_point_in_hill(quat_to_matrix(qp), wp, x_body, N)
        rm, vm, _ = body_point_in_hill(quat_to_matrix(qm), wm, x_body, N)
        numeric[:, k] = np.concatenate((rp - rm, vp - vm)) / (2 * eps)
    np.testing.assert_allclose(jac, numeric, atol=1e-7)


def test_covariance_in_hill_matches_sampled_errors():
    """covariance_hill is the covariance of [dtheta_hill, domega_hill] (seed 000 eq 6) of sampled body errors."""
    rng = np.random.default_rng(5)
    q_eci = quat_normalize([0.3, 0.1, -0.4, 0.8])
    omega = np.array([0.2, -0.1, 0.3])
    p = np.diag([1e-6, 4e-6, 9e-6, 1e-8, 4e-8, 1e-8])
    state = make_state(12.0, N, q_eci, omega, p)
    samples = []
    for dx in rng.multivariate_normal(np.zeros(6), p, size=4000):
        q_true, w_true = perturbed(q_eci, omega, dx)
        q_hb = q_hill_from_body(12.0, N, q_true)
        dtheta_hill = rotation_vector_from_quat(quat_multiply(q_hb, quat_conjugate(state.q_hill_from_body)))
        samples.append(np.concatenate((dtheta_hill, quat_to_matrix(q_hb) @ w_true - state.omega_hill)))
    sampled = np.cov(np.array(samples).T)
    scale = np.sqrt(np.outer(np.diag(state.covariance_hill), np.diag(state.covariance_hill)))
    assert np.abs(sampled - state.covariance_hill).max() / scale.max() < 0.1
    np.testing.assert_allclose(covariance_in_hill(np.eye(3), np.zeros(3), p), p)


DEG = math.radians(1.0)
OMEGA_H = orbit_rate_hill(N)


@pytest.mark.parametrize('omega_hill, excursion, category', [
    (OMEGA_H, math.radians(0.2), 'I'),  # Earth pointing, held tightly
    (np.array([1e-5, 0.0, 0.0]), None, 'I'),  # inertially held (sun pointing)
    (OMEGA_H + np.array([0.03 * DEG, 0.0, 0.0]), math.radians(8.0), 'II'),  # gravity-gradient libration
    (OMEGA_H, math.radians(10.0), 'II'),  # at rest in hill but with a large excursion
    (np.array([0.0, 0.0, 5.0 * DEG]), None, 'III'),  # seed 000 section 5: 5 deg/s
    (np.array([0.0, 0.5 * DEG, 0.0]), None, 'III'),  # 720 s period
    (np.array([25.0 * DEG, 0.0, 0.0]), None, 'IV'),
])
def test_seed000_section2_1_categories(omega_hill, excursion, category):
    result = classify_motion(omega_hill, N, excursion)
    assert result.category == category, result.reason
    assert result.reason


def test_seed001_tumbler_is_category_iv_at_default_thresholds():
    """|(0.3, 0.2, 0.1)| rad/s = 21.4 deg/s, a 17 s period: faster than the fly-by range (20-3600 s)."""
    result = classify_motion(OMEGA_TUMBLER, N)
    assert result.category == 'IV'
    assert classify_motion(OMEGA_TUMBLER, N, thresholds=MotionThresholds(spin_rate_rad_s=0.5)).category == 'III'


def test_classify_rejects_bad_input():
    with pytest.raises(ValueError, match='omega_hill'):
        classify_motion([math.nan, 0.0, 0.0], N)
    with pytest.raises(ValueError, match='spin_rate_rad_s'):
        MotionThresholds(spin_rate_rad_s=-1.0)


def test_published_covariance_blocks_round_trip_and_propagate():
    """covariance_from_published inverts covariance_in_hill's attitude block (the rate block is published in
    body axes), and MotionPrediction.attitude_sigma_rad is the largest attitude sigma of state(t).covariance
    (P = Phi P0 Phi' + Qd), growing from the rate error."""
    rng = np.random.default_rng(4)
    a = rng.standard_normal((6, 6))
    p_body = a @ a.T * 1e-6
    p_body[:3, 3:] = p_body[3:, :3] = 0.0  # the cross block is not published
    q = np.array([0.2, -0.4, 0.1, 0.88])
    q /= np.linalg.norm(q)
    omega_body = np.radians([1.0, -2.0, 6.0])
    c = quat_to_matrix(q)
    p_hill = covariance_in_hill(c, omega_body, p_body)
    np.testing.assert_allclose(covariance_from_published(q, p_hill[:3, :3], p_body[3:, 3:]), p_body, atol=1e-18)
    n = mean_motion_rad_s(7.0e6)
    dynamics = ErrorStateDynamics(np.diag([1200.0, 1000.0, 2000.0]), 1e-10)
    pred = prediction_from_estimate(dynamics, n, 10.0, q, omega_body, 400.0, p_body)
    times = np.array([10.0, 50.0, 200.0, 400.0])
    sigma = pred.attitude_sigma_rad(times)
    expected = [math.sqrt(np.linalg.eigvalsh(pred.state(t).covariance[:3, :3])[-1]) for t in times]
    np.testing.assert_allclose(sigma, expected, rtol=1e-9)
    assert sigma[0] == pytest.approx(math.sqrt(np.linalg.eigvalsh(p_body[:3, :3])[-1]), rel=1e-9)
    assert sigma[-1] > sigma[0]
    with pytest.raises(ValueError, match='no covariance'):
        prediction_from_estimate(dynamics, n, 10.0, q, omega_body, 400.0).attitude_sigma_rad(times)


# -- the time update and the states as they were computed before (issue 12's throughput work), to the bit ------

def previous_propagate(dyn, q, omega, dt, max_step_angle_rad=0.02, max_step_s=0.1):
    """ErrorStateDynamics.propagate as it was: rates by flyby_sim's quaternion_rate and euler_rate (arrays), one
    substep_transition call per substep with its own two Euler rates, 2D products."""
    inertia, inertia_inv = tuple(map(tuple, dyn.inertia.tolist())), tuple(map(tuple, dyn.inertia_inv.tolist()))

    def rate(_, v):
        return quaternion_rate(v[:4], v[4:]).tolist() + euler_rate(v[4:], inertia, inertia_inv).tolist()

    def transition(w0, w1, h):
        w_dot0, w_dot1 = euler_rate(w0, inertia, inertia_inv), euler_rate(w1, inertia, inertia_inv)
        w_mean = [0.5 * (a + b) + h / 12.0 * (da - db) for a, b, da, db in zip(w0, w1, w_dot0, w_dot1, strict=True)]
        w_change = [b - a for a, b in zip(w0, w1, strict=True)]
        f_mean, d_f = (np.array((w_mean, w_change)) @ dyn._f_per_omega).reshape(2, 6, 6)
        f_mean = f_mean + dyn._f_constant
        magnus = h * f_mean + (h * h / 12.0) * (d_f @ f_mean - f_mean @ d_f)
        phi = np.eye(6) + magnus / 4.0
        for k in (3.0, 2.0, 1.0):
            phi = np.eye(6) + (magnus @ phi) / k
        if not dyn.torque_psd:
            return phi, np.zeros((6, 6))
        f, x = magnus / h, dyn.noise_density
        for k in (4.0, 3.0, 2.0):
            fx = f @ x
            x = dyn.noise_density + (h / k) * (fx + fx.T)
        return phi, h * x

    y = np.concatenate((q, omega), dtype=float).tolist()
    if not dt > 0.0:
        return quat_normalize(y[:4]), np.array(y[4:]), np.eye(6), np.zeros((6, 6))
    rate_norm = float(np.linalg.norm(omega))
    steps = max(1, math.ceil(dt / max_step_s - 1e-9), math.ceil(rate_norm * dt / max_step_angle_rad))
    h = dt / steps
    phi = qd = None
    for _ in range(steps):
        y_next = rk4_step_floats(rate, 0.0, y, h)
        phi_k, qd_k = transition(y[4:], y_next[4:], h)
        phi, qd = (phi_k, qd_k) if phi is None else (phi_k @ phi, phi_k @ qd @ phi_k.T + qd_k)
        y = y_next
    return quat_normalize(y[:4]), np.array(y[4:]), phi, qd


inertias = st.tuples(*[st.floats(100.0, 5000.0)] * 3, *[st.floats(-50.0, 50.0)] * 3).map(
    lambda v: np.diag(v[:3]) + np.array(((0.0, v[3], v[4]), (v[3], 0.0, v[5]), (v[4], v[5], 0.0))))


@settings(max_examples=60, deadline=None)
@given(inertias, st.booleans(), st.tuples(*[st.floats(-0.3, 0.3)] * 3), st.sampled_from((0.0, 0.05, 0.1, 0.3, 1.0)),
       st.sampled_from((0.0, 1e-10, 1e-4)))
def test_time_update_is_the_previous_formulation_to_the_bit(inertia, principal, omega, dt, torque_psd):
    """propagate (float rates, the substeps' transitions in one stacked call, the Euler rates of the RK4 steps
    reused) gives the q, omega, Phi and Qd of the per-substep formulation it replaced, to the bit: 1 to 8
    substeps, principal and general inertia, with and without torque noise."""
    dyn = ErrorStateDynamics(np.diag(np.diag(inertia)) if principal else inertia, torque_psd)
    for got, expected in zip(dyn.propagate(Q0, np.array(omega), dt), previous_propagate(dyn, Q0, np.array(omega), dt),
                             strict=True):
        np.testing.assert_array_equal(got, expected)


@settings(max_examples=100, deadline=None)
@given(inertias, st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1),
       st.tuples(*[st.floats(-0.5, 0.5)] * 3))
def test_float_reference_rate_is_attitudes_to_the_bit(inertia, q, omega):
    """reference_rate_floats (and reference_rate, DOP853's) is flyby_sim's quaternion_rate and euler_rate
    (seed 000 eq 4), to the bit."""
    dyn = ErrorStateDynamics(inertia)
    inertia_t, inertia_inv_t = tuple(map(tuple, dyn.inertia.tolist())), tuple(map(tuple, dyn.inertia_inv.tolist()))
    expected = np.concatenate((quaternion_rate(q, omega), euler_rate(omega, inertia_t, inertia_inv_t)))
    np.testing.assert_array_equal(dyn.reference_rate_floats(list(q) + list(omega)), expected)
    np.testing.assert_array_equal(dyn.reference_rate(0.0, np.array(list(q) + list(omega))), expected)


def test_substep_transition_is_the_previous_formulation_to_the_bit():
    """substep_transition (one substep of the stacked closed form) is the one-substep time update's Phi and Qd."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER, torque_psd=1e-6)
    _, w1, phi, qd = previous_propagate(dyn, Q0, OMEGA_TUMBLER, 0.01)  # one substep of 0.01 s
    phi_new, qd_new = dyn.substep_transition(OMEGA_TUMBLER, w1, 0.01)
    np.testing.assert_array_equal(phi_new, phi)
    np.testing.assert_array_equal(qd_new, qd)


def test_states_compute_their_covariance_at_first_use_as_before():
    """MotionPrediction.state's covariance (now computed when first asked for) and covariance_hill are those
    computed with the state before: 0.5 (P + P') of the interpolated P and covariance_in_hill of it, to the
    bit; make_state(symmetric=True) of an exactly symmetric P is make_state of it."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER, torque_psd=1e-6)
    a = np.random.default_rng(2).standard_normal((6, 6))
    p0 = a @ a.T * 1e-6
    prediction = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, p0, 400.0)
    for t in (10.0, 123.4, 400.0):
        s = prediction.state(t)
        p = prediction._covariance(np.array((t,)), slice(None))[0]
        expected = make_state(t, N, s.q_eci_from_body, s.omega_body, p)
        np.testing.assert_array_equal(s.covariance, expected.covariance)
        np.testing.assert_array_equal(s.covariance_hill, expected.covariance_hill)
        np.testing.assert_array_equal(s.omega_hill, expected.omega_hill)
        np.testing.assert_array_equal(s.q_hill_from_body, expected.q_hill_from_body)
        assert s.t == expected.t == t
        same = make_state(t, N, s.q_eci_from_body, s.omega_body, expected.covariance, symmetric=True)
        np.testing.assert_array_equal(same.covariance, expected.covariance)
        np.testing.assert_array_equal(same.covariance_hill, expected.covariance_hill)
    assert 'covariance_hill=array' in repr(prediction.state(20.0))
    bare = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, None, 400.0, with_covariance=False).state(50.0)
    assert bare.covariance is None and bare.covariance_hill is None


def test_covariance_nodes_are_the_previous_chain_to_the_bit():
    """The prediction's covariance at its substep ends (P_k+1 = Phi_k P_k Phi_k' + Qd_k, now with ndarray.dot) is
    the chain as it was computed before (@ into a preallocated stack), to the bit."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER, torque_psd=1e-6)
    a = np.random.default_rng(3).standard_normal((6, 6))
    p0 = a @ a.T * 1e-6
    prediction = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, p0, 300.0)
    nodes, p, p_dot = prediction._covariance_nodes()
    w = prediction._dense(nodes)[4:7].T
    phi, qd = dyn.substep_transition_many(w[:-1], w[1:], np.diff(nodes))
    expected = np.empty((nodes.size, 6, 6))
    expected[0] = p_k = p0
    for k in range(nodes.size - 1):
        expected[k + 1] = p_k = phi[k] @ p_k @ phi[k].T + qd[k]
    np.testing.assert_array_equal(p, expected)
    fp = dyn.jacobian_many(w) @ expected
    np.testing.assert_array_equal(p_dot, fp + np.swapaxes(fp, 1, 2) + dyn.noise_density)
    assert nodes.size > 100
    # the Hermite interpolant between them, from the blocks gathered per node, as it was from the full stack
    t = np.random.default_rng(5).uniform(10.0, 300.0, 500)
    for block in (slice(3), slice(None)):
        k = np.minimum(np.searchsorted(nodes, t, side='right') - 1, nodes.size - 2)
        h = (nodes[k + 1] - nodes[k])[:, None, None]
        s = (t - nodes[k])[:, None, None] / h
        s2 = s * s
        h00, h10, h01, h11 = 1.0 - 3.0 * s2 + 2.0 * s2 * s, s - 2.0 * s2 + s2 * s, 3.0 * s2 - 2.0 * s2 * s, s2 * s - s2
        previous = (h00 * p[k, block, block] + (h10 * h) * p_dot[k, block, block]
                    + h01 * p[k + 1, block, block] + (h11 * h) * p_dot[k + 1, block, block])
        np.testing.assert_array_equal(prediction._covariance(t, block), previous)


quaternions = st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1)
small_or_not = st.sampled_from((1e-9, 1e-7, 1e-3, 0.5, 3.0))


@settings(max_examples=200, deadline=None)
@given(quaternions, quaternions, st.tuples(*[st.floats(-1.0, 1.0)] * 3), small_or_not,
       st.floats(0.0, 1e5), st.sampled_from((N, 1e-3)))
def test_quaternion_floats_are_rotations_to_the_bit(q1, q2, axis, scale, t, n):
    """target_motion's quaternions on floats (the filter's update, make_state) are flyby_sim's rotation and
    orbital functions, to the bit: products, normalization, the log map on either side of its small-angle
    switch and for w < 0, the exp map, q_eci_from_hill (also from its cache) and the hill attitude of make_state."""
    from flyby_estimation.target_motion import (
        q_eci_from_hill_floats,
        quat_exp_floats,
        quat_normalize_floats,
        quat_product_floats,
        rotation_vector_floats,
    )
    from flyby_sim.dynamics.orbital import quat_eci_from_hill

    np.testing.assert_array_equal(quat_product_floats(q1, q2), quat_multiply(np.array(q1), np.array(q2)))
    np.testing.assert_array_equal(quat_normalize_floats(q1), quat_normalize(np.array(q1)))
    r = np.array(axis) * scale
    small = quat_multiply(np.array(q1), quat_from_rotation_vector(r))
    for q in (q1, (-q1[0], -q1[1], -q1[2], -q1[3]), tuple(small), quat_from_rotation_vector(r).tolist()):
        np.testing.assert_array_equal(rotation_vector_floats(q), rotation_vector_from_quat(np.array(q)))
    np.testing.assert_array_equal(quat_exp_floats(r.tolist()), quat_from_rotation_vector(r))
    for _ in range(2):  # computed, then from the cache
        np.testing.assert_array_equal(q_eci_from_hill_floats(t, n), quat_eci_from_hill(t, n))
    q_eci = quat_normalize(np.array(q2))
    s = make_state(t, n, q_eci, np.array(axis), None)
    np.testing.assert_array_equal(s.q_hill_from_body, q_hill_from_body(t, n, q_eci))
    np.testing.assert_array_equal(s.omega_hill, quat_to_matrix(q_hill_from_body(t, n, q_eci)) @ np.array(axis))


def test_dense_solution_is_scipys_to_the_bit():
    """DenseSolution (all times at once) gives scipy's OdeSolution values to the bit and in its layout: times
    unsorted, repeated, on the solver's steps (the lower segment), at both ends and outside; a scalar and no
    time at all go to scipy itself."""
    dyn = ErrorStateDynamics(INERTIA_TUMBLER, torque_psd=1e-6)
    prediction = MotionPrediction(dyn, N, 10.0, Q0, OMEGA_TUMBLER, np.eye(6) * 1e-8, 610.0)
    dense = prediction._dense
    scipy_solution = dense._solution
    steps = scipy_solution.ts
    rng = np.random.default_rng(4)
    for times in (rng.uniform(10.0, 610.0, 500), np.linspace(10.0, 610.0, 1201), steps, steps[::-1],
                  np.array((10.0, 10.0, 610.0, 5.0, 700.0, steps[7], steps[7])), np.array((123.4,))):
        got, expected = dense(times), scipy_solution(times)
        np.testing.assert_array_equal(got, expected)
        assert got.flags.c_contiguous and got.shape == expected.shape
    np.testing.assert_array_equal(dense(123.4), scipy_solution(123.4))
    with pytest.raises(ValueError):
        dense(np.array(()))  # as scipy (nothing to stack)


@settings(max_examples=15, deadline=None)
@given(inertias, quaternions, st.tuples(*[st.floats(-0.4, 0.4)] * 3), st.floats(1.0, 900.0))
def test_dop853_reference_is_solve_ivps_to_the_bit(inertia, q, omega, span):
    """dop853_reference (solve_ivp's loop around scipy's DOP853, the rate called without its wrappers) gives
    solve_ivp's steps, states and dense output, to the bit."""
    dyn = ErrorStateDynamics(inertia)
    y0 = np.concatenate((quat_normalize(q), omega))
    expected = solve_ivp(dyn.reference_rate, (10.0, 10.0 + span), y0, method='DOP853', rtol=1e-9, atol=1e-12,
                         dense_output=True)
    solution, y_steps = dop853_reference(dyn, 10.0, 10.0 + span, y0, 1e-9, 1e-12)
    np.testing.assert_array_equal(solution.ts, expected.t)
    np.testing.assert_array_equal(y_steps, expected.y)
    times = np.linspace(10.0, 10.0 + span, 301)
    np.testing.assert_array_equal(solution(times), expected.sol(times))
    np.testing.assert_array_equal(solution(10.0 + span / 3.0), expected.sol(10.0 + span / 3.0))


def test_seed000_eq4_perturbed_predictions_are_separate_predictions_of_the_perturbed_estimates():
    """perturbed_predictions integrates K torque-free motions as one system: each is the MotionPrediction of its own
    estimate (q_ref * exp(dtheta), omega_ref + domega, the filter's error convention), within the tolerances, for
    an intermediate-axis tumbler whose perturbed motions part over 1000 s."""
    dyn = ErrorStateDynamics(np.diag([1200.0, 1000.0, 2000.0]))
    n = 1.078e-3
    q0 = np.array([0.1, 0.2, 0.3, 0.9]) / np.linalg.norm([0.1, 0.2, 0.3, 0.9])
    w0 = np.radians([-8.2, -0.6, -0.2])
    errors = np.array([np.zeros(6), [0.02, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, -0.01, 0.0, 0.0, 1e-3, 0.0],
                       [0.0, 0.0, 0.0, 0.0, 0.0, -2e-3]])
    together = perturbed_predictions(dyn, n, 100.0, q0, w0, errors, 1100.0)
    times = np.linspace(100.0, 1100.0, 41)
    parted = 0.0
    for e, p in zip(errors, together, strict=True):
        q = quat_multiply(q0, quat_from_rotation_vector(e[:3]))
        alone = MotionPrediction(dyn, n, 100.0, q, w0 + e[3:], None, 1100.0, with_covariance=False)
        assert np.abs(alone.c_hill_from_body(times) - p.c_hill_from_body(times)).max() < 1e-5
        assert np.abs(alone.state(777.0).omega_body - p.state(777.0).omega_body).max() < 1e-8
        assert p.state(100.0).covariance is None
        parted = max(parted, np.abs(p.c_hill_from_body(times) - together[0].c_hill_from_body(times)).max())
    assert parted > 0.1  # the motions differ: the test compares motions, not copies of one
