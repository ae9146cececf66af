"""Step 4 of the search on a batch of candidates (package doc): the passive path's clearance, the sphere entry,
the unguided coast, the predicted miss and, with the re-aim model, the re-aimed passage; the unsafe rejected.

Pure numpy, no ROS.
"""

import math

import numpy as np

from flyby_planner.flyby.passive_safety import passive_passages
from flyby_planner.flyby.reaim import check_reaimed_passage
from flyby_planner.flyby.uncertainty import chaser_error_at_estimate, predicted_miss

# Candidates checked for passive safety at once, in order of delta-v.
BATCH = 12


def passes_checks(c):
    """Checked, no reason against it, and its re-aim checked where the plan has the model."""
    return c.clearance_approach_m is not None and not c.reasons and c.reaim_checked is not False


def check_passive_safety(batch, passages, prediction, region, config, uncertainty=None, reaim=None,
                          reaim_all=False):
    """Step 4 for a batch of candidates: fill their clearances, sphere entry, coast and predicted miss, reject the
    unsafe ones and those whose predicted miss exceeds the manipulator's tolerances; with reaim (ReaimModel), those
    whose re-aimed passage (check_reaimed_passage) keeps less than the margin, in order of delta-v up to the cheapest
    that passes and its ties (reaim_all: every one)."""
    new = {}
    for c in batch:
        key = (c.t_grasp, c.offset_m)
        if key not in passages and key not in new:
            new[key] = np.concatenate((c.x_ft, c.v_ft))
    if new:
        passages.update(passive_passages(list(new), list(new.values()), prediction, region, config,
                                  uncertainty=uncertainty))
    for c in batch:
        ps = passages[(c.t_grasp, c.offset_m)]
        c.unguided_coast_s = min(ps.coast_s, c.flyby_duration_s)
        chaser_cov = None
        if uncertainty is not None:
            chaser_cov = chaser_error_at_estimate(c, ps.coast_s, config)
            c.miss_3sigma_m, c.miss_3sigma_mps, parts = predicted_miss(c, ps, chaser_cov, c.unguided_coast_s, config)
        gap_all, closest_all = ps.profile(chaser_cov, config.mean_motion_rad_s)
        inside = ps.tau >= -c.flyby_duration_s
        tau, gap, closest = ps.tau[inside], gap_all[inside], closest_all[inside]
        approach = tau <= 0.0
        c.clearance_approach_m = float(gap[approach].min())
        c.clearance_escape_m = float(gap[~approach].min())
        i = int(np.argmin(gap))
        c.closest = str(closest[i])
        c.t_min_clearance = float(c.t_grasp + tau[i])
        entered = np.flatnonzero((ps.r_tau >= -c.flyby_duration_s) & (ps.radius <= config.restriction_sphere_radius_m))
        c.t_sphere_entry = float(c.t_grasp + ps.r_tau[entered[0]]) if entered.size else None
        if uncertainty is not None and (c.miss_3sigma_m > config.position_tolerance_m
                                        or c.miss_3sigma_mps > config.velocity_tolerance_mps):
            c.reasons.append(f'predicted 3-sigma miss at the grasp {c.miss_3sigma_m:.3f} m, '
                             f'{c.miss_3sigma_mps * 1e3:.2f} mm/s exceeds the manipulator tolerance '
                             f'{config.position_tolerance_m:g} m, {config.velocity_tolerance_mps * 1e3:g} mm/s '
                             f'(navigation {parts[0]:.3f} m, last burn {parts[1]:.3f} m, target {parts[2]:.3f} m '
                             f'over an unguided coast of {c.unguided_coast_s:.0f} s)')
        if gap[i] < config.clearance_margin_m:
            part = 'approach' if tau[i] <= 0.0 else 'escape'
            c.reasons.append(f'passive {part} clearance {gap[i]:.3f} m from the {c.closest} at t = '
                             f'{c.t_grasp + tau[i]:.1f} s is below the margin {config.clearance_margin_m:g} m')
    if reaim is None:
        return
    cheapest = math.inf
    for c in sorted((c for c in batch if not c.reasons), key=lambda c: c.dv_total_mps):
        c.reaim_checked = False
        if not reaim_all and c.dv_total_mps > cheapest + config.delta_v_tie_mps:
            continue
        c.reaim_checked = True
        ps = passages[(c.t_grasp, c.offset_m)]
        found = check_reaimed_passage(c, ps, chaser_error_at_estimate(c, ps.coast_s, config), reaim, config)
        if found is None:
            cheapest = min(cheapest, c.dv_total_mps)
            continue
        c.reaim_gap_m, closest, t_gap, spread = found
        if not math.isfinite(c.reaim_gap_m):
            c.reasons.append(f'the re-aimed passage: with the plan estimate 3 sigma off over '
                             f'{c.t_grasp - reaim.t_plan:.0f} s, {closest}')
        elif c.reaim_gap_m < config.clearance_margin_m:
            c.reasons.append(f'the re-aimed passage: with the plan estimate 3 sigma off over '
                             f'{c.t_grasp - reaim.t_plan:.0f} s, the arc through the re-solved grasp comes '
                             f'{c.reaim_gap_m:.3f} m from the {closest} at t = {t_gap:.1f} s (re-aim spread '
                             f'{spread:.3f} m), below the margin {config.clearance_margin_m:g} m')
        else:
            cheapest = min(cheapest, c.dv_total_mps)
