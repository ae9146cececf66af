"""The target's torque-free attitude motion and its 6-state error dynamics (seed 000 eq 4, 6): the reference
motion's rate and RK4 on Python floats, and the transition matrix and process noise over a substep in closed form.

Pure numpy/scipy, no ROS. The target attitude filter (``target_filter``) and the prediction (``target_motion``)
use it.

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
a prediction (``target_motion.MotionPrediction``) take them in closed form over each substep, a fourth-order Magnus
expansion, to the accuracy of RK4 of the 72 extra states (``augmented_rate``) at a fraction of its cost.
"""

import math

import numpy as np

from flyby_estimation.quaternion_floats import float_list
from flyby_sim.dynamics.attitude import euler_rate, quaternion_rate, validated_inertia
from flyby_sim.dynamics.rotation import quat_normalize, skew

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
        q_floats, w = float_list(q_eci_from_body), np.asarray(omega_body, dtype=float)
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
