"""What the direction-limited thrusters give the transport (package doc, step 1 and 3): the push axis of the
largest pure force about the combined CoM and the burn wrench of a torque with the least side force.
"""


import numpy as np
from scipy.optimize import linprog, minimize

from flyby_planner.transport.model import TransportConfig, TransportModel, TransportRefused
from flyby_sim.dynamics.actuators import allocate_max_force

# Directions tried for the push axis: a Fibonacci lattice of this many on the sphere, with the body axes and the
# CoM's direction, the best then refined locally.
_PUSH_DIRECTIONS = 96
_PUSH_REFINE_EVALUATIONS = 80
# The push axes found, by the combined CoM and the thrusters (a search of some 180 LPs: guidance, the planner and each
# slew's re-solve ask for the same body's); emptied beyond this many bodies.
_PUSH_AXES = {}
_PUSH_AXES_KEPT = 32


def push_axis(body):
    """``find_push_axis`` of the body, once per combined CoM and thruster set: (b, largest pure force [N])."""
    layout = body.layout
    key = tuple(np.asarray(a, dtype=float).tobytes() for a in (
        body.com_body_m, layout.positions_body_m, layout.force_directions_body, layout.max_thrust_n))
    if key not in _PUSH_AXES:
        if len(_PUSH_AXES) >= _PUSH_AXES_KEPT:
            _PUSH_AXES.clear()
        _PUSH_AXES[key] = find_push_axis(body)
    axis, force_n = _PUSH_AXES[key]
    return axis.copy(), force_n


def find_push_axis(body):
    """(b, largest pure force along it [N]): the body direction with the largest pure force about the combined CoM
    (package doc, step 1). A force through a CoM metres off the tug mixes thrusters of several faces, so the best
    direction is rarely a body axis (a 28 kg tug holding 618 kg 1.4 m off: 1.8 N along its best axis, 20 N near the
    CoM's direction): the largest of a lattice of directions, refined by Nelder-Mead on the sphere about it. Raises
    TransportRefused if the thrusters give a pure force along none."""
    layout_com = TransportModel(body, TransportConfig()).layout_com

    def force_along(direction):
        try:
            return allocate_max_force(layout_com, direction).force_n
        except ValueError:
            return 0.0

    com = np.asarray(body.com_body_m, dtype=float)
    candidates = [*np.eye(3), *-np.eye(3), *_fibonacci_sphere(_PUSH_DIRECTIONS)]
    if np.linalg.norm(com) > 0.0:
        candidates.append(com / np.linalg.norm(com))
    forces = [force_along(d) for d in candidates]
    best = int(np.argmax(forces))
    if forces[best] <= 0.0:
        raise TransportRefused('no thruster set gives a pure force about the combined CoM along any direction '
                               f'(CoM {np.round(body.com_body_m, 4).tolist()} m from the chaser CoM)')
    axis = candidates[best]
    across = np.linalg.svd(axis[None, :])[2][1:]  # two unit vectors across it

    def tilted(x):
        d = axis + across.T @ x
        return d / np.linalg.norm(d)

    refined = minimize(lambda x: -force_along(tilted(x)), np.zeros(2), method='Nelder-Mead',
                       options={'initial_simplex': [[0.0, 0.0], [0.05, 0.0], [0.0, 0.05]], 'xatol': 1e-4,
                                'fatol': 1e-6 * forces[best], 'maxfev': _PUSH_REFINE_EVALUATIONS})
    if -refined.fun > forces[best]:
        return tilted(refined.x), float(-refined.fun)
    return axis, float(forces[best])


def _fibonacci_sphere(count):
    """count nearly uniform unit vectors (the Fibonacci lattice)."""
    i = np.arange(count) + 0.5
    polar = np.arccos(1.0 - 2.0 * i / count)
    azimuth = np.pi * (1.0 + np.sqrt(5.0)) * i
    return np.column_stack((np.cos(azimuth) * np.sin(polar), np.sin(azimuth) * np.sin(polar), np.cos(polar)))


def torque_capacity_n_m(model, direction_body):
    """The largest torque [N m] about the combined CoM along a body direction at the least side force per unit
    torque the thrusters allow along it (0 if they give none): two LPs, B about the combined CoM,

    1. sigma = min sum s  s.t.  B_T f = u T_ref,  -s <= B_F f <= s,  f >= 0            (per T_ref = 0.01 N m)
    2. max t  s.t.  B_T f = t u,  -s <= B_F f <= s,  sum s <= sigma t / T_ref,  0 <= f <= f_max

    so a slew's burns are made long enough that its torque needs no more side force per unit than the least."""
    b = model.layout_com.wrench_matrix
    n = model.layout_com.count
    u = np.asarray(direction_body, dtype=float) / float(np.linalg.norm(direction_body))
    eye3 = np.eye(3)
    side = np.vstack((np.hstack((b[:3], -eye3, np.zeros((3, 1)))), np.hstack((-b[:3], -eye3, np.zeros((3, 1))))))
    f_bounds = [(0.0, f) for f in model.layout_com.max_thrust_n.tolist()]
    torque_ref = 0.01
    least = linprog(np.concatenate((np.zeros(n), np.ones(3))), A_ub=side[:, :-1], b_ub=np.zeros(6),
                    A_eq=np.hstack((b[3:], np.zeros((3, 3)))), b_eq=torque_ref * u,
                    bounds=f_bounds + [(0.0, None)] * 3, method='highs')
    if least.status != 0:
        return 0.0
    ratio = least.fun / torque_ref * (1.0 + 1e-6) + 1e-9
    budget = np.concatenate((np.zeros(n), np.ones(3), [-ratio]))[None, :]
    largest = linprog(np.concatenate((np.zeros(n + 3), [-1.0])), A_ub=np.vstack((side, budget)), b_ub=np.zeros(7),
                      A_eq=np.hstack((b[3:], np.zeros((3, 3)), -u[:, None])), b_eq=np.zeros(3),
                      bounds=f_bounds + [(0.0, None)] * 4, method='highs')
    return -largest.fun if largest.status == 0 else 0.0


def torque_burn_wrench(model, torque_com):
    """(force [N], torque about the chaser CoM [N m]) of the least side force making torque_com about the combined
    CoM, or None if the thrusters cannot:  min sum s + 1e-3 sum f  s.t.  B_T f = T,  -s <= B_F f <= s,
    0 <= f <= f_max (B about the combined CoM; the small fuel weight breaks ties)."""
    b = model.layout_com.wrench_matrix
    n = model.layout_com.count
    eye3 = np.eye(3)
    a_ub = np.vstack((np.hstack((b[:3], -eye3)), np.hstack((-b[:3], -eye3))))  # |B_F f| <= s component-wise
    result = linprog(np.concatenate((np.full(n, 1e-3), np.ones(3))), A_ub=a_ub, b_ub=np.zeros(6),
                     A_eq=np.hstack((b[3:], np.zeros((3, 3)))), b_eq=torque_com,
                     bounds=[(0.0, f) for f in model.layout_com.max_thrust_n.tolist()] + [(0.0, None)] * 3,
                     method='highs', options={'primal_feasibility_tolerance': 1e-10})
    if result.status != 0:
        return None
    force = b[:3] @ result.x[:n]
    return force, np.asarray(torque_com, dtype=float) + np.cross(model.com_body_m, force)  # T_chaser = T_com + c x F


def torque_wrench(body, config, torque_com_body_n_m):
    """(force [N], torque about the chaser's CoM [N m]), chaser_body, of the least side force that gives
    torque_com_body_n_m about the combined CoM with the body's thrusters (a slew's burns, guidance's detumbling), or
    None where they cannot."""
    return torque_burn_wrench(TransportModel(body, config), np.asarray(torque_com_body_n_m, dtype=float))


def nearest_wrench(body, config, force_body_n, torque_com_n_m):
    """(force [N], torque about the chaser's CoM [N m]), chaser_body: the wrench nearest the wanted one (a force and a
    torque about the combined CoM) that the thrusters give, the torque first (two LPs, B about the combined CoM):

        1. tau = min sum |B_T f - T|                                   s.t.  0 <= f <= f_max
        2.       min sum |B_F f - F| + 1e-6 sum f   s.t.  sum |B_T f - T| <= tau,  0 <= f <= f_max

    A force's error is a velocity error the next estimates see and the next commands take out; a torque's turns the
    body and with it every later force (a 2000 kg body pushed 300 s with 6 N m of torque given up for 7 N of side
    force spun at 0.1 rad/s). A closed-loop push whose wanted force leaves the thrusters' cone of pure forces (a push
    axis off the body axes has a narrow one) gets the nearest force with the torque wanted."""
    model = TransportModel(body, config)
    b = model.layout_com.wrench_matrix
    n = model.layout_com.count
    wanted = np.concatenate((np.asarray(force_body_n, dtype=float), np.asarray(torque_com_n_m, dtype=float)))
    a_eq = np.hstack((b, -np.eye(6), np.eye(6)))  # B f - e+ + e- = wanted
    bounds = [(0.0, f) for f in model.layout_com.max_thrust_n.tolist()] + [(0.0, None)] * 12
    torque_cost = np.concatenate((np.zeros(n + 3), np.ones(3), np.zeros(3), np.ones(3)))
    first = linprog(torque_cost, A_eq=a_eq, b_eq=wanted, bounds=bounds, method='highs')
    if first.status != 0:
        return np.zeros(3), np.zeros(3)
    tau = first.fun * (1.0 + 1e-6) + 1e-6  # HiGHS holds its constraints to 1e-7
    force_cost = np.concatenate((np.full(n, 1e-6), np.ones(3), np.zeros(3), np.ones(3), np.zeros(3)))
    second = linprog(force_cost, A_ub=torque_cost[None, :], b_ub=[tau], A_eq=a_eq, b_eq=wanted, bounds=bounds,
                     method='highs')
    x = (second if second.status == 0 else first).x
    force, torque_com = b[:3] @ x[:n], b[3:] @ x[:n]
    return force, torque_com + np.cross(model.com_body_m, force)
