"""The transport planner's model (package doc): the combined body, its state and burns, the settings, and the
propagation the plan is made and checked on (``propagate``), with seed 004 §3.2's three rendezvous conditions
(``conditions_of``, ``missed_conditions``).
"""

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from flyby_sim.dynamics.actuators import ThrusterLayout
from flyby_sim.dynamics.attitude import euler_rate, quaternion_rate
from flyby_sim.dynamics.constants import MU_EARTH_M3_S2
from flyby_sim.dynamics.orbital import (
    hill_axes_in_eci,
    mean_motion_rad_s,
    nonlinear_relative_accel_components,
    q_eci_from_body,
    q_hill_from_body,
    rk4_step,
)
from flyby_sim.dynamics.rotation import (
    quat_normalize,
    quat_rotate,
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
    max_momentum_error_n_s: float = 0.01  # condition 3 (package doc: our reading)
    slew_rate_rad_s: float = 0.01  # a slew's coasting rate
    push_force_fraction: float = 0.7  # of the largest pure force: room for Newton's corrections of a push
    slew_torque_fraction: float = 0.5  # of the largest torque along the slew's: room for the shooting's corrections
    solve_fraction: float = 0.01  # Newton stops with each condition's value below this fraction of its bound
    max_iterations: int = 20  # of the Newton on the impulses
    max_step_s: float = 5.0  # RK4 step limit [s]
    max_step_angle_rad: float = 0.02  # and the rotation per step


TOO_LITTLE_TIME = 'too little time'  # how a refusal for time begins: a later arrival may not be refused


class TransportRefused(Exception):
    """No plan: ``reason`` names the bound that refused it."""

    def __init__(self, reason):
        super().__init__(reason)
        self.reason = reason


class TransportModel:
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
    """d/dt of (r_hill, v_hill, q_eci_from_body, omega_body) under a constant body wrench (package doc)."""
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
    """The planner's model (package doc) from ``state`` to t_end_s under ``burns``: a TransportState.

    errors: optional, one (force_factor, torque_factor) per burn (each a scalar or a 3x3 matrix, applied to the
    burn's force and to its torque about the chaser CoM), for execution-error studies.
    """
    model = TransportModel(body, config)
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


def rotate_body(model, config, q_eci, omega_body, t_a, t_b, torque_segments):
    """q_eci_from_body and omega_body at t_b under (t_start, t_end, torque about the combined CoM) segments (none:
    torque-free)."""
    y = np.concatenate((q_eci, omega_body)).astype(float)
    for s, e, torque in torque_segments or ((t_a, t_b, np.zeros(3)),):
        if e > s:
            alpha = float(np.linalg.norm(model.inertia_inv @ torque))
            y = _integrate(_rotation_rates(model, torque.tolist()), y, max(s, t_a), min(e, t_b), slice(4, 7), alpha,
                           config)
    return y[0:4], y[4:7]


def attitude_at(body, config, q_eci, omega_body, t_a, t_b, burns):
    """(q_eci_from_body, omega_body) at t_b from (q_eci, omega_body) at t_a under the burns' torques about the
    combined CoM (T_com = T_chaser - c x F, seed 004 §2.2; Euler's equation, torque-free between the burns): the
    planner's attitude, which guidance's wheels track (``flyby_guidance.transport``)."""
    model = TransportModel(body, config)
    burns = tuple(burns)
    q, w = np.asarray(q_eci, dtype=float), np.asarray(omega_body, dtype=float)
    for s, e, i in _segments(burns, float(t_a), float(t_b)):
        torque = np.zeros(3)
        if i is not None:
            force = np.asarray(burns[i].force_body_n, dtype=float)
            torque = np.asarray(burns[i].torque_body_n_m, dtype=float) - np.cross(model.com_body_m, force)
        q, w = rotate_body(model, config, q, w, s, e, ((s, e, torque),))
    return q, w


def _check_burns(burns):
    for a, b in zip(burns[:-1], burns[1:], strict=False):
        if b.t_start_s < a.t_start_s + a.duration_s - 1e-9:
            raise ValueError(f'burns overlap or are out of order: {a.purpose} at {a.t_start_s} s '
                             f'for {a.duration_s} s, then {b.purpose} at {b.t_start_s} s')


def conditions_of(body, state, goal_r_hill):
    """Seed 004 §3.2's three rendezvous quantities of a state (package doc): the body's own angular momentum about
    the combined CoM, I omega (what its wheels hold is judged apart: a body turning is not ready for a rendezvous
    whatever its wheels hold), the CoM's distance from the goal, its linear momentum in hill; a dict."""
    h = np.asarray(body.inertia_body_kg_m2, dtype=float) @ np.asarray(state.omega_body, dtype=float)
    return {
        'angular_momentum_kg_m2_s': float(np.linalg.norm(h)),
        'position_error_m': float(np.linalg.norm(np.asarray(state.r_hill) - np.asarray(goal_r_hill, dtype=float))),
        'momentum_error_n_s': float(body.mass_kg * np.linalg.norm(state.v_hill)),
    }


def missed_conditions(conditions, config):
    """[(key, value, bound)] of seed 004 §3.2's conditions that the quantities (``conditions_of``'s keys) miss under
    the TransportConfig's bounds, in the order angular momentum, position, momentum."""
    return [(key, conditions[key], bound)
            for key, bound in (('angular_momentum_kg_m2_s', config.max_angular_momentum_kg_m2_s),
                               ('position_error_m', config.max_position_error_m),
                               ('momentum_error_n_s', config.max_momentum_error_n_s))
            if not conditions[key] < bound]


def check_conditions(conditions, config):
    missed = missed_conditions(conditions, config)
    if missed:
        key, value, bound = missed[0]
        raise TransportRefused(f'the plan ends with {key} {value:.4g} above seed 004 §3.2\'s {bound}')


def unit_vector(v):
    return np.asarray(v, dtype=float) / float(np.linalg.norm(v))
