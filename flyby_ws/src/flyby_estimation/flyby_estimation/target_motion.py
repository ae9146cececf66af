"""Target attitude motion: error-state dynamics, prediction (seed 000 eq 4, 6-9) and categories I-IV.

Pure numpy/scipy, no ROS. The target attitude filter (``target_filter``) and the planner use it.

Conventions. Quaternions are (x, y, z, w), scalar last; ``q_a_from_b`` rotates b-frame vectors into
frame a (``flyby_sim.dynamics.rotation``). ``hill`` and ``eci`` are those of ``flyby_sim.dynamics.orbital``: hill
rotates relative to inertial space with Omega^H = [0, -n, 0] in its own axes (seed 000 eq 11).
``omega_body`` is the target's inertial angular velocity in body axes; ``omega_hill`` is the same
vector in hill axes (seed 000 eq 6) -- *not* the rate relative to the rotating hill frame, which is
``omega_hill - Omega^H``.

Error state (6): x = [dtheta_body, domega_body]. The true attitude is the reference attitude turned
by the small body-frame rotation vector dtheta, q_true = q_ref * exp(dtheta) (a right, body-frame
error, the form of Lefferts, Markley and Shuster, seed 004 ref. 3), and omega_true = omega_ref +
domega. Its linearized dynamics about the torque-free reference motion (seed 000 eq 4 / seed 001
eq 3 with M = 0 plus white torque noise w) are

    d(dtheta)/dt = -[omega x] dtheta + domega
    d(domega)/dt = I^-1 ([(I omega) x] - [omega x] I) domega + I^-1 w

The transition matrix Phi (dPhi/dt = F Phi) and the discrete process noise Qd
(dQd/dt = F Qd + Qd F' + G Qc G', Qd(0) = 0) give P(t) = Phi P(t0) Phi' + Qd, the exact covariance
of the linearized system. Both the filter's 0.1 s time update (``ErrorStateDynamics.propagate``) and
a prediction (``MotionPrediction``) take them in closed form over each substep, a fourth-order Magnus
expansion, to the accuracy of RK4 of the 72 extra states (``augmented_rate``) at a fraction of its cost.
"""

import dataclasses
import math

import numpy as np
from scipy.integrate import DOP853, OdeSolution
from scipy.integrate._ivp.rk import Dop853DenseOutput

from flyby_sim.dynamics.attitude import body_point_state, euler_rate, quaternion_rate, validated_inertia
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.orbital import eci_vector_in_hill, hill_axes_in_eci, q_eci_from_body
from flyby_sim.dynamics.rotation import (
    quat_from_matrix,
    quat_normalize,
    quat_to_matrix,
    quat_to_matrix_many,
    skew,
)

_I3 = np.eye(3)
_I6 = np.eye(6)
_ZERO6 = np.zeros((6, 6))
_PHI = slice(7, 43)  # of augmented_rate's y
_QD = slice(43, 79)


class ErrorStateDynamics:
    """Torque-free rigid body with known inertia and its 6-state error dynamics (module doc).

    Args:
        inertia: 3x3 [kg m^2], body axes (validated: symmetric positive definite).
        torque_psd: two-sided power spectral density of the white torque noise per body axis
            [N^2 m^2 s]. It models the unmodelled torques (gravity gradient, drag, outgassing)
            of seed 000 eq 4's M_T^B; 0 makes the rate a constant of the model.
    """

    def __init__(self, inertia, torque_psd=0.0):
        i = validated_inertia(inertia)
        if not (math.isfinite(torque_psd) and torque_psd >= 0.0):
            raise ValueError(f'torque_psd must be finite and >= 0 [N^2 m^2 s], got {torque_psd}')
        self.inertia = i
        self.inertia_inv = np.linalg.inv(i)
        self.torque_psd = float(torque_psd)
        self._inertia_t = tuple(map(tuple, i.tolist()))
        self._inertia_inv_t = tuple(map(tuple, self.inertia_inv.tolist()))
        self.reference_rate_floats = reference_rate_floats(self._inertia_t, self._inertia_inv_t)
        # G Qc G': torque noise enters the rate error through I^-1.
        self.noise_density = np.zeros((6, 6))
        self.noise_density[3:, 3:] = self.torque_psd * self.inertia_inv @ self.inertia_inv.T
        # F(omega) = F(0) + sum_k omega_k dF/domega_k (jacobian is affine in omega): substep_transition
        # builds F from these with one product.
        self._f_constant = self.jacobian(np.zeros(3))
        self._f_per_omega = np.array([(self.jacobian(e) - self._f_constant).ravel() for e in _I3])

    def jacobian(self, omega_body):
        """F, the 6x6 Jacobian of the error dynamics at omega_body (module doc)."""
        w = np.asarray(omega_body, dtype=float)
        w_x = skew(w)
        f = np.zeros((6, 6))
        f[:3, :3] = -w_x  # attitude-error kinematics, body-frame error
        f[:3, 3:] = _I3
        # d/domega of -I^-1 (omega x I omega), seed 000 eq 4
        f[3:, 3:] = self.inertia_inv @ (skew(self.inertia @ w) - w_x @ self.inertia)
        return f

    def jacobian_many(self, omega_body):
        """(M, 6, 6) F at the M rates omega_body (M, 3) [rad/s], from F's affine dependence on omega."""
        return (np.asarray(omega_body, dtype=float) @ self._f_per_omega).reshape(-1, 6, 6) + self._f_constant

    def state_rate(self, q_eci_from_body, omega_body):
        """(dq/dt, domega/dt) of the reference motion, seed 000 eq 4 (flyby_sim.dynamics.attitude)."""
        return (quaternion_rate(q_eci_from_body, omega_body),
                euler_rate(omega_body, self._inertia_t, self._inertia_inv_t))

    def augmented_rate(self, t, y):
        """d/dt of y = [q_eci_from_body (4), omega_body (3), Phi (36, row-major), Qd (36)]."""
        q = y[:4].tolist()
        w = y[4:7].tolist()
        q_dot, w_dot = self.state_rate(q, w)
        f = self.jacobian(w)
        phi_dot = f @ y[_PHI].reshape(6, 6)  # dPhi/dt = F Phi
        fq = f @ y[_QD].reshape(6, 6)
        qd_dot = fq + fq.T + self.noise_density  # dQd/dt = F Qd + Qd F' + G Qc G'
        return np.concatenate((q_dot, w_dot, phi_dot.ravel(), qd_dot.ravel()))

    def reference_rate(self, t, y):
        """d/dt of y = [q_eci_from_body (4), omega_body (3)], the reference motion alone (``state_rate`` to the
        bit, by ``reference_rate_floats``: DOP853 calls it some 2000 times a prediction)."""
        return np.array(self.reference_rate_floats(y.tolist()))

    def propagate(self, q_eci_from_body, omega_body, dt, max_step_angle_rad=0.02, max_step_s=0.1):
        """(q, omega, Phi, Qd) after dt [s] >= 0: the filter's time update.

        The interval is cut into equal substeps no longer than max_step_s (give or take 1e-9 s) that
        turn the body by at most max_step_angle_rad. The reference (q, omega) takes one RK4 step per
        substep (``reference_rk4_step``); its local error is ~(angle)^5 / 120, below 1e-10 rad for the
        default, far under any measurement noise. The quaternion is renormalized at the end.

        Phi and Qd of each substep come in closed form from the reference rates at its ends
        (``substep_transition``, with the Euler rates the RK4 stages evaluate anyway) instead of integrating
        the 72 extra states of ``augmented_rate`` alongside; they are chained as Phi = Phi_2 Phi_1,
        Qd = Phi_2 Qd_1 Phi_2' + Qd_2.
        """
        if not dt >= 0.0:
            raise ValueError(f'dt must be >= 0, got {dt}')
        q_floats, w = _floats(q_eci_from_body), np.asarray(omega_body, dtype=float)
        y = q_floats + w.tolist()
        if not dt > 0.0:
            return quat_normalize(y[:4]), np.array(y[4:]), _I6.copy(), _ZERO6.copy()
        rate = math.sqrt(w.dot(w))  # np.linalg.norm's arithmetic for a vector
        # Stamps 0.1 s apart differ by 0.1 s and a few ulp: that excess must not double the steps.
        steps = max(1, math.ceil(dt / max_step_s - 1e-9), math.ceil(rate * dt / max_step_angle_rad))
        h = dt / steps
        rate_of = self.reference_rate_floats
        r0 = rate_of(y)  # the substep's first RK4 stage; its last three, the Euler rates at its start (eq 4)
        if steps == 1:
            y1 = _rk4_step_floats(rate_of, y, h, r0)
            phi, qd = self._transition(y[4:], y1[4:], r0[4:], rate_of(y1)[4:], h)
            return quat_normalize(y1[:4]), np.array(y1[4:]), phi, qd
        ends, rates = [y], [r0]
        for _ in range(steps):
            ends.append(_rk4_step_floats(rate_of, ends[-1], h, rates[-1]))
            rates.append(rate_of(ends[-1]))
        phis, qds = self._transitions(ends, rates, h)
        phi, qd = phis[0], qds[0]
        for phi_k, qd_k in zip(phis[1:], qds[1:], strict=True):  # Phi = Phi_k Phi, Qd = Phi_k Qd Phi_k' + Qd_k
            phi, qd = phi_k.dot(phi), phi_k.dot(qd).dot(phi_k.T) + qd_k
        y = ends[-1]
        return quat_normalize(y[:4]), np.array(y[4:]), phi, qd

    def reference_rk4_step(self, y, h):
        """One RK4 step of ``reference_rate`` from the 7 floats y = [q_eci_from_body, omega_body] (a list),
        as a list: the same IEEE operations in the same order as rk4_step on the numpy vector, so the same
        result to the bit, without numpy's cost per call on seven numbers
        (test_float_rk4_step_is_rk4_step_to_the_bit)."""
        return _rk4_step_floats(self.reference_rate_floats, y, h, self.reference_rate_floats(y))

    def substep_transition(self, omega_body0, omega_body1, h):
        """(Phi, Qd) of the error state over a short step h [s] of the reference motion whose body
        rates at the ends are omega_body0 and omega_body1 [rad/s].

        Phi = exp(Omega) with Omega the fourth-order Magnus expansion of dPhi/dt = F(t) Phi on the two
        Gauss-Legendre nodes (Blanes, Casas, Oteo, Ros, "The Magnus expansion and some of its
        applications", Phys. Rep. 470 (2009), the fourth-order Magnus integrator),
        Omega = h/2 (F_1 + F_2) - sqrt(3)/12 h^2 [F_1, F_2]. F is affine in omega (``jacobian``) and
        omega(t) is taken as the cubic Hermite interpolant of the ends and their Euler rates (seed 000
        eq 4), so the Gauss nodes give h/2 (F_1 + F_2) = h F(omega_mean) with omega_mean =
        (omega_0 + omega_1)/2 + h (domega_0 - domega_1)/12, and [F_1, F_2] = [F_mean, F(omega_1) -
        F(omega_0)] / sqrt(3) to the same order. exp is its Taylor series to fourth order; with
        |omega| h <= max_step_angle_rad the local error stays below 1e-10 (the RK4 it replaces is
        of the same order).

        Qd = int_0^h exp(F s) G Qc G' exp(F s)' ds with the step's mean generator F = Omega / h, by
        its series sum_k h^(k+1)/(k+1)! L^k(G Qc G'), L(X) = F X + X F', to k = 3: the attitude
        block, which starts at h^3/3 Qc, then has a relative error ~(|F| h)^2.
        """
        w0, w1 = [float(a) for a in omega_body0], [float(a) for a in omega_body1]
        q, rate_of = [0.0, 0.0, 0.0, 1.0], self.reference_rate_floats  # the Euler rates do not depend on q
        return self._transition(w0, w1, rate_of(q + w0)[4:], rate_of(q + w1)[4:], h)

    def _transition(self, w0, w1, w_dot0, w_dot1, h):
        """``substep_transition`` (its doc) from the body rates w0, w1 at the substep's ends and their Euler rates
        w_dot0, w_dot1 (lists of 3 floats; the filter's RK4 stages have them). The products are ndarray.dot,
        which runs the same BLAS product as @ (the same bits, test_time_update_is_the_previous_formulation_to_the_bit)
        at half of @'s cost per call on 6x6 matrices."""
        h12 = h / 12.0
        (a0, a1, a2), (b0, b1, b2), (da0, da1, da2), (db0, db1, db2) = w0, w1, w_dot0, w_dot1
        w_mean = (0.5 * (a0 + b0) + h12 * (da0 - db0), 0.5 * (a1 + b1) + h12 * (da1 - db1),
                  0.5 * (a2 + b2) + h12 * (da2 - db2))
        f_mean, d_f = np.array((w_mean, (b0 - a0, b1 - a1, b2 - a2))).dot(self._f_per_omega).reshape(2, 6, 6)
        f_mean = f_mean + self._f_constant  # F(omega_mean); d_f = F(omega_1) - F(omega_0) has no constant part
        magnus = h * f_mean + (h * h / 12.0) * (d_f.dot(f_mean) - f_mean.dot(d_f))  # -sqrt(3)/12 h^2 [F_1, F_2]
        phi = _I6 + magnus / 4.0  # Horner: I + W (I + W/2 (I + W/3 (I + W/4)))
        for k in (3.0, 2.0):
            phi = _I6 + magnus.dot(phi) / k
        phi = _I6 + magnus.dot(phi)  # the last division is by 1
        if not self.torque_psd:
            return phi, np.zeros((6, 6))
        f = magnus / h
        x = self.noise_density
        for k in (4.0, 3.0, 2.0):  # Horner: Qd = h (Qc + h/2 L(Qc + h/3 L(Qc + h/4 L(Qc))))
            fx = f.dot(x)
            x = self.noise_density + (h / k) * (fx + fx.T)
        return phi, h * x

    def _transitions(self, ends, rates, h):
        """``_transition`` of the M substeps of length h [s] between the M + 1 reference states ``ends`` (lists of 7
        floats [q, omega]) with the rates ``rates`` (reference_rate_floats) there, all in one call: (Phi, Qd), each
        (M, 6, 6). Every element-wise operation is the one a substep alone takes, and numpy's stacked matmul runs
        the same BLAS product per matrix as ndarray.dot, so each substep's Phi and Qd are _transition's, to the bit
        (test_time_update_is_the_previous_formulation_to_the_bit), for the numpy calls of one substep."""
        h12 = h / 12.0
        rows = [([0.5 * (a + b) + h12 * (da - db) for a, b, da, db in zip(y0[4:], y1[4:], r0[4:], r1[4:], strict=True)],
                 [b - a for a, b in zip(y0[4:], y1[4:], strict=True)])
                for y0, y1, r0, r1 in zip(ends[:-1], ends[1:], rates[:-1], rates[1:], strict=True)]
        f = (np.array(rows) @ self._f_per_omega).reshape(-1, 2, 6, 6)
        f_mean = f[:, 0] + self._f_constant
        d_f = f[:, 1]
        magnus = h * f_mean + (h * h / 12.0) * (d_f @ f_mean - f_mean @ d_f)
        phi = _I6 + magnus / 4.0
        for k in (3.0, 2.0):
            phi = _I6 + (magnus @ phi) / k
        phi = _I6 + magnus @ phi
        if not self.torque_psd:
            return phi, np.zeros_like(phi)
        f = magnus / h
        x = self.noise_density
        for k in (4.0, 3.0, 2.0):
            fx = f @ x
            x = self.noise_density + (h / k) * (fx + np.swapaxes(fx, 1, 2))
        return phi, h * x

    def substep_transition_many(self, omega_body0, omega_body1, h):
        """``substep_transition`` of M substeps at once: omega_body0, omega_body1 (M, 3) [rad/s] and h (M,)
        [s] >= 0 give Phi and Qd (M, 6, 6).

        The same fourth-order Magnus exponent Omega and mean generator Omega / h, for the longer substeps
        of a prediction (|omega| h up to ~0.15 rad rather than the filter's 0.02): exp(Omega) by its
        Taylor series to sixth order and Qd's series to k = 4, so that their truncation (~(|omega| h)^7 / 7!
        and ~(|omega| h)^4 relative) stays far under the Magnus expansion's own error. h = 0 gives (I, 0).
        """
        h = np.asarray(h, dtype=float)[:, None, None]
        w0 = np.asarray(omega_body0, dtype=float)
        w1 = np.asarray(omega_body1, dtype=float)
        w_dot0 = euler_rate(w0.T, self._inertia_t, self._inertia_inv_t).T  # eq 4, element-wise on the columns
        w_dot1 = euler_rate(w1.T, self._inertia_t, self._inertia_inv_t).T
        w_mean = 0.5 * (w0 + w1) + (h[:, 0] / 12.0) * (w_dot0 - w_dot1)
        f_mean = self.jacobian_many(w_mean)
        d_f = ((w1 - w0) @ self._f_per_omega).reshape(-1, 6, 6)  # F(omega_1) - F(omega_0)
        magnus = h * f_mean + (h * h / 12.0) * (d_f @ f_mean - f_mean @ d_f)  # -sqrt(3)/12 h^2 [F_1, F_2]
        phi = _I6 + magnus / 6.0  # Horner, as substep_transition
        for k in (5.0, 4.0, 3.0, 2.0, 1.0):
            phi = _I6 + (magnus @ phi) / k
        if not self.torque_psd:
            return phi, np.zeros_like(phi)
        f = f_mean + (h / 12.0) * (d_f @ f_mean - f_mean @ d_f)  # Omega / h, defined at h = 0 too
        x = self.noise_density
        for k in (5.0, 4.0, 3.0, 2.0):
            fx = f @ x
            x = self.noise_density + (h / k) * (fx + np.swapaxes(fx, 1, 2))
        return phi, h * x


def reference_rate_floats(inertia, inertia_inv):
    """The reference motion's rate on Python floats: a function of y = [q_eci_from_body (4), omega_body (3)]
    (a sequence of 7 floats) that returns [dq/dt (4), domega/dt (3)] as a list, for the inertia and its
    inverse (3x3 nested sequences) [kg m^2, 1/(kg m^2)].

    It is ``flyby_sim.dynamics.attitude``'s quaternion_rate and euler_rate (seed 000 eq 4, torque free:
    dq/dt = 1/2 q * (omega, 0), domega/dt = I^-1 (0 - omega x I omega)) written out with the inertia's
    numbers bound once: the same operations in the same order, hence the same bits
    (test_float_reference_rate_is_attitudes_to_the_bit), without their two arrays and their unpacking of
    the inertia at every call (the filter's RK4 calls it 5 times a substep).
    """
    (i00, i01, i02), (i10, i11, i12), (i20, i21, i22) = inertia
    (j00, j01, j02), (j10, j11, j12), (j20, j21, j22) = inertia_inv

    def rate(y):
        x, y_, z, w, wx, wy, wz = y
        hx = i00 * wx + i01 * wy + i02 * wz  # h = I omega
        hy = i10 * wx + i11 * wy + i12 * wz
        hz = i20 * wx + i21 * wy + i22 * wz
        bx = 0.0 - (wy * hz - wz * hy)  # M - omega x h, M = 0
        by = 0.0 - (wz * hx - wx * hz)
        bz = 0.0 - (wx * hy - wy * hx)
        return [0.5 * (w * wx + y_ * wz - z * wy),
                0.5 * (w * wy + z * wx - x * wz),
                0.5 * (w * wz + x * wy - y_ * wx),
                -0.5 * (x * wx + y_ * wy + z * wz),
                j00 * bx + j01 * by + j02 * bz,
                j10 * bx + j11 * by + j12 * bz,
                j20 * bx + j21 * by + j22 * bz]

    return rate


def _rk4_step_floats(rate, y, h, k1):
    """``orbital.rk4_step_floats`` of the autonomous rate(y) of the 7 reference states, with k1 = rate(y) given
    (the caller has it): the same operations in the same order, so the same bits, written out for 7 states."""
    y0, y1, y2, y3, y4, y5, y6 = y
    half = 0.5 * h
    a0, a1, a2, a3, a4, a5, a6 = k1
    b0, b1, b2, b3, b4, b5, b6 = rate((y0 + half * a0, y1 + half * a1, y2 + half * a2, y3 + half * a3,
                                       y4 + half * a4, y5 + half * a5, y6 + half * a6))
    c0, c1, c2, c3, c4, c5, c6 = rate((y0 + half * b0, y1 + half * b1, y2 + half * b2, y3 + half * b3,
                                       y4 + half * b4, y5 + half * b5, y6 + half * b6))
    d0, d1, d2, d3, d4, d5, d6 = rate((y0 + h * c0, y1 + h * c1, y2 + h * c2, y3 + h * c3, y4 + h * c4,
                                       y5 + h * c5, y6 + h * c6))
    sixth = h / 6.0
    return [y0 + sixth * (a0 + 2.0 * (b0 + c0) + d0), y1 + sixth * (a1 + 2.0 * (b1 + c1) + d1),
            y2 + sixth * (a2 + 2.0 * (b2 + c2) + d2), y3 + sixth * (a3 + 2.0 * (b3 + c3) + d3),
            y4 + sixth * (a4 + 2.0 * (b4 + c4) + d4), y5 + sixth * (a5 + 2.0 * (b5 + c5) + d5),
            y6 + sixth * (a6 + 2.0 * (b6 + c6) + d6)]


def _floats(v):
    """A vector's components as a list of Python floats."""
    return v.tolist() if type(v) is np.ndarray and v.dtype == np.float64 else [float(a) for a in v]


# -- quaternions on Python floats, for the filter's measurement update and make_state ------------------------------
# flyby_sim.dynamics.rotation and orbital compute these element-wise on floats and return one numpy array each; the
# filter chains five of them per measurement, where those arrays cost more than the arithmetic. These are their
# expressions in the same order, on tuples, hence the same bits (test_quaternion_floats_are_rotations_to_the_bit).
# Quaternions (x, y, z, w) as everywhere in this module.

_Q_ECI_FROM_HILL_T0 = tuple(quat_from_matrix(hill_axes_in_eci(0.0, 1.0)).tolist())  # orbital's q_eci_from_hill at t = 0
_SMALL_ANGLE_RAD = 1e-6  # rotation's switch to the exp/log maps' Taylor series
_eci_from_hill_at = [None, None]  # (t, n) and q_eci_from_hill there: the update and the state after it share it


def quat_product_floats(q1, q2):
    """rotation.quat_multiply (the Hamilton product q1 * q2) of two float sequences, as a tuple."""
    x1, y1, z1, w1 = q1
    x2, y2, z2, w2 = q2
    return (w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2)


def q_eci_from_hill_floats(t, n):
    """orbital.quat_eci_from_hill(t, n) as a tuple: the t = 0 attitude turned by n t about ECI +z."""
    key, q = _eci_from_hill_at
    if key != (t, n):
        half = 0.5 * n * t
        q = quat_product_floats((0.0, 0.0, math.sin(half), math.cos(half)), _Q_ECI_FROM_HILL_T0)
        _eci_from_hill_at[:] = (t, n), q
    return q


def quat_normalize_floats(q):
    """rotation.quat_normalize as a tuple; ValueError for a zero or non-finite q."""
    x, y, z, w = q
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(norm) or norm == 0.0:
        raise ValueError(f'quaternion {list(q)} cannot be normalized (norm {norm})')
    return x / norm, y / norm, z / norm, w / norm


def rotation_vector_floats(q):
    """rotation.rotation_vector_from_quat (the logarithmic map, angle in [0, pi]) as a tuple [rad]."""
    x, y, z, w = quat_normalize_floats(q)
    if w < 0.0:  # q and -q are the same rotation; take the short way round
        x, y, z, w = -x, -y, -z, -w
    sin_half = math.sqrt(x * x + y * y + z * z)
    angle = 2.0 * math.atan2(sin_half, w)
    k = 2.0 / w if angle < _SMALL_ANGLE_RAD else angle / sin_half
    return k * x, k * y, k * z


def quat_exp_floats(r):
    """rotation.quat_from_rotation_vector (the exponential map) of the rotation vector r [rad], as a tuple."""
    rx, ry, rz = r
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    if not math.isfinite(angle):
        raise ValueError(f'rotation vector {list(r)} is not finite')
    k = 0.5 - angle * angle / 48.0 if angle < _SMALL_ANGLE_RAD else math.sin(0.5 * angle) / angle  # sin(a/2)/a
    return k * rx, k * ry, k * rz, math.cos(0.5 * angle)


def orbit_rate_hill(n):
    """Omega^H = [0, -n, 0] [rad/s]: the hill frame's inertial angular velocity in hill axes, seed 000 eq 11."""
    return np.array((0.0, -n, 0.0))


def covariance_in_hill(c_hill_from_body, omega_body, covariance_body):
    """The error covariance in hill axes: of [dtheta_hill, domega_hill] from [dtheta_body, domega_body].

    dtheta_hill = C dtheta_body (q_ref * exp(dtheta_b) = exp(C dtheta_b) * q_ref), and
    omega_hill = C omega_body (eq 6) varies as d(omega_hill) = C (-[omega x] dtheta_body + domega_body)
    because C_true = C (I + [dtheta x]).
    """
    c = np.asarray(c_hill_from_body, dtype=float)
    j = np.zeros((6, 6))
    j[:3, :3] = c
    j[3:, :3] = (-c).dot(skew(omega_body))
    j[3:, 3:] = c
    return j.dot(covariance_body).dot(j.T)  # ndarray.dot: @'s BLAS products at half their cost per call


def body_point_in_hill(c_hill_from_body, omega_body, x_body, n):
    """Position and velocity of a body-fixed point in hill and their Jacobian, seed 000 eq 8-9.

    Eq 8: x_g^H = C_I^H C_B^I x_g^B + C_I^H x_T^I. Our hill frame is centred on the target's centre
    of mass (DESIGN §3), so the second term (the target's own position in hill) is zero.

    Eq 9 as printed has the wrong sign on the orbital-rate term for a velocity relative to the
    rotating hill frame (the velocity the chaser must match, DESIGN §3): v_g^H = (omega^H - Omega^H) x x_g^H
    (flyby_sim.dynamics.attitude.body_point_state, which computes both;
    test_target_motion.py::test_seed000_eq9_sign_by_numerical_derivative settles the sign).

    Args:
        c_hill_from_body: rotation matrix of q_hill_from_body.
        omega_body: inertial angular velocity, body axes [rad/s].
        x_body: the point in body axes [m] (e.g. the grasp point).
        n: orbital mean motion [rad/s].

    Returns:
        (r_hill [m], v_hill [m/s] relative to the rotating hill frame, J) with J the 6x6 Jacobian of
        [r_hill; v_hill] with respect to the error state [dtheta_body; domega_body].
    """
    r_hill, v_hill = body_point_state(c_hill_from_body, omega_body, x_body, n)  # eq 8-9
    c = np.asarray(c_hill_from_body, dtype=float)
    x_b = np.asarray(x_body, dtype=float)
    wx_b = np.cross(np.asarray(omega_body, dtype=float), x_b)
    big_omega_x = skew(orbit_rate_hill(n))
    c_xb = c @ skew(x_b)
    j = np.zeros((6, 6))
    j[:3, :3] = -c_xb  # C [dtheta x] x_b = -C [x_b x] dtheta
    j[3:, :3] = -c @ skew(wx_b) + big_omega_x @ c_xb
    j[3:, 3:] = -c_xb
    return r_hill, v_hill, j


class PredictedState:
    """The target's attitude motion predicted to time t (or the filter's estimate at t).

    Attributes:
        t: sim time [s].
        q_hill_from_body, q_eci_from_body: attitude (x, y, z, w).
        omega_body: inertial angular velocity in body axes [rad/s] (odometry twist.angular).
        omega_hill: the same vector in hill axes, seed 000 eq 6 (inertial rate, not relative to hill).
        covariance: 6x6 (None for a prediction without covariance) of the error state
            [dtheta_body, domega_body] [rad^2, rad^2/s, rad^2/s^2].
        covariance_hill: 6x6 of [dtheta_hill, domega_hill] (covariance_in_hill). For a
            nav_msgs/Odometry with frame hill and child target_body: pose orientation covariance =
            covariance_hill[:3, :3] (rotation about hill axes), twist angular covariance =
            covariance[3:, 3:] (body axes, as twist is in child_frame_id).

    The covariance may be given as a function of no argument that returns it (``MotionPrediction.state``:
    most of its states are asked only for the motion, by the planner's and guidance's scans); it is then
    computed at its first use, and covariance_hill (given or not) at its own. Read-only by convention.
    """

    __slots__ = ('t', 'q_hill_from_body', 'q_eci_from_body', 'omega_body', 'omega_hill', '_covariance',
                 '_covariance_hill', '_c_hill_from_body')

    def __init__(self, t, q_hill_from_body, q_eci_from_body, omega_body, omega_hill, covariance, covariance_hill=None,
                 c_hill_from_body=None):
        self.t = t
        self.q_hill_from_body = q_hill_from_body
        self.q_eci_from_body = q_eci_from_body
        self.omega_body = omega_body
        self.omega_hill = omega_hill
        self._covariance = covariance
        self._covariance_hill = covariance_hill
        self._c_hill_from_body = c_hill_from_body

    @property
    def covariance(self):
        if callable(self._covariance):
            self._covariance = self._covariance()
        return self._covariance

    @property
    def covariance_hill(self):
        if self._covariance_hill is None and self.covariance is not None:
            c = self._c_hill_from_body
            self._covariance_hill = covariance_in_hill(quat_to_matrix(self.q_hill_from_body) if c is None else c,
                                                       self.omega_body, self._covariance)
        return self._covariance_hill

    def __repr__(self):
        return (f'PredictedState(t={self.t!r}, q_hill_from_body={self.q_hill_from_body!r}, q_eci_from_body='
                f'{self.q_eci_from_body!r}, omega_body={self.omega_body!r}, omega_hill={self.omega_hill!r}, '
                f'covariance={self.covariance!r}, covariance_hill={self.covariance_hill!r})')


@dataclasses.dataclass(frozen=True)
class BodyPointPrediction:
    """A body-fixed point in hill at time t (seed 000 eq 8-9) with its 6x6 covariance of [r_hill; v_hill]."""

    t: float
    r_hill: np.ndarray  # [m], from the target's centre of mass
    v_hill: np.ndarray  # [m/s], relative to the rotating hill frame (= d r_hill / dt)
    covariance: np.ndarray  # [m^2, m^2/s, m^2/s^2]


def make_state(t, n, q_eci_from_body_, omega_body, covariance, symmetric=False):
    """PredictedState from the inertial reference state and error covariance (or None) at t.

    The covariance is made exactly symmetric, 0.5 (P + P'), unless ``symmetric`` says it is already (that
    would give it back unchanged, to the bit); it may then also be a function that returns it, called at its
    first use (PredictedState).
    """
    if covariance is not None and not symmetric:
        covariance = 0.5 * (covariance + covariance.T)
    x, y, z, w = q_eci_from_hill_floats(t, n)
    q_hb = quat_product_floats((-x, -y, -z, w), _floats(q_eci_from_body_))  # orbital.q_hill_from_body
    c = quat_to_matrix(q_hb)
    omega = np.array(omega_body, dtype=float)
    return PredictedState(float(t), np.array(q_hb), np.array(q_eci_from_body_), omega, c @ omega, covariance, None, c)


def point_prediction(state, x_body, n):
    """BodyPointPrediction of x_body [m, body axes] from a PredictedState (seed 000 eq 8-9).

    The covariance is None when the state has none (a MotionPrediction without covariance).
    """
    c = quat_to_matrix(state.q_hill_from_body)
    r, v, j = body_point_in_hill(c, state.omega_body, x_body, n)
    cov = None if state.covariance is None else j @ state.covariance @ j.T
    return BodyPointPrediction(t=state.t, r_hill=r, v_hill=v, covariance=cov)


@dataclasses.dataclass(frozen=True)
class PointTrack:
    """A body point over many times (vectorized eq 8-9): t (N,), r_hill (N, 3) [m],
    v_hill (N, 3) [m/s] relative to hill, omega_hill (N, 3) [rad/s] (eq 6)."""

    t: np.ndarray
    r_hill: np.ndarray
    v_hill: np.ndarray
    omega_hill: np.ndarray


def dop853_reference(dynamics, t0, t_end, y0, rtol, atol):
    """solve_ivp(dynamics.reference_rate, (t0, t_end), y0, method='DOP853', rtol, atol, dense_output=True):
    (sol.sol, sol.y), the same steps and dense output to the bit (test_dop853_reference_is_solve_ivps_to_the_bit).

    solve_ivp's loop for this case (no t_eval, no events), with scipy's DOP853 stepping; the solver calls the
    reference rate directly rather than through its two wrappers (np.asarray of an array it already has and a
    count of the calls), which cost a third of the rate itself at 15 calls a step. RuntimeError if DOP853 fails.
    """
    rate = dynamics.reference_rate_floats
    solver = DOP853(dynamics.reference_rate, float(t0), y0, float(t_end), rtol=rtol, atol=atol)
    solver.fun = lambda t, y: np.array(rate(y.tolist()))  # what the wrappers return, without them
    ts, ys, segments = [float(t0)], [y0], []
    while solver.status == 'running':
        message = solver.step()
        if solver.status == 'failed':
            raise RuntimeError(f'attitude prediction to t = {t_end} s failed: {message}')
        segments.append(solver.dense_output())
        if len(ts) > 1 and ts[-1] == solver.t:  # solve_ivp keeps no empty step
            segments.pop()
        else:
            ts.append(solver.t)
            ys.append(solver.y)
    return OdeSolution(ts, segments), np.vstack(ys).T


class DenseSolution:
    """A DOP853 dense solution (scipy's OdeSolution) evaluated at many times at once.

    scipy evaluates an array of times segment by segment, a dozen numpy calls per segment the times fall in: a
    prediction's covariance asks for a few hundred times spread over a hundred segments. This takes, per time,
    the segment scipy would take (the lower one at a step, OdeSolution's rule) and runs Dop853DenseOutput's
    arithmetic on all times at once: the same operations on each element, hence the same values to the bit
    (test_dense_solution_is_scipys_to_the_bit). A single time, or a solution of another kind, is left to scipy.
    """

    def __init__(self, ode_solution):
        self._solution = ode_solution
        self._segments = None  # (t_old, h, F reversed, y_old) of every segment, gathered at the first array call
        self._own = (ode_solution.ascending and ode_solution.side == 'left'
                     and all(type(i) is Dop853DenseOutput for i in ode_solution.interpolants))

    def __call__(self, t):
        t = np.asarray(t)
        solution = self._solution
        if t.ndim != 1 or not t.size or not self._own:
            return solution(t)
        if self._segments is None:
            segments = solution.interpolants
            self._segments = (np.array([s.t_old for s in segments]), np.array([s.h for s in segments]),
                              np.array([s.F[::-1] for s in segments]), np.array([s.y_old for s in segments]))
        t_old, h, f_reversed, y_old = self._segments
        k = np.searchsorted(solution.ts_sorted, t, side='left') - 1  # OdeSolution.__call__'s choice
        np.clip(k, 0, solution.n_segments - 1, out=k)
        x = ((t - t_old[k]) / h[k])[:, None]  # Dop853DenseOutput._call_impl, on every time at once
        f = f_reversed[k]
        y = np.zeros((t.size, y_old.shape[1]))
        for i in range(f.shape[1]):
            y += f[:, i]
            if i % 2 == 0:
                y *= x
            else:
                y *= 1 - x
        y += y_old[k]
        return y.T.copy()  # (states, times), C-contiguous as scipy's


class MotionPrediction:
    """Dense prediction of the target's attitude motion over [t0, t_end] (seed 000 eq 4, 6-9).

    One DOP853 integration of the reference state; ``state(t)`` and ``body_point_in_hill(x_body, t)``
    then answer at any t in the interval from the dense output without integrating again, and
    ``track(x_body, times)`` answers for many times at once (for a planner scanning candidate grasp
    times).

    The covariance P(t) = Phi P0 Phi' + Qd is built at its first use, not with the motion: the interval
    is cut into equal substeps that turn the body by at most max_step_angle_rad (and last at most
    max_step_s); Phi and Qd of each come in closed form from the dense reference rates at its ends
    (``ErrorStateDynamics.substep_transition_many``) and are chained into P at the substep ends,
    P_k+1 = Phi_k P_k Phi_k' + Qd_k. Between two ends P is the cubic Hermite interpolant of P and
    dP/dt = F P + P F' + G Qc G' there (error h^4/384 max|d^4P/dt^4|, ~(angle)^4/24 of |P| for the
    rotating attitude block). Against DOP853 of the 79 augmented states (what this did before, 4x
    the cost of the reference alone) the attitude sigma agrees to 3e-5 relative over 600 s of the
    21 deg/s seed 001 tumbler (test_lazy_covariance_matches_dop853_of_the_augmented_state).

    Args:
        dynamics: ErrorStateDynamics.
        n: orbital mean motion [rad/s].
        t0, q_eci_from_body0, omega_body0, covariance0: the estimate at t0 (error-state covariance 6x6).
        t_end: last time of interest [s], >= t0.
        rtol, atol: DOP853 tolerances; the default keeps a 600 s prediction of the 21 deg/s seed 001
            tumbler within 1e-8 rad of flyby_sim's reference integration (rtol 1e-13), far below
            the estimation error.
        with_covariance: False makes a prediction without covariance (states then carry covariance
            None); covariance0 may then be None. The motion is the same either way.
        max_step_angle_rad, max_step_s: substep limits of the covariance (above).
    """

    def __init__(self, dynamics, n, t0, q_eci_from_body0, omega_body0, covariance0, t_end,
                 rtol=1e-9, atol=1e-12, with_covariance=True, max_step_angle_rad=0.15, max_step_s=10.0):
        if not (math.isfinite(t_end) and t_end >= t0):
            raise ValueError(f't_end = {t_end} s must be finite and >= t0 = {t0} s')
        self.t0 = float(t0)
        self.t_end = float(t_end)
        self._n = n
        self._dynamics = dynamics
        self._p0 = np.array(covariance0, dtype=float) if with_covariance else None
        self._max_step_angle_rad = max_step_angle_rad
        self._max_step_s = max_step_s
        self._nodes = None  # (substep ends, P, dP/dt there), built at the first use of the covariance
        self._blocks = {}  # block.indices(6) -> (P, dP/dt) of that block at the nodes
        y0 = np.concatenate((q_eci_from_body0, omega_body0), dtype=float)
        if t_end > t0:
            solution, y_steps = dop853_reference(dynamics, self.t0, self.t_end, y0, rtol, atol)
            self._dense = DenseSolution(solution)
            self._rate_max = float(np.linalg.norm(y_steps[4:7], axis=0).max())  # at DOP853's steps
        else:
            self._dense = lambda t: np.repeat(y0[:, None], np.size(t), axis=1) if np.ndim(t) else y0

    @classmethod
    def from_dense(cls, dynamics, n, t0, t_end, dense):
        """A prediction without covariance whose motion is ``dense``: t -> [q_eci_from_body; omega_body] (7,) or
        (7, N) for times (N,) (perturbed_predictions)."""
        self = cls.__new__(cls)
        self.t0, self.t_end, self._n, self._dynamics = float(t0), float(t_end), n, dynamics
        self._p0, self._dense = None, dense
        return self

    def state(self, t):
        """PredictedState at t [s] in [t0, t_end]; its covariance is computed at its first use."""
        if not (self.t0 <= t <= self.t_end):
            raise ValueError(f't = {t} s is outside the predicted interval [{self.t0}, {self.t_end}] s')
        y = self._dense(t)
        return make_state(t, self._n, quat_normalize(y[:4].tolist()), y[4:7],
                          None if self._p0 is None else lambda: self._symmetric_covariance(t), symmetric=True)

    def _symmetric_covariance(self, t):
        p = self._covariance(np.array((t,), dtype=float), slice(None))[0]
        return 0.5 * (p + p.T)

    @property
    def has_covariance(self):
        return self._p0 is not None

    def attitude_sigma_rad(self, times):
        """(N,) 1-sigma attitude error [rad] at the times (N,) [s]: the square root of the largest eigenvalue of
        the attitude block of P(t) = Phi P0 Phi' + Qd. Needs a prediction with covariance."""
        if self._p0 is None:
            raise ValueError('this prediction carries no covariance')
        p = self._covariance(np.atleast_1d(np.asarray(times, dtype=float)), slice(3))
        return np.sqrt(np.maximum(np.linalg.eigvalsh(0.5 * (p + np.swapaxes(p, 1, 2)))[:, -1], 0.0))

    def _covariance(self, t, block):
        """(N, b, b) block [block, block] of P at the times t (N,) in [t0, t_end] (class doc)."""
        if self.t_end == self.t0:
            return np.broadcast_to(self._p0[block, block], (t.size,) + self._p0[block, block].shape)
        if self._nodes is None:
            self._nodes = self._covariance_nodes()
        nodes = self._nodes[0]
        key = block.indices(6)
        if key not in self._blocks:  # the block of P and dP/dt at every node, contiguous: gathered per time below
            self._blocks[key] = tuple(np.ascontiguousarray(a[:, block, block]) for a in self._nodes[1:])
        p, p_dot = self._blocks[key]
        k = np.minimum(np.searchsorted(nodes, t, side='right') - 1, nodes.size - 2)
        h = (nodes[k + 1] - nodes[k])[:, None, None]
        s = (t - nodes[k])[:, None, None] / h
        s2 = s * s
        # cubic Hermite basis on [0, 1]: h00, h10, h01, h11
        h00, h10, h01, h11 = 1.0 - 3.0 * s2 + 2.0 * s2 * s, s - 2.0 * s2 + s2 * s, 3.0 * s2 - 2.0 * s2 * s, s2 * s - s2
        return h00 * p[k] + (h10 * h) * p_dot[k] + h01 * p[k + 1] + (h11 * h) * p_dot[k + 1]

    def _covariance_nodes(self):
        """(substep ends (M+1,), P there (M+1, 6, 6), dP/dt there (M+1, 6, 6)) over [t0, t_end] (class doc)."""
        dyn = self._dynamics
        span = self.t_end - self.t0
        steps = max(1, math.ceil(span * self._rate_max / self._max_step_angle_rad), math.ceil(span / self._max_step_s))
        nodes = np.linspace(self.t0, self.t_end, steps + 1)
        w = self._dense(nodes)[4:7].T
        phi, qd = dyn.substep_transition_many(w[:-1], w[1:], np.diff(nodes))
        p_k = self._p0
        chained = [p_k]
        for phi_k, qd_k in zip(phi, qd, strict=True):
            p_k = phi_k.dot(p_k).dot(phi_k.T) + qd_k  # P_k+1 = Phi_k P_k Phi_k' + Qd_k (ndarray.dot: @'s product)
            chained.append(p_k)
        p = np.array(chained)
        fp = dyn.jacobian_many(w) @ p
        return nodes, p, fp + np.swapaxes(fp, 1, 2) + dyn.noise_density  # dP/dt = F P + P F' + G Qc G'

    def body_point_in_hill(self, x_body, t):
        """BodyPointPrediction of the body point x_body [m] at t [s] (seed 000 eq 8-9)."""
        return point_prediction(self.state(t), x_body, self._n)

    def track(self, x_body, times):
        """PointTrack of the body point x_body [m] at the times (N,) [s], without covariance.

        Eq 8-9 evaluated for all times at once (flyby_sim.dynamics.attitude.body_point_state on the
        stack of C_hill_from_body).
        """
        t = np.atleast_1d(np.asarray(times, dtype=float))
        if t.size and not (self.t0 <= t.min() and t.max() <= self.t_end):
            raise ValueError(f'times [{t.min()}, {t.max()}] s leave the predicted interval [{self.t0}, {self.t_end}] s')
        y = self._dense(t)
        c_hill_from_body = self._c_hill_from_body(t, y)
        w_body = y[4:7].T
        r_hill, v_hill = body_point_state(c_hill_from_body, w_body, x_body, self._n)  # eq 8-9
        omega_hill = np.einsum('nij,nj->ni', c_hill_from_body, w_body)  # eq 6
        return PointTrack(t=t, r_hill=r_hill, v_hill=v_hill, omega_hill=omega_hill)


    def c_hill_from_body(self, times):
        """(N, 3, 3) rotation matrices hill <- body at the times (N,) [s] in the predicted interval."""
        t = np.atleast_1d(np.asarray(times, dtype=float))
        if t.size and not (self.t0 <= t.min() and t.max() <= self.t_end):
            raise ValueError(f'times [{t.min()}, {t.max()}] s leave the predicted interval [{self.t0}, {self.t_end}] s')
        return self._c_hill_from_body(t, self._dense(t))

    def _c_hill_from_body(self, t, y):
        body_axes_eci = np.swapaxes(quat_to_matrix_many(y[:4].T), 1, 2)  # row k: body axis k in ECI
        # C_hill_from_body = C_hill_from_eci(t) C_eci_from_body: the body axes seen in hill at their time.
        return np.swapaxes(eci_vector_in_hill(body_axes_eci, t[:, None], self._n), 1, 2)


def perturbed_predictions(dynamics, n, t0, q_eci_from_body0, omega_body0, errors, t_end, rtol=1e-8, atol=1e-10):
    """MotionPredictions (without covariance) of the estimate at t0 with each error state added, one per row of
    errors (K, 6) = [dtheta_body, domega_body] (q = q_ref * exp(dtheta), omega = omega_ref + domega, the filter's
    convention): the true motions an estimate's covariance allows (its sigma points), integrated as one DOP853
    system of the K torque-free states (seed 000 eq 4), which costs about one prediction."""
    errors = np.atleast_2d(np.asarray(errors, dtype=float))
    if not (math.isfinite(t_end) and t_end > t0):
        raise ValueError(f't_end = {t_end} s must be finite and > t0 = {t0} s')
    count = len(errors)
    q0 = _floats(q_eci_from_body0)
    y0 = np.array([quat_product_floats(q0, quat_exp_floats(_floats(e[:3]))) + tuple(np.asarray(omega_body0) + e[3:])
                   for e in errors]).T  # (7, K): row i holds component i of every state
    inertia, inertia_inv = dynamics.inertia, dynamics.inertia_inv

    def stacked(t, y):
        """dq/dt = 1/2 q * (omega, 0), domega/dt = -I^-1 (omega x I omega) of every state at once."""
        y = y.reshape(7, count)
        x, y_, z, w = y[:4]
        wx, wy, wz = omega = y[4:]
        h = inertia @ omega
        q_dot = 0.5 * np.array((w * wx + y_ * wz - z * wy, w * wy + z * wx - x * wz, w * wz + x * wy - y_ * wx,
                                -(x * wx + y_ * wy + z * wz)))
        omega_dot = inertia_inv @ -np.array((wy * h[2] - wz * h[1], wz * h[0] - wx * h[2], wx * h[1] - wy * h[0]))
        return np.concatenate((q_dot, omega_dot)).ravel()
    solver = DOP853(stacked, float(t0), y0.ravel(), float(t_end), rtol=rtol, atol=atol)
    ts, segments = [float(t0)], []
    while solver.status == 'running':
        message = solver.step()
        if solver.status == 'failed':
            raise RuntimeError(f'perturbed attitude predictions to t = {t_end} s failed: {message}')
        segments.append(solver.dense_output())
        ts.append(solver.t)
    out = []
    for k in range(count):  # each motion its own dense output: its components of every step's interpolant
        own = [Dop853DenseOutput(s.t_old, s.t, s.y_old[k::count], s.F[:, k::count]) for s in segments]
        out.append(MotionPrediction.from_dense(dynamics, n, t0, t_end, DenseSolution(OdeSolution(ts, own))))
    return out


def prediction_from_estimate(dynamics, n, t, q_hill_from_body_, omega_body, t_end, covariance_body=None):
    """MotionPrediction from a published estimate: attitude in hill and body rate at t, and, if given, the
    6x6 error covariance of [dtheta_body, domega_body] (covariance_from_published); without it, none."""
    return MotionPrediction(dynamics, n, t, q_eci_from_body(t, n, q_hill_from_body_), omega_body, covariance_body,
                            t_end, with_covariance=covariance_body is not None)


def covariance_from_published(q_hill_from_body_, attitude_covariance_hill, rate_covariance_body):
    """The error covariance of [dtheta_body, domega_body] from the blocks an estimate publishes
    (estimation/target/odom: pose orientation covariance about hill axes, twist angular covariance in
    body axes; covariance_in_hill's dtheta_hill = C dtheta_body inverted). The attitude-rate
    cross-covariance is not published and is taken as zero."""
    c = quat_to_matrix(q_hill_from_body_)
    p = np.zeros((6, 6))
    p[:3, :3] = c.T @ np.asarray(attitude_covariance_hill, dtype=float) @ c
    p[3:, 3:] = np.asarray(rate_covariance_body, dtype=float)
    return 0.5 * (p + p.T)


# --------------------------------------------------------------------------------------------------
# Categories of target motion, seed 000 section 2.1 / Fig. 2

@dataclasses.dataclass(frozen=True)
class MotionThresholds:
    """Thresholds of classify_motion (defaults from seed 000 section 2.1).

    Attributes:
        spin_rate_rad_s: inertial rate at and above which the target is category IV (spinning).
            Default 18 deg/s, a 20 s rotation period: the paper gives 20-3600 s as the period range
            of categories II and III, the fly-by cases.
        hill_fixed_rate_rad_s: rate relative to the hill frame below which the attitude counts as
            held in hill (categories I, II). Default 0.1 deg/s, a 3600 s period, the slow end of
            the paper's range.
        inertial_hold_rate_rad_s: inertial rate below which the target counts as held in inertial
            space (category I, e.g. sun pointing). Default 0.01 deg/s.
        controlled_rate_rad_s: rate relative to hill below which a hill-held target counts as
            three-axis controlled (I) rather than librating under gravity gradient (II).
            Default 0.01 deg/s: a 10 deg gravity-gradient libration at sqrt(3) n (LEO) moves at
            about 0.1 deg/s peak.
        controlled_excursion_rad: largest attitude excursion in hill over the observation window
            for category I (when known). Default 2 deg; gravity-gradient librations are larger.
    """

    spin_rate_rad_s: float = math.radians(18.0)
    hill_fixed_rate_rad_s: float = math.radians(0.1)
    inertial_hold_rate_rad_s: float = math.radians(0.01)
    controlled_rate_rad_s: float = math.radians(0.01)
    controlled_excursion_rad: float = math.radians(2.0)

    def __post_init__(self):
        for field in dataclasses.fields(self):
            require_positive(field.name, getattr(self, field.name))


@dataclasses.dataclass(frozen=True)
class MotionCategory:
    """Result of classify_motion: category 'I'..'IV' of seed 000 section 2.1 and a one-line reason."""

    category: str
    reason: str
    inertial_rate_rad_s: float
    hill_relative_rate_rad_s: float


CATEGORY_NAMES = {
    'I': 'three-axis controlled',
    'II': 'gravity-gradient stabilized',
    'III': 'slowly tumbling',
    'IV': 'spinning',
}


def classify_motion(omega_hill, n, attitude_excursion_rad=None, thresholds=MotionThresholds()):
    """Category I-IV of the target motion (seed 000 section 2.1, Fig. 2).

    Decision, in order:
      IV  |omega| >= spin_rate (rotation period under 20 s): synchronized approach, not fly-by.
      I   |omega| < inertial_hold_rate: attitude held in inertial space.
      III |omega - Omega^H| >= hill_fixed_rate: slowly tumbling relative to the orbit frame.
      I   held in hill with |omega - Omega^H| < controlled_rate and (if known) an attitude
          excursion < controlled_excursion: three-axis controlled (e.g. Earth pointing).
      II  otherwise held in hill, librating: gravity-gradient stabilized.

    Args:
        omega_hill: inertial angular velocity in hill axes [rad/s] (seed 000 eq 6).
        n: orbital mean motion [rad/s].
        attitude_excursion_rad: largest attitude change in hill over the observation window, or None.
        thresholds: MotionThresholds.
    """
    w = np.asarray(omega_hill, dtype=float)
    if w.shape != (3,) or not np.all(np.isfinite(w)):
        raise ValueError(f'omega_hill must be 3 finite values [rad/s], got {omega_hill!r}')
    th = thresholds
    rate = float(np.linalg.norm(w))
    rel = float(np.linalg.norm(w - orbit_rate_hill(n)))

    def result(category, why):
        return MotionCategory(category, f'{CATEGORY_NAMES[category]}: {why}', rate, rel)

    deg = math.degrees
    if rate >= th.spin_rate_rad_s:
        return result('IV', f'inertial rate {deg(rate):.3g} deg/s >= {deg(th.spin_rate_rad_s):.3g} deg/s '
                            f'(period {2 * math.pi / rate:.3g} s)')
    if rate < th.inertial_hold_rate_rad_s:
        return result('I', f'inertial rate {deg(rate):.3g} deg/s < {deg(th.inertial_hold_rate_rad_s):.3g} deg/s '
                           '(held in inertial space)')
    if rel >= th.hill_fixed_rate_rad_s:
        return result('III', f'rate relative to hill {deg(rel):.3g} deg/s >= {deg(th.hill_fixed_rate_rad_s):.3g} '
                             f'deg/s (period {2 * math.pi / rel:.3g} s)')
    excursion_ok = attitude_excursion_rad is None or attitude_excursion_rad < th.controlled_excursion_rad
    excursion = 'unknown' if attitude_excursion_rad is None else f'{deg(attitude_excursion_rad):.3g} deg'
    if rel < th.controlled_rate_rad_s and excursion_ok:
        return result('I', f'rate relative to hill {deg(rel):.3g} deg/s < {deg(th.controlled_rate_rad_s):.3g} '
                           f'deg/s, attitude excursion {excursion} (held in hill)')
    return result('II', f'rate relative to hill {deg(rel):.3g} deg/s, attitude excursion {excursion} '
                        '(librating about the hill attitude)')
