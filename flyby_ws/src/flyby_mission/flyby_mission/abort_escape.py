"""The avoidance burn of an abort: the chaser's coast checked against the target's keep-out region, and one burn when
it comes too close (seed 000 section 4.2's passive safety; flyby_planner.flyby.avoidance).

The coast starts from the latest chaser estimate and goes through the burns guidance commanded and the plant has
still to fly: a burn is sent up to ``command_lead_s`` ahead of its start, and the plant flies what it was sent,
whether the mission aborted since or guidance's core raised (only the CAM cancels queued burns): a coast judged
without them is not the one flown (docs/runtime.md). So the avoidance burn comes after the last of them, from the
state they leave. No ROS here.
"""

import dataclasses

import numpy as np

from flyby_msgs_py import events
from flyby_planner.flyby.avoidance import avoidance_burn
from flyby_planner.flyby.keepout import any_attitude_region, swept_region
from flyby_sim.dynamics.orbital import cw_coast, q_eci_from_body


@dataclasses.dataclass(frozen=True)
class EscapeVerdict:
    """The abort's check: the burn's start and its impulse (None: the coast is safe, or inside the sphere where
    nothing fires), the least clearance to the region before and after it, and how the region was swept (``basis``,
    for the event's message)."""

    t_burn_s: float
    dv_hill_mps: np.ndarray | None
    before_m: float
    after_m: float
    basis: str
    inside_sphere: bool


class PendingBurns:
    """Guidance's commanded burns (its ``maneuver_commanded`` events: start t_burn_s, dv_hill_mps) that the chaser
    estimate does not yet hold."""

    def __init__(self):
        self.burns = []

    def add(self, t_burn_s, dv_hill_mps):
        self.burns.append((float(t_burn_s), np.asarray(dv_hill_mps, dtype=float)))

    def after(self, t_s):
        """The burns starting after t_s (the latest estimate's stamp), in start order; the older ones dropped."""
        self.burns = sorted((b for b in self.burns if b[0] > t_s), key=lambda b: b[0])
        return list(self.burns)


def coast_through(r_hill, v_hill, t_from_s, t_to_s, burns, n_rad_s):
    """The CW state [r_hill, v_hill] at t_to_s from (r_hill, v_hill) at t_from_s, the impulses ``burns`` ((t_burn_s,
    dv_hill_mps), in order) in (t_from_s, t_to_s] added at their starts."""
    state = np.concatenate((np.asarray(r_hill, dtype=float), np.asarray(v_hill, dtype=float)))
    t_s = t_from_s
    for t_burn_s, dv_hill_mps in burns:
        if t_from_s < t_burn_s <= t_to_s:
            state = cw_coast(state[:3], state[3:], t_burn_s - t_s, n_rad_s)
            state[3:] += dv_hill_mps
            t_s = t_burn_s
    return cw_coast(state[:3], state[3:], t_to_s - t_s, n_rad_s)


def escape_check(p, t, chaser, pending, spinning_target, t_latest_target):
    """The abort's verdict at t [s] (module doc). ``p``: the supervisor's parameters; ``chaser``: the latest chaser
    estimate (t, r_hill, v_hill); ``pending``: guidance's burns after it; ``spinning_target``: the latest target
    estimate with a spin axis (t, q_hill_from_body, omega_body) or None (the region that holds the body at every
    attitude: a filter just restarted has no spin axis); t_latest_target [s]: the latest target estimate's stamp."""
    t_c, r, v = chaser
    burns = pending.after(t_c)
    t_burn_s = max(max(t, t_c) + p.command_lead_s, burns[-1][0] if burns else -np.inf)
    state = coast_through(r, v, t_c, t_burn_s, burns, p.n_rad_s)
    queued = f'; through guidance\'s burns still to fly ({len(burns)})' if burns else ''
    if np.linalg.norm(state[:3]) < p.restriction_sphere_radius_m + p.sphere_margin_m:
        return EscapeVerdict(t_burn_s, None, np.nan, np.nan, queued, True)
    if spinning_target is not None:
        t_t, q_hb, omega_body = spinning_target
        region = swept_region(p.boxes, p.target_inertia_kg_m2, [q_eci_from_body(t_t, p.n_rad_s, q_hb)], [omega_body])
        basis = '' if t_t == t_latest_target else f' (region about the spin axis of t = {t_t:.2f} s)'
    else:
        region = any_attitude_region(p.boxes)
        basis = ' (no target estimate with a spin axis: the region of every attitude)'
    dv, before, after = avoidance_burn(state[:3], state[3:], t_burn_s, region, p.planner, p.avoidance_delta_v_mps)
    return EscapeVerdict(t_burn_s, dv, before, after, basis + queued, False)


@dataclasses.dataclass(frozen=True)
class AvoidanceBurn:
    """The collision-avoidance impulse of an abort: start time t [s], dv_hill [m/s] (guidance/maneuver)."""

    t: float
    dv_hill: np.ndarray


def escape_outputs(p, t, chaser, pending, spinning_target, t_latest_target):
    """After an abort or a retreat at t [s]: [AvoidanceBurn] where the coast through the burns still to fly is unsafe
    (escape_check), and the verdict as an event's (level, name, message, values). Nothing without a chaser estimate
    or a target estimate (t_latest_target None). The region is swept about the spin axis of the latest target
    estimate that has one, else it holds the body at every attitude. Never raising: the abort must be published (a
    raise fences the supervisor's core off, and the mission would idle in the phase it aborted from, fd_s8 run 59)."""
    if chaser is None or t_latest_target is None:
        return []
    verdict = escape_check(p, t, chaser, pending, spinning_target, t_latest_target)
    basis = verdict.basis
    if verdict.inside_sphere:
        return [('WARN', events.NO_AVOIDANCE_BURN, f'inside the restriction sphere: coasting, never thrusting{basis}',
                 {})]
    if verdict.dv_hill_mps is None:
        return [('OK', events.NO_AVOIDANCE_BURN, f'the coast is passively safe (least clearance '
                                                 f'{verdict.before_m:.2f} m){basis}',
                 {'clearance_m': verdict.before_m})]
    dv = verdict.dv_hill_mps
    return [AvoidanceBurn(verdict.t_burn_s, dv),
            ('WARN', events.AVOIDANCE_BURN, f'coast would come {verdict.before_m:.2f} m from the keep-out region; burn '
                                            f'of {np.linalg.norm(dv):.3f} m/s at t = {verdict.t_burn_s:.2f} s keeps '
                                            f'{verdict.after_m:.2f} m{basis}',
             {'dv_hill_mps': [float(x) for x in dv]})]
