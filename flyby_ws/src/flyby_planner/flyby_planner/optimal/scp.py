"""Sequential convex programming of the seed 003 approach: the same problem as the Nelder-Mead baseline, solved
as a sequence of second-order cone programs (cvxpy, Clarabel).

Model, one robot (several are stacked with a common time grid):

* Thrust acceleration u_k held over N equal steps h = T / N (zero-order hold); the state [r; v] follows the
  Clohessy-Wiltshire motion exactly: x_k+1 = Phi(h) x_k + Gamma(h) u_k with Phi of seed 000 eq 22
  (flyby_sim.dynamics.orbital.cw_transition_matrix) and Gamma(h) = int_0^h Phi(s) [0; I] ds (zoh_input_matrix).
* x_0 = the chaser's state now; x_N = X_Ft, V_Ft of the grasp point at t0 + T (seed 000 eq 20-21).
* |u_k| <= a_max (second-order cones): the actuator metric of eq 5 is then zero.
* Keep-out against the target's real geometry at each time: at M check points per step (the nodes and M - 1 inside
  the step, where the position is affine in x_k, u_k), for every box, the supporting plane of the box at its point
  closest to the reference position, turned with the predicted attitude of that time:
  n . r >= n . q + envelope + margin. A point on the far side of a supporting plane is outside the convex box, so
  every iterate meets the keep-out at the check points, not only the converged one (but for a virtual buffer
  priced at keepout_penalty, which lets a first reference that the planes and the dynamics cannot both meet
  through; the exact cost's collision penalty and the converged plans' clearance, tested, show none is left).
* Plume rule, seed 003 metric 4 as a constraint: where the reference is within the plume radius (plus a margin),
  u_k . r_hat + sin(alpha) |u_k| <= 0 at every check point of the step and at its end, r_hat the reference's
  direction from the target and alpha the largest angle a position within plume_trust_m of it can turn that
  direction by: no thrust component away from the target, so the exhaust never has a component toward it. A virtual
  buffer (SCvx) priced at buffer_penalty k_pi keeps an early linearization feasible; the converged plans have none
  (test). The first reference is solved without the rule (a continuation), which then only reshapes its braking.
* Several robots: the robots' envelopes apart at every check point, n_ref . (r_1 - r_2) >= R_1 + R_2 + margin with
  n_ref the reference's unit separation, which implies |r_1 - r_2| >= R_1 + R_2 + margin.
* Objective: eq 5 made convex about the reference -- fuel k_f m / (Isp g0) sum |u_k| h (exact); safety
  k_s h sum ratio with ratio >= closing^2 / gap (a rotated cone), closing the speed toward each box's closest point
  to first order in r and v (its position gradient by differences: the normal and the closest point turn as the
  chaser moves) and gap the distance to the box's supporting plane (a lower bound: the box is convex); the robots'
  mutual safety likewise. k_t T^2 is a constant for a given T, which an outer golden-section search chooses on the
  exact eq 5 of each converged plan. With k_s = 0 (least fuel) the program has no safety cones: its objective is the
  delta-v priced, keep-out and plume constraints alone.
* Trust region |r_k - r_ref,k| <= rho_k, rho_k = min(rho, max(trust_fraction |r_ref,k|, trust_min_m)) (near the
  target the linearizations hold over a shorter distance). Each iterate is judged on the exact eq 5
  (cost.total_cost): a lower cost is accepted and rho doubles, a higher one is rejected and rho shrinks; the
  iterations stop when the nodes move less than the tolerance or the cost falls by less than merit_tolerance.

The program of one iteration is ``program.ScpProgram``; ``delta_v_bound.delta_v_lower_bound`` gives the least delta-v
any path can have for a time and acceleration bound, whatever its shape (keep-out and plume only add constraints).
"""

import dataclasses
import math
import time

import cvxpy as cp
import numpy as np
from scipy.optimize import minimize_scalar

from flyby_planner.optimal import mutual
from flyby_planner.optimal.cost import Trajectory, box_contacts, total_cost
from flyby_planner.optimal.problem import heuristic_route
from flyby_planner.optimal.program import program_for, solver_options
from flyby_sim.dynamics.orbital import cw_transition_matrix

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(8)
# The cost the search over T sees where no plan exists (finite: the bounded golden-section search does arithmetic on
# it).
_INFEASIBLE = 1e9
# Thrust away from the target inside the plume radius that counts as none [m/s^2] (the solver's tolerance).
_PLUME_TOLERANCE_MPS2 = 1e-6


def zoh_input_matrix(n, tau_s):
    """Gamma(tau) = int_0^tau Phi(s)[:, 3:] ds: the state a unit constant thrust acceleration adds over tau [s].

    Phi is the CW transition of seed 000 eq 22; the integral is 8-point Gauss-Legendre on its sines and cosines,
    exact to round-off for n tau << 1 (test_zoh_input_matrix_matches_integration). tau_s scalar: (6, 3);
    (M,): (M, 6, 3).
    """
    tau = np.asarray(tau_s, dtype=float)
    s = 0.5 * tau[..., None] * (_GAUSS_X + 1.0)  # (..., 8) nodes on [0, tau]
    phi = cw_transition_matrix(n, s.reshape(-1)).reshape(s.shape + (6, 6))
    return 0.5 * tau[..., None, None] * np.einsum('...g,...gij->...ij', np.broadcast_to(_GAUSS_W, s.shape),
                                                  phi[..., :, 3:])


@dataclasses.dataclass(frozen=True)
class ZohPlan:
    """A planned approach: thrust acceleration u_hill (N, 3) [m/s^2] held over N equal steps from t0_s [s], node
    states x_hill (N+1, 6) [m, m/s] (hill, relative velocity), n the mean motion [rad/s]."""

    t0_s: float
    duration_s: float
    x_hill: np.ndarray
    u_hill: np.ndarray
    n: float

    @property
    def step_s(self):
        return self.duration_s / len(self.u_hill)

    def sample(self, tau):
        """Trajectory at tau (M,) [s from the start]: the exact CW motion under the held thrust."""
        tau = np.clip(np.atleast_1d(np.asarray(tau, dtype=float)), 0.0, self.duration_s)
        h = self.step_s
        k = np.minimum((tau / h).astype(int), len(self.u_hill) - 1)
        s = tau - k * h
        x = (np.einsum('mij,mj->mi', cw_transition_matrix(self.n, s), self.x_hill[k])
             + np.einsum('mij,mj->mi', zoh_input_matrix(self.n, s), self.u_hill[k]))
        return Trajectory(self.t0_s + tau, x[:, :3], x[:, 3:], self.u_hill[k].copy())


@dataclasses.dataclass(frozen=True)
class ScpSettings:
    """steps N, check points M per step, keep-out and robot-separation margins [m], iteration limit, stop
    tolerance [m] on the nodes' move, trust region [m], plume margin [m] on the reference's distance, the conic
    solver and its thread count, and the golden-section search's tolerance on T [s]."""

    steps: int = 40
    substeps: int = 3
    keepout_margin_m: float = 0.05
    separation_margin_m: float = 0.5
    max_iterations: int = 12
    tolerance_m: float = 0.02
    trust_region_m: float = 15.0
    trust_fraction: float = 0.3
    trust_min_m: float = 0.5
    buffer_penalty: float = 10.0
    plume_trust_m: float = 0.05
    keepout_penalty: float = 1e3
    trust_shrink: float = 0.25
    plume_margin_m: float = 1.0
    solver: str = 'CLARABEL'
    solver_threads: int = 1
    duration_tolerance_s: float = 1.0
    merit_steps: int = 300
    merit_tolerance: float = 1e-3
    collision_penalty: float = 1e4


@dataclasses.dataclass(frozen=True)
class ScpResult:
    """plans: one ZohPlan per robot; iterations of the last solve; converged; objective of the last convex program;
    solves: convex programs solved in all; wall_time_s; durations_s: every T the search tried."""

    plans: list
    iterations: int
    converged: bool
    objective: float
    solves: int
    wall_time_s: float
    durations_s: tuple


class _Grid:
    """The check points of one time grid: N steps, M per step (check point k M + j at k h + j h / M, then the end),
    and the matrices giving their positions from the step's start state and thrust."""

    def __init__(self, n, duration_s, steps, substeps):
        self.steps, self.substeps = steps, substeps
        self.h = duration_s / steps
        self.phi = cw_transition_matrix(n, self.h)
        self.gamma = zoh_input_matrix(n, self.h)
        sub = np.arange(substeps) * self.h / substeps
        self.phi_r = cw_transition_matrix(n, sub)[:, :3, :]  # (M, 3, 6)
        self.gamma_r = zoh_input_matrix(n, sub)[:, :3, :]  # (M, 3, 3)
        self.tau = np.concatenate(((np.arange(steps)[:, None] * self.h + sub[None, :]).reshape(-1), [duration_s]))

    def split(self, a):
        """An array over the check points (N M + 1, ...) as M arrays (N, ...) and the end row (1, ...)."""
        main = a[:-1].reshape((self.steps, self.substeps) + a.shape[1:])
        return [main[:, j] for j in range(self.substeps)], a[-1:]


def _reference_from_route(problem, grid, duration_s):
    """Check positions (C, 3) and node velocities (N+1, 3) along the heuristic route (the first reference)."""
    r = heuristic_route(problem, duration_s)(grid.tau / duration_s)
    return r, np.gradient(r[::grid.substeps], grid.h, axis=0)


def _reference_from_plan(plan, grid):
    """Check positions and node velocities of a plan, its time stretched onto the grid's approach time."""
    traj = plan.sample(grid.tau * plan.duration_s / grid.tau[-1])
    return traj.r_hill, traj.v_hill[::grid.substeps]


def _closing_and_gradient(r_hill, v_hill, c_hill_from_body, omega_rel_hill, boxes, step_m=1e-4):
    """Closing speed (K, M) of points toward each box's closest point (safety metric, cost.safety_metric) and its
    gradient in the position (K, M, 3), by forward differences of step_m [m]."""
    def closing(r):
        _, q, normal = box_contacts(r, c_hill_from_body, boxes)
        return -np.sum(normal * (v_hill[None] - np.cross(omega_rel_hill[None], q)), axis=2)

    base = closing(r_hill)
    grad = np.stack([(closing(r_hill + step_m * e) - base) / step_m for e in np.eye(3)], axis=2)
    return base, grad


def _contacts(problem, att, grid, r_ref, v_ref, obstacles):
    """What the keep-out planes and the safety metric are linearized on, about the reference: the closest point
    q and outward normal at the check points (K, C, 3) each, the closing speed (K, N+1) at the nodes and its position
    gradient (K, N+1, 3) -- the target's boxes (att not None), then other robots' planned motion (mutual.py)."""
    node = slice(None, None, grid.substeps)
    parts = []
    if att is not None:
        c_hb, omega_rel = att
        _, q, normal = box_contacts(r_ref, c_hb, problem.target.boxes)
        parts.append((q, normal) + _closing_and_gradient(r_ref[node], v_ref, c_hb[node], omega_rel[node],
                                                         problem.target.boxes))
    if obstacles:
        parts.append(mutual.obstacle_contacts(obstacles, problem.t0_s + grid.tau, r_ref, v_ref, node))
    return tuple(np.concatenate(arrays) for arrays in zip(*parts, strict=True))


def _set_iteration(model, problems, grid, settings, attitudes, refs, pairs, trusts, obstacles=()):
    """Set the linearizations about the references (check positions, node velocities) for one iteration."""
    h = grid.h
    node = slice(None, None, grid.substeps)
    for p, att, (r_ref, v_ref), robot, trust in zip(problems, attitudes, refs, model.robots, trusts, strict=True):
        par = robot['par']
        par['r_ref'].value = r_ref[node]
        ch = p.chaser
        if att is not None or obstacles:
            q, normal, closing, j_r = _contacts(p, att, grid, r_ref, v_ref, obstacles)  # (K, C, 3), (K, N+1)
            bound = np.einsum('kci,kci->kc', normal, q) + ch.envelope_radius_m + settings.keepout_margin_m
            par['safety'].value = p.weights.safety * h
            for b in range(len(normal)):
                normals, last_n = grid.split(normal[b])
                bounds, last_b = grid.split(bound[b])
                for param_n, param_b, nn, bb in zip(par['keep_n'][b], par['keep_b'][b], normals + [last_n],
                                                    bounds + [last_b], strict=True):
                    param_n.value, param_b.value = nn, bb  # supporting plane of box b at the reference
                if p.weights.safety == 0.0:  # no safety cones in the program (_Model)
                    continue
                n_node = normal[b, node]
                # closing speed -n . (v - v_point) to first order: d/dv = -n, d/dr by differences (the normal and
                # the closest point turn as the chaser moves)
                par['safe_r'][b].value = j_r[b]
                par['safe_c'][b].value = (closing[b] + np.einsum('ci,ci->c', n_node, v_ref)
                                          - np.einsum('ci,ci->c', j_r[b], r_ref[node]))
                par['gap_c'][b].value = np.einsum('ci,ci->c', n_node, q[b, node]) + ch.envelope_radius_m
        # The direction to the target of any position within the trust region (Euclidean radius sqrt(3) rho) is
        # within alpha of the reference's, sin(alpha) = sqrt(3) rho / |r_ref|: u . r_hat + sin(alpha) |u| <= 0
        # keeps the thrust off the away side for all of them. Whether a step is inside the sphere is the
        # reference's (plus the margin); the exact cost of each iterate catches one that moves a burn inside.
        rho_node = np.minimum(trust[:, 0], settings.plume_trust_m)
        rho = math.sqrt(3.0) * np.concatenate((np.repeat(np.maximum(rho_node[:-1], rho_node[1:]), grid.substeps),
                                               rho_node[-1:]))
        distance = np.maximum(np.linalg.norm(r_ref, axis=1), 1e-9)
        member = (distance < p.plume_radius_m + settings.plume_margin_m) & (p.plume_radius_m > 0.0)
        r_hat = member[:, None] * r_ref / distance[:, None]
        sin_alpha = member * np.minimum(rho / distance, 1.0)
        hats, _ = grid.split(r_hat)
        sines, _ = grid.split(sin_alpha)
        end = slice(grid.substeps, None, grid.substeps)  # the end of each step
        for param, param_sin, rows, rows_sin in zip(par['plume'], par['plume_sin'], hats + [r_hat[end]],
                                                    sines + [sin_alpha[end]], strict=True):
            param.value, param_sin.value = rows, rows_sin
    for (i, j), par in zip(pairs, model.pairs, strict=True):
        d_ref = refs[i][0] - refs[j][0]
        dist = np.linalg.norm(d_ref, axis=1)
        n_ref = d_ref / np.maximum(dist, 1e-9)[:, None]
        need = (problems[i].chaser.envelope_radius_m + problems[j].chaser.envelope_radius_m
                + settings.separation_margin_m)
        normals, last_n = grid.split(n_ref)
        for param_n, param_b, nn in zip(par['sep_n'], par['sep_b'], normals + [last_n], strict=True):
            param_n.value, param_b.value = nn, np.full(len(nn), need)
        # closing speed -n . dv, with n = dr / |dr|: d/d(dr) = -(I - n n') dv / |dr|
        dv_ref = refs[i][1] - refs[j][1]
        n_node, dist_node = n_ref[node], np.maximum(dist[node], 1e-9)
        j_r = -(dv_ref - np.einsum('ci,ci->c', n_node, dv_ref)[:, None] * n_node) / dist_node[:, None]
        par['safe_n'].value = n_node
        par['safe_r'].value = j_r
        par['safe_c'].value = -np.einsum('ci,ci->c', j_r, d_ref[node])
        par['need'].value = need - settings.separation_margin_m
        par['safety'].value = problems[i].weights.safety * h


def _solve_fixed(problems, duration_s, settings, references, pairs, obstacles=()):
    """SCP iterations at a fixed approach time from the references (per robot: check positions (C, 3), node
    velocities (N+1, 3)), each robot kept off the obstacles. Returns (plans or None if a program is infeasible,
    iterations, converged, objective)."""
    grid = _Grid(problems[0].n, duration_s, settings.steps, settings.substeps)
    boxes = [(len(p.target.boxes) if p.target is not None else 0) + len(obstacles) for p in problems]
    model = program_for(len(problems), settings.steps, settings.substeps, boxes, pairs,
                   [p.weights.safety > 0.0 for p in problems])
    model.phi.value, model.gamma.value = grid.phi, grid.gamma
    for j in range(settings.substeps):
        model.phi_r[j].value, model.gamma_r[j].value = grid.phi_r[j], grid.gamma_r[j]
    attitudes = [p.target.attitude(p.t0_s + grid.tau) if p.target is not None else None for p in problems]
    for p, robot in zip(problems, model.robots, strict=True):
        r_f, v_f = p.end_state(duration_s)
        par, ch = robot['par'], p.chaser
        par['x0'].value = np.concatenate((p.r0_hill, p.v0_hill))
        par['xf'].value = np.concatenate((r_f, v_f))
        par['accel_max'].value = ch.accel_max_mps2
        par['fuel'].value = p.weights.fuel_per_kg * ch.mass_kg / ch.exhaust_velocity_mps * grid.h
        par['buffer'].value = settings.buffer_penalty * p.weights.plume * grid.h
        par['keep_price'].value = settings.keepout_penalty
    refs, best, trust = list(references), None, settings.trust_region_m
    for it in range(1, settings.max_iterations + 1):
        rhos = []
        for p, robot, (r_ref, _) in zip(problems, model.robots, refs, strict=True):
            # near the target the linearizations hold over a shorter distance: a trust radius in proportion
            rho = np.full(settings.steps + 1, trust)
            if p.target is not None:
                distance = np.linalg.norm(r_ref[::grid.substeps], axis=1)
                rho = np.minimum(rho, np.maximum(settings.trust_fraction * distance, settings.trust_min_m))
            robot['par']['trust'].value = rho[:, None]
            rhos.append(rho[:, None])
        _set_iteration(model, problems, grid, settings, attitudes, refs, pairs, rhos, obstacles)
        try:
            model.program.solve(solver=settings.solver, **solver_options(settings))
            model.compiled = True
            solved = model.program.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE)
        except cp.error.SolverError:
            solved = False
        if not solved:  # infeasible from here: the best iterate so far, if any, stands
            return (None, it, False, math.inf) if best is None else (best[0], it, False, best[2])
        plans = [ZohPlan(p.t0_s, duration_s, r['x'].value.copy(), r['u'].value.copy(), p.n)
                 for p, r in zip(problems, model.robots, strict=True)]
        merit = (total_cost(problems, plans, settings.merit_steps, settings.collision_penalty, bool(pairs))
                 + mutual.obstacle_cost(problems, plans, obstacles, settings.merit_steps, settings.collision_penalty))
        # the plume rule is a constraint only where the reference is inside the sphere: what an iterate breaks
        # elsewhere (a burn moved inside, a sliver between check points) is priced like a collision
        largest, impulse = _plume_violation(problems, plans)
        plume_clear = largest <= _PLUME_TOLERANCE_MPS2
        merit += settings.collision_penalty * impulse
        new_refs = [_reference_from_plan(plan, grid) for plan in plans]
        move = max(float(np.abs(new[0] - old[0]).max()) for new, old in zip(new_refs, refs, strict=True))
        if best is None or merit < best[1]:  # the exact cost fell: accept, and trust the model farther
            improved = math.inf if best is None else best[1] - merit
            best = (plans, merit, float(model.program.value))
            refs = new_refs
            trust = min(2.0 * trust, settings.trust_region_m)
            # converged, unless the plume rule holds only by the reference's membership of the sphere: an iterate
            # that moved a burn inside is linearized once more about itself
            if (move < settings.tolerance_m or improved < settings.merit_tolerance) and plume_clear:
                return best[0], it, True, best[2]
        else:  # the exact cost rose: the linearization was trusted too far
            trust *= settings.trust_shrink
            if trust < settings.tolerance_m:
                return best[0], it, True, best[2]
    return best[0], settings.max_iterations, False, best[2]


def _plume_violation(problems, plans, rate_hz=20.0):
    """The largest thrust away from the target inside the plume radius [m/s^2] of any plan and its integral over
    time [m/s], on samples at rate_hz (the mission's check, approach.check_approach, samples as densely)."""
    largest = impulse = 0.0
    for p, plan in zip(problems, plans, strict=True):
        if p.plume_radius_m <= 0.0:
            continue
        steps = int(np.ceil(plan.duration_s * rate_hz))
        s = plan.sample(np.linspace(0.0, plan.duration_s, steps + 1))
        dist = np.linalg.norm(s.r_hill, axis=1)
        away = np.where(dist < p.plume_radius_m,
                        np.einsum('ij,ij->i', s.a_hill, s.r_hill) / np.maximum(dist, 1e-9), 0.0).clip(min=0.0)
        largest = max(largest, float(away.max()))
        impulse += float(away.sum()) * plan.duration_s / steps
    return largest, impulse


def plan_scp(problems, settings=ScpSettings(), duration_s=None, separate=True, obstacles=(), initial=None):
    """Plan the approach of one or several robots (a list of ApproachProblem with one mean motion) by SCP.

    With duration_s None the approach time T is chosen in [duration_min_s, duration_max_s] of the first problem by
    a golden-section search (scipy.optimize.minimize_scalar, bounded) on the exact eq 5 of each converged plan
    (flyby_planner.optimal.cost.plan_terms, summed over the robots), each solve warm-started from the last plan;
    otherwise T = duration_s. ``separate``: the robots' separation constraints and mutual safety (several robots).
    ``obstacles``: other robots' planned motion (mutual.MovingObstacle), which every robot keeps off with the same
    keep-out and mutual safety terms (seed 003 section 4.2 against a known plan). ``initial``: plans (one per robot,
    e.g. of a coarser grid) as the first reference instead of the heuristic route.

    Returns:
        ScpResult; its plans are None when no T gave a feasible program (RuntimeError is not raised: the caller
        decides, e.g. NO_SAFE_PLAN).
    """
    start = time.perf_counter()
    pairs = [(i, j) for i in range(len(problems)) for j in range(i + 1, len(problems))] if separate else []
    tried, solves = [], [0]
    best = {}

    def solve(t_f):
        grid = _Grid(problems[0].n, t_f, settings.steps, settings.substeps)
        if best or initial is not None:
            refs = [_reference_from_plan(plan, grid) for plan in (best['plans'] if best else initial)]
        else:  # from the heuristic route, first without the plume rule (a continuation: the rule then only
            # reshapes the braking of a path that already clears the target)
            free = [dataclasses.replace(p, plume_radius_m=0.0) for p in problems]
            refs = [_reference_from_route(p, grid, t_f) for p in problems]
            plans, it, _, _ = _solve_fixed(free, t_f, settings, refs, pairs, obstacles)
            solves[0] += it
            if plans is not None:
                refs = [_reference_from_plan(plan, grid) for plan in plans]
        plans, it, converged, objective = _solve_fixed(problems, t_f, settings, refs, pairs, obstacles)
        solves[0] += it
        tried.append(float(t_f))
        if plans is None:
            return None, _INFEASIBLE, it, converged, objective
        total = (total_cost(problems, plans, settings.merit_steps, settings.collision_penalty, bool(pairs))
                 + mutual.obstacle_cost(problems, plans, obstacles, settings.merit_steps, settings.collision_penalty))
        return plans, total, it, converged, objective

    def record(t_f):
        plans, total, it, converged, objective = solve(t_f)
        if plans is not None and total < best.get('total', math.inf):
            best.update(plans=plans, total=total, iterations=it, converged=converged, objective=objective)
        return total

    if duration_s is not None:
        record(float(duration_s))
    else:
        lo, hi = problems[0].duration_min_s, problems[0].duration_max_s
        minimize_scalar(record, bounds=(lo, hi), method='bounded',
                        options={'xatol': settings.duration_tolerance_s})
    return ScpResult(plans=best.get('plans'), iterations=best.get('iterations', 0),
                     converged=best.get('converged', False), objective=best.get('objective', math.inf),
                     solves=solves[0], wall_time_s=time.perf_counter() - start, durations_s=tuple(tried))
