"""The convex program of one SCP iteration (scp, module doc: the model), written once with cvxpy Parameters
(disciplined parametrized programming), so that every iteration and every approach time only sets parameters and
re-solves; kept per shape (``program_for``) and compiled before the plan (``compile_program``).

Per robot: the state x (N+1, 6), the held thrust u (N, 3) and its norm bound ``thrust`` (N,), the check-point
positions rc_j (N, 3) tied to the node states (rc_j = Phi_r(j h / M) x_k + Gamma_r u_k) so that every constraint is
a parameter times a variable; per box its keep-out buffer and, where the safety metric is priced, the closing speed
and the cone's ratio; the plume buffer. Per robot pair the separation and its mutual safety.
"""

import dataclasses

import cvxpy as cp
import numpy as np


@dataclasses.dataclass
class _Builder:
    """What the program's terms are gathered in, in the order they are written (cvxpy orders the program by it).

    cone_t, cone_x: every second-order cone's bound and vector, which go into one SOC constraint at the end (rows of
    dimension 4; the rotated cones padded with a zero): cvxpy's cone formatting costs per constraint object, in
    proportion to the variables times the parameters, so one object compiles several times faster than one per
    cone family."""

    cone_t: list = dataclasses.field(default_factory=list)
    cone_x: list = dataclasses.field(default_factory=list)
    constraints: list = dataclasses.field(default_factory=list)
    cost: object = 0.0


class ScpProgram:
    """The program of one shape: robots with their keep-out boxes (target and obstacles) and whether each prices
    the safety metric, robot pairs; its Parameters in ``phi``, ``gamma``, ``phi_r``, ``gamma_r``, per robot
    ``robots[i]['par']`` and per pair ``pairs[k]``."""

    def __init__(self, robots, steps, substeps, boxes_per_robot, pairs, safety_per_robot):
        n_check = [steps] * substeps + [1]
        self.phi, self.gamma = cp.Parameter((6, 6)), cp.Parameter((6, 3))
        self.phi_r = [cp.Parameter((3, 6)) for _ in range(substeps)]
        self.gamma_r = [cp.Parameter((3, 3)) for _ in range(substeps)]
        build = _Builder()
        self.robots = [self._robot(build, steps, substeps, n_check, k_boxes, priced)
                       for k_boxes, priced in zip(boxes_per_robot, safety_per_robot, strict=True)]
        self.pairs = [self._pair(build, i, j, steps, substeps, n_check) for i, j in pairs]
        build.constraints.append(cp.SOC(cp.hstack(build.cone_t), cp.vstack(build.cone_x), axis=1))
        self.program = cp.Problem(cp.Minimize(build.cost), build.constraints)
        self.compiled = False  # cvxpy has compiled the program (its first solve, or compile_program)

    def _robot(self, build, steps, substeps, n_check, k_boxes, priced):
        """One robot's variables and parameters, its constraints (the state now, X_Ft, CW, the actuator limit, the
        trust region, keep-out, plume) and cost terms (safety where priced, the buffers, fuel)."""
        x, u = cp.Variable((steps + 1, 6)), cp.Variable((steps, 3))
        thrust = cp.Variable(steps)  # >= |u_k|, equal at the optimum (fuel prices it): one cone per step
        rc = [cp.Variable((steps, 3)) for _ in range(substeps)] + [x[steps:, :3]]
        par = _robot_parameters(steps, substeps, n_check, k_boxes)
        build.constraints += [
            x[0] == par['x0'],  # the state now
            x[steps] == par['xf'],  # X_Ft, V_Ft at t0 + T, seed 000 eq 20-21
            x[1:] == x[:-1] @ self.phi.T + u @ self.gamma.T,  # CW with held thrust, seed 000 eq 22
            thrust <= par['accel_max'],  # actuator limit
            cp.abs(x[:, :3] - par['r_ref']) <= par['trust'],  # trust region, per node
        ]
        build.cone_t.append(thrust)  # |u_k| <= thrust_k
        build.cone_x.append(u)
        build.constraints += [rc[j] == x[:-1] @ self.phi_r[j].T + u @ self.gamma_r[j].T for j in range(substeps)]
        # one buffer per box and step, shared by its check points (fewer variables: cvxpy's compile time grows
        # with the variables times the parameters)
        keep_buffer = cp.Variable((k_boxes, steps), nonneg=True) if k_boxes else None
        for b in range(k_boxes):
            _keep_out(build, par, b, x, rc, keep_buffer, steps, substeps, priced)
        # plume: no thrust component away from the target, for any direction to it within the trust region;
        # a virtual buffer (SCvx) at an exact-penalty price keeps an early linearization feasible
        buffer = cp.Variable(steps, nonneg=True)  # one per step, shared by its check points
        build.constraints += [cp.multiply(par['plume_sin'][j], thrust)
                              + cp.sum(cp.multiply(par['plume'][j], u), axis=1) <= buffer for j in range(substeps + 1)]
        build.cost += par['buffer'] * cp.sum(buffer)
        if k_boxes:
            build.cost += par['keep_price'] * cp.sum(keep_buffer)
        build.cost += par['fuel'] * cp.sum(thrust)  # fuel, k_f m / (Isp g0) h sum |u|
        return dict(x=x, u=u, rc=rc, par=par)

    def _pair(self, build, i, j, steps, substeps, n_check):
        """Robots i and j apart at every check point, and their mutual safety k_s h closing^2 / gap."""
        par = dict(sep_n=[cp.Parameter((m, 3)) for m in n_check], sep_b=[cp.Parameter(m) for m in n_check],
                   safe_n=cp.Parameter((steps + 1, 3)), safe_r=cp.Parameter((steps + 1, 3)),
                   safe_c=cp.Parameter(steps + 1), need=cp.Parameter(nonneg=True),
                   safety=cp.Parameter(nonneg=True))
        rc_i, rc_j = self.robots[i]['rc'], self.robots[j]['rc']
        build.constraints += [cp.sum(cp.multiply(par['sep_n'][c], rc_i[c] - rc_j[c]), axis=1) >= par['sep_b'][c]
                              for c in range(substeps + 1)]  # the robots apart
        dx = self.robots[i]['x'] - self.robots[j]['x']
        closing, ratio = cp.Variable(steps + 1, nonneg=True), cp.Variable(steps + 1)
        gap = cp.sum(cp.multiply(par['safe_n'], dx[:, :3]), axis=1) - par['need']
        build.constraints += [closing >= par['safe_c'] - cp.sum(cp.multiply(par['safe_n'], dx[:, 3:]), axis=1)
                              + cp.sum(cp.multiply(par['safe_r'], dx[:, :3]), axis=1)]
        build.cone_t.append(gap + ratio)
        build.cone_x.append(cp.vstack((2.0 * closing, gap - ratio, np.zeros(steps + 1))).T)
        build.cost += par['safety'] * cp.sum(ratio)  # mutual safety, k_s h closing^2 / gap
        return par


def _robot_parameters(steps, substeps, n_check, k_boxes):
    """One robot's Parameters: its end states, limits and prices, the reference and trust radius, per box and check
    point the supporting planes (keep_n, keep_b) and the safety metric's linearization, per check point the plume."""
    return dict(x0=cp.Parameter(6), xf=cp.Parameter(6), accel_max=cp.Parameter(nonneg=True),
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


def _keep_out(build, par, b, x, rc, keep_buffer, steps, substeps, priced):
    """Box b's supporting planes at every check point and, where priced, its safety metric."""
    # supporting plane of box b; the buffer (SCvx) lets a first reference through the geometry start
    build.constraints += [cp.sum(cp.multiply(par['keep_n'][b][j], rc[j]), axis=1)
                          >= par['keep_b'][b][j] - (keep_buffer[b] if j < substeps else keep_buffer[b, -1:])
                          for j in range(substeps + 1)]
    if not priced:  # k_s = 0: fuel alone, the keep-out constraints above keep it safe
        return
    # safety metric k_s h closing^2 / gap: closing >= the speed toward the box's closest point to first
    # order in r and v, gap the supporting plane's distance (a lower bound of the gap: the box is convex)
    closing, ratio = cp.Variable(steps + 1, nonneg=True), cp.Variable(steps + 1)
    gap = cp.sum(cp.multiply(par['keep_n'][b][0], x[:-1, :3]), axis=1) - par['gap_c'][b][:-1]
    gap = cp.hstack((gap, cp.sum(cp.multiply(par['keep_n'][b][substeps], x[steps:, :3]), axis=1)
                     - par['gap_c'][b][-1:]))
    # d closing / dv = -n, the supporting plane's normal at the node
    n_node = cp.vstack((par['keep_n'][b][0], par['keep_n'][b][substeps]))
    build.constraints += [
        closing >= par['safe_c'][b] - cp.sum(cp.multiply(n_node, x[:, 3:]), axis=1)
        + cp.sum(cp.multiply(par['safe_r'][b], x[:, :3]), axis=1),
    ]
    build.cone_t.append(gap + ratio)  # ratio >= closing^2 / gap
    build.cone_x.append(cp.vstack((2.0 * closing, gap - ratio, np.zeros(steps + 1))).T)
    build.cost += par['safety'] * cp.sum(ratio)


_MODELS = {}


def program_for(robots, steps, substeps, boxes_per_robot, pairs, safety_per_robot):
    """The ScpProgram of this shape, built at its first use and kept (cvxpy compiles it once). safety_per_robot:
    whether each robot's program prices the safety metric (k_s > 0); without it the program has no safety cones."""
    key = (robots, steps, substeps, tuple(boxes_per_robot), tuple(pairs), tuple(safety_per_robot))
    if key not in _MODELS:
        _MODELS[key] = ScpProgram(robots, steps, substeps, boxes_per_robot, pairs, safety_per_robot)
    return _MODELS[key]


def compile_program(robots, settings, boxes_per_robot, pairs=(), safety_per_robot=None):
    """Build and compile the program ``plan_scp`` solves for this shape (robots, settings' grid, keep-out boxes and
    obstacles per robot, robot pairs, whether each prices safety; default none does), every parameter at zero:
    cvxpy compiles a parametrized program once per process (jacobsen_optimal's: 0.2-0.5 s of CPU, docs/optimal.md),
    so a planner that compiles at its start plans at the plan time with the solves alone, as a flight computer's
    solver is generated before flight. The plans are the same either way (test)."""
    safety = tuple(safety_per_robot) if safety_per_robot is not None else (False,) * robots
    model = program_for(robots, settings.steps, settings.substeps, boxes_per_robot, pairs, safety)
    if not model.compiled:
        for par in model.program.parameters():
            par.value = np.zeros(par.shape)
        model.program.get_problem_data(settings.solver, solver_opts=solver_options(settings))
        model.compiled = True
    return model


def solver_options(settings):
    """Clarabel's thread count: one, since its worker threads cost more than they give on programs of this size
    (1.5 ms per interior-point iteration) and, on a machine shared with other jobs, spin while they wait. No warm
    start: cvxpy would hand the cached program's new data to the solver object of its last solve (Clarabel's
    update), whose result would then depend on what that process had solved before (docs/optimal.md, "How these
    rules were found")."""
    options = {'warm_start': False}
    if settings.solver == 'CLARABEL':
        options['max_threads'] = settings.solver_threads
    return options
