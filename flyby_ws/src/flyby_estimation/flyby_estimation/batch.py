"""Batch maximum-likelihood fit of the target's attitude motion to a window of vision attitudes (no ROS).

The independent route to the target filter's answer. Where the EKF (``target_filter``) fuses one
measurement at a time through a linearized error model, this fits the full nonlinear torque-free
motion (seed 000 eq 4 with M = 0, the known inertia of seed 001 section 1) to every measurement of a
window at once: the state at the epoch t_e (the last measurement) is the 6-vector
p = [dtheta_body, domega_body] about a reference (q_ref * exp(dtheta), omega_ref + domega); each
measurement time is reached by integrating backward from t_e with DOP853 (rtol 1e-10), and
scipy.optimize.least_squares minimizes the sum of the whitened residuals

    r_k = log(q_model(t_k)^-1 * q_meas_k) / sigma        (body-frame rotation vector, 3 per sample)

which is the negative log-likelihood of the plant's sensor model (a Gaussian body-frame rotation
error of sigma per axis, ``flyby_sim.sensors``). Jacobians are taken by finite differences of the
nonlinear model, not from the EKF's transition matrix, so the two routes share nothing but the
Euler equation itself. The perturbed motions are integrated in one DOP853 call with the nominal one
(seven or thirteen copies of the state side by side), so they share its steps: the differences are
then smooth in the perturbation, free of the step-size changes of separate integrations ("internal
numerical differentiation", Bock 1981), and the tolerance can stay at 1e-10 (a model error of
~1e-9 rad, 1e-7 of a 1 deg sigma). A window of 700 samples of a 15 deg/s tumbler costs 0.17 s, 2000
samples 0.4 s: an eighth of separate integrations at rtol 1e-12 under scipy's own forward differences,
with the same fit to 4e-5 sigma and the same bound to 4e-8 (docs/estimation.md).

At the optimum, (J' J)^-1 of the whitened Jacobian is the Cramer-Rao bound of the epoch state: the
smallest covariance any unbiased estimator can reach from these measurements (Bar-Shalom, Li,
Kirubarajan 2001, section 2.7.2). An efficient filter matches both the fitted state (to a small
fraction of sigma) and the bound.

Conventions are those of ``target_motion``: quaternions (x, y, z, w), q_eci_from_body, omega_body
the inertial angular velocity in body axes, error state with q_true = q_ref * exp(dtheta).
"""

import dataclasses

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

from flyby_sim.dynamics.attitude import euler_rate, quaternion_rate, validated_inertia
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.orbital import q_eci_from_body
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    rotation_vector_from_quat,
)

# Below this rotation angle [rad] the log map takes its series (flyby_sim.dynamics.rotation's threshold).
_SMALL_ANGLE_RAD = 1e-6


@dataclasses.dataclass(frozen=True)
class BatchFit:
    """The fitted attitude motion at the epoch t (the last measurement of the window).

    Attributes:
        t: epoch [s].
        q_eci_from_body: fitted attitude (x, y, z, w).
        omega_body: fitted inertial angular velocity in body axes [rad/s].
        covariance: 6x6 Cramer-Rao bound (J' J)^-1 of [dtheta_body, domega_body] at t [rad^2, rad^2/s, rad^2/s^2].
        chi2: sum of squared whitened residuals at the optimum (about 3 N - 6 for N samples).
        samples: number of attitude measurements N.
        evaluations: model evaluations the optimizer used (finite-difference Jacobians not counted).
    """

    t: float
    q_eci_from_body: np.ndarray
    omega_body: np.ndarray
    covariance: np.ndarray
    chi2: float
    samples: int
    evaluations: int


def fit_attitude_motion(times_s, q_hill_from_body_meas, n, inertia, attitude_sigma_rad,
                        q_eci_from_body_guess, omega_body_guess):
    """BatchFit of the torque-free motion (seed 000 eq 4) to vision attitudes, by least squares (module doc).

    Args:
        times_s: (N,) strictly increasing measurement times [s], N >= 3; the epoch is times_s[-1].
        q_hill_from_body_meas: (N, 4) measured attitudes (x, y, z, w), as on /sensors/target/attitude.
        n: mean motion of the hill frame [rad/s] (flyby_sim.dynamics.orbital.quat_eci_from_hill).
        inertia: 3x3 target inertia [kg m^2], body axes (known).
        attitude_sigma_rad: vision noise, 1 sigma per body axis [rad].
        q_eci_from_body_guess, omega_body_guess: starting point at the epoch. Any start from which
            the spin phase is not ambiguous over the window converges (e.g. the EKF's estimate).

    Raises ValueError naming the argument for a malformed window, RuntimeError if the fit fails.
    """
    t = np.asarray(times_s, dtype=float)
    z = np.asarray(q_hill_from_body_meas, dtype=float)
    if t.ndim != 1 or t.size < 3 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0.0):
        raise ValueError(f'times_s must be at least 3 finite, strictly increasing times [s], got shape {t.shape}')
    if z.shape != (t.size, 4) or not np.all(np.isfinite(z)):
        raise ValueError(f'q_hill_from_body_meas must be {t.size} finite quaternions, got shape {z.shape}')
    require_positive('attitude_sigma_rad', attitude_sigma_rad)
    i = validated_inertia(inertia)
    inertia_t = tuple(map(tuple, i.tolist()))
    inertia_inv_t = tuple(map(tuple, np.linalg.inv(i).tolist()))
    q_meas_eci = np.array([q_eci_from_body(tk, n, zk / np.linalg.norm(zk)) for tk, zk in zip(t, z, strict=True)]).T
    guess = (np.asarray(q_eci_from_body_guess, dtype=float), np.asarray(omega_body_guess, dtype=float))
    t_epoch = float(t[-1])
    backward = t[::-1]

    def rhs(_, y):
        # one motion per column of y.reshape(7, m), each on Python floats (cheaper than numpy on m-vectors)
        return np.array([quaternion_rate(s[:4], s[4:]).tolist() + euler_rate(s[4:], inertia_t, inertia_inv_t).tolist()
                         for s in y.reshape(7, -1).T.tolist()]).T.ravel()  # eq 4, M = 0

    def epoch_state(reference, p):
        q_ref, omega_ref = reference
        return quat_multiply(q_ref, quat_from_rotation_vector(p[:3])), omega_ref + p[3:]

    def residuals_many(ps, reference):
        """(m, 3 N) whitened residuals of the motions from the m epoch states about reference, ps (m, 6)."""
        states = np.array([np.concatenate(epoch_state(reference, p)) for p in ps]).T  # (7, m)
        sol = solve_ivp(rhs, (t_epoch, float(t[0])), states.ravel(), method='DOP853', t_eval=backward,
                        rtol=1e-10, atol=1e-12)
        if not sol.success:
            raise RuntimeError(f'attitude integration failed over the window: {sol.message}')
        q_model = sol.y.reshape(7, len(ps), t.size)[:4, :, ::-1]  # (4, m, N) in time order
        r = _rotation_vectors(quat_multiply(quat_conjugate(q_model), q_meas_eci[:, None, :]))  # (3, m, N)
        return np.moveaxis(r, 0, -1).reshape(len(ps), -1) / attitude_sigma_rad

    def residuals(p, reference):
        return residuals_many(p[None, :], reference)[0]

    # Scales: about a measurement sigma in attitude, and that over the window length in rate.
    span = max(t_epoch - float(t[0]), 1e-3)
    scale = np.array([attitude_sigma_rad] * 3 + [attitude_sigma_rad / span] * 3)
    steps = np.diag(1e-4 * scale)

    def forward_jacobian(p, reference):
        r = residuals_many(np.vstack((p, p + steps)), reference)
        return ((r[1:] - r[0]) / np.diag(steps)[:, None]).T

    result = least_squares(residuals, np.zeros(6), jac=forward_jacobian, x_scale=scale, xtol=1e-12, ftol=1e-12,
                           gtol=1e-12, args=(guess,))
    if not result.success:
        raise RuntimeError(f'batch attitude fit did not converge: {result.message}')
    q, w = epoch_state(guess, result.x)
    # The bound from a central-difference Jacobian about the fitted state itself, so that it is the
    # covariance of [dtheta_body, domega_body] about the estimate (the optimizer's Jacobian is a
    # one-sided difference about the guess).
    r = residuals_many(np.vstack((steps, -steps)), (q, w))
    jac = ((r[:6] - r[6:]) / (2.0 * np.diag(steps))[:, None]).T
    covariance = np.linalg.inv(jac.T @ jac)  # inverse Fisher information of the whitened problem
    return BatchFit(t=t_epoch, q_eci_from_body=np.asarray(q), omega_body=np.asarray(w),
                    covariance=0.5 * (covariance + covariance.T), chi2=float(2.0 * result.cost),
                    samples=int(t.size), evaluations=int(result.nfev))


def _rotation_vectors(q):
    """rotation_vector_from_quat of quaternions stacked along axis 0: (4, ...) -> (3, ...) [rad], angle in [0, pi]."""
    q = q / np.sqrt(np.einsum('i...,i...->...', q, q))
    q = np.where(q[3] < 0.0, -q, q)  # q and -q are the same rotation; take the short way round
    sin_half = np.sqrt(np.einsum('i...,i...->...', q[:3], q[:3]))
    angle = 2.0 * np.arctan2(sin_half, q[3])
    small = angle < _SMALL_ANGLE_RAD
    k = np.where(small, 2.0 / np.where(small, q[3], 1.0), angle / np.where(small, 1.0, sin_half))
    return k * q[:3]


def error_between(q_eci_from_body_a, omega_body_a, q_eci_from_body_b, omega_body_b):
    """[dtheta_body, domega_body] of b relative to a: q_b = q_a * exp(dtheta), omega_b = omega_a + domega."""
    dtheta = rotation_vector_from_quat(quat_multiply(quat_conjugate(q_eci_from_body_a), q_eci_from_body_b))
    return np.concatenate((dtheta, np.asarray(omega_body_b, dtype=float) - np.asarray(omega_body_a, dtype=float)))


@dataclasses.dataclass(frozen=True)
class FilterCheck:
    """A filter estimate against the batch fit of the same measurements (check_filter).

    Attributes:
        gap_sigma: largest component of the filter-minus-fit state, in units of the fit's sigma.
        ratio_min, ratio_max: extreme eigenvalues of CRB^-1/2 P CRB^-1/2 (1: P is the bound).
        chi2_per_dof: fit residual chi2 / (3 N - 6); about 1 when the sensor noise is as configured.
        fit: the BatchFit.
    """

    gap_sigma: float
    ratio_min: float
    ratio_max: float
    chi2_per_dof: float
    fit: BatchFit

    # An efficient filter sits at ~0.02 sigma and ratios 0.96-1.05 (docs/estimation.md); these
    # limits flag a filter that has lost the optimum (divergence, a bad linearization), not noise.
    GAP_LIMIT_SIGMA = 1.0
    RATIO_LIMITS = (0.5, 2.0)

    @property
    def consistent(self):
        """True if the filter state is within GAP_LIMIT_SIGMA of the fit and P within RATIO_LIMITS of the bound."""
        lo, hi = self.RATIO_LIMITS
        return self.gap_sigma < self.GAP_LIMIT_SIGMA and lo < self.ratio_min and self.ratio_max < hi


def check_filter(q_eci_from_body, omega_body, covariance, fit):
    """FilterCheck of a filter state (attitude, omega_body [rad/s], 6x6 covariance) at fit.t."""
    sigma = np.sqrt(np.diag(fit.covariance))
    gap = error_between(q_eci_from_body, omega_body, fit.q_eci_from_body, fit.omega_body)
    root_inv = np.linalg.inv(np.linalg.cholesky(fit.covariance))
    ratios = np.linalg.eigvalsh(root_inv @ np.asarray(covariance) @ root_inv.T)
    return FilterCheck(gap_sigma=float(np.abs(gap / sigma).max()), ratio_min=float(ratios[0]),
                       ratio_max=float(ratios[-1]), chi2_per_dof=fit.chi2 / (3 * fit.samples - 6), fit=fit)

