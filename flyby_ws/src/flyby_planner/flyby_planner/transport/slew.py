"""The rest-to-rest slews that aim the push axis (package doc, step 3): spin-up, torque-free coast, spin-down,
their body torques by Newton shooting on Euler's equation; and guidance's re-solved slew (``resolve_slew``).
"""

import math
from typing import NamedTuple

import numpy as np

from flyby_planner.transport.model import TransportModel, TransportRefused, rotate_body, unit_vector
from flyby_planner.transport.thrusters import push_axis, torque_burn_wrench, torque_capacity_n_m
from flyby_sim.dynamics.orbital import (
    hill_axes_in_eci,
    q_eci_from_body,
)
from flyby_sim.dynamics.rotation import (
    quat_from_axis_angle,
    quat_normalize,
    quat_rotate,
    quat_shortest_arc,
    rotation_vector_from_quat,
)


def resolve_slew(body, config, state, slew_start, slew_stop, u_hill, t_aim_s, t_arrival_s):
    """A planned slew's burns (slew_start, slew_stop) solved again from the state (the estimate before the slew)
    so that the push axis ends along the hill direction u_hill at t_aim_s (the push's middle) at rest: the same
    Newton shooting on Euler's equation as the plan's (guidance flies the slew from where the body really is).
    Returns the two new Burns; TransportRefused where it does not converge or the thrusters cannot."""
    model = TransportModel(body, config)
    p = config.period_s
    b_body, _ = push_axis(body)
    k_start = round(slew_start.t_start_s / p)
    slew = Slew(k_start, round(slew_start.duration_s / p), round((slew_stop.t_start_s + slew_stop.duration_s) / p))
    q_eci = q_eci_from_body(state.t, model.n, quat_normalize(state.q_hill_from_body))
    q_eci, omega = rotate_body(model, config, q_eci, np.asarray(state.omega_body, dtype=float), state.t, k_start * p,
                               ())
    u_eci = hill_axes_in_eci(t_aim_s, model.n) @ unit_vector(np.asarray(u_hill, dtype=float))
    torques, _, _, _ = solve_slew(model, config, slew, q_eci, omega, b_body, u_eci, t_arrival_s - k_start * p)
    burns = []
    for old, torque in ((slew_start, torques[:3]), (slew_stop, torques[3:])):
        wrench = torque_burn_wrench(model, torque)
        if wrench is None:
            raise TransportRefused(f'the {old.purpose} torque {np.round(torque, 4).tolist()} N m about the combined '
                                   f'CoM at {old.t_start_s:.1f} s is beyond the thrusters')
        burns.append(old._replace(force_body_n=wrench[0], torque_body_n_m=wrench[1]))
    return tuple(burns)


# A slew's shooting that lands on b = -u starts again from arcs about these axes, turned about b [rad].
_SLEW_RESTART_TURNS_RAD = (0.5 * np.pi, -0.5 * np.pi)
# A slew's shooting that asks its spin-up for more than this times the slew rate has diverged.
_DIVERGED_RATE_FACTOR = 20.0
# A shooting step that does not lower the residual is halved at most this often.
_BACKTRACKS = 6
# A slew ends with the push axis this close to its aim [rad], and its residual rate turns it less up to the arrival.
_AIM_RAD = 1e-9


class Slew(NamedTuple):
    """A rest-to-rest slew's schedule on the grid (ticks of the control period)."""

    k_start: int
    k_burn: int  # the spin-up's and the spin-down's length
    k_end: int


def _slew_ticks(model, config, angle_rad, momentum_body, burn_factor):
    """(k_burn, k_total) of a slew turning angle_rad at the slew rate: burns long enough that the spin-up's and the
    spin-down's torques (first guess: momentum_body over each) are within slew_torque_fraction of the thrusters'
    at the least side force (``torque_capacity_n_m``), times burn_factor (a reschedule's)."""
    p = config.period_s
    k_coast = max(1, math.ceil(angle_rad / config.slew_rate_rad_s / p - 1e-9))
    k_burn = 1
    for momentum in momentum_body:
        size = float(np.linalg.norm(momentum))
        if size > 0.0:
            capacity = config.slew_torque_fraction * torque_capacity_n_m(model, momentum)
            if capacity <= 0.0:
                raise TransportRefused(f'no thruster set gives a torque about body {np.round(momentum / size, 3)} '
                                       'about the combined CoM: the push axis cannot be turned onto the impulse')
            k_burn = max(k_burn, math.ceil(size / capacity / p - 1e-9))
    k_burn *= burn_factor
    return k_burn, k_coast + 2 * k_burn


def slew_ending(model, config, q_eci, omega_body, b_body, u_eci, k_end, burn_factor):
    """The slew ending at tick k_end that turns b from q_eci (at rate omega_body) onto u_eci."""
    angle = float(np.linalg.norm(rotation_vector_from_quat(quat_shortest_arc(quat_rotate(q_eci, b_body), u_eci))))
    momentum = slew_guess(model, q_eci, omega_body, b_body, u_eci, 1.0,
                           max(angle / config.slew_rate_rad_s, config.period_s))
    k_burn, k_total = _slew_ticks(model, config, angle, (momentum[:3], momentum[3:]), burn_factor)
    return Slew(k_end - k_total, k_burn, k_end)


def slew_guess(model, q_eci, omega_body, b_body, u_eci, burn_s, coast_s, axis_turn_rad=0.0):
    """Spin-up and spin-down torques [N m] (6,) of a rigid rotation about the shortest arc (its axis turned about b by
    axis_turn_rad: an arc of the same angle that ends elsewhere, a restart's guess), gyroscopic terms left to the
    shooting: I (omega_c - omega_0) / d and -I omega_c / d, omega_c the arc over the coast."""
    b_eci = quat_rotate(q_eci, b_body)
    arc_eci = quat_rotate(quat_from_axis_angle(b_eci, axis_turn_rad),
                          rotation_vector_from_quat(quat_shortest_arc(b_eci, u_eci)))
    arc_body = quat_rotate(np.concatenate((-np.asarray(q_eci[:3]), q_eci[3:])), arc_eci)
    omega_c = arc_body / (coast_s + burn_s)  # the burns each turn the body about half as far as a coast as long
    return np.concatenate((model.inertia @ (omega_c - omega_body), -model.inertia @ omega_c)) / burn_s


def solve_slew(model, config, slew, q_eci, omega_body, b_body, u_eci, horizon_s, start=None):
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
        return rotate_body(model, config, q_eci, omega_body, t_a, t_b, segments)

    def residual(z):
        q, w = end(z)
        return np.concatenate((w * scale_s, across @ quat_rotate(q, b_body))), q, w

    def guess(axis_turn_rad=0.0):
        return slew_guess(model, q_eci, omega_body, b_body, u, d, t_b - t_a - 2 * d, axis_turn_rad)

    if start is None:
        z, jacobian = guess(), None
    else:  # the last solution and its Jacobian (the Newton on the impulses moves the aim a little)
        z, jacobian = start
    rate_bound = _DIVERGED_RATE_FACTOR * max(config.slew_rate_rad_s, float(np.linalg.norm(omega_body)))
    restarts = list(_SLEW_RESTART_TURNS_RAD)
    r, q, w = residual(z)
    for _ in range(30 * (1 + len(restarts))):
        if np.linalg.norm(w) < omega_tol and np.linalg.norm(r[3:]) < _AIM_RAD:
            if float(quat_rotate(q, b_body) @ u) > 0.0:
                return z, q, w, jacobian
            if not restarts:
                break
            # b on -u, the residual's other root (its components across u vanish there too): again from an arc
            # about another axis
            z, jacobian = guess(restarts.pop(0)), None
            r, q, w = residual(z)
            continue
        if float(np.linalg.norm(model.inertia_inv @ z[:3])) * d > rate_bound:  # diverging: each step costs more
            break
        if jacobian is None:
            jacobian = _jacobian(residual, z, r)
        z, r, q, w, jacobian = _newton_step(residual, z, r, jacobian)
    raise TransportRefused(f'the slew from {t_a:.1f} s to {t_b:.1f} s did not converge: rate {np.linalg.norm(w):.3g} '
                           f'rad/s, pointing {np.linalg.norm(r[3:]):.3g} rad at its end')


def _jacobian(residual, z, r):
    step = 1e-6 * max(1.0, float(np.max(np.abs(z))))
    return np.column_stack([(residual(z + step * e)[0] - r) / step for e in np.eye(6)])


def _newton_step(residual, z, r, jacobian):
    """One step of the slew's shooting: a chord step (the Jacobian kept) where it halves the residual, else a fresh
    Jacobian's step, halved until the residual falls (a long torque-free coast about a non-principal axis makes the
    end a strongly nonlinear function of the burns' torques). (z, r, q, w, jacobian) after the step."""
    step = np.linalg.lstsq(jacobian, r, rcond=None)[0]
    r_new, q, w = residual(z - step)
    if np.linalg.norm(r_new) < 0.5 * np.linalg.norm(r):
        return z - step, r_new, q, w, jacobian
    jacobian = _jacobian(residual, z, r)
    step = np.linalg.lstsq(jacobian, r, rcond=None)[0]
    for _ in range(_BACKTRACKS):
        r_new, q, w = residual(z - step)
        if np.linalg.norm(r_new) < np.linalg.norm(r):
            break
        step = 0.5 * step
    return z - step, r_new, q, w, jacobian
