"""The combined body's state for seed 004 §2.2's mass-property filter (``mass_properties``): its layout, the
principal-moment re-map, the error state's arithmetic, the combined body's dynamics and IMU over a batch of nominal
states (the filter's central differences), and the prior and estimate records. Pure numpy, no ROS.

Model: ``flyby_sim.dynamics.combined_body`` (seed 004 §2.2: the combined body's CoM, inertia by the parallel-axis
theorem, v_dot = C F / (m + M), Euler's equation with the thrusters' torque about the combined CoM). Frames and
conventions are that module's: chaser_body axes, vectors from the chaser's CoM, quaternions (x, y, z, w),
``q_inertial_from_body`` of the combined body (= the chaser's), ``q_body_from_principal`` the target's principal
axes (seed 004's Q, its D = C_principal_from_body).

Nominal state (seed 004: "state variables" and "estimated quantities"): r, v (combined CoM, inertial), q,
omega (body rate, body axes), target mass M, principal axes Q, target CoM X_s from the chaser CoM, and the
principal moments through j = (j1, j2, j3) (``moments_from_j``). The chaser's mass, inertia and thruster
positions are known (seed 004: I_t0, m, X_f). The filter is multiplicative in both quaternions: its 22-element
error state is

    [dr (3), dv (3), dtheta (3), domega (3), dM (1), dphi (3), dX_s (3), dj (3), (de_i (3) per thruster)]

with q_true = q * exp(dtheta) (body axes) and Q_true = Q * exp(dphi) (principal axes), every other error
additive.

The thrusters' execution errors (``thrust_magnitude_sigma``, ``thrust_misalignment_sigma_rad``: each thruster's force
off by a relative magnitude and a small rotation, drawn once per run in the plant, unknown here) make the known
input uncertain: a firing's force error dF has the covariance S_F = s_m^2 F F' + s_d^2 (|F|^2 U - F F') per
thruster; it enters v_dot as C dF / (m + M) and omega_dot as I^-1 ((X_f - c) x dF), which is added to Qd as white
noise of psd S_F times the firing's duration (the error is constant over a firing: its velocity error at the
firing's end has the right variance; that one thruster's errors recur from firing to firing is left out), and the
accelerometer reads it directly, dF / (m + M) - p x I^-1 ((X_f - c) x dF), which is added to the IMU update's R.
Without them (the default, 0) the firings are exact. With ``thrust_error_states`` the errors are what the plant
draws, constant per thruster over the run (``actuators.draw_thruster_errors``): each thruster (a distinct position
and force direction u among the firings) gets a state e_i, its force error per newton of thrust (F_true = |F|
(u + e_i), e_i = s u + delta x u to first order), prior N(0, s_m^2 u u' + s_d^2 (U - u u')), constant, in the
wrench of every firing of that thruster (propagation and accelerometer); the white-noise terms are then off. The
accelerometer sees the force errors at ten of its sigmas on a 1600 kg body (docs/post_capture.md), so they are
estimated alongside the mass properties instead of washing out as noise that recurs firing to firing.
"""

import math
from typing import NamedTuple

import numpy as np

from flyby_sim.dynamics.rotation import quat_multiply, quat_to_matrix_many, skew

# The principal-moment re-map: corners of the physical cone {I_i < I_j + I_k}, each where two of the three
# triangle inequalities are equalities.
_CONE_EDGES = np.ones((3, 3)) - np.eye(3)
N_ERR = 22
SL_R, SL_V, SL_TH, SL_W = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
I_M, SL_PHI, SL_X, SL_J = 12, slice(13, 16), slice(16, 19), slice(19, 22)
PARAMETER_SLICE = slice(I_M, SL_J.stop)  # the ten parameters M, dphi, X_s, j in the error state
# Nominal layout: r 0:3, v 3:6, q 6:10, omega 10:13, M 13, Q 14:18, X_s 18:21, j 21:24.
N_NOM = 24
# Central-difference steps per error component (a fraction of each quantity's scale; truncation ~ eps^2).
DIFFERENCE_STEPS = np.array([1e-3] * 3 + [1e-4] * 3 + [1e-6] * 3 + [1e-7] * 3 + [1e-4] + [1e-6] * 3 + [1e-6] * 3
                            + [1e-6] * 3)


def moments_from_j(j):
    """Principal moments (..., 3) [kg m^2] of re-mapped parameters j (..., 3), seed 004 §2.2:

        I = zeta ((1 - s) a1 + s (1 - t) a2 + s t a3),  s = (1 + xi)/2, t = (1 + eta)/2,
        xi = 2/pi atan(j1), eta = 2/pi atan(j2), zeta = exp(j3)

    with a1, a2, a3 = (0, 1, 1), (1, 0, 1), (1, 1, 0). The printed map is garbled: its bracket closes before the
    last term (zeta would scale only part of it), and its corners (1, 1, 2), (2, 1, 1), (1, 2, 1) (each over
    sqrt 6) are the midpoints of the cone's faces, whose hull holds only inertias with every moment at least a
    quarter of the trace (no slender body); the corners here are the cone's edges, so every j gives a physical
    inertia and every physical inertia has one j (test_mass_properties: round trips). Unnormalized corners
    make zeta half the trace: I_i = zeta (1 - b_i) with barycentric b = (1 - s, s (1 - t), s t), and b_i > 0
    is exactly I_i < I_j + I_k.
    """
    j = np.asarray(j, dtype=float)
    s = 0.5 + np.arctan(j[..., 0]) / math.pi  # (1 + xi) / 2
    t = 0.5 + np.arctan(j[..., 1]) / math.pi  # (1 + eta) / 2
    b = np.stack((1.0 - s, s * (1.0 - t), s * t), axis=-1)
    return np.exp(j[..., 2])[..., None] * (b @ _CONE_EDGES)


def j_from_moments(moments_kg_m2):
    """The inverse of ``moments_from_j``; raises ValueError unless the moments are finite, > 0 and satisfy the
    strict triangle inequality."""
    i = np.asarray(moments_kg_m2, dtype=float)
    if i.shape[-1:] != (3,) or not np.all(np.isfinite(i)) or np.any(i <= 0.0):
        raise ValueError(f'principal moments must be finite and > 0 [kg m^2], got {moments_kg_m2!r}')
    zeta = 0.5 * i.sum(axis=-1)
    b = 1.0 - i / zeta[..., None]
    if np.any(b <= 0.0):
        raise ValueError(f'principal moments {i.tolist()} break the triangle inequality I_i < I_j + I_k')
    s = 1.0 - b[..., 0]
    t = b[..., 2] / s
    return np.stack((np.tan(math.pi * (s - 0.5)), np.tan(math.pi * (t - 0.5)), np.log(zeta)), axis=-1)


def _quat_exp_many(rotvec):
    """Unit quaternions (N, 4) of rotation vectors (N, 3) (the exponential map, vectorized)."""
    angle = np.linalg.norm(rotvec, axis=1)
    half = 0.5 * angle
    k = np.where(angle < 1e-8, 0.5 - angle * angle / 48.0, np.sin(half) / np.where(angle < 1e-8, 1.0, angle))
    return np.column_stack((k[:, None] * rotvec, np.cos(half)))


def _quat_log_many(q):
    """Rotation vectors (N, 3) of unit quaternions (N, 4), the short way round (the logarithmic map)."""
    q = np.where(q[:, 3:4] < 0.0, -q, q)
    sin_half = np.linalg.norm(q[:, :3], axis=1)
    angle = 2.0 * np.arctan2(sin_half, q[:, 3])
    k = np.where(sin_half < 1e-12, 2.0 / q[:, 3], angle / np.where(sin_half < 1e-12, 1.0, sin_half))
    return k[:, None] * q[:, :3]


def _qmul_many(q1, q2):
    """Hamilton products (N, 4) row by row (``rotation.quat_multiply`` on columns)."""
    return np.column_stack(quat_multiply(q1.T, q2.T))


def cross_rows(a, b):
    """Row-wise cross products of (K, 3) arrays (or one (3,) with (K, 3)); np.cross's axis handling costs more
    than the arithmetic at these sizes."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def perturb(y_ref, e):
    """Nominal states (K, 24 + 3 n) of the reference (24 + 3 n,) displaced by error states e (K, 22 + 3 n) (module
    doc; n thrusters' force errors as states, 0 without them)."""
    k = e.shape[0]
    y = np.repeat(y_ref[None, :], k, axis=0)
    y[:, 0:6] += e[:, 0:6]
    y[:, 6:10] = _qmul_many(y[:, 6:10], _quat_exp_many(e[:, SL_TH]))
    y[:, 10:13] += e[:, SL_W]
    y[:, 13] += e[:, I_M]
    y[:, 14:18] = _qmul_many(y[:, 14:18], _quat_exp_many(e[:, SL_PHI]))
    y[:, 18:24] += e[:, 16:22]
    y[:, N_NOM:] += e[:, N_ERR:]  # the thrusters' force errors, additive
    return y


def difference(y, y_ref):
    """Error states (K, 22 + 3 n) of nominal states y (K, 24 + 3 n) from the reference y_ref: the inverse of
    perturb."""
    e = np.empty((y.shape[0], y.shape[1] - N_NOM + N_ERR))
    e[:, 0:6] = y[:, 0:6] - y_ref[0:6]
    conj = y_ref[[6, 7, 8, 9]] * np.array([-1.0, -1.0, -1.0, 1.0])
    e[:, SL_TH] = _quat_log_many(_qmul_many(np.broadcast_to(conj, (y.shape[0], 4)), y[:, 6:10]))
    e[:, SL_W] = y[:, 10:13] - y_ref[10:13]
    e[:, I_M] = y[:, 13] - y_ref[13]
    conj_q = y_ref[[14, 15, 16, 17]] * np.array([-1.0, -1.0, -1.0, 1.0])
    e[:, SL_PHI] = _quat_log_many(_qmul_many(np.broadcast_to(conj_q, (y.shape[0], 4)), y[:, 14:18]))
    e[:, 16:22] = y[:, 18:24] - y_ref[18:24]
    e[:, N_ERR:] = y[:, N_NOM:] - y_ref[N_NOM:]
    return e


def folded(y, p, dx):
    """(the nominal y displaced by the error dx, the covariance of the error about it): both quaternions with
    Markley's reset, P <- G P G' with G = I - 1/2 [dtheta x] (and [dphi x]) on their blocks."""
    g = np.eye(p.shape[0])
    g[SL_TH, SL_TH] -= 0.5 * skew(dx[SL_TH])
    g[SL_PHI, SL_PHI] -= 0.5 * skew(dx[SL_PHI])
    p = g @ p @ g.T
    return perturb(y, dx[None, :])[0], 0.5 * (p + p.T)


def central_offsets(eps):
    """Error states (2 n + 1, n): zero, then +eps_i and -eps_i one component at a time (central differences)."""
    n = eps.size
    e = np.zeros((2 * n + 1, n))
    idx = np.arange(n)
    e[1 + idx, idx] = eps
    e[1 + n + idx, idx] = -eps
    return e


def thruster_key(firing):
    """A thruster's identity in the firings: its position and force direction (rounded; the allocation changes only
    the thrust)."""
    force = np.asarray(firing.force_body_n, dtype=float)
    return (tuple(np.round(firing.position_body_m, 9).tolist()),
            tuple(np.round(force / np.linalg.norm(force), 6).tolist()))


class BatchBody:
    """The combined body's mass properties for a batch of nominal states (K, 24) (combined_body's equations,
    vectorized over the batch); ``mass`` the total less the propellant burned_kg [kg] the firings have burned
    (``MassPropertyFilterConfig.exhaust_velocity_mps``), the CoM and inertia the chaser's own mass's."""

    def __init__(self, y, chaser_mass_kg, chaser_inertia_body, burned_kg=0.0):
        big_m = y[:, 13]
        c_body_from_principal = quat_to_matrix_many(y[:, 14:18])
        moments = moments_from_j(y[:, 21:24])
        i_s = np.einsum('kab,kb,kcb->kac', c_body_from_principal, moments, c_body_from_principal)
        total = big_m + chaser_mass_kg
        c = (big_m / total)[:, None] * y[:, 18:21]  # c = M/(M+m) X_s
        y_s = y[:, 18:21] - c
        eye = np.eye(3)
        inertia = (chaser_inertia_body + i_s
                   + chaser_mass_kg * (np.einsum('ka,ka->k', c, c)[:, None, None] * eye - np.einsum('ka,kb->kab', c, c))
                   + big_m[:, None, None] * (np.einsum('ka,ka->k', y_s, y_s)[:, None, None] * eye
                                             - np.einsum('ka,kb->kab', y_s, y_s)))
        self.mass = total - burned_kg
        self.c = c
        self.inertia = inertia
        self.inertia_inv = np.linalg.inv(inertia)

    def omega_dot(self, omega, force, moment, h_wheels):
        """I^-1 (T_c - c x F - omega x (I omega + h_w)) (K, 3)."""
        torque = moment - cross_rows(self.c, force)
        h = np.einsum('kab,kb->ka', self.inertia, omega) + h_wheels
        return np.einsum('kab,kb->ka', self.inertia_inv, torque - cross_rows(omega, h))

    def rates(self, x, force, moment, h_wheels):
        """d/dt of (r, v, q, omega) (K, 13)."""
        q, omega = x[:, 6:10], x[:, 10:13]
        qx, qy, qz, qw = q.T
        wx, wy, wz = omega.T
        q_dot = 0.5 * np.column_stack((qw * wx + qy * wz - qz * wy, qw * wy + qz * wx - qx * wz,
                                       qw * wz + qx * wy - qy * wx, -(qx * wx + qy * wy + qz * wz)))
        # v_dot = C_inertial_from_body F / (m + M)
        u = q[:, :3]
        t = 2.0 * cross_rows(u, force)
        v_dot = (force + q[:, 3:4] * t + cross_rows(u, t)) / self.mass[:, None]
        return np.column_stack((x[:, 3:6], v_dot, q_dot, self.omega_dot(omega, force, moment, h_wheels)))


def rk4_batch(y, dt, force, moment, h_wheels, chaser_mass_kg, chaser_inertia_body, burned_kg):
    """The nominal states (K, 24) after dt [s] of RK4 under a constant wrench and propellant burned_kg [kg] burned
    (``BatchBody``), quaternions renormalized."""
    body = BatchBody(y, chaser_mass_kg, chaser_inertia_body, burned_kg)
    x = y[:, :13]
    k1 = body.rates(x, force, moment, h_wheels)
    k2 = body.rates(x + 0.5 * dt * k1, force, moment, h_wheels)
    k3 = body.rates(x + 0.5 * dt * k2, force, moment, h_wheels)
    k4 = body.rates(x + dt * k3, force, moment, h_wheels)
    out = y.copy()
    out[:, :13] = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    out[:, 6:10] /= np.linalg.norm(out[:, 6:10], axis=1)[:, None]
    return out


def imu_batch(y, force, moment, h_wheels, chaser_mass_kg, chaser_inertia_body, burned_kg, accel_position_body,
               interval_s):
    """Gyro and accelerometer (K, 6) predicted for nominal states (K, 24) at a sample (seed 004 §2.2's observations
    omega and x_t'', its equations unnumbered): omega, and the specific force F/(m+M) + omega_dot x p
    + omega x (omega x p) with p the accelerometer from the combined CoM (combined_body.specific_force_body).
    interval_s > 0: the accelerometer of ``MassPropertyFilterConfig.accel_interval_s``, the states carried back over
    the interval under the held wrench (two RK4 half-steps): the thrust's mean acceleration over it resolved in the
    body axes at the sample, (1/T) int C_b(t)<-b(tau) F/(m+M) dtau by Simpson's rule over the body's turn, and
    omega_dot x p as its interval mean (omega(t) - omega(t - T)) / T x p; omega x (omega x p) at the sample."""
    body = BatchBody(y, chaser_mass_kg, chaser_inertia_body, burned_kg)
    omega = y[:, 10:13]
    p = accel_position_body - body.c
    thrust = np.broadcast_to(force, omega.shape) / body.mass[:, None]
    if interval_s == 0.0:
        w_dot = body.omega_dot(omega, force, moment, h_wheels)
    else:
        chaser = (chaser_mass_kg, chaser_inertia_body, burned_kg)
        mid = rk4_batch(y, -0.5 * interval_s, force, moment, h_wheels, *chaser)
        start = rk4_batch(mid, -0.5 * interval_s, force, moment, h_wheels, *chaser)
        w_dot = (omega - start[:, 10:13]) / interval_s
        c_end = quat_to_matrix_many(y[:, 6:10])  # C_inertial_from_body at the sample

        def turned(states):  # the thrust at an earlier time resolved in the body axes at the sample
            c_end_from_then = np.einsum('kba,kbc->kac', c_end, quat_to_matrix_many(states[:, 6:10]))
            return np.einsum('kab,kb->ka', c_end_from_then, thrust)

        thrust = (thrust + 4.0 * turned(mid) + turned(start)) / 6.0
    accel = thrust + cross_rows(w_dot, p) + cross_rows(omega, cross_rows(omega, p))
    return np.column_stack((omega, accel))


class MassPropertyPrior(NamedTuple):
    """The target's mass properties before the excitation, and their 1-sigma spread (the filter's P0)."""

    target_mass_kg: float
    target_com_body_m: tuple  # X_s
    q_body_from_principal: tuple
    principal_moments_kg_m2: tuple
    mass_sigma_kg: float
    com_sigma_m: float  # per axis
    axes_sigma_rad: float  # per principal axis
    j_sigma: tuple  # per j component (j3 = log of half the trace: a relative sigma of the trace)


class MassPropertyEstimate(NamedTuple):
    """The filter's estimate of the target at the filter time, each with its 1-sigma (chaser_body axes)."""

    t: float
    target_mass_kg: float
    target_com_body_m: np.ndarray  # X_s, from the chaser CoM
    q_body_from_principal: np.ndarray
    principal_moments_kg_m2: np.ndarray
    target_inertia_body_kg_m2: np.ndarray  # about the target's CoM
    mass_sigma_kg: float
    com_sigma_m: np.ndarray
    axes_sigma_rad: np.ndarray  # of dphi, principal axes
    principal_moments_sigma_kg_m2: np.ndarray
    r_m: np.ndarray
    v_mps: np.ndarray
    q_inertial_from_body: np.ndarray
    omega_body: np.ndarray
    covariance: np.ndarray  # (22 + 3 n, 22 + 3 n) of the error state (module doc)
    thrust_errors: np.ndarray  # (n, 3) each thruster's force error per newton of thrust (thrust_error_states)
