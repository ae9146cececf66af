"""Guidance in TRANSPORT (seed 004 §2.3, §3.2): the combined body flown to a goal on the reference orbit with the
tug's direction-limited thrusters, closed loop on the estimates (no ROS). ``TransportControl`` applies these rules,
each command for the control period one period after its estimate (DESIGN §5, §10); docs/transport.md states them.

1. Start at the final mass-property estimate (``mass_properties_estimated``): plan for the combined body of that
   estimate, with only the thrusters whose exhaust misses the estimated target CoM (``transport_body``).
2. Detumble first (``attitude``): the capture's damping law in couples of least side force, until the body's own
   angular momentum (its rate averaged over DETUMBLED_S) is below half the first condition's
   (``transport_detumbled``), and hold until the navigation has settled for NAV_SETTLE_S.
3. Plan to the goal, arriving ``transfer_time_s`` after the start, and state the time the conditions need after
   the arrival (``terminal.settle_bound_s``); a plan that cannot meet them within the run is refused
   (``transport_refused``, the body held where it is).
4. Fly the plan closed loop (``push``): each slew solved again from the estimate before it starts; each push's force
   from CW's response over its rest, aimed at the plan's position at the last push, its axis steered toward the
   force wanted; the last one to rest, short by its expected error along the push axis;
   each spin-down takes out the estimated angular momentum; between the first push and the next slew a miss at the
   last push beyond a quarter of the second condition gets a one-impulse correction (``transport_correction``).
5. After the last burn (``terminal``) the wheels hold the attitude and the terminal program, solved again at every
   check from the estimate, fires the impulses that bring the body to rest at the goal with the wheels within
   their share; the push axis turned first where no horizon is feasible.
6. ``transport_complete`` once the conditions, judged from the estimate with its 3-sigma, held ``hold_s``; at the
   run's end (``simulation.duration_s``) with the conditions as they are (WARN).
"""

import collections
import dataclasses

import numpy as np

from flyby_estimation.transport_navigation import COM_PERIOD_S, command_error
from flyby_guidance.transport.attitude import DETUMBLED_S, WHEEL_SPINUP_S, TransportAttitude
from flyby_guidance.transport.push import TransportPush
from flyby_guidance.transport.terminal import TransportTerminal, navigation_coast_s, settle_bound_s
from flyby_msgs_py import events, params
from flyby_msgs_py.wire import STAMP_TOLERANCE_S
from flyby_planner.transport.model import (
    TransportBody,
    TransportConfig,
    TransportState,
    conditions_of,
    missed_conditions,
)
from flyby_planner.transport.terminal import rest_point
from flyby_planner.transport.thrusters import push_axis, torque_wrench
from flyby_sim.dynamics.actuators import plume_free_thrusters
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.combined_body import combined_mass_properties, inertia_from_principal
from flyby_sim.dynamics.rotation import quat_to_matrix

NAV_SETTLE_S = 30.0  # the combined body's navigation converges from its first position before the plan [s]
PULSE_BITS = 10.0  # a couple's pulse at most this many minimum impulse bits at the mean lever arm ...
PULSE_BOUND_FRACTION = 0.25  # ... and this share of the first condition's bound (``transport_pulse_n_m_s``)


def transport_body(estimate, chaser_mass_kg, chaser_inertia_kg_m2, layout, plume_cone_deg):
    """The TransportBody of the final mass-property estimate (the ``mass_properties_estimated`` payload,
    flyby_msgs_py.event_payloads.MassPropertiesEstimated): the combined body of the chaser and the estimated target,
    and the thrusters whose exhaust misses the estimated target CoM."""
    target_mass = estimate.mass_kg
    x_s = np.asarray(estimate.com_body_m, dtype=float)
    inertia_target = inertia_from_principal(np.asarray(estimate.principal_moments_kg_m2, dtype=float),
                                            np.asarray(estimate.principal_axes_q, dtype=float))
    props = combined_mass_properties(chaser_mass_kg, chaser_inertia_kg_m2, target_mass, x_s, inertia_target)
    return TransportBody(props.mass_kg, props.com_body_m, props.inertia_body_kg_m2,
                         layout.subset(plume_free_thrusters(layout, x_s, plume_cone_deg)))


def transport_pulse_n_m_s(body, momentum_bound_kg_m2_s):
    """A couple's pulse about the combined CoM [N m s]: at most PULSE_BITS minimum impulse bits at the thrusters' mean
    lever arm and PULSE_BOUND_FRACTION of the first condition's bound (a pulse changes the body's own momentum by
    that much: a cycle of pulses stays within half the bound, the detumbling's end), at least two bits at the
    largest arm (the least couple the plant fires)."""
    arms = np.linalg.norm(body.layout.positions_body_m - body.com_body_m, axis=1)
    bit = body.layout.min_impulse_bit_n_s
    return min(PULSE_BITS * bit * float(np.mean(arms)),
               max(PULSE_BOUND_FRACTION * momentum_bound_kg_m2_s, 2.0 * bit * float(np.max(arms))))


def com_state(body, t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega_body, n):
    """The TransportState of the combined CoM from a chaser estimate (eq 8-9 of the chaser's CoM, -c in the body)."""
    r_point, v_point = body_point_state(quat_to_matrix(q_hill_from_body), np.asarray(omega_body, dtype=float),
                                        -np.asarray(body.com_body_m), n)
    return TransportState(t, np.asarray(r_chaser_hill, dtype=float) - r_point,
                          np.asarray(v_chaser_hill, dtype=float) - v_point, np.asarray(q_hill_from_body, dtype=float),
                          np.asarray(omega_body, dtype=float))


def _transport_planner_config(scenario):
    """The transport planner's TransportConfig: post_capture.transport's bounds, the orbit, and guidance's control
    period (the chaser IMU's)."""
    tr = scenario.post_capture.transport
    return TransportConfig(period_s=1.0 / scenario.sensors.chaser_imu.rate_hz, radius_m=scenario.orbit_radius_m,
                           mu=scenario.orbit.mu_m3_s2, max_angular_momentum_kg_m2_s=tr.max_angular_momentum_kg_m2_s,
                           max_position_error_m=tr.max_position_error_m,
                           max_momentum_error_n_s=tr.max_momentum_error_n_s)


@params.record
class TransportGuidanceConfig:
    """scenario post_capture.transport, the sensors the settle bound rests on, the run's end, and guidance's control
    period: the transport mode's record (``flyby_msgs_py.params``)."""

    goal_hill_m: tuple = params.key('post_capture.transport.goal_hill_m', tuple)
    transfer_time_s: float = params.key('post_capture.transport.transfer_time_s')
    plume_cone_deg: float = params.key('post_capture.transport.plume_cone_deg')
    replan_interval_s: float = params.key('post_capture.transport.replan_interval_s')
    hold_s: float = params.key('post_capture.transport.hold_s')
    wheel_momentum_share: float = params.key('post_capture.transport.wheel_momentum_share')
    position_sigma_m: float = params.key('sensors.relative_position.noise_sigma_m')
    position_rate_hz: float = params.key('sensors.relative_position.rate_hz')
    accel_noise_sigma_mps2: float = params.key('sensors.chaser_imu.accel_noise_sigma_mps2')
    star_tracker_sigma_deg: float = params.key('sensors.chaser_imu.star_tracker_sigma_deg')
    duration_s: float = params.key('simulation.duration_s')
    thrust_magnitude_sigma: float = params.key('chaser.thrusters.magnitude_error_sigma')
    thrust_misalignment_sigma_deg: float = params.key('chaser.thrusters.direction_error_sigma_deg')
    planner: TransportConfig = params.derived(_transport_planner_config)


class TransportControl(TransportAttitude, TransportPush, TransportTerminal):
    """Guidance's rules in TRANSPORT (module doc; their parts in ``attitude``, ``push`` and ``terminal``): ``start``
    at the final mass-property estimate, then ``command`` at every chaser estimate stamped from it on; each returns
    (force_body_n, torque_body_n_m, wheel_torque_body_n_m, events) for the control period that starts one period after
    the estimate's stamp (torque about the chaser's CoM, DESIGN §10)."""

    def __init__(self, config, n, gains, wheel_max_torque_n_m, wheel_max_momentum_n_m_s):
        """gains: the capture's DampingGains (the detumbling and, its wheel gain, the hold before the plan); the
        wheels' torque and momentum capacity (the least of the wheels') [N m, N m s]."""
        self.config = config
        self.n = n
        self.gains = gains
        self.wheel_max_torque_n_m = wheel_max_torque_n_m
        self.wheel_capacity_n_m_s = wheel_max_momentum_n_m_s
        self.t_detumbled = None
        self.rates = collections.deque()  # (t, omega_body) over the last DETUMBLED_S
        self.body_momentum = None  # the body's own angular momentum |I omega|, the rate averaged [kg m^2/s]
        self.carried = np.zeros(3)  # a couple's angular impulse not yet fired [N m s]
        self.resolved = set()  # the start times of the slews solved again from the estimate
        self.goal = np.asarray(config.goal_hill_m, dtype=float)
        self.rest = rest_point(self.goal, config.planner.radius_m)
        self.deadline = config.duration_s - 2.0 * config.replan_interval_s  # the judgement at the latest [s]
        self.body = None
        self.t_start = None
        self.t_arrival = None
        self.settle_bound = None  # the time after the arrival the conditions need, stated with the plan [s]
        self.plan = None
        self.plan_start = None  # the TransportState the plan was made from
        self.t_check = None
        # The attitude the wheels track: (t, q_eci_from_body, omega_body) of the plan's model; after the last burn the
        # attitude held (q_eci_from_body) and a turn of it (t0, q0_eci, axis_eci, angle [rad], rate [rad/s]).
        self.reference = None
        self.hold = None
        self.turning = None
        self.t_terminal = None
        self.pulses = []  # (t_start, t_end, force_body_n, torque_body_n_m) of the firings on the grid
        self.kept = None  # the terminal plan flown, its TerminalSolution (``_monitor``)
        self.t_fired = -np.inf  # the end of the last terminal firing [s]
        self.t_held = None  # the conditions have held since [s]
        self.issued = None  # (t, force, torque) of the last command: it acts from t + period, after the estimate at t
        self.done = False
        self.t_com = None  # the stamp of the last refined combined CoM taken (``refine_com``) [s] ...
        self.com_pending = collections.deque()  # ... and (t, com_body_m, nav sigmas) of those for later estimates
        self.nav_sigma = None  # (t, position [m], velocity [m/s]) 1-sigma of the last taken

    def refine_com(self, t_event, com_body_m, position_sigma_m=None, velocity_sigma_mps=None):
        """The estimator's combined CoM [m], estimated with the translation, and its navigation's 1-sigma (the
        velocity's with what it does not know of the combined CoM), stamped t_event (``transport_com_estimate``): the
        body's CoM for the estimates from t_event on (the topics race: it may come before the estimates stamped
        earlier)."""
        self.t_com = t_event
        self.com_pending.append((t_event, np.asarray(com_body_m, dtype=float), position_sigma_m, velocity_sigma_mps))

    def _take_com(self, t):
        """The refined combined CoM and the navigation's sigmas for the estimate stamped t (``refine_com``)."""
        while self.com_pending and self.com_pending[0][0] <= t + STAMP_TOLERANCE_S:
            t_event, com, position_sigma, velocity_sigma = self.com_pending.popleft()
            self.body = dataclasses.replace(self.body, com_body_m=com)
            if position_sigma is not None and velocity_sigma is not None:
                self.nav_sigma = (t_event, position_sigma, velocity_sigma)

    def start(self, t_event, body):
        """TRANSPORT from the final estimate stamped t_event [s], for the TransportBody of that estimate."""
        self.t_start = t_event
        self.t_arrival = t_event + self.config.transfer_time_s
        self.body = body
        self.b_body, self.push_force_max_n = push_axis(body)
        self.pulse_n_m_s = transport_pulse_n_m_s(body, self.config.planner.max_angular_momentum_kg_m2_s)
        inertia_max = float(np.max(np.linalg.eigvalsh(body.inertia_body_kg_m2)))
        # The wheels steer the body (track the plan's attitude) where they spin it up to the slews' rate within
        # WHEEL_SPINUP_S; on a heavier body the thrusters' couples track it and the wheels damp its rate at rest.
        spin_up_rad_s = self.wheel_max_torque_n_m * WHEEL_SPINUP_S / inertia_max
        self.wheels_steer = spin_up_rad_s >= self.config.planner.slew_rate_rad_s
        # A terminal turn: at the rate the wheels' share of their momentum gives the body where they steer it, else
        # at the slews' rate by the thrusters' couples.
        self.turn_rate_rad_s = (self.config.wheel_momentum_share * self.wheel_capacity_n_m_s / inertia_max
                                if self.wheels_steer else self.config.planner.slew_rate_rad_s)
        cfg = self.config
        self.command_error = command_error(cfg.thrust_magnitude_sigma, np.radians(cfg.thrust_misalignment_sigma_deg))
        self.coast_s = navigation_coast_s(body.mass_kg, cfg.planner.max_momentum_error_n_s, cfg.position_sigma_m,
                                          cfg.position_rate_hz, COM_PERIOD_S)
        self.settle_bound = settle_bound_s(self.coast_s, cfg.hold_s, cfg.replan_interval_s)

    def command(self, t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega_body, h_wheels_body_n_m_s):
        """(force [N], torque about the chaser's CoM [N m], wheel motor torque [N m], chaser_body; events) for the
        control period from t + period."""
        out = self._command(t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega_body, h_wheels_body_n_m_s)
        self.issued = (t, out[0], out[1])
        return out

    def _command(self, t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega_body, h_wheels_body_n_m_s):
        zero = np.zeros(3)
        self._take_com(t)
        if self.done or self.t_start is None:
            return zero, zero, zero, []
        omega = np.asarray(omega_body, dtype=float)
        h_wheels = np.asarray(h_wheels_body_n_m_s, dtype=float)
        # The body's own angular momentum |I omega|, the rate its mean over DETUMBLED_S (the gyro's noise on a
        # 3000 kg m^2 body is of the first condition's size); the wheels' is judged on its own.
        self.rates.append((t, omega))
        while self.rates[0][0] < t - DETUMBLED_S - 1e-9:
            self.rates.popleft()
        self.body_momentum = float(np.linalg.norm(self.body.inertia_body_kg_m2
                                                  @ np.mean([w for _, w in self.rates], axis=0)))
        if self.t_detumbled is None:
            return self._detumble(t, omega, h_wheels)
        events = []
        state = com_state(self.body, t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega, self.n)
        if self.plan is None:
            if t < max(self.t_start + NAV_SETTLE_S, self.t_detumbled) - 1e-9:
                return zero, zero, self._hold(omega), []
            events += self._plan(state, self.t_arrival)
            if self.done:
                return zero, zero, zero, events
        if self.t_terminal is not None:
            ended = self._judged(t, state, h_wheels)
            if ended:
                return zero, zero, zero, events + ended
            if self._overfull(state, h_wheels) and not self.pulses_pending(t) and not self._turn_under_way(t):
                # The terminal program plans on a body its wheels can hold still: damped first, as at the start (not
                # while the wheels turn it on purpose).
                self.hold = None
                return (*self._damp(omega, h_wheels), events)
            if self.hold is None:
                self._enter_terminal(state)
        return self._fly(t, state, omega, h_wheels, events)

    def _judged(self, t, state, h_wheels):
        """[transport_complete] once the conditions held ``hold_s`` (``terminal._judge``), or at the deadline."""
        if self._judge(state, h_wheels):
            self.t_held = t if self.t_held is None else self.t_held
        else:
            self.t_held = None
        held = self.t_held is not None and t - self.t_held >= self.config.hold_s - 1e-9
        if held or t >= self.deadline - 1e-9:
            self.done = True
            return [self._complete(t, state, h_wheels)]
        return []

    def _fly(self, t, state, omega, h_wheels, events):
        """The command of an estimate once planned: the plan's burns closed loop, the firings of the mid-course
        correction and of the terminal program, the wheels on the attitude."""
        period = self.config.planner.period_s
        t_mid = t + 1.5 * period
        last_burn_end = max(b.t_start_s + b.duration_s for b in self.plan.burns)
        if self.t_terminal is None and t_mid >= last_burn_end + period and t >= self.plan.t_arrival_s - 1e-9:
            self._enter_terminal(state)
        at_rest = not any(a.t_start_s - period <= t_mid < b.t_start_s + b.duration_s + period
                          for a, b in self._slews())
        if at_rest and t >= self.t_check - 1e-9:
            if not self.pulses_pending(t):
                events += self._check(state, h_wheels)
            elif self.monitoring(t):
                events += self._monitor(state, h_wheels)
        for start, stop in self._slews():
            if start.t_start_s <= t_mid < start.t_start_s + period and start.t_start_s not in self.resolved:
                events += self._resolve(state, start, stop)
                break
        hold = np.zeros(3)
        if self.t_terminal is not None or self.wheels_steer:
            wheels = self._track(state)
            if not self.wheels_steer and self._turn_under_way(t):  # a terminal turn of a body the wheels cannot steer
                hold = -self._attitude_torque(state)
        elif at_rest and not self._burning(t_mid) and self._wheels_hold(state, h_wheels,
                                                                         reference := self._reference_error(state)):
            wheels = self._track(state, reference)  # a coast at rest the wheels hold: they do, as after the last burn
        else:  # the thrusters' couples hold the plan's attitude to its last burn, the wheels only damp the rate at rest
            wheels = self._hold(omega) if at_rest else np.zeros(3)
            hold = -self._attitude_torque(state) if t_mid < last_burn_end else np.zeros(3)
            if at_rest and not self._burning(t_mid) and self._beyond_share(state, h_wheels):
                wheels, hold = self._dumped(wheels, hold, h_wheels)
        for t_a, t_b, force, torque in self.pulses:
            if t_a <= t_mid < t_b:
                return force, torque, wheels, events
        for burn in self.plan.burns:
            if burn.t_start_s <= t_mid < burn.t_start_s + burn.duration_s:
                force, torque = (np.asarray(burn.force_body_n, dtype=float),
                                 np.asarray(burn.torque_body_n_m, dtype=float))
                if burn.purpose == 'push':  # the hold's couple from the push's own thrusters
                    if self._push_stopping(t, burn):
                        wheels = np.zeros(3)
                    force, torque = self._closed_loop_push(t, state, burn, force, torque, h_wheels, hold)
                    return force, torque, wheels, events
                if burn.purpose == 'slew_stop':
                    force, torque = self._closed_loop_stop(t, state, burn, force, torque, h_wheels)
                wrench = torque_wrench(self.body, self.config.planner, hold) if any(hold) else None
                if wrench is not None:
                    force, torque = force + wrench[0], torque + wrench[1]
                return force, torque, wheels, events
        if any(hold):
            return (*self._couple(hold, self.pulse_n_m_s), wheels, events)
        return np.zeros(3), np.zeros(3), wheels, events

    def _burning(self, t_mid):
        """True where a burn of the plan is under way at t_mid, or starts or ended within a control period."""
        p = self.config.planner.period_s
        return any(b.t_start_s - p <= t_mid < b.t_start_s + b.duration_s + p for b in self.plan.burns)

    def _check(self, state, h_wheels):
        """Between the first push and the next slew, the mid-course correction (``_correct``); after the last burn,
        the terminal program (``_terminal``)."""
        if self.t_terminal is not None:
            return self._terminal(state, h_wheels)
        self.t_check = state.t + self.config.replan_interval_s
        p = self.config.planner.period_s
        pushes = [b for b in self.plan.burns if b.purpose == 'push']
        remaining = [b for b in self.plan.burns if b.t_start_s + b.duration_s > state.t + 1.5 * p]
        if state.t >= pushes[0].t_start_s + pushes[0].duration_s + p and remaining and remaining[0] is not pushes[-1]:
            return self._correct(state, pushes, remaining[0], h_wheels)
        return []

    def _complete(self, t, state, h_wheels):
        # The body's angular momentum as judged: its rate averaged over DETUMBLED_S (the gyro's noise alone is of the
        # first condition's size on a heavy body).
        conditions = {**conditions_of(self.body, state, self.goal), 'angular_momentum_kg_m2_s': self.body_momentum}
        wheel_share = self._wheel_share(h_wheels)
        met = (not missed_conditions(conditions, self.config.planner)
               and wheel_share <= self.config.wheel_momentum_share)
        miss, momentum, h = (conditions[k] for k in ('position_error_m', 'momentum_error_n_s',
                                                     'angular_momentum_kg_m2_s'))
        held_s = 0.0 if self.t_held is None else t - self.t_held
        held = held_s >= self.config.hold_s - 1e-9
        settle_s = t - self.t_arrival
        return ('OK' if met and held else 'WARN', events.TRANSPORT_COMPLETE,
                f'transport ended at t = {t:.1f} s, {settle_s:.0f} s after the arrival (bound '
                f'{self.settle_bound:.0f} s): {miss:.3g} m from the goal, momentum {momentum:.3g} N s, body angular '
                f'momentum {h:.3g} kg m^2/s, wheels {100.0 * wheel_share:.0f} % of their capacity (estimated'
                f'{"" if met else ", a condition missed"}{"" if held else ", not held"})',
                {**conditions, 'wheel_momentum_n_m_s': float(np.linalg.norm(h_wheels)),
                 'wheel_momentum_share': wheel_share, 't_arrival_s': self.t_arrival, 'goal_hill_m': self.goal,
                 'settle_time_s': settle_s, 'settle_bound_s': self.settle_bound, 'held_s': held_s,
                 'conditions_met': met})
