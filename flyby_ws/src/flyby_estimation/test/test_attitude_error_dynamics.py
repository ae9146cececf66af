"""attitude_error_dynamics.py and quaternion_floats.py: the error dynamics against finite differences and the
integrals they stand for (seed 000 eq 4, 6), the closed-form time update against RK4 and the earlier formulations
to the bit, the float arithmetic against flyby_sim's to the bit."""

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import (
    MotionPrediction,
    make_state,
)
from flyby_sim.dynamics.attitude import euler_rate, quaternion_rate
from flyby_sim.dynamics.orbital import mean_motion_rad_s, q_hill_from_body, rk4_step, rk4_step_floats
from flyby_sim.dynamics.rotation import (
    quat_from_rotation_vector,
    quat_multiply,
    quat_normalize,
    quat_to_matrix,
    rotation_vector_from_quat,
)
from flyby_testing import error_between, perturbed

N = mean_motion_rad_s(7.0e6)
# Seed 001 Table 1: the tumbler, and seed 000 section 5: the stable spinner.
INERTIA_TUMBLER = np.diag([4069.0, 12030.0, 11029.0])
OMEGA_TUMBLER = np.array([0.3, 0.2, 0.1])
INERTIA_PAPER = np.diag([1200.0, 1000.0, 2000.0])
Q0 = quat_normalize([0.1, -0.2, 0.3, 0.9])


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


quaternions = st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1)
small_or_not = st.sampled_from((1e-9, 1e-7, 1e-3, 0.5, 3.0))


@settings(max_examples=200, deadline=None)
@given(quaternions, quaternions, st.tuples(*[st.floats(-1.0, 1.0)] * 3), small_or_not,
       st.floats(0.0, 1e5), st.sampled_from((N, 1e-3)))
def test_quaternion_floats_are_rotations_to_the_bit(q1, q2, axis, scale, t, n):
    """target_motion's quaternions on floats (the filter's update, make_state) are flyby_sim's rotation and
    orbital functions, to the bit: products, normalization, the log map on either side of its small-angle
    switch and for w < 0, the exp map, q_eci_from_hill (also from its cache) and the hill attitude of make_state."""
    from flyby_estimation.quaternion_floats import (
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
