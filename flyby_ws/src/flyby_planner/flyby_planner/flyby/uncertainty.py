"""The fly-by planner's uncertainty model (package doc, step 4), seed 000 eq 4-9 and 22 linearized.

What the estimators will know at the last burn (``EstimateAccuracy``, from the scenario's sensors and estimation
sections), the target estimate's covariance predicted along the predicted motion (``TargetUncertainty``), the
chaser's state error at the estimate the last burn is computed from (``chaser_error_at_estimate``) and the
predicted 3-sigma miss at the grasp (``predicted_miss``).

Pure numpy/scipy, no ROS. Frames and units as in flyby_planner.flyby.grasp_search (hill, SI).
"""

import functools
import math

import numpy as np
from scipy.linalg import solve_discrete_are

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_msgs_py import params
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.orbital import cw_transition_matrix

# A prediction's attitude uncertainty, where it carries its covariance, counts at this many sigma.
UNCERTAINTY_SIGMAS = 3.0
# The target filter's covariance is predicted over substeps that turn the body by at most this [rad] and last at
# most this [s]: against 0.1 s / 0.01 rad substeps its sigmas agree to 2 % over 600 s (docs/planner.md, "How these
# rules were found").
_COVARIANCE_STEP_RAD = 0.3
_COVARIANCE_STEP_S = 20.0


@params.record
class EstimateAccuracy:
    """What the planner predicts the estimators will know at the last burn, from their sensors and tuning
    (scenario sections sensors and estimation; package doc, step 4).

    Attributes:
        position_sigma_m, position_rate_hz: relative-position sensor, 1 sigma per hill axis [m] and rate [Hz].
        accel_psd_m2_s3: the navigation filter's white-acceleration density q [m^2/s^3].
        attitude_sigma_rad, attitude_rate_hz: vision attitude sensor, 1 sigma per body axis [rad] and rate [Hz].
        torque_psd_n2m2s: the target filter's torque-noise density [N^2 m^2 s].
        converged_attitude_3sigma_rad, converged_rate_3sigma_rad_s: the target filter's convergence bounds; the
            plan's estimate is converged, so its covariance is within them.
    """

    position_sigma_m: float = params.key('sensors.relative_position.noise_sigma_m')
    position_rate_hz: float = params.key('sensors.relative_position.rate_hz')
    accel_psd_m2_s3: float = params.key('estimation.accel_psd_m2_s3')
    attitude_sigma_rad: float = params.key('sensors.target_attitude.noise_sigma_deg', math.radians)
    attitude_rate_hz: float = params.key('sensors.target_attitude.rate_hz')
    torque_psd_n2m2s: float = params.key('estimation.torque_psd_n2m2s')
    converged_attitude_3sigma_rad: float = params.key('estimation.convergence_attitude_3sigma_deg', math.radians)
    converged_rate_3sigma_rad_s: float = params.key('estimation.convergence_rate_3sigma_deg_s', math.radians)

    def __post_init__(self):
        for name in ('position_sigma_m', 'position_rate_hz', 'attitude_sigma_rad', 'attitude_rate_hz',
                     'converged_attitude_3sigma_rad', 'converged_rate_3sigma_rad_s'):
            require_positive(name, getattr(self, name))
        for name in ('accel_psd_m2_s3', 'torque_psd_n2m2s'):
            require_positive(name, getattr(self, name), allow_zero=True)

    @functools.cached_property
    def navigation_covariance(self):
        """6x6 covariance of the navigation estimate [r; v] (hill; m, m/s) between burns: the steady state (a
        posteriori) of its per-axis Kalman filter, Phi = [[1, dt], [0, 1]], Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]],
        H = [1 0], R = sigma^2 at dt = 1 / rate (flyby_estimation.relative_nav, whose CW coupling over dt is
        O(n dt) ~ 1e-4)."""
        dt = 1.0 / self.position_rate_hz
        q = self.accel_psd_m2_s3
        phi = np.array(((1.0, dt), (0.0, 1.0)))
        h = np.array(((1.0, 0.0),))
        r = self.position_sigma_m ** 2
        prior = solve_discrete_are(phi.T, h.T, q * np.array(((dt ** 3 / 3.0, dt ** 2 / 2.0), (dt ** 2 / 2.0, dt))),
                                   np.array(((r,),)))
        axis = prior - prior @ h.T @ h @ prior / (prior[0, 0] + r)  # P+ = P- - P- H' (H P- H' + R)^-1 H P-
        cov = np.zeros((6, 6))
        for k in range(3):
            cov[np.ix_((k, k + 3), (k, k + 3))] = axis
        return cov

    @property
    def converged_covariance(self):
        """6x6 bound of the converged target estimate's covariance of [dtheta_body, domega_body]: each block's
        worst direction at its convergence bound, and twice that (a covariance is at most twice its
        block-diagonal part, whatever the attitude-rate correlation)."""
        return 2.0 * np.diag([(self.converged_attitude_3sigma_rad / 3.0) ** 2] * 3
                             + [(self.converged_rate_3sigma_rad_s / 3.0) ** 2] * 3)


class TargetUncertainty:
    """The target estimate's covariance the planner predicts over [t0, t_end] (default: the prediction's end;
    package doc, step 4).

    An EKF's covariance depends on the trajectory, not on the measured values, so the target filter's can be
    predicted along the predicted motion: from the converged estimate's bound at t0
    (EstimateAccuracy.converged_covariance; the Riccati recursion is monotone, so a larger start gives a larger
    covariance later), each substep P <- Phi P Phi' + Qd of seed 000 eq 4 linearized
    (ErrorStateDynamics.substep_transition_many, substeps of at most _COVARIANCE_STEP_S and _COVARIANCE_STEP_RAD),
    then the substep's vision measurements (f h of them, H = [I 0], sigma per body axis) fused at its end as one of
    their information, R = sigma^2 / (f h) I. Checked against the target filter's own covariance at the last burn
    of flown runs (docs/planner.md, "How these rules were found").

    covariance0 replaces the converged bound at t0 (a test against the filter's own covariance).
    ``filtered`` holds that covariance at the substep ends (the estimate guidance re-aims with at each burn);
    ``predicted(t_from, times)`` carries the estimate of t_from on to later times without measurements (the
    estimate of the last burn, seen from the grasp and the escape).
    """

    def __init__(self, prediction, t0, config, covariance0=None, t_end=None):
        acc = config.accuracy
        self.dynamics = ErrorStateDynamics(config.inertia_kg_m2, acc.torque_psd_n2m2s)
        inertia = np.asarray(config.inertia_kg_m2, dtype=float)
        omega0 = prediction.state(t0).omega_body
        # Torque-free: |omega| <= |H| / I_min at any time (seed 000 eq 4).
        rate_max = float(np.linalg.norm(inertia @ omega0)) / float(np.linalg.eigvalsh(inertia)[0])
        t_end = prediction.t_end if t_end is None else min(t_end, prediction.t_end)
        span = t_end - t0
        steps = max(1, math.ceil(span / _COVARIANCE_STEP_S), math.ceil(span * rate_max / _COVARIANCE_STEP_RAD))
        nodes = np.linspace(t0, t_end, steps + 1)
        c_hill_from_body = prediction.c_hill_from_body(nodes)
        omega_body = np.einsum('nji,nj->ni', c_hill_from_body, prediction.track(np.zeros(3), nodes).omega_hill)
        h = np.diff(nodes)
        self.phi, self.qd = self.dynamics.substep_transition_many(omega_body[:-1], omega_body[1:], h)
        self.nodes = nodes
        p = acc.converged_covariance if covariance0 is None else np.asarray(covariance0, dtype=float)
        filtered = [p]
        for k in range(steps):
            p = self.phi[k] @ p @ self.phi[k].T + self.qd[k]  # P = Phi P Phi' + Qd
            if h[k] > 0.0:
                s = p[:3, :3] + np.eye(3) * acc.attitude_sigma_rad ** 2 / (acc.attitude_rate_hz * h[k])  # S = HPH' + R
                gain = np.linalg.solve(s, p[:3, :]).T  # K = P H' S^-1
                p = p - gain @ p[:3, :]  # P = (I - K H) P
                p = 0.5 * (p + p.T)
            filtered.append(p)
        self.filtered = np.array(filtered)

    def predicted(self, t_from, times):
        """(N, 6, 6) covariance at the times (N,) [s] of the estimate of t_from carried on without measurements
        (before t_from: the filtered one). It starts from the substep end at or before t_from (fewer
        measurements: larger) and is linear in time between substep ends (above the covariance's convex growth)."""
        t = np.atleast_1d(np.asarray(times, dtype=float))
        nodes = self.nodes
        last = len(nodes) - 1
        k0 = int(np.clip(np.searchsorted(nodes, t_from, side='right') - 1, 0, last))
        k1 = int(np.clip(np.searchsorted(nodes, t.max(), side='left'), k0, last))
        chain = np.empty((k1 - k0 + 1, 6, 6))
        chain[0] = p = self.filtered[k0]
        for k in range(k0, k1):
            chain[k - k0 + 1] = p = self.phi[k] @ p @ self.phi[k].T + self.qd[k]  # P = Phi P Phi' + Qd
        out = np.empty((len(t), 6, 6))
        before = t < nodes[k0]
        if before.any():
            out[before] = self._interpolate(self.filtered, nodes, t[before])
        out[~before] = self._interpolate(chain, nodes[k0:k1 + 1], t[~before])
        return out

    @staticmethod
    def _interpolate(table, nodes, t):
        """Linear interpolation of the matrices table (K, 6, 6) at the nodes (K,) to the times t (clamped)."""
        if len(nodes) == 1:
            return np.broadcast_to(table[0], (len(t), 6, 6))
        i = np.clip(np.searchsorted(nodes, t, side='right') - 1, 0, len(nodes) - 2)
        w = np.clip((t - nodes[i]) / (nodes[i + 1] - nodes[i]), 0.0, 1.0)[:, None, None]
        return (1.0 - w) * table[i] + w * table[i + 1]

    def attitude_sigma_rad(self, t_from, times):
        """(N,) 1-sigma attitude error [rad] along its worst direction (predicted, above)."""
        return np.sqrt(largest_eigenvalue(self.predicted(t_from, times)[:, :3, :3]))


def largest_eigenvalue(a):
    """Largest eigenvalue (...,) of symmetric 3x3 matrices a (..., 3, 3), >= 0 (covariances), in closed form
    (the trigonometric solution of the characteristic cubic, O. K. Smith, Comm. ACM 4 (1961) 168), which is
    much faster than numpy's eigvalsh on many small matrices."""
    a = np.asarray(a, dtype=float)
    q = np.trace(a, axis1=-2, axis2=-1) / 3.0
    off = a[..., 0, 1] ** 2 + a[..., 0, 2] ** 2 + a[..., 1, 2] ** 2
    p = np.sqrt(((a[..., 0, 0] - q) ** 2 + (a[..., 1, 1] - q) ** 2 + (a[..., 2, 2] - q) ** 2 + 2.0 * off) / 6.0)
    safe = np.where(p > 0.0, p, 1.0)
    b = (a - q[..., None, None] * np.eye(3)) / safe[..., None, None]
    r = np.clip(np.linalg.det(b) / 2.0, -1.0, 1.0)
    return np.maximum(np.where(p > 0.0, q + 2.0 * p * np.cos(np.arccos(r) / 3.0), q), 0.0)


def _sigma3(cov):
    """3 sigma [m or m/s] along the worst direction of a 3x3 covariance."""
    return UNCERTAINTY_SIGMAS * math.sqrt(float(largest_eigenvalue(cov)))


def chaser_error_at_estimate(c, coast_s, config):
    """6x6 covariance of the chaser's state error at the estimate guidance's last burn is computed from: the
    navigation estimate's (EstimateAccuracy.navigation_covariance) and the velocity error of the last burn.

    The last burn is the injection (eq 29, |dV_Tf|) when no adjusting burn fits between t_i and the last burnable
    instant (adjust_interval_s apart); each adjusting burn before the last corrects the one before to the
    thrusters' execution error, so the last burn's error is impulse_error_sigma^(k + 1) |dV_Tf| after k adjusting
    burns (isotropic: magnitude and pointing together)."""
    k = math.floor(max(c.flyby_duration_s - coast_s, 0.0) / config.adjust_interval_s)
    sigma_v = config.impulse_error_sigma ** (k + 1) * float(np.linalg.norm(c.dv_tf))
    cov = config.accuracy.navigation_covariance.copy()
    cov[3:, 3:] += sigma_v ** 2 * np.eye(3)
    return cov


def predicted_miss(c, ps, chaser_cov, coast_s, config):
    """The predicted 3-sigma miss at the grasp ([m], [m/s], worst direction) and its parts [m]: the chaser's state
    error at the estimate carried along CW over the command lead and the coast (seed 000 eq 22), plus the target
    estimate's error at X_Ft (_add_uncertainty). Parts: navigation, last burn, target."""
    n = config.mean_motion_rad_s
    stm = cw_transition_matrix(n, coast_s + config.command_lead_s)
    nav = config.accuracy.navigation_covariance
    chaser = stm @ chaser_cov @ stm.T
    total = chaser + ps.target_miss_cov
    parts = (_sigma3((stm @ nav @ stm.T)[:3, :3]), _sigma3((stm @ (chaser_cov - nav) @ stm.T)[:3, :3]),
             _sigma3(ps.target_miss_cov[:3, :3]))
    return _sigma3(total[:3, :3]), _sigma3(total[3:, 3:]), parts
