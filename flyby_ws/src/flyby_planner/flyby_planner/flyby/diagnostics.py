"""The evidence behind a refusal: every fly-by of seed 000's form open at a plan time, checked as the planner
checks (``exhaustive_check``), for the campaigns' refusal reports (scripts/check_refusals.py).

Pure numpy, no ROS.
"""

import dataclasses
import math

import numpy as np

from flyby_planner.flyby.candidates import build_candidate, grasp_reasons, offset_gaps, rate_relative_to_hill
from flyby_planner.flyby.checks import BATCH, check_passive_safety
from flyby_planner.flyby.grasp_search import grasp_candidates
from flyby_planner.flyby.passive_safety import predicted_region
from flyby_planner.flyby.reaim import ReaimModel
from flyby_planner.flyby.uncertainty import TargetUncertainty
from flyby_sim.dynamics.orbital import cw_coast


@dataclasses.dataclass
class RefusalCheck:
    """Every fly-by of seed 000's form open at a plan time, checked (exhaustive_check).

    offsets_clear: offsets whose X_Ft (eq 20) clears the target with the attitude exact; grasp_instants and
    grasp_rejected: the roots of eq 13 in the grasp and extended windows and those failing (a)-(c) or eq 15;
    candidates: every offset x fly-by duration of the others, the transfer's conditions set aside; n_miss_ok,
    n_clear_ok, n_both: those whose predicted 3-sigma miss is within the manipulator's position and velocity
    tolerances, whose passive path keeps clearance_margin_m (the planner's checks), and both; n_flyable: both
    and a transfer that passes; the least miss, the largest clearance, each among the candidates that meet the
    other bound (None: none does).
    """

    offsets_clear: int
    grasp_instants: int = 0
    grasp_rejected: int = 0
    candidates: int = 0
    n_miss_ok: int = 0
    n_clear_ok: int = 0
    n_both: int = 0
    n_flyable: int = 0
    min_miss_m: float | None = None
    max_clearance_m: float | None = None
    min_miss_if_clear_m: float | None = None
    max_clearance_if_miss_ok_m: float | None = None
    coast_at_min_miss_s: float | None = None


def exhaustive_check(prediction, r_chaser_hill, v_chaser_hill, t_now, config, covariance_body=None):
    """Check every candidate plan_capture could fly, and more, for passive clearance and the predicted miss.

    The evidence that a refusal holds no safe and capturable fly-by (docs/campaigns.md): every grasp
    instant of the grasp and extended windows (up to config.latest_grasp_s), every offset whose X_Ft clears
    the target, every fly-by duration, with the transfer's conditions (window, impulse, X_Fi outside the
    sphere) set aside; plan_capture searches a subset of these in stages and stops at the first safe stage.
    ``prediction`` must reach the extended window plus geometry_window_s; covariance_body as plan_capture's.
    Returns a RefusalCheck.
    """
    n = config.mean_motion_rad_s
    r_now = np.asarray(r_chaser_hill, dtype=float)
    v_now = np.asarray(v_chaser_hill, dtype=float)
    rate_rel = rate_relative_to_hill(prediction.state(t_now).omega_hill, n)
    w_lo, w_hi = (t_now + dt for dt in config.search_window(rate_rel, extended=True))
    w_hi = min(w_hi, config.latest_grasp_s)
    offsets = [dr for dr, (gap, _name) in offset_gaps(config).items() if gap >= config.clearance_margin_m]
    check = RefusalCheck(offsets_clear=len(offsets))
    if not offsets or w_hi <= w_lo:
        return check
    region = predicted_region(prediction, t_now, config)
    uncertainty = TargetUncertainty(prediction, t_now, config) if config.accuracy is not None else None
    reaim = ReaimModel(prediction, t_now, config, covariance_body) if config.reaims(covariance_body) else None
    found = grasp_candidates(prediction, config.x_grasp_body_m, w_lo, w_hi, n)
    t_ti = t_now + config.maneuver_lead_s
    chaser_at_ti = cw_coast(r_now, v_now, config.maneuver_lead_s, n)
    transfer_cap = max(config.transfer_cap_s, config.transfer_max_for(rate_rel))
    candidates, transfer_ok = [], []
    for g in found:
        if grasp_reasons(g, config):
            check.grasp_rejected += 1
            continue
        for duration in config.flyby_durations_s:
            if not config.transfer_min_s <= g.t_grasp - duration - t_ti <= transfer_cap:
                continue
            for dr in offsets:
                c = build_candidate(g, dr, duration, t_ti, chaser_at_ti, (), config)
                transfer_ok.append(not c.reasons)
                c.reasons = []  # set aside: only the passage's checks reject below
                candidates.append(c)
    passages = {}
    for k in range(0, len(candidates), BATCH):
        check_passive_safety(candidates[k:k + BATCH], passages, prediction, region, config, uncertainty, reaim,
                              reaim_all=True)
    check.grasp_instants, check.candidates = len(found), len(candidates)
    if not candidates:
        return check
    miss = np.array([math.inf if c.miss_3sigma_m is None else c.miss_3sigma_m for c in candidates])
    clearance = np.array([c.clearance_min_m for c in candidates])
    # The planner's own verdicts (check_passive_safety's reasons), not the bounds stated again here.
    miss_ok = np.array([not any(r.startswith('predicted 3-sigma miss') for r in c.reasons) for c in candidates])
    clear_ok = np.array([not any(r.startswith(('passive', 'the re-aimed passage')) for r in c.reasons)
                         for c in candidates])
    transfer_ok = np.array(transfer_ok)
    check.n_miss_ok, check.n_clear_ok = int(miss_ok.sum()), int(clear_ok.sum())
    check.n_both, check.n_flyable = int((miss_ok & clear_ok).sum()), int((miss_ok & clear_ok & transfer_ok).sum())
    check.min_miss_m, check.max_clearance_m = float(miss.min()), float(clearance.max())
    check.min_miss_if_clear_m = float(miss[clear_ok].min()) if clear_ok.any() else None
    check.max_clearance_if_miss_ok_m = float(clearance[miss_ok].max()) if miss_ok.any() else None
    check.coast_at_min_miss_s = float(candidates[int(np.argmin(miss))].unguided_coast_s)
    return check
