"""The supervisor's collision-avoidance burn of an abort outside the restriction sphere: the fly-by's passive
safety (seed 000 section 4.1) of the coast from where the chaser is, and the burn that restores it.

Pure numpy, no ROS. Frames and units as in flyby_planner.flyby.grasp_search (hill, SI).
"""

import numpy as np

from flyby_planner.flyby.passive_safety import passive_gaps


def avoidance_burn(r_hill, v_hill, t, region, config, dv_mps):
    """The collision-avoidance burn of an abort outside the restriction sphere, or None if none is needed.

    The chaser's coast from (r, v) at t is propagated (nonlinear) for escape_check_orbits orbits; if
    its envelope keeps clearance_margin_m from the swept region no burn is needed (the fly-by's
    passive safety, seed 000 section 4.1). Otherwise impulses of dv_mps along +-x, +-y, +-z and
    radially away from the target, and a retreat (cancel the closing speed, then dv_mps away), are
    tried and the one whose coast keeps the largest least clearance is returned.

    Returns:
        (dv_hill or None, least clearance of the coast without the burn [m], with it [m]).
    """
    r = np.asarray(r_hill, dtype=float)
    v = np.asarray(v_hill, dtype=float)
    away = r / np.linalg.norm(r) if np.linalg.norm(r) > 0.0 else np.array((1.0, 0.0, 0.0))
    closing = min(float(v @ away), 0.0)
    options = [np.zeros(3)] + [dv_mps * d for d in (*np.eye(3), *-np.eye(3), away)] + [(dv_mps - closing) * away]
    *_, gaps = passive_gaps(np.array([np.concatenate((r, v + dv)) for dv in options]), [t] * len(options),
                             config.escape_duration_s, region, config)
    least = [float(g.min()) for g in gaps]
    if least[0] >= config.clearance_margin_m:
        return None, least[0], least[0]
    best = int(np.argmax(least[1:])) + 1
    return options[best], least[0], least[best]
