"""The transport planner's pure core (issue 17): the combined body moved to a goal point on the reference orbit
with direction-limited thrusters, seed 004 §2.3 (orbit advance, Fig 4's "acrobatic" motion) and §3.2 (its
simulation and three rendezvous conditions).

Frames and conventions. Body vectors are in ``chaser_body`` axes and from the chaser's CoM unless the name says
``com`` (the combined CoM, c from the chaser's). ``r_hill``, ``v_hill`` are the combined CoM's position and velocity
relative to the rotating hill frame (``flyby_sim.dynamics.orbital``). Quaternions are (x, y, z, w), scalar last;
the planner turns ``q_hill_from_body`` into ``q_eci_from_body`` (``orbital.q_eci_from_body``) and works in inertial
space, where a body at rest stays at rest (it turns in hill at n about hill -y). A burn's torque is about the
chaser's CoM (the ``/guidance/wrench`` contract); about the combined CoM it is T_com = T_chaser - c x F (seed 004
§2.2, ``combined_body`` module doc).

The planner's model (``propagate``): the combined CoM on the nonlinear relative dynamics (seed 000 eq 1,
``orbital.nonlinear_relative_accel_components``) with the burn's body force turned into hill by the attitude; the
rotation by Euler's equation about the combined CoM (``attitude.euler_rate``); gravity-gradient torque and the
fuel's mass left out (seed 004 §3.2 assumptions 2 and 4; its assumption 3, impulsive inputs, is replaced by finite
burns on the control grid). Classical RK4 (``orbital.rk4_step``), steps cut at every burn edge and limited to
``max_step_s`` and to ``max_step_angle_rad`` of rotation.

The rendezvous conditions of seed 004 §3.2, read as: (1) the angular momentum about the combined CoM below
0.1 kg m^2/s; (2) the CoM within 10 m of the goal; (3) "orbital momentum error below 0.01 N m s": the paper's unit
is garbled (N m s is an angular momentum); we read it as the linear momentum relative to the goal's circular motion,
m |v_hill| < 0.01 N s (the goal is fixed in hill).

The method (constructive, seed 004 §2.3's Fig 4 made systematic; the paper found its sequences by trial and error):

1. The push axis b: the body axis (of +-x, +-y, +-z) along which the allowed thrusters give the largest pure force
   about the combined CoM (``actuators.allocate_max_force`` on the layout moved to the combined CoM: max s with
   B_F f = s b, B_T f = 0, 0 <= f <= f_max). Every push is along b and turns nothing.
2. A two-impulse transfer: the CW solution (seed 000 eq 22) gives the first guess of the two impulses (hill), the
   first push's time searched for the least total delta-v (away from CW's singular transfer times), the second
   push ending at the arrival time.
3. Before each push a rest-to-rest slew aims b along the push's direction (inertial, at the push's middle): a spin-up
   burn, a torque-free coast, a spin-down burn; their body torques (six numbers) are found by Newton shooting on
   Euler's equation so that the rate is zero and b points along the push at the slew's end (roll about b left
   free: the least-norm Newton step). The burns are made long enough that each torque needs no more side force
   per unit than the least the thrusters allow along it (a pure torque where one exists), and each is allocated
   with the least side force (a linear program); a layout without a pure torque (the default less its -x pair has
   none about z) pushes the body while it turns.
4. Newton on the two impulses (six numbers, hill) against the full propagation of the whole sequence (slews' side
   forces, finite pushes, hill's turn during a push, the nonlinear dynamics), with the CW Jacobian of the impulses
   at the pushes' middles and Broyden's update (an out-of-plane aim turns the body about z, whose torque pushes).
   A schedule that does not hold (a push or a torque beyond the thrusters) is lengthened and planned again.
5. The three conditions checked on ``propagate``'s end state; ``TransportRefused`` names the bound otherwise.
"""

import dataclasses
import math
from typing import NamedTuple

import numpy as np
from scipy.optimize import linprog

from flyby_planner.transfer import terminal_impulses
from flyby_sim.dynamics.actuators import ThrusterLayout, allocate_max_force, allocate_wrench
from flyby_sim.dynamics.attitude import euler_rate, quaternion_rate
from flyby_sim.dynamics.constants import MU_EARTH_M3_S2
from flyby_sim.dynamics.orbital import (
    cw_transition_matrix,
    hill_axes_in_eci,
    mean_motion_rad_s,
    nonlinear_relative_accel_components,
    q_eci_from_body,
    q_hill_from_body,
    rk4_step,
)
from flyby_sim.dynamics.rotation import (
    quat_from_axis_angle,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_shortest_arc,
    rotation_vector_from_quat,
)


@dataclasses.dataclass(frozen=True)
class TransportBody:
    """The combined body as the planner knows it: chaser_body axes, vectors from the chaser's CoM."""

    mass_kg: float  # chaser + target (estimated)
    com_body_m: np.ndarray  # (3,) the combined CoM from the chaser's CoM
    inertia_body_kg_m2: np.ndarray  # (3, 3) about the combined CoM, chaser_body axes
    layout: ThrusterLayout  # the thrusters the tug may fire in transport, positions from the chaser's CoM


class TransportState(NamedTuple):
    """The combined body's state."""

    t: float  # [s]
    r_hill: np.ndarray  # the combined CoM [m], hill (origin: the reference orbit's point)
    v_hill: np.ndarray  # its velocity relative to the rotating hill frame [m/s]
    q_hill_from_body: np.ndarray  # chaser_body in hill, (x, y, z, w)
    omega_body: np.ndarray  # inertial angular velocity, chaser_body axes [rad/s]


class Burn(NamedTuple):
    """A constant body wrench held over whole control periods."""

    t_start_s: float  # on the control grid (k * period_s)
    duration_s: float  # a whole number of control periods
    force_body_n: np.ndarray  # constant body force [N], chaser_body
    torque_body_n_m: np.ndarray  # constant torque about the CHASER's CoM [N m] (the /guidance/wrench contract)
    purpose: str  # 'slew_start', 'slew_stop', 'push'


class TransportPlan(NamedTuple):
    """A planned transport and its predicted end (by ``propagate``)."""

    burns: tuple  # in time order, non-overlapping
    t_arrival_s: float
    predicted: TransportState  # at t_arrival_s, by `propagate`
    conditions: dict  # angular_momentum_kg_m2_s, position_error_m, momentum_error_n_s (predicted)
    fuel_kg: float
    impulses: int  # number of burns


@dataclasses.dataclass(frozen=True)
class TransportConfig:
    """The planner's settings."""

    period_s: float = 0.1  # guidance's control period (wrench commands are held this long)
    radius_m: float = 7.0e6  # the reference orbit (nonlinear relative dynamics, seed 000 eq 1)
    mu: float = MU_EARTH_M3_S2
    max_angular_momentum_kg_m2_s: float = 0.1  # seed 004 §3.2 condition 1
    max_position_error_m: float = 10.0  # condition 2
    max_momentum_error_n_s: float = 0.01  # condition 3 (module doc: our reading)
    slew_rate_rad_s: float = 0.01  # a slew's coasting rate
    push_force_fraction: float = 0.7  # of the largest pure force: room for Newton's corrections of a push
    slew_torque_fraction: float = 0.5  # of the largest torque along the slew's: room for the shooting's corrections
    solve_fraction: float = 0.01  # Newton stops with each condition's value below this fraction of its bound
    max_iterations: int = 20  # of the Newton on the impulses
    max_step_s: float = 5.0  # RK4 step limit [s]
    max_step_angle_rad: float = 0.02  # and the rotation per step


class TransportRefused(Exception):
    """No plan: ``reason`` names the bound that refused it."""

    def __init__(self, reason):
        super().__init__(reason)
        self.reason = reason


class _Model:
    """Quantities of the body and the orbit every step needs, computed once."""

    def __init__(self, body, config):
        self.mass_kg = float(body.mass_kg)
        self.com_body_m = np.asarray(body.com_body_m, dtype=float)
        self.inertia = np.asarray(body.inertia_body_kg_m2, dtype=float)
        self.inertia_inv = np.linalg.inv(self.inertia)
        self.inertia_t = self.inertia.tolist()
        self.inertia_inv_t = self.inertia_inv.tolist()
        self.n = mean_motion_rad_s(config.radius_m, config.mu)
        self.radius_m = float(config.radius_m)
        layout = body.layout
        # The thrusters seen from the combined CoM: their torques are then the T_com of seed 004 §2.2.
        self.layout_com = ThrusterLayout(layout.positions_body_m - self.com_body_m, layout.force_directions_body,
                                         layout.max_thrust_n, layout.isp_s, layout.min_impulse_bit_n_s)


def _full_rates(model, force_body, torque_com):
    """d/dt of (r_hill, v_hill, q_eci_from_body, omega_body) under a constant body wrench (module doc)."""
    force = np.asarray(force_body, dtype=float) / model.mass_kg
    pushes = bool(np.any(force))

    def rates(t, y):
        q, w = y[6:10], y[10:13]
        a_hill = (hill_axes_in_eci(t, model.n).T @ quat_rotate(q, force)).tolist() if pushes else (0.0, 0.0, 0.0)
        accel = nonlinear_relative_accel_components(y[0:3].tolist(), y[3:6].tolist(), model.n, model.radius_m,
                                                    a_hill)  # seed 000 eq 1
        return np.concatenate((y[3:6], accel, quaternion_rate(q, w),
                               euler_rate(w, model.inertia_t, model.inertia_inv_t, torque_com)))
    return rates


def _rotation_rates(model, torque_com):
    """d/dt of (q_eci_from_body, omega_body): Euler's equation about the combined CoM (seed 004 §2.2)."""
    def rates(_t, y):
        return np.concatenate((quaternion_rate(y[0:4], y[4:7]),
                               euler_rate(y[4:7], model.inertia_t, model.inertia_inv_t, torque_com)))
    return rates


def _integrate(rates, y, t_a, t_b, omega_slice, alpha_bound, config):
    """RK4 from t_a to t_b with steps limited in time and in rotation (alpha_bound: |omega_dot| over the segment)."""
    t = t_a
    while t_b - t > 1e-9:
        w = float(np.linalg.norm(y[omega_slice])) + alpha_bound * config.max_step_s
        h = min(config.max_step_s, t_b - t, config.max_step_angle_rad / w if w > 0.0 else math.inf)
        y = rk4_step(rates, t, y, h)
        q = y[omega_slice.start - 4:omega_slice.start]
        y[omega_slice.start - 4:omega_slice.start] = q / math.sqrt(float(q @ q))
        t += h
    return y


def _segments(burns, t_a, t_b):
    """(t_start, t_end, burn index or None) covering [t_a, t_b], cut at every burn edge."""
    edges = {t_a, t_b}
    for burn in burns:
        edges.update(e for e in (burn.t_start_s, burn.t_start_s + burn.duration_s) if t_a < e < t_b)
    edges = sorted(edges)
    out = []
    for s, e in zip(edges[:-1], edges[1:], strict=True):
        active = [i for i, b in enumerate(burns) if b.t_start_s <= s < b.t_start_s + b.duration_s - 1e-9]
        out.append((s, e, active[0] if active else None))
    return out


def _applied_wrench(burn, error):
    """(force [N], torque about the chaser CoM [N m]) of a burn with optional multipliers (scalar or 3x3 each)."""
    force = np.asarray(burn.force_body_n, dtype=float)
    torque = np.asarray(burn.torque_body_n_m, dtype=float)
    if error is None:
        return force, torque
    force_factor, torque_factor = error
    return np.dot(force_factor, force), np.dot(torque_factor, torque)


def propagate(body, state, burns, t_end_s, config, errors=None):
    """The planner's model (module doc) from ``state`` to t_end_s under ``burns``: a TransportState.

    errors: optional, one (force_factor, torque_factor) per burn (each a scalar or a 3x3 matrix, applied to the
    burn's force and to its torque about the chaser CoM), for execution-error studies.
    """
    model = _Model(body, config)
    burns = tuple(burns)
    _check_burns(burns)
    if errors is not None and len(errors) != len(burns):
        raise ValueError(f'errors must give one (force, torque) factor pair per burn ({len(burns)}), got {len(errors)}')
    y = np.concatenate((state.r_hill, state.v_hill,
                        q_eci_from_body(state.t, model.n, quat_normalize(state.q_hill_from_body)),
                        state.omega_body)).astype(float)
    for t_a, t_b, i in _segments(burns, float(state.t), float(t_end_s)):
        force, torque = np.zeros(3), np.zeros(3)
        if i is not None:
            force, torque = _applied_wrench(burns[i], None if errors is None else errors[i])
        torque_com = torque - np.cross(model.com_body_m, force)  # T_com = T_chaser - c x F (seed 004 §2.2)
        alpha = float(np.linalg.norm(model.inertia_inv @ torque_com))
        y = _integrate(_full_rates(model, force, torque_com.tolist()), y, t_a, t_b, slice(10, 13), alpha, config)
    return TransportState(float(t_end_s), y[0:3].copy(), y[3:6].copy(),
                          q_hill_from_body(float(t_end_s), model.n, y[6:10]), y[10:13].copy())


def attitude_at(body, config, q_eci, omega_body, t_a, t_b, burns):
    """(q_eci_from_body, omega_body) at t_b from (q_eci, omega_body) at t_a under the burns' torques about the
    combined CoM (T_com = T_chaser - c x F, seed 004 §2.2; Euler's equation, torque-free between the burns): the
    planner's attitude, which guidance's wheels track (``transport_control``)."""
    model = _Model(body, config)
    burns = tuple(burns)
    q, w = np.asarray(q_eci, dtype=float), np.asarray(omega_body, dtype=float)
    for s, e, i in _segments(burns, float(t_a), float(t_b)):
        torque = np.zeros(3)
        if i is not None:
            force = np.asarray(burns[i].force_body_n, dtype=float)
            torque = np.asarray(burns[i].torque_body_n_m, dtype=float) - np.cross(model.com_body_m, force)
        q, w = _rotate(model, config, q, w, s, e, ((s, e, torque),))
    return q, w


def _check_burns(burns):
    for a, b in zip(burns[:-1], burns[1:], strict=False):
        if b.t_start_s < a.t_start_s + a.duration_s - 1e-9:
            raise ValueError(f'burns overlap or are out of order: {a.purpose} at {a.t_start_s} s '
                             f'for {a.duration_s} s, then {b.purpose} at {b.t_start_s} s')


def conditions_of(body, state, goal_r_hill, h_wheels_body_n_m_s=(0.0, 0.0, 0.0)):
    """Seed 004 §3.2's three rendezvous quantities of a state (module doc), the wheels' angular momentum [N m s, body]
    included: a dict."""
    h = (np.asarray(body.inertia_body_kg_m2, dtype=float) @ np.asarray(state.omega_body, dtype=float)
         + np.asarray(h_wheels_body_n_m_s, dtype=float))
    return {
        'angular_momentum_kg_m2_s': float(np.linalg.norm(h)),
        'position_error_m': float(np.linalg.norm(np.asarray(state.r_hill) - np.asarray(goal_r_hill, dtype=float))),
        'momentum_error_n_s': float(body.mass_kg * np.linalg.norm(state.v_hill)),
    }


def push_axis(body):
    """(b, largest pure force along it [N]): the body axis with the largest pure force about the combined CoM
    (module doc, step 1). Raises TransportRefused if no body axis has one."""
    layout_com = _Model(body, TransportConfig()).layout_com
    best = None
    for axis in np.vstack((np.eye(3), -np.eye(3))):
        try:
            force_n = allocate_max_force(layout_com, axis).force_n
        except ValueError:
            continue
        if best is None or force_n > best[1]:
            best = (axis, force_n)
    if best is None:
        raise TransportRefused('no thruster set gives a pure force about the combined CoM along any body axis '
                               f'(CoM {np.round(body.com_body_m, 4).tolist()} m from the chaser CoM)')
    return best


def _torque_capacity_n_m(model, direction_body):
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


def _torque_burn_wrench(model, torque_com):
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
    return _torque_burn_wrench(_Model(body, config), np.asarray(torque_com_body_n_m, dtype=float))


def resolve_slew(body, config, state, slew_start, slew_stop, u_hill, t_aim_s, t_arrival_s):
    """A planned slew's burns (slew_start, slew_stop) solved again from the state (the estimate before the slew)
    so that the push axis ends along the hill direction u_hill at t_aim_s (the push's middle) at rest: the same
    Newton shooting on Euler's equation as the plan's (guidance flies the slew from where the body really is).
    Returns the two new Burns; TransportRefused where it does not converge or the thrusters cannot."""
    model = _Model(body, config)
    p = config.period_s
    b_body, _ = push_axis(body)
    k_start = round(slew_start.t_start_s / p)
    slew = _Slew(k_start, round(slew_start.duration_s / p), round((slew_stop.t_start_s + slew_stop.duration_s) / p))
    q_eci = q_eci_from_body(state.t, model.n, quat_normalize(state.q_hill_from_body))
    q_eci, omega = _rotate(model, config, q_eci, np.asarray(state.omega_body, dtype=float), state.t, k_start * p, ())
    u_eci = hill_axes_in_eci(t_aim_s, model.n) @ _unit(np.asarray(u_hill, dtype=float))
    torques, _, _, _ = _solve_slew(model, config, slew, q_eci, omega, b_body, u_eci, t_arrival_s - k_start * p)
    burns = []
    for old, torque in ((slew_start, torques[:3]), (slew_stop, torques[3:])):
        wrench = _torque_burn_wrench(model, torque)
        if wrench is None:
            raise TransportRefused(f'the {old.purpose} torque {np.round(torque, 4).tolist()} N m about the combined '
                                   f'CoM at {old.t_start_s:.1f} s is beyond the thrusters')
        burns.append(old._replace(force_body_n=wrench[0], torque_body_n_m=wrench[1]))
    return tuple(burns)


# A slew's shooting that lands on b = -u starts again from arcs about these axes, turned about b [rad].
_SLEW_RESTART_TURNS_RAD = (0.5 * np.pi, -0.5 * np.pi)
# A slew's shooting that asks its spin-up for more than this times the slew rate has diverged.
_DIVERGED_RATE_FACTOR = 20.0
# A slew ends with the push axis this close to its aim [rad], and its residual rate turns it less up to the arrival.
_AIM_RAD = 1e-9


class _Slew(NamedTuple):
    """A rest-to-rest slew's schedule on the grid (ticks of the control period)."""

    k_start: int
    k_burn: int  # the spin-up's and the spin-down's length
    k_end: int


class _Reschedule(Exception):
    """A schedule that did not hold (a push or a slew torque beyond the thrusters): its reason and the remedy."""

    def __init__(self, reason, slew=None, push=None):
        super().__init__(reason)
        self.reason, self.slew, self.push = reason, slew, push


class _Schedule(NamedTuple):
    slews: tuple  # (_Slew, _Slew)
    pushes: tuple  # ((k_start, k_len), (k_start, k_len))
    t_mid: tuple  # the pushes' middles [s]


def _slew_ticks(model, config, angle_rad, momentum_body, burn_factor):
    """(k_burn, k_total) of a slew turning angle_rad at the slew rate: burns long enough that the spin-up's and the
    spin-down's torques (first guess: momentum_body over each) are within slew_torque_fraction of the thrusters'
    at the least side force (``_torque_capacity_n_m``), times burn_factor (a reschedule's)."""
    p = config.period_s
    k_coast = max(1, math.ceil(angle_rad / config.slew_rate_rad_s / p - 1e-9))
    k_burn = 1
    for momentum in momentum_body:
        size = float(np.linalg.norm(momentum))
        if size > 0.0:
            capacity = config.slew_torque_fraction * _torque_capacity_n_m(model, momentum)
            if capacity <= 0.0:
                raise TransportRefused(f'no thruster set gives a torque about body {np.round(momentum / size, 3)} '
                                       'about the combined CoM: the push axis cannot be turned onto the impulse')
            k_burn = max(k_burn, math.ceil(size / capacity / p - 1e-9))
    k_burn *= burn_factor
    return k_burn, k_coast + 2 * k_burn


def _slew_ending(model, config, q_eci, omega_body, b_body, u_eci, k_end, burn_factor):
    """The slew ending at tick k_end that turns b from q_eci (at rate omega_body) onto u_eci."""
    angle = float(np.linalg.norm(rotation_vector_from_quat(quat_shortest_arc(quat_rotate(q_eci, b_body), u_eci))))
    momentum = _slew_guess(model, q_eci, omega_body, b_body, u_eci, 1.0,
                           max(angle / config.slew_rate_rad_s, config.period_s))
    k_burn, k_total = _slew_ticks(model, config, angle, (momentum[:3], momentum[3:]), burn_factor)
    return _Slew(k_end - k_total, k_burn, k_end)


def _slew_guess(model, q_eci, omega_body, b_body, u_eci, burn_s, coast_s, axis_turn_rad=0.0):
    """Spin-up and spin-down torques [N m] (6,) of a rigid rotation about the shortest arc (its axis turned about b by
    axis_turn_rad: an arc of the same angle that ends elsewhere, a restart's guess), gyroscopic terms left to the
    shooting: I (omega_c - omega_0) / d and -I omega_c / d, omega_c the arc over the coast."""
    b_eci = quat_rotate(q_eci, b_body)
    arc_eci = quat_rotate(quat_from_axis_angle(b_eci, axis_turn_rad),
                          rotation_vector_from_quat(quat_shortest_arc(b_eci, u_eci)))
    arc_body = quat_rotate(np.concatenate((-np.asarray(q_eci[:3]), q_eci[3:])), arc_eci)
    omega_c = arc_body / (coast_s + burn_s)  # the burns each turn the body about half as far as a coast as long
    return np.concatenate((model.inertia @ (omega_c - omega_body), -model.inertia @ omega_c)) / burn_s


def _rotate(model, config, q_eci, omega_body, t_a, t_b, torque_segments):
    """q_eci_from_body and omega_body at t_b under (t_start, t_end, torque about the combined CoM) segments (none:
    torque-free)."""
    y = np.concatenate((q_eci, omega_body)).astype(float)
    for s, e, torque in torque_segments or ((t_a, t_b, np.zeros(3)),):
        if e > s:
            alpha = float(np.linalg.norm(model.inertia_inv @ torque))
            y = _integrate(_rotation_rates(model, torque.tolist()), y, max(s, t_a), min(e, t_b), slice(4, 7), alpha,
                           config)
    return y[0:4], y[4:7]


def _solve_slew(model, config, slew, q_eci, omega_body, b_body, u_eci, horizon_s, start=None):
    """The spin-up and spin-down torques about the combined CoM (body axes) that end the slew at rest with b along
    u_eci: Newton shooting on Euler's equation, the least-norm step of five conditions in six unknowns (the rate,
    and b's two components across u; the roll about b is free), again from the arcs of _SLEW_RESTART_TURNS_RAD where
    it lands on b = -u. Returns (torques (6,), q_eci and omega_body at the end, the Jacobian used)."""
    p = config.period_s
    t_a, t_b = slew.k_start * p, slew.k_end * p
    d = slew.k_burn * p
    u = np.asarray(u_eci, dtype=float)
    across = np.cross(u, np.eye(3)[int(np.argmin(np.abs(u)))])
    across /= np.linalg.norm(across)
    across = np.vstack((across, np.cross(u, across)))
    scale_s = t_b - t_a
    # Tight, so that what is left turns the body by less than _AIM_RAD up to the arrival: the Newton on the impulses
    # then sees a smooth function of them.
    omega_tol = _AIM_RAD / horizon_s

    def end(z):
        segments = ((t_a, t_a + d, z[:3]), (t_a + d, t_b - d, np.zeros(3)), (t_b - d, t_b, z[3:]))
        return _rotate(model, config, q_eci, omega_body, t_a, t_b, segments)

    def residual(z):
        q, w = end(z)
        return np.concatenate((w * scale_s, across @ quat_rotate(q, b_body))), q, w

    def guess(axis_turn_rad=0.0):
        return _slew_guess(model, q_eci, omega_body, b_body, u, d, t_b - t_a - 2 * d, axis_turn_rad)

    if start is None:
        z, jacobian = guess(), None
    else:  # the last solution and its Jacobian (the Newton on the impulses moves the aim a little)
        z, jacobian = start
    rate_bound = _DIVERGED_RATE_FACTOR * max(config.slew_rate_rad_s, float(np.linalg.norm(omega_body)))
    restarts = list(_SLEW_RESTART_TURNS_RAD)
    for iteration in range(30 * (1 + len(restarts))):
        r, q, w = residual(z)
        if np.linalg.norm(w) < omega_tol and np.linalg.norm(r[3:]) < _AIM_RAD:
            if float(quat_rotate(q, b_body) @ u) > 0.0:
                return z, q, w, jacobian
            if not restarts:
                break
            # b on -u, the residual's other root (its components across u vanish there too): again from an arc
            # about another axis
            z, jacobian = guess(restarts.pop(0)), None
            continue
        if float(np.linalg.norm(model.inertia_inv @ z[:3])) * d > rate_bound:  # diverging: each step costs more
            break
        if jacobian is None or iteration % 5 == 4:  # chord steps; a fresh Jacobian if they are slow
            step = 1e-6 * max(1.0, float(np.max(np.abs(z))))
            jacobian = np.column_stack([(residual(z + step * e)[0] - r) / step for e in np.eye(6)])
        z = z - np.linalg.lstsq(jacobian, r, rcond=None)[0]
    raise TransportRefused(f'the slew from {t_a:.1f} s to {t_b:.1f} s did not converge: rate {np.linalg.norm(w):.3g} '
                           f'rad/s, pointing {np.linalg.norm(r[3:]):.3g} rad at its end')


def _grid_ticks(t_s, period_s):
    return math.ceil(t_s / period_s - 1e-9)


def plan_transport(body, state, goal_r_hill, t_arrival_s, config):
    """Plan the combined body's transport from ``state`` to rest at goal_r_hill (fixed in hill) at t_arrival_s
    (module doc: method). Returns a TransportPlan whose predicted end state meets seed 004 §3.2's three conditions;
    raises TransportRefused naming the bound otherwise (no pure force or no torque, too little time or thrust,
    no well-conditioned CW transfer, a wrench the layout cannot deliver, an unmet condition).

    The first push's time is chosen by a search over the CW two-impulse transfers (seed 000 eq 22) from the state
    coasted to each candidate time, the least total delta-v (it keeps away from the transfer times where CW is
    singular: the out-of-plane motion at half an orbit, all of it at a whole one). A schedule that does not hold (a
    push needs more than the pure force, a slew torque more than the thrusters give) is lengthened and planned again.
    """
    model = _Model(body, config)
    p = config.period_s
    goal = np.asarray(goal_r_hill, dtype=float)
    b_body, force_max_n = push_axis(body)
    k0 = _grid_ticks(state.t, p)
    k_arr = math.floor(t_arrival_s / p + 1e-9)
    if k_arr <= k0:
        raise TransportRefused(f'arrival at {t_arrival_s} s is not after the state at {state.t} s')
    q0_eci = q_eci_from_body(state.t, model.n, quat_normalize(state.q_hill_from_body))
    omega0 = np.asarray(state.omega_body, dtype=float)
    q0_eci, omega0 = _rotate(model, config, q0_eci, omega0, state.t, k0 * p, ())  # torque-free to the grid
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
    _check_conditions(conditions, config)
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
            reason = (f'too little time: pushes of {push_s:.1f} s at {config.push_force_fraction} of the largest '
                      f'pure force ({force_max_n:.3g} N) and two half-turn slews do not fit in {t_arr - k0 * p:.1f} s')
            continue
        cost = sum(float(np.linalg.norm(x)) for x in dv)
        if best is None or cost < best[0]:
            best = (cost, dv, float(t1))
    if best is None:
        raise TransportRefused(reason or f'too little time: {t_arr - k0 * p:.1f} s does not hold two half-turn slews '
                                         f'of {half_turn_s:.0f} s at {config.slew_rate_rad_s} rad/s')
    return list(best[1]), best[2]


def _schedule(model, config, b_body, q0_eci, omega0, k0, k_arr, dv, t_mid1, push_force_n, burn_factor):
    """Slew A, push 1 (its middle near t_mid1), slew B, push 2 (ending at the arrival), on the control grid."""
    p = config.period_s
    n = model.n
    k_len = [max(1, _grid_ticks(model.mass_kg * float(np.linalg.norm(x)) / f, p)) for x, f in zip(dv, push_force_n,
                                                                                                   strict=True)]
    k_push1 = max(k0 + 1, round(t_mid1 / p - 0.5 * k_len[0]))
    u1_eci = hill_axes_in_eci((k_push1 + 0.5 * k_len[0]) * p, n) @ _unit(dv[0])
    slew_a = _slew_ending(model, config, q0_eci, omega0, b_body, u1_eci, k_push1, burn_factor[0])
    if slew_a.k_start < k0:  # no room before: push 1 later
        slew_a = slew_a._replace(k_start=k0, k_end=k0 + slew_a.k_end - slew_a.k_start)
        k_push1 = slew_a.k_end
    k_push2 = k_arr - k_len[1]
    t_mid = ((k_push1 + 0.5 * k_len[0]) * p, (k_push2 + 0.5 * k_len[1]) * p)
    u2_eci = hill_axes_in_eci(t_mid[1], n) @ _unit(dv[1])
    slew_b = _slew_ending(model, config, _aimed(q0_eci, b_body, u1_eci), np.zeros(3), b_body, u2_eci, k_push2,
                          burn_factor[1])
    if slew_b.k_start < k_push1 + k_len[0]:
        need_s = (k_len[0] + k_len[1] + slew_a.k_end - slew_a.k_start + slew_b.k_end - slew_b.k_start) * p
        raise TransportRefused(f'too little time: the slews and pushes need {need_s:.1f} s after the state, the '
                               f'arrival leaves {(k_arr - k0) * p:.1f} s')
    return _Schedule((slew_a, slew_b), ((k_push1, k_len[0]), (k_push2, k_len[1])), t_mid)


def _solve_impulses(model, config, body, state, b_body, force_max_n, q0_eci, omega0, t_grid_s, schedule, goal, t_arr):
    """Newton on the two impulses x (hill, 6) against the full propagation (module doc, step 4): (burns, end)."""
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


def _unit(v):
    return np.asarray(v, dtype=float) / float(np.linalg.norm(v))


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
    """The burns of impulses x (6,) hill on a schedule: slew A, push 1, slew B, push 2 (module doc), and the slews'
    solutions (warm starts for the next). q0_eci, omega0: the attitude at t_grid_s."""
    p = config.period_s
    burns = []
    q, w = q0_eci, omega0
    new_starts = []
    for k in range(2):
        slew, (k_push, k_len) = schedule.slews[k], schedule.pushes[k]
        dv = x[3 * k:3 * k + 3]
        u_eci = hill_axes_in_eci(schedule.t_mid[k], model.n) @ _unit(dv)
        # torque-free to the slew (from the grid's first point, or from slew A's end through push 1's pure force)
        q, w = _rotate(model, config, q, w, schedule.slews[0].k_end * p if k else t_grid_s,
                       slew.k_start * p, ())
        torques, q, w, jacobian = _solve_slew(model, config, slew, q, w, b_body, u_eci, t_arr - slew.k_start * p,
                                              starts[k])
        new_starts.append((torques, jacobian))
        for purpose, k_t, torque in (('slew_start', slew.k_start, torques[:3]),
                                     ('slew_stop', slew.k_end - slew.k_burn, torques[3:])):
            if not np.any(torque):
                continue
            wrench = _torque_burn_wrench(model, torque)
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


def missed_conditions(conditions, config):
    """[(key, value, bound)] of seed 004 §3.2's conditions that the quantities (``conditions_of``'s keys) miss under
    the TransportConfig's bounds, in the order angular momentum, position, momentum."""
    return [(key, conditions[key], bound)
            for key, bound in (('angular_momentum_kg_m2_s', config.max_angular_momentum_kg_m2_s),
                               ('position_error_m', config.max_position_error_m),
                               ('momentum_error_n_s', config.max_momentum_error_n_s))
            if not conditions[key] < bound]


def _check_conditions(conditions, config):
    missed = missed_conditions(conditions, config)
    if missed:
        key, value, bound = missed[0]
        raise TransportRefused(f'the plan ends with {key} {value:.4g} above seed 004 §3.2\'s {bound}')
