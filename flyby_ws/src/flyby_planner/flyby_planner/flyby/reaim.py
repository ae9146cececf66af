"""The re-aim check (package doc, step 4): the passage guidance flies once it re-aims at the grasp re-solved from a
later estimate (seed 000 eq 13-15, 20-21), checked at 3 sigma of the plan estimate's covariance.

Pure numpy, no ROS. Frames and units as in flyby_planner.flyby.grasp_search (hill, SI).
"""

import math

import numpy as np

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import perturbed_predictions
from flyby_planner.flyby.grasp_search import REFINE_HORIZON_S, flyby_target_point, refine_grasp
from flyby_planner.flyby.passive_safety import predicted_distance
from flyby_planner.flyby.uncertainty import UNCERTAINTY_SIGMAS
from flyby_sim.dynamics.orbital import cw_transition_matrix

# The re-aim check's inflation of the target filter's published covariance at the plan time (ReaimModel): the worst
# mean NEES measured over failed runs (3 expected), not the worst over a stretch (docs/planner.md, "How these rules
# were found").
REAIM_COVARIANCE_SCALE = 3.4 / 3.0
# The re-aim check sums each principal direction's effect, a model linear in the plan estimate's error: where its
# 3-sigma motions part by more than this at the grasp it vouches for nothing and refuses. A chosen bound, not derived
# (docs/planner.md, "How these rules were found").
REAIM_MAX_PARTING_RAD = math.radians(30.0)


class ReaimModel:
    """The true target motions the plan estimate allows, for the passage guidance will fly once it re-aims (package
    doc, step 4).

    Guidance re-aims every adjusting burn at the grasp re-solved from the latest estimate (grasp_search.refine_grasp,
    the same offset, eq 20-21), and by the last burn that estimate is close to the truth: the passage flown is the
    one through the *true* motion's grasp, not the plan's. The plan estimate's error, carried 500-700 s to the grasp,
    moves that passage against the target's parts by decimetres (docs/planner.md, "How these rules were found"). So
    the re-aim is checked against the motions of the plan estimate moved
    UNCERTAINTY_SIGMAS sigma along each principal direction of its covariance: the target filter's own at the plan
    time (covariance_body, 6x6 [dtheta_body, domega_body], target_motion.covariance_from_published) inflated by
    REAIM_COVARIANCE_SCALE; integrated in full (target_motion.perturbed_predictions): motions[0] is the estimate's,
    then the +- pairs."""

    def __init__(self, prediction, t_now, config, covariance_body):
        cov = REAIM_COVARIANCE_SCALE * np.asarray(covariance_body, dtype=float)
        if cov.shape != (6, 6) or not np.all(np.isfinite(cov)):
            raise ValueError(f'the plan estimate covariance must be a finite 6x6 matrix, got {covariance_body!r}')
        values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
        steps = UNCERTAINTY_SIGMAS * vectors * np.sqrt(np.maximum(values, 0.0))  # columns: 3 sigma along each
        errors = np.vstack([np.zeros(6)] + [sign * steps[:, k] for k in range(6) for sign in (1.0, -1.0)])
        s = prediction.state(t_now)
        self.t_plan, self.t_end = t_now, prediction.t_end
        self.errors = errors
        self.motions = perturbed_predictions(ErrorStateDynamics(config.inertia_kg_m2), config.mean_motion_rad_s,
                                             t_now, s.q_eci_from_body, s.omega_body, errors, prediction.t_end)


def check_reaimed_passage(c, ps, chaser_cov, model, config):
    """The re-aimed passage of candidate c at 3 sigma of the plan estimate (ReaimModel): (least gap [m], what it is
    to, when [s], the re-aim's 3-sigma spread there [m]), or None when the passage has no sample near the target
    (the swept region holds there at any timing).

    For each motion the grasp is re-solved as guidance does (refine_grasp near c's grasp time), X_Ft, V_Ft placed
    with c's offset (eq 20-21) and the arc coasted along CW (eq 22) over the samples where the planner checks the
    predicted geometry (those within the window, from X_Fi on), each at the same time from its own grasp; the gap
    of each motion's arc from that motion's geometry, e_k. Per principal direction the larger shortfall of its two
    motions below e_0 is its 3-sigma effect, and their root sum square the re-aim's 3-sigma spread S; with the
    last burn's uncertainty L = 3 sqrt((|r| sigma_att)^2 + sigma_c^2) (the planner's passage model) the gap is
    e_0 - sqrt(S^2 + L^2). A motion with no grasp near c's (the turn drifts out of reach), or motions parting by more
    than REAIM_MAX_PARTING_RAD at c's grasp, give -inf."""
    n = config.mean_motion_rad_s
    c_grasp = np.array([m.c_hill_from_body(np.array([c.t_grasp]))[0] for m in model.motions])
    cos_parting = (np.einsum('ij,kij->k', c_grasp[0], c_grasp[1:]) - 1.0) / 2.0  # (trace(C0' Ck) - 1) / 2
    parting = math.acos(float(np.clip(cos_parting.min(), -1.0, 1.0)))
    if parting > REAIM_MAX_PARTING_RAD:
        why = (f'its 3-sigma motions part by {math.degrees(parting):.0f} deg at the grasp (beyond '
               f'{math.degrees(REAIM_MAX_PARTING_RAD):.0f} deg the re-aim model vouches for nothing)')
        return -math.inf, why, c.t_grasp, math.inf
    near = np.flatnonzero(ps.window & np.isfinite(ps.predicted) & (ps.tau >= -c.flyby_duration_s))
    if not near.size:
        return None
    tau = ps.tau[near]
    stm = cw_transition_matrix(n, tau)
    gaps, names = [], None
    for motion in model.motions:
        g = refine_grasp(motion, config.x_grasp_body_m, c.t_grasp, n,
                         t_latest=min(c.t_grasp + REFINE_HORIZON_S, motion.t_end))
        if g is None:
            return -math.inf, 'no convex grasp re-solved near the planned one', c.t_grasp, math.inf
        x_ft, v_ft = flyby_target_point(g.x_g, g.v_g, c.offset_m)  # eq 20-21
        t = g.t_grasp + tau
        inside = (t >= motion.t0) & (t <= motion.t_end)
        gap = np.full(len(tau), math.inf)
        r = np.einsum('mij,j->mi', stm[inside], np.concatenate((x_ft, v_ft)))[:, :3]  # eq 22
        gap[inside], boxes = predicted_distance(motion, r, t[inside], config)
        if names is None:
            names = np.full(len(tau), 'target', dtype=object)
            names[inside] = boxes
        gaps.append(gap)
    e0, pairs = gaps[0], np.array(gaps[1:]).reshape(-1, 2, len(tau))
    shortfall = np.maximum(e0 - pairs.min(axis=1), 0.0)
    spread = np.sqrt(np.sum(np.where(np.isfinite(shortfall), shortfall, 0.0) ** 2, axis=0))
    last_burn = UNCERTAINTY_SIGMAS * np.hypot(ps.lever[near], ps.chaser_sigma(chaser_cov, n)[near])
    total = e0 - np.hypot(spread, last_burn)
    i = int(np.argmin(total))
    return float(total[i]), str(names[i]), float(c.t_grasp + tau[i]), float(spread[i])
