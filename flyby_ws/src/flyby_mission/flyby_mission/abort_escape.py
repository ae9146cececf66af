"""The avoidance burn of an abort: the chaser's coast checked against the target's keep-out region, and one burn when
it comes too close (seed 000 section 4.2's passive safety; flyby_planner.flyby.avoidance).

The coast starts from the latest chaser estimate and goes through the burns guidance commanded and the plant has
still to fly: a burn is sent up to ``command_lead_s`` ahead of its start, and the plant flies what it was sent,
whether the mission aborted since or guidance's core raised (only the CAM cancels queued burns). Judging the coast
without them called a coast "passively safe" that the queued injection then turned into a 0.27 m pass (paper_flyby,
guidance raising at 509 s: docs/runtime.md). So the avoidance burn comes after the last of them, from the state they
leave. No ROS here.
"""

import dataclasses

import numpy as np

from flyby_planner.flyby.avoidance import avoidance_burn
from flyby_planner.flyby.keepout import any_attitude_region, swept_region
from flyby_sim.dynamics.orbital import cw_coast, q_eci_from_body


@dataclasses.dataclass(frozen=True)
class EscapeVerdict:
    """The abort's check: the burn's start t_burn [s] and dv_hill [m/s] (None: the coast is safe, or inside the
    sphere where nothing fires), the least clearance to the region before and after it [m], and how the region was
    swept (``basis``, for the event's message)."""

    t_burn: float
    dv_hill: np.ndarray | None
    before_m: float
    after_m: float
    basis: str
    inside_sphere: bool


class PendingBurns:
    """Guidance's commanded burns (its ``maneuver_commanded`` events: start t_burn [s], dv_hill [m/s]) that the chaser
    estimate does not yet hold."""

    def __init__(self):
        self.burns = []

    def add(self, t_burn, dv_hill):
        self.burns.append((float(t_burn), np.asarray(dv_hill, dtype=float)))

    def after(self, t):
        """The burns starting after t [s] (the latest estimate's stamp), in start order; the older ones dropped."""
        self.burns = sorted((b for b in self.burns if b[0] > t), key=lambda b: b[0])
        return list(self.burns)


def coast_through(r_hill, v_hill, t_from, t_to, burns, n):
    """The CW state [r_hill, v_hill] at t_to [s] from (r_hill, v_hill) at t_from, the impulses ``burns`` ((t_burn,
    dv_hill), in order) in (t_from, t_to] added at their starts."""
    state = np.concatenate((np.asarray(r_hill, dtype=float), np.asarray(v_hill, dtype=float)))
    t = t_from
    for t_burn, dv_hill in burns:
        if t_from < t_burn <= t_to:
            state = cw_coast(state[:3], state[3:], t_burn - t, n)
            state[3:] += dv_hill
            t = t_burn
    return cw_coast(state[:3], state[3:], t_to - t, n)


def escape_check(p, t, chaser, pending, spinning_target, t_latest_target):
    """The abort's verdict at t [s] (module doc). ``p``: the supervisor's parameters; ``chaser``: the latest chaser
    estimate (t, r_hill, v_hill); ``pending``: guidance's burns after it; ``spinning_target``: the latest target
    estimate with a spin axis (t, q_hill_from_body, omega_body) or None (the region that holds the body at every
    attitude: a filter just restarted has no spin axis); t_latest_target [s]: the latest target estimate's stamp."""
    t_c, r, v = chaser
    burns = pending.after(t_c)
    t_burn = max(max(t, t_c) + p.command_lead_s, burns[-1][0] if burns else -np.inf)
    state = coast_through(r, v, t_c, t_burn, burns, p.n_rad_s)
    queued = f'; through guidance\'s burns still to fly ({len(burns)})' if burns else ''
    if np.linalg.norm(state[:3]) < p.restriction_sphere_radius_m + p.sphere_margin_m:
        return EscapeVerdict(t_burn, None, np.nan, np.nan, queued, True)
    if spinning_target is not None:
        t_t, q_hb, omega_body = spinning_target
        region = swept_region(p.boxes, p.target_inertia_kg_m2, [q_eci_from_body(t_t, p.n_rad_s, q_hb)], [omega_body])
        basis = '' if t_t == t_latest_target else f' (region about the spin axis of t = {t_t:.2f} s)'
    else:
        region = any_attitude_region(p.boxes)
        basis = ' (no target estimate with a spin axis: the region of every attitude)'
    dv, before, after = avoidance_burn(state[:3], state[3:], t_burn, region, p.planner, p.avoidance_delta_v_mps)
    return EscapeVerdict(t_burn, dv, before, after, basis + queued, False)
