"""The captured target's mass properties from the combined body's response to known thruster firings: the
extended Kalman filter of seed 004 §2.2 on filterpy (no ROS).

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
additive. Observations (seed 004: omega, x_t'', q): the gyro rate and the accelerometer's specific force at
the chaser (``on_imu``, 6 values together), the star tracker's attitude (``update``), and, optionally, the
combined CoM's position (``on_position``; seed 004's GPS).

Time update: the nominal is integrated by RK4 in steps of at most ``max_step_s``, cut at every firing's start
and end (the known input, ``combined_body.Firing``); the transition Phi of the error over each step is the
central difference of that same step (44 perturbed copies integrated with the nominal as one batch); P = Phi P
Phi' + Qd is filterpy's ``ExtendedKalmanFilter.predict`` with F = Phi (the error state is zero between
updates). Qd: white noise of psd ``accel_psd_m2_s3`` on v_dot and ``angular_accel_psd_rad2_s3`` on omega_dot
(the model's integration and the unmodelled, e.g. the orbit's differential gravity; zero where the truth has
none, below), integrated into r and theta over the step (dt^3/3, dt^2/2 terms), and ``parameter_psd`` on the
parameters (default 0: constants).

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

Measurement update: filterpy's ``ExtendedKalmanFilter.update`` (Joseph form) with H the central difference of
the measurement function (the IMU) or [.. I ..] (attitude, position), the innovation computed from the nominal
(attitude: ``filter_interface.attitude_innovation``), gated on the chi-square of its size; then the error is
folded into the nominal (both quaternions by Markley's reset, ``_fold``) and zeroed.

Iterated IMU update over a firing (``imu_iterations``): seed 004's gyro (1e-5 rad/s) against a full-thrust
pulse's response (~0.1 rad/s per IMU interval on the TugRobot) makes the response's curvature in a parameter
error of a few percent (~(3 %)^2 x 0.1 rad/s) several gyro sigmas, in the propagation, not in the measurement.
Over an interval in which a firing acts the update is Gauss-Newton on the error theta at the last update (prior
N(0, P0)) with the measurement z = h(f(x0 + theta)) + H w + v, f the propagation re-run from each iterate:
theta' = P0 Phi' H' S^-1 (z - h(f(x0 + theta)) + H Phi theta), to < 1 % of a sigma; the last linearization gives
the update, its prior mean -Phi theta from the re-propagated nominal (the one-step maximum a posteriori, test
``test_seed004_iterated_imu_update_over_a_firing_is_the_one_step_map_estimate``); it also takes the curvature of
F/(m + M) in M. Between firings the plain EKF update (the torque-free response's curvature is below a gyro sigma).

Re-linearization over the whole run (``relinearize``): the forward filter's covariance is the information of
every sample linearized where the estimate stood when the sample came, a few percent off at the first pulses;
the posterior after a full-thrust pulse from the prior is not Gaussian (the principal axes enter the inertia
times the moments' differences, the CoM squared, both uncertain), and what those early linearizations put into P
stays there. Worst where two true moments are equal (seed 004 §3.1's cylinder, (2, 1.5, 1.5)): the inertia
moves with the rotation dphi about the symmetry axis by (I2 - I3) dphi, zero in truth, but the prior's
I2 - I3 (a few percent) lends dphi information early that no data holds (its sigma falls from the prior's 1 deg
to ~0.7 deg, RMS z 1.9 to 5 over 50 runs). ``relinearize`` is Gauss-Newton on the whole run, the maximum a
posteriori of the prior and every sample under seed 004 §2.2's model (its equations are unnumbered): carry the
current estimate back to the prior's time with the model without noise (``_propagate``), re-run the Kalman filter
on every finite, timely sample with Phi, H and the innovations from that one trajectory (the error state relative
to it, its prior mean the prior's, each sample gated on its own innovation, so that samples the forward filter
rejected while far off come back), take its end as the estimate; repeat until a step is below 1 % of every sigma
(two or three iterations from the default prior; test ``test_seed004_relinearize_is_the_batch_map_estimate``:
equal to scipy's least_squares on the same problem).
Its covariance is then the information along one trajectory near the truth, and at two equal moments dphi
about the symmetry axis keeps its prior (test
``test_seed004_relinearized_cylinder_learns_nothing_of_its_rotation_about_its_axis``). Measured
(docs/post_capture.md): over 50 TugRobot runs the relinearized NEES is inside its 95 % band for Table 1 and the
chosen sequence, where the forward filter's is 1.4 to 2.9 times it; from a prior ten times wider (tens of
percent, the forward gate rejecting most samples) the errors go from percents to hundredths of a percent, but
the runs need 6 to 8 iterations and the NEES stays above its band.

The gyro's residual bias (``gyro_bias_covariance`` of the constructor): in a mission the gyro comes less an attitude
filter's bias estimate, whose error (~2e-6 rad/s on the TugRobot after 60 s, a fifth of a gyro sigma on every
sample, correlated over the run) the filter otherwise reads as dynamics; b is then a state after the thrusters'
errors (additive, its prior that estimate's covariance, walking as ``gyro_bias_walk_rad_s_sqrt_s``), the gyro
predicted as omega + b.

Process noise and consistency: ``accel_psd_m2_s3`` and ``angular_accel_psd_rad2_s3`` must be what the truth has.
A rate random walk the truth does not have makes P conservative where the information comes slowly: the split
of two equal moments (j2) is told by the gyroscopic drift the torque-free turn accumulates after the firings
(its sigma keeps falling to the window's end), which 1e-12 rad^2/s^3 masks; on the TugRobot experiment (no
unmodelled torque) j2's error was half its sigma with it.
"""

import dataclasses
import math
from typing import NamedTuple

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter
from scipy.stats import chi2

from flyby_estimation.filter_interface import FilterBase, attitude_innovation, new_counts
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.combined_body import (
    firing_breaks,
    inertia_from_principal,
    wrench_about_chaser,
)
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_multiply,
    quat_normalize,
    quat_to_matrix_many,
    rotation_vector_from_quat,
    skew,
)

# The principal-moment re-map: corners of the physical cone {I_i < I_j + I_k}, each where two of the three
# triangle inequalities are equalities.
_CONE_EDGES = np.ones((3, 3)) - np.eye(3)

N_ERR = 22
_SL_R, _SL_V, _SL_TH, _SL_W = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
_I_M, _SL_PHI, _SL_X, _SL_J = 12, slice(13, 16), slice(16, 19), slice(19, 22)
PARAMETER_SLICE = slice(_I_M, _SL_J.stop)  # the ten parameters M, dphi, X_s, j in the error state
# Nominal layout: r 0:3, v 3:6, q 6:10, omega 10:13, M 13, Q 14:18, X_s 18:21, j 21:24.
N_NOM = 24
# Central-difference steps per error component (a fraction of each quantity's scale; truncation ~ eps^2).
_EPS = np.array([1e-3] * 3 + [1e-4] * 3 + [1e-6] * 3 + [1e-7] * 3 + [1e-4] + [1e-6] * 3 + [1e-6] * 3 + [1e-6] * 3)


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


def _cross(a, b):
    """Row-wise cross products of (K, 3) arrays (or one (3,) with (K, 3)); np.cross's axis handling costs more
    than the arithmetic at these sizes."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def _perturb(y_ref, e):
    """Nominal states (K, 24 + 3 n) of the reference (24 + 3 n,) displaced by error states e (K, 22 + 3 n) (module
    doc; n thrusters' force errors as states, 0 without them)."""
    k = e.shape[0]
    y = np.repeat(y_ref[None, :], k, axis=0)
    y[:, 0:6] += e[:, 0:6]
    y[:, 6:10] = _qmul_many(y[:, 6:10], _quat_exp_many(e[:, _SL_TH]))
    y[:, 10:13] += e[:, _SL_W]
    y[:, 13] += e[:, _I_M]
    y[:, 14:18] = _qmul_many(y[:, 14:18], _quat_exp_many(e[:, _SL_PHI]))
    y[:, 18:24] += e[:, 16:22]
    y[:, N_NOM:] += e[:, N_ERR:]  # the thrusters' force errors, additive
    return y


def _difference(y, y_ref):
    """Error states (K, 22 + 3 n) of nominal states y (K, 24 + 3 n) from the reference y_ref: the inverse of
    _perturb."""
    e = np.empty((y.shape[0], y.shape[1] - N_NOM + N_ERR))
    e[:, 0:6] = y[:, 0:6] - y_ref[0:6]
    conj = y_ref[[6, 7, 8, 9]] * np.array([-1.0, -1.0, -1.0, 1.0])
    e[:, _SL_TH] = _quat_log_many(_qmul_many(np.broadcast_to(conj, (y.shape[0], 4)), y[:, 6:10]))
    e[:, _SL_W] = y[:, 10:13] - y_ref[10:13]
    e[:, _I_M] = y[:, 13] - y_ref[13]
    conj_q = y_ref[[14, 15, 16, 17]] * np.array([-1.0, -1.0, -1.0, 1.0])
    e[:, _SL_PHI] = _quat_log_many(_qmul_many(np.broadcast_to(conj_q, (y.shape[0], 4)), y[:, 14:18]))
    e[:, 16:22] = y[:, 18:24] - y_ref[18:24]
    e[:, N_ERR:] = y[:, N_NOM:] - y_ref[N_NOM:]
    return e


def _folded(y, p, dx):
    """(the nominal y displaced by the error dx, the covariance of the error about it): both quaternions with
    Markley's reset, P <- G P G' with G = I - 1/2 [dtheta x] (and [dphi x]) on their blocks."""
    g = np.eye(p.shape[0])
    g[_SL_TH, _SL_TH] -= 0.5 * skew(dx[_SL_TH])
    g[_SL_PHI, _SL_PHI] -= 0.5 * skew(dx[_SL_PHI])
    p = g @ p @ g.T
    return _perturb(y, dx[None, :])[0], 0.5 * (p + p.T)


def _central_offsets(eps):
    """Error states (2 n + 1, n): zero, then +eps_i and -eps_i one component at a time (central differences)."""
    n = eps.size
    e = np.zeros((2 * n + 1, n))
    idx = np.arange(n)
    e[1 + idx, idx] = eps
    e[1 + n + idx, idx] = -eps
    return e


def _thruster_key(firing):
    """A thruster's identity in the firings: its position and force direction (rounded; the allocation changes only
    the thrust)."""
    force = np.asarray(firing.force_body_n, dtype=float)
    return (tuple(np.round(firing.position_body_m, 9).tolist()),
            tuple(np.round(force / np.linalg.norm(force), 6).tolist()))


class _BatchBody:
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
        torque = moment - _cross(self.c, force)
        h = np.einsum('kab,kb->ka', self.inertia, omega) + h_wheels
        return np.einsum('kab,kb->ka', self.inertia_inv, torque - _cross(omega, h))

    def rates(self, x, force, moment, h_wheels):
        """d/dt of (r, v, q, omega) (K, 13)."""
        q, omega = x[:, 6:10], x[:, 10:13]
        qx, qy, qz, qw = q.T
        wx, wy, wz = omega.T
        q_dot = 0.5 * np.column_stack((qw * wx + qy * wz - qz * wy, qw * wy + qz * wx - qx * wz,
                                       qw * wz + qx * wy - qy * wx, -(qx * wx + qy * wy + qz * wz)))
        # v_dot = C_inertial_from_body F / (m + M)
        u = q[:, :3]
        t = 2.0 * _cross(u, force)
        v_dot = (force + q[:, 3:4] * t + _cross(u, t)) / self.mass[:, None]
        return np.column_stack((x[:, 3:6], v_dot, q_dot, self.omega_dot(omega, force, moment, h_wheels)))


def _rk4_batch(y, dt, force, moment, h_wheels, chaser_mass_kg, chaser_inertia_body, burned_kg):
    """The nominal states (K, 24) after dt [s] of RK4 under a constant wrench and propellant burned_kg [kg] burned
    (``_BatchBody``), quaternions renormalized."""
    body = _BatchBody(y, chaser_mass_kg, chaser_inertia_body, burned_kg)
    x = y[:, :13]
    k1 = body.rates(x, force, moment, h_wheels)
    k2 = body.rates(x + 0.5 * dt * k1, force, moment, h_wheels)
    k3 = body.rates(x + 0.5 * dt * k2, force, moment, h_wheels)
    k4 = body.rates(x + dt * k3, force, moment, h_wheels)
    out = y.copy()
    out[:, :13] = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    out[:, 6:10] /= np.linalg.norm(out[:, 6:10], axis=1)[:, None]
    return out


def _imu_batch(y, force, moment, h_wheels, chaser_mass_kg, chaser_inertia_body, burned_kg, accel_position_body,
               interval_s):
    """Gyro and accelerometer (K, 6) predicted for nominal states (K, 24) at a sample (seed 004 §2.2's observations
    omega and x_t'', its equations unnumbered): omega, and the specific force F/(m+M) + omega_dot x p
    + omega x (omega x p) with p the accelerometer from the combined CoM (combined_body.specific_force_body).
    interval_s > 0: the accelerometer of ``MassPropertyFilterConfig.accel_interval_s``, the states carried back over
    the interval under the held wrench (two RK4 half-steps): the thrust's mean acceleration over it resolved in the
    body axes at the sample, (1/T) int C_b(t)<-b(tau) F/(m+M) dtau by Simpson's rule over the body's turn, and
    omega_dot x p as its interval mean (omega(t) - omega(t - T)) / T x p; omega x (omega x p) at the sample."""
    body = _BatchBody(y, chaser_mass_kg, chaser_inertia_body, burned_kg)
    omega = y[:, 10:13]
    p = accel_position_body - body.c
    thrust = np.broadcast_to(force, omega.shape) / body.mass[:, None]
    if interval_s == 0.0:
        w_dot = body.omega_dot(omega, force, moment, h_wheels)
    else:
        chaser = (chaser_mass_kg, chaser_inertia_body, burned_kg)
        mid = _rk4_batch(y, -0.5 * interval_s, force, moment, h_wheels, *chaser)
        start = _rk4_batch(mid, -0.5 * interval_s, force, moment, h_wheels, *chaser)
        w_dot = (omega - start[:, 10:13]) / interval_s
        c_end = quat_to_matrix_many(y[:, 6:10])  # C_inertial_from_body at the sample

        def turned(states):  # the thrust at an earlier time resolved in the body axes at the sample
            c_end_from_then = np.einsum('kba,kbc->kac', c_end, quat_to_matrix_many(states[:, 6:10]))
            return np.einsum('kab,kb->ka', c_end_from_then, thrust)

        thrust = (thrust + 4.0 * turned(mid) + turned(start)) / 6.0
    accel = thrust + _cross(w_dot, p) + _cross(omega, _cross(omega, p))
    return np.column_stack((omega, accel))


@dataclasses.dataclass(frozen=True)
class MassPropertyFilterConfig:
    """Parameters of MassPropertyFilter (validated; ValueError names the field).

    Attributes:
        chaser_mass_kg, chaser_inertia_body_kg_m2: the chaser's (seed 004's m, I_t0), known.
        accel_position_body_m: the accelerometer's position from the chaser CoM [m].
        gyro_sigma_rad_s, accel_sigma_mps2, attitude_sigma_rad, position_sigma_m: measurement noise, 1 sigma
            per axis (defaults: the chaser IMU's of chaser_body.ImuConfig; position 1 cm).
        accel_psd_m2_s3, angular_accel_psd_rad2_s3, parameter_psd: process noise (module doc).
        h_wheels_body_n_m_s: the wheels' momentum in body axes, held constant while the filter runs.
        max_step_s: longest propagation step [s].
        imu_iterations: most Gauss-Newton iterations of an IMU update over an interval with a firing, each
            re-propagating from the last update (module doc; 1: the plain EKF update).
        gate_probability: chi-square probability of the innovation gate (of the measurement's size).
        max_consecutive_outliers: rejections in a row after which a measurement is taken anyway (the model is
            then trusted less than the data: the gate must not lock the filter out).
        thrust_magnitude_sigma, thrust_misalignment_sigma_rad: each thruster's execution errors, 1 sigma (relative
            magnitude; misalignment [rad] about each axis normal to its force) (module doc).
        thrust_error_states: the execution errors as states, three per thruster (constant over the run, as the
            plant draws them), instead of white input noise (module doc).
        accel_interval_s: 0: the accelerometer reads the specific force at its stamp; > 0: as the plant's IMU
            (``flyby_sim.plant``) gives it over the interval T of this length ending at its stamp: the thrust's
            velocity increment over T (inertial) over T, resolved in the body axes at the stamp, the mean of
            omega_dot x p over T, and omega x (omega x p) at the stamp (``_imu_batch``); the wrench held at the
            interval's middle, exact for firings that start and end on samples. Over a full-thrust firing on the
            TugRobot the body turns ~0.03 rad in an interval and its rate by ~0.04 rad/s: read at the stamp instead,
            the thrust's turn and the gyroscopic term's change are tens of accelerometer sigmas
            (docs/post_capture.md).
        exhaust_velocity_mps: the thrusters' Isp g0 [m/s]: the propellant the firings burn (|F| / v_e per second of
            each, known) leaves the combined body's mass in v_dot and the accelerometer's F/(m + M), as the plant
            burns it (its share of the CoM and inertia left out, as there); None: the mass is constant (seed 004
            §2.2's m). The chosen excitation burns 22 g of the TugRobot's 50 kg (4.4e-4 of F/(m + M), two of the
            mass's sigmas).
        gyro_bias_walk_rad_s_sqrt_s: the gyro bias's random walk, the bias state's process noise (the filter's
            gyro_bias_covariance; module doc).
    """

    chaser_mass_kg: float
    chaser_inertia_body_kg_m2: tuple
    accel_position_body_m: tuple = (0.0, 0.0, 0.0)
    gyro_sigma_rad_s: float = 1e-5
    accel_sigma_mps2: float = 1e-4
    attitude_sigma_rad: float = math.radians(0.01)
    position_sigma_m: float = 0.01
    accel_psd_m2_s3: float = 1e-10
    angular_accel_psd_rad2_s3: float = 1e-12
    parameter_psd: float = 0.0
    h_wheels_body_n_m_s: tuple = (0.0, 0.0, 0.0)
    max_step_s: float = 0.1
    imu_iterations: int = 3
    gate_probability: float = 0.9999
    max_consecutive_outliers: int = 20
    thrust_magnitude_sigma: float = 0.0
    thrust_misalignment_sigma_rad: float = 0.0
    thrust_error_states: bool = False
    accel_interval_s: float = 0.0
    exhaust_velocity_mps: float = None
    gyro_bias_walk_rad_s_sqrt_s: float = 0.0

    def __post_init__(self):
        require_positive('chaser_mass_kg', self.chaser_mass_kg)
        inertia = np.asarray(self.chaser_inertia_body_kg_m2, dtype=float)
        if inertia.shape != (3, 3) or not np.all(np.isfinite(inertia)) or np.linalg.eigvalsh(
                0.5 * (inertia + inertia.T)).min() <= 0.0:
            raise ValueError(f'chaser_inertia_body_kg_m2 must be a positive definite 3x3 [kg m^2], '
                             f'got {self.chaser_inertia_body_kg_m2!r}')
        for name in ('gyro_sigma_rad_s', 'accel_sigma_mps2', 'attitude_sigma_rad', 'position_sigma_m', 'max_step_s'):
            require_positive(name, getattr(self, name))
        if self.exhaust_velocity_mps is not None:
            require_positive('exhaust_velocity_mps', self.exhaust_velocity_mps)
        for name in ('accel_psd_m2_s3', 'angular_accel_psd_rad2_s3', 'parameter_psd', 'accel_interval_s',
                     'gyro_bias_walk_rad_s_sqrt_s', 'thrust_magnitude_sigma', 'thrust_misalignment_sigma_rad'):
            require_positive(name, getattr(self, name), allow_zero=True)
        if not 0.0 < self.gate_probability < 1.0:
            raise ValueError(f'gate_probability must be in (0, 1), got {self.gate_probability!r}')


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


class MassPropertyFilter(FilterBase):
    """Seed 004 §2.2's EKF of the combined body's state and the target's mass properties (module doc).

    ``update(t, q)`` fuses a star-tracker attitude (the ``filter_interface`` verb); ``on_imu(t, gyro, accel)``
    a gyro and accelerometer sample; ``on_position(t, r)`` a position. Known inputs: the firings given to the
    constructor or ``add_firings``, which must not start before the filter time (nor, with thrust_error_states,
    come from a thruster the constructor's firings did not name).
    """

    def __init__(self, config, prior, t0, r_m, v_mps, q_inertial_from_body, omega_body, state_sigmas,
                 firings=(), gyro_bias_covariance=None):
        """state_sigmas: 1 sigma per axis of (r [m], v [m/s], attitude [rad], omega [rad/s]) at t0 [s];
        gyro_bias_covariance: (3, 3) [rad^2/s^2] the prior of the gyro's residual bias b (gyro = omega + b + noise,
        a state after the thrusters' errors, walking as config.gyro_bias_walk_rad_s_sqrt_s; module doc), None: no
        bias."""
        super().__init__(config.gate_probability, config.max_consecutive_outliers)
        self.config = config
        self._gate_by_size = {n: float(chi2.ppf(config.gate_probability, df=n)) for n in (3, 6)}
        self.imu_counts = new_counts()
        self.position_counts = new_counts()
        self._m = float(config.chaser_mass_kg)
        self._i_t0 = np.asarray(config.chaser_inertia_body_kg_m2, dtype=float)
        self._p_acc = np.asarray(config.accel_position_body_m, dtype=float)
        self._h_w = np.asarray(config.h_wheels_body_n_m_s, dtype=float)
        self._firings = sorted(firings, key=lambda f: f.t_start_s)
        # thruster key -> index of its force-error state (thrust_error_states), in order of first firing
        self._thrusters = {}
        self._error_states = config.thrust_error_states and (config.thrust_magnitude_sigma > 0.0
                                                             or config.thrust_misalignment_sigma_rad > 0.0)
        if self._error_states:
            for f in self._firings:
                self._thrusters.setdefault(_thruster_key(f), len(self._thrusters))
        n_thr = len(self._thrusters)
        n_bias = 0 if gyro_bias_covariance is None else 3
        self._sl_bias = slice(N_ERR + 3 * n_thr, N_ERR + 3 * n_thr + n_bias)  # in the error state
        self._n = N_ERR + 3 * n_thr + n_bias
        self._eps = np.concatenate((_EPS, np.full(3 * n_thr + n_bias, 1e-6)))
        self._y = np.concatenate((r_m, v_mps, quat_normalize(q_inertial_from_body), omega_body,
                                  [prior.target_mass_kg], quat_normalize(prior.q_body_from_principal),
                                  prior.target_com_body_m, j_from_moments(prior.principal_moments_kg_m2),
                                  np.zeros(3 * n_thr + n_bias)))
        sig_r, sig_v, sig_att, sig_w = state_sigmas
        sigmas = np.concatenate(([sig_r] * 3, [sig_v] * 3, [sig_att] * 3, [sig_w] * 3, [prior.mass_sigma_kg],
                                 [prior.axes_sigma_rad] * 3, [prior.com_sigma_m] * 3, prior.j_sigma))
        p0 = np.zeros((self._n, self._n))
        p0[:N_ERR, :N_ERR] = np.diag(sigmas ** 2)
        for (_, u), i in self._thrusters.items():
            k = N_ERR + 3 * i
            p0[k:k + 3, k:k + 3] = self._force_error_covariance(np.array(u))
        if n_bias:
            p0[self._sl_bias, self._sl_bias] = gyro_bias_covariance
        self._kf = ExtendedKalmanFilter(dim_x=self._n, dim_z=6)
        self._kf.x = np.zeros((self._n, 1))
        self._kf.P = p0
        self._t = float(t0)
        self._consecutive_rejects = 0
        self._start = (self._t, self._y.copy(), p0.copy())  # the prior, for relinearize
        self._samples = []  # (t, kind, z) of every finite, timely measurement, in order, for relinearize

    def add_firings(self, firings):
        """More known inputs (combined_body.Firing); raises ValueError for one starting before the filter time or
        (thrust_error_states) from a thruster without an error state."""
        for f in firings:
            if f.t_start_s < self._t:
                raise ValueError(f'firing at t = {f.t_start_s} s starts before the filter time {self._t} s')
            if self._error_states and _thruster_key(f) not in self._thrusters:
                raise ValueError(f'firing at t = {f.t_start_s} s is from a thruster the filter has no error state '
                                 f'for (position {f.position_body_m}): give every thruster in the constructor')
        self._firings = sorted(self._firings + list(firings), key=lambda f: f.t_start_s)

    @property
    def covariance(self):
        return self._kf.P.copy()

    def _force_error_covariance(self, force):
        """S_F = s_m^2 F F' + s_d^2 (|F|^2 U - F F'): a force's execution error (module doc)."""
        cfg = self.config
        ff = np.outer(force, force)
        return cfg.thrust_magnitude_sigma ** 2 * ff + cfg.thrust_misalignment_sigma_rad ** 2 * (
            float(force @ force) * np.eye(3) - ff)

    def _active(self, t):
        return [f for f in self._firings if f.t_start_s <= t < f.t_start_s + f.duration_s]

    def _burned_kg(self, t):
        """The propellant the firings have burned by t [kg]: |F| / v_e over each firing's time before t (0 without
        ``exhaust_velocity_mps``); a step's integration takes it at the step's middle."""
        v_e = self.config.exhaust_velocity_mps
        if v_e is None:
            return 0.0
        return sum(math.hypot(*f.force_body_n) * min(max(t - f.t_start_s, 0.0), f.duration_s)
                   for f in self._firings) / v_e

    def _wrench(self, y, t):
        """(force, moment about the chaser CoM) at t [s] of the firings for nominal states y (K, 24 + 3 n): the known
        wrench, plus (thrust_error_states) each firing thruster's error |F| e_i at its position, one per row."""
        force, moment = wrench_about_chaser(self._firings, t)
        if not self._thrusters:
            return force, moment
        force = np.repeat(force[None, :], y.shape[0], axis=0)
        moment = np.repeat(moment[None, :], y.shape[0], axis=0)
        for f in self._active(t):
            k = N_NOM + 3 * self._thrusters[_thruster_key(f)]
            d_f = math.hypot(*f.force_body_n) * y[:, k:k + 3]
            force += d_f
            moment += _cross(np.asarray(f.position_body_m, dtype=float), d_f)
        return force, moment

    # --- time update -----------------------------------------------------------------------------------------

    def propagate_to(self, t):
        """Time update to t >= the filter time [s], cut at the firings' starts and ends (module doc)."""
        if t < self._t:
            raise ValueError(f'cannot propagate back from {self._t} s to {t} s')
        if t == self._t:
            return
        self._y, self._kf.F, self._kf.Q = self._transition(self._y, self._t, t)
        self._kf.predict()  # P = F P F' + Q (x stays zero)
        self._t = float(t)

    def _transition(self, y, t0, t1):
        """(the nominal at t1, Phi, Qd) from the nominal y at t0 [s]: RK4 steps of at most max_step_s cut at the
        firings' starts and ends, each step's Phi the central difference of that step, composed (module doc)."""
        n = self._n
        phi, q = np.eye(n), np.zeros((n, n))
        offsets = _central_offsets(self._eps)
        t = t0
        for t_end in [b for b in firing_breaks(self._firings) if t0 < b < t1] + [t1]:
            while t < t_end:
                dt = min(self.config.max_step_s, t_end - t)
                if t_end - (t + dt) < 1e-9:
                    dt = t_end - t
                batch = _perturb(y, offsets)
                out = _rk4_batch(batch, dt, *self._wrench(batch, t), self._h_w, self._m, self._i_t0,
                                 self._burned_kg(t + 0.5 * dt))
                d = _difference(out[1:], out[0])
                phi_step = ((d[:n] - d[n:]) / (2.0 * self._eps)[:, None]).T  # column i: d(error')/d(error_i)
                phi = phi_step @ phi
                q = phi_step @ q @ phi_step.T + self._process_noise(dt) + self._firing_noise(y, t, dt)
                y = out[0]
                t = t_end if dt == t_end - t else t + dt
        return y, phi, q

    def _firing_errors(self, y, t):
        """[(S_F (3, 3), X_f - c (3,), duration)] of the thruster firings active at t for the nominal y, when the
        execution errors are white input noise (module doc)."""
        cfg = self.config
        if self._error_states or (cfg.thrust_magnitude_sigma == 0.0 and cfg.thrust_misalignment_sigma_rad == 0.0):
            return []
        c = y[13] / (y[13] + self._m) * y[18:21]  # c = M/(M+m) X_s
        return [(self._force_error_covariance(np.asarray(f.force_body_n, dtype=float)),
                 np.asarray(f.position_body_m, dtype=float) - c, f.duration_s) for f in self._active(t)]

    def _firing_noise(self, y, t, dt):
        """Qd of the firings' force errors over a step of dt from t with the nominal y (module doc): dF held as white
        noise of psd S_F x the firing's duration on v_dot (inertial) and omega_dot, integrated into r and theta."""
        errors = self._firing_errors(y, t)
        q = np.zeros((self._n, self._n))
        if not errors:
            return q
        body = _BatchBody(y[None, :], self._m, self._i_t0, self._burned_kg(t + 0.5 * dt))
        c_inertial_from_body = quat_to_matrix_many(y[None, 6:10])[0]
        rates = np.zeros((6, 6))
        for s_f, lever, duration in errors:
            g = np.vstack((c_inertial_from_body / body.mass[0], body.inertia_inv[0] @ skew(lever)))
            rates += g @ s_f @ g.T * duration
        pos, rate = np.r_[0:3, 6:9], np.r_[3:6, 9:12]
        q[np.ix_(rate, rate)] = rates * dt
        q[np.ix_(pos, pos)] = rates * dt ** 3 / 3.0
        q[np.ix_(pos, rate)] = q[np.ix_(rate, pos)] = rates * dt ** 2 / 2.0
        return q

    def _process_noise(self, dt):
        q = np.zeros((self._n, self._n))
        for sl_pos, sl_rate, psd in ((_SL_R, _SL_V, self.config.accel_psd_m2_s3),
                                     (_SL_TH, _SL_W, self.config.angular_accel_psd_rad2_s3)):
            q[sl_pos, sl_pos] = np.eye(3) * psd * dt ** 3 / 3.0
            q[sl_pos, sl_rate] = q[sl_rate, sl_pos] = np.eye(3) * psd * dt ** 2 / 2.0
            q[sl_rate, sl_rate] = np.eye(3) * psd * dt
        q[12:N_ERR, 12:N_ERR] += np.eye(N_ERR - 12) * self.config.parameter_psd * dt
        bias = np.arange(self._sl_bias.start, self._sl_bias.stop)  # empty without the gyro bias state
        q[bias, bias] += self.config.gyro_bias_walk_rad_s_sqrt_s ** 2 * dt
        return q

    # --- measurement updates ---------------------------------------------------------------------------------

    def on_imu(self, t, gyro_rad_s, accel_mps2):
        """Fuse a gyro rate and an accelerometer specific force (body axes) stamped t; an UpdateResult.

        Over an interval with a firing the update is iterated (module doc): Gauss-Newton on the error theta at the
        last update's time t0 under its prior N(0, P0), the measurement z = h(f(x0 + theta)) + H w + v with f the
        propagation to t re-run from each iterate, so the curvature of both the response to the firing and the
        accelerometer's F/(m + M) in the parameters is seen; the last linearization gives the update."""
        z, rejected = self._finite_measurement(t, np.concatenate((np.ravel(gyro_rad_s), np.ravel(accel_mps2))), 6,
                                               'imu sample', self.imu_counts)
        if rejected is not None:
            return rejected
        stale = self._stale_measurement(t, self._t, 'imu sample', self.imu_counts)
        if stale is not None:
            return stale
        self._samples.append((float(t), 'imu', z))
        t0, y0, p0 = self._t, self._y, self._kf.P
        t_wrench = t - 0.5 * self.config.accel_interval_s
        r = self._imu_noise(y0, t_wrench)
        curved = any(f.t_start_s < t and f.t_start_s + f.duration_s > min(t0, t_wrench) for f in self._firings)
        iterations = self.config.imu_iterations if curved else 1
        sigma0 = np.sqrt(np.diag(p0))
        sigma0 = np.where(sigma0 > 0.0, sigma0, np.inf)
        theta = np.zeros(self._n)
        for iteration in range(iterations):
            y1, phi, q = self._transition(_perturb(y0, theta[None, :])[0], t0, t)
            h, jac = self._imu_and_jacobian(y1, t_wrench)
            m = -phi @ theta  # the prior's mean at t, from the nominal y1 = f(x0 + theta)
            p_pred = phi @ p0 @ phi.T + q
            residual = z - h - jac @ m
            if iteration + 1 == iterations:
                break
            # theta' = P0 Phi' H' S^-1 (z - h(f(x0 + theta)) + H Phi theta)
            theta_next = p0 @ phi.T @ jac.T @ np.linalg.solve(jac @ p_pred @ jac.T + r, residual)
            if np.max(np.abs(theta_next - theta) / sigma0) < 1e-2:  # the iterate moved by < 1 % of a sigma
                break
            theta = theta_next
        self._y, self._t = y1, float(t)
        self._kf.P = p_pred
        self._kf.x = m[:, None]
        return self._fuse(t, residual, jac, r, self.imu_counts, z - h)

    def _imu_noise(self, y, t_wrench):
        """The IMU's R (6, 6) for the nominal y: the gyro's and accelerometer's noise, plus (white-noise execution
        errors) the firings' force errors the accelerometer reads directly (module doc)."""
        r = np.diag([self.config.gyro_sigma_rad_s ** 2] * 3 + [self.config.accel_sigma_mps2 ** 2] * 3)
        errors = self._firing_errors(y, t_wrench)
        if errors:
            body = _BatchBody(y[None, :], self._m, self._i_t0, self._burned_kg(t_wrench))
            p_acc = self._p_acc - body.c[0]
            for s_f, lever, _ in errors:
                h_f = np.eye(3) / body.mass[0] - skew(p_acc) @ body.inertia_inv[0] @ skew(lever)
                r[3:, 3:] += h_f @ s_f @ h_f.T
        return r

    def _imu_and_jacobian(self, y, t_wrench):
        """The IMU predicted at the nominal y (24 + 3 n,) with the wrench at t_wrench, and its Jacobian in the error
        state there."""
        n = self._n
        batch = _perturb(y, _central_offsets(self._eps))
        h = _imu_batch(batch, *self._wrench(batch, t_wrench), self._h_w, self._m, self._i_t0,
                       self._burned_kg(t_wrench), self._p_acc, self.config.accel_interval_s)
        if self._sl_bias.stop > self._sl_bias.start:  # the gyro's bias state
            h[:, :3] += batch[:, N_NOM + self._sl_bias.start - N_ERR:N_NOM + self._sl_bias.stop - N_ERR]
        return h[0], ((h[1:n + 1] - h[n + 1:]) / (2.0 * self._eps)[:, None]).T

    def update(self, t, z):
        """Fuse a star-tracker attitude q_inertial_from_body (x, y, z, w) stamped t; an UpdateResult."""
        q, rejected = self._unit_quaternion_measurement(t, z, 1e-3, 'attitude')
        if rejected is not None:
            return rejected
        stale = self._stale_measurement(t, self._t, 'attitude')
        if stale is not None:
            return stale
        self._samples.append((float(t), 'attitude', q))
        self.propagate_to(t)
        innovation, jac, r = self._linearized('attitude', self._y, t, q)
        return self._fuse(t, innovation, jac, r, self.counts, innovation)

    def on_position(self, t, r_m):
        """Fuse a position of the combined CoM (inertial) stamped t; an UpdateResult."""
        z, rejected = self._finite_measurement(t, r_m, 3, 'position', self.position_counts)
        if rejected is not None:
            return rejected
        stale = self._stale_measurement(t, self._t, 'position', self.position_counts)
        if stale is not None:
            return stale
        self._samples.append((float(t), 'position', z))
        self.propagate_to(t)
        innovation, jac, r = self._linearized('position', self._y, t, z)
        return self._fuse(t, innovation, jac, r, self.position_counts, innovation)

    def _linearized(self, kind, y, t, z):
        """(z - h(y), H, R) of a measurement of kind 'imu', 'attitude' or 'position' stamped t at the nominal y."""
        if kind == 'imu':
            t_wrench = t - 0.5 * self.config.accel_interval_s
            h, jac = self._imu_and_jacobian(y, t_wrench)
            return z - h, jac, self._imu_noise(y, t_wrench)
        jac = np.zeros((3, self._n))
        if kind == 'attitude':
            jac[:, _SL_TH] = np.eye(3)
            return attitude_innovation(y[6:10], z), jac, np.eye(3) * self.config.attitude_sigma_rad ** 2
        jac[:, _SL_R] = np.eye(3)
        return z - y[0:3], jac, np.eye(3) * self.config.position_sigma_m ** 2

    def _fuse(self, t, innovation, jac, r, counts, z):
        """Gate on the innovation's NIS, then filterpy's update of the error (prior mean kf.x, measurement z from
        the nominal, so that z - H x is the innovation) and the fold; a rejected sample folds the prior mean."""
        kf = self._kf
        s = jac @ kf.P @ jac.T + r
        nis = float(innovation @ np.linalg.solve(s, innovation))
        gate = self._gate_by_size[innovation.size]
        if self._gated(nis, innovation.size, self._consecutive_rejects):
            self._consecutive_rejects += 1
            self._fold(kf.x[:, 0])
            return self._outcome('outlier', t, nis, f'normalized innovation squared {nis:.4g} above the gate '
                                                     f'{gate:.4g}', innovation, counts)
        self._consecutive_rejects = 0
        kf.update(z[:, None], HJacobian=lambda _x: jac, Hx=lambda x: jac @ x, R=r)  # Joseph form
        self._fold(kf.x[:, 0])
        return self._outcome('accepted', t, nis, '', innovation, counts)

    def _gated(self, nis, size, consecutive_rejects):
        """Whether a measurement of size with this NIS is rejected: above the gate, unless it would make
        max_consecutive_outliers in a row."""
        return nis > self._gate_by_size[size] and consecutive_rejects + 1 < self.config.max_consecutive_outliers

    def _fold(self, dx):
        """The update's error folded into the nominal, both quaternions with Markley's reset, P <- G P G'."""
        self._y, self._kf.P = _folded(self._y, self._kf.P, dx)
        self._kf.x = np.zeros((self._n, 1))

    # --- re-linearization over the whole run -------------------------------------------------------------------

    def relinearize(self, max_iterations=6, tolerance=0.01):
        """Gauss-Newton on the whole run (module doc): each iteration carries the current estimate back to the
        prior's time (the model without noise), re-runs the Kalman filter on every sample linearized along that one
        trajectory (``_batch_pass``), and takes its end as the estimate; until an iteration moves no error component
        by tolerance of its sigma, at most max_iterations (>= 1). Returns the iterations taken."""
        if max_iterations < 1:
            raise ValueError(f'max_iterations must be >= 1, got {max_iterations!r}')
        y, iterations = self._y, 0
        while iterations < max_iterations:
            y_next, p = self._batch_pass(y)
            step = _difference(y_next[None, :], y)[0] / np.sqrt(np.diag(p))
            y, iterations = y_next, iterations + 1
            if np.max(np.abs(step)) < tolerance:
                break
        self._y, self._kf.P = y, p
        return iterations

    def _batch_pass(self, y):
        """(the estimate, its covariance) at the filter time of the Kalman filter on every sample since the prior,
        linearized along the noise-free trajectory through y: the error state relative to it, its prior mean the
        prior's, each sample gated on its own innovation as the forward filter gates (``_gated``)."""
        t0, y_prior, p = self._start
        ref = self._propagate(y, self._t, t0)
        dx = _difference(y_prior[None, :], ref)[0]
        t, rejects = t0, 0
        for t_k, kind, z in self._samples + [(self._t, None, None)]:
            if t_k > t:
                ref, phi, q = self._transition(ref, t, t_k)
                dx, p, t = phi @ dx, phi @ p @ phi.T + q, t_k
            if kind is None:
                break
            innovation, jac, r = self._linearized(kind, ref, t_k, z)
            innovation = innovation - jac @ dx
            s = jac @ p @ jac.T + r
            if self._gated(float(innovation @ np.linalg.solve(s, innovation)), innovation.size, rejects):
                rejects += 1
                continue
            rejects = 0
            gain = p @ jac.T @ np.linalg.inv(s)
            dx = dx + gain @ innovation
            i_kh = np.eye(self._n) - gain @ jac
            p = i_kh @ p @ i_kh.T + gain @ r @ gain.T  # Joseph form
        return _folded(ref, p, dx)

    # --- outputs ---------------------------------------------------------------------------------------------

    def predict(self, t):
        """The nominal (24 + 3 n,) carried to t >= the filter time without changing the filter (r, v, q, omega, M,
        Q, X_s, j, the thrusters' errors)."""
        if t < self._t:
            raise ValueError(f'cannot predict back from {self._t} s to {t} s')
        return self._propagate(self._y, self._t, t)

    def _propagate(self, y, t_from, t_to):
        """The nominal y (24 + 3 n,) carried from t_from to t_to [s], forward or back, by the model without noise:
        RK4 steps of at most max_step_s cut at the firings' starts and ends, each under the wrench over it."""
        sign = 1.0 if t_to >= t_from else -1.0
        lo, hi = min(t_from, t_to), max(t_from, t_to)
        cuts = [b for b in firing_breaks(self._firings) if lo < b < hi]
        y, t = y[None, :].copy(), t_from
        for t_end in (cuts if sign > 0.0 else cuts[::-1]) + [t_to]:
            while sign * (t_end - t) > 0.0:
                dt = min(self.config.max_step_s, sign * (t_end - t))
                t_next = t_end if sign * (t_end - t) - dt < 1e-9 else t + sign * dt
                y = _rk4_batch(y, t_next - t, *self._wrench(y, min(t, t_next)), self._h_w, self._m, self._i_t0,
                               self._burned_kg(0.5 * (t + t_next)))
                t = t_next
        return y[0]

    def state(self):
        """The MassPropertyEstimate at the filter time."""
        y, p = self._y, self._kf.P
        sig = np.sqrt(np.diag(p))
        # Principal moments' sigma through the map's Jacobian (central differences in j).
        j = y[21:24]
        jac = np.empty((3, 3))
        for k in range(3):
            dj = np.zeros(3)
            dj[k] = 1e-6
            jac[:, k] = (moments_from_j(j + dj) - moments_from_j(j - dj)) / 2e-6
        moments_cov = jac @ p[_SL_J, _SL_J] @ jac.T
        moments = moments_from_j(j)
        return MassPropertyEstimate(
            self._t, float(y[13]), y[18:21].copy(), quat_normalize(y[14:18]), moments,
            inertia_from_principal(moments, y[14:18]), float(sig[_I_M]), sig[_SL_X].copy(), sig[_SL_PHI].copy(),
            np.sqrt(np.diag(moments_cov)), y[0:3].copy(), y[3:6].copy(), y[6:10].copy(), y[10:13].copy(), p.copy(),
            y[N_NOM:N_NOM + self._sl_bias.start - N_ERR].reshape(-1, 3).copy())


def defined_axes(principal_moments_kg_m2, rel_tol=1e-9):
    """(3,) bool: the principal axes a body's moments define, those whose moment differs from both others (by more
    than rel_tol of the largest); about two equal moments (a body symmetric about the third axis, seed 004's cylinder)
    any pair of perpendicular axes in their plane is principal."""
    m = np.asarray(principal_moments_kg_m2, dtype=float)
    gaps = np.where(np.eye(3, dtype=bool), np.inf, np.abs(m[:, None] - m[None, :]))
    return gaps.min(axis=1) > rel_tol * float(np.max(np.abs(m)))


def principal_axis_errors_rad(q_body_from_principal_est, q_body_from_principal_true):
    """Angle [rad] between each estimated and true principal axis (3,), the axes' signs ignored (an axis is a
    line). Where two true moments are equal only the third axis is defined: the caller picks which to read."""
    c_est = quat_to_matrix_many(np.asarray(q_body_from_principal_est, dtype=float)[None, :])[0]
    c_true = quat_to_matrix_many(np.asarray(q_body_from_principal_true, dtype=float)[None, :])[0]
    cosines = np.clip(np.abs(np.einsum('ak,ak->k', c_est, c_true)), 0.0, 1.0)
    return np.arccos(cosines)


def parameter_error(estimate, mass_kg, com_body_m, q_body_from_principal, principal_moments_kg_m2):
    """The error (10,) of the ten parameters (M, dphi, X_s, j) of a MassPropertyEstimate, truth minus estimate in
    the filter's coordinates (module doc): dphi = log(Q_est^-1 Q_true) about the estimate's principal axes, j of the
    true moments less the estimate's; the true moments (in the order of the filter's principal axes) and axes
    q_body_from_principal, mass [kg] and CoM X_s [m, chaser_body]."""
    dphi = rotation_vector_from_quat(quat_multiply(quat_conjugate(estimate.q_body_from_principal),
                                                   q_body_from_principal))
    return np.concatenate(([mass_kg - estimate.target_mass_kg], dphi,
                           np.asarray(com_body_m, dtype=float) - estimate.target_com_body_m,
                           j_from_moments(principal_moments_kg_m2) - j_from_moments(estimate.principal_moments_kg_m2)))


def defined_parameters(principal_moments_kg_m2, rel_tol=1e-9):
    """Indices into the ten parameters (M, dphi, X_s, j) that the true moments define: all but a rotation dphi_k
    about a principal axis k whose two other moments are equal (within rel_tol of the largest): it only turns two
    equal axes into each other (seed 004 §3.1's cylinder: the rotation about its symmetry axis)."""
    m = np.asarray(principal_moments_kg_m2, dtype=float)
    scale = rel_tol * float(np.max(np.abs(m)))
    return [0] + [1 + k for k in range(3) if abs(m[(k + 1) % 3] - m[(k + 2) % 3]) > scale] + list(range(4, 10))


def parameter_nees(estimate, error, principal_moments_kg_m2):
    """(NEES of the error (10,) over the defined parameters with the estimate's own covariance, each parameter's
    z = error / sigma (10,)): the filter's consistency (docs/post_capture.md)."""
    p = estimate.covariance[PARAMETER_SLICE, PARAMETER_SLICE]
    keep = defined_parameters(principal_moments_kg_m2)
    e = np.asarray(error, dtype=float)
    return float(e[keep] @ np.linalg.solve(p[np.ix_(keep, keep)], e[keep])), e / np.sqrt(np.diag(p))
