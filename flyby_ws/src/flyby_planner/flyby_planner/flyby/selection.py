"""Step 5 of the search (package doc): the plan chosen among the safe candidates, and the one-line reason of a
refusal when none is.

Pure numpy, no ROS.
"""

import collections

import numpy as np

from flyby_planner.flyby.checks import passes_checks
from flyby_planner.flyby.passive_safety import nearest_box


def select_plan(candidates, config):
    """Step 5 among the checked candidates (one stage's): least total delta-v; within delta_v_tie_mps of
    it the larger least clearance wins."""
    safe = [c for c in candidates if passes_checks(c)]
    for c in safe:
        c.status = 'safe'
    if not safe:
        return None
    cheapest = min(c.dv_total_mps for c in safe)
    tied = [c for c in safe if c.dv_total_mps <= cheapest + config.delta_v_tie_mps]
    chosen = max(tied, key=lambda c: c.clearance_min_m)
    chosen.status = 'selected'
    return chosen


# Classes of rejection, by the start of the reason, and the step of the checks that makes it (package doc: the
# grasp instant's conditions, X_Fi, the transfer's impulses, the transfer's path, then the passage and the miss).
_REASON_CLASSES = (
    ('condition (a)', 'condition (a), rate', 0), ('condition (b)', 'condition (b), spin axis near hill y', 0),
    ('not convex', 'not convex (eq 15)', 0), ('condition (c)', 'condition (c), lighting', 0),
    ('X_Fi', 'X_Fi inside the restriction sphere', 1), ('transfer impulse', 'transfer impulse above the limit', 2),
    ('transfer passes', 'transfer through the restriction sphere', 3),
    ('predicted 3-sigma miss', 'predicted miss above the tolerance', 4),
    ('passive', 'passive clearance below the margin', 4),
    ('the re-aimed passage', 'the re-aimed passage below the margin', 5),
)


def _reason_class(reason):
    return next((label for prefix, label, _ in _REASON_CLASSES if reason.startswith(prefix)), reason)


def _reason_step(label):
    return next((step for _, name, step in _REASON_CLASSES if name == label), -1)


def refusal_reason(candidates, region, config):
    """One line: how many candidates fell to each class of reason, the classes of the latest check first (what
    bound the candidates that came furthest, e.g. the passage or the miss, before the many a short fly-by's X_Fi
    rejects at once), then by count; the best clearance found and, when a part of the target sweeps through the
    grasp point, which."""
    counts = collections.Counter(_reason_class(c.reasons[0]) for c in candidates if c.reasons)
    parts = [f'{k} {label}' for label, k in sorted(counts.items(), key=lambda item: (-_reason_step(item[0]),
                                                                                      -item[1], item[0]))]
    checked = [c for c in candidates if c.clearance_approach_m is not None]
    if checked:
        best = max(checked, key=lambda c: c.clearance_min_m)
        parts.append(f'best passive clearance {best.clearance_min_m:.3f} m (from the {best.closest}, offset '
                     f'{best.offset_m:g} m, fly-by {best.flyby_duration_s:g} s)')
        g = checked[0]
        own = nearest_box(np.atleast_2d(config.x_grasp_body_m), config.boxes)[1][0]
        axial, radial = region.axial_radial(g.x_g[None, :], np.array([g.t_grasp]), config.mean_motion_rad_s)
        sweeping = [name for name, lo, hi, rad in zip(region.names, region.axial_min_m, region.axial_max_m,
                                                      region.radius_m, strict=True)
                    if lo <= axial[0] <= hi and radial[0] <= rad and name != own]
        if sweeping:
            parts.append('the grasp point lies in the region ' + ' and '.join(sweeping) + ' sweep'
                         + ('s' if len(sweeping) == 1 else ''))
    return f'all {len(candidates)} candidates rejected: ' + '; '.join(parts)
