"""Passive safety of the fly-by (package doc, step 4; seed 000 section 4.1): the chaser's coast through X_Ft at
the grasp time, backward to X_Fi and on over the escape (nonlinear relative dynamics), and its gap from the target:
the swept region (flyby_planner.flyby.keepout) at any timing, the predicted geometry near the grasp.

``predicted_gaps`` is the one home of the gap from the predicted geometry less its uncertainty: guidance's gate
(``check_passage``) and the optimization-based approach (flyby_planner.optimal.approach) check with it.

Pure numpy/scipy, no ROS. Frames and units as in flyby_planner.flyby.grasp_search (hill, SI).
"""

import dataclasses
import math

import numpy as np
from scipy.integrate import solve_ivp

from flyby_estimation.target_motion import body_point_in_hill
from flyby_planner.flyby.keepout import swept_region
from flyby_planner.flyby.uncertainty import UNCERTAINTY_SIGMAS, largest_eigenvalue
from flyby_sim.dynamics.geometry import signed_distance_to_box
from flyby_sim.dynamics.orbital import cw_transition_matrix, nonlinear_relative_accel

# Samples of the target motion for the swept region (a tumbler's polhode) and of the passive path.
_REGION_SAMPLES = 64
_PATH_STEP_S = 1.0
# The passage is sampled so that the target's surface moves at most this far between samples [m].
_FINE_STEP_M = 0.02
# Guidance's last adjusting burn is where the passive arc is still this far beyond the restriction
# sphere and its burn margin [m] (flyby_guidance.guidance, arc law); from there the chaser coasts.
LAST_BURN_SLACK_M = 2.0


def _propagate_passive(states0, t_end_s, config):
    """Nonlinear coast of several hill states (K, 6) at once over [0, t_end_s] (t_end_s may be negative);
    dense solution tau -> (6, K, len(tau))."""
    k = states0.shape[0]
    n, radius = config.mean_motion_rad_s, config.orbit_radius_m

    def rate(_, y):
        s = y.reshape(6, k)
        return np.concatenate((s[3:], nonlinear_relative_accel(s[:3], s[3:], n, radius))).ravel()

    sol = solve_ivp(rate, (0.0, t_end_s), states0.T.ravel(), method='DOP853', rtol=1e-10, atol=1e-9,
                    dense_output=True)
    if not sol.success:
        raise RuntimeError(f'passive-path propagation failed: {sol.message}')
    return lambda tau: sol.sol(tau).reshape(6, k, -1)


def passive_gaps(states0, t0s, span_s, region, config):
    """Coast the hill states (K, 6), starting at the times t0s (K,), for span_s and sample their
    clearance from the swept region every _PATH_STEP_S.

    Returns (dense, tau (M,), states (6, K, M), gaps (K, M)); dense(tau) -> (6, K, len(tau)).
    """
    dense = _propagate_passive(states0, span_s, config)
    tau = np.linspace(0.0, span_s, int(math.ceil(span_s / _PATH_STEP_S)) + 1)
    states = dense(tau)
    gaps = np.array([region.clearance(states[:3, j, :].T, t0 + tau, config.mean_motion_rad_s,
                                      config.envelope_radius_m) for j, t0 in enumerate(t0s)])
    return dense, tau, states, gaps


@dataclasses.dataclass
class _Passage:
    """The passive path through one (grasp instant, offset): X_Ft, V_Ft at t_grasp, coasted back
    over the longest fly-by and on over the escape; its clearance profile on tau = t - t_grasp.

    tau (M,) and, per sample, gap (M,) [m] (with the fixed uncertainty model, or before any chaser dispersion: the
    larger of the swept-region gap and the predicted-geometry gap less the target's uncertainty), closest (M,) what
    it is to; r_tau (M',), radius (M',) |r| [m] on the coarse samples; coast_s, the unguided coast from the last
    burn guidance can fly on this arc to the grasp (guidance.py, arc law: where the arc is still LAST_BURN_SLACK_M
    beyond the sphere and its burn margin; the whole back span if it never is).

    With the planner's uncertainty model (TargetUncertainty) also, per sample: swept (M,) the swept-region gap,
    predicted (M,) the predicted-geometry gap before any uncertainty (-inf where not sampled), lever (M,) |r| times
    the target estimate's 1-sigma attitude error there (seen from the estimate the last burn is computed from, at
    t_estimate), window (M,) whether the sample is within geometry_window_s of the grasp; and target_miss_cov, the
    6x6 covariance of X_Ft, V_Ft at the grasp from that estimate's error (seed 000 eq 8-9 and 20-21 linearized).
    """

    t_grasp: float
    tau: np.ndarray
    gap: np.ndarray
    closest: np.ndarray
    r_tau: np.ndarray
    radius: np.ndarray
    path: object  # tau (relative to t_grasp) -> (3, len(tau)) hill positions
    coast_s: float = None
    t_estimate: float = None
    swept: np.ndarray = None
    predicted: np.ndarray = None
    lever: np.ndarray = None
    window: np.ndarray = None
    names: np.ndarray = None
    target_miss_cov: np.ndarray = None

    def profile(self, chaser_cov, n):
        """(gap (M,), closest (M,)) with the chaser's dispersion counted (package doc, step 4): chaser_cov, the 6x6
        covariance of its state error at t_estimate, carried along CW (seed 000 eq 22) to each sample of the
        window after it; gap = the larger of swept - 3 sigma_c and predicted - 3 sqrt((|r| sigma_att)^2 +
        sigma_c^2), sigma_c the chaser's 1-sigma position error along its worst direction. None (or a passage
        without the uncertainty model): the gap as computed."""
        if chaser_cov is None or self.swept is None:
            return self.gap, self.closest
        sigma_c = self.chaser_sigma(chaser_cov, n)
        swept = self.swept - UNCERTAINTY_SIGMAS * sigma_c
        predicted = self.predicted - UNCERTAINTY_SIGMAS * np.hypot(self.lever, sigma_c)
        use_predicted = predicted > swept
        return (np.where(use_predicted, predicted, swept),
                np.where(use_predicted, self.names, 'swept region').astype(object))

    def chaser_sigma(self, chaser_cov, n):
        """(M,) sigma_c [m]: the chaser's 1-sigma position error along its worst direction at each sample of the
        window (zero outside), from chaser_cov at t_estimate carried along CW (seed 000 eq 22)."""
        # On a grid of _PATH_STEP_S over the window, interpolated to the samples (it grows smoothly).
        tau = self.tau[self.window]
        sigma_c = np.zeros(len(self.tau))
        if tau.size:
            grid = np.arange(tau.min(), tau.max() + _PATH_STEP_S, _PATH_STEP_S)
            stm = cw_transition_matrix(n, np.maximum(self.t_grasp + grid - self.t_estimate, 0.0))[:, :3, :]  # eq 22
            spread = np.einsum('mij,jk,mlk->mil', stm, chaser_cov, stm)
            sigma_c[self.window] = np.interp(tau, grid, np.sqrt(largest_eigenvalue(spread)))
        return sigma_c


def _runs(mask):
    """(start, stop) index pairs of the runs of True in a boolean array (stop exclusive)."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(int), [0]))))
    return list(zip(edges[::2], edges[1::2], strict=True))


def nearest_box(p_body, boxes):
    """Signed distance (N,) [m] from body points (N, 3) to the nearest target box, and that box's name (N,)."""
    dist = np.array([signed_distance_to_box(p_body, center, size)
                     for center, size in zip(boxes.center_body_m, boxes.size_m, strict=True)])
    nearest = np.argmin(dist, axis=0)
    return dist[nearest, np.arange(dist.shape[1])], np.asarray(boxes.names)[nearest]


def predicted_distance(prediction, r_hill, t, config):
    """Gap [m] of the chaser envelope from the target's predicted geometry at each (r_hill (M, 3), t (M,)), with no
    uncertainty, and the nearest box's name per sample."""
    c_hb = prediction.c_hill_from_body(t)
    dist, names = nearest_box(np.einsum('mji,mj->mi', c_hb, r_hill), config.boxes)  # C_hill_from_body' r
    return dist - config.envelope_radius_m, names


def predicted_gaps(prediction, r_hill, t, t_grasp, config):
    """Gap [m] of the chaser envelope from the target's predicted geometry at each (r_hill (M, 3), t (M,)),
    less the prediction's uncertainty, and the nearest box's name per sample.

    The uncertainty is |r| times an attitude error: for a prediction that carries the estimate's
    covariance (guidance's gate), UNCERTAINTY_SIGMAS times its own propagated 1-sigma attitude error;
    otherwise (a PlannerConfig without EstimateAccuracy) the fixed model geometry_attitude_margin +
    geometry_rate_margin |t - t_g|. The planner with EstimateAccuracy uses TargetUncertainty instead
    (passive_passages)."""
    gap, names = predicted_distance(prediction, r_hill, t, config)
    if getattr(prediction, 'has_covariance', False):
        angle = UNCERTAINTY_SIGMAS * prediction.attitude_sigma_rad(t)
    else:
        angle = config.geometry_attitude_margin_rad + config.geometry_rate_margin_rad_s * np.abs(t - t_grasp)
    return gap - np.linalg.norm(r_hill, axis=1) * angle, names


def passive_passages(keys, states_at_grasp, prediction, region, config, back_s=None, uncertainty=None):
    """_Passage of each (t_grasp, offset) key from its hill state (6,) at the grasp (package doc, step 4),
    from back_s before the grasp (default: the longest fly-by) over the escape. With uncertainty
    (TargetUncertainty) the passages carry the parts of the planner's uncertainty model (_Passage)."""
    n = config.mean_motion_rad_s
    back = max(config.flyby_durations_s) if back_s is None else back_s
    escape = config.escape_duration_s
    x0 = np.array(states_at_grasp)
    dense_back = _propagate_passive(x0, -back, config)
    dense_on = _propagate_passive(x0, escape, config)
    tau = np.concatenate((np.linspace(-back, 0.0, int(math.ceil(back / _PATH_STEP_S)) + 1)[:-1],
                          np.linspace(0.0, escape, int(math.ceil(escape / _PATH_STEP_S)) + 1)))
    r_all = np.concatenate((dense_back(tau[tau < 0.0]), dense_on(tau[tau >= 0.0])), axis=2)[:3]
    rate = max(float(np.linalg.norm(prediction.state(min(k[0], prediction.t_end)).omega_body)) for k in keys)
    burn_limit = config.restriction_sphere_radius_m + config.sphere_margin_m + LAST_BURN_SLACK_M
    out = {}
    for j, key in enumerate(keys):
        t_g = key[0]
        r = r_all[:, j, :].T
        radius = np.linalg.norm(r, axis=1)
        burnable = np.flatnonzero((tau <= 0.0) & (radius > burn_limit))
        coast = float(-tau[burnable[-1]]) if burnable.size else back
        swept = region.clearance(r, t_g + tau, n, config.envelope_radius_m)
        gap = swept.copy()
        closest = np.full(len(tau), 'swept region', dtype=object)
        # Near the grasp, where the swept region is too close, the predicted geometry at each instant.
        near = ((np.abs(tau) <= config.geometry_window_s) & (t_g + tau >= prediction.t0)
                & (t_g + tau <= prediction.t_end))
        danger = near & (gap < config.clearance_margin_m)
        danger = near & (danger | np.roll(danger, 1) | np.roll(danger, -1))
        keep = ~danger
        fine_tau = []
        speed = rate * region.bounding_radius_m + float(np.linalg.norm(x0[j, 3:]))
        step = min(max(_FINE_STEP_M / speed, 0.002), 0.25) if speed > 0.0 else 0.25
        for a, b in _runs(danger):
            lo, hi = tau[max(a - 1, 0)], tau[min(b, len(tau) - 1)]
            fine_tau.append(np.linspace(lo, hi, int(math.ceil((hi - lo) / step)) + 1))
        tau_k, gap_k, closest_k = tau[keep], gap[keep], closest[keep]
        swept_k, predicted_k = swept[keep], np.full(int(keep.sum()), -np.inf)
        names_k, radius_k = closest[keep], radius[keep]
        if fine_tau:
            tf = np.unique(np.concatenate(fine_tau))
            tf = tf[(t_g + tf >= prediction.t0) & (t_g + tf <= prediction.t_end)]
            # CW near the target: over a few hundred seconds within ~20 m it differs from the
            # nonlinear coast by far less than a micrometre.
            rf = np.einsum('mij,j->mi', cw_transition_matrix(n, tf), x0[j])[:, :3]
            swept_f = region.clearance(rf, t_g + tf, n, config.envelope_radius_m)
            if uncertainty is None:
                predicted, boxes = predicted_gaps(prediction, rf, t_g + tf, t_g, config)
            else:
                predicted, boxes = predicted_distance(prediction, rf, t_g + tf, config)
            use_predicted = predicted > swept_f
            order = np.argsort(np.concatenate((tau_k, tf)), kind='stable')
            tau_k = np.concatenate((tau_k, tf))[order]
            gap_k = np.concatenate((gap_k, np.where(use_predicted, predicted, swept_f)))[order]
            closest_k = np.concatenate((closest_k, np.where(use_predicted, boxes, 'swept region')))[order]
            swept_k = np.concatenate((swept_k, swept_f))[order]
            predicted_k = np.concatenate((predicted_k, predicted))[order]
            names_k = np.concatenate((names_k, boxes.astype(object)))[order]
            radius_k = np.concatenate((radius_k, np.linalg.norm(rf, axis=1)))[order]

        def path(tau_q, j=j):
            tau_q = np.atleast_1d(tau_q)
            xyz = np.empty((3, len(tau_q)))
            xyz[:, tau_q < 0.0] = dense_back(tau_q[tau_q < 0.0])[:3, j, :]
            xyz[:, tau_q >= 0.0] = dense_on(tau_q[tau_q >= 0.0])[:3, j, :]
            return xyz
        ps = _Passage(t_grasp=t_g, tau=tau_k, gap=gap_k, closest=closest_k, r_tau=tau, radius=radius, path=path,
                      coast_s=coast)
        if uncertainty is not None:
            _add_uncertainty(ps, x0[j], swept_k, predicted_k, names_k, radius_k, prediction, uncertainty, config)
        out[key] = ps
    return out


def _add_uncertainty(ps, state_at_grasp, swept, predicted, names, radius, prediction, uncertainty, config):
    """Fill the uncertainty parts of a passage (_Passage): the target estimate guidance computes the last burn
    from is that of command_lead_s before it; seen from there, |r| sigma_att at each sample within the window
    (the surface moves by |r| times the attitude error) and the covariance of X_Ft, V_Ft at the grasp, J P J' with
    J the Jacobian of the body point X_Ft^B (seed 000 eq 8-9, 20-21: X_Ft is a body point) and P the
    estimate's covariance carried to the grasp."""
    t_g = ps.t_grasp
    ps.t_estimate = t_g - ps.coast_s - config.command_lead_s
    window = np.abs(ps.tau) <= config.geometry_window_s
    window &= (t_g + ps.tau >= prediction.t0) & (t_g + ps.tau <= prediction.t_end)
    # On a grid of _PATH_STEP_S over the window (the sigma grows smoothly), interpolated to the samples.
    tau = ps.tau[window]
    grid = np.arange(tau.min(), tau.max() + _PATH_STEP_S, _PATH_STEP_S) if tau.size else tau
    cov = uncertainty.predicted(ps.t_estimate, np.concatenate(((t_g,), t_g + grid)))
    lever = np.zeros(len(ps.tau))
    if tau.size:
        lever[window] = radius[window] * np.interp(tau, grid, np.sqrt(largest_eigenvalue(cov[1:, :3, :3])))
    ps.swept, ps.predicted, ps.lever, ps.window, ps.names = swept, predicted, lever, window, names
    at_grasp = prediction.state(t_g)
    c_hill_from_body = prediction.c_hill_from_body(np.array((t_g,)))[0]
    x_ft_body = c_hill_from_body.T @ state_at_grasp[:3]
    _, _, jac = body_point_in_hill(c_hill_from_body, at_grasp.omega_body, x_ft_body, config.mean_motion_rad_s)
    ps.target_miss_cov = jac @ cov[0] @ jac.T  # J P J'


def predicted_region(prediction, t_from, config):
    """The swept region (keepout.SweptRegion) of the predicted motion from t_from to the prediction's end."""
    samples = [prediction.state(t) for t in np.linspace(t_from, prediction.t_end, _REGION_SAMPLES)]
    return swept_region(config.boxes, config.inertia_kg_m2, [s.q_eci_from_body for s in samples],
                        [s.omega_body for s in samples])


@dataclasses.dataclass(frozen=True)
class PassageCheck:
    """Step 4 for one passive arc: its least gap [m] from the target, what that gap is to (a box of the
    predicted geometry or 'swept region') and when [s]; safe when the gap keeps clearance_margin_m."""

    gap_m: float
    closest: str
    t_min_gap: float
    margin_m: float

    @property
    def safe(self):
        return self.gap_m >= self.margin_m


def check_passage(prediction, x_ft, v_ft, t_grasp, t_from, config, margin_m=None):
    """The passive-safety check of step 4 for the arc through X_Ft, V_Ft at t_grasp (hill, velocity
    relative to hill), coasted from t_from over the grasp and the escape: the predicted geometry less
    its uncertainty near the grasp (3 sigma of the prediction's own covariance if it carries one), the
    swept region elsewhere; safe when the least gap keeps margin_m (default: the planning margin,
    clearance_margin_m). Guidance runs it on every re-aimed arc before
    it flies onto it (flyby_guidance.guidance_core); ``prediction`` covers [t_from,
    t_grasp + geometry_window_s] for the predicted geometry to count over the whole passage."""
    region = predicted_region(prediction, max(t_from, prediction.t0), config)
    key = (float(t_grasp), 0.0)
    ps = passive_passages([key], [np.concatenate((x_ft, v_ft))], prediction, region, config,
                   back_s=max(float(t_grasp) - t_from, 0.0))[key]
    later = ps.tau >= t_from - t_grasp
    i = int(np.argmin(np.where(later, ps.gap, np.inf)))
    return PassageCheck(gap_m=float(ps.gap[i]), closest=str(ps.closest[i]), t_min_gap=float(t_grasp + ps.tau[i]),
                        margin_m=config.clearance_margin_m if margin_m is None else margin_m)
