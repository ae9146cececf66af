"""rigid_body.py: seed 001 eq 3 / seed 000 eq 4 with reaction wheels, its conservation laws and wheel limits."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rigid_body_strategies import inertia_from, principal_moments, rate, rotation_vector
from scipy.integrate import solve_ivp

from flyby_sim.dynamics.attitude import euler_rate, kinetic_energy, quaternion_rate
from flyby_sim.dynamics.rigid_body import (
    ChaserAttitudeState,
    GyrostatPropagator,
    ReactionWheels,
    gyrostat_rates,
    gyrostat_rates_floats,
    substep_count,
    total_angular_momentum_inertial,
)
from flyby_sim.dynamics.rotation import quat_normalize

SEED001_SERVICER = np.diag([13.0, 38.0, 35.0])  # seed 001 Table 1, the servicing satellite S_r [kg m^2]
WHEELS = ReactionWheels.orthogonal(max_torque_n_m=0.1, max_momentum_n_m_s=4.0, spin_inertia_kg_m2=0.01)
PYRAMID = ReactionWheels(  # four wheels, 54.74 deg from the body z axis, for an N > 3 assembly
    [[1.0, 0.0, 1.0 / math.sqrt(2)], [0.0, 1.0, 1.0 / math.sqrt(2)], [-1.0, 0.0, 1.0 / math.sqrt(2)],
     [0.0, -1.0, 1.0 / math.sqrt(2)]], 0.1, 4.0, 0.01)


def relative_drifts(propagator, state, t_end_s, dt_s, wheel_torque_n_m=None):
    """(max relative drift of total inertial angular momentum, of 1/2 omega.I omega (nan from rest), end state),
    sampled every step."""
    wheels, inertia = propagator.wheels, propagator.inertia
    u = np.zeros(wheels.count) if wheel_torque_n_m is None else wheel_torque_n_m
    h0 = total_angular_momentum_inertial(state, inertia, wheels)
    energy0 = kinetic_energy(state.omega_body, inertia)
    worst_h = worst_energy = 0.0
    for _ in range(int(round(t_end_s / dt_s))):
        state = propagator.step(state, dt_s, (0.0, 0.0, 0.0), u).state
        h = total_angular_momentum_inertial(state, inertia, wheels)
        worst_h = max(worst_h, float(np.linalg.norm(h - h0) / np.linalg.norm(h0)))
        energy_change = abs(kinetic_energy(state.omega_body, inertia) - energy0)
        worst_energy = max(worst_energy, energy_change / energy0) if energy0 > 0.0 else math.nan
    return worst_h, worst_energy, state


@settings(max_examples=4, deadline=None)
@given(principal_moments, rotation_vector, st.tuples(rate, rate, rate).filter(lambda w: np.linalg.norm(w) > 0.02),
       st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.floats(-2.0, 2.0)))
def test_seed001_eq3_torque_free_conserves_momentum_and_energy(moments, axes_rotvec, omega0, h_wheels0):
    """No torque for 1000 s in 1 s steps, with constant wheel momentum: H and 1/2 omega.I omega to 1e-9."""
    propagator = GyrostatPropagator(inertia_from(moments, axes_rotvec), WHEELS)
    state = ChaserAttitudeState(quat_normalize([0.3, -0.1, 0.5, 0.8]), np.array(omega0), np.array(h_wheels0))
    momentum_drift, energy_drift, end = relative_drifts(propagator, state, 1000.0, 1.0)
    assert momentum_drift < 1e-9
    assert energy_drift < 1e-9
    assert end.h_wheels_n_m_s.tolist() == list(h_wheels0)  # h_dot = u = 0


@settings(max_examples=5, deadline=None)
@given(principal_moments, rotation_vector, st.tuples(rate, rate, rate),
       st.lists(st.floats(-0.1, 0.1), min_size=4, max_size=4))
def test_wheel_torque_exchanges_momentum_and_keeps_the_total(moments, axes_rotvec, omega0, torques):
    """Wheel motor torques, no external torque: the total inertial momentum (body + wheels) stays to 1e-9
    over 100 s while the wheels' share changes (four wheels in a pyramid)."""
    propagator = GyrostatPropagator(inertia_from(moments, axes_rotvec), PYRAMID)
    state = ChaserAttitudeState(np.array([0.0, 0.0, 0.0, 1.0]), np.array(omega0), np.array([0.5, -0.5, 0.2, 0.0]))
    momentum_drift, _, end = relative_drifts(propagator, state, 100.0, 0.5, np.array(torques))
    assert momentum_drift < 1e-9
    moved = np.clip(state.h_wheels_n_m_s + 100.0 * np.array(torques), -4.0, 4.0)  # h_dot = u, up to the limit
    assert np.allclose(end.h_wheels_n_m_s, moved, rtol=0.0, atol=1e-12)


def test_seed001_eq3_rates_agree_with_the_total_momentum_balance():
    """dH/dt = M_ext for H = I omega + A h, by differentiating in the body frame: d/dt(I w + A h) + w x H."""
    rng = np.random.default_rng(3)
    inertia = inertia_from([20.0, 30.0, 25.0], [0.2, -0.4, 0.1])
    omega, h, u, m_ext = rng.normal(size=3), rng.normal(size=4), rng.normal(size=4), rng.normal(size=3)
    axes = PYRAMID.axes_body
    _, omega_dot, h_dot = gyrostat_rates([0, 0, 0, 1], omega, h, inertia, np.linalg.inv(inertia), axes, m_ext, u)
    h_body = inertia @ omega + axes.T @ h
    assert np.allclose(inertia @ omega_dot + axes.T @ h_dot + np.cross(omega, h_body), m_ext, atol=1e-12)
    # No wheels: exactly attitude.euler_rate (the target's Euler equation).
    _, omega_dot_bare, _ = gyrostat_rates([0, 0, 0, 1], omega, [], inertia, np.linalg.inv(inertia), [], m_ext, [])
    assert np.array_equal(omega_dot_bare, euler_rate(omega, inertia, np.linalg.inv(inertia), m_ext))


def test_step_matches_an_independent_solve_ivp_with_external_and_wheel_torques():
    """One 20 s step against scipy's Radau on the same equations written out with numpy (to 1e-8)."""
    inertia = SEED001_SERVICER
    q0, omega0, h0 = quat_normalize([0.1, 0.2, -0.3, 0.9]), np.array([0.05, -0.02, 0.03]), np.array([0.3, -1.0, 0.5])
    m_ext, u = np.array([0.01, -0.02, 0.005]), np.array([0.05, 0.02, -0.08])
    state = GyrostatPropagator(inertia, WHEELS).step(ChaserAttitudeState(q0, omega0, h0), 20.0, m_ext, u).state

    def rhs(_t, y):
        q, w, h = y[:4], y[4:7], y[7:]
        x, yy, z, s = q
        q_dot = 0.5 * np.array([[s, -z, yy], [z, s, -x], [-yy, x, s], [-x, -yy, -z]]) @ w
        w_dot = np.linalg.solve(inertia, m_ext - np.cross(w, inertia @ w + h) - u)
        return np.concatenate((q_dot, w_dot, u))

    ref = solve_ivp(rhs, (0.0, 20.0), np.concatenate((q0, omega0, h0)), method='Radau', rtol=1e-11, atol=1e-13).y[:, -1]
    assert np.allclose(state.q_inertial_from_body, ref[:4] / np.linalg.norm(ref[:4]), atol=1e-8)
    assert np.allclose(state.omega_body, ref[4:7], atol=1e-8)
    assert np.allclose(state.h_wheels_n_m_s, ref[7:], atol=1e-10)


def test_wheel_limits_are_applied_and_reported():
    """Torque clipped to 0.1 N m, momentum stopped at 4 N m s partway through a step, both reported."""
    propagator = GyrostatPropagator(SEED001_SERVICER, WHEELS)
    state = ChaserAttitudeState(np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3), np.array([3.95, 0.0, -4.0]))
    result = propagator.step(state, 1.0, (0.0, 0.0, 0.0), [0.1, 0.5, -0.1])
    assert result.torque_limited.tolist() == [False, True, False]
    assert result.momentum_limited.tolist() == [True, False, True]
    # Wheel 0 reaches 4 N m s after 0.5 s; wheel 2 starts on its limit and gets nothing.
    assert np.allclose(result.wheel_torque_applied_n_m, [0.05, 0.1, 0.0], rtol=0.0, atol=1e-15)
    assert result.state.h_wheels_n_m_s.tolist() == [4.0, pytest.approx(0.1, abs=1e-15), -4.0]
    # Away from the limit again: torque toward zero momentum is applied in full.
    back = propagator.step(result.state, 1.0, (0.0, 0.0, 0.0), [-0.1, 0.0, 0.1])
    assert not back.momentum_limited.any() and np.allclose(back.state.h_wheels_n_m_s, [3.9, 0.1, -3.9])


def test_wheel_speed_is_relative_to_the_body():
    speeds = WHEELS.speeds_rad_s([1.0, 0.0, 0.0], [0.1, 0.0, 0.0])
    assert np.allclose(speeds, [1.0 / 0.01 - 0.1, 0.0, 0.0])


def test_bad_inputs_name_themselves():
    propagator = GyrostatPropagator(SEED001_SERVICER, WHEELS)
    state = ChaserAttitudeState(np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match='dt_s'):
        propagator.step(state, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match='wheel_torque_cmd_n_m'):
        propagator.step(state, 0.1, (0.0, 0.0, 0.0), (0.0, math.nan, 0.0))
    with pytest.raises(ValueError, match='torque_ext_body_n_m'):
        propagator.step(state, 0.1, (0.0, 0.0), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match='exceeds max_momentum_n_m_s'):
        propagator.step(state._replace(h_wheels_n_m_s=np.array([5.0, 0.0, 0.0])), 0.1, (0, 0, 0), (0, 0, 0))
    with pytest.raises(ValueError, match='max_torque_n_m'):
        ReactionWheels.orthogonal(-0.1, 4.0, 0.01)
    with pytest.raises(ValueError, match='zero axis'):
        ReactionWheels([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]], 0.1, 4.0, 0.01)
    with pytest.raises(ValueError, match='positive definite'):
        GyrostatPropagator(np.diag([1.0, -1.0, 1.0]), WHEELS)


@settings(max_examples=30, deadline=None)
@given(principal_moments, rotation_vector, st.tuples(rate, rate, rate),
       st.lists(st.floats(-2.0, 2.0), min_size=4, max_size=4), st.lists(st.floats(-0.1, 0.1), min_size=4, max_size=4),
       st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)))
def test_gyrostat_rates_on_floats_are_the_targets_euler_equation_with_the_wheels_to_the_bit(moments, rotvec, omega,
                                                                                              h, u, torque):
    """The float version of seed 001 eq 3 with the wheels is the wheels' torque terms followed by the target's
    own attitude.euler_rate and attitude.quaternion_rate (the same operations in the same order)."""
    inertia = inertia_from(moments, rotvec)
    i = tuple(map(tuple, inertia.tolist()))
    i_inv = tuple(map(tuple, np.linalg.inv(inertia).tolist()))
    axes = tuple(map(tuple, PYRAMID.axes_body.tolist()))
    q = quat_normalize([0.3, -0.1, 0.5, 0.8]).tolist()
    wx, wy, wz = omega
    mx, my, mz = torque
    for (ax, ay, az), hk, uk in zip(axes, h, u, strict=True):  # - omega x (a h) - a u
        mx -= (wy * az - wz * ay) * hk + ax * uk
        my -= (wz * ax - wx * az) * hk + ay * uk
        mz -= (wx * ay - wy * ax) * hk + az * uk
    reference = (quaternion_rate(q, omega).tolist() + euler_rate(omega, i, i_inv, (mx, my, mz)).tolist()
                 + [float(x) for x in u])
    assert gyrostat_rates_floats(q, omega, h, i, i_inv, axes, torque, u) == reference
    q_dot, omega_dot, h_dot = gyrostat_rates(q, omega, h, i, i_inv, axes, torque, u)
    assert q_dot.tolist() + omega_dot.tolist() + h_dot.tolist() == reference


def test_substep_count_bounds_the_turn_of_the_body_and_of_its_rate():
    """|omega| dt or |I omega + A h| / I_min dt, whichever is larger, over the largest angle per substep."""
    assert substep_count((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 5.0, 0.05, 0.01) == 1
    assert substep_count((0.3, 0.0, 0.4), (0.0, 0.0, 0.0), 5.0, 0.05, 0.01) == 3  # 0.5 rad/s x 0.05 s / 0.01 rad
    assert substep_count((0.0, 0.0, 0.0), (0.0, 4.0, 3.0), 5.0, 0.05, 0.01) == 5  # wheels: 5 N m s / 5 kg m^2
