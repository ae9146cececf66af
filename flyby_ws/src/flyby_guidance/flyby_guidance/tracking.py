"""Tracking of an optimization-based approach (seed 003 section 4; DESIGN §10 ``OPTIMAL_APPROACH``), no ROS.

The planner's trajectory (planner/trajectory: times, r_hill, v_hill and the thrust acceleration a_hill it was
planned with, held over each step) is flown with continuous force commands: the commanded thrust acceleration is
the plan's feed-forward plus a critically damped feedback on the navigation estimate,

    a = a_ref + w^2 (r_ref - r) + 2 w (v_ref - v),

(the CW terms are the plan's: a is what the thrusters add to the relative motion, seed 000 eq 2), then

* the plume rule (seed 003 metric 4 as a rule): where the estimate, carried at its velocity to the end of the
  command's hold, comes within the plume radius plus PLUME_MARGIN_M (the estimate's error;
  flyby_planner.optimal.problem, whose plans keep the rule from twice that margin out) of the target's centre of
  mass, the component of a pointing away from the target (the exhaust toward it) is removed, for the direction to
  the target now and at the hold's end;
* the acceleration bound: |a| <= accel_max (the plan keeps a share of it for this feedback, planner.optimal).

The reference between two points is the cubic Hermite interpolant of the positions and velocities; the
feed-forward of a command is the mean over its hold of the plan's acceleration, held from each point to the next
(the planner puts points on the plan's step boundaries, where its thrust changes). After the trajectory's end
nothing is commanded (the supervisor decides the capture at the grasp time, the trajectory's end).

``ReferenceTrajectory.error`` is the estimate's distance from the reference; guidance asks for a re-plan when it
exceeds planner.optimal.replan_error_m (outside the last replan_cutoff_s).

Frames and units: hill (flyby_sim.dynamics.orbital), velocities relative to the rotating hill frame, SI.
"""

import numpy as np

from flyby_msgs_py import params
from flyby_planner.optimal.problem import PLUME_MARGIN_M


def _tracking_accel_max_mps2(scenario):
    """The commanded bound: planner.optimal.accel_max_mps2 (omitted: chaser.thrusters.max_thrust_n / mass_kg) less
    3 sigma of the thrusters' magnitude error, so that what they give stays within it."""
    o, th = scenario.planner.optimal, scenario.chaser.thrusters
    accel = th.max_thrust_n / scenario.chaser.mass_kg if o.accel_max_mps2 is None else o.accel_max_mps2
    return accel * (1.0 - 3.0 * th.magnitude_error_sigma)


@params.record
class TrackingConfig:
    """accel_max_mps2: largest commanded thrust acceleration [m/s^2]; plume_radius_m [m]; frequency_rad_s: the
    feedback's natural frequency w [rad/s]; replan_error_m: the position error that asks for a re-plan [m];
    replan_cutoff_s: no re-plan request this close to the trajectory's end [s]. The tracking mode's record of
    planner.optimal (``flyby_msgs_py.params``)."""

    accel_max_mps2: float = params.derived(_tracking_accel_max_mps2)
    plume_radius_m: float = params.key('planner.optimal.plume_radius_m')
    frequency_rad_s: float = params.key('planner.optimal.tracking_frequency_rad_s')
    replan_error_m: float = params.key('planner.optimal.replan_error_m')
    replan_cutoff_s: float = params.key('planner.optimal.replan_cutoff_s')


class ReferenceTrajectory:
    """The planned trajectory: t_s (M,) [s], r_hill (M, 3) [m], v_hill (M, 3) [m/s], a_hill (M, 3) [m/s^2]."""

    def __init__(self, t_s, r_hill, v_hill, a_hill):
        self.t_s = np.asarray(t_s, dtype=float)
        self.r_hill = np.asarray(r_hill, dtype=float)
        self.v_hill = np.asarray(v_hill, dtype=float)
        self.a_hill = np.asarray(a_hill, dtype=float)
        if len(self.t_s) < 2 or np.any(np.diff(self.t_s) <= 0.0):
            raise ValueError(f'a reference trajectory needs at least 2 points in increasing time, got {self.t_s!r}')

    @property
    def t_start(self):
        return float(self.t_s[0])

    @property
    def t_end(self):
        return float(self.t_s[-1])

    def at(self, t):
        """(r_ref [m], v_ref [m/s], a_ref [m/s^2]) at time t [s], clamped to the trajectory's span (a_ref zero
        after its end)."""
        ts = self.t_s
        if t >= ts[-1]:
            return self.r_hill[-1].copy(), self.v_hill[-1].copy(), np.zeros(3)
        t = max(float(t), ts[0])
        k = int(np.searchsorted(ts, t, side='right') - 1)
        h = ts[k + 1] - ts[k]
        s = (t - ts[k]) / h
        r0, r1, v0, v1 = self.r_hill[k], self.r_hill[k + 1], self.v_hill[k] * h, self.v_hill[k + 1] * h
        # cubic Hermite basis and its derivative in s
        r = ((2 * s ** 3 - 3 * s ** 2 + 1) * r0 + (s ** 3 - 2 * s ** 2 + s) * v0 + (-2 * s ** 3 + 3 * s ** 2) * r1
             + (s ** 3 - s ** 2) * v1)
        dr = ((6 * s ** 2 - 6 * s) * r0 + (3 * s ** 2 - 4 * s + 1) * v0 + (-6 * s ** 2 + 6 * s) * r1
              + (3 * s ** 2 - 2 * s) * v1)
        return r, dr / h, self.a_hill[k].copy()

    def mean_acceleration(self, t0, t1):
        """Mean [m/s^2] over [t0, t1] (t1 > t0) of the held acceleration (zero outside the trajectory)."""
        edges = np.clip(np.concatenate(((t0,), self.t_s[(self.t_s > t0) & (self.t_s < t1)], (t1,))),
                        self.t_s[0], self.t_s[-1])
        k = np.clip(np.searchsorted(self.t_s, edges[:-1], side='right') - 1, 0, len(self.t_s) - 2)
        return np.diff(edges) @ self.a_hill[k] / (t1 - t0)

    def error(self, t, r_hill):
        """Distance [m] of a position at t from the reference."""
        return float(np.linalg.norm(np.asarray(r_hill, dtype=float) - self.at(t)[0]))


def plume_rule(a_hill, r_hill, plume_radius_m, v_hill=(0.0, 0.0, 0.0), ahead_s=0.0):
    """a_hill [m/s^2] without its component away from the target where the chaser at r_hill [m] (from the target's
    centre of mass), moving at v_hill [m/s] for ahead_s [s] (the command's delay and hold), comes within
    plume_radius_m + PLUME_MARGIN_M of it: no exhaust toward the target (seed 003 metric 4). The away component is
    removed for the direction to the target now, then for the one at the end of ahead_s (after the first removal
    the second leaves the first direction's component non-positive, the two being less than 90 deg apart). A radius of
    zero is no rule."""
    a = np.asarray(a_hill, dtype=float)
    if plume_radius_m <= 0.0:  # no rule (the synchronized approach's link)
        return a
    r0 = np.asarray(r_hill, dtype=float)
    r1 = r0 + np.asarray(v_hill, dtype=float) * ahead_s
    step = r1 - r0
    s = 0.0 if not step.any() else min(max(-float(r0 @ step) / float(step @ step), 0.0), 1.0)
    if float(np.linalg.norm(r0 + s * step)) >= plume_radius_m + PLUME_MARGIN_M:
        return a
    for r in (r0, r1):
        dist = float(np.linalg.norm(r))
        if dist == 0.0:
            continue
        u = r / dist
        away = float(a @ u)
        if away > 0.0:
            a = a - away * u
    return a


def tracking_acceleration(reference, t_apply, hold_s, t_estimate, r_hill, v_hill, config):
    """The thrust acceleration [m/s^2, hill] to hold from t_apply for hold_s [s], from the estimate (r_hill [m],
    v_hill [m/s]) of t_estimate [s] (module doc): the reference's feed-forward over the hold, feedback on the error at
    the estimate's time, the plume rule, the bound. Zero outside the trajectory's span."""
    if not reference.t_start <= t_apply < reference.t_end:
        return np.zeros(3)
    r_ref, v_ref, _ = reference.at(t_estimate)
    a_ff = reference.mean_acceleration(t_apply, t_apply + hold_s)
    w = config.frequency_rad_s
    a = a_ff + w * w * (r_ref - r_hill) + 2.0 * w * (v_ref - v_hill)
    a = plume_rule(a, r_hill, config.plume_radius_m, v_hill, t_apply + hold_s - t_estimate)
    norm = float(np.linalg.norm(a))
    if norm > config.accel_max_mps2:
        a = a * (config.accel_max_mps2 / norm)
    return a
