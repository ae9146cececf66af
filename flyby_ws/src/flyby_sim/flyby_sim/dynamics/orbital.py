"""Relative orbital motion of the chaser about a target on a circular orbit (seed 000 section 3).

Frames. ``hill`` is the Hill frame of seed 000 Fig. 3: origin at the target's centre of mass, x
along-track (V-bar), y orbit anti-normal, z toward Earth's centre (R-bar); it rotates relative to
inertial space with angular velocity Omega = [0, -n, 0] in its own axes (seed 000 eq 11), n the mean
motion. Earth's centre is at [0, 0, R] in hill. ``v_hill`` is always the velocity relative to the
rotating frame (d/dt of r_hill), in hill axes.

ECI convention: the target orbit lies in the ECI x-y plane, the target is at R [1, 0, 0] at t = 0
and moves toward +y (orbit normal +z). Hence at t = 0 hill x = ECI +y, hill y = ECI -z and hill
z = ECI -x; afterwards the hill axes turn by n t about ECI +z.

Quaternions are (x, y, z, w), scalar last.

SI units throughout: m, s, rad, m/s^2.
"""

import math

import numpy as np

from flyby_sim.dynamics.constants import MU_EARTH_M3_S2
from flyby_sim.dynamics.rotation import quat_conjugate, quat_from_matrix, quat_multiply


def mean_motion_rad_s(radius_m, mu=MU_EARTH_M3_S2):
    """Mean motion n = sqrt(mu / R^3) [rad/s] of a circular orbit of radius radius_m [m]."""
    if not (math.isfinite(radius_m) and radius_m > 0.0):
        raise ValueError(f'radius_m must be finite and positive, got {radius_m}')
    if not (math.isfinite(mu) and mu > 0.0):
        raise ValueError(f'mu must be finite and positive, got {mu}')
    return math.sqrt(mu / radius_m**3)


def nonlinear_relative_accel(r_hill, v_hill, n, radius_m, accel_ext_hill=(0.0, 0.0, 0.0)):
    """Relative acceleration d2(r_hill)/dt2 [m/s^2] under exact two-body gravity.

    Seed 000 eq 1 with a circular target orbit (Euler term zero), which is seed 001 eq 2 written
    in the rotating frame: p'' = -2 Omega x p' - Omega x (Omega x p) + g(r_t + p) - g(r_t) + A.
    (Seed 000 eq 1 prints term (B) as Omega x p'; the Euler acceleration is dOmega/dt x p, zero here.
    Seed 001 eq 2 holds with r2 the chaser and r1 the target, the reverse of its text's labels.)

    n must be the mean motion of radius_m (the gravity term uses mu = n^2 R^3). With
    q = (p.p - 2 R z) / R^2 and f = (1 + q)^(-3/2) - 1 (from log1p/expm1), the differential gravity
    plus centrifugal term is n^2 [-f x, -(1 + f) y, f (R - z)], free of cancellation for |p| << R.

    Args:
        r_hill: chaser position [m], hill axes: shape (3,), or (3, N) for N states at once.
        v_hill: chaser velocity relative to the rotating frame [m/s], hill axes, shaped as r_hill.
        n: mean motion [rad/s].
        radius_m: target orbit radius [m].
        accel_ext_hill: external (thrust) acceleration [m/s^2], hill axes.

    Returns:
        the acceleration, shaped as r_hill.
    """
    return np.array(nonlinear_relative_accel_components(r_hill, v_hill, n, radius_m, accel_ext_hill))


def nonlinear_relative_accel_components(r_hill, v_hill, n, radius_m, accel_ext_hill=(0.0, 0.0, 0.0)):
    """``nonlinear_relative_accel`` as a tuple of its 3 components: Python floats for one state given as
    floats (the same arithmetic, hence the same bits, for RK4 on floats: ``rk4_step_floats``), arrays
    for N states."""
    x, y, z = r_hill
    vx, vy, vz = v_hill
    ax, ay, az = accel_ext_hill
    q = ((x * x + y * y + z * z) / radius_m - 2.0 * z) / radius_m  # |r_chaser|^2 / R^2 - 1
    # np.all costs more than the rest for one state (the plant's RK4 asks 4 times a step)
    if not (q > -1.0 if isinstance(q, float) else np.all(q > -1.0)):
        raise ValueError(f'r_hill {np.asarray(r_hill).tolist()} is at or beyond Earth centre (radius_m {radius_m})')
    f = np.expm1(-1.5 * np.log1p(q))  # (R / |r_chaser|)^3 - 1
    if isinstance(q, float):
        f = float(f)  # the same value; Python float arithmetic costs a third of numpy scalars'
    n2 = n * n
    return (
        2.0 * n * vz - n2 * f * x + ax,
        -n2 * (1.0 + f) * y + ay,
        -2.0 * n * vx + n2 * f * (radius_m - z) + az,
    )


def relative_accel_components(dynamics, n, radius_m):
    """The relative acceleration (r_hill, v_hill, accel_ext_hill) -> its 3 components of ``dynamics``: 'nonlinear'
    (seed 000 eq 1, ``nonlinear_relative_accel_components``) or 'cw' (eq 2a-2c, ``cw_accel_components``)."""
    if dynamics == 'nonlinear':
        return lambda r, v, a: nonlinear_relative_accel_components(r, v, n, radius_m, a)
    return lambda r, v, a: cw_accel_components(r, v, n, a)


def cw_accel(r_hill, v_hill, n, accel_ext_hill=(0.0, 0.0, 0.0)):
    """Linearized (Hill / Clohessy-Wiltshire) relative acceleration [m/s^2], seed 000 eq 2a-2c."""
    return np.array(cw_accel_components(r_hill, v_hill, n, accel_ext_hill))


def cw_accel_components(r_hill, v_hill, n, accel_ext_hill=(0.0, 0.0, 0.0)):
    """``cw_accel`` as a tuple of its 3 components (Python floats for float input: the same bits)."""
    x, y, z = r_hill
    vx, vy, vz = v_hill
    ax, ay, az = accel_ext_hill
    n2 = n * n
    return (
        2.0 * n * vz + ax,  # eq 2a
        -n2 * y + ay,  # eq 2b
        -2.0 * n * vx + 3.0 * n2 * z + az,  # eq 2c
    )


def cw_transition_matrix(n, t):
    """6x6 state transition matrix [[Phi11, Phi12], [Phi21, Phi22]] of eq 2, seed 000 eq 22.

    Maps [r_hill; v_hill] at time t0 to time t0 + t with no external acceleration. The signs are as
    printed in the paper (checked against numerical integration of eq 2 in
    test_orbital.py::test_seed000_eq22_matches_integration_of_eq2). Being the flow of a
    time-invariant linear system, Phi(t)^-1 = Phi(-t), which is seed 000 eq 23 (the paper's
    "anti-unitarity" is this identity; Phi is not unitary).

    Args:
        n: mean motion Omega_f [rad/s].
        t: elapsed time [s], may be negative; a scalar gives (6, 6), an array (M,) gives (M, 6, 6).
    """
    if np.ndim(t) == 0:  # the common scalar case, without the array bookkeeping
        nt = n * float(t)
        s, c = math.sin(nt), math.cos(nt)
        zero, one = 0.0, 1.0
    else:
        nt = n * np.asarray(t, dtype=float)
        s, c = np.sin(nt), np.cos(nt)
        zero, one = np.zeros_like(nt), np.ones_like(nt)
    rows = (
        # Phi11 | Phi12
        (one, zero, 6.0 * (nt - s), (4.0 * s - 3.0 * nt) / n, zero, 2.0 * (1.0 - c) / n),
        (zero, c, zero, zero, s / n, zero),
        (zero, zero, 4.0 - 3.0 * c, -2.0 * (1.0 - c) / n, zero, s / n),
        # Phi21 | Phi22
        (zero, zero, 6.0 * n * (1.0 - c), 4.0 * c - 3.0, zero, 2.0 * s),
        (zero, -n * s, zero, zero, c, zero),
        (zero, zero, 3.0 * n * s, -2.0 * s, zero, c),
    )
    phi = np.array(rows)  # (6, 6) or (6, 6, M)
    return phi if phi.ndim == 2 else np.moveaxis(phi, -1, 0)


def cw_coast(r_hill, v_hill, dt_s, n):
    """State [r_hill; v_hill] (6,) after coasting dt_s [s] (may be negative) along CW, seed 000 eq 22."""
    return cw_transition_matrix(n, dt_s) @ np.concatenate((r_hill, v_hill))


def hill_axes_in_eci(t, n):
    """C_eci_from_hill at time t [s]: its columns are the hill x, y, z axes in ECI (module doc)."""
    s = math.sin(n * t)
    c = math.cos(n * t)
    return np.array((
        (-s, 0.0, -c),
        (c, 0.0, -s),
        (0.0, -1.0, 0.0),
    ))


def eci_vector_in_hill(v_eci, t, n):
    """ECI vectors expressed in hill axes at the times t [s]: C_hill_from_eci(t) v = hill_axes_in_eci(t, n).T v.

    v_eci is one vector (3,) (then an inertially fixed direction, e.g. the sun or a torque-free
    target's angular momentum, seen at every t: it turns in hill by n t about +y, opposite to the
    frame's rotation Omega^H = [0, -n, 0]) or one vector per time (N, 3); t is a scalar or (N,).
    Returns shape (3,) or (N, 3).
    """
    vx, vy, vz = np.moveaxis(np.asarray(v_eci, dtype=float), -1, 0)
    s = np.sin(n * np.asarray(t, dtype=float))
    c = np.cos(n * np.asarray(t, dtype=float))
    return np.stack(np.broadcast_arrays(-s * vx + c * vy, -vz, -c * vx - s * vy), axis=-1)


# q_eci_from_hill at t = 0: hill x = ECI +y, hill y = ECI -z, hill z = ECI -x.
_Q_ECI_FROM_HILL0 = quat_from_matrix(hill_axes_in_eci(0.0, 1.0))


def quat_eci_from_hill(t, n):
    """q_eci_from_hill at time t [s]: the t = 0 attitude turned by n t about ECI +z."""
    half = 0.5 * n * t
    return quat_multiply((0.0, 0.0, math.sin(half), math.cos(half)), _Q_ECI_FROM_HILL0)


def q_hill_from_body(t, n, q_eci_from_body):
    """A body's attitude in hill at time t [s] from its attitude in ECI: q_hill_from_eci(t) * q_eci_from_body."""
    return quat_multiply(quat_conjugate(quat_eci_from_hill(t, n)), q_eci_from_body)


def q_hill_from_body_many(t_s, n, q_eci_from_body_):
    """q_hill_from_body at each of the times t_s (N,) [s] for the attitudes q_eci_from_body_ (N, 4); (N, 4).

    Equal to the bit to q_hill_from_body at each time: the same math.sin / math.cos per time and the
    same products and sums, element-wise on the columns.
    """
    half = [0.5 * n * t for t in np.asarray(t_s, dtype=float).tolist()]
    q_eci_from_hill = quat_multiply((0.0, 0.0, np.array([math.sin(a) for a in half]),
                                     np.array([math.cos(a) for a in half])), _Q_ECI_FROM_HILL0)
    q = quat_multiply(quat_conjugate(q_eci_from_hill), np.asarray(q_eci_from_body_, dtype=float).T)
    return np.ascontiguousarray(q.T)


def q_eci_from_body(t, n, q_hill_from_body_):
    """Inverse of q_hill_from_body: q_eci_from_hill(t) * q_hill_from_body."""
    return quat_multiply(quat_eci_from_hill(t, n), q_hill_from_body_)


def target_eci_state(t, radius_m, n):
    """Target position [m] and velocity [m/s] in ECI on its circular orbit at time t [s]."""
    s = math.sin(n * t)
    c = math.cos(n * t)
    return (np.array((radius_m * c, radius_m * s, 0.0)),
            np.array((-radius_m * n * s, radius_m * n * c, 0.0)))


def _hill_frame_of_target(r_t_eci, v_t_eci):
    """C_eci_from_hill and the orbital angular velocity Omega^I [rad/s] (seed 000 eq 7) in ECI."""
    r_t = np.asarray(r_t_eci, dtype=float)
    v_t = np.asarray(v_t_eci, dtype=float)
    h = np.cross(r_t, v_t)
    r2 = float(r_t @ r_t)
    h_norm = math.sqrt(float(h @ h))
    if not (math.isfinite(h_norm) and h_norm > 0.0):
        raise ValueError(f'target state r_t_eci {r_t}, v_t_eci {v_t} does not define an orbit plane')
    z_axis = -r_t / math.sqrt(r2)  # toward Earth's centre
    y_axis = -h / h_norm  # orbit anti-normal
    x_axis = np.cross(y_axis, z_axis)
    return np.column_stack((x_axis, y_axis, z_axis)), h / r2


def relative_from_eci(r_c_eci, v_c_eci, r_t_eci, v_t_eci):
    """(r_hill, v_hill) of the chaser from both inertial states; v_hill is relative to the rotating frame.

    The hill axes are built from the target state (z = -r_t/|r_t|, y = -h/|h|), so this holds for any
    target orbit; Omega^I = r_t x v_t / |r_t|^2 (seed 000 eq 7).
    """
    c_eci_from_hill, omega_eci = _hill_frame_of_target(r_t_eci, v_t_eci)
    p_eci = np.asarray(r_c_eci, dtype=float) - np.asarray(r_t_eci, dtype=float)
    v_rel_eci = np.asarray(v_c_eci, dtype=float) - np.asarray(v_t_eci, dtype=float)
    # Transport theorem: velocity seen in the rotating frame = inertial rate - Omega x p.
    v_rel_eci = v_rel_eci - np.cross(omega_eci, p_eci)
    return c_eci_from_hill.T @ p_eci, c_eci_from_hill.T @ v_rel_eci


def eci_from_relative(r_hill, v_hill, r_t_eci, v_t_eci):
    """(r_c_eci, v_c_eci) of the chaser: the inverse of relative_from_eci."""
    c_eci_from_hill, omega_eci = _hill_frame_of_target(r_t_eci, v_t_eci)
    p_eci = c_eci_from_hill @ np.asarray(r_hill, dtype=float)
    v_rel_eci = c_eci_from_hill @ np.asarray(v_hill, dtype=float) + np.cross(omega_eci, p_eci)
    return (np.asarray(r_t_eci, dtype=float) + p_eci,
            np.asarray(v_t_eci, dtype=float) + v_rel_eci)


def rk4_step(f, t, y, h):
    """One classical fourth-order Runge-Kutta step of dy/dt = f(t, y) from t to t + h."""
    half = 0.5 * h
    k1 = f(t, y)
    k2 = f(t + half, y + half * k1)
    k3 = f(t + half, y + half * k2)
    k4 = f(t + h, y + h * k3)
    return y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


def rk4_step_floats(f, t, y, h):
    """``rk4_step`` on a state of Python floats: the same operations in the same order, component by
    component, hence the same bits, without numpy's per-call cost on a 6-vector.

    f(t, y) takes and returns a sequence of floats; returns the new state as a list.
    """
    half = 0.5 * h
    k1 = f(t, y)
    k2 = f(t + half, [a + half * b for a, b in zip(y, k1, strict=True)])
    k3 = f(t + half, [a + half * b for a, b in zip(y, k2, strict=True)])
    k4 = f(t + h, [a + h * b for a, b in zip(y, k3, strict=True)])
    sixth = h / 6.0
    return [a + sixth * (b1 + 2.0 * (b2 + b3) + b4)
            for a, b1, b2, b3, b4 in zip(y, k1, k2, k3, k4, strict=True)]
