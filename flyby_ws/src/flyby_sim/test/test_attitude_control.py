"""attitude_control.py: wheel-only quaternion feedback, and the 90 deg slew of seed 001's servicer."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_sim.dynamics.attitude_control import (
    QuaternionFeedbackController,
    attitude_error_rotation_vector,
    pointing_error_rad,
    simulate_slew,
)
from flyby_sim.dynamics.rigid_body import ChaserAttitudeState, GyrostatPropagator, ReactionWheels
from flyby_sim.dynamics.rotation import quat_from_axis_angle, quat_from_rotation_vector, quat_multiply, quat_rotate

SEED001_SERVICER = np.diag([13.0, 38.0, 35.0])  # seed 001 Table 1, the servicing satellite S_r [kg m^2]
WHEELS = ReactionWheels.orthogonal(max_torque_n_m=0.1, max_momentum_n_m_s=4.0, spin_inertia_kg_m2=0.01)
PROPAGATOR = GyrostatPropagator(SEED001_SERVICER, WHEELS)
# omega_n 0.2 rad/s, zeta 1, omega_max 0.05 rad/s: the settings of docs/chaser_6dof.md and
# scripts/bench/benchmark_slew.py
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


def _track_constant_rate_goal(omega_goal, feed_forward, duration_s=150.0, period_s=0.1):
    """Closed loop on a goal turning at the constant omega_goal (goal axes) from q_inertial_from_goal(0) = 1:
    q_goal(t) = exp(omega_goal t), the chaser starting 5 deg off about (1, 1, 0) and at rest. The final
    error angle [deg] and the final relative rate [rad/s]."""
    state = ChaserAttitudeState(quat_from_axis_angle([1.0, 1.0, 0.0], math.radians(5.0)), np.zeros(3), np.zeros(3))
    steps = int(round(duration_s / period_s))
    for k in range(steps):
        q_goal = quat_from_rotation_vector(omega_goal * (k * period_s))
        if feed_forward:
            torque = CONTROLLER.body_torque(state.q_inertial_from_body, state.omega_body, state.h_wheels_n_m_s,
                                            q_goal, omega_goal, np.zeros(3))
        else:
            torque = CONTROLLER.body_torque(state.q_inertial_from_body, state.omega_body, state.h_wheels_n_m_s,
                                            q_goal)
        state = PROPAGATOR.step(state, period_s, (0.0, 0.0, 0.0), CONTROLLER.wheel_torque_for(torque)).state
    q_goal = quat_from_rotation_vector(omega_goal * duration_s)
    error = attitude_error_rotation_vector(state.q_inertial_from_body, q_goal)
    return math.degrees(np.linalg.norm(error)), np.linalg.norm(state.omega_body - omega_goal), error


def test_a_constant_rate_goal_is_tracked_without_lag():
    """About body y at 0.02 rad/s (1.15 deg/s): with the feed-forward the error goes to zero; without it the
    rate loop needs omega_ref = omega_goal, i.e. -(k_p / k_d) e = omega_goal: the closed-form lag
    |e| = (k_d / k_p) |omega_goal| = 10 s x 0.02 rad/s = 11.46 deg behind the goal."""
    omega_goal = np.array([0.0, 0.02, 0.0])
    error_deg, rate_error, _ = _track_constant_rate_goal(omega_goal, feed_forward=True)
    assert error_deg < 1e-6 and rate_error < 1e-9
    error_deg, rate_error, error = _track_constant_rate_goal(omega_goal, feed_forward=False)
    lag = (CONTROLLER.k_d / CONTROLLER.k_p) * omega_goal  # the body trails the goal: e = -(k_d / k_p) omega_goal
    assert np.allclose(error, -lag, atol=1e-4) and rate_error < 1e-6
    assert error_deg == pytest.approx(11.459, abs=0.01)


def test_tracking_torque_at_the_goal_is_the_feed_forward_and_gyroscopic_torque():
    """On the goal (e = 0) at its rate: tau = I C alpha_g + omega x (I omega + A h) exactly (the damping and the
    -I omega x omega_g^b terms vanish), for a goal attitude away from the reference frame's axes."""
    q_ref_from_goal = quat_from_rotation_vector([0.3, -0.5, 0.2])
    omega_goal = np.array([0.01, -0.02, 0.015])
    omega_dot_goal = np.array([1e-4, 2e-4, -3e-4])
    h = np.array([0.4, -0.2, 0.7])
    torque = CONTROLLER.body_torque(q_ref_from_goal, omega_goal, h, q_ref_from_goal, omega_goal, omega_dot_goal)
    expected = SEED001_SERVICER @ omega_dot_goal + np.cross(omega_goal, SEED001_SERVICER @ omega_goal + h)
    assert np.allclose(torque, expected, rtol=1e-13, atol=1e-17)


def test_the_rate_limit_bounds_the_rate_relative_to_a_moving_goal():
    """1 rad from a goal turning at omega_g: the reference rate is omega_g (body axes) plus omega_max toward the
    goal; a body turning at exactly that rate gets only the feed-forward and gyroscopic torque."""
    error_axis = np.array([1.0, 0.0, 0.0])
    q_goal = quat_from_rotation_vector(-1.0 * error_axis)  # body (identity) is 1 rad about x past the goal
    omega_goal = np.array([0.0, 0.0, 0.03])
    omega_goal_body = quat_rotate(q_goal, omega_goal)  # q_body_from_goal = q_goal here
    omega = omega_goal_body - 0.05 * error_axis
    torque = CONTROLLER.body_torque([0.0, 0.0, 0.0, 1.0], omega, np.zeros(3), q_goal, omega_goal, np.zeros(3))
    expected = -SEED001_SERVICER @ np.cross(omega, omega_goal_body) + np.cross(omega, SEED001_SERVICER @ omega)
    assert np.allclose(torque, expected, rtol=0.0, atol=1e-16)


def test_wheels_take_the_control_torque_less_the_thruster_torque():
    torque = np.array([0.02, -0.01, 0.005])
    thruster = np.array([-0.03, 0.0, 0.01])
    u = CONTROLLER.wheel_torque_for(torque, thruster)
    assert np.allclose(-WHEELS.axis_matrix @ u + thruster, torque, atol=1e-17)


def test_pointing_error_closed_forms():
    r_hill = np.array([-3.0, 4.0, 0.0])  # the line of sight is (3, -4, 0) / 5
    on_target = quat_from_axis_angle([0.0, 0.0, 1.0], math.atan2(-4.0, 3.0))
    assert pointing_error_rad(on_target, r_hill) == pytest.approx(0.0, abs=1e-15)
    # any roll about the line of sight leaves it zero; a turn about a perpendicular axis is the error itself
    rolled = quat_multiply(on_target, quat_from_axis_angle([1.0, 0.0, 0.0], 2.0))
    assert pointing_error_rad(rolled, r_hill) == pytest.approx(0.0, abs=1e-15)
    tilted = quat_multiply(on_target, quat_from_axis_angle([0.0, 0.3, 1.0], 1e-7))
    assert pointing_error_rad(tilted, r_hill) == pytest.approx(1e-7, rel=1e-8)  # atan2 keeps small angles
    assert pointing_error_rad([0.0, 0.0, 0.0, 1.0], r_hill) == pytest.approx(math.acos(0.6), rel=1e-14)
    many = pointing_error_rad(np.array([on_target, tilted, [0.0, 0.0, 0.0, 1.0]]), np.array([r_hill] * 3))
    assert many.shape == (3,) and many[1] == pytest.approx(1e-7, rel=1e-8)
    with pytest.raises(ValueError, match='r_hill'):
        pointing_error_rad(on_target, [0.0, 0.0, 0.0])
