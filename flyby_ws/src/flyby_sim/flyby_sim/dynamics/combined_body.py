"""The combined body after a capture: chaser and target joined rigidly (seed 004 §2.2), and its motion under
thruster firings.

Frames: the combined body's axes are ``chaser_body``; every body vector is from the chaser's centre of mass
(CoM) unless its name says otherwise. Quaternions (x, y, z, w), scalar last, as in ``rotation``;
``q_inertial_from_body`` rotates chaser_body vectors into an inertial frame, ``q_body_from_principal`` the
target's principal axes into chaser_body.

Seed 004 §2.2 (TugRobot mass m, inertia I_t0 about its CoM; target mass M, principal moments I_s0,
principal axes D, CoM X_s from the TugRobot CoM):

.. math::

    c = \\frac{M}{M + m} X_s, \\quad y_t = -c, \\quad y_s = X_s - c = \\frac{m}{M + m} X_s

    I = I_{t0} + m (y_t^T y_t U - y_t y_t^T) + D^T I_{s0} D + M (y_s^T y_s U - y_s y_s^T)

with c the combined CoM from the chaser CoM (the paper's x = x_s + M/(M+m) C^T X_s has the sign of the
TugRobot-to-target vector; its x_s is the TugRobot's CoM). The paper's torque T = (X_f - M/(M+m) X_s)^T F is
a cross product: T = sum_f (r_f - c) x F_f = T_chaser - c x F, the thrusters' moment about the combined CoM.

Equations of motion (inertial frame, gravity and the orbit left out over the seconds these run; the
accelerometer does not see gravity):

.. math::

    \\dot r = v, \\quad \\dot v = C_{inertial\\,body} F / (m + M), \\quad
    I \\dot\\omega = T - \\omega \\times (I \\omega + h_w), \\quad \\dot q = \\tfrac12 q \\otimes (\\omega, 0)

(r, v: the combined CoM; h_w: the wheels' momentum in body axes, held constant.) The accelerometer at a
body point p (from the combined CoM) reads the specific force F / (m + M) + omega_dot x p + omega x (omega x p).
"""

import math
from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from flyby_sim.dynamics.attitude import euler_rate, quaternion_rate, validated_inertia
from flyby_sim.dynamics.rotation import quat_normalize, quat_rotate, quat_to_matrix


def parallel_axis(mass_kg, r_m):
    """m (r.r U - r r^T) [kg m^2]: the inertia a point mass m at r adds about the origin (Huygens-Steiner)."""
    r = np.asarray(r_m, dtype=float)
    return float(mass_kg) * (float(r @ r) * np.eye(3) - np.outer(r, r))


def inertia_from_principal(principal_moments_kg_m2, q_body_from_principal):
    """C diag(I_1, I_2, I_3) C^T [kg m^2]: a body's inertia about its CoM in body axes from its principal
    moments and the orientation of its principal axes (seed 004's D^T I_s0 D, C = D^T)."""
    c = quat_to_matrix(quat_normalize(q_body_from_principal))
    i = c @ np.diag(np.asarray(principal_moments_kg_m2, dtype=float)) @ c.T
    return 0.5 * (i + i.T)  # exactly symmetric (validated_inertia checks it)


class CombinedMassProperties(NamedTuple):
    """Mass, CoM and inertia of the combined body (module doc)."""

    mass_kg: float
    com_body_m: np.ndarray  # (3,) c, the combined CoM from the chaser CoM, chaser_body axes
    inertia_body_kg_m2: np.ndarray  # (3, 3) about the combined CoM, chaser_body axes


def combined_mass_properties(chaser_mass_kg, chaser_inertia_body_kg_m2, target_mass_kg, target_com_body_m,
                             target_inertia_body_kg_m2):
    """Seed 004 §2.2: the combined body of a chaser (inertia about its CoM) and a target whose CoM is at
    target_com_body_m (X_s) and whose inertia about that CoM is target_inertia_body_kg_m2, both in chaser_body
    axes. Raises ValueError naming the input that is not physical."""
    m = float(chaser_mass_kg)
    big_m = float(target_mass_kg)
    for name, value in (('chaser_mass_kg', m), ('target_mass_kg', big_m)):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f'{name} must be finite and > 0, got {value!r}')
    x_s = np.asarray(target_com_body_m, dtype=float)
    if x_s.shape != (3,) or not np.all(np.isfinite(x_s)):
        raise ValueError(f'target_com_body_m must be 3 finite numbers [m], got {target_com_body_m!r}')
    i_t0 = validated_inertia(chaser_inertia_body_kg_m2)
    i_s = validated_inertia(target_inertia_body_kg_m2)
    c = big_m / (big_m + m) * x_s
    y_t, y_s = -c, x_s - c
    inertia = i_t0 + parallel_axis(m, y_t) + i_s + parallel_axis(big_m, y_s)
    return CombinedMassProperties(m + big_m, c, 0.5 * (inertia + inertia.T))


class Firing(NamedTuple):
    """One thruster firing held constant over [t_start_s, t_start_s + duration_s): its force [N] in
    chaser_body axes, applied at position_body_m (from the chaser CoM)."""

    t_start_s: float
    duration_s: float
    position_body_m: tuple
    force_body_n: tuple

    @property
    def impulse_n_s(self):
        """|F| times the duration [N s] (the propellant is this over Isp g0)."""
        return math.sqrt(sum(f * f for f in self.force_body_n)) * self.duration_s


def firing_breaks(firings):
    """The sorted instants [s] at which the firings' wrench changes (every start and end)."""
    return sorted({f.t_start_s for f in firings} | {f.t_start_s + f.duration_s for f in firings})


def wrench_about_chaser(firings, t_s):
    """(force [N], moment about the chaser CoM [N m]), chaser_body axes, of the firings active at t_s (a firing
    is active on [start, start + duration))."""
    force = np.zeros(3)
    moment = np.zeros(3)
    for f in firings:
        if f.t_start_s <= t_s < f.t_start_s + f.duration_s:
            force += f.force_body_n
            moment += np.cross(f.position_body_m, f.force_body_n)
    return force, moment


class CombinedState(NamedTuple):
    """Translational and rotational state of the combined body (module doc)."""

    r_m: np.ndarray  # (3,) combined CoM, inertial
    v_mps: np.ndarray  # (3,) inertial
    q_inertial_from_body: np.ndarray  # (4,)
    omega_body: np.ndarray  # (3,) inertial angular velocity in chaser_body axes [rad/s]


def combined_rates(state_vector, props, inertia_inv, force_body_n, moment_chaser_n_m, h_wheels_body_n_m_s=(0, 0, 0)):
    """d/dt of (r, v, q, omega) (13,) under a constant wrench about the chaser CoM (module doc)."""
    q = state_vector[6:10]
    omega = state_vector[10:13]
    force = np.asarray(force_body_n, dtype=float)
    torque = np.asarray(moment_chaser_n_m, dtype=float) - np.cross(props.com_body_m, force)  # T = T_c - c x F
    # I omega_dot = T - omega x (I omega + h_w): euler_rate with the wheels' gyroscopic torque moved into T.
    torque = torque - np.cross(omega, np.asarray(h_wheels_body_n_m_s, dtype=float))
    omega_dot = euler_rate(omega.tolist(), props.inertia_body_kg_m2.tolist(), inertia_inv.tolist(), torque.tolist())
    v_dot = quat_rotate(quat_normalize(q), force) / props.mass_kg
    return np.concatenate((state_vector[3:6], v_dot, quaternion_rate(q.tolist(), omega.tolist()), omega_dot))


def _rates_t(_t, state_vector, *args):
    return combined_rates(state_vector, *args)


def specific_force_body(props, omega_body, omega_dot_body, force_body_n, point_body_m=(0.0, 0.0, 0.0)):
    """What an accelerometer at point_body_m (from the chaser CoM) reads [m/s^2], chaser_body axes: F/(m + M)
    + omega_dot x p + omega x (omega x p), p the point from the combined CoM."""
    p = np.asarray(point_body_m, dtype=float) - props.com_body_m
    w = np.asarray(omega_body, dtype=float)
    return (np.asarray(force_body_n, dtype=float) / props.mass_kg + np.cross(omega_dot_body, p)
            + np.cross(w, np.cross(w, p)))


def simulate_combined_body(props, state0, firings, t_samples_s, h_wheels_body_n_m_s=(0.0, 0.0, 0.0),
                           rtol=1e-11, atol=1e-13):
    """The combined body's truth at each of the sorted times t_samples_s (from t = t_samples_s[0]), integrated by
    DOP853 restarted at every firing start and end.

    Returns (states (N, 13): r, v, q, omega; omega_dot (N, 3); force_body (N, 3)), the last two as they are
    at each sample (the wrench active there), for an accelerometer model.
    """
    t = np.asarray(t_samples_s, dtype=float)
    if t.ndim != 1 or t.size == 0 or np.any(np.diff(t) < 0.0) or not np.all(np.isfinite(t)):
        raise ValueError(f't_samples_s must be sorted finite times [s], got {t_samples_s!r}')
    inertia_inv = np.linalg.inv(props.inertia_body_kg_m2)
    y = np.concatenate((state0.r_m, state0.v_mps, quat_normalize(state0.q_inertial_from_body), state0.omega_body))
    bounds = [float(t[0])] + [b for b in firing_breaks(firings) if t[0] < b < t[-1]] + [float(t[-1])]
    out = np.empty((t.size, 13))
    for k, (t_a, t_b) in enumerate(zip(bounds[:-1], bounds[1:], strict=True)):
        force, moment = wrench_about_chaser(firings, t_a)
        # The samples of this segment: [t_a, t_b), the last segment closed.
        inside = (t >= t_a) & ((t < t_b) | ((k == len(bounds) - 2) & (t <= t_b)))
        if t_b > t_a:
            sol = solve_ivp(_rates_t, (t_a, t_b), y, method='DOP853', dense_output=True, rtol=rtol, atol=atol,
                            args=(props, inertia_inv, force, moment, h_wheels_body_n_m_s))
            if sol.status != 0:
                raise RuntimeError(f'combined-body integration failed between {t_a} s and {t_b} s: {sol.message}')
            if inside.any():
                out[inside] = sol.sol(t[inside]).T
            y = sol.y[:, -1]
        else:
            out[inside] = y
    out[:, 6:10] /= np.linalg.norm(out[:, 6:10], axis=1)[:, None]
    omega_dot = np.empty((t.size, 3))
    forces = np.empty((t.size, 3))
    for i, ti in enumerate(t.tolist()):
        forces[i], moment = wrench_about_chaser(firings, ti)
        omega_dot[i] = combined_rates(out[i], props, inertia_inv, forces[i], moment, h_wheels_body_n_m_s)[10:13]
    return out, omega_dot, forces


def angular_momentum_inertial(props, state, h_wheels_body_n_m_s=(0.0, 0.0, 0.0)):
    """The combined body's angular momentum about its CoM [kg m^2/s], inertial axes: C (I omega + h_w)."""
    h = props.inertia_body_kg_m2 @ np.asarray(state.omega_body, dtype=float) + np.asarray(h_wheels_body_n_m_s)
    return quat_rotate(quat_normalize(state.q_inertial_from_body), h)
