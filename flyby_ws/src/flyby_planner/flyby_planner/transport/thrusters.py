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


_TORQUE_REF_N_M = 0.01  # the torque the side force per unit torque is found at [N m]


def _side_lp(model):
    """(B, n, |B_F f| <= s rows, thrust bounds): the pieces of the side-force LPs, B about the combined CoM."""
    b = model.layout_com.wrench_matrix
    n = model.layout_com.count
    eye3 = np.eye(3)
    side = np.vstack((np.hstack((b[:3], -eye3, np.zeros((3, 1)))), np.hstack((-b[:3], -eye3, np.zeros((3, 1))))))
    return b, n, side, [(0.0, f) for f in model.layout_com.max_thrust_n.tolist()]


def side_force_ratio(model, direction_body):
    """The least side force per unit torque [N / N m] the thrusters make a torque about the combined CoM along a
    body direction with (L1 norm of the force), or None where they give none along it:

        sigma = min sum s  s.t.  B_T f = u T_ref,  -s <= B_F f <= s,  f >= 0

    0 where a pure couple gives it: a pair of opposed thrusters side by side turns the body about any point."""
    b, n, side, f_bounds = _side_lp(model)
    u = np.asarray(direction_body, dtype=float) / float(np.linalg.norm(direction_body))
    least = linprog(np.concatenate((np.zeros(n), np.ones(3))), A_ub=side[:, :-1], b_ub=np.zeros(6),
                    A_eq=np.hstack((b[3:], np.zeros((3, 3)))), b_eq=_TORQUE_REF_N_M * u,
                    bounds=f_bounds + [(0.0, None)] * 3, method='highs')
    return None if least.status != 0 else float(least.fun) / _TORQUE_REF_N_M


def torque_capacity_n_m(model, direction_body):
    """The largest torque [N m] about the combined CoM along a body direction at the least side force per unit
    torque the thrusters allow along it (``side_force_ratio``; 0 if they give none), an LP, B about the combined CoM:

        max t  s.t.  B_T f = t u,  -s <= B_F f <= s,  sum s <= sigma t,  0 <= f <= f_max

    so a slew's burns are made long enough that its torque needs no more side force per unit than the least."""
    ratio = side_force_ratio(model, direction_body)
    if ratio is None:
        return 0.0
    b, n, side, f_bounds = _side_lp(model)
    u = np.asarray(direction_body, dtype=float) / float(np.linalg.norm(direction_body))
    budget = np.concatenate((np.zeros(n), np.ones(3), [-(ratio * (1.0 + 1e-6) + 1e-9)]))[None, :]
    largest = linprog(np.concatenate((np.zeros(n + 3), [-1.0])), A_ub=np.vstack((side, budget)), b_ub=np.zeros(7),
                      A_eq=np.hstack((b[3:], np.zeros((3, 3)), -u[:, None])), b_eq=np.zeros(3),
                      bounds=f_bounds + [(0.0, None)] * 4, method='highs')
    return -largest.fun if largest.status == 0 else 0.0


def quiet_turn(body, config, from_body, to_body, candidates=36):
    """(axis [unit, body], angle [rad]) of the turn taking the body direction from_body onto to_body whose torques
    the thrusters make with the least side force: the turns taking one direction onto another are about the axes
    a of the plane normal to their difference, each with its own angle; the side impulse of a spin-up and a
    spin-down about a at a given rate is (ratio(a) + ratio(-a)) a.I.a times the rate (``side_force_ratio``), and
    the least of them within a percent, the shortest turn of those. About a CoM metres off the tug a turn by the
    shortest arc may need a side force per unit torque of a metre's lever (a 2000 kg body's turn of 70 deg gave it
    newton-seconds, a thousand times the third condition) where pure couples turn it about another axis."""
    model = TransportModel(body, config)
    b = np.asarray(from_body, dtype=float) / float(np.linalg.norm(from_body))
    d = np.asarray(to_body, dtype=float) / float(np.linalg.norm(to_body))
    if float(np.linalg.norm(b - d)) < 1e-12:
        return np.array([1.0, 0.0, 0.0]), 0.0
    plane = np.linalg.svd((b - d)[None, :])[2][1:]  # two unit vectors normal to b - d
    inertia = np.asarray(body.inertia_body_kg_m2, dtype=float)
    turns = []
    for phi in np.linspace(0.0, np.pi, candidates, endpoint=False):
        a = np.cos(phi) * plane[0] + np.sin(phi) * plane[1]
        b_across, d_across = b - (a @ b) * a, d - (a @ d) * a
        if float(np.linalg.norm(b_across)) < 0.1:  # about an axis near b a turn of b is ill-defined and long
            continue
        angle = float(np.arctan2(a @ np.cross(b_across, d_across), b_across @ d_across))
        a, angle = (a, angle) if angle >= 0.0 else (-a, -angle)
        ratios = (side_force_ratio(model, a), side_force_ratio(model, -a))
        if None in ratios:
            continue
        turns.append((sum(ratios) * float(a @ inertia @ a), angle, a))
    if not turns:
        raise TransportRefused('the thrusters give no torque to turn the push axis about any axis that turns it '
                               'onto the impulse wanted')
    least = min(cost for cost, _, _ in turns)
    _, angle, axis = min((t for t in turns if t[0] <= 1.01 * least + 1e-12), key=lambda t: t[1])
    return axis, angle


def pure_couple(body, config, torque_com):
    """(force [N], torque about the chaser's CoM [N m], torque given about the combined CoM [N m]), chaser_body: the
    couple nearest torque_com the thrusters give with no net force, an LP (B about the combined CoM):

        min sum |B_T f - T| + 1e-6 sum f   s.t.  B_F f = 0,  0 <= f <= f_max

    Opposed thrusters side by side turn the body about any point; about an axis they do not span (a tug whose
    thrusters toward the held body are blocked has none about the axis normal to them) nothing is given."""
    model = TransportModel(body, config)
    b = model.layout_com.wrench_matrix
    n = model.layout_com.count
    wanted = np.asarray(torque_com, dtype=float)
    result = linprog(np.concatenate((np.full(n, 1e-6), np.ones(6))), A_eq=np.vstack((
        np.hstack((b[:3], np.zeros((3, 6)))), np.hstack((b[3:], -np.eye(3), np.eye(3))))),
        b_eq=np.concatenate((np.zeros(3), wanted)),
        bounds=[(0.0, f) for f in model.layout_com.max_thrust_n.tolist()] + [(0.0, None)] * 6, method='highs')
    if result.status != 0:
        return np.zeros(3), np.zeros(3), np.zeros(3)
    force, given = b[:3] @ result.x[:n], b[3:] @ result.x[:n]
    return force, given + np.cross(model.com_body_m, force), given


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


def nearest_wrench(body, config, force_body_n, torque_com_n_m, torque_first=True):
    """(force [N], torque about the chaser's CoM [N m]), chaser_body: the wrench nearest the wanted one (a force and a
    torque about the combined CoM) that the thrusters give, one part first (two LPs, B about the combined CoM; with
    torque_first, e_1 the torque's error and e_2 the force's, else the other way):

        1. tau = min sum |e_1|                                 s.t.  0 <= f <= f_max
        2.       min sum |e_2| + 1e-6 sum f   s.t.  sum |e_1| <= tau,  0 <= f <= f_max

    The torque first where it holds the attitude (thrusters steer the body): a force's error is a velocity error the
    next estimates see and the next commands take out, a torque's turns the body and with it every later force (a
    2000 kg body pushed 300 s with 6 N m of torque given up for 7 N of side force spun at 0.1 rad/s). The force first
    where the torque only empties wheels that hold the body (it can wait for the next push or the terminal program).
    A closed-loop push whose wanted force leaves the thrusters' cone of pure forces (a push axis off the body axes
    has a narrow one) gets the nearest force with the torque wanted."""
    model = TransportModel(body, config)
    b = model.layout_com.wrench_matrix
    n = model.layout_com.count
    wanted = np.concatenate((np.asarray(force_body_n, dtype=float), np.asarray(torque_com_n_m, dtype=float)))
    a_eq = np.hstack((b, -np.eye(6), np.eye(6)))  # B f - e+ + e- = wanted
    bounds = [(0.0, f) for f in model.layout_com.max_thrust_n.tolist()] + [(0.0, None)] * 12
    torque_cost = np.concatenate((np.zeros(n + 3), np.ones(3), np.zeros(3), np.ones(3)))
    force_cost = np.concatenate((np.zeros(n), np.ones(3), np.zeros(3), np.ones(3), np.zeros(3)))
    first_cost, second_cost = (torque_cost, force_cost) if torque_first else (force_cost, torque_cost)
    first = linprog(first_cost, A_eq=a_eq, b_eq=wanted, bounds=bounds, method='highs')
    if first.status != 0:
        return np.zeros(3), np.zeros(3)
    tau = first.fun * (1.0 + 1e-6) + 1e-6  # HiGHS holds its constraints to 1e-7
    second = linprog(second_cost + np.concatenate((np.full(n, 1e-6), np.zeros(12))), A_ub=first_cost[None, :],
                     b_ub=[tau], A_eq=a_eq, b_eq=wanted, bounds=bounds, method='highs')
    x = (second if second.status == 0 else first).x
    force, torque_com = b[:3] @ x[:n], b[3:] @ x[:n]
    return force, torque_com + np.cross(model.com_body_m, force)
