"""Relative-motion damping after the grasp (seed 000 §2.2 phase (6)): the chaser detumbles the combined body with
its thrusters and wheels until the angular momentum is below seed 004's first rendezvous condition (0.1 kg m^2/s,
§3.2), with rate feedback that needs no inertia (no ROS).

Law, from the gyro rate omega (body axes) and the wheels' momentum h (body axes, A h):

.. math::

    \\tau_{thr} = -\\mathrm{sat}(k_t \\omega) - k_d h, \\qquad u = \\mathrm{sat}(k_w \\omega - k_d h)

(thruster couple on the body; wheel motor torque, whose reaction on the body is -u; sat per axis). While u is
not saturated the body's torque is -sat(k_t omega) - k_w omega: with V = 1/2 omega' I omega, whatever the
inertia, V_dot = omega' (torque) - omega' (omega x (I omega + h)) = -omega' sat(k_t omega) - k_w |omega|^2 <= 0, so
omega -> 0 for any positive definite I (the gyroscopic term does no work); the -k_d h terms move the wheels'
momentum to the thrusters (equal and opposite on the body) so h -> 0 with it, and the total angular momentum
I omega + h -> 0. The thrusters give the couple as a pure torque (``actuators.allocate_wrench``, zero force: a
couple is the same about the combined CoM as about the chaser's), which counts the fuel thruster by thruster.

Sampling: the law is held over each control period T, so for one axis omega_(k+1) = (1 - k T / I) omega_k: it
needs k T / I < 2, i.e. a lower bound of the inertia, not its value. ``DampingGains.for_inertia_bound`` takes
k_t + k_w = I_lb / (2 T): every axis of every combined body whose moments are at least I_lb then decays without
overshoot (1 - k T / I in [1/2, 1)). The chaser's smallest principal moment is always such a bound (the combined
inertia about the combined CoM is the chaser's plus positive semi-definite parallel-axis and target terms), but a
slow one for a heavy target (decay rate I_lb / (2 T I)); half the smallest moment of the target's prior is a
bound the planner has, and a faster one.
"""

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from flyby_sim.dynamics.actuators import allocate_wrench
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.rigid_body import ChaserAttitudeState, GyrostatPropagator

SEED004_MOMENTUM_BOUND_KG_M2_S = 0.1  # seed 004 §3.2, rendezvous condition 1


@dataclasses.dataclass(frozen=True)
class DampingGains:
    """Gains and limits of the damping law (module doc; validated, ValueError names the field)."""

    thruster_gain_n_m_s: float = 20.0  # k_t
    max_thruster_torque_n_m: float = 2.0  # sat of the thruster term, per body axis
    wheel_gain_n_m_s: float = 2.0  # k_w
    dump_rate_per_s: float = 0.05  # k_d

    def __post_init__(self):
        for f in dataclasses.fields(self):
            require_positive(f.name, getattr(self, f.name))

    @classmethod
    def for_inertia_bound(cls, inertia_lower_bound_kg_m2, period_s, wheel_share=0.1, **limits):
        """Gains whose sum is I_lb / (2 T) for a lower bound I_lb of the combined body's principal moments (module
        doc), wheel_share of it on the wheels; limits: max_thruster_torque_n_m, dump_rate_per_s."""
        require_positive('inertia_lower_bound_kg_m2', inertia_lower_bound_kg_m2)
        require_positive('period_s', period_s)
        k = inertia_lower_bound_kg_m2 / (2.0 * period_s)
        return cls(thruster_gain_n_m_s=(1.0 - wheel_share) * k, wheel_gain_n_m_s=wheel_share * k, **limits)


def damping_command(omega_body, h_wheels_body_n_m_s, gains, wheel_max_torque_n_m):
    """(thruster couple [N m], wheel motor torque [N m]), body axes, of the damping law (module doc)."""
    w = np.asarray(omega_body, dtype=float)
    h = np.asarray(h_wheels_body_n_m_s, dtype=float)
    tau = -np.clip(gains.thruster_gain_n_m_s * w, -gains.max_thruster_torque_n_m, gains.max_thruster_torque_n_m)
    u = np.clip(gains.wheel_gain_n_m_s * w - gains.dump_rate_per_s * h, -wheel_max_torque_n_m, wheel_max_torque_n_m)
    return tau - gains.dump_rate_per_s * h, u


class DampingResult(NamedTuple):
    """What the damping did."""

    t_s: np.ndarray  # control instants
    momentum_kg_m2_s: np.ndarray  # |I omega + A h| at each
    damped: bool  # the momentum went below the bound
    time_to_bound_s: float  # nan unless damped
    fuel_kg: float
    state: ChaserAttitudeState  # at the end


def simulate_damping(inertia_body_kg_m2, wheels, state0, gains, duration_s, period_s=0.5, layout=None,
                     bound_kg_m2_s=SEED004_MOMENTUM_BOUND_KG_M2_S):
    """The damping law held over each control period (zero-order hold) on the combined body
    (rigid_body.GyrostatPropagator: the true inertia, which the law never reads) until the total angular momentum
    is below bound_kg_m2_s or duration_s has passed.

    layout: the chaser's ThrusterLayout; the couple is allocated on it (saturation and fuel as flown). None: the
    couple is applied as commanded and no fuel is counted.
    """
    require_positive('duration_s', duration_s)
    require_positive('period_s', period_s)
    propagator = GyrostatPropagator(inertia_body_kg_m2, wheels)
    a = wheels.axis_matrix
    a_pinv = np.linalg.pinv(a)
    inertia = propagator.inertia
    state = state0
    fuel = 0.0
    t = 0.0
    times, momenta = [], []
    t_bound = math.nan
    while True:
        h_body = a @ state.h_wheels_n_m_s
        h_total = float(np.linalg.norm(inertia @ state.omega_body + h_body))
        times.append(t)
        momenta.append(h_total)
        if h_total < bound_kg_m2_s:
            t_bound = t
            break
        if t >= duration_s - 1e-9:
            break
        tau, u_body = damping_command(state.omega_body, h_body, gains, float(wheels.max_torque_n_m.min()))
        if layout is not None:
            alloc = allocate_wrench(layout, np.zeros(3), tau)
            tau = alloc.wrench_delivered_body[3:]
            fuel += alloc.total_thrust_n * period_s / layout.exhaust_velocity_mps
        state = propagator.step(state, period_s, tau, a_pinv @ u_body).state
        t += period_s
    return DampingResult(np.array(times), np.array(momenta), not math.isnan(t_bound), t_bound, fuel, state)
