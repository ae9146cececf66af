"""orbital.py: seed 000 eq 1, 2, 22, 23 and the hill/ECI conventions."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from flyby_sim.dynamics.constants import MU_EARTH_M3_S2
from flyby_sim.dynamics.orbital import (
    cw_accel,
    cw_accel_components,
    cw_transition_matrix,
    eci_from_relative,
    eci_vector_in_hill,
    hill_axes_in_eci,
    mean_motion_rad_s,
    nonlinear_relative_accel,
    nonlinear_relative_accel_components,
    q_hill_from_body,
    q_hill_from_body_many,
    quat_eci_from_hill,
    relative_from_eci,
    rk4_step,
    rk4_step_floats,
    target_eci_state,
)
from flyby_sim.dynamics.rotation import quat_normalize, quat_to_matrix

RADIUS_M = 7.0e6
N = mean_motion_rad_s(RADIUS_M)


def cw_rhs(t, y):
    return np.concatenate((y[3:], cw_accel(y[:3], y[3:], N)))


def test_mean_motion_of_7000_km_orbit():
    assert N == pytest.approx(math.sqrt(MU_EARTH_M3_S2 / RADIUS_M**3), rel=1e-15)
    assert 2 * math.pi / N == pytest.approx(5828.5, abs=0.1)  # period [s]
    with pytest.raises(ValueError, match='radius_m'):
        mean_motion_rad_s(-1.0)


@pytest.mark.parametrize('t', [1.0, 300.0, 1500.0, 5828.5, 9000.0, -700.0])
def test_seed000_eq22_matches_integration_of_eq2(t):
    """Each column of Phi(t) is the eq 2 solution from a unit initial state (signs as printed)."""
    phi = cw_transition_matrix(N, t)
    for j in range(6):
        y0 = np.eye(6)[j]
        sol = solve_ivp(cw_rhs, (0.0, t), y0, method='DOP853', rtol=1e-13, atol=1e-15)
        column = sol.y[:, -1]
        assert np.linalg.norm(phi[:, j] - column) <= 1e-9 * np.linalg.norm(column)


def test_seed000_eq22_is_identity_at_zero_and_solves_eq2():
    np.testing.assert_array_equal(cw_transition_matrix(N, 0.0), np.eye(6))
    # d/dt Phi = A Phi with A the eq 2 system matrix, by central differences.
    a = np.array([cw_rhs(0.0, e) for e in np.eye(6)]).T
    t, dt = 1234.0, 1e-2
    dphi = (cw_transition_matrix(N, t + dt) - cw_transition_matrix(N, t - dt)) / (2 * dt)
    np.testing.assert_allclose(dphi, a @ cw_transition_matrix(N, t), atol=1e-9)


times = st.floats(-2.0e4, 2.0e4, allow_nan=False)
rates = st.floats(1.0e-4, 2.0e-3, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(rates, times, times)
def test_property_seed000_eq22_composition(n, a, b):
    """Phi(a + b) = Phi(a) Phi(b)."""
    lhs = cw_transition_matrix(n, a + b)
    rhs = cw_transition_matrix(n, a) @ cw_transition_matrix(n, b)
    scale = np.linalg.norm(cw_transition_matrix(n, a)) * np.linalg.norm(cw_transition_matrix(n, b))
    assert np.max(np.abs(lhs - rhs)) <= 1e-12 * scale


@settings(max_examples=200, deadline=None)
@given(rates, times)
def test_property_seed000_eq23_inverse_is_negative_time(n, t):
    """Phi(t)^-1 = Phi(-t): Phi(t) Phi(-t) = I."""
    phi = cw_transition_matrix(n, t)
    product = phi @ cw_transition_matrix(n, -t)
    assert np.max(np.abs(product - np.eye(6))) <= 1e-12 * np.linalg.norm(phi) ** 2


def test_seed000_eq1_nonlinear_reduces_to_eq2_for_small_offsets():
    """The nonlinear minus linear acceleration is second order: n^2 |p|^2 / R scale."""
    v = np.array([0.1, -0.05, 0.02])
    for p in ([50.0, 0.0, 0.0], [0.0, 30.0, 0.0], [0.0, 0.0, -40.0], [20.0, -10.0, 35.0]):
        p = np.array(p)
        diff = nonlinear_relative_accel(p, v, N, RADIUS_M) - cw_accel(p, v, N)
        bound = 3.0 * N**2 * (p @ p) / RADIUS_M
        assert np.linalg.norm(diff) <= bound
        assert np.linalg.norm(diff) > 0.0


def test_seed000_eq1_nonlinear_accel_is_exact_differential_gravity():
    """Against the textbook form in ECI with extended precision (numpy longdouble), near and far."""
    for p, v in (([50.0, 1.0, -2.0], [0.01, 0.02, -0.03]), ([3.0e4, -2.0e4, 1.0e4], [5.0, 1.0, -2.0])):
        r_t, v_t = target_eci_state(0.0, RADIUS_M, N)
        c = hill_axes_in_eci(0.0, N).astype(np.longdouble)
        p_eci = c @ np.array(p, dtype=np.longdouble)
        r_t = r_t.astype(np.longdouble)
        r_c = r_t + p_eci
        mu = np.longdouble(N) ** 2 * np.longdouble(RADIUS_M) ** 3
        dg = -mu * r_c / np.sqrt(r_c @ r_c) ** 3 + mu * r_t / np.sqrt(r_t @ r_t) ** 3
        omega = c @ np.array([0.0, -N, 0.0], dtype=np.longdouble)
        v_eci = c @ np.array(v, dtype=np.longdouble)
        a_rot = dg - 2 * np.cross(omega, v_eci) - np.cross(omega, np.cross(omega, p_eci))
        expected = (c.T @ a_rot).astype(float)
        got = nonlinear_relative_accel(p, v, N, RADIUS_M)
        # longdouble is 80-bit on x86 (eps 1e-19): the reference itself is good to ~1e-19 * g.
        assert np.linalg.norm(got - expected) <= 1e-15 * np.linalg.norm(expected) + 1e-18


def test_external_acceleration_adds_linearly():
    p, v, a = [10.0, 2.0, -3.0], [0.1, 0.0, 0.2], [1e-3, -2e-3, 3e-3]
    np.testing.assert_allclose(nonlinear_relative_accel(p, v, N, RADIUS_M, a)
                               - nonlinear_relative_accel(p, v, N, RADIUS_M), a, atol=1e-17)
    np.testing.assert_allclose(cw_accel(p, v, N, a) - cw_accel(p, v, N), a, atol=1e-17)


def test_hill_axes_convention_at_t0_and_rotation_rate():
    c0 = hill_axes_in_eci(0.0, N)
    np.testing.assert_array_equal(c0[:, 0], [0.0, 1.0, 0.0])  # hill x = ECI +y
    np.testing.assert_array_equal(c0[:, 1], [0.0, 0.0, -1.0])  # hill y = ECI -z
    np.testing.assert_array_equal(c0[:, 2], [-1.0, 0.0, 0.0])  # hill z = ECI -x
    r_t, v_t = target_eci_state(0.0, RADIUS_M, N)
    np.testing.assert_array_equal(r_t, [RADIUS_M, 0.0, 0.0])
    assert v_t[1] > 0.0
    # The hill frame turns at Omega = [0, -n, 0] in its own axes: skew(Omega) = C^T dC/dt.
    t, dt = 1000.0, 1e-3
    dc = (hill_axes_in_eci(t + dt, N) - hill_axes_in_eci(t - dt, N)) / (2 * dt)
    skew = hill_axes_in_eci(t, N).T @ dc
    np.testing.assert_allclose([skew[2, 1], skew[0, 2], skew[1, 0]], [0.0, -N, 0.0], atol=1e-12)
    for tt in (0.0, 100.0, 4000.0):
        np.testing.assert_allclose(quat_to_matrix(quat_eci_from_hill(tt, N)), hill_axes_in_eci(tt, N),
                                   atol=1e-15)


def test_eci_vector_in_hill_is_the_transposed_hill_axes_for_many_times():
    v = np.array((0.3, -1.2, 0.7))
    t = np.array((0.0, 250.0, 4000.0))
    expected = np.array([hill_axes_in_eci(tt, N).T @ v for tt in t])
    np.testing.assert_allclose(eci_vector_in_hill(v, t, N), expected, atol=1e-15)
    np.testing.assert_allclose(eci_vector_in_hill(v, 250.0, N), expected[1], atol=1e-15)
    per_time = np.array((v, 2 * v, -v))
    np.testing.assert_allclose(eci_vector_in_hill(per_time, t, N), expected * [[1], [2], [-1]], atol=1e-15)
    # An inertially fixed vector turns in hill by n t about +y (opposite to the frame's -n about y).
    u0 = eci_vector_in_hill(v, 0.0, N)
    a = N * 250.0
    rot_y = np.array(((math.cos(a), 0.0, math.sin(a)), (0.0, 1.0, 0.0), (-math.sin(a), 0.0, math.cos(a))))
    np.testing.assert_allclose(expected[1], rot_y @ u0, atol=1e-15)


def test_nonlinear_accel_of_many_states_at_once():
    rng = np.random.default_rng(3)
    r, v = rng.normal(0.0, 50.0, (3, 5)), rng.normal(0.0, 0.1, (3, 5))
    together = nonlinear_relative_accel(r, v, N, RADIUS_M)
    one_by_one = np.array([nonlinear_relative_accel(r[:, k], v[:, k], N, RADIUS_M) for k in range(5)]).T
    np.testing.assert_allclose(together, one_by_one, rtol=1e-14, atol=1e-20)


def test_eci_round_trip_and_circular_neighbour():
    r_t, v_t = target_eci_state(2000.0, RADIUS_M, N)
    r_hill, v_hill = np.array([30.0, -5.0, 12.0]), np.array([0.05, 0.01, -0.02])
    r_c, v_c = eci_from_relative(r_hill, v_hill, r_t, v_t)
    r_back, v_back = relative_from_eci(r_c, v_c, r_t, v_t)
    np.testing.assert_allclose(r_back, r_hill, atol=1e-8)
    np.testing.assert_allclose(v_back, v_hill, atol=1e-11)
    # A spacecraft on the same circular orbit 10 s ahead sits still in hill, ahead (+x) and slightly
    # toward Earth (+z), with |p| the chord length.
    r_c, v_c = target_eci_state(2010.0, RADIUS_M, N)
    r_hill, v_hill = relative_from_eci(r_c, v_c, r_t, v_t)
    chord = 2 * RADIUS_M * math.sin(5.0 * N)
    assert r_hill[0] > 0.0 and r_hill[2] > 0.0 and abs(r_hill[1]) < 1e-9
    assert np.linalg.norm(r_hill) == pytest.approx(chord, rel=1e-12)
    np.testing.assert_allclose(v_hill, 0.0, atol=1e-9)


def test_relative_from_eci_rejects_degenerate_target_state():
    with pytest.raises(ValueError, match='orbit plane'):
        relative_from_eci([1.0, 0, 0], [0, 0, 0], [RADIUS_M, 0, 0], [1.0, 0, 0])


def test_rk4_step_is_fourth_order():
    def f(t, y):
        return -y

    errors = []
    for h in (0.1, 0.05):
        y = np.array([1.0])
        for k in range(int(round(1.0 / h))):
            y = rk4_step(f, k * h, y, h)
        errors.append(abs(y[0] - math.exp(-1.0)))
    assert errors[0] / errors[1] == pytest.approx(16.0, rel=0.05)


def test_float_accelerations_and_rk4_equal_the_numpy_ones_to_the_bit():
    rng = np.random.default_rng(11)
    for _ in range(200):
        y = rng.normal(0.0, [60.0, 60.0, 60.0, 0.1, 0.1, 0.1])
        a_ext = tuple(rng.normal(0.0, 1e-3, 3).tolist())
        h = float(rng.uniform(1e-3, 0.05))
        state = y.tolist()
        assert nonlinear_relative_accel_components(state[:3], state[3:], N, RADIUS_M, a_ext) == tuple(
            nonlinear_relative_accel(state[:3], state[3:], N, RADIUS_M, a_ext).tolist())
        assert cw_accel_components(state[:3], state[3:], N, a_ext) == tuple(
            cw_accel(state[:3], state[3:], N, a_ext).tolist())

        def rhs_numpy(t, s, a_ext=a_ext):
            return np.concatenate((s[3:], nonlinear_relative_accel(s[:3].tolist(), s[3:].tolist(), N, RADIUS_M, a_ext)))

        def rhs_floats(t, s, a_ext=a_ext):
            return (*s[3:], *nonlinear_relative_accel_components(s[:3], s[3:], N, RADIUS_M, a_ext))

        assert rk4_step_floats(rhs_floats, 3.0, state, h) == rk4_step(rhs_numpy, 3.0, y, h).tolist()


def test_q_hill_from_body_many_equals_one_at_a_time_to_the_bit():
    rng = np.random.default_rng(5)
    t_s = [k * 0.05 for k in range(0, 4000, 37)]
    q_eci_from_body = np.array([quat_normalize(q) for q in rng.normal(size=(len(t_s), 4))])
    together = q_hill_from_body_many(t_s, N, q_eci_from_body)
    assert together.shape == (len(t_s), 4)
    for k, t in enumerate(t_s):
        assert together[k].tolist() == q_hill_from_body(t, N, q_eci_from_body[k]).tolist()
