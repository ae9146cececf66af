"""Wheel-only attitude control of the chaser: rate-limited quaternion feedback with gyroscopic compensation.

Quaternions are (x, y, z, w), scalar last (``rotation``); ``q_inertial_from_body`` is the chaser's attitude,
``q_inertial_from_goal`` the commanded one (fixed in inertial space). The error rotation
q_goal_from_body = conj(q_inertial_from_goal) * q_inertial_from_body has the rotation vector e (its axis has
the same components in both frames); e_dot = omega_body for a small error.

The law, after Wie and Lu (J. Guidance 18(6), 1995: u = -K sat(P q) - C omega with K = k I, C = c I) with
the rotation vector e in place of the quaternion's vector part, so that the rate limit holds exactly:

.. math::

    \\omega_{ref} = -\\mathrm{sat}_{\\omega_{max}}\\big(\\tfrac{k_p}{k_d} e\\big), \\qquad
    \\tau = k_d I (\\omega_{ref} - \\omega) + \\omega \\times (I \\omega + A h)

sat scales the vector down to norm omega_max (the direction, an eigenaxis, kept). With the gyroscopic term
cancelling omega x H in seed 001 eq 3 (``rigid_body``), the unsaturated loop is e'' + k_d e' + k_p e = 0,
k_p = omega_n^2, k_d = 2 zeta omega_n: far from the goal the chaser turns about the eigenaxis at omega_max,
within |e| = omega_max k_d / k_p it settles as a second-order system. The wheels deliver the body torque
tau with motor torques u = -A^+ tau (body torque -A u); when u exceeds a wheel's torque limit the whole
command is scaled down, keeping tau's direction.
"""

import math
from typing import NamedTuple

import numpy as np

from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.rigid_body import ChaserAttitudeState, total_angular_momentum_inertial
from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, quat_normalize, rotation_vector_from_quat


class QuaternionFeedbackController:
    """The module's law for one chaser: inertia [kg m^2], ReactionWheels, gains and rate limit."""

    def __init__(self, inertia, wheels, natural_frequency_rad_s, damping_ratio, max_rate_rad_s):
        """natural_frequency_rad_s (omega_n), damping_ratio (zeta) and max_rate_rad_s (omega_max) > 0."""
        require_positive('natural_frequency_rad_s', natural_frequency_rad_s)
        require_positive('damping_ratio', damping_ratio)
        require_positive('max_rate_rad_s', max_rate_rad_s)
        self.inertia = np.asarray(inertia, dtype=float)
        self.wheels = wheels
        self.k_p = natural_frequency_rad_s ** 2
        self.k_d = 2.0 * damping_ratio * natural_frequency_rad_s
        self.max_rate_rad_s = max_rate_rad_s
        axes = wheels.axis_matrix
        if np.linalg.matrix_rank(axes) < 3:
            raise ValueError(f'wheel axes {wheels.axes_body.tolist()} do not span 3 axes: no wheel-only control')
        self._axes = axes
        self._axes_pinv = np.linalg.pinv(axes)

    def wheel_torque(self, state, q_inertial_from_goal):
        """Wheel motor torques [N m] (N,) for a ChaserAttitudeState and the commanded attitude (module doc)."""
        e = attitude_error_rotation_vector(state.q_inertial_from_body, q_inertial_from_goal)
        omega_ref = -(self.k_p / self.k_d) * e
        norm = math.sqrt(float(omega_ref @ omega_ref))
        if norm > self.max_rate_rad_s:
            omega_ref *= self.max_rate_rad_s / norm  # eigenaxis rate limit
        omega = state.omega_body
        h_body = self.inertia @ omega + self._axes @ state.h_wheels_n_m_s
        torque_body = self.k_d * (self.inertia @ (omega_ref - omega)) + np.cross(omega, h_body)
        u = -self._axes_pinv @ torque_body  # body torque -A u = tau
        limit = self.wheels.max_torque_n_m
        excess = float(np.max(np.abs(u) / limit))
        if excess <= 1.0:
            return u
        return np.clip(u / excess, -limit, limit)  # the clip only removes the division's round-off


def attitude_error_rotation_vector(q_inertial_from_body, q_inertial_from_goal):
    """Rotation vector [rad] of q_goal_from_body, the short way round (angle in [0, pi])."""
    return rotation_vector_from_quat(quat_multiply(quat_conjugate(q_inertial_from_goal), q_inertial_from_body))


class SlewResult(NamedTuple):
    """Time histories of a simulated slew, one row per control period (t = 0 first)."""

    t_s: np.ndarray  # (K,)
    error_deg: np.ndarray  # (K,) attitude error angle
    omega_body: np.ndarray  # (K, 3) [rad/s]
    h_wheels_n_m_s: np.ndarray  # (K, N)
    wheel_torque_n_m: np.ndarray  # (K - 1, N) applied, mean over each period
    momentum_error_n_m_s: np.ndarray  # (K,) |H(t) - H(0)|, total angular momentum (body + wheels)
    torque_limited_steps: int  # periods in which a wheel's torque limit clipped the command
    momentum_limited_steps: int  # periods in which a wheel sat at its momentum limit

    def settling_time_s(self, tolerance_deg):
        """First time after which the error stays within tolerance_deg to the end (inf if it never does)."""
        outside = np.flatnonzero(self.error_deg > tolerance_deg)
        if outside.size == 0:
            return float(self.t_s[0])
        return math.inf if outside[-1] == self.t_s.size - 1 else float(self.t_s[outside[-1] + 1])

    @property
    def peak_wheel_momentum_n_m_s(self):
        """Largest |h| of any wheel over the slew [N m s]."""
        return float(np.max(np.abs(self.h_wheels_n_m_s)))


def simulate_slew(propagator, controller, q_inertial_from_body0, q_inertial_from_goal, duration_s, period_s):
    """Closed-loop wheel-only slew from rest with zero wheel momentum: the controller's command held over each
    control period (zero-order hold) through a GyrostatPropagator, no external torque."""
    n = propagator.wheels.count
    state = ChaserAttitudeState(quat_normalize(q_inertial_from_body0), np.zeros(3), np.zeros(n))
    q_goal = quat_normalize(q_inertial_from_goal)
    h0 = total_angular_momentum_inertial(state, propagator.inertia, propagator.wheels)
    steps = int(round(duration_s / period_s))
    states, torques = [state], []
    torque_limited = momentum_limited = 0
    for _ in range(steps):
        result = propagator.step(state, period_s, (0.0, 0.0, 0.0), controller.wheel_torque(state, q_goal))
        state = result.state
        states.append(state)
        torques.append(result.wheel_torque_applied_n_m)
        torque_limited += bool(result.torque_limited.any())
        momentum_limited += bool(result.momentum_limited.any())
    error = [np.degrees(np.linalg.norm(attitude_error_rotation_vector(s.q_inertial_from_body, q_goal)))
             for s in states]
    momentum_error = [np.linalg.norm(total_angular_momentum_inertial(s, propagator.inertia, propagator.wheels) - h0)
                      for s in states]
    return SlewResult(period_s * np.arange(steps + 1), np.array(error), np.array([s.omega_body for s in states]),
                      np.array([s.h_wheels_n_m_s for s in states]), np.array(torques), np.array(momentum_error),
                      torque_limited, momentum_limited)
