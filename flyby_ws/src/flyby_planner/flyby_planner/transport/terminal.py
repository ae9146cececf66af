"""The transport's terminal program: after the transfer's last burn, the impulses of the allowed thrusters that bring
the combined body to rest at the goal with its wheels' momentum within their share, as one mixed-integer linear
program solved again on every new estimate (receding horizon).

The body holds its attitude fixed in inertial space (the wheels hold it, so its own rotation, seed 004 §3.2's
condition 1, stays nil); thruster j's force direction in hill at time t is C_hill_from_eci(t) C_eci_from_body d_j,
and its couple about the combined CoM, (p_j - c) x d_j per unit impulse, goes to the wheels. The state is the
deviation from the goal's rest point (``rest_point``), an equilibrium of the relative dynamics, so its motion is
CW's to first order (seed 000 eq 22). With u_kj >= 0 the impulse of thruster j at slot k (time t_k) [N s]:

    min  sum u_kj + w |m v_T|_1 + W_s sum s_stage + W_m sum s_margin   (fuel, the end centred, the slacks)
    s.t. bit z_kj <= u_kj <= u_max z_kj,  z_kj in {0, 1}          the minimum impulse bit and the slot's thrust
         x_T = Phi(T) x_0 + sum_kj Phi(T - t_k)[:, 3:] d_kj u_kj / m
         |a_i . r_T| <= rho_r + s_r,  |a_i . m v_T| <= rho_p + s_p  conditions 2 and 3 within their margins, a_i the
         |a_i . m v_T+k hold| <= rho_p + s_p                      13 directions of ``BALL_DIRECTIONS``; the momentum
                                                                 also k = HOLD_TIMES holds later (CW from the end)
         |a_i . m v_T+t_w| <= rho_p + s_w                         and over the judgement's window (``_window_rows``)
         the same + e . u <= the stage + s_r', s_p'              with the firings' execution error, within a stage:
                                                                 rho_p or STAGE_FRACTION of the unfired end momentum
         |h_0 + sum_kj tau_j u_kj|_inf <= rho_h                   the wheels' share of their capacity at the end
         |h_0 + sum_{k' <= k, j} tau_j u_k'j|_inf <= h_room          and within their room after every slot: saturated,
                                                                 they would no longer hold the attitude the program
                                                                 fires at
         |sum_j tau_j u_kj|_inf <= couple_max                     a slot's couple the wheels stop within a small turn

The conditions are soft: each slack s >= 0 costs its tier's weight per margin, so the program always has a plan, the one
whose end comes nearest (the stage with the error first, STAGE_WEIGHT, then the margins without it, EXCESS_WEIGHT; then
the window's, WINDOW_WEIGHT), and says how far beyond it ends (``TerminalSolution.excess`` and ``window_excess``); a
state it cannot bring nearer fires nothing. A plan need not end within the margins with its error: the next plan, from
the estimate that has seen it, takes the error out (its own error a share of that); one that ends, error included,
beyond a stage is the last resort, and says by how much.
scipy.optimize.milp (HiGHS), bounded by its branch-and-bound nodes, not by wall time: a run replayed, on any machine and
load, fires the same. The horizon T is searched over HORIZONS_S up to the time left: the shortest whose end lies within
both and within the window is kept, else the nearest (the stage, the margins, then the window); a state that stays
within the margins over it fires nothing. Slots are the start and a grid fixed in time (``slot_times``). A side force
the thrusters cannot give at the attitude held (the direction limit) leaves every horizon's end beyond the margins:
guidance then turns the body or waits (docs/transport.md).
"""

import math
from typing import NamedTuple

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, linprog, milp

from flyby_sim.dynamics.orbital import cw_transition_matrix, hill_axes_in_eci
from flyby_sim.dynamics.rotation import quat_to_matrix

HORIZONS_S = (60.0, 120.0, 240.0, 480.0, 960.0, 1920.0, 2880.0)  # the terminal horizons tried, shortest first [s]
SLOTS = 4  # firing times per horizon: its start, then multiples of a quarter of it
HOLD_TIMES = (1,)  # the momentum within its margin also this many hold_s after the end: the rest the program leaves
#                   lasts through the judgement's hold
WINDOW_TIMES = 4  # the momentum over the judgement's window after the end, at this many times evenly within it ...
WINDOW_WEIGHT = 10.0  # ... a margin beyond it costing this many margins of momentum in impulse (not an excess)
MAX_PULSE_S = 30.0  # a thruster's firing in a slot at most this long at full thrust [s]
BIT_MARGIN = 1.05  # a firing's impulse at least this many minimum impulse bits: the plant fires it whole
TURN_RAD = 0.02  # a slot's couple is one the wheels stop within this turn of the body [rad]
MILP_NODE_LIMIT = 1000  # branch-and-bound nodes per solve: a bound on the solver's work, not its wall time, so
#                         the answer does not depend on the machine's load
LATER_SLOT_COST = 0.05  # each later slot's impulse costs this much more: what can be fired now is, and a pair of
#                         opposed firings that nets less than a bit lies in one slot, which the next solve keeps
CORRECTION_WEIGHT = 10.0  # a mid-course correction's miss of its delta-v against its impulse (``impulses_for``)
STAGE_FRACTION = 0.25  # a state whose momentum would end beyond the margin by itself is brought within this share
#                        of it, the firings' execution error included: the deviation shrinks each plan, however far
#                        off it starts, and no plan fires more than its error allows (the stage's slack)
EXCESS_WEIGHT = 100.0  # a margin's worth of excess costs this many margins of momentum in impulse ...
STAGE_WEIGHT = 1000.0  # ... and beyond a stage with the error, this many
SLACKS = ('stage position', 'stage momentum', 'position', 'momentum', 'window momentum')  # the program's slack
#                                                                                      variables, last
EXCESS_TOLERANCE = 1e-6  # an excess below this (in margins) is none
MOMENTUM_WEIGHT = 2.0  # w: a newton second of end momentum costs twice one of impulse, so the program takes out what
#                        the bit allows rather than ride the margin's edge

# Unit directions whose slabs |a . x| <= rho bound a ball: the axes, the face and the body diagonals. A vector
# within every slab has a norm of at most rho / cos(the largest angle to the nearest direction), 1.23 rho
# (test_terminal).
BALL_DIRECTIONS = np.array([d / np.linalg.norm(d) for d in (
    (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, -1, 0), (1, 0, 1), (1, 0, -1), (0, 1, 1), (0, 1, -1),
    (1, 1, 1), (1, 1, -1), (1, -1, 1), (-1, 1, 1))], dtype=float)
BALL_SLAB_FACTOR = 1.0 / 1.23  # rho of the slabs that keep a vector within a ball of radius 1


def rest_point(goal_hill_m, radius_m):
    """The point of the reference orbit nearest the goal (hill, [m]): the orbit's circle in its plane at the goal's
    along-track angle. A body there at rest in hill stays at rest under two-body gravity (a point fixed in hill off
    that circle does not: 2 km ahead on V-bar is 0.29 m above it and drifts)."""
    goal = np.asarray(goal_hill_m, dtype=float)
    theta = math.atan2(goal[0], radius_m - goal[2])
    return np.array((radius_m * math.sin(theta), 0.0, radius_m * (1.0 - math.cos(theta))))


class TerminalProblem(NamedTuple):
    """What the program needs: the body and its thrusters, the state to bring to rest, the margins."""

    mass_kg: float
    directions_body: np.ndarray  # (J, 3) the allowed thrusters' force directions, chaser_body
    couples_body_m: np.ndarray  # (J, 3) their couples about the combined CoM per newton [m], (p_j - c) x d_j
    max_thrust_n: np.ndarray  # (J,)
    min_impulse_bit_n_s: float
    n: float  # mean motion [rad/s]
    t0: float  # the first slot's time [s]
    x0: np.ndarray  # (6,) the combined CoM's deviation from the rest point at t0, hill [m, m/s]
    q_eci_from_body: np.ndarray  # the attitude held
    h_wheels_body_n_m_s: np.ndarray  # (3,) the wheels' momentum at t0
    rho_position_m: float  # the margins of the terminal ball: position
    rho_momentum_n_s: float  # linear momentum, at the end and hold_s after it
    hold_s: float  # the end state must keep its momentum this long [s]
    rho_wheels_n_m_s: float  # the wheels' momentum per body axis at the end (or (3,), per axis)
    wheel_room_n_m_s: float  # the wheels' momentum per body axis at any time: within it they hold the attitude
    couple_max_n_m_s: float  # a slot's couple per body axis
    impulse_error: float  # a firing's execution error at the margins' sigmas, per unit impulse (magnitude, direction)
    window_s: float = 0.0  # the judgement's window after the end: the navigation's coast and the hold [s]


class TerminalSolution(NamedTuple):
    """The firings the program chose over its horizon, and their predicted end."""

    horizon_s: float
    slot_times_s: np.ndarray  # (K,)
    impulses_n_s: np.ndarray  # (K, J)
    predicted: np.ndarray  # (6,) the deviation from the rest point at t0 + horizon_s
    h_wheels_body_n_m_s: np.ndarray  # (3,) the wheels' momentum then
    excess: tuple  # how far the end lies beyond a stage with the error, and beyond the margins without it, in
#                    units of each margin (0: within)
    window_excess: float = 0.0  # how far beyond the momentum's margin the window after the end goes, in margins


def couple_limit(inertia_body_kg_m2, wheel_max_torque_n_m):
    """The largest couple impulse [N m s] a slot may give: the body turned by it stops within TURN_RAD at the
    wheels' torque (h^2 / (2 I tau) = TURN_RAD, the least principal moment)."""
    inertia_min = float(np.min(np.linalg.eigvalsh(np.asarray(inertia_body_kg_m2, dtype=float))))
    return math.sqrt(2.0 * inertia_min * wheel_max_torque_n_m * TURN_RAD)


def _wheel_room(problem):
    """(3,) the wheels' momentum per body axis a firing may leave them [N m s]: their room, or what they hold
    already where that is more (a firing need not bring it within at once, only not add to it)."""
    return np.maximum(problem.wheel_room_n_m_s, np.abs(problem.h_wheels_body_n_m_s))


def _c_hill_from_body(problem, t):
    """C_hill_from_body at time t [s] of the attitude held inertially."""
    return hill_axes_in_eci(t, problem.n).T @ quat_to_matrix(problem.q_eci_from_body)


def _directions_hill(problem, t):
    """(J, 3) the thrusters' directions in hill at time t, the attitude held inertially."""
    return problem.directions_body @ _c_hill_from_body(problem, t).T


def slot_times(t0, horizon_s):
    """The firing times of a horizon [s]: now, then a grid of spacing horizon_s / SLOTS fixed in time (its
    multiples), so the solves of successive checks offer the same later times."""
    spacing = horizon_s / SLOTS
    first = math.floor(t0 / spacing + 1e-9) + 1
    grid = [k * spacing for k in range(first, first + SLOTS) if k * spacing < t0 + horizon_s - 1e-9]
    return np.array([t0] + grid)


def _program(problem, horizon_s):
    """The MILP of one horizon (module doc): (c, constraints, bounds, integrality, slot times, the end's effect per
    impulse, the end without firings)."""
    m = problem.mass_kg
    j_count = len(problem.max_thrust_n)
    slots = slot_times(problem.t0, horizon_s)
    k_count = len(slots)
    t_end = problem.t0 + horizon_s
    free = cw_transition_matrix(problem.n, horizon_s) @ problem.x0
    to_end = [cw_transition_matrix(problem.n, t_end - t_k) for t_k in slots]  # each slot's transition to the end
    # State at the end per unit impulse of each (slot, thruster): (6, K J).
    effect = np.hstack([g[:, 3:] @ _directions_hill(problem, t_k).T / m for g, t_k in zip(to_end, slots, strict=True)])
    couples = problem.couples_body_m.T  # (3, J)
    size = k_count * j_count
    # The thrusters of a slot fire one after another (``firing_periods``) within half the slot.
    u_max = np.tile(problem.max_thrust_n * min(MAX_PULSE_S, 0.5 * horizon_s / SLOTS / j_count), k_count)
    bit = BIT_MARGIN * problem.min_impulse_bit_n_s
    eye = np.eye(size)
    # The momentum at the end and hold_s later (CW from the end): a body off its rest point gains momentum, 3 n^2
    # per metre radially, so a heavy body must end nearer it.
    held = [np.eye(6)[3:]] + [cw_transition_matrix(problem.n, k * problem.hold_s)[3:] for k in HOLD_TIMES]
    a_r = BALL_DIRECTIONS @ effect[:3]
    r_free = BALL_DIRECTIONS @ free[:3]
    a_v, p_free = _momentum_slabs(held, effect, free, m)
    # Each impulse's execution error moves the end by at most its size times the transition's gain, in any
    # direction: a margin taken from every slab (``impulse_error`` at the slabs' sigmas).
    e_r = problem.impulse_error / m * np.repeat([np.linalg.norm(g[:3, 3:], 2) for g in to_end], j_count)
    e_v = problem.impulse_error * np.repeat([max(np.linalg.norm((h @ g)[:, 3:], 2) for h in held) for g in to_end],
                                            j_count)
    h_total = np.tile(couples, k_count)
    per_slot = np.kron(np.eye(k_count), couples)
    after_slot = np.kron(np.tril(np.ones((k_count, k_count))), couples)  # the wheels' gain by each slot's end
    room = np.tile(_wheel_room(problem), k_count)
    h0 = np.tile(problem.h_wheels_body_n_m_s, k_count)
    # A far state's plan need only bring it, error included, within STAGE_FRACTION of the momentum it would end
    # with unfired (a stage); the next plan goes on from there.
    rho_p = problem.rho_momentum_n_s
    rho_stage = max(rho_p, STAGE_FRACTION * max(float(np.linalg.norm(h @ free)) * m for h in held) * BALL_SLAB_FACTOR)
    rho_r = problem.rho_position_m

    def on_u(a, col=None):  # a row block on u, and -1 on the slack SLACKS[col]
        slack = np.zeros((a.shape[0], len(SLACKS)))
        if col is not None:
            slack[:, col] = -1.0
        return np.hstack((a, np.zeros((a.shape[0], size + 3)), slack))

    p_end = effect[3:] * m  # (3, size): the end momentum per impulse, hill
    zeros = np.zeros((size, 3 + len(SLACKS)))
    rows = [
        LinearConstraint(np.hstack((eye, -np.diag(u_max), zeros)), -np.inf, 0.0),  # u <= u_max z
        LinearConstraint(np.hstack((eye, -bit * eye, zeros)), 0.0, np.inf),  # u >= bit z
        LinearConstraint(on_u(h_total), -problem.rho_wheels_n_m_s - problem.h_wheels_body_n_m_s,
                         problem.rho_wheels_n_m_s - problem.h_wheels_body_n_m_s),
        LinearConstraint(on_u(per_slot), -problem.couple_max_n_m_s, problem.couple_max_n_m_s),
        LinearConstraint(on_u(after_slot), -room - h0, room - h0),
        # s >= |p_end| per hill axis: the end momentum's 1-norm, which the cost weighs (centring within the ball)
        LinearConstraint(np.hstack((p_end, np.zeros((3, size)), -np.eye(3), np.zeros((3, len(SLACKS))))), -np.inf,
                         -free[3:] * m),
        LinearConstraint(np.hstack((-p_end, np.zeros((3, size)), -np.eye(3), np.zeros((3, len(SLACKS))))), -np.inf,
                         free[3:] * m),
    ]
    # Conditions 2 and 3 at the end, each beyond its margin by its slack at most: the stage with the firings'
    # execution error, and the margins themselves without it.
    for col, (a_x, e_x, rho, x_free) in enumerate(((a_r, e_r, rho_r, r_free), (a_v, e_v, rho_stage, p_free),
                                                   (a_r, np.zeros_like(e_r), rho_r, r_free),
                                                   (a_v, np.zeros_like(e_v), rho_p, p_free))):
        rows += [LinearConstraint(on_u(a_x + e_x, col), -np.inf, rho - x_free),
                 LinearConstraint(on_u(e_x - a_x, col), -np.inf, rho + x_free)]
    rows += _window_rows(problem, effect, free, on_u)
    slot_cost = np.repeat(1.0 + LATER_SLOT_COST * np.arange(k_count), j_count)
    # Each slack in units of its margin, weighed as its tier's margins of momentum: the program fires what brings
    # the end nearest its margins before it saves fuel, and keeps its error within a stage before that.
    per_margin = rho_p / _slack_units(problem)
    slack_cost = per_margin * np.append(np.repeat((STAGE_WEIGHT, EXCESS_WEIGHT), 2), WINDOW_WEIGHT)
    cost = np.concatenate((slot_cost, np.zeros(size), np.full(3, MOMENTUM_WEIGHT), slack_cost))
    n_var = 2 * size + 3 + len(SLACKS)
    bounds = Bounds(np.zeros(n_var), np.concatenate((u_max, np.ones(size), np.full(3 + len(SLACKS), np.inf))))
    integrality = np.concatenate((np.zeros(size), np.ones(size), np.zeros(3 + len(SLACKS))))
    return cost, rows, bounds, integrality, slots, effect, free


def _momentum_slabs(flows, effect, free, mass_kg):
    """(A (13 F, K J), p (13 F,)): the momentum along BALL_DIRECTIONS after each of the F flows ((3, 6) rows of a CW
    transition from the end) is A u + p, for impulses u (the end's effect per impulse) and the state unfired."""
    return (np.vstack([BALL_DIRECTIONS @ (h @ effect) for h in flows]) * mass_kg,
            np.concatenate([BALL_DIRECTIONS @ (h @ free) for h in flows]) * mass_kg)


def _window_rows(problem, effect, free, on_u):
    """The momentum within its margin, beyond it by the window's slack, at WINDOW_TIMES times over the judgement's
    window after the end (CW from the end): the judgement needs the navigation's coast and the hold after the last
    firing, and a body off its rest point gains momentum all the while (n^2 m per metre cross-track, 3 n^2 m
    radially: 0.14 m cross-track on 1254 kg is 0.012 N s a minute). Soft and not an excess: where the thrusters
    cannot bring the body to its rest point at the attitude held, the plan that comes nearest it."""
    if problem.window_s <= 0.0:
        return []
    flows = [cw_transition_matrix(problem.n, problem.window_s * (k + 1) / WINDOW_TIMES)[3:]
             for k in range(WINDOW_TIMES)]
    a_w, p_w = _momentum_slabs(flows, effect, free, problem.mass_kg)
    col = SLACKS.index('window momentum')
    rho = problem.rho_momentum_n_s
    return [LinearConstraint(on_u(a_w, col), -np.inf, rho - p_w), LinearConstraint(on_u(-a_w, col), -np.inf, rho + p_w)]


def solve(problem, horizons_s):
    """The firings over the first of the horizons [s] (HORIZONS_S up to the time left) whose end lies within the
    margins, within a stage with the firings' error and within the window's margin; where none does, over the horizon
    whose end comes nearest (the least excess beyond the stage, then beyond the margins, then beyond the window's,
    each in units of the margins; the shorter on a tie).
    A horizon whose linear relaxation (a bound on its excess) comes no nearer than the best so far is not solved.
    Where the wheels hold more than their share and no plan brings them within it, the plans that take them no
    further on any axis. None only where HiGHS returns no point."""
    j_count = len(problem.max_thrust_n)
    best = nearest = None  # the best solution and its excess (``_excess``)
    for horizon_s in horizons_s:
        cost, rows, bounds, integrality, slots, effect, free = _program(problem, horizon_s)
        if best is not None:
            relaxed = milp(cost, constraints=rows, bounds=bounds, options={'presolve': False})
            if relaxed.x is None or not _nearer(_excess(problem, relaxed.x), nearest):
                continue
        result = milp(cost, constraints=rows, bounds=bounds, integrality=integrality,
                      options={'node_limit': MILP_NODE_LIMIT, 'presolve': False})
        if result.x is None or result.status not in (0, 1):
            continue
        size = j_count * len(slots)
        u = np.where(result.x[size:2 * size] > 0.5, result.x[:size], 0.0)
        impulses = u.reshape(len(slots), j_count)
        h_end = problem.h_wheels_body_n_m_s + problem.couples_body_m.T @ impulses.sum(axis=0)
        excess = _excess(problem, result.x)
        if best is None or _nearer(excess, nearest):
            best = TerminalSolution(horizon_s, slots, impulses, free + effect @ u, h_end, excess[:2], excess[2])
            nearest = excess
        if max(excess) <= EXCESS_TOLERANCE:
            break
    held = np.abs(problem.h_wheels_body_n_m_s)
    if best is None and np.any(held > problem.rho_wheels_n_m_s):
        # Wheels beyond their share that no plan brings back within it: the plan that takes them no further.
        return solve(problem._replace(rho_wheels_n_m_s=np.maximum(problem.rho_wheels_n_m_s, held)), horizons_s)
    return best


def firings_end(problem, slot_times_s, impulses_n_s, t_end_s):
    """The deviation from the rest point (6,) at t_end_s of the state problem.x0 at problem.t0 under firings at
    slot_times_s (>= problem.t0, impulses (K, J) [N s]) at the attitude held, CW (seed 000 eq 22)."""
    m = problem.mass_kg
    end = cw_transition_matrix(problem.n, t_end_s - problem.t0) @ problem.x0
    for t_k, u_k in zip(slot_times_s, impulses_n_s, strict=True):
        dv_hill = _directions_hill(problem, t_k).T @ np.asarray(u_k, dtype=float) / m
        end = end + cw_transition_matrix(problem.n, t_end_s - t_k)[:, 3:] @ dv_hill
    return end


def kept_excess(problem, slot_times_s, impulses_n_s, t_end_s):
    """How far beyond the margins, without the firings' error, in units of each (position's and momentum's, summed
    as the program's slacks: the largest slab's), a plan's firings still to come leave the state problem.x0 at
    t_end_s (``firings_end``): a plan flown is kept while this stays as its own, and solved again from the estimate
    where it grows (guidance's check while it flies)."""
    end = firings_end(problem, slot_times_s, impulses_n_s, t_end_s)
    held = [end] + [cw_transition_matrix(problem.n, k * problem.hold_s) @ end for k in HOLD_TIMES]
    position = float(np.max(np.abs(BALL_DIRECTIONS @ end[:3])))
    momentum = problem.mass_kg * max(float(np.max(np.abs(BALL_DIRECTIONS @ x[3:]))) for x in held)
    return (max(0.0, position - problem.rho_position_m) / problem.rho_position_m
            + max(0.0, momentum - problem.rho_momentum_n_s) / problem.rho_momentum_n_s)


def _excess(problem, x):
    """(beyond the stage, beyond the margins, beyond the window's margin) of a point of the program, each in units of
    the margins (its last variables, the SLACKS)."""
    s = x[-len(SLACKS):] / _slack_units(problem)
    return float(s[0] + s[1]), float(s[2] + s[3]), float(s[4])


def _slack_units(problem):
    """The margin each slack of SLACKS is counted in: the position's, the momentum's, for the stage and the
    margins alike."""
    return np.array((problem.rho_position_m, problem.rho_momentum_n_s) * 2 + (problem.rho_momentum_n_s,))


def _nearer(excess, than):
    """True where an excess (``_excess``) is nearer than another: the stage's first, then the margins', then the
    window's."""
    for mine, theirs in zip(excess, than, strict=True):
        if abs(mine - theirs) > EXCESS_TOLERANCE:
            return mine < theirs
    return False


def firing_periods(impulses_n_s, max_thrust_n, min_impulse_bit_n_s, period_s):
    """(thrusts [N] (P, J), one row per control period) that deliver each thruster's impulse: one thruster after
    another, each over n_j periods at u_j / (n_j period), as few as its thrust allows and never below the bit in a
    period. One thruster a period: its wrench is the plant's allocation of it (``actuators.allocate_wrench``, least
    total thrust), where two opposed thrusters in one period would net to less than a bit and not fire at all."""
    u = np.asarray(impulses_n_s, dtype=float)
    counts = np.where(u > 0.0, np.ceil(u / (np.asarray(max_thrust_n, dtype=float) * period_s) - 1e-9), 0).astype(int)
    if min_impulse_bit_n_s > 0.0:
        counts = np.minimum(counts, np.maximum(np.floor(u / min_impulse_bit_n_s + 1e-9), 1).astype(int))
    thrusts = np.zeros((int(counts.sum()), len(u)))
    row = 0
    for j, count in enumerate(counts):
        thrusts[row:row + count, j] = u[j] / max(count, 1) / period_s
        row += count
    return thrusts


def impulses_for(dv_hill_mps, problem):
    """(impulses [N s] (J,), the delta-v they give [m/s, hill]): the thrusters' impulses now at the attitude held
    that come nearest a wanted delta-v (a mid-course correction), an LP (scipy.optimize.linprog, HiGHS):

        min  sum u + W |D u / m - dv|_1   s.t.  0 <= u <= u_max,  |C u|_inf <= couple_max,  |h_0 + C u|_inf <= h_room

    with D the thrusters' directions and the miss in the held body's axes, C their couples about the combined CoM
    (the wheels take them up, within their room);
    where the direction limit leaves part of dv out of reach, the part within it. Impulses below the minimum impulse
    bit are left out."""
    m = problem.mass_kg
    # The miss measured in the held body's axes, where the thrusters' cone is aligned with them: its 1-norm there is
    # the miss of the part within reach (in hill's it would not be, the push axis off hill's).
    c_body_from_hill = _c_hill_from_body(problem, problem.t0).T
    dv = c_body_from_hill @ np.asarray(dv_hill_mps, dtype=float)
    d = problem.directions_body.T / m  # (3, J): delta-v per newton second, body axes
    j_count = d.shape[1]
    weight = CORRECTION_WEIGHT * m  # a newton second of impulse is worth W newton seconds of the delta-v's miss
    # Variables: u (J), e+ (3), e- (3) with D u - dv = e+ - e-.
    cost = np.concatenate((np.ones(j_count), np.full(6, weight)))
    a_eq = np.hstack((d, -np.eye(3), np.eye(3)))
    couples = problem.couples_body_m.T
    a_ub = np.vstack((np.hstack((couples, np.zeros((3, 6)))), np.hstack((-couples, np.zeros((3, 6))))))
    room, h0 = _wheel_room(problem), problem.h_wheels_body_n_m_s
    b_ub = np.minimum(np.full(6, problem.couple_max_n_m_s), np.concatenate((room - h0, room + h0)))
    u_max = problem.max_thrust_n * MAX_PULSE_S
    bounds = [(0.0, float(u)) for u in u_max] + [(0.0, None)] * 6
    result = linprog(cost, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=dv, bounds=bounds, method='highs')
    if result.status != 0:
        return np.zeros(j_count), np.zeros(3)
    u = result.x[:j_count]
    u = np.where(u >= BIT_MARGIN * problem.min_impulse_bit_n_s, u, 0.0)
    return u, c_body_from_hill.T @ (d @ u)
