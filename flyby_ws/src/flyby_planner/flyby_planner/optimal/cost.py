"""The cost of an approach trajectory, seed 003 eq 5, and its five performance metrics (section 4.1).

.. math:: P(\\nu) = \\sum_{p=1}^{m} (k_a a_p + k_f f_p + k_s s_p + k_{pi} pi_p) \\Delta t + k_t t_r^2   (5)

evaluated at m equal steps of the approach time t_r = T, each metric at the step's midpoint (the rectangle rule of
the integral eq 4). Paper notes (one line each; the tests named settle them):

* Eq 5 is garbled in the extracted text ("2 a p f p s p pi p t r m ( ) = (k a + k f + k s + k pi ) t + k tP ∆∑ν");
  read with the metric list above it: the four rate metrics summed over the m steps times Delta t plus k_t t_r^2
  (test_seed003_eq5_is_the_sum_of_the_weighted_terms).
* The safety penalty prints as "2 r s r sv /d→ →": v_{r->s}^2 / d_{r->s}, the robot's speed toward the satellite
  (or a panel) over its distance to it, Fig 9; we count only a closing speed (an opening one is safe), relative to
  the closest body point's own velocity, and the distance is the envelope's gap to the box
  (test_seed003_eq5_safety_term).
* Fuel "based on acceleration, mass of the robot, and specific impulse": f_p = m |a_p| / (Isp g0) [kg/s], the
  rocket equation to first order in the delta-v (test_seed003_eq5_fuel_term).
* Plume impingement "proportional to acceleration away from the satellite": the exhaust points opposite the
  thrust, so a thrust acceleration with a component away from the target's centre of mass sends its plume onto
  the target; pi_p = max(0, a_p . r_p / |r_p|) inside the plume radius (test_seed003_eq5_plume_term).
* Actuator limit, "limits acceleration ... to less than maximum possible": a_p = max(0, |a_p| / a_max - 1)^2, zero
  within the limit (test_seed003_eq5_actuator_term).

Frames and units as in flyby_planner.optimal.problem.
"""

import dataclasses
import math

import numpy as np

from flyby_sim.dynamics.geometry import signed_distance_to_box

# The safety metric divides by the gap; below this [m] (contact) it is held at this value.
GAP_FLOOR_M = 0.01


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """A sampled approach: times t_s (M,) [s], r_hill (M, 3) [m], v_hill (M, 3) [m/s] and the thrust
    acceleration a_hill (M, 3) [m/s^2] (what the thrusters add to the CW motion)."""

    t_s: np.ndarray
    r_hill: np.ndarray
    v_hill: np.ndarray
    a_hill: np.ndarray


def box_contacts(r_hill, c_hill_from_body, boxes):
    """Signed distance of hill points to each body box and the closest box point with its outward normal.

    Args:
        r_hill: (M, 3) points [m] (hill, from the target's centre of mass).
        c_hill_from_body: (M, 3, 3) target attitude at each point's time.
        boxes: flyby_sim.scenario.Boxes (K boxes).

    Returns:
        (distance (K, M) [m], negative inside; q_hill (K, M, 3) the closest box point [m]; normal_hill (K, M, 3)
        the unit outward normal there: from q toward the point outside, the nearest face's inside).
    """
    r = np.atleast_2d(np.asarray(r_hill, dtype=float))
    c = np.asarray(c_hill_from_body, dtype=float)
    p_body = np.einsum('mji,mj->mi', c, r)  # C' r
    k = len(boxes)
    distance = np.empty((k, r.shape[0]))
    q_hill = np.empty((k, r.shape[0], 3))
    normal_hill = np.empty((k, r.shape[0], 3))
    for i, (center, size) in enumerate(zip(boxes.center_body_m, boxes.size_m, strict=True)):
        half = 0.5 * np.asarray(size, dtype=float)
        d = p_body - center
        distance[i] = signed_distance_to_box(p_body, center, size)
        q_body = center + np.clip(d, -half, half)
        diff = p_body - q_body
        norm = np.linalg.norm(diff, axis=1)
        outside = norm > 0.0
        n_body = np.zeros_like(d)
        n_body[outside] = diff[outside] / norm[outside, None]
        # inside (or on) the box: the face of least depth
        inside = ~outside
        if np.any(inside):
            depth = np.abs(d[inside]) - half
            axis = np.argmax(depth, axis=1)
            rows = np.flatnonzero(inside)
            sign = np.where(d[rows, axis] >= 0.0, 1.0, -1.0)
            n_body[rows, axis] = sign
            q_body[rows, axis] = center[axis] + sign * half[axis]
        q_hill[i] = np.einsum('mij,mj->mi', c, q_body)
        normal_hill[i] = np.einsum('mij,mj->mi', c, n_body)
    return distance, q_hill, normal_hill


def safety_metric(r_hill, v_hill, c_hill_from_body, omega_rel_hill, boxes, envelope_radius_m):
    """Safety metric s_p of seed 003 section 4.1 metric 1 (Fig 9), summed over the satellite's boxes.

    .. math:: s_p = \\sum_b \\max(0, v_{r \\to b})^2 / d_{r \\to b}

    v_{r->b} is the chaser's speed toward box b relative to the box's closest point (which moves at
    omega_rel x q relative to hill), d_{r->b} the gap between the chaser envelope and the box, held at GAP_FLOOR_M.

    Returns:
        (s_p (M,) [m/s^2], the least gap over the boxes (M,) [m]).
    """
    distance, q_hill, normal_hill = box_contacts(r_hill, c_hill_from_body, boxes)
    v_point = np.cross(np.asarray(omega_rel_hill, dtype=float)[None, :, :], q_hill)
    closing = -np.sum(normal_hill * (np.asarray(v_hill, dtype=float)[None] - v_point), axis=2)
    gap = distance - envelope_radius_m
    s = np.sum(np.maximum(closing, 0.0) ** 2 / np.maximum(gap, GAP_FLOOR_M), axis=0)
    return s, gap.min(axis=0)


def mutual_safety_metric(r1_hill, v1_hill, r2_hill, v2_hill, separation_m):
    """The safety metric between two robots (seed 003 section 4.2, multiple robots): max(0, closing)^2 / gap.

    separation_m is the sum of the two envelope radii; returns (s_p (M,) [m/s^2], gap (M,) [m]).
    """
    dr = np.asarray(r1_hill, dtype=float) - np.asarray(r2_hill, dtype=float)
    dv = np.asarray(v1_hill, dtype=float) - np.asarray(v2_hill, dtype=float)
    distance = np.linalg.norm(dr, axis=1)
    closing = -np.sum(dr * dv, axis=1) / np.maximum(distance, 1e-12)
    gap = distance - separation_m
    return np.maximum(closing, 0.0) ** 2 / np.maximum(gap, GAP_FLOOR_M), gap


def actuator_metric(a_hill, accel_max_mps2):
    """Actuator-limit metric a_p = max(0, |a| / a_max - 1)^2 (seed 003 metric 2), (M,)."""
    return np.maximum(np.linalg.norm(a_hill, axis=1) / accel_max_mps2 - 1.0, 0.0) ** 2


def fuel_metric(a_hill, mass_kg, exhaust_velocity_mps):
    """Fuel rate f_p = m |a| / (Isp g0) [kg/s] (seed 003 metric 3), (M,)."""
    return mass_kg * np.linalg.norm(a_hill, axis=1) / exhaust_velocity_mps


def plume_metric(r_hill, a_hill, plume_radius_m):
    """Plume metric pi_p = max(0, a . r / |r|) inside plume_radius_m of the centre of mass [m/s^2] (seed 003
    metric 4; module doc), (M,)."""
    r = np.asarray(r_hill, dtype=float)
    distance = np.linalg.norm(r, axis=1)
    away = np.sum(np.asarray(a_hill, dtype=float) * r, axis=1) / np.maximum(distance, 1e-12)
    return np.where(distance < plume_radius_m, np.maximum(away, 0.0), 0.0)


@dataclasses.dataclass(frozen=True)
class CostTerms:
    """Eq 5 of one trajectory, term by term (weighted), with the figures of Table 1.

    actuator, fuel, safety, plume, time, mutual: the weighted terms (mutual: the robots' safety metric, seed 003
    section 4.2, counted with k_s); duration_s [s]; fuel_kg: sum of f_p Delta t [kg]; delta_v_mps: integral of
    |a| [m/s]; peak_accel_mps2; clearance_min_m: least envelope gap to the boxes at the samples [m].
    """

    actuator: float
    fuel: float
    safety: float
    plume: float
    time: float
    duration_s: float
    fuel_kg: float
    delta_v_mps: float
    peak_accel_mps2: float
    clearance_min_m: float
    mutual: float = 0.0

    @property
    def total(self):
        """P of eq 5 (with the mutual term of several robots)."""
        return self.actuator + self.fuel + self.safety + self.plume + self.time + self.mutual


def midpoint_times(duration_s, steps):
    """The m = steps midpoints [s from the start] and Delta t of eq 5's rectangle rule over [0, duration_s]."""
    dt = duration_s / steps
    return (np.arange(steps) + 0.5) * dt, dt


def eq5_terms(problem, trajectory, dt_s, duration_s):
    """CostTerms of seed 003 eq 5 of a trajectory sampled at the midpoints of equal steps dt_s (midpoint_times).

    trajectory.t_s are absolute times (problem.t0_s + midpoints); the target's attitude is taken at them.
    """
    w, ch = problem.weights, problem.chaser
    a = trajectory.a_hill
    a_p = actuator_metric(a, ch.accel_max_mps2)
    f_p = fuel_metric(a, ch.mass_kg, ch.exhaust_velocity_mps)
    pi_p = plume_metric(trajectory.r_hill, a, problem.plume_radius_m)
    if problem.target is not None:
        c, omega_rel = problem.target.attitude(trajectory.t_s)
        s_p, gap = safety_metric(trajectory.r_hill, trajectory.v_hill, c, omega_rel, problem.target.boxes,
                                 ch.envelope_radius_m)
        clearance_min = float(gap.min())
    else:
        s_p, clearance_min = np.zeros(len(a)), math.inf
    accel = np.linalg.norm(a, axis=1)
    return CostTerms(
        actuator=w.actuator * float(a_p.sum()) * dt_s,
        fuel=w.fuel_per_kg * float(f_p.sum()) * dt_s,
        safety=w.safety * float(s_p.sum()) * dt_s,
        plume=w.plume * float(pi_p.sum()) * dt_s,
        time=w.time * duration_s ** 2,  # eq 5: k_t t_r^2
        duration_s=float(duration_s), fuel_kg=float(f_p.sum()) * dt_s, delta_v_mps=float(accel.sum()) * dt_s,
        peak_accel_mps2=float(accel.max()), clearance_min_m=clearance_min)


def plan_terms(problem, plan, steps=600):
    """CostTerms of eq 5 of a plan (anything with duration_s and sample(tau) -> Trajectory, tau from t0_s) on
    ``steps`` equal steps: the common yardstick of both solvers."""
    tau, dt = midpoint_times(plan.duration_s, steps)
    return eq5_terms(problem, plan.sample(tau), dt, plan.duration_s)


def _penalty(least_gap_m, collision_penalty):
    """collision_penalty (1 + depth) for a least gap below zero, else 0."""
    return collision_penalty * (1.0 - least_gap_m) if least_gap_m < 0.0 else 0.0


def total_cost(problems, plans, samples, collision_penalty=0.0, separate=True):
    """P of eq 5 of plans (one per robot, one approach time) on ``samples`` equal steps, summed over the robots, with
    each pair's mutual safety (seed 003 section 4.2, weighted by k_s) when ``separate``, plus collision_penalty
    (1 + depth [m]) for a sample where an envelope touches the target's boxes or another robot's envelope."""
    duration = plans[0].duration_s
    tau, dt = midpoint_times(duration, samples)
    trajectories = [plan.sample(tau) for plan in plans]
    total = 0.0
    for p, traj in zip(problems, trajectories, strict=True):
        terms = eq5_terms(p, traj, dt, duration)
        total += terms.total + _penalty(terms.clearance_min_m, collision_penalty)
    if separate:
        for i in range(len(problems)):
            for j in range(i + 1, len(problems)):
                s, gap = mutual_safety_metric(trajectories[i].r_hill, trajectories[i].v_hill, trajectories[j].r_hill,
                                              trajectories[j].v_hill, problems[i].chaser.envelope_radius_m
                                              + problems[j].chaser.envelope_radius_m)
                least = float(gap.min())
                total += problems[i].weights.safety * float(s.sum()) * dt  # section 4.2, robot to robot
                total += _penalty(least, collision_penalty)
    return total
