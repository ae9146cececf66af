"""attitude_control.py: wheel-only quaternion feedback, and the 90 deg slew of seed 001's servicer."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_sim.dynamics.attitude_control import (
    QuaternionFeedbackController,
    attitude_error_rotation_vector,
    simulate_slew,
)
from flyby_sim.dynamics.rigid_body import ChaserAttitudeState, GyrostatPropagator, ReactionWheels
from flyby_sim.dynamics.rotation import quat_from_axis_angle, quat_from_rotation_vector

SEED001_SERVICER = np.diag([13.0, 38.0, 35.0])  # seed 001 Table 1, the servicing satellite S_r [kg m^2]
WHEELS = ReactionWheels.orthogonal(max_torque_n_m=0.1, max_momentum_n_m_s=4.0, spin_inertia_kg_m2=0.01)
PROPAGATOR = GyrostatPropagator(SEED001_SERVICER, WHEELS)
# omega_n 0.2 rad/s, zeta 1, omega_max 0.05 rad/s: the settings of docs/chaser_6dof.md and scripts/benchmark_slew.py
CONTROLLER = QuaternionFeedbackController(SEED001_SERVICER, WHEELS, 0.2, 1.0, 0.05)


def test_seed001_servicer_90_deg_slew_about_y_settles_within_0_1_deg():
    """About the largest principal axis (38 kg m^2): settled in 72.4 s (measured), wheels under their limits,
    total angular momentum (body + wheels) kept."""
    result = simulate_slew(PROPAGATOR, CONTROLLER, [0.0, 0.0, 0.0, 1.0], quat_from_axis_angle([0, 1, 0], math.pi / 2),
                           duration_s=120.0, period_s=0.1)
    assert result.error_deg[0] == pytest.approx(90.0, abs=1e-12)
    settling_s = result.settling_time_s(0.1)
    assert settling_s < 80.0
    assert result.error_deg[-1] < 1e-3 and np.linalg.norm(result.omega_body[-1]) < 1e-5
    assert 1.8 < result.peak_wheel_momentum_n_m_s < 2.0  # about I_yy omega_max = 1.9 N m s
    assert result.momentum_limited_steps == 0 and result.torque_limited_steps == 0
    assert np.max(np.abs(result.wheel_torque_n_m)) <= 0.1
    assert result.momentum_error_n_m_s.max() < 1e-12


@settings(max_examples=3, deadline=None)
@given(st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)).filter(
    lambda a: np.linalg.norm(a) > 0.2))
def test_90_deg_slew_about_any_axis_settles_within_0_1_deg(axis):
    result = simulate_slew(PROPAGATOR, CONTROLLER, [0.0, 0.0, 0.0, 1.0], quat_from_axis_angle(axis, math.pi / 2),
                           duration_s=120.0, period_s=0.1)
    assert result.settling_time_s(0.1) < 90.0
    assert result.peak_wheel_momentum_n_m_s < 4.0


def test_gyroscopic_compensation_and_damping_on_the_goal():
    """At zero error the body torque is -k_d I omega + omega x (I omega + A h); the wheels make it as -u."""
    state = ChaserAttitudeState(np.array([0.0, 0.0, 0.0, 1.0]), np.array([0.001, -0.002, 0.0015]),
                                np.array([0.5, -1.0, 0.2]))
    u = CONTROLLER.wheel_torque(state, [0.0, 0.0, 0.0, 1.0])
    omega = state.omega_body
    torque = -0.4 * SEED001_SERVICER @ omega + np.cross(omega, SEED001_SERVICER @ omega + state.h_wheels_n_m_s)
    assert np.allclose(-u, torque, rtol=1e-14, atol=0.0)


def test_rate_limit_holds_the_eigenaxis_rate():
    """Far from the goal, turning at omega_max about the error axis toward it needs only the gyroscopic torque."""
    error_axis = np.array([1.0, 2.0, -2.0]) / 3.0
    q_goal = quat_from_rotation_vector(-1.0 * error_axis)  # body is 1 rad about error_axis past the goal
    omega = -0.05 * error_axis
    state = ChaserAttitudeState(np.array([0.0, 0.0, 0.0, 1.0]), omega, np.zeros(3))
    assert np.allclose(attitude_error_rotation_vector(state.q_inertial_from_body, q_goal), error_axis, atol=1e-15)
    u = CONTROLLER.wheel_torque(state, q_goal)
    assert np.allclose(-u, np.cross(omega, SEED001_SERVICER @ omega), rtol=1e-12, atol=1e-18)


def test_command_beyond_the_torque_limit_is_scaled_keeping_its_direction():
    state = ChaserAttitudeState(np.array([0.0, 0.0, 0.0, 1.0]), np.array([0.1, -0.05, 0.02]), np.zeros(3))
    u = CONTROLLER.wheel_torque(state, [0.0, 0.0, 0.0, 1.0])
    unlimited = -(-0.4 * SEED001_SERVICER @ state.omega_body
                  + np.cross(state.omega_body, SEED001_SERVICER @ state.omega_body))
    assert np.max(np.abs(u)) == pytest.approx(0.1, rel=1e-14)
    assert np.allclose(u / np.linalg.norm(u), unlimited / np.linalg.norm(unlimited), atol=1e-14)


def test_bad_settings_name_themselves():
    with pytest.raises(ValueError, match='max_rate_rad_s'):
        QuaternionFeedbackController(SEED001_SERVICER, WHEELS, 0.2, 1.0, 0.0)
    planar = ReactionWheels([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], 0.1, 4.0, 0.01)
    with pytest.raises(ValueError, match='do not span 3 axes'):
        QuaternionFeedbackController(SEED001_SERVICER, planar, 0.2, 1.0, 0.05)
