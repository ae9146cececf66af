"""Rotational motion of the chaser: a rigid body carrying a reaction-wheel assembly (a gyrostat).

Quaternions are (x, y, z, w), scalar last, as in ``rotation`` and ``attitude``; ``q_inertial_from_body``
rotates ``chaser_body`` vectors into the inertial frame. ``omega_body`` is the chaser's inertial angular
velocity in body axes [rad/s].

Equations of motion (seed 001 eq 3 / seed 000 eq 4, Euler's equation, with the wheels' momentum added):

.. math::

    I \\dot\\omega = M_{ext} - \\omega \\times (I \\omega + A h) - A u, \\qquad \\dot h = u,
    \\qquad \\dot q = \\tfrac12 q \\otimes (\\omega, 0)

A (3 x N) holds the wheels' unit spin axes in body axes as columns, h (N) each wheel's absolute angular
momentum along its axis [N m s] (spin inertia times the wheel's inertial spin rate), u (N) the motor
torque on each wheel [N m]; the wheels push back on the body with -A u. I is the chaser's inertia
about its centre of mass with the wheels' spin-axis inertia left out (the wheels' mass and transverse
inertia in): with that split, h_dot = u holds exactly and the total angular momentum is
H = C_inertial_from_body (I omega + A h), constant without external torque.

Wheel limits: each motor torque is clipped to +-max_torque_n_m, and a wheel whose momentum has reached
+-max_momentum_n_m_s gets no torque that would push it further (its speed limit). Neither is hidden:
each step reports the torque applied and which wheels were limited.
"""

import math
from typing import NamedTuple

import numpy as np
from scipy.integrate import DOP853

from flyby_sim.dynamics.attitude import validated_inertia
from flyby_sim.dynamics.rotation import quat_normalize, quat_rotate


class ReactionWheels:
    """A reaction-wheel assembly: spin axes in chaser_body and per-wheel limits (validated here)."""

    def __init__(self, axes_body, max_torque_n_m, max_momentum_n_m_s, spin_inertia_kg_m2):
        """axes_body (N, 3): spin axes (any nonzero length, normalized here); the limits and each wheel's
        spin-axis inertia are one value for all wheels or one per wheel; all must be finite and > 0."""
        axes = np.atleast_2d(np.asarray(axes_body, dtype=float))
        if axes.ndim != 2 or axes.shape[1] != 3 or not np.all(np.isfinite(axes)):
            raise ValueError(f'axes_body must be N finite 3-vectors, got {axes_body!r}')
        norms = np.linalg.norm(axes, axis=1)
        if np.any(norms == 0.0):
            raise ValueError(f'axes_body has a zero axis: {axes.tolist()}')
        n = axes.shape[0]
        self.axes_body = axes / norms[:, None]
        self.max_torque_n_m = _per_wheel('max_torque_n_m', max_torque_n_m, n)
        self.max_momentum_n_m_s = _per_wheel('max_momentum_n_m_s', max_momentum_n_m_s, n)
        self.spin_inertia_kg_m2 = _per_wheel('spin_inertia_kg_m2', spin_inertia_kg_m2, n)

    @classmethod
    def orthogonal(cls, max_torque_n_m, max_momentum_n_m_s, spin_inertia_kg_m2):
        """Three wheels along the body x, y and z axes."""
        return cls(np.eye(3), max_torque_n_m, max_momentum_n_m_s, spin_inertia_kg_m2)

    @property
    def count(self):
        """Number of wheels N."""
        return self.axes_body.shape[0]

    @property
    def axis_matrix(self):
        """A (3, N): the unit spin axes as columns, so that A h is the wheels' momentum in body axes."""
        return self.axes_body.T

    def speeds_rad_s(self, h_wheels_n_m_s, omega_body):
        """Each wheel's spin rate relative to the body [rad/s]: h / J_s - a . omega (what a tachometer reads)."""
        h = np.asarray(h_wheels_n_m_s, dtype=float)
        return h / self.spin_inertia_kg_m2 - self.axes_body @ np.asarray(omega_body, dtype=float)


def _per_wheel(name, value, n):
    """value as an (n,) float array (a scalar repeated); raises ValueError naming it unless finite and > 0."""
    v = np.asarray(value, dtype=float)
    if v.ndim == 0:
        v = np.full(n, float(v))
    if v.shape != (n,) or not np.all(np.isfinite(v)) or np.any(v <= 0.0):
        raise ValueError(f'{name} must be one finite value > 0 or {n} of them, got {value!r}')
    return v


class ChaserAttitudeState(NamedTuple):
    """Rotational state of the chaser: attitude, inertial rate in body axes, wheel momenta."""

    q_inertial_from_body: np.ndarray  # (4,), x, y, z, w
    omega_body: np.ndarray  # (3,) [rad/s]
    h_wheels_n_m_s: np.ndarray  # (N,) along each wheel's axis [N m s]


class WheelStep(NamedTuple):
    """The outcome of one propagation step: the new state and what the wheels actually did."""

    state: ChaserAttitudeState
    wheel_torque_applied_n_m: np.ndarray  # (N,) mean motor torque over the step
    torque_limited: np.ndarray  # (N,) bool: the command exceeded max_torque_n_m
    momentum_limited: np.ndarray  # (N,) bool: the wheel sat at its momentum limit for part of the step


def gyrostat_rates(q_inertial_from_body, omega_body, h_wheels_n_m_s, inertia, inertia_inv, axes_body,
                   torque_ext_body_n_m, wheel_torque_n_m):
    """(q_dot, omega_dot [rad/s^2], h_dot [N m]) of the module's equations of motion (seed 001 eq 3 /
    seed 000 eq 4 with the wheels): I omega_dot = M_ext - omega x (I omega + A h) - A u, h_dot = u;
    ``gyrostat_rates_floats`` as arrays.

    inertia and inertia_inv are 3x3 nested sequences, axes_body the (N, 3) unit axes; every vector may be
    a sequence of Python floats.
    """
    rates = gyrostat_rates_floats(q_inertial_from_body, omega_body, h_wheels_n_m_s, inertia, inertia_inv, axes_body,
                                  torque_ext_body_n_m, wheel_torque_n_m)
    return np.array(rates[:4]), np.array(rates[4:7]), np.array(rates[7:], dtype=float)


def gyrostat_rates_floats(q_inertial_from_body, omega_body, h_wheels_n_m_s, inertia, inertia_inv, axes_body,
                          torque_ext_body_n_m, wheel_torque_n_m):
    """``gyrostat_rates`` as one list of Python floats [q_dot (4), omega_dot (3), h_dot (N)]: the same operations
    in the same order as the wheel terms followed by ``attitude.euler_rate`` and ``attitude.quaternion_rate``
    (the target's equations), hence the same bits, without numpy's per-call cost (the plant asks four times
    per RK4 substep; the propagator's DOP853 calls it too).
    Seed 001 eq 3 / seed 000 eq 4 with the wheels: I omega_dot = M_ext - omega x (I omega + A h) - A u, h_dot = u.
    """
    wx, wy, wz = omega_body
    mx, my, mz = torque_ext_body_n_m
    for (ax, ay, az), h, u in zip(axes_body, h_wheels_n_m_s, wheel_torque_n_m, strict=True):
        mx -= (wy * az - wz * ay) * h + ax * u
        my -= (wz * ax - wx * az) * h + ay * u
        mz -= (wx * ay - wy * ax) * h + az * u
    (i00, i01, i02), (i10, i11, i12), (i20, i21, i22) = inertia
    hx = i00 * wx + i01 * wy + i02 * wz
    hy = i10 * wx + i11 * wy + i12 * wz
    hz = i20 * wx + i21 * wy + i22 * wz
    bx = mx - (wy * hz - wz * hy)  # M - omega x (I omega), seed 001 eq 3
    by = my - (wz * hx - wx * hz)
    bz = mz - (wx * hy - wy * hx)
    (j00, j01, j02), (j10, j11, j12), (j20, j21, j22) = inertia_inv
    x, y, z, w = q_inertial_from_body
    return [0.5 * (w * wx + y * wz - z * wy),  # q_dot = 1/2 q * (omega, 0), seed 000 eq 4
            0.5 * (w * wy + z * wx - x * wz),
            0.5 * (w * wz + x * wy - y * wx),
            -0.5 * (x * wx + y * wy + z * wz),
            j00 * bx + j01 * by + j02 * bz,
            j10 * bx + j11 * by + j12 * bz,
            j20 * bx + j21 * by + j22 * bz,
            *(float(u) for u in wheel_torque_n_m)]


def substep_count(omega_body, h_body_n_m_s, inertia_min_kg_m2, dt_s, max_angle_rad):
    """Substeps of a fixed-step integrator over dt_s [s] so that no substep turns the body, or its rate vector,
    by more than max_angle_rad: ceil(s dt / max_angle) with s = max(|omega|, |I omega + A h| / I_min) [rad/s].

    |omega| bounds the attitude's turn; omega_dot = -I^-1 (omega x H) turns omega in the body at most
    |H| / I_min (the nutation, or a wheel's gyroscopic coupling at rest), H = I omega + A h the body's total
    momentum in body axes (h_body_n_m_s).
    """
    wx, wy, wz = omega_body
    hx, hy, hz = h_body_n_m_s
    rate = max(math.sqrt(wx * wx + wy * wy + wz * wz), math.sqrt(hx * hx + hy * hy + hz * hz) / inertia_min_kg_m2)
    return max(1, math.ceil(rate * dt_s / max_angle_rad))


def total_angular_momentum_inertial(state, inertia, wheels):
    """H = C_inertial_from_body (I omega + A h) [N m s], inertial axes: body plus wheels."""
    h_body = np.asarray(inertia, dtype=float) @ state.omega_body + wheels.axis_matrix @ state.h_wheels_n_m_s
    return quat_rotate(quat_normalize(state.q_inertial_from_body), h_body)


class GyrostatPropagator:
    """Propagates a ChaserAttitudeState over a step with piecewise-constant inputs (zero-order hold).

    Each step integrates the module's equations with scipy's DOP853 (8th order, rtol 1e-12, atol 1e-14 by
    default), restarted at every step and at every instant inside it where a wheel reaches its momentum
    limit, so no discontinuity falls inside an integration step; the quaternion is renormalized at the
    end of each step. Measured (scripts/bench/benchmark_slew.py, seed 001's servicer with wheel momentum): a
    torque-free body keeps its inertial angular momentum to 1e-13 and its rotational energy to 1e-14
    relative over 1000 s; a step costs about 0.5 ms (0.5 ms per simulated second in 1 s steps, 4.5 ms in
    0.1 s steps: the cost is per step, mostly DOP853's start-up).
    """

    def __init__(self, inertia, wheels, rtol=1e-12, atol=1e-14):
        """inertia: 3x3 [kg m^2] about the CoM without the wheels' spin-axis inertia; wheels: ReactionWheels."""
        i = validated_inertia(inertia)
        self.inertia = i
        self.wheels = wheels
        self._inertia = tuple(map(tuple, i.tolist()))
        self._inertia_inv = tuple(map(tuple, np.linalg.inv(i).tolist()))
        self._axes = tuple(map(tuple, wheels.axes_body.tolist()))
        self._rtol, self._atol = rtol, atol

    def step(self, state, dt_s, torque_ext_body_n_m, wheel_torque_cmd_n_m):
        """WheelStep after dt_s [s] with the external torque [N m, body axes] and the wheel motor torque
        commands [N m] held constant; the commands are limited as the module doc says."""
        if not (math.isfinite(dt_s) and dt_s > 0.0):
            raise ValueError(f'dt_s must be finite and > 0, got {dt_s!r}')
        n = self.wheels.count
        torque_ext = _finite_vector('torque_ext_body_n_m', torque_ext_body_n_m, 3)
        u_cmd = _finite_vector('wheel_torque_cmd_n_m', wheel_torque_cmd_n_m, n)
        h0 = _finite_vector('h_wheels_n_m_s', state.h_wheels_n_m_s, n)
        h_max = self.wheels.max_momentum_n_m_s
        if np.any(np.abs(h0) > h_max):
            raise ValueError(f'h_wheels_n_m_s {h0.tolist()} exceeds max_momentum_n_m_s {h_max.tolist()}')
        u = np.clip(u_cmd, -self.wheels.max_torque_n_m, self.wheels.max_torque_n_m)
        torque_limited = u != u_cmd
        # h(t) = h0 + u t exactly (h_dot = u), so each wheel's arrival at its limit is known in advance.
        with np.errstate(divide='ignore', over='ignore', invalid='ignore'):
            t_limit = np.where(u != 0.0, (np.sign(u) * h_max - h0) / u, math.inf)
        momentum_limited = t_limit < dt_s
        breaks = sorted({min(max(t, 0.0), dt_s) for t in t_limit[momentum_limited].tolist()} | {dt_s})
        y = np.concatenate((np.asarray(state.q_inertial_from_body, dtype=float),
                            _finite_vector('omega_body', state.omega_body, 3), h0))
        t = 0.0
        for t_end in breaks:
            active = np.where(t_limit > t, u, 0.0)
            if t_end > t:
                y = self._integrate(y, t_end - t, torque_ext.tolist(), active.tolist())
            # A wheel that reached its limit now sits exactly on it (no round-off past it).
            reached = np.flatnonzero(momentum_limited & (t_limit <= t_end))
            y[7 + reached] = np.sign(u[reached]) * h_max[reached]
            t = t_end
        new_state = ChaserAttitudeState(quat_normalize(y[:4].tolist()), y[4:7].copy(), y[7:].copy())
        # Each wheel pushes with u until it reaches its limit (exactly u for one that never does).
        applied = u * (np.clip(t_limit, 0.0, dt_s) / dt_s)
        return WheelStep(new_state, applied, torque_limited, momentum_limited)

    def _integrate(self, y0, duration_s, torque_ext, wheel_torque):
        """y after duration_s of DOP853 with constant inputs (y = q, omega, h)."""
        inertia, inertia_inv, axes = self._inertia, self._inertia_inv, self._axes

        def rhs(_t, y):
            values = y.tolist()
            return np.array(gyrostat_rates_floats(values[:4], values[4:7], values[7:], inertia, inertia_inv, axes,
                                                  torque_ext, wheel_torque))

        solver = DOP853(rhs, 0.0, y0, t_bound=duration_s, rtol=self._rtol, atol=self._atol)
        while solver.status == 'running':
            message = solver.step()
            if solver.status == 'failed':
                raise RuntimeError(f'chaser attitude integration failed after {solver.t} s of {duration_s} s: '
                                   f'{message}')
        return solver.y.copy()


def _finite_vector(name, value, n):
    """value as an (n,) float array; raises ValueError naming it otherwise."""
    v = np.asarray(value, dtype=float)
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise ValueError(f'{name} must be {n} finite values, got {value!r}')
    return v
