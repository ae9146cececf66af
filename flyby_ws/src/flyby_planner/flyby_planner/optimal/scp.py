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

``delta_v_lower_bound`` gives the least delta-v any path can have for a time and acceleration bound, whatever its
shape (keep-out and plume only add constraints): module doc of that function.
"""

import dataclasses
import math
import time

import cvxpy as cp
import numpy as np
from scipy.optimize import minimize, minimize_scalar

from flyby_planner.optimal import mutual
from flyby_planner.optimal.cost import Trajectory, box_contacts, total_cost
from flyby_planner.optimal.problem import heuristic_route
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


class _Model:
    """The convex program of one SCP iteration, written once with cvxpy Parameters (disciplined parametrized
    programming), so that every iteration and every approach time only sets parameters and re-solves.

    Check-point positions are variables tied to the node states (rc_j = Phi_r(j h / M) x_k + Gamma_r u_k) so that
    every constraint is a parameter times a variable.
    """

    def __init__(self, robots, steps, substeps, boxes_per_robot, pairs, safety_per_robot):
        n_check = [steps] * substeps + [1]
        self.phi, self.gamma = cp.Parameter((6, 6)), cp.Parameter((6, 3))
        self.phi_r = [cp.Parameter((3, 6)) for _ in range(substeps)]
        self.gamma_r = [cp.Parameter((3, 3)) for _ in range(substeps)]
        self.robots = []
        # every second-order cone goes into one SOC constraint at the end (rows of dimension 4; the rotated cones
        # padded with a zero): cvxpy's cone formatting costs per constraint object, in proportion to the variables
        # times the parameters, so one object compiles several times faster than one per cone family
        cone_t, cone_x = [], []
        cost, constraints = 0.0, []
        for k_boxes, priced in zip(boxes_per_robot, safety_per_robot, strict=True):
            x, u = cp.Variable((steps + 1, 6)), cp.Variable((steps, 3))
            thrust = cp.Variable(steps)  # >= |u_k|, equal at the optimum (fuel prices it): one cone per step
            rc = [cp.Variable((steps, 3)) for _ in range(substeps)] + [x[steps:, :3]]
            par = dict(x0=cp.Parameter(6), xf=cp.Parameter(6), accel_max=cp.Parameter(nonneg=True),
                       fuel=cp.Parameter(nonneg=True), r_ref=cp.Parameter((steps + 1, 3)),
                       trust=cp.Parameter((steps + 1, 1), nonneg=True),
                       keep_n=[[cp.Parameter((m, 3)) for m in n_check] for _ in range(k_boxes)],
                       keep_b=[[cp.Parameter(m) for m in n_check] for _ in range(k_boxes)],
                       safety=cp.Parameter(nonneg=True), buffer=cp.Parameter(nonneg=True),
                       keep_price=cp.Parameter(nonneg=True),
                       safe_r=[cp.Parameter((steps + 1, 3)) for _ in range(k_boxes)],
                       safe_c=[cp.Parameter(steps + 1) for _ in range(k_boxes)],
                       gap_c=[cp.Parameter(steps + 1) for _ in range(k_boxes)],
                       plume=[cp.Parameter((steps, 3)) for _ in range(substeps + 1)],
                       plume_sin=[cp.Parameter(steps, nonneg=True) for _ in range(substeps + 1)])
            constraints += [
                x[0] == par['x0'],  # the state now
                x[steps] == par['xf'],  # X_Ft, V_Ft at t0 + T, seed 000 eq 20-21
                x[1:] == x[:-1] @ self.phi.T + u @ self.gamma.T,  # CW with held thrust, seed 000 eq 22
                thrust <= par['accel_max'],  # actuator limit
                cp.abs(x[:, :3] - par['r_ref']) <= par['trust'],  # trust region, per node
            ]
            cone_t.append(thrust)  # |u_k| <= thrust_k
            cone_x.append(u)
            constraints += [rc[j] == x[:-1] @ self.phi_r[j].T + u @ self.gamma_r[j].T for j in range(substeps)]
            # one buffer per box and step, shared by its check points (fewer variables: cvxpy's compile time grows
            # with the variables times the parameters)
            keep_buffer = cp.Variable((k_boxes, steps), nonneg=True) if k_boxes else None
            for b in range(k_boxes):
                # supporting plane of box b; the buffer (SCvx) lets a first reference through the geometry start
                constraints += [cp.sum(cp.multiply(par['keep_n'][b][j], rc[j]), axis=1)
                                >= par['keep_b'][b][j] - (keep_buffer[b] if j < substeps else keep_buffer[b, -1:])
                                for j in range(substeps + 1)]
                if not priced:  # k_s = 0: fuel alone, the keep-out constraints above keep it safe
                    continue
                # safety metric k_s h closing^2 / gap: closing >= the speed toward the box's closest point to first
                # order in r and v, gap the supporting plane's distance (a lower bound of the gap: the box is convex)
                closing, ratio = cp.Variable(steps + 1, nonneg=True), cp.Variable(steps + 1)
                gap = cp.sum(cp.multiply(par['keep_n'][b][0], x[:-1, :3]), axis=1) - par['gap_c'][b][:-1]
                gap = cp.hstack((gap, cp.sum(cp.multiply(par['keep_n'][b][substeps], x[steps:, :3]), axis=1)
                                 - par['gap_c'][b][-1:]))
                # d closing / dv = -n, the supporting plane's normal at the node
                n_node = cp.vstack((par['keep_n'][b][0], par['keep_n'][b][substeps]))
                constraints += [
                    closing >= par['safe_c'][b] - cp.sum(cp.multiply(n_node, x[:, 3:]), axis=1)
                    + cp.sum(cp.multiply(par['safe_r'][b], x[:, :3]), axis=1),
                ]
                cone_t.append(gap + ratio)  # ratio >= closing^2 / gap
                cone_x.append(cp.vstack((2.0 * closing, gap - ratio, np.zeros(steps + 1))).T)
                cost += par['safety'] * cp.sum(ratio)
            # plume: no thrust component away from the target, for any direction to it within the trust region;
            # a virtual buffer (SCvx) at an exact-penalty price keeps an early linearization feasible
            buffer = cp.Variable(steps, nonneg=True)  # one per step, shared by its check points
            constraints += [cp.multiply(par['plume_sin'][j], thrust)
                            + cp.sum(cp.multiply(par['plume'][j], u), axis=1) <= buffer for j in range(substeps + 1)]
            cost += par['buffer'] * cp.sum(buffer)
            if k_boxes:
                cost += par['keep_price'] * cp.sum(keep_buffer)
            cost += par['fuel'] * cp.sum(thrust)  # fuel, k_f m / (Isp g0) h sum |u|
            self.robots.append(dict(x=x, u=u, rc=rc, par=par))
        self.pairs = []
        for i, j in pairs:
            par = dict(sep_n=[cp.Parameter((m, 3)) for m in n_check], sep_b=[cp.Parameter(m) for m in n_check],
                       safe_n=cp.Parameter((steps + 1, 3)), safe_r=cp.Parameter((steps + 1, 3)),
                       safe_c=cp.Parameter(steps + 1), need=cp.Parameter(nonneg=True),
                       safety=cp.Parameter(nonneg=True))
            rc_i, rc_j = self.robots[i]['rc'], self.robots[j]['rc']
            constraints += [cp.sum(cp.multiply(par['sep_n'][c], rc_i[c] - rc_j[c]), axis=1) >= par['sep_b'][c]
                            for c in range(substeps + 1)]  # the robots apart
            dx = self.robots[i]['x'] - self.robots[j]['x']
            closing, ratio = cp.Variable(steps + 1, nonneg=True), cp.Variable(steps + 1)
            gap = cp.sum(cp.multiply(par['safe_n'], dx[:, :3]), axis=1) - par['need']
            constraints += [closing >= par['safe_c'] - cp.sum(cp.multiply(par['safe_n'], dx[:, 3:]), axis=1)
                            + cp.sum(cp.multiply(par['safe_r'], dx[:, :3]), axis=1)]
            cone_t.append(gap + ratio)
            cone_x.append(cp.vstack((2.0 * closing, gap - ratio, np.zeros(steps + 1))).T)
            cost += par['safety'] * cp.sum(ratio)  # mutual safety, k_s h closing^2 / gap
            self.pairs.append(par)
        constraints.append(cp.SOC(cp.hstack(cone_t), cp.vstack(cone_x), axis=1))
        self.program = cp.Problem(cp.Minimize(cost), constraints)
        self.compiled = False  # cvxpy has compiled the program (its first solve, or compile_program)


_MODELS = {}


def _model(robots, steps, substeps, boxes_per_robot, pairs, safety_per_robot):
    """The _Model of this shape, built at its first use and kept (cvxpy compiles it once). safety_per_robot: whether
    each robot's program prices the safety metric (k_s > 0); without it the program has no safety cones."""
    key = (robots, steps, substeps, tuple(boxes_per_robot), tuple(pairs), tuple(safety_per_robot))
    if key not in _MODELS:
        _MODELS[key] = _Model(robots, steps, substeps, boxes_per_robot, pairs, safety_per_robot)
    return _MODELS[key]


def compile_program(robots, settings, boxes_per_robot, pairs=(), safety_per_robot=None):
    """Build and compile the program ``plan_scp`` solves for this shape (robots, settings' grid, keep-out boxes and
    obstacles per robot, robot pairs, whether each prices safety; default none does), every parameter at zero:
    cvxpy compiles a parametrized program once per process (jacobsen_optimal's: 0.2-0.5 s of CPU, docs/optimal.md),
    so a planner that compiles at its start plans at the plan time with the solves alone, as a flight computer's
    solver is generated before flight. The plans are the same either way (test)."""
    safety = tuple(safety_per_robot) if safety_per_robot is not None else (False,) * robots
    model = _model(robots, settings.steps, settings.substeps, boxes_per_robot, pairs, safety)
    if not model.compiled:
        for par in model.program.parameters():
            par.value = np.zeros(par.shape)
        model.program.get_problem_data(settings.solver, solver_opts=_solver_options(settings))
        model.compiled = True
    return model


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
    model = _model(len(problems), settings.steps, settings.substeps, boxes, pairs,
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
            model.program.solve(solver=settings.solver, **_solver_options(settings))
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


def _solver_options(settings):
    """Clarabel's thread count: one, since its worker threads cost more than they give on programs of this size
    (1.5 ms per interior-point iteration) and, on a machine shared with other jobs, spin while they wait. No warm
    start: cvxpy would hand the cached program's new data to the solver object of its last solve (Clarabel's
    update), whose result then depended on what that process had solved before (a campaign run flown after
    another differed from the same run flown alone by 4 mm and 1.4 mm/s at the grasp)."""
    options = {'warm_start': False}
    if settings.solver == 'CLARABEL':
        options['max_threads'] = settings.solver_threads
    return options


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


@dataclasses.dataclass(frozen=True)
class DeltaVBound:
    """The least delta-v of a transfer in a given time under an acceleration bound (delta_v_lower_bound).

    lower_mps: no thrust history a(t), |a| <= a_max, of any shape does it with less [m/s] (weak duality);
    held_mps: the least delta-v of thrust held over ``steps`` equal steps [m/s], which a path reaches (without
    keep-out or plume), so the true least delta-v lies between the two; multiplier: the dual vector used.
    """

    lower_mps: float
    held_mps: float
    steps: int
    multiplier: np.ndarray


def delta_v_lower_bound(r0_hill, v0_hill, r_f_hill, v_f_hill, duration_s, accel_max_mps2, n, steps=200,
                        quadrature=6000):
    """The least delta-v int |a| dt taking (r0, v0) to (r_f, v_f) in duration_s on the CW dynamics, |a| <= a_max.

    Keep-out, the plume rule and the robots' separation only remove paths, so what holds without them bounds every
    planner of the same time and acceleration bound from below. Two numbers bracket it:

    * Held thrust (the relaxation as a second-order cone program, cvxpy Clarabel): with d = x_f - Phi(T) x_0 and
      G_k = Phi(T - t_k+1) Gamma(h), min sum |u_k| h subject to sum G_k u_k = d, |u_k| <= a_max. Its optimum is
      reached by a path, so it is at least the continuous-time least delta-v.
    * Weak duality, valid for any thrust history: for every multiplier lambda (6,),
      int |a| >= int |a| - lambda' (int Phi(T - s) B a ds - d)
              >= lambda' d - a_max int max(0, |B' Phi(T - s)' lambda| - 1) ds
      with B = [0; I], since min over |a| <= a_max of |a| - c' a is -a_max max(0, |c| - 1). lambda starts from the
      cone program's equality multiplier (either sign convention) and is polished by Nelder-Mead on that concave
      function; the integral is the midpoint rule on ``quadrature`` points.

    Returns:
        DeltaVBound.
    """
    phi_t = cw_transition_matrix(n, duration_s)
    d = np.concatenate((r_f_hill, v_f_hill)) - phi_t @ np.concatenate((r0_hill, v0_hill))
    h = duration_s / steps
    g = np.einsum('kij,jl->kil', cw_transition_matrix(n, duration_s - (np.arange(steps) + 1) * h),
                  zoh_input_matrix(n, h))  # (N, 6, 3)
    u = cp.Variable((steps, 3))
    reach = np.transpose(g, (1, 0, 2)).reshape(6, 3 * steps) @ cp.vec(u, order='C') == d  # sum G_k u_k = d
    program = cp.Problem(cp.Minimize(h * cp.sum(cp.norm(u, 2, axis=1))),
                         [reach, cp.norm(u, 2, axis=1) <= accel_max_mps2])
    program.solve(solver='CLARABEL')
    if program.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise ValueError(f'no thrust of at most {accel_max_mps2} m/s^2 makes the transfer in {duration_s} s '
                         f'({program.status})')
    s = (np.arange(quadrature) + 0.5) * duration_s / quadrature
    psi = cw_transition_matrix(n, duration_s - s)[:, :, 3:]  # Phi(T - s) B, (Q, 6, 3)

    def dual(lam):
        c = np.linalg.norm(np.einsum('qij,i->qj', psi, lam), axis=1)
        return float(lam @ d) - accel_max_mps2 * float(np.maximum(c - 1.0, 0.0).sum()) * duration_s / quadrature

    lam0 = max((sign * np.asarray(reach.dual_value, dtype=float) for sign in (1.0, -1.0)), key=dual)
    polished = minimize(lambda lam: -dual(lam), lam0, method='Nelder-Mead',
                        options={'xatol': 1e-10, 'fatol': 1e-12, 'maxfev': 4000})
    lam = polished.x if -polished.fun > dual(lam0) else lam0
    return DeltaVBound(lower_mps=dual(lam), held_mps=float(program.value), steps=steps, multiplier=lam)
