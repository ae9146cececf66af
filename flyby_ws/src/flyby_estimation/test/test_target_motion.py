"""target_motion.py and motion_category.py: the prediction and its covariance (seed 000 eq 4, 6-9) against the
dense references to the bit, a body point's state and Jacobian, categories I-IV (seed 000 section 2.1)."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.motion_category import MotionThresholds, classify_motion
from flyby_estimation.target_motion import (
    MotionPrediction,
    body_point_in_hill,
    covariance_from_published,
    covariance_in_hill,
    dop853_reference,
    make_state,
    orbit_rate_hill,
    perturbed_predictions,
    prediction_from_estimate,
)
from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.orbital import mean_motion_rad_s, q_hill_from_body
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    quat_normalize,
    quat_to_matrix,
    rotation_vector_from_quat,
)
from flyby_sim.scenario import load_scenario
from flyby_testing import SCENARIOS, error_between, perturbed

N = mean_motion_rad_s(7.0e6)
# Seed 001 Table 1: the tumbler.
INERTIA_TUMBLER = np.diag([4069.0, 12030.0, 11029.0])
OMEGA_TUMBLER = np.array([0.3, 0.2, 0.1])
# The scenario schema's category thresholds (seed 000 section 2.1; paper_flyby leaves them out).
MOTION = MotionThresholds.from_scenario(load_scenario(SCENARIOS / 'paper_flyby.yaml'))
Q0 = quat_normalize([0.1, -0.2, 0.3, 0.9])

inertias = st.tuples(*[st.floats(100.0, 5000.0)] * 3, *[st.floats(-50.0, 50.0)] * 3).map(
    lambda v: np.diag(v[:3]) + np.array(((0.0, v[3], v[4]), (v[3], 0.0, v[5]), (v[4], v[5], 0.0))))
quaternions = st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1)


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
    result = classify_motion(omega_hill, N, MOTION, excursion)
    assert result.category == category, result.reason
    assert result.reason


def test_seed001_tumbler_is_category_iv_at_default_thresholds():
    """|(0.3, 0.2, 0.1)| rad/s = 21.4 deg/s, a 17 s period: faster than the fly-by range (20-3600 s)."""
    result = classify_motion(OMEGA_TUMBLER, N, MOTION)
    assert result.category == 'IV'
    assert classify_motion(OMEGA_TUMBLER, N, dataclasses.replace(MOTION, spin_rate_rad_s=0.5)).category == 'III'


def test_classify_rejects_bad_input():
    with pytest.raises(ValueError, match='omega_hill'):
        classify_motion([math.nan, 0.0, 0.0], N, MOTION)
    with pytest.raises(ValueError, match='spin_rate_rad_s'):
        dataclasses.replace(MOTION, spin_rate_rad_s=-1.0)


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
