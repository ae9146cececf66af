"""Rigid-body attitude motion of the target (seed 000 eq 4, seed 001 eq 3).

Quaternions are (x, y, z, w), scalar last; ``q_inertial_from_body`` rotates body vectors into the
inertial frame. The paper writes eq 4 scalar first, q = [q0 q1 q2 q3] with q0 the scalar; its
1/2 Q_T omega is the Hamilton product 1/2 q * (omega, 0), which is what quaternion_rate computes.
``omega_body`` is the inertial angular velocity in body axes [rad/s]; inertia in kg m^2, torque
in N m, body axes.
"""

import math

import numpy as np
from scipy.integrate import DOP853

from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    skew,
)


def euler_rate(omega_body, inertia, inertia_inv, torque_body=(0.0, 0.0, 0.0)):
    """d(omega_body)/dt = I^-1 (M - omega x (I omega)) [rad/s^2], seed 000 eq 4 / seed 001 eq 3."""
    wx, wy, wz = omega_body
    (i00, i01, i02), (i10, i11, i12), (i20, i21, i22) = inertia
    hx = i00 * wx + i01 * wy + i02 * wz
    hy = i10 * wx + i11 * wy + i12 * wz
    hz = i20 * wx + i21 * wy + i22 * wz
    mx, my, mz = torque_body
    # M - omega x h
    bx = mx - (wy * hz - wz * hy)
    by = my - (wz * hx - wx * hz)
    bz = mz - (wx * hy - wy * hx)
    (j00, j01, j02), (j10, j11, j12), (j20, j21, j22) = inertia_inv
    return np.array((
        j00 * bx + j01 * by + j02 * bz,
        j10 * bx + j11 * by + j12 * bz,
        j20 * bx + j21 * by + j22 * bz,
    ))


def quaternion_rate(q_inertial_from_body, omega_body):
    """dq/dt = 1/2 q * (omega_body, 0) for an (x, y, z, w) quaternion, seed 000 eq 4."""
    x, y, z, w = q_inertial_from_body
    wx, wy, wz = omega_body
    return np.array((
        0.5 * (w * wx + y * wz - z * wy),
        0.5 * (w * wy + z * wx - x * wz),
        0.5 * (w * wz + x * wy - y * wx),
        -0.5 * (x * wx + y * wy + z * wz),
    ))


def body_point_state(c_hill_from_body, omega_body, x_body, n):
    """Position and velocity of a body-fixed point in hill, seed 000 eq 8-9, for a body whose centre
    of mass is the hill origin.

    Eq 8: x^H = C_hill_from_body x_B. Eq 9 as printed, v^H = C (omega x x_B) + C_I^H (Omega^I x C_B^I x_B),
    has the wrong sign on the orbital-rate term for a velocity relative to the rotating hill frame:
    d/dt(C x_B) = C (omega_B x x_B) - Omega^H x x^H with Omega^H = [0, -n, 0] (seed 000 eq 11).
    test_target_motion.py::test_seed000_eq9_sign_by_numerical_derivative settles it.

    One state, or N at once: a stack c_hill_from_body (N, 3, 3) with omega_body (N, 3) gives (N, 3)
    positions and velocities (x_body (3,) shared, or one per state (N, 3)).

    Args:
        c_hill_from_body: rotation matrix of q_hill_from_body, (3, 3) or (N, 3, 3).
        omega_body: inertial angular velocity, body axes [rad/s], (3,) or (N, 3).
        x_body: the point in body axes [m], (3,) or (N, 3).
        n: orbital mean motion [rad/s].

    Returns:
        (r_hill [m], v_hill [m/s] relative to the rotating hill frame).
    """
    c = np.asarray(c_hill_from_body, dtype=float)
    x_b = np.asarray(x_body, dtype=float)
    r_hill = _matrix_times_vector(c, x_b)  # eq 8
    omega_x_b = np.cross(np.asarray(omega_body, dtype=float), x_b)
    big_omega_x = skew((0.0, -n, 0.0))  # [Omega^H x]
    v_hill = _matrix_times_vector(c, omega_x_b) - r_hill @ big_omega_x.T  # eq 9, sign settled above
    return r_hill, v_hill


def attitude_ahead(q_hill_from_body, omega_body, dt_s, n):
    """q_hill_from_body dt_s [s] ahead at the constant body rate omega_body [rad/s, inertial], hill turning at
    (0, -n, 0). A thruster force is held fixed in chaser_body over a control period that starts one period after the
    estimate: guidance turns its hill-axes force into body axes at the hold's midpoint (a synchronized chaser turns
    3.2 deg in those 0.15 s)."""
    q = np.asarray(q_hill_from_body, dtype=float)
    w_rel = np.asarray(omega_body, dtype=float) - quat_rotate(quat_conjugate(q), (0.0, -n, 0.0))  # less hill's rate
    return quat_multiply(q, quat_from_rotation_vector(w_rel * dt_s))


def moving_body_point_state(c_hill_from_body, omega_body, omega_dot_body, x_body, x_dot_body, x_ddot_body, n):
    """Position, velocity and acceleration in hill of a point moving in the body frame (seed 001 stages 3-4: a
    station held in the target's body frame, a radial docking in it), the body's centre of mass at the hill origin.

    In inertial axes the point's acceleration relative to the centre of mass is the rotating-frame kinematics
    C (x'' + 2 omega x x' + omega' x x + omega x (omega x x)); hill turns at Omega = (0, -n, 0) in its own axes
    (constant on a circular orbit), so v^H = C (x' + omega x x) - Omega x r^H (eq 9 with x' = 0, as
    ``body_point_state``) and a^H = C (...) - 2 Omega x v^H - Omega x (Omega x r^H).

    Args:
        c_hill_from_body: rotation matrix of q_hill_from_body (3, 3).
        omega_body, omega_dot_body: inertial angular velocity [rad/s] and its derivative [rad/s^2], body axes.
        x_body, x_dot_body, x_ddot_body: the point and its first two derivatives in the body frame [m, m/s, m/s^2].
        n: orbital mean motion [rad/s].

    Returns:
        (r_hill [m], v_hill [m/s], a_hill [m/s^2]), velocity and acceleration relative to the rotating hill frame.
    """
    c = np.asarray(c_hill_from_body, dtype=float)
    w, w_dot = np.asarray(omega_body, dtype=float), np.asarray(omega_dot_body, dtype=float)
    x, x_dot, x_ddot = (np.asarray(a, dtype=float) for a in (x_body, x_dot_body, x_ddot_body))
    big_omega = np.array((0.0, -n, 0.0))
    r = c @ x
    v = c @ (x_dot + np.cross(w, x)) - np.cross(big_omega, r)
    a_inertial = c @ (x_ddot + 2.0 * np.cross(w, x_dot) + np.cross(w_dot, x) + np.cross(w, np.cross(w, x)))
    a = a_inertial - 2.0 * np.cross(big_omega, v) - np.cross(big_omega, np.cross(big_omega, r))
    return r, v, a


def _matrix_times_vector(c, v):
    """c @ v for one matrix and vector or stacks of them ((N, 3, 3) with (3,) or (N, 3))."""
    return (c @ v[..., None])[..., 0]


def kinetic_energy(omega_body, inertia):
    """Rotational kinetic energy 1/2 omega . I omega [J]."""
    w = np.asarray(omega_body, dtype=float)
    return 0.5 * float(w @ (np.asarray(inertia, dtype=float) @ w))


def angular_momentum_inertial(q_inertial_from_body, omega_body, inertia):
    """Angular momentum C_inertial_from_body I omega [kg m^2/s] in inertial axes."""
    h_body = np.asarray(inertia, dtype=float) @ np.asarray(omega_body, dtype=float)
    return quat_rotate(quat_normalize(q_inertial_from_body), h_body)


def validated_inertia(inertia):
    """The inertia as a 3x3 float array; raises ValueError unless finite, symmetric and positive definite."""
    i = np.asarray(inertia, dtype=float)
    if i.shape != (3, 3) or not np.all(np.isfinite(i)):
        raise ValueError(f'inertia must be a finite 3x3 matrix [kg m^2], got {inertia!r}')
    if not np.allclose(i, i.T, rtol=1e-12, atol=0.0):
        raise ValueError(f'inertia must be symmetric, got {i.tolist()}')
    if np.linalg.eigvalsh(i).min() <= 0.0:
        raise ValueError(f'inertia must be positive definite, got {i.tolist()}')
    return i


class AttitudePropagator:
    """Torque-free target attitude from one initial state, integrated once forward with DOP853.

    state_at(t) answers from the integrator's dense output (renormalized quaternion) for
    non-decreasing t, stepping the integrator on as needed. It is never restarted by outside events,
    so the answer depends only on t and the initial state. states_at answers many times at once with
    the same numbers to the bit: the dense output's arithmetic is element-wise, so evaluating it on
    an array of times repeats the scalar evaluation's operations per time.
    """

    def __init__(self, q_inertial_from_body0, omega_body0, inertia, t0=0.0, rtol=1e-12, atol=1e-14):
        """Start at t0 [s] from q_inertial_from_body0 (normalized here) and omega_body0 [rad/s]."""
        omega0 = np.asarray(omega_body0, dtype=float)
        if omega0.shape != (3,) or not np.all(np.isfinite(omega0)):
            raise ValueError(f'omega_body0 must be 3 finite values [rad/s], got {omega_body0!r}')
        if not math.isfinite(t0):
            raise ValueError(f't0 must be finite, got {t0}')
        i = validated_inertia(inertia)
        self._inertia = tuple(map(tuple, i.tolist()))
        self._inertia_inv = tuple(map(tuple, np.linalg.inv(i).tolist()))
        y0 = np.concatenate((quat_normalize(q_inertial_from_body0), omega0))
        self._solver = DOP853(self._rhs, t0, y0, t_bound=np.inf, rtol=rtol, atol=atol)
        self._dense = None
        self._t_last = t0

    def _rhs(self, t, y):
        q = y[:4].tolist()
        w = y[4:].tolist()
        return np.concatenate((quaternion_rate(q, w), euler_rate(w, self._inertia, self._inertia_inv)))

    def state_at(self, t):
        """(q_inertial_from_body, omega_body) at t [s]; t must not decrease from call to call."""
        if not t >= self._t_last:
            raise ValueError(f't = {t} s precedes the last requested time {self._t_last} s')
        self._t_last = t
        solver = self._solver
        while solver.t < t:
            message = solver.step()
            if solver.status == 'failed':
                raise RuntimeError(f'attitude integration failed at t = {solver.t} s: {message}')
            self._dense = solver.dense_output()
        y = solver.y if t == solver.t else self._dense(t)
        return quat_normalize(y[:4].tolist()), y[4:].copy()

    def states_at(self, t_s):
        """state_at at each of the non-decreasing times t_s (N,) [s]: (q_inertial_from_body (N, 4), omega_body (N, 3)).

        Each time takes the dense output of the integrator step that state_at would use (the first
        step ending at or after it; its end state where it ends there), evaluated once per step for
        all its times, and the quaternion is normalized component-wise as quat_normalize does.
        """
        t = np.asarray(t_s, dtype=float)
        if t.ndim != 1 or t.size == 0 or not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0.0):
            raise ValueError(f'times must be a non-empty, finite, non-decreasing sequence [s], got {t_s!r}')
        if not t[0] >= self._t_last:
            raise ValueError(f't = {t[0]} s precedes the last requested time {self._t_last} s')
        self._t_last = float(t[-1])
        solver = self._solver
        y = np.empty((t.size, 7))
        i = 0
        while i < t.size:
            while solver.t < t[i]:
                message = solver.step()
                if solver.status == 'failed':
                    raise RuntimeError(f'attitude integration failed at t = {solver.t} s: {message}')
                self._dense = solver.dense_output()
            inside = int(np.searchsorted(t, solver.t, side='left'))  # t[i:inside] < solver.t
            if inside > i:
                y[i:inside] = self._dense(t[i:inside]).T
            end = int(np.searchsorted(t, solver.t, side='right'))  # t[inside:end] == solver.t
            y[inside:end] = solver.y
            i = end
        x, yy, z, w = y[:, :4].T
        norm = np.sqrt(x * x + yy * yy + z * z + w * w)  # as quat_normalize, term by term
        bad = np.flatnonzero(~(np.isfinite(norm) & (norm > 0.0)))
        if bad.size:
            raise ValueError(f'attitude quaternion {y[bad[0], :4].tolist()} at t = {t[bad[0]]} s cannot be normalized')
        return y[:, :4] / norm[:, None], y[:, 4:]
