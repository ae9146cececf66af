"""The transport plan (package doc, steps 2-5): the two-impulse transfer, its schedule of slews and pushes, and
Newton on the impulses against the full propagation (``plan_transport``).
"""

import math
from typing import NamedTuple

import numpy as np

from flyby_planner.transfer import terminal_impulses
from flyby_planner.transport.model import (
    TOO_LITTLE_TIME,
    Burn,
    TransportModel,
    TransportPlan,
    TransportRefused,
    check_conditions,
    conditions_of,
    propagate,
    rotate_body,
    unit_vector,
)
from flyby_planner.transport.slew import slew_ending, solve_slew
from flyby_planner.transport.thrusters import push_axis, torque_burn_wrench
from flyby_sim.dynamics.actuators import allocate_wrench
from flyby_sim.dynamics.orbital import (
    cw_transition_matrix,
    hill_axes_in_eci,
    q_eci_from_body,
)
from flyby_sim.dynamics.rotation import (
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_shortest_arc,
)


class _Reschedule(Exception):
    """A schedule that did not hold (a push or a slew torque beyond the thrusters): its reason and the remedy."""

    def __init__(self, reason, slew=None, push=None):
        super().__init__(reason)
        self.reason, self.slew, self.push = reason, slew, push


class _Schedule(NamedTuple):
    slews: tuple  # (Slew, Slew)
    pushes: tuple  # ((k_start, k_len), (k_start, k_len))
    t_mid: tuple  # the pushes' middles [s]


def _grid_ticks(t_s, period_s):
    return math.ceil(t_s / period_s - 1e-9)


def plan_transport(body, state, goal_r_hill, t_arrival_s, config):
    """Plan the combined body's transport from ``state`` to rest at goal_r_hill (fixed in hill) at t_arrival_s
    (package doc: method). Returns a TransportPlan whose predicted end state meets seed 004 §3.2's three conditions;
    raises TransportRefused naming the bound otherwise (no pure force or no torque, too little time or thrust,
    no well-conditioned CW transfer, a wrench the layout cannot deliver, an unmet condition).

    The first push's time is chosen by a search over the CW two-impulse transfers (seed 000 eq 22) from the state
    coasted to each candidate time, the least total delta-v (it keeps away from the transfer times where CW is
    singular: the out-of-plane motion at half an orbit, all of it at a whole one). A schedule that does not hold (a
    push needs more than the pure force, a slew torque more than the thrusters give) is lengthened and planned again.
    """
    model = TransportModel(body, config)
    p = config.period_s
    goal = np.asarray(goal_r_hill, dtype=float)
    b_body, force_max_n = push_axis(body)
    k0 = _grid_ticks(state.t, p)
    k_arr = math.floor(t_arrival_s / p + 1e-9)
    if k_arr <= k0:
        raise TransportRefused(f'arrival at {t_arrival_s} s is not after the state at {state.t} s')
    q0_eci = q_eci_from_body(state.t, model.n, quat_normalize(state.q_hill_from_body))
    omega0 = np.asarray(state.omega_body, dtype=float)
    q0_eci, omega0 = rotate_body(model, config, q0_eci, omega0, state.t, k0 * p, ())  # torque-free to the grid
    dv, t_mid1 = _first_push(model, config, state, goal, k0, k_arr, force_max_n)
    push_force_n = [config.push_force_fraction * force_max_n] * 2
    burn_factor = [1, 1]
    for _ in range(4):
        try:
            schedule = _schedule(model, config, b_body, q0_eci, omega0, k0, k_arr, dv, t_mid1, push_force_n,
                                 burn_factor)
            burns, end = _solve_impulses(model, config, body, state, b_body, force_max_n, q0_eci, omega0, k0 * p,
                                         schedule, goal, k_arr * p)
            break
        except _Reschedule as failed:
            reason = failed.reason
            if failed.slew is not None:
                burn_factor[failed.slew] *= 2
            else:
                k, x = failed.push
                dv[k] = x  # the impulse it needed, pushed at the thrusters' fraction again
    else:
        raise TransportRefused(reason)
    conditions = conditions_of(body, end, goal)
    check_conditions(conditions, config)
    fuel = 0.0
    for burn in burns:
        allocation = allocate_wrench(body.layout, burn.force_body_n, burn.torque_body_n_m)
        if allocation.saturated:
            raise TransportRefused(f'the {burn.purpose} burn at {burn.t_start_s:.1f} s is beyond the thrusters: '
                                   f'{np.round(allocation.wrench_undelivered_body, 4).tolist()} undelivered')
        fuel += allocation.total_thrust_n * burn.duration_s / body.layout.exhaust_velocity_mps
    return TransportPlan(tuple(burns), k_arr * p, end, conditions, fuel, len(burns))


def _first_push(model, config, state, goal, k0, k_arr, force_max_n):
    """(dv (two hill impulses [m/s]), the first push's middle [s]): the least total CW delta-v over the first push's
    times that leave room for two half-turn slews and both pushes (plan_transport's doc)."""
    p = config.period_s
    t_arr = k_arr * p
    r0v0 = np.concatenate((state.r_hill, state.v_hill)).astype(float)
    half_turn_s = math.pi / config.slew_rate_rad_s
    best, reason = None, None
    for t1 in np.linspace(k0 * p + half_turn_s, t_arr - half_turn_s, 400):
        if t1 <= k0 * p or t1 >= t_arr:  # a window shorter than two half-turns: linspace runs backwards
            continue
        r1, v1 = np.split(cw_transition_matrix(model.n, t1 - state.t) @ r0v0, 2)
        try:
            dv = _cw_two_impulse(model.n, r1, v1, goal, t_arr - t1)
        except TransportRefused as singular:
            reason = singular.reason
            continue
        push_s = sum(model.mass_kg * float(np.linalg.norm(x)) / (config.push_force_fraction * force_max_n)
                     for x in dv)
        if t1 + push_s + half_turn_s > t_arr:
            reason = (f'{TOO_LITTLE_TIME}: pushes of {push_s:.1f} s at {config.push_force_fraction} of the largest '
                      f'pure force ({force_max_n:.3g} N) and two half-turn slews do not fit in {t_arr - k0 * p:.1f} s')
            continue
        cost = sum(float(np.linalg.norm(x)) for x in dv)
        if best is None or cost < best[0]:
            best = (cost, dv, float(t1))
    if best is None:
        raise TransportRefused(reason or f'{TOO_LITTLE_TIME}: {t_arr - k0 * p:.1f} s does not hold two half-turn slews '
                                         f'of {half_turn_s:.0f} s at {config.slew_rate_rad_s} rad/s')
    return list(best[1]), best[2]


def _schedule(model, config, b_body, q0_eci, omega0, k0, k_arr, dv, t_mid1, push_force_n, burn_factor):
    """Slew A, push 1 (its middle near t_mid1), slew B, push 2 (ending at the arrival), on the control grid."""
    p = config.period_s
    n = model.n
    k_len = [max(1, _grid_ticks(model.mass_kg * float(np.linalg.norm(x)) / f, p)) for x, f in zip(dv, push_force_n,
                                                                                                   strict=True)]
    k_push1 = max(k0 + 1, round(t_mid1 / p - 0.5 * k_len[0]))
    u1_eci = hill_axes_in_eci((k_push1 + 0.5 * k_len[0]) * p, n) @ unit_vector(dv[0])
    slew_a = slew_ending(model, config, q0_eci, omega0, b_body, u1_eci, k_push1, burn_factor[0])
    for _ in range(2):  # sized again on the attitude a turning body coasts to by the slew's start
        q_a, w_a = rotate_body(model, config, q0_eci, omega0, k0 * p, max(slew_a.k_start, k0) * p, ())
        slew_a = slew_ending(model, config, q_a, w_a, b_body, u1_eci, k_push1, burn_factor[0])
    if slew_a.k_start < k0:  # no room before: push 1 later
        slew_a = slew_a._replace(k_start=k0, k_end=k0 + slew_a.k_end - slew_a.k_start)
        k_push1 = slew_a.k_end
    k_push2 = k_arr - k_len[1]
    t_mid = ((k_push1 + 0.5 * k_len[0]) * p, (k_push2 + 0.5 * k_len[1]) * p)
    u2_eci = hill_axes_in_eci(t_mid[1], n) @ unit_vector(dv[1])
    slew_b = slew_ending(model, config, _aimed(q0_eci, b_body, u1_eci), np.zeros(3), b_body, u2_eci, k_push2,
                          burn_factor[1])
    if slew_b.k_start < k_push1 + k_len[0]:
        need_s = (k_len[0] + k_len[1] + slew_a.k_end - slew_a.k_start + slew_b.k_end - slew_b.k_start) * p
        raise TransportRefused(f'{TOO_LITTLE_TIME}: the slews and pushes need {need_s:.1f} s after the state, the '
                               f'arrival leaves {(k_arr - k0) * p:.1f} s')
    return _Schedule((slew_a, slew_b), ((k_push1, k_len[0]), (k_push2, k_len[1])), t_mid)


def _solve_impulses(model, config, body, state, b_body, force_max_n, q0_eci, omega0, t_grid_s, schedule, goal, t_arr):
    """Newton on the two impulses x (hill, 6) against the full propagation (package doc, step 4): (burns, end)."""
    n = model.n
    # d[r, v](t_arr) / d[dv1, dv2] by CW at the pushes' middles, then Broyden's update: the slews' side forces
    # move the end too (an out-of-plane aim turns the body about an axis without a pure torque)
    jacobian = np.hstack([cw_transition_matrix(n, t_arr - t)[:, 3:] for t in schedule.t_mid])
    # the CW transfer again with the schedule's times, coasting by CW to the first push
    r1, v1 = np.split(cw_transition_matrix(n, schedule.t_mid[0] - state.t)
                      @ np.concatenate((state.r_hill, state.v_hill)).astype(float), 2)
    x = np.concatenate(_cw_two_impulse(n, r1, v1, goal, t_arr - schedule.t_mid[0]))
    tolerance = config.solve_fraction * np.array([config.max_position_error_m,
                                                  config.max_momentum_error_n_s / model.mass_kg])
    starts = [None, None]
    previous = None
    for _ in range(config.max_iterations):
        burns, starts = _build(model, config, b_body, force_max_n, q0_eci, omega0, t_grid_s, schedule, x, t_arr,
                               starts)
        end = propagate(body, state, burns, t_arr, config)
        residual = np.concatenate((end.r_hill - goal, end.v_hill))
        if np.linalg.norm(residual[:3]) < tolerance[0] and np.linalg.norm(residual[3:]) < tolerance[1]:
            break
        if previous is not None:  # Broyden's update
            dx, dr = x - previous[0], residual - previous[1]
            jacobian = jacobian + np.outer(dr - jacobian @ dx, dx) / float(dx @ dx)
        previous = (x, residual)
        x = x - np.linalg.solve(jacobian, residual)
    return burns, end


def _aimed(q_eci, b_body, u_eci):
    """The attitude reached from q_eci by the shortest arc taking b onto u (inertial)."""
    return quat_multiply(quat_shortest_arc(quat_rotate(q_eci, b_body), u_eci), q_eci)


def _cw_two_impulse(n, r0, v0, goal, dt_s):
    """The CW two-impulse transfer (seed 000 eq 28-29, ``transfer.terminal_impulses``) from (r0, v0) to rest at goal
    after dt_s: [dv1, dv2] hill; refused near CW's singular transfer times, where the impulses blow up."""
    if not dt_s > 0.0:
        raise TransportRefused(f'no time for the transfer: {dt_s:.1f} s')
    phi12 = cw_transition_matrix(n, dt_s)[:3, 3:]
    if np.linalg.cond(phi12) > 1e6:
        raise TransportRefused(f'the transfer time {dt_s:.1f} s is too near a multiple of the orbit period '
                               f'({2 * math.pi / n:.1f} s): the CW transfer is singular')
    return list(terminal_impulses(r0, v0, goal, np.zeros(3), dt_s, n))


def _build(model, config, b_body, force_max_n, q0_eci, omega0, t_grid_s, schedule, x, t_arr, starts):
    """The burns of impulses x (6,) hill on a schedule: slew A, push 1, slew B, push 2 (package doc), and the slews'
    solutions (warm starts for the next). q0_eci, omega0: the attitude at t_grid_s."""
    p = config.period_s
    burns = []
    q, w = q0_eci, omega0
    new_starts = []
    for k in range(2):
        slew, (k_push, k_len) = schedule.slews[k], schedule.pushes[k]
        dv = x[3 * k:3 * k + 3]
        u_eci = hill_axes_in_eci(schedule.t_mid[k], model.n) @ unit_vector(dv)
        # torque-free to the slew (from the grid's first point, or from slew A's end through push 1's pure force)
        q, w = rotate_body(model, config, q, w, schedule.slews[0].k_end * p if k else t_grid_s,
                       slew.k_start * p, ())
        torques, q, w, jacobian = solve_slew(model, config, slew, q, w, b_body, u_eci, t_arr - slew.k_start * p,
                                              starts[k])
        new_starts.append((torques, jacobian))
        for purpose, k_t, torque in (('slew_start', slew.k_start, torques[:3]),
                                     ('slew_stop', slew.k_end - slew.k_burn, torques[3:])):
            if not np.any(torque):
                continue
            wrench = torque_burn_wrench(model, torque)
            if wrench is None:
                raise _Reschedule(f'the {purpose} torque {np.round(torque, 4).tolist()} N m about the combined CoM at '
                                  f'{k_t * p:.1f} s is beyond the thrusters', slew=k)
            burns.append(Burn(k_t * p, slew.k_burn * p, wrench[0], wrench[1], purpose))
        force_n = model.mass_kg * float(np.linalg.norm(dv)) / (k_len * p)
        if force_n > force_max_n:
            raise _Reschedule(f'push {k + 1} needs {force_n:.3g} N along body {np.round(b_body, 3).tolist()} for '
                              f'{k_len * p:.1f} s, the thrusters give at most {force_max_n:.3g} N of pure force there',
                              push=(k, dv.copy()))
        force = force_n * b_body
        burns.append(Burn(k_push * p, k_len * p, force, np.cross(model.com_body_m, force), 'push'))
    return burns, new_starts
