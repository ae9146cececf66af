"""Relative-motion damping after the grasp (seed 000 §2.2 phase (6)), then the mass-property excitation: the chaser
detumbles the combined body with its thrusters and wheels until the angular momentum is below seed 004's first
rendezvous condition (0.1 kg m^2/s, §3.2), with rate feedback that needs no inertia, and then fires the excitation
the estimator observes (``PostCaptureControl``; no ROS).

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

import collections
import dataclasses
import math
from typing import NamedTuple

import numpy as np

from flyby_estimation.mass_properties_excitation import excitation_firings, firing_wrench
from flyby_msgs_py import event_payloads, events, params
from flyby_sim.dynamics.actuators import allocate_wrench
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.rigid_body import ChaserAttitudeState, GyrostatPropagator

SEED004_MOMENTUM_BOUND_KG_M2_S = 0.1  # seed 004 §3.2, rendezvous condition 1
# The damping's couple is fired in pulses of this many minimum impulse bits (``PostCaptureConfig.pulse_n_m_s``).
DAMPING_PULSE_BITS = 4.0
# The damping ends when its momentum bound is below this share of the threshold: the bound takes the rate estimate
# and the account of the wheels' momentum as exact; their errors (the gyro bias estimate's, ~1e-6 rad/s times some
# 3000 kg m^2) are kept inside the margin.
MOMENTUM_MARGIN = 0.5


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


def inertia_upper_bound(chaser_inertia_kg_m2, target_inertia_kg_m2, chaser_mass_kg, target_mass_kg, distance_m):
    """A bound [kg m^2] of the combined body's largest principal moment: the chaser's and the target's largest plus
    the reduced mass at the distance between their CoMs (lambda_max(A + B) <= lambda_max(A) + lambda_max(B); the
    parallel-axis terms about the combined CoM are mu (d'd U - d d'), mu = m M / (m + M), largest mu d^2)."""
    mu = chaser_mass_kg * target_mass_kg / (chaser_mass_kg + target_mass_kg)
    return float(np.linalg.eigvalsh(chaser_inertia_kg_m2)[-1] + np.linalg.eigvalsh(target_inertia_kg_m2)[-1]
                 + mu * distance_m ** 2)


def _period_s(hz):
    """The control period [s] of the chaser IMU's rate [Hz]."""
    return 1.0 / hz


def _damping_gains(scenario):
    """The DampingGains for the inertia bound post_capture.damping gives, or half the smallest principal moment of
    the target's inertia; the IMU's period."""
    d = scenario.post_capture.damping
    bound = d.inertia_lower_bound_kg_m2 or 0.5 * float(np.linalg.eigvalsh(scenario.target_inertia)[0])
    return DampingGains.for_inertia_bound(bound, _period_s(scenario.sensors.chaser_imu.rate_hz), d.wheel_share,
                                          max_thruster_torque_n_m=d.max_thruster_torque_n_m,
                                          dump_rate_per_s=d.dump_rate_per_s)


def _damping_pulse_n_m_s(scenario):
    """A pulse: DAMPING_PULSE_BITS minimum impulse bits at the thrusters' mean lever arm about the chaser's CoM (the
    small couple that moves the wheels' momentum to the thrusters is below the bit, and would never fire)."""
    layout = scenario.thruster_layout
    return DAMPING_PULSE_BITS * layout.min_impulse_bit_n_s * float(np.mean(np.linalg.norm(
        layout.positions_body_m, axis=1)))


@params.record
class PostCaptureConfig:
    """What guidance needs after the arm locks (scenario post_capture; ``PostCaptureControl``): the damping mode's
    record (``flyby_msgs_py.params``)."""

    gains: DampingGains = params.derived(_damping_gains)
    period_s: float = params.key('sensors.chaser_imu.rate_hz', _period_s)  # the control period (the IMU's) [s]
    momentum_threshold_kg_m2_s: float = params.key('post_capture.damping.momentum_threshold_kg_m2_s')
    settle_s: float = params.key('post_capture.damping.settle_s')
    # flyby_estimation.mass_properties_excitation.EXCITATIONS
    excitation: str = params.key('post_capture.mass_estimation.excitation')
    start_delay_s: float = params.key('post_capture.mass_estimation.start_delay_s')
    window_s: float = params.key('post_capture.mass_estimation.window_s')
    # False: a run that starts attached excites the body as it turns (seed 004 §3.1)
    damping: bool = params.derived(lambda scenario: scenario.post_capture.start != 'attached')
    # The damping's couple is fired once its angular impulse is worth this (``pulse_modulated``; 0: every period):
    # below the thrusters' minimum impulse bit it would not be fired at all [N m s].
    pulse_n_m_s: float = params.derived(_damping_pulse_n_m_s)


def pulse_modulated(carried_n_m_s, torque_n_m, period_s, pulse_n_m_s):
    """(torque to fire over the period [N m], angular impulse carried on [N m s]): a couple's angular impulse added
    to what is carried and fired once it is worth pulse_n_m_s, the same mean torque in pulses (pulse-frequency
    modulation: below the thrusters' minimum impulse bit a small couple would not be fired at all, and the wheels'
    momentum it should take out would stay)."""
    carried = np.asarray(carried_n_m_s, dtype=float) + np.asarray(torque_n_m, dtype=float) * period_s
    if float(np.linalg.norm(carried)) < pulse_n_m_s:
        return np.zeros(3), carried
    return carried / period_s, np.zeros(3)


class PostCaptureCommand(NamedTuple):
    """One control period's command after the lock: thrusters' force [N] and torque about the chaser CoM [N m]
    (chaser_body), the wheels' motor torque [N m, chaser_body axes: the body feels -u], events (level, name,
    message, values)."""

    force_body_n: np.ndarray
    torque_body_n_m: np.ndarray
    wheel_torque_body_n_m: np.ndarray
    events: list


class PostCaptureControl:
    """Guidance's rules from the arm's lock on, one command per chaser estimate, applied one control
    period after its stamp (DESIGN §10):

    * damping: ``damping_command`` on the estimated rate and the wheels' momentum, until the bound of the angular
      momentum, inertia_upper_bound |mean omega| + |A h| with the rate's mean over the last settle_s, is below
      MOMENTUM_MARGIN of the threshold (seed 004 §3.2): it needs no inertia, only a bound, and the mean keeps the
      gyro's noise out of it;
      then ``damping_complete`` with the excitation's start t_x = its stamp + start_delay_s (without damping, a run
      that starts attached: ``excitation_scheduled`` at the first estimate, t_x likewise);
    * from t_x the excitation's wrench (``mass_properties_excitation.excitation_firings``, each firing's wrench
      about the chaser CoM held over the control periods it covers), nothing on the wheels (the filter holds
      their momentum constant), and nothing after it, until the mission completes.
    """

    def __init__(self, config, wheel_max_torque_n_m):
        """wheel_max_torque_n_m: the smallest wheel's torque limit."""
        self.config = config
        self.wheel_max_torque_n_m = wheel_max_torque_n_m
        self.rates = collections.deque()  # (t, omega_body) over the last settle_s
        self.t_first = None
        self.t_excitation = None
        self.firings = ()
        self.excitation_ended = False
        self.carried = np.zeros(3)  # the damping couple's angular impulse not yet fired [N m s]

    def command(self, t, omega_body, h_wheels_body_n_m_s, h_wheels_settled_body_n_m_s, inertia_bound_kg_m2):
        """The PostCaptureCommand of the estimate stamped t [s] (rate [rad/s], wheels' momentum [N m s], both
        chaser_body; h_wheels_settled: once every wheel command so far has acted)."""
        cfg = self.config
        zero = np.zeros(3)
        if self.t_first is None:
            self.t_first = t
        if self.t_excitation is not None:
            return PostCaptureCommand(*self._excitation(t), zero, self._excitation_events(t))
        if not cfg.damping:
            self.t_excitation = t + cfg.start_delay_s
            self.firings = excitation_firings(cfg.excitation, self.t_excitation)
            return PostCaptureCommand(zero, zero, zero, [(
                'OK', events.EXCITATION_SCHEDULED,
                f'{cfg.excitation} excitation from t = {self.t_excitation:.2f} s on the body as it turns (no damping)',
                event_payloads.encode(event_payloads.ExcitationScheduled(
                    self.t_excitation, cfg.excitation, np.asarray(h_wheels_settled_body_n_m_s, dtype=float))))])
        omega = np.asarray(omega_body, dtype=float)
        self.rates.append((t, omega))
        while self.rates[0][0] < t - cfg.settle_s - 1e-9:
            self.rates.popleft()
        if t - self.t_first >= cfg.settle_s - 1e-9:
            mean = np.mean([w for _, w in self.rates], axis=0)
            bound = inertia_bound_kg_m2 * float(np.linalg.norm(mean)) + float(np.linalg.norm(h_wheels_body_n_m_s))
            if bound < MOMENTUM_MARGIN * cfg.momentum_threshold_kg_m2_s:
                self.t_excitation = t + cfg.start_delay_s
                self.firings = excitation_firings(cfg.excitation, self.t_excitation)
                h = np.asarray(h_wheels_settled_body_n_m_s, dtype=float)
                return PostCaptureCommand(zero, zero, zero, [(
                    'OK', events.DAMPING_COMPLETE,
                    f'angular momentum at most {bound:.4f} kg m^2/s (< {MOMENTUM_MARGIN:g} x '
                    f'{cfg.momentum_threshold_kg_m2_s:g}) after '
                    f'{t - self.t_first:.1f} s of damping; {cfg.excitation} excitation from t = '
                    f'{self.t_excitation:.2f} s',
                    event_payloads.encode(event_payloads.DampingComplete(
                        bound, t - self.t_first, self.t_excitation, cfg.excitation, h)))])
        tau, u = damping_command(omega, h_wheels_body_n_m_s, cfg.gains, self.wheel_max_torque_n_m)
        tau, self.carried = pulse_modulated(self.carried, tau, cfg.period_s, cfg.pulse_n_m_s)
        return PostCaptureCommand(zero, tau, u, [])

    def _excitation(self, t):
        """(force, torque) held over the control period from t + period: the firing active at its middle."""
        t_mid = t + 1.5 * self.config.period_s
        force, torque = np.zeros(3), np.zeros(3)
        for f in self.firings:
            if f.t_start_s <= t_mid < f.t_start_s + f.duration_s:
                force_f, torque_f = firing_wrench(f)
                force, torque = force + force_f, torque + torque_f
        return force, torque

    def _excitation_events(self, t):
        t_end = max((f.t_start_s + f.duration_s for f in self.firings), default=self.t_excitation)
        if self.excitation_ended or t + self.config.period_s < t_end:
            return []
        self.excitation_ended = True
        return [('OK', events.EXCITATION_ENDED, f'{self.config.excitation} excitation ended at t = {t_end:.2f} s',
                 {'t_end_s': t_end})]
