"""Wheel-only attitude control of the chaser: rate-limited quaternion feedback with gyroscopic compensation,
for a fixed goal (a slew, a hold) or a moving one (tracking, with feed-forward of the goal's rate and
acceleration).

Quaternions are (x, y, z, w), scalar last (``rotation``). The law needs the body and the goal attitude in one
reference frame R, any frame (inertial for a slew, ``hill`` for the fly-by's pointing): ``q_ref_from_body``
and ``q_ref_from_goal``. The error rotation q_goal_from_body = conj(q_ref_from_goal) * q_ref_from_body, with
rotation vector e (its axis has the same components in body and goal axes), does not depend on R. Angular
velocities are always INERTIAL: ``omega_body`` the chaser's in body axes, ``omega_goal`` the goal frame's in
goal axes, ``omega_dot_goal`` its inertial derivative in goal axes (the inertial and the goal-frame
derivative of the goal's own angular velocity coincide, since omega x omega = 0).

The law, after Wie and Lu (J. Guidance 18(6), 1995: u = -K sat(P q) - C omega with K = k I, C = c I) with
the rotation vector e in place of the quaternion's vector part, so that the rate limit holds exactly, and the
tracking feed-forward of Wen and Kreutz-Delgado (The Attitude Control Problem, IEEE Trans. Automatic Control
36(10), 1991: the reference's rate and acceleration carried into body axes, the body-frame derivative of the
reference rate fed forward; the same law in Markley and Crassidis, Fundamentals of Spacecraft Attitude
Determination and Control, Springer 2014, ch. 7):

.. math::

    \\omega_g^b = C_{bg} \\omega_g, \\qquad
    \\omega_{ref} = \\omega_g^b - \\mathrm{sat}_{\\omega_{max}}\\big(\\tfrac{k_p}{k_d} e\\big), \\qquad
    \\tau = I (C_{bg} \\dot\\omega_g - \\omega \\times \\omega_g^b) + k_d I (\\omega_{ref} - \\omega)
           + \\omega \\times (I \\omega + A h)

sat scales the vector down to norm omega_max (the direction, an eigenaxis, kept): the rate limit bounds the
body's rate RELATIVE to the goal (for a fixed goal, its rate). I (C_bg omega_dot_g - omega x omega_g^b) is
I times the body-frame derivative of omega_g^b (C_bg' = -[(omega - omega_g^b) x] C_bg), so with the
gyroscopic term cancelling omega x H in seed 001 eq 3 (``rigid_body``) the unsaturated loop is
I (dw' + k_d dw + k_p e) = 0 with dw = omega - omega_g^b = e' for a small error: e'' + k_d e' + k_p e = 0,
k_p = omega_n^2, k_d = 2 zeta omega_n, whatever the goal's motion (no lag behind a turning goal). For a fixed
goal (omega_g = omega_dot_g = 0) it is the slew law: far from the goal the chaser turns about the eigenaxis at
omega_max, within |e| = omega_max k_d / k_p it settles as a second-order system.

The wheels deliver the body torque: the body feels -A u from the wheels plus any thruster torque tau_thr
(momentum dumping), so u = -A^+ (tau - tau_thr); when u exceeds a wheel's torque limit the whole command is
scaled down, keeping its direction.

``pointing_error_rad`` is the mission's figure: the angle between the chaser's +x axis (camera and
manipulator, DESIGN section 3) and the line of sight to the target's centre of mass (the hill origin).
"""

import math
from typing import NamedTuple

import numpy as np

from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.rigid_body import ChaserAttitudeState, total_angular_momentum_inertial
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_to_matrix,
    quat_to_matrix_many,
    rotation_vector_from_quat,
)


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
        """Wheel motor torques [N m] (N,) for a ChaserAttitudeState and a fixed commanded attitude (module doc)."""
        torque_body = self.body_torque(state.q_inertial_from_body, state.omega_body, state.h_wheels_n_m_s,
                                       q_inertial_from_goal)
        return self.wheel_torque_for(torque_body)

    def body_torque(self, q_ref_from_body, omega_body, h_wheels_n_m_s, q_ref_from_goal, omega_goal=None,
                    omega_dot_goal=None):
        """The body torque tau [N m] (3,), body axes, the law asks for (module doc).

        q_ref_from_body, q_ref_from_goal: the body's and the goal's attitude in one frame R; omega_body
        [rad/s]: the body's inertial angular velocity, body axes; h_wheels_n_m_s (N,): the wheels' momenta;
        omega_goal [rad/s] and omega_dot_goal [rad/s^2]: the goal frame's inertial angular velocity and its
        derivative, goal axes (None: a fixed goal).
        """
        e = attitude_error_rotation_vector(q_ref_from_body, q_ref_from_goal)
        omega_ref = -(self.k_p / self.k_d) * e
        norm = math.sqrt(float(omega_ref @ omega_ref))
        if norm > self.max_rate_rad_s:
            omega_ref *= self.max_rate_rad_s / norm  # eigenaxis rate limit, relative to the goal
        omega = np.asarray(omega_body, dtype=float)
        h_body = self.inertia @ omega + self._axes @ np.asarray(h_wheels_n_m_s, dtype=float)
        if omega_goal is None and omega_dot_goal is None:
            return self.k_d * (self.inertia @ (omega_ref - omega)) + cross3(omega, h_body)
        q_body_from_goal = quat_multiply(quat_conjugate(q_ref_from_body), q_ref_from_goal)
        omega_goal_body = quat_rotate(q_body_from_goal, (0.0, 0.0, 0.0) if omega_goal is None else omega_goal)
        omega_dot_goal_body = quat_rotate(q_body_from_goal,
                                          (0.0, 0.0, 0.0) if omega_dot_goal is None else omega_dot_goal)
        omega_ref = omega_goal_body + omega_ref
        # I d/dt(omega_g^b), body-frame derivative: the feed-forward that removes the tracking lag
        feed_forward = self.inertia @ (omega_dot_goal_body - cross3(omega, omega_goal_body))
        return feed_forward + self.k_d * (self.inertia @ (omega_ref - omega)) + cross3(omega, h_body)

    def wheel_torque_for(self, torque_body_n_m, thruster_torque_body_n_m=None, axes_pinv=None):
        """Wheel motor torques u [N m] (N,) giving the body torque torque_body_n_m together with a thruster
        torque (body axes, None: none): u = -A^+ (tau - tau_thr), scaled down as a whole to the torque limits.
        axes_pinv: another A^+ (N, 3) (None: all the wheels'), e.g. with a failed wheel's row zero."""
        torque = np.asarray(torque_body_n_m, dtype=float)
        if thruster_torque_body_n_m is not None:
            torque = torque - np.asarray(thruster_torque_body_n_m, dtype=float)
        u = -(self._axes_pinv if axes_pinv is None else axes_pinv) @ torque  # body torque -A u (+ tau_thr) = tau
        limit = self.wheels.max_torque_n_m
        excess = float(np.max(np.abs(u) / limit))
        if excess <= 1.0:
            return u
        return np.clip(u / excess, -limit, limit)  # the clip only removes the division's round-off

    @property
    def axes_pinv(self):
        """A^+ (N, 3): wheel torques from a body torque (u = -A^+ tau)."""
        return self._axes_pinv


def attitude_error_rotation_vector(q_ref_from_body, q_ref_from_goal):
    """Rotation vector [rad] of q_goal_from_body, the short way round (angle in [0, pi]); both attitudes in
    one frame R (any)."""
    return rotation_vector_from_quat(quat_multiply(quat_conjugate(q_ref_from_goal), q_ref_from_body))


def cross3(a, b):
    """a x b of two 3-vectors as a numpy array, computed on Python floats: the same IEEE products and
    differences as np.cross, at a tenth of its cost for one pair (the controller runs every control period)."""
    ax, ay, az = a.tolist() if type(a) is np.ndarray else a
    bx, by, bz = b.tolist() if type(b) is np.ndarray else b
    return np.array((ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx))


def pointing_error_rad(q_hill_from_body, r_hill):
    """Angle [rad] between the chaser's body +x axis and its line of sight to the hill origin (the target's
    centre of mass while it flies free, DESIGN section 3): acos(x_body . (-r / |r|)), computed as
    atan2(|x_body x los|, x_body . los) so that small angles keep their precision.

    One attitude (4,) with one position r_hill (3,) [m] gives a float; N of each, (N, 4) and (N, 3), give (N,).
    """
    q = np.asarray(q_hill_from_body, dtype=float)
    r = np.asarray(r_hill, dtype=float)
    if q.shape[-1:] != (4,) or r.shape[-1:] != (3,) or q.shape[:-1] != r.shape[:-1] or q.ndim > 2:
        raise ValueError(f'q_hill_from_body {q.shape} and r_hill {r.shape} must be (4,) and (3,) or (N, 4) and (N, 3)')
    if not np.all(np.isfinite(r)) or np.any(np.all(r == 0.0, axis=-1)):
        raise ValueError('r_hill must be finite and nonzero (the chaser at the target centre has no line of sight)')
    if q.ndim == 1:
        x_body_hill = quat_to_matrix(q)[:, 0]  # body +x in hill: C_hill_from_body's first column (unit)
        return math.atan2(math.sqrt(float(np.sum(cross3(x_body_hill, -r) ** 2))), -float(x_body_hill @ r))
    x_body_hill = quat_to_matrix_many(q)[:, :, 0]
    return np.arctan2(np.linalg.norm(np.cross(x_body_hill, -r), axis=1), -np.einsum('ij,ij->i', x_body_hill, r))


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
