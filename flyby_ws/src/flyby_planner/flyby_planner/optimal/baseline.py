"""The paper's planner: Nelder-Mead on the eq 5 cost of a parabolic-spline path, seed 003 section 4.1 (eq 3-7).

* Eq 3: the path T = f(nu), nu = (W_1..W_n, T) (flyby_planner.optimal.spline.parabolic_path); several robots
  approaching together stack their waypoints and share T.
* Eq 5: P(nu), flyby_planner.optimal.cost.eq5_terms on ``samples`` equal steps; several robots add their terms
  and the mutual safety metric of each pair (section 4.2: "applying a safety metric to the relative motion between
  robots"). A path whose envelope touches the target's boxes (or another robot's envelope) at a sample costs
  ``collision_penalty`` (1 + depth [m]) more: outside the paper's eq 5, it keeps the search on the collision-free
  side its start is on.
* Eq 6: nu* = argmin P(nu) by Nelder-Mead (scipy.optimize.minimize), "because it does not require an explicit
  representation of the gradient"; the start is the heuristic collision-free route
  (flyby_planner.optimal.problem.heuristic_route) sampled at the knots.
* "When the trajectory has been optimized for a given set of n waypoints, n is incremented and a new P(nu*) is
  found. This process is repeated while the addition of waypoints significantly improves the total cost":
  stages n = 1, 2, ..., each started from the previous optimum's path sampled at the new knots, stop when
  P_n - P_n+1 < ``tolerance`` (or at ``waypoints_max``); eq 7, the plan is the best stage's path.
"""

import dataclasses
import math
import time

import numpy as np
from scipy.optimize import minimize

from flyby_planner.optimal.cost import total_cost
from flyby_planner.optimal.problem import heuristic_route
from flyby_planner.optimal.spline import parabolic_path


@dataclasses.dataclass(frozen=True)
class NelderMeadSettings:
    """waypoints_max: the last stage's n; tolerance: the least eq 5 improvement that earns another waypoint;
    max_evaluations: of P per stage; samples: m of eq 5; simplex_step_m, simplex_step_s: the initial simplex's
    size on the waypoints [m] and T [s]; collision_penalty (module doc); xatol_m, fatol: Nelder-Mead's stop."""

    waypoints_max: int = 6
    tolerance: float = 0.05
    max_evaluations: int = 4000
    samples: int = 200
    simplex_step_m: float = 3.0
    simplex_step_s: float = 5.0
    collision_penalty: float = 1e4
    xatol_m: float = 1e-3
    fatol: float = 1e-4


@dataclasses.dataclass(frozen=True)
class NelderMeadResult:
    """plans: one ParabolicPath per robot (the best stage); stages: (n, P_n) of every stage in order; evaluations of
    P in all; wall_time_s."""

    plans: list
    stages: list
    evaluations: int
    wall_time_s: float

    @property
    def waypoints(self):
        """n of the plan chosen."""
        return min(self.stages, key=lambda s: s[1])[0]


def _paths(problems, nu, waypoints, duration_s):
    """The robots' paths of a parameter vector (module doc); duration_s None: T is its last entry."""
    t_f = float(nu[-1]) if duration_s is None else duration_s
    per = 3 * waypoints
    return [parabolic_path(p.r0_hill, p.v0_hill, nu[i * per:(i + 1) * per].reshape(-1, 3), *p.end_state(t_f), t_f,
                           p.n, p.t0_s) for i, p in enumerate(problems)], t_f


def plan_nelder_mead(problems, settings=NelderMeadSettings(), duration_s=None, duration0_s=None, separate=True):
    """Plan one or several robots' approach by the paper's method (module doc).

    Args:
        problems: list of ApproachProblem (several: they approach together and share T).
        settings: NelderMeadSettings.
        duration_s: a fixed approach time [s]; None: T is a parameter in [duration_min_s, duration_max_s] of the
            first problem, started at duration0_s (default the middle of that range).
        separate: count the robots' mutual safety.

    Returns:
        NelderMeadResult.
    """
    start = time.perf_counter()
    p0 = problems[0]
    t_start = duration_s if duration_s is not None else (
        duration0_s if duration0_s is not None else 0.5 * (p0.duration_min_s + p0.duration_max_s))
    routes = [heuristic_route(p, t_start) for p in problems]
    evaluations = 0

    def cost(nu, waypoints):
        nonlocal evaluations
        evaluations += 1
        if duration_s is None and not (p0.duration_min_s <= nu[-1] <= p0.duration_max_s):
            return settings.collision_penalty * (1.0 + abs(nu[-1] - np.clip(nu[-1], p0.duration_min_s,
                                                                          p0.duration_max_s)))
        plans, _ = _paths(problems, nu, waypoints, duration_s)
        return total_cost(problems, plans, settings.samples, settings.collision_penalty, separate)

    stages, best, best_cost, previous = [], None, math.inf, None
    for waypoints in range(1, settings.waypoints_max + 1):
        fractions = np.arange(1, waypoints + 1) / (waypoints + 1)
        if previous is None:
            w0 = np.concatenate([route(fractions).reshape(-1) for route in routes])
            t0 = t_start
        else:  # the previous optimum's path at the new knots
            t0 = previous[0].duration_s
            w0 = np.concatenate([plan.kinematics(fractions * t0)[0].reshape(-1) for plan in previous])
        nu0 = w0 if duration_s is not None else np.append(w0, t0)
        steps = np.full(len(nu0), settings.simplex_step_m)
        if duration_s is None:
            steps[-1] = settings.simplex_step_s
        simplex = np.vstack((nu0, nu0 + np.diag(steps)))
        result = minimize(cost, nu0, args=(waypoints,), method='Nelder-Mead',
                          options={'initial_simplex': simplex, 'maxfev': settings.max_evaluations,
                                   'xatol': settings.xatol_m, 'fatol': settings.fatol})  # eq 6
        plans, _ = _paths(problems, result.x, waypoints, duration_s)
        stages.append((waypoints, float(result.fun)))
        improvement = best_cost - result.fun
        if result.fun < best_cost:
            best, best_cost = plans, float(result.fun)
        previous = plans
        if improvement < settings.tolerance:  # the stop rule of section 4.1: P_n - P_n+1 below a tolerance
            break
    return NelderMeadResult(plans=best, stages=stages, evaluations=evaluations,
                            wall_time_s=time.perf_counter() - start)
