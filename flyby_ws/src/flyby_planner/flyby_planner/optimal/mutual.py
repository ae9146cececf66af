"""Mutual safety against another robot's published plan (seed 003 section 4.2, Fig 12).

The chasers of a ``chasers:`` scenario plan in the file's order: chaser i plans after chasers 0..i-1 have, with
their published trajectories (``/<name>/planner/trajectory``) as known moving obstacles. Seed 003 section 4.2
"applies a safety metric to the relative motion between robots in addition to the relative motion of each robot
with the target"; with the other robot's motion known, the robot-to-robot terms become terms of one robot's
program of the same form as the target's boxes (scp.py):

* keep-out: at every check point k the supporting plane of the other robot's keep-out sphere (its envelope plus
  a margin) at the reference, n_k . r_k >= n_k . p_k + R_other + margin + R_own (+ SCP's keep-out margin), with
  n_k = (r_ref,k - p_k) / |r_ref,k - p_k|: linear in r_k, and a point on the far side of a supporting plane is
  outside the sphere, so |r_k - p_k| >= the same bound;
* mutual safety k_s max(0, closing)^2 / gap (cost.mutual_safety_metric), closing = -n . (v - v_p), its position
  gradient -(I - n n') (v - v_p) / |r - p| analytic.

The other robot's motion (``MovingObstacle``): its trajectory's points (cubic Hermite in position and velocity,
exact for the quadratic arcs of a held thrust up to the CW terms); before its first point a CW coast (it holds its
safe state until its start); after its last point, where a target's attitude is given, the body-fixed point it
ended at (a captured robot turns with the target), else a CW coast.

Frames and units as in flyby_planner.optimal.problem (hill, velocities relative to the rotating hill frame, SI).
"""

import dataclasses

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from flyby_planner.optimal.cost import _penalty, midpoint_times, mutual_safety_metric
from flyby_sim.dynamics.orbital import cw_transition_matrix

# Samples per second of the dense separation check of a plan (as approach.check_approach's).
CHECK_RATE_HZ = 20.0


@dataclasses.dataclass(frozen=True)
class MovingObstacle:
    """Another robot's planned motion: name; t_s (K,) [s], r_hill (K, 3) [m], v_hill (K, 3) [m/s] its trajectory's
    points (K >= 2, increasing times); envelope_radius_m [m]; margin_m [m] kept beyond its envelope by a plan;
    n the mean motion [rad/s]; attitude: None, or times (M,) -> (C_hill_from_body (M, 3, 3), omega_rel_hill (M, 3))
    (problem.TargetMotion.attitude) to carry it with the target after its last point."""

    name: str
    t_s: np.ndarray
    r_hill: np.ndarray
    v_hill: np.ndarray
    envelope_radius_m: float
    margin_m: float
    n: float
    attitude: object = None

    def __post_init__(self):
        t = np.asarray(self.t_s, dtype=float)
        if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) <= 0.0):
            raise ValueError(f'obstacle {self.name}: t_s must hold at least two increasing times, got {t}')
        for key in ('r_hill', 'v_hill'):
            shape = np.shape(getattr(self, key))
            if shape != (len(t), 3):
                raise ValueError(f'obstacle {self.name}: {key} must be ({len(t)}, 3), got {shape}')
        if not (self.envelope_radius_m >= 0.0 and self.margin_m >= 0.0):
            raise ValueError(f'obstacle {self.name}: envelope_radius_m and margin_m must be >= 0, got '
                             f'{self.envelope_radius_m}, {self.margin_m}')

    @property
    def keepout_radius_m(self):
        """The sphere a plan keeps its envelope out of: the envelope plus the margin [m]."""
        return self.envelope_radius_m + self.margin_m

    def state(self, times):
        """(r_hill (M, 3), v_hill (M, 3)) at the times (M,) [s] (module doc)."""
        t = np.atleast_1d(np.asarray(times, dtype=float))
        t_s, r_s, v_s = (np.asarray(a, dtype=float) for a in (self.t_s, self.r_hill, self.v_hill))
        r, v = np.empty((len(t), 3)), np.empty((len(t), 3))
        inside = (t >= t_s[0]) & (t <= t_s[-1])
        if np.any(inside):
            spline = CubicHermiteSpline(t_s, r_s, v_s, axis=0)
            r[inside], v[inside] = spline(t[inside]), spline(t[inside], 1)
        before, after = t < t_s[0], t > t_s[-1]
        for mask, k in ((before, 0), (after, -1)):
            if not np.any(mask):
                continue
            if k == -1 and self.attitude is not None:  # turns with the target from the body point it ended at
                c_end, _ = self.attitude(t_s[-1:])
                p_body = c_end[0].T @ r_s[-1]
                c, omega_rel = self.attitude(t[mask])
                r[mask] = np.einsum('mij,j->mi', c, p_body)
                v[mask] = np.cross(omega_rel, r[mask])
                continue
            x = np.einsum('mij,j->mi', cw_transition_matrix(self.n, t[mask] - t_s[k]), np.concatenate((r_s[k], v_s[k])))
            r[mask], v[mask] = x[:, :3], x[:, 3:]
        return r, v


def obstacle_contacts(obstacles, t_check_s, r_ref, v_ref_node, node):
    """The obstacles as contacts of SCP's keep-out and safety terms (module doc), linearized at the reference.

    Args:
        obstacles: MovingObstacle list (O >= 1).
        t_check_s: (C,) the check points' times [s]; r_ref (C, 3) the reference there [m].
        v_ref_node: (N+1, 3) the reference velocity at the nodes [m/s]; node: the slice of the check points that
            are nodes.

    Returns:
        (q (O, C, 3) the closest point of each keep-out sphere [m], normal (O, C, 3) its outward unit normal toward
        the reference, closing (O, N+1) the reference's closing speed on the obstacle at the nodes [m/s], j_r
        (O, N+1, 3) its gradient in the position [1/s]).
    """
    r_ref = np.asarray(r_ref, dtype=float)
    out = [], [], [], []
    for obs in obstacles:
        p, v_p = obs.state(t_check_s)
        d = r_ref - p
        dist = np.linalg.norm(d, axis=1)
        normal = d / np.maximum(dist, 1e-9)[:, None]
        normal[dist < 1e-9] = (1.0, 0.0, 0.0)  # on the obstacle's centre: any plane pushes out
        dv = np.asarray(v_ref_node, dtype=float) - v_p[node]
        n_node = normal[node]
        closing = -np.einsum('ci,ci->c', n_node, dv)  # -n . (v - v_p)
        # d closing / d r = -(I - n n') (v - v_p) / |r - p|
        j_r = -(dv + closing[:, None] * n_node) / np.maximum(dist[node], 1e-9)[:, None]
        for acc, value in zip(out, (p + obs.keepout_radius_m * normal, normal, closing, j_r), strict=True):
            acc.append(value)
    return tuple(np.stack(a) for a in out)


def obstacle_cost(problems, plans, obstacles, samples, collision_penalty=0.0):
    """The mutual safety of plans (one per robot) against the obstacles on ``samples`` equal steps, weighted by each
    robot's k_s (seed 003 section 4.2), plus collision_penalty (1 + depth [m]) where an envelope enters an
    obstacle's keep-out sphere: the term scp adds to eq 5 (cost.total_cost) to judge its iterates."""
    if not obstacles:
        return 0.0
    tau, dt = midpoint_times(plans[0].duration_s, samples)
    total = 0.0
    for p, plan in zip(problems, plans, strict=True):
        traj = plan.sample(tau)
        for obs in obstacles:
            r_o, v_o = obs.state(traj.t_s)
            s, gap = mutual_safety_metric(traj.r_hill, traj.v_hill, r_o, v_o,
                                          p.chaser.envelope_radius_m + obs.keepout_radius_m)
            total += p.weights.safety * float(s.sum()) * dt + _penalty(float(gap.min()), collision_penalty)
    return total


@dataclasses.dataclass(frozen=True)
class Separation:
    """The least distance between a plan's envelope and an obstacle's envelope [m] (negative: they overlap), its
    time t_s [s] and the obstacle's name."""

    distance_m: float
    t_s: float
    name: str


def least_separation(plan, obstacles, envelope_radius_m, rate_hz=CHECK_RATE_HZ):
    """Separation of a plan (anything with t0_s, duration_s and sample(tau)) from the nearest obstacle, on dense
    samples at rate_hz over the plan (the check before it is flown); None without obstacles."""
    if not obstacles:
        return None
    steps = max(2, int(np.ceil(plan.duration_s * rate_hz)))
    traj = plan.sample(np.linspace(0.0, plan.duration_s, steps + 1))
    best = None
    for obs in obstacles:
        r_o, _ = obs.state(traj.t_s)
        gap = np.linalg.norm(traj.r_hill - r_o, axis=1) - envelope_radius_m - obs.envelope_radius_m
        k = int(np.argmin(gap))
        if best is None or gap[k] < best.distance_m:
            best = Separation(float(gap[k]), float(traj.t_s[k]), obs.name)
    return best
