"""Guidance in TRANSPORT (issue 17; seed 004 §2.3, §3.2): the combined body flown to a goal on the reference orbit
with the tug's direction-limited thrusters, closed loop on the estimates (no ROS).

Timeline, every instant a stamp (DESIGN §5):

* t_e, the estimator's final mass-property estimate (``mass_properties_estimated``): the supervisor enters
  TRANSPORT and the plant fires only the thrusters whose exhaust misses the target; guidance builds the body it
  plans for from that estimate (``transport_body``: the combined mass, CoM and inertia, the allowed thrusters by
  ``actuators.plume_free_thrusters`` about the estimated target CoM) and first detumbles it with the damping law
  of the capture (``post_capture.damping_command``: the excitation leaves it turning; its couple made with the
  least side force the allowed thrusters need, ``transport.torque_wrench``) until the estimated angular
  momentum, its rate averaged over DETUMBLED_S, is below half the condition's (``transport_detumbled``), while the
  combined body's navigation settles (at least NAV_SETTLE_S);
* then the plan (``flyby_planner.transport.plan_transport``) from the estimate to the goal, arriving
  ``transfer_time_s`` after t_e (``transport_planned``, or ``transport_refused`` with the planner's reason: the
  supervisor completes the run with the body held where it is);
* each estimate at t commands the wrench of the burn that covers the control period from t + period (the burns
  lie on that grid); where the plan has the body at rest (outside its slews) the wheels damp the rate its burns
  left (the estimated mass properties are not the true ones: an open-loop slew stops a little off); there, every
  ``replan_interval_s`` from the end of the first push on, the rest of the plan is propagated from the estimate and
  a miss of the goal by more than ``replan_position_m`` plans again to the same arrival (``transport_replanned``);
  after the arrival an estimate off the goal by more than ``replan_position_m`` or ``replan_momentum_n_s`` is
  trimmed (``transport_trim``): a velocity the allowed thrusters reach as a pure force at once, else by a short plan
  of ``TRIM_TIME_S``;
* ``settle_s`` after the arrival, ``transport_complete`` with the estimated conditions (the summary judges them
  from the truth).
"""

import collections
import dataclasses
import json

import numpy as np

from flyby_guidance.post_capture import damping_command
from flyby_planner.transfer import terminal_impulses
from flyby_planner.transport import (
    TransportBody,
    TransportConfig,
    TransportRefused,
    TransportState,
    plan_transport,
    propagate,
    resolve_slew,
    torque_wrench,
)
from flyby_sim.dynamics.actuators import allocate_wrench, plume_free_thrusters
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.combined_body import combined_mass_properties, inertia_from_principal
from flyby_sim.dynamics.orbital import cw_transition_matrix
from flyby_sim.dynamics.rotation import quat_to_matrix

TRIM_TIME_S = 300.0  # a trim's transfer, after the arrival [s]
NAV_SETTLE_S = 30.0  # the combined body's navigation converges from its first position [s]
DETUMBLED_S = 5.0  # the detumbling's end: the momentum bound held this long [s]
DETUMBLE_HALVINGS = 8  # a detumbling torque beyond the thrusters is halved at most this often
PUSH_FORCE_MARGIN = 1.3  # a closed-loop push asks at most this much more force than planned
DIRECT_TRIM_S = 10.0  # a direct trim nulls the velocity over this long [s]
SLEW_RATE_DOUBLINGS = 3  # a re-plan short of time for the configured slew rate doubles it at most this often


def transport_body(values, chaser_mass_kg, chaser_inertia_kg_m2, layout, plume_cone_deg):
    """The TransportBody of the final mass-property estimate (the ``mass_properties_estimated`` event's values, as
    text or numbers): the combined body of the chaser and the estimated target, and the thrusters whose exhaust
    misses the estimated target CoM."""
    def number(key):
        value = values[key]
        return np.asarray(json.loads(value) if isinstance(value, str) else value, dtype=float)

    target_mass = float(number('mass_kg'))
    x_s = number('com_body_m')
    inertia_target = inertia_from_principal(number('principal_moments_kg_m2'), number('principal_axes_q'))
    props = combined_mass_properties(chaser_mass_kg, chaser_inertia_kg_m2, target_mass, x_s, inertia_target)
    return TransportBody(props.mass_kg, props.com_body_m, props.inertia_body_kg_m2,
                         layout.subset(plume_free_thrusters(layout, x_s, plume_cone_deg)))


def com_state(body, t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega_body, n):
    """The TransportState of the combined CoM from a chaser estimate (eq 8-9 of the chaser's CoM, -c in the body)."""
    r_point, v_point = body_point_state(quat_to_matrix(q_hill_from_body), np.asarray(omega_body, dtype=float),
                                        -np.asarray(body.com_body_m), n)
    return TransportState(t, np.asarray(r_chaser_hill, dtype=float) - r_point,
                          np.asarray(v_chaser_hill, dtype=float) - v_point, np.asarray(q_hill_from_body, dtype=float),
                          np.asarray(omega_body, dtype=float))


@dataclasses.dataclass(frozen=True)
class TransportGuidanceConfig:
    """scenario post_capture.transport, and guidance's control period."""

    goal_hill_m: tuple
    transfer_time_s: float
    plume_cone_deg: float
    replan_interval_s: float
    replan_position_m: float
    replan_momentum_n_s: float
    settle_s: float
    planner: TransportConfig


def transport_guidance_config_from_scenario(scenario, period_s):
    tr = scenario.post_capture.transport
    planner = TransportConfig(period_s=period_s, radius_m=scenario.orbit_radius_m, mu=scenario.orbit.mu_m3_s2,
                              max_angular_momentum_kg_m2_s=tr.max_angular_momentum_kg_m2_s,
                              max_position_error_m=tr.max_position_error_m,
                              max_momentum_error_n_s=tr.max_momentum_error_n_s)
    return TransportGuidanceConfig(tuple(tr.goal_hill_m), tr.transfer_time_s, tr.plume_cone_deg, tr.replan_interval_s,
                                   tr.replan_position_m, tr.replan_momentum_n_s, tr.settle_s, planner)


class TransportControl:
    """Guidance's rules in TRANSPORT (module doc): ``start`` at the final mass-property estimate, then ``command`` at
    every chaser estimate stamped from it on; each returns (force_body_n, torque_body_n_m, wheel_torque_body_n_m,
    events) for the control period that starts one period after the estimate's stamp (torque about the chaser's CoM,
    DESIGN §10)."""

    def __init__(self, config, n, gains, wheel_max_torque_n_m):
        """gains: the capture's DampingGains (the detumbling and, its wheel gain, the rest hold)."""
        self.config = config
        self.n = n
        self.gains = gains
        self.wheel_max_torque_n_m = wheel_max_torque_n_m
        self.t_detumbled = None
        self.rates = collections.deque()  # (t, omega_body) over the last DETUMBLED_S
        self.carried = np.zeros(3)  # the detumbling's angular impulse not yet fired [N m s]
        self.resolved = set()  # the start times of the slews solved again from the estimate
        self.trimming = None  # the end of a direct trim in progress [s]
        self.goal = np.asarray(config.goal_hill_m, dtype=float)
        self.body = None
        self.t_start = None
        self.t_arrival = None
        self.plan = None
        self.plan_start = None  # the TransportState the plan was made from
        self.t_check = None
        self.done = False

    def start(self, t_event, body):
        """TRANSPORT from the final estimate stamped t_event [s], for the TransportBody of that estimate."""
        self.t_start = t_event
        self.t_arrival = t_event + self.config.transfer_time_s
        self.body = body
        # A pulse: ten minimum impulse bits at the thrusters' mean lever arm about the combined CoM [N m s].
        arms = np.linalg.norm(body.layout.positions_body_m - body.com_body_m, axis=1)
        self.pulse_n_m_s = 10.0 * body.layout.min_impulse_bit_n_s * float(np.mean(arms))

    def command(self, t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega_body, h_wheels_body_n_m_s):
        """(force [N], torque about the chaser's CoM [N m], wheel motor torque [N m], chaser_body; events) for the
        control period from t + period."""
        zero = np.zeros(3)
        cfg = self.config
        if self.done or self.t_start is None:
            return zero, zero, zero, []
        period = cfg.planner.period_s
        omega = np.asarray(omega_body, dtype=float)
        h_wheels = np.asarray(h_wheels_body_n_m_s, dtype=float)
        if self.t_detumbled is None:
            return self._detumble(t, omega, h_wheels)
        events = []
        state = com_state(self.body, t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega, self.n)
        if self.plan is None:
            if t < max(self.t_start + NAV_SETTLE_S, self.t_detumbled) - 1e-9:
                return zero, zero, self._hold(omega), []
            events += self._plan(state, self.t_arrival, 'transport_planned')
            if self.done:
                return zero, zero, zero, events
        t_mid = t + 1.5 * period
        at_rest = not any(a.t_start_s - period <= t_mid < b.t_start_s + b.duration_s + period
                          for a, b in self._slews())
        if at_rest and t >= self.t_check - 1e-9:
            events += self._check(state)
        if t >= self.t_arrival + cfg.settle_s - 1e-9:
            self.done = True
            events.append(self._complete(t, state, h_wheels))
            return zero, zero, zero, events
        wheels = self._hold(omega) if at_rest else zero
        if self.trimming is not None:
            return (*self._direct_trim(t, state), wheels, events)
        for start, stop in self._slews():
            if start.t_start_s <= t_mid < start.t_start_s + period and start.t_start_s not in self.resolved:
                events += self._resolve(state, start, stop)
                break
        for burn in self.plan.burns:
            if burn.t_start_s <= t_mid < burn.t_start_s + burn.duration_s:
                force, torque = (np.asarray(burn.force_body_n, dtype=float),
                                 np.asarray(burn.torque_body_n_m, dtype=float))
                if burn.purpose == 'push':
                    force, torque = self._closed_loop_push(t, state, burn, force, torque)
                elif burn.purpose == 'slew_stop':
                    force, torque = self._closed_loop_stop(t, state, burn, force, torque)
                return force, torque, wheels, events
        return zero, zero, wheels, events

    def _resolve(self, state, start, stop):
        """The slew about to start solved again from the estimate (``transport.resolve_slew``), to aim the push axis
        where the push after it must go from the trajectory the body is really on: the first impulse of eq 28-29 at
        that push, or at the last push the velocity it must null (the state coasted by CW to the push's middle)."""
        burns = list(self.plan.burns)
        i = next(k for k, b in enumerate(burns) if b is stop)
        push = burns[i + 1]
        t_aim = push.t_start_s + 0.5 * push.duration_s
        r, v = np.split(cw_transition_matrix(self.n, t_aim - state.t) @ np.concatenate((state.r_hill, state.v_hill)),
                        2)
        if push is [b for b in burns if b.purpose == 'push'][-1]:
            u_hill = -v
        else:
            u_hill, _ = terminal_impulses(r, v, self.goal, np.zeros(3), self.plan.t_arrival_s - t_aim, self.n)
        try:
            new_start, new_stop = resolve_slew(self.body, self.config.planner, state, start, stop, u_hill, t_aim,
                                               self.plan.t_arrival_s)
        except TransportRefused as err:
            self.resolved.add(start.t_start_s)
            return [('WARN', 'transport_slew_kept', f'the slew at {start.t_start_s:.1f} s flown as planned: '
                                                    f'{err.reason}', {'reason': err.reason})]
        burns[i - 1], burns[i] = new_start, new_stop
        self.plan = self.plan._replace(burns=tuple(burns))
        self.resolved.add(new_start.t_start_s)
        return []

    def _closed_loop_stop(self, t, state, burn, force, torque):
        """A slew's spin-down flown on the estimate: the torque about the combined CoM that takes out the estimated
        angular momentum I omega over the rest of the burn (the open-loop slew, planned on the estimated inertia,
        stops a little off), with the least side force; the planned wrench where the thrusters cannot."""
        p = self.config.planner.period_s
        remaining_s = burn.t_start_s + burn.duration_s - (t + p)
        if remaining_s < 0.5 * p:
            return force, torque
        wrench = torque_wrench(self.body, self.config.planner,
                               -self.body.inertia_body_kg_m2 @ state.omega_body / remaining_s)
        return (force, torque) if wrench is None else wrench

    def _closed_loop_push(self, t, state, burn, force, torque):
        """A push flown on the estimate (module doc): the force over the rest of the burn that gives the velocity the
        plan has at the push's end (its propagation from the state it was made from; the last push's is the goal's
        rest), turned into the body by the attitude estimate, with no torque about the combined CoM; the planned
        wrench where the allowed thrusters cannot give it (an attitude far off its plan). Pointing and execution
        errors of the push are taken out; a miss of the position is the re-plans' and trims'."""
        p = self.config.planner.period_s
        t_from = t + p
        remaining_s = burn.t_start_s + burn.duration_s - t_from
        if remaining_s < 0.5 * p:
            return force, torque
        dv_hill = self.push_velocity[round(burn.t_start_s / p)] - state.v_hill
        force_hill = self.body.mass_kg * dv_hill / remaining_s
        limit = PUSH_FORCE_MARGIN * float(np.linalg.norm(force))
        if float(np.linalg.norm(force_hill)) > limit:
            force_hill = force_hill * (limit / float(np.linalg.norm(force_hill)))
        force_body = quat_to_matrix(state.q_hill_from_body).T @ force_hill
        torque_body = np.cross(self.body.com_body_m, force_body)  # about the chaser's CoM: none about the combined
        if allocate_wrench(self.body.layout, force_body, torque_body).saturated:
            return force, torque
        return force_body, torque_body

    def _slews(self):
        """(start, stop) burn pairs of the plan: the body turns between them."""
        starts = [b for b in self.plan.burns if b.purpose == 'slew_start']
        stops = [b for b in self.plan.burns if b.purpose == 'slew_stop']
        return list(zip(starts, stops, strict=True))

    def _hold(self, omega):
        """The wheels against the rate (the damping law's wheel gain), within their torque."""
        return np.clip(self.gains.wheel_gain_n_m_s * omega, -self.wheel_max_torque_n_m, self.wheel_max_torque_n_m)

    def _detumble(self, t, omega, h_wheels):
        """The damping law until the estimated angular momentum |I omega + h|, the rate its mean over DETUMBLED_S
        (the gyro's noise on a 3000 kg m^2 body is of the bound's size), is below half the condition's."""
        self.rates.append((t, omega))
        while self.rates[0][0] < t - DETUMBLED_S - 1e-9:
            self.rates.popleft()
        mean = np.mean([w for _, w in self.rates], axis=0)
        momentum = float(np.linalg.norm(self.body.inertia_body_kg_m2 @ mean + h_wheels))
        bound = 0.5 * self.config.planner.max_angular_momentum_kg_m2_s
        if momentum < bound and t - self.t_start >= DETUMBLED_S:  # the mean over a whole window
            self.t_detumbled = t
            return np.zeros(3), np.zeros(3), np.zeros(3), [(
                'OK', 'transport_detumbled', f'the combined body detumbled for the transport after '
                                             f'{t - self.t_start:.1f} s: {momentum:.3g} kg m^2/s (estimated)',
                {'angular_momentum_kg_m2_s': momentum, 'detumbling_time_s': t - self.t_start})]
        tau, u = damping_command(omega, h_wheels, self.gains, self.wheel_max_torque_n_m)
        # Below the thrusters' minimum impulse bit a small couple is not fired at all: its angular impulse is carried
        # until it is worth a pulse (pulse-frequency modulation of the same mean torque).
        period = self.config.planner.period_s
        self.carried = self.carried + tau * period
        if float(np.linalg.norm(self.carried)) < self.pulse_n_m_s:
            return np.zeros(3), np.zeros(3), u, []
        tau, self.carried = self.carried / period, np.zeros(3)
        for _ in range(DETUMBLE_HALVINGS):  # no pure couple about every axis: the least side force, within reach
            wrench = torque_wrench(self.body, self.config.planner, tau)
            if wrench is not None:
                return wrench[0], wrench[1], u, []
            tau = 0.5 * tau
        return np.zeros(3), np.zeros(3), u, []

    def _plan(self, state, t_arrival, name):
        """A plan from the estimated state to the goal, arriving at t_arrival; its event (a refusal ends the
        transport: the body is held where it is)."""
        cfg = self.config
        first = state.t + 2.0 * cfg.planner.period_s  # the first period a command of this estimate can still reach
        start = TransportState(first, *state[1:])
        try:
            plan = self._plan_with_faster_slews(start, t_arrival)
        except TransportRefused as err:
            if self.plan is not None:  # keep flying the plan there is
                self.t_check = state.t + cfg.replan_interval_s
                return [('WARN', 'transport_replan_refused', f'no new transport plan: {err.reason}',
                         {'reason': err.reason})]
            self.done = True
            return [('ERROR', 'transport_refused', f'no transport plan meets the conditions: {err.reason}',
                     {'reason': err.reason})]
        self.plan, self.plan_start = plan, start
        # The velocity the plan has at each push's end (hill), by grid tick of its start: the closed-loop push's aim.
        self.push_velocity = {}
        for burn in plan.burns:
            if burn.purpose == 'push':
                end = burn.t_start_s + burn.duration_s
                self.push_velocity[round(burn.t_start_s / cfg.planner.period_s)] = propagate(
                    self.body, start, [b for b in plan.burns if b.t_start_s < end], end, cfg.planner).v_hill
        self.t_check = state.t + cfg.replan_interval_s
        c = plan.conditions
        return [('OK', name, f'transport to {np.round(self.goal, 2).tolist()} m in {len(plan.burns)} burns, '
                             f'{plan.fuel_kg * 1e3:.1f} g, arrival at t = {plan.t_arrival_s:.1f} s; predicted '
                             f'{c["position_error_m"]:.3g} m, {c["momentum_error_n_s"]:.3g} N s, '
                             f'{c["angular_momentum_kg_m2_s"]:.3g} kg m^2/s',
                 {'t_arrival_s': plan.t_arrival_s, 'burns': len(plan.burns), 'fuel_kg': plan.fuel_kg,
                  'predicted_position_error_m': c['position_error_m'],
                  'predicted_momentum_error_n_s': c['momentum_error_n_s'],
                  'predicted_angular_momentum_kg_m2_s': c['angular_momentum_kg_m2_s']})]

    def _plan_with_faster_slews(self, start, t_arrival):
        """plan_transport, and where the slews at the configured rate leave too little time, again with the rate
        doubled (at most SLEW_RATE_DOUBLINGS times): a correction late in the transfer turns faster."""
        planner = self.config.planner
        for _ in range(SLEW_RATE_DOUBLINGS):
            try:
                return plan_transport(self.body, start, self.goal, t_arrival, planner)
            except TransportRefused as err:
                if not err.reason.startswith('too little time'):
                    raise
                planner = dataclasses.replace(planner, slew_rate_rad_s=2.0 * planner.slew_rate_rad_s)
        return plan_transport(self.body, start, self.goal, t_arrival, planner)

    def _check(self, state):
        """Before the arrival, from the end of the first push on: the rest of the plan predicted from the estimate,
        planned again to the same arrival when it misses the goal by more than replan_position_m (the momentum at the
        arrival is the last push's to match, planned from the state then); after it, a trim when the estimate is
        off the goal by more than replan_position_m or replan_momentum_n_s, arriving TRIM_TIME_S later (module
        doc). None that would end after the judgement."""
        cfg = self.config
        self.t_check = state.t + cfg.replan_interval_s
        p = cfg.planner.period_s
        pushes = [b for b in self.plan.burns if b.purpose == 'push']
        if pushes and state.t < pushes[0].t_start_s + pushes[0].duration_s + p:
            return []  # the first push not flown yet: the plan is as good as when it was made
        remaining = [b for b in self.plan.burns if b.t_start_s + b.duration_s > state.t + 1.5 * p]
        if remaining and remaining[0].t_start_s < state.t + 2.0 * p:
            return []  # a burn is on: judged after it
        if state.t < self.t_arrival - TRIM_TIME_S:
            predicted = propagate(self.body, state, remaining, self.t_arrival, cfg.planner)
            if float(np.linalg.norm(predicted.r_hill - self.goal)) <= cfg.replan_position_m:
                return []
            return self._plan(state, self.t_arrival, 'transport_replanned')
        if remaining or state.t < self.plan.t_arrival_s:
            return []  # the last burns of the plan are to come
        miss = float(np.linalg.norm(state.r_hill - self.goal))
        momentum = self.body.mass_kg * float(np.linalg.norm(state.v_hill))
        if miss <= cfg.replan_position_m and momentum <= cfg.replan_momentum_n_s:
            return []
        if miss <= cfg.replan_position_m and self._pure_force(-state.v_hill, state) is not None:
            self.trimming = state.t + DIRECT_TRIM_S  # the velocity within reach: nulled at once, no slew
            return [('OK', 'transport_trim', f'momentum {momentum:.3g} N s nulled by a pure force in '
                                             f'{DIRECT_TRIM_S:g} s (no slew)', {'momentum_n_s': momentum})]
        if state.t + TRIM_TIME_S > self.t_arrival + cfg.settle_s:
            return []
        return self._plan(state, state.t + TRIM_TIME_S, 'transport_trim')

    def _pure_force(self, direction_hill, state):
        """(force, torque about the chaser's CoM), body axes, of a one-newton force along direction_hill with no
        torque about the combined CoM; None where the allowed thrusters cannot give it at the body's attitude."""
        d = np.asarray(direction_hill, dtype=float)
        if not float(np.linalg.norm(d)) > 0.0:
            return None
        f_body = quat_to_matrix(state.q_hill_from_body).T @ (d / float(np.linalg.norm(d)))
        allocation = allocate_wrench(self.body.layout, f_body, np.cross(self.body.com_body_m, f_body))
        return None if allocation.saturated else (f_body, np.cross(self.body.com_body_m, f_body))

    def _direct_trim(self, t, state):
        """The direct trim's command: the force that nulls the estimated velocity over the rest of the trim, when
        the thrusters give it as a pure force (else nothing, and the trim ends)."""
        p = self.config.planner.period_s
        remaining_s = self.trimming - (t + p)
        zero = np.zeros(3)
        if remaining_s < 0.5 * p:
            self.trimming = None
            self.t_check = t + self.config.replan_interval_s
            return zero, zero
        force_hill = -self.body.mass_kg * state.v_hill / remaining_s
        unit = self._pure_force(force_hill, state)
        if unit is None:
            self.trimming = None
            return zero, zero
        size = float(np.linalg.norm(force_hill))
        if allocate_wrench(self.body.layout, size * unit[0], size * unit[1]).saturated:
            return zero, zero  # beyond the thrusters at once: wait for the rest of the trim
        return size * unit[0], size * unit[1]

    def _complete(self, t, state, h_wheels):
        momentum = self.body.mass_kg * float(np.linalg.norm(state.v_hill))
        h = float(np.linalg.norm(self.body.inertia_body_kg_m2 @ state.omega_body + h_wheels))
        miss = float(np.linalg.norm(state.r_hill - self.goal))
        return ('OK', 'transport_complete',
                f'transport ended at t = {t:.1f} s: {miss:.3g} m from the goal, momentum {momentum:.3g} N s, angular '
                f'momentum {h:.3g} kg m^2/s (estimated)',
                {'position_error_m': miss, 'momentum_error_n_s': momentum, 'angular_momentum_kg_m2_s': h,
                 't_arrival_s': self.t_arrival, 'goal_hill_m': self.goal})

