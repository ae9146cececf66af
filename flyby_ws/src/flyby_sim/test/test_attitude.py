"""attitude.py: seed 000 eq 4 / seed 001 eq 3 and the conservation laws of torque-free motion."""

import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from flyby_sim.dynamics.attitude import (
    AttitudePropagator,
    angular_momentum_inertial,
    body_point_state,
    euler_rate,
    kinetic_energy,
    quaternion_rate,
)
from flyby_sim.dynamics.orbital import hill_axes_in_eci
from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_multiply, quat_normalize, quat_to_matrix

STABLE_SPIN = (np.diag([1200.0, 1000.0, 2000.0]), [0.0, 0.0, math.radians(5.0)])  # seed 000 section 5
SEED001_TUMBLER = (np.diag([4069.0, 12030.0, 11029.0]), [0.3, 0.2, 0.1])  # seed 001 Table 1


def conservation_errors(propagator, inertia, t_end, dt):
    """Max relative drift of kinetic energy and inertial angular momentum, sampled every dt."""
    q0, w0 = propagator.state_at(0.0)
    energy0 = kinetic_energy(w0, inertia)
    h0 = angular_momentum_inertial(q0, w0, inertia)
    worst_energy = worst_momentum = 0.0
    for k in range(1, int(round(t_end / dt)) + 1):
        q, w = propagator.state_at(k * dt)
        worst_energy = max(worst_energy, abs(kinetic_energy(w, inertia) - energy0) / energy0)
        h = angular_momentum_inertial(q, w, inertia)
        worst_momentum = max(worst_momentum, np.linalg.norm(h - h0) / np.linalg.norm(h0))
    return worst_energy, worst_momentum


@pytest.mark.parametrize('case', [STABLE_SPIN, SEED001_TUMBLER], ids=['stable_spin', 'seed001_tumbler'])
def test_seed001_table1_energy_and_momentum_conserved_over_1000_s(case):
    inertia, omega0 = case
    q0 = quat_normalize([0.1, -0.3, 0.2, 0.9])
    propagator = AttitudePropagator(q0, omega0, inertia)
    energy_err, momentum_err = conservation_errors(propagator, inertia, 1000.0, 0.05)
    print(f'relative drift over 1000 s: energy {energy_err:.2e}, momentum {momentum_err:.2e}')
    assert energy_err < 1e-9
    assert momentum_err < 1e-9


def test_sampling_seed001_tumbler_every_50_ms_for_1000_s_is_cheap():
    inertia, omega0 = SEED001_TUMBLER
    start = time.perf_counter()
    propagator = AttitudePropagator([0.0, 0.0, 0.0, 1.0], omega0, inertia)
    for k in range(20001):
        propagator.state_at(0.05 * k)
    elapsed = time.perf_counter() - start
    print(f'20001 samples over 1000 s: {elapsed:.3f} s')
    assert elapsed < 3.0  # target < 1 s; headroom for a loaded test machine


def test_dense_output_matches_independent_integration():
    inertia, omega0 = SEED001_TUMBLER
    q0 = quat_normalize([0.2, 0.1, -0.4, 0.8])
    inertia_inv = np.linalg.inv(inertia)

    def rhs(t, y):
        return np.concatenate((quaternion_rate(y[:4], y[4:]), euler_rate(y[4:], inertia, inertia_inv)))

    times = np.sort(np.random.default_rng(3).uniform(0.0, 300.0, 50))
    sol = solve_ivp(rhs, (0.0, 300.0), np.concatenate((q0, omega0)), method='DOP853', t_eval=times,
                    rtol=1e-13, atol=1e-15)
    propagator = AttitudePropagator(q0, omega0, inertia)
    for k, t in enumerate(times):
        q, w = propagator.state_at(t)
        np.testing.assert_allclose(q, sol.y[:4, k] / np.linalg.norm(sol.y[:4, k]), atol=1e-9)
        np.testing.assert_allclose(w, sol.y[4:, k], atol=1e-9)


def test_stable_spin_about_major_axis_keeps_its_rate_and_turns_about_it():
    inertia, omega0 = STABLE_SPIN
    propagator = AttitudePropagator([0.0, 0.0, 0.0, 1.0], omega0, inertia)
    q, w = propagator.state_at(18.0)  # 90 deg at 5 deg/s
    np.testing.assert_allclose(w, omega0, atol=1e-15)
    np.testing.assert_allclose(q, [0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)], atol=1e-12)


def test_seed000_eq4_quaternion_rate_matches_paper_q_matrix():
    """Paper: dq/dt = 1/2 Q_T omega with q = [q0 q1 q2 q3], q0 the scalar."""
    rng = np.random.default_rng(11)
    for _ in range(20):
        x, y, z, w = quat_normalize(rng.normal(size=4))
        q0, q1, q2, q3 = w, x, y, z
        q_matrix = np.array([[-q1, -q2, -q3], [q0, -q3, q2], [q3, q0, -q1], [-q2, q1, q0]])
        omega = rng.normal(size=3)
        paper = 0.5 * q_matrix @ omega  # scalar first
        ours = quaternion_rate([x, y, z, w], omega)
        np.testing.assert_allclose(ours, [paper[1], paper[2], paper[3], paper[0]], atol=1e-15)


def test_seed001_eq3_euler_rate_with_torque():
    inertia = np.array([[100.0, 2.0, -1.0], [2.0, 80.0, 3.0], [-1.0, 3.0, 120.0]])
    omega = np.array([0.1, -0.2, 0.3])
    torque = np.array([0.5, -0.1, 0.2])
    expected = np.linalg.solve(inertia, torque - np.cross(omega, inertia @ omega))
    np.testing.assert_allclose(euler_rate(omega, inertia, np.linalg.inv(inertia), torque), expected,
                               rtol=1e-13)


def test_seed000_eq8_9_body_point_velocity_is_the_derivative_of_its_position():
    """body_point_state's v^H against central differences of eq 8's x^H(t) = C_hill_from_eci(t) C_eci_from_body(t) x_B.

    The body turns at a constant body rate (q(t) = q0 exp(omega t)); the orbit rate is exaggerated so that
    eq 9's orbital-rate term, and its sign, are far above the difference error.
    """
    n_fast = 0.05  # [rad/s]
    q0 = quat_normalize([0.1, -0.2, 0.3, 0.9])
    omega_body = np.array((0.3, 0.2, -0.1))
    x_body = np.array((1.5, 0.0, 1.5))

    def c_hill_from_body(t):
        q_eci_from_body = quat_multiply(q0, quat_from_rotation_vector(omega_body * t))
        return hill_axes_in_eci(t, n_fast).T @ quat_to_matrix(q_eci_from_body)

    h = 1e-4
    for t in (3.0, 17.5, 40.0):
        r, v = body_point_state(c_hill_from_body(t), omega_body, x_body, n_fast)
        np.testing.assert_allclose(r, c_hill_from_body(t) @ x_body, atol=1e-15)  # eq 8
        numeric = (c_hill_from_body(t + h) @ x_body - c_hill_from_body(t - h) @ x_body) / (2 * h)
        np.testing.assert_allclose(v, numeric, atol=1e-8)
        assert np.linalg.norm(np.cross((0.0, -n_fast, 0.0), r)) > 1e4 * np.linalg.norm(v - numeric)


def test_body_point_state_of_a_stack_equals_one_at_a_time():
    rng = np.random.default_rng(8)
    c = np.array([quat_to_matrix(quat_normalize(q)) for q in rng.normal(size=(5, 4))])
    omega_body = rng.normal(size=(5, 3)) * 0.2
    x_body = np.array((1.0, -0.5, 2.0))
    r, v = body_point_state(c, omega_body, x_body, 1e-3)
    assert r.shape == v.shape == (5, 3)
    for k in range(5):
        r_k, v_k = body_point_state(c[k], omega_body[k], x_body, 1e-3)
        np.testing.assert_array_equal(r[k], r_k)
        np.testing.assert_array_equal(v[k], v_k)


def test_state_at_rejects_going_back_and_bad_inputs():
    propagator = AttitudePropagator([0, 0, 0, 1], [0.1, 0.0, 0.0], np.eye(3))
    propagator.state_at(5.0)
    with pytest.raises(ValueError, match='precedes'):
        propagator.state_at(4.0)
    with pytest.raises(ValueError, match='positive definite'):
        AttitudePropagator([0, 0, 0, 1], [0.1, 0.0, 0.0], np.diag([1.0, -1.0, 1.0]))
    with pytest.raises(ValueError, match='omega_body0'):
        AttitudePropagator([0, 0, 0, 1], [math.nan, 0.0, 0.0], np.eye(3))


def test_states_at_equals_state_at_to_the_bit():
    # Times on a 50 ms grid as the plant asks them, in batches that end inside, at and past integrator
    # steps; the first batch starts at t0, where the answer is the initial state itself.
    inertia, omega0 = SEED001_TUMBLER
    one_at_a_time = AttitudePropagator([0.3, -0.1, 0.5, 0.8], omega0, inertia)
    batched = AttitudePropagator([0.3, -0.1, 0.5, 0.8], omega0, inertia)
    k = 0
    for size in (1, 7, 100, 3, 250, 1, 40):
        t_s = [i * 0.05 for i in range(k, k + size)]
        q, omega = batched.states_at(t_s)
        for i, t in enumerate(t_s):
            q_i, omega_i = one_at_a_time.state_at(t)
            assert q[i].tolist() == q_i.tolist() and omega[i].tolist() == omega_i.tolist()
        k += size
    # A time equal to an integrator step's end gives that step's state, as state_at does.
    t_end = float(batched._solver.t)
    q, omega = batched.states_at([t_end, t_end])
    q_ref, omega_ref = one_at_a_time.state_at(t_end)
    assert q[1].tolist() == q[0].tolist() == q_ref.tolist() and omega[0].tolist() == omega_ref.tolist()


def test_states_at_rejects_going_back_and_unsorted_times():
    propagator = AttitudePropagator([0, 0, 0, 1], [0.1, 0.0, 0.0], np.eye(3))
    propagator.states_at([1.0, 2.0])
    with pytest.raises(ValueError, match='precedes'):
        propagator.states_at([1.5, 3.0])
    with pytest.raises(ValueError, match='non-decreasing'):
        propagator.states_at([3.0, 2.5])
    with pytest.raises(ValueError, match='non-decreasing'):
        propagator.states_at([])


moments = st.floats(100.0, 20000.0)
rates = st.floats(-0.5, 0.5)


@settings(max_examples=15, deadline=None)
@given(st.tuples(moments, moments, moments), st.tuples(rates, rates, rates).filter(
    lambda w: sum(c * c for c in w) > 1e-4))
def test_property_torque_free_motion_conserves_energy_and_momentum(moments_kg_m2, omega0):
    inertia = np.diag(moments_kg_m2)
    propagator = AttitudePropagator([0.3, -0.1, 0.5, 0.8], omega0, inertia)
    energy_err, momentum_err = conservation_errors(propagator, inertia, 100.0, 1.0)
    assert energy_err < 1e-9 and momentum_err < 1e-9
