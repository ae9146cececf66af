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
  lie on that grid); the wheels track the attitude the plan has at t (``transport.attitude_at`` of the planned
  torques about the combined CoM on the estimated inertia, from the estimate where the plan or a slew was solved
  again): the open-loop slews' coasts follow it though the estimated inertia is a few percent off, and a push, pure
  about the estimated CoM but not about the true one, keeps its direction. A push gives the velocity the plan has at
  its end and a spin-down takes out the estimated angular momentum, each less what the command already issued for
  the period after the estimate gives. Between the first push and the next slew, every ``replan_interval_s``, the
  estimate's deviation from the plan's coast is carried to the last push (CW, seed 000 eq 22); a miss there beyond
  ``replan_position_m`` gets a one-impulse correction (``transport_correction``) where the thrusters give it at the
  attitude held, keeping the last push, which nulls the velocity at the arrival whatever it is;
* after the arrival and the plan's last burn, the trim (``_trim``, every ``replan_interval_s`` while nothing is
  moving): the estimated angular momentum (wheels included) above DUMP_FRACTION of the first condition is dumped
  by thruster couples (``transport_dump``); else a position off the goal by more than ``replan_position_m`` gets a
  CW transfer back arriving TRIM_TIME_S later (seed 000 eq 28-29, ``transport_trim``), only where it arrives early
  enough before the judgement for its arrival velocity to be taken out (checked at once at its arrival; a late one
  left four of 100 campaign runs moving at 0.36-0.46 N s); else the velocity error
  beyond ``replan_momentum_n_s`` (from the velocity that coasts to rest at the judgement, CW: off the goal the body
  is not at rest in hill) is nulled by a pulse (``transport_pulse``): a pure force along it where the allowed
  thrusters give one with every firing thruster above the minimum impulse bit, else along the push axis, which the
  wheels first turn onto it (a wheel slew changes no angular momentum and pushes nothing), by the thrusters along
  it or, below a bit each, by one of them whose small couple the wheels take;
* on a body the wheels do not steer (they would spin it up to the slews' rate in more than WHEEL_SPINUP_S:
  paper_flyby_transport's 1600 kg), the thrusters' couples track the plan's attitude instead, to its last burn; the
  arrival push stops ARRIVAL_MARGIN_N_S short of rest and each trim pulse short along the push axis, so that what is
  left stays within the pure forces the thrusters give about the combined CoM at the attitude held (none against
  the push axis); an error out of reach waits, and pulses come NAV_COAST_S apart;
* where the combined CoM's uncertainty matters (``_coasting``: on paper_flyby_transport each mm is 0.0017 N s of
  velocity error, the body turning in hill at n), the trim lets the estimator's coasts sharpen it
  (``transport_com_estimate``, ``refine_com``) until COM_FINAL_RAD of orbit before the judgement: it aims at no
  along-track drift, fires only for a drift beyond COM_WAIT_FACTOR times that uncertainty, starts no transfer back and
  dumps only beyond the first condition, and where the wheels do not steer they turn the push axis onto the change
  the pulses after the coast need (``_plan_coast_slew``); then it aims at rest at the judgement, where a pulse that
  costs more than AIM_COST_RATIO times what it takes off the judged error waits;
* ``settle_s`` after the arrival, ``transport_complete`` with the estimated conditions, a WARN where the estimate
  misses one (the summary judges them from the truth).
"""

import collections
import dataclasses
import json

import numpy as np

from flyby_guidance.post_capture import damping_command, pulse_modulated
from flyby_msgs_py.wire import STAMP_TOLERANCE_S
from flyby_planner.transfer import terminal_impulses
from flyby_planner.transport import (
    TransportBody,
    TransportConfig,
    TransportRefused,
    TransportState,
    attitude_at,
    conditions_of,
    missed_conditions,
    plan_transport,
    propagate,
    push_axis,
    resolve_slew,
    torque_wrench,
)
from flyby_sim.dynamics.actuators import allocate_wrench, fire, plume_free_thrusters
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.combined_body import combined_mass_properties, inertia_from_principal
from flyby_sim.dynamics.orbital import cw_transition_matrix, hill_axes_in_eci, q_eci_from_body
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    quat_rotate,
    quat_shortest_arc,
    quat_to_matrix,
    rotation_vector_from_quat,
)

TRIM_TIME_S = 300.0  # a trim's transfer, after the arrival [s]
NAV_SETTLE_S = 30.0  # the combined body's navigation converges from its first position [s]
DETUMBLED_S = 5.0  # the detumbling's end: the momentum bound held this long [s]
DETUMBLE_HALVINGS = 8  # a detumbling torque beyond the thrusters is halved at most this often
PUSH_FORCE_MARGIN = 1.3  # a closed-loop push asks at most this much more force than planned
TRACK_BANDWIDTH_RAD_S = 0.2  # the wheels' attitude tracking: natural frequency [rad/s] ...
TRACK_DAMPING = 0.7  # ... and damping ratio
TRIM_SLEW_RATE_RAD_S = 0.05  # a trim's wheel slew turns at most this fast ...
WHEEL_SPINUP_S = 10.0  # ... and reaches its rate within this long at the wheels' torque
ARRIVAL_MARGIN_N_S = 10.0  # on a body the wheels do not steer the arrival push stops this short of rest ...
PULSE_LEAVE_FRACTION = 0.3  # ... and a trim pulse there stops short along the push axis by this much of the error
PULSE_LEAVE_N_S = 0.004  # ... or by this, at least [N s] ...
PULSE_FORCE_TOLERANCE = 0.3  # ... and its thrusters below the bit may leave this much of its force ...
PULSE_TORQUE_FRACTION = 5.0  # ... and this much of the first condition's angular momentum undelivered (dumped after)
PULSE_LENGTHENINGS = 6  # ... made longer (its force halved) at most this often where the thrusters saturate
AIM_COST_RATIO = 2.0  # a trim pulse waits while it costs more than this many times what it takes off the judged error
COM_SHARP_FRACTION = 0.25  # where the CoM's uncertainty is worth more than this of the third condition in velocity ...
COM_WAIT_FACTOR = 3.0  # ... the trim takes out only a drift beyond this many times that worth ...
DRIFT_ALONG_FRACTION = 0.2  # ... along the push axis where it is at least this much along the drift's gradient ...
COM_FINAL_RAD = 1.2  # ... until this much of an orbit before the judgement [rad] ...
COAST_SLEW_MOMENTUM_FRACTION = 0.6  # ... meanwhile a wheel slew at this much of the wheels' momentum ...
COAST_SLEW_MARGIN_S = 300.0  # ... done this long before the coast's end [s]
NAV_COAST_S = 100.0  # ... each after a coast this long from the last firing (the navigation's velocity converges)
TRIM_POINTING_RAD = 0.05  # a trim pulse along the push axis fires with it this close to the velocity error
DUMP_FRACTION = 0.3  # an angular momentum worth this much of the first condition is dumped after the arrival
DUMP_S = 10.0  # a dump's couple takes the angular momentum out over this long [s] ...
DUMP_TAIL_S = 1.0  # ... aimed at its end, but never over less than this [s]
SLEW_RATE_DOUBLINGS = 3  # a plan short of time for the configured slew rate doubles it at most this often
_FIRING_N = 1e-6  # an allocation's thrust above this fires (the LP leaves ~1e-12 N on the others)


def event_array(values, key):
    """An event's value (text or numbers) as a float array."""
    value = values[key]
    return np.asarray(json.loads(value) if isinstance(value, str) else value, dtype=float)


def transport_body(values, chaser_mass_kg, chaser_inertia_kg_m2, layout, plume_cone_deg):
    """The TransportBody of the final mass-property estimate (the ``mass_properties_estimated`` event's values, as
    text or numbers): the combined body of the chaser and the estimated target, and the thrusters whose exhaust
    misses the estimated target CoM."""
    target_mass = float(event_array(values, 'mass_kg'))
    x_s = event_array(values, 'com_body_m')
    inertia_target = inertia_from_principal(event_array(values, 'principal_moments_kg_m2'),
                                            event_array(values, 'principal_axes_q'))
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

    def __init__(self, config, n, gains, wheel_max_torque_n_m, wheel_max_momentum_n_m_s=None):
        """gains: the capture's DampingGains (the detumbling and, its wheel gain, the hold before the plan); the
        wheels' momentum bounds the CoM's coast slew (none without it)."""
        self.config = config
        self.n = n
        self.gains = gains
        self.wheel_max_torque_n_m = wheel_max_torque_n_m
        self.wheel_max_momentum_n_m_s = wheel_max_momentum_n_m_s
        self.t_detumbled = None
        self.rates = collections.deque()  # (t, omega_body) over the last DETUMBLED_S
        self.momentum = None  # the estimated angular momentum, the rate averaged over DETUMBLED_S [kg m^2/s]
        self.carried = np.zeros(3)  # a couple's angular impulse not yet fired [N m s]
        self.resolved = set()  # the start times of the slews solved again from the estimate
        self.goal = np.asarray(config.goal_hill_m, dtype=float)
        self.body = None
        self.t_start = None
        self.t_arrival = None
        self.plan = None
        self.plan_start = None  # the TransportState the plan was made from
        self.t_check = None
        # The attitude the wheels track: (t, q_eci_from_body, omega_body) of the plan's model, and after the arrival
        # the trim's wheel slew (t0, q0_eci, axis_eci, angle [rad], rate [rad/s]).
        self.reference = None
        self.trim_slew = None
        self.trim_arrival = None  # a trim's transfer back to the goal arrives then [s]
        self.pulses = []  # (t_start, t_end, force_body_n, torque_body_n_m) of the trim's pulses, on the grid
        self.dumping = None  # the end of a dump in progress [s]
        self.dumped = None  # the estimated angular momentum at the last dump's start [kg m^2/s]
        self.issued = None  # (t, force, torque) of the last command: it acts from t + period, after the estimate at t
        self.done = False
        self.t_com = None  # the stamp of the last refined combined CoM taken (``refine_com``) [s] ...
        self.com_sigma_m = None  # ... the 1-sigma per axis [m, chaser_body] of the one taken ...
        self.com_pending = collections.deque()  # ... and (t, com_body_m, com_sigma_m) of those for later estimates
        self.com_worth = None  # the CoM's uncertainty in momentum at the first trim where it matters [N s] (_coasting)
        self.coast_slew = False  # the coast's wheel slew is planned (``_plan_coast_slew``)

    def refine_com(self, t_event, values):
        """The estimator's combined CoM, refined over the coasts, stamped t_event (``transport_com_estimate``'s
        values): the body's CoM, and its 1-sigma, for the estimates from t_event on (the topics race: it may come
        before the estimates stamped earlier)."""
        self.t_com = t_event
        self.com_pending.append((t_event, event_array(values, 'com_body_m'), event_array(values, 'com_sigma_m')))

    def _take_com(self, t):
        """The refined combined CoM for the estimate stamped t (``refine_com``)."""
        while self.com_pending and self.com_pending[0][0] <= t + STAMP_TOLERANCE_S:
            _, com, self.com_sigma_m = self.com_pending.popleft()
            self.body = dataclasses.replace(self.body, com_body_m=com)

    def start(self, t_event, body):
        """TRANSPORT from the final estimate stamped t_event [s], for the TransportBody of that estimate."""
        self.t_start = t_event
        self.t_arrival = t_event + self.config.transfer_time_s
        self.body = body
        self.b_body = push_axis(body)[0]
        # A pulse: ten minimum impulse bits at the thrusters' mean lever arm about the combined CoM [N m s].
        arms = np.linalg.norm(body.layout.positions_body_m - body.com_body_m, axis=1)
        self.pulse_n_m_s = 10.0 * body.layout.min_impulse_bit_n_s * float(np.mean(arms))
        # A trim's wheel slew: as fast as TRIM_SLEW_RATE_RAD_S, or as the wheels spin the body up in WHEEL_SPINUP_S.
        spin_up_rad_s = self.wheel_max_torque_n_m * WHEEL_SPINUP_S / float(
            np.max(np.linalg.eigvalsh(body.inertia_body_kg_m2)))
        self.trim_slew_rate = min(TRIM_SLEW_RATE_RAD_S, spin_up_rad_s)
        # The wheels steer the body (track the plan's attitude, turn it for a trim) where they spin it up to the
        # slews' rate within WHEEL_SPINUP_S; on a heavier body they only damp its rate at rest.
        self.wheels_steer = spin_up_rad_s >= self.config.planner.slew_rate_rad_s
        # A transfer back must arrive this long before the judgement: two checks and a half turn of the push axis by
        # the wheels before the pulse that takes its arrival velocity out. Where the wheels do not steer, no half
        # turn: a pulse there is a pure force at the attitude held (with the half turn at their 5e-4 rad/s,
        # paper_flyby_transport never dumped its last trim's 1 kg m^2/s).
        self.trim_stop_s = 2.0 * self.config.replan_interval_s + WHEEL_SPINUP_S + (
            np.pi / self.trim_slew_rate if self.wheels_steer else 0.0)

    def command(self, t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega_body, h_wheels_body_n_m_s):
        """(force [N], torque about the chaser's CoM [N m], wheel motor torque [N m], chaser_body; events) for the
        control period from t + period."""
        out = self._command(t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega_body, h_wheels_body_n_m_s)
        self.issued = (t, out[0], out[1])
        return out

    def _command(self, t, r_chaser_hill, v_chaser_hill, q_hill_from_body, omega_body, h_wheels_body_n_m_s):
        zero = np.zeros(3)
        self._take_com(t)
        cfg = self.config
        if self.done or self.t_start is None:
            return zero, zero, zero, []
        period = cfg.planner.period_s
        omega = np.asarray(omega_body, dtype=float)
        h_wheels = np.asarray(h_wheels_body_n_m_s, dtype=float)
        # The estimated angular momentum |I omega + h|, the rate its mean over DETUMBLED_S (the gyro's noise on a
        # 3000 kg m^2 body is of the first condition's size).
        self.rates.append((t, omega))
        while self.rates[0][0] < t - DETUMBLED_S - 1e-9:
            self.rates.popleft()
        self.momentum = float(np.linalg.norm(self.body.inertia_body_kg_m2 @ np.mean([w for _, w in self.rates], axis=0)
                                             + h_wheels))
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
        t_mid = t + 1.5 * period
        if t >= self.t_arrival + cfg.settle_s - 1e-9:
            self.done = True
            events.append(self._complete(t, state, h_wheels))
            return zero, zero, zero, events
        at_rest = not any(a.t_start_s - period <= t_mid < b.t_start_s + b.duration_s + period
                          for a, b in self._slews())
        if at_rest and t >= self.t_check - 1e-9:
            events += self._check(state)
        for start, stop in self._slews():
            if start.t_start_s <= t_mid < start.t_start_s + period and start.t_start_s not in self.resolved:
                events += self._resolve(state, start, stop)
                break
        if self.wheels_steer:
            wheels, hold = self._track(state), zero
        else:  # the thrusters' couples hold the plan's attitude to its last burn, the wheels only damp the rate at rest
            flying = t_mid < max(b.t_start_s + b.duration_s for b in self.plan.burns)
            wheels = self._track(state) if self.coast_slew else (self._hold(omega) if at_rest else zero)
            hold = -self._attitude_torque(state) if flying else zero
        if self.dumping is not None:
            return (*self._dump(t, state, h_wheels), wheels, events)
        for t_a, t_b, force, torque in self.pulses:
            if t_a <= t_mid < t_b:
                return force, torque, wheels, events
        for burn in self.plan.burns:
            if burn.t_start_s <= t_mid < burn.t_start_s + burn.duration_s:
                force, torque = (np.asarray(burn.force_body_n, dtype=float),
                                 np.asarray(burn.torque_body_n_m, dtype=float))
                if burn.purpose == 'push':  # the hold's couple from the push's own thrusters
                    force, torque = self._closed_loop_push(t, state, burn, force, torque)
                    return force, torque + hold, wheels, events
                if burn.purpose == 'slew_stop':
                    force, torque = self._closed_loop_stop(t, state, burn, force, torque, h_wheels)
                wrench = torque_wrench(self.body, self.config.planner, hold) if any(hold) else None
                if wrench is not None:
                    force, torque = force + wrench[0], torque + wrench[1]
                return force, torque, wheels, events
        if any(hold):
            return (*self._couple(hold, self.pulse_n_m_s), wheels, events)
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
        self._set_reference(state)
        return []

    def _closed_loop_stop(self, t, state, burn, force, torque, h_wheels):
        """A slew's spin-down flown on the estimate: the torque about the combined CoM that takes out the estimated
        angular momentum I omega + h (the wheels', which track the plan's attitude, included) over the rest of the
        burn (the open-loop slew, planned on the estimated inertia, stops a little off), with the least side force;
        the planned wrench where the thrusters cannot."""
        p = self.config.planner.period_s
        remaining_s = burn.t_start_s + burn.duration_s - (t + p)
        if remaining_s < 0.5 * p:
            return force, torque
        _, issued_torque_com = self._in_flight(t)
        wrench = torque_wrench(self.body, self.config.planner, -(self.body.inertia_body_kg_m2 @ state.omega_body
                                                                 + h_wheels + p * issued_torque_com) / remaining_s)
        return (force, torque) if wrench is None else wrench

    def _in_flight(self, t):
        """(force [N], torque about the combined CoM [N m]), body axes, of the command issued at the previous estimate:
        it acts over the period from t, which the estimate at t does not see yet."""
        p = self.config.planner.period_s
        if self.issued is None or abs(self.issued[0] - (t - p)) > 0.5 * p:
            return np.zeros(3), np.zeros(3)
        _, force, torque = self.issued
        return force, torque - np.cross(self.body.com_body_m, force)

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
        issued_force, _ = self._in_flight(t)
        dv_hill = (self.push_end[round(burn.t_start_s / p)].v_hill - state.v_hill
                   - quat_to_matrix(state.q_hill_from_body) @ issued_force * (p / self.body.mass_kg))
        if not self.wheels_steer and burn is [b for b in self.plan.burns if b.purpose == 'push'][-1]:
            # Short of the goal's rest by ARRIVAL_MARGIN_N_S along the push: what it leaves across then lies in the
            # pure forces the thrusters give about the combined CoM at the attitude held (the trim's pulses).
            need = self.body.mass_kg * float(np.linalg.norm(dv_hill))
            dv_hill = dv_hill * max(0.0, 1.0 - ARRIVAL_MARGIN_N_S / need) if need > 0.0 else dv_hill
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

    def _track(self, state):
        """The wheels' torque [N m] (body axes; the body feels its opposite) that holds the estimated attitude on the
        reference (``_attitude_torque``), within the wheels' torque."""
        return np.clip(self._attitude_torque(state), -self.wheel_max_torque_n_m, self.wheel_max_torque_n_m)

    def _attitude_torque(self, state):
        """The torque [N m] (body axes) against the estimated attitude's error from the reference: the plan's model
        advanced to the estimate's stamp (``transport.attitude_at``), or the trim's wheel slew; PD on the attitude
        error (its rotation vector, body axes) and the rate error, scaled by the estimated inertia
        (TRACK_BANDWIDTH_RAD_S, TRACK_DAMPING)."""
        t_ref, q_ref, w_ref = self.reference
        if self.trim_slew is not None:
            t0, q0, axis, angle, rate = self.trim_slew
            turned = min(rate * (state.t - t0), angle)
            q_ref = quat_multiply(quat_from_rotation_vector(turned * axis), q0)
            w_ref = quat_rotate(quat_conjugate(q_ref), axis * rate) if turned < angle else np.zeros(3)
        elif state.t > t_ref:
            q_ref, w_ref = attitude_at(self.body, self.config.planner, q_ref, w_ref, t_ref, state.t, self.plan.burns)
            self.reference = (state.t, q_ref, w_ref)
        q_est = q_eci_from_body(state.t, self.n, state.q_hill_from_body)
        error = rotation_vector_from_quat(quat_multiply(quat_conjugate(q_ref), q_est))
        return self.body.inertia_body_kg_m2 @ (TRACK_BANDWIDTH_RAD_S ** 2 * error + 2.0 * TRACK_DAMPING
                                               * TRACK_BANDWIDTH_RAD_S * (state.omega_body - w_ref))

    def _set_reference(self, state):
        """The plan's model restarts from the estimate (a new plan, a slew solved again)."""
        self.reference = (state.t, q_eci_from_body(state.t, self.n, state.q_hill_from_body),
                          np.asarray(state.omega_body, dtype=float))

    def _detumble(self, t, omega, h_wheels):
        """The damping law until the estimated angular momentum (its rate averaged) is below half the condition's."""
        momentum = self.momentum
        bound = 0.5 * self.config.planner.max_angular_momentum_kg_m2_s
        if momentum < bound and t - self.t_start >= DETUMBLED_S:  # the mean over a whole window
            self.t_detumbled = t
            self.carried = np.zeros(3)
            return np.zeros(3), np.zeros(3), np.zeros(3), [(
                'OK', 'transport_detumbled', f'the combined body detumbled for the transport after '
                                             f'{t - self.t_start:.1f} s: {momentum:.3g} kg m^2/s (estimated)',
                {'angular_momentum_kg_m2_s': momentum, 'detumbling_time_s': t - self.t_start})]
        tau, u = damping_command(omega, h_wheels, self.gains, self.wheel_max_torque_n_m)
        return (*self._couple(tau, self.pulse_n_m_s), u, [])

    def _couple(self, tau, pulse_n_m_s):
        """(force, torque about the chaser's CoM) of a couple tau [N m] about the combined CoM fired in pulses: below
        the thrusters' minimum impulse bit a small couple is not fired at all, so its angular impulse is carried
        until it is worth pulse_n_m_s (``post_capture.pulse_modulated``); the least side force
        (``transport.torque_wrench``), halved where the thrusters cannot."""
        tau, self.carried = pulse_modulated(self.carried, tau, self.config.planner.period_s, pulse_n_m_s)
        if not np.any(tau):
            return np.zeros(3), np.zeros(3)
        for _ in range(DETUMBLE_HALVINGS):  # no pure couple about every axis: the least side force, within reach
            wrench = torque_wrench(self.body, self.config.planner, tau)
            if wrench is not None:
                return wrench
            tau = 0.5 * tau
        return np.zeros(3), np.zeros(3)

    def _plan(self, state, t_arrival):
        """The transport's plan from the estimated state to the goal arriving at t_arrival (``transport_planned``; a
        refusal ends the transport, the body held where it is)."""
        cfg = self.config
        first = state.t + 2.0 * cfg.planner.period_s  # the first period a command of this estimate can still reach
        start = TransportState(first, *state[1:])
        try:
            plan = self._plan_with_faster_slews(start, t_arrival)
        except TransportRefused as err:
            self.done = True
            return [('ERROR', 'transport_refused', f'no transport plan meets the conditions: {err.reason}',
                     {'reason': err.reason})]
        self.plan, self.plan_start = plan, start
        self._set_reference(state)
        # The plan's state at each push's end, by grid tick of its start: the closed-loop push's aim, and the first
        # push's the nominal coast the mid-course corrections keep to.
        self.push_end = {}
        for burn in plan.burns:
            if burn.purpose == 'push':
                end = burn.t_start_s + burn.duration_s
                self.push_end[round(burn.t_start_s / cfg.planner.period_s)] = propagate(
                    self.body, start, [b for b in plan.burns if b.t_start_s < end], end, cfg.planner)
        self.t_check = state.t + cfg.replan_interval_s
        c = plan.conditions
        message = (f'transport to {np.round(self.goal, 2).tolist()} m in {len(plan.burns)} burns, '
                   f'{plan.fuel_kg * 1e3:.1f} g, arrival at t = {plan.t_arrival_s:.1f} s; predicted '
                   f'{c["position_error_m"]:.3g} m, {c["momentum_error_n_s"]:.3g} N s, '
                   f'{c["angular_momentum_kg_m2_s"]:.3g} kg m^2/s')
        return [('OK', 'transport_planned', message,
                 {'t_arrival_s': plan.t_arrival_s, 'burns': len(plan.burns), 'fuel_kg': plan.fuel_kg,
                  'predicted_position_error_m': c['position_error_m'],
                  'predicted_momentum_error_n_s': c['momentum_error_n_s'],
                  'predicted_angular_momentum_kg_m2_s': c['angular_momentum_kg_m2_s']})]

    def _plan_with_faster_slews(self, start, t_arrival):
        """plan_transport, and where the slews at the configured rate leave too little time, again with the rate
        doubled (at most SLEW_RATE_DOUBLINGS times: paper_flyby_transport's first plan needs one doubling)."""
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
        """Between the first push and the next slew, the mid-course correction (``_correct``); after the arrival and
        the plan's last burn, the trim (``_trim``)."""
        self.t_check = state.t + self.config.replan_interval_s
        p = self.config.planner.period_s
        pushes = [b for b in self.plan.burns if b.purpose == 'push']
        remaining = [b for b in self.plan.burns if b.t_start_s + b.duration_s > state.t + 1.5 * p]
        if not remaining and state.t >= self.plan.t_arrival_s:
            events = self._trim(state)
            if self.trim_arrival is not None and state.t < self.trim_arrival < self.t_check:
                self.t_check = self.trim_arrival  # the transfer back's arrival velocity is taken out at once
            return events
        if state.t >= pushes[0].t_start_s + pushes[0].duration_s + p and remaining and remaining[0] is not pushes[-1]:
            return self._correct(state, pushes, remaining[0])
        return []

    def _correct(self, state, pushes, next_burn):
        """The mid-course correction, keeping the last push (it nulls the velocity at the arrival, closed loop): the
        estimate's deviation from the plan's coast after the first push (its state at the push's end coasted by CW,
        seed 000 eq 22) carried to the last push's middle; beyond replan_position_m there, the one impulse now that
        takes it out (Phi_rv dv = -miss), fired as a pulse when the allowed thrusters give it at the attitude the
        wheels hold and it ends before the next burn (else at a later check, or the trim after the arrival)."""
        p = self.config.planner.period_s
        t = state.t
        first, last = pushes[0], pushes[-1]
        nominal = self.push_end[round(first.t_start_s / p)]
        x_nominal = cw_transition_matrix(self.n, t - nominal.t) @ np.concatenate((nominal.r_hill, nominal.v_hill))
        phi = cw_transition_matrix(self.n, last.t_start_s + 0.5 * last.duration_s - t)
        miss = (phi @ (np.concatenate((state.r_hill, state.v_hill)) - x_nominal))[:3]
        if float(np.linalg.norm(miss)) <= self.config.replan_position_m:
            return []
        dv = -np.linalg.solve(phi[:3, 3:], miss)
        impulse = self.body.mass_kg * float(np.linalg.norm(dv))
        pulse = self._pulse(state, dv / float(np.linalg.norm(dv)), impulse)
        k0 = round((t + 2.0 * p) / p)
        if pulse is None or (k0 + pulse[2]) * p > next_burn.t_start_s - 1e-9:
            return []
        self.pulses = [(k0 * p, (k0 + pulse[2]) * p, pulse[0], pulse[1])]
        return [('OK', 'transport_correction', f'{float(np.linalg.norm(miss)):.3g} m off at the last push: a '
                                               f'correction of {impulse:.3g} N s', {'miss_m': float(np.linalg.norm(
                                                   miss)), 'impulse_n_s': impulse})]

    def _trim(self, state):
        """After the arrival (module doc): a dump, a transfer back, a pulse or the wheel slew before it; nothing
        while a wheel slew or a pulse is on."""
        cfg = self.config
        planner = cfg.planner
        p = planner.period_s
        t = state.t
        if self.trim_slew is None:  # the plan's model at rest from now on: the trim's slews start there
            _, q_ref, _ = self.reference
            self.trim_slew = (t, q_ref, np.array([1.0, 0.0, 0.0]), 0.0, 0.0)
        t0, _, _, angle, rate = self.trim_slew
        coast = p if self.wheels_steer else NAV_COAST_S
        if (angle > 0.0 and t < t0 + angle / rate + WHEEL_SPINUP_S - 1e-9) or any(t < t_b + coast for _, t_b, _, _
                                                                                    in self.pulses):
            return []
        body = self.body
        h = self.momentum
        # Dumped until a dump no longer halves it: the estimate's floor (the gyro's bias and noise on the inertia);
        # again once it has grown beyond twice that (a trim pulse's couple, taken by the wheels, adds to it) where a
        # pulse can still follow the dump (its couples push a little: 0.03-0.04 N s on campaign runs 13 and 25).
        t_end = self.t_arrival + cfg.settle_s
        grown = h > 2.0 * self.dumped if self.dumped is not None else False
        # Beyond the first condition it is dumped again whatever follows (a thruster trim's slews left 1.9 kg m^2/s
        # on paper_flyby_transport with 57 s to go).
        coasting = self._coasting(t, t_end)  # a dump ends the CoM's coast: there, beyond the first condition only
        if h > DUMP_FRACTION * planner.max_angular_momentum_kg_m2_s and (
                not coasting or h > planner.max_angular_momentum_kg_m2_s) and (
                self.dumped is None or h < 0.5 * self.dumped or (grown and t + DUMP_S + self.trim_stop_s < t_end)
                or (h > planner.max_angular_momentum_kg_m2_s and t + DUMP_S < t_end)):
            self.dumping, self.dumped = t + DUMP_S, h
            self.carried = np.zeros(3)
            return [('OK', 'transport_dump', f'angular momentum {h:.3g} kg m^2/s dumped by couples over {DUMP_S:g} s',
                     {'angular_momentum_kg_m2_s': h})]
        events = []
        if self.trim_arrival is not None and t >= self.trim_arrival:
            self.trim_arrival = None  # the transfer back has arrived: from rest again
        if self.trim_arrival is not None and t > self.trim_arrival - 0.5 * TRIM_TIME_S:
            return events  # its last half coasts: a correction now would cost more than the miss it saves
        miss = float(np.linalg.norm(state.r_hill - self.goal))
        arrival = self.trim_arrival
        if arrival is None and miss > cfg.replan_position_m and t + TRIM_TIME_S + self.trim_stop_s < t_end \
                and not coasting:
            arrival = t + 2.0 * p + TRIM_TIME_S  # a new transfer back, if its pulse fires now
        if arrival is not None:  # the velocity wanted now (hill): the transfer back's (seed 000 eq 28-29) ...
            dv1, _ = terminal_impulses(state.r_hill, state.v_hill, self.goal, np.zeros(3), arrival - t, self.n)
            aim = state.v_hill + dv1
        elif coasting:  # ... or on the CoM's coast the nearest with no along-track drift (module doc) ...
            aim = state.v_hill + self._drift_free_change(state)
        else:  # ... or the one that coasts to rest at the judgement (off the goal the body is not at rest in hill)
            aim, phi = self._to_rest(state.r_hill - self.goal, t_end - t)
        error = state.v_hill - aim
        impulse = body.mass_kg * float(np.linalg.norm(error))
        # What the judgement sees of it if nothing fires (CW, seed 000 eq 22): the pulse's worth.
        judged = impulse if arrival is not None or coasting else body.mass_kg * float(np.linalg.norm(
            phi[3:, 3:] @ error))
        bit = body.layout.min_impulse_bit_n_s
        if judged <= max(cfg.replan_momentum_n_s, 0.5 * bit, COM_WAIT_FACTOR * self.com_worth if coasting else 0.0):
            if coasting and not self.wheels_steer and not self.coast_slew:
                events += self._plan_coast_slew(state, t_end)
            return events
        # A pulse that costs more than AIM_COST_RATIO times what it saves waits: CW's velocity that coasts to rest at
        # the judgement is out of all proportion a quarter orbit before it (out of plane, 1 / cos(n T)).
        if impulse > AIM_COST_RATIO * judged:
            return events
        d_hill = -error / float(np.linalg.norm(error))
        if not self.wheels_steer:
            # Short along the push axis by PULSE_LEAVE_FRACTION of the error (at least PULSE_LEAVE_N_S): what is
            # left is then within the next pulse's reach (an overshoot would need thrust against the push axis);
            # no thrust against it (an overshoot's error: the rest, where it is most of it).
            b_hill = quat_to_matrix(state.q_hill_from_body) @ self.b_body
            wanted = -error * body.mass_kg - max(PULSE_LEAVE_FRACTION * impulse, PULSE_LEAVE_N_S) * b_hill
            within = wanted - min(0.0, float(wanted @ b_hill)) * b_hill
            impulse = float(np.linalg.norm(within))
            pulse = (self._pulse(state, within / impulse, impulse, cfg.replan_momentum_n_s)
                     if impulse > float(np.linalg.norm(wanted - within)) else None)
        else:
            pulse = self._pulse(state, d_hill, impulse, cfg.replan_momentum_n_s)
        if pulse is not None:
            k0 = round((t + 2.0 * p) / p)
            force, torque, k_len = pulse
            self.pulses = [(k0 * p, (k0 + k_len) * p, force, torque)]
            if arrival is not None and self.trim_arrival is None:
                self.trim_arrival = arrival
                return events + [('OK', 'transport_trim', f'{miss:.3g} m from the goal: a transfer back of '
                                                          f'{impulse:.3g} N s arriving at t = {arrival:.1f} s',
                                  {'position_error_m': miss, 'impulse_n_s': impulse, 't_arrival_s': arrival})]
            return events + [('OK', 'transport_pulse', f'a pulse of {impulse:.3g} N s against the velocity error',
                              {'impulse_n_s': impulse})]
        if not self.wheels_steer:  # out of reach at this attitude: the thrusters' slews would leave far more
            return events
        # The push axis turned onto the velocity error by the wheels, from the reference where it is now, aimed at
        # the error the body will have then (CW, seed 000 eq 22; hill turns meanwhile).
        q_est = q_eci_from_body(t, self.n, state.q_hill_from_body)
        b_eci = quat_rotate(q_est, self.b_body)
        turn = float(np.arccos(np.clip(b_eci @ (hill_axes_in_eci(t, self.n) @ d_hill), -1.0, 1.0)))
        t_fire = t + turn / self.trim_slew_rate + WHEEL_SPINUP_S
        _, v = np.split(cw_transition_matrix(self.n, t_fire - t) @ np.concatenate((state.r_hill, error)), 2)
        d_eci = -hill_axes_in_eci(t_fire, self.n) @ (v / float(np.linalg.norm(v)))
        q_goal = quat_multiply(quat_shortest_arc(b_eci, d_eci), q_est)
        q_now = self._reference_now(t)
        arc = rotation_vector_from_quat(quat_multiply(q_goal, quat_conjugate(q_now)))
        angle = float(np.linalg.norm(arc))
        if angle > 0.0:
            self.trim_slew = (t, q_now, arc / angle, angle, self.trim_slew_rate)
            self.t_check = t + angle / self.trim_slew_rate + WHEEL_SPINUP_S  # the pulse as soon as it is turned
        return events

    def _plan_coast_slew(self, state, t_end):
        """Where the wheels do not steer, on the CoM's coast once its drift is out: a wheel slew that turns the push
        axis onto the velocity change the pulses after the coast need (CW, seed 000 eq 22: at rest at the judgement).
        The body is at rest inertially, so the axis turns in hill at n, and a drift-free relative orbit's velocity
        turns with it: a change against the axis at the coast's end would stay out of reach (paper_flyby_transport
        seeds 2-3 ended at 0.8 and 0.5 N s so). At COAST_SLEW_MOMENTUM_FRACTION of the wheels' momentum (about 1e-3
        rad/s on 3000 kg m^2), done COAST_SLEW_MARGIN_S before the coast's end, or none; the wheels then hold the
        attitude. Nothing fires: the CoM's coast goes on, and sees the CoM better for the turn."""
        self.coast_slew = True
        t_f = t_end - COM_FINAL_RAD / self.n
        x_f = cw_transition_matrix(self.n, t_f - state.t) @ np.concatenate((state.r_hill - self.goal, state.v_hill))
        wanted = self._to_rest(x_f[:3], t_end - t_f)[0] - x_f[3:]
        if self.wheel_max_momentum_n_m_s is None or not np.any(wanted):
            self.coast_slew = False
            return []
        q_est = q_eci_from_body(state.t, self.n, state.q_hill_from_body)
        d_eci = hill_axes_in_eci(t_f, self.n) @ (wanted / float(np.linalg.norm(wanted)))
        q_goal = quat_multiply(quat_shortest_arc(quat_rotate(q_est, self.b_body), d_eci), q_est)
        arc = rotation_vector_from_quat(quat_multiply(q_goal, quat_conjugate(q_est)))
        angle = float(np.linalg.norm(arc))
        if angle == 0.0:
            return []
        axis = arc / angle
        axis_body = quat_rotate(quat_conjugate(q_est), axis)
        rate = COAST_SLEW_MOMENTUM_FRACTION * self.wheel_max_momentum_n_m_s / float(
            axis_body @ self.body.inertia_body_kg_m2 @ axis_body)
        if state.t + angle / rate + COAST_SLEW_MARGIN_S > t_f:
            self.coast_slew = False
            return [('WARN', 'transport_coast_slew', f'no time on the coast for the wheels to turn the push axis '
                                                     f'{np.degrees(angle):.0f} deg at {rate:.2g} rad/s',
                     {'angle_deg': float(np.degrees(angle)), 'rate_rad_s': rate})]
        self.trim_slew = (state.t, q_est, axis, angle, rate)
        impulse = self.body.mass_kg * float(np.linalg.norm(wanted))
        return [('OK', 'transport_coast_slew', f'the wheels turn the push axis {np.degrees(angle):.0f} deg at '
                                               f'{rate:.2g} rad/s onto the {impulse:.3g} N s the pulses after the '
                                               f'coast need', {'angle_deg': float(np.degrees(angle)),
                                                               'rate_rad_s': rate, 'impulse_n_s': impulse})]

    def _to_rest(self, offset_hill_m, dt_s):
        """(the velocity [m/s, hill] at offset_hill_m from the goal whose CW coast is at rest dt_s later, seed 000
        eq 22; the transition matrix over dt_s)."""
        phi = cw_transition_matrix(self.n, dt_s)
        return -np.linalg.solve(phi[3:, 3:], phi[3:, :3] @ offset_hill_m), phi

    def _drift_free_change(self, state):
        """The least velocity change [m/s, hill] after which the body's CW coast (seed 000 eq 22) is back at its
        along-track position an orbit later: no drift away from the goal's V-bar. Where the wheels do not steer, one
        the thrusters give at the attitude held: along the push axis where that takes the drift out (a pulse across it
        needs couples several times its size), else across it."""
        row = cw_transition_matrix(self.n, 2.0 * np.pi / self.n)[0]  # along-track after an orbit
        offset = state.r_hill - self.goal
        drift = float(row @ np.concatenate((offset, state.v_hill))) - offset[0]
        g = row[3:]
        if self.wheels_steer:
            return -drift / float(g @ g) * g
        b_hill = quat_to_matrix(state.q_hill_from_body) @ self.b_body
        along = float(g @ b_hill)
        across = g - along * b_hill
        if abs(along) > DRIFT_ALONG_FRACTION * float(np.linalg.norm(g)) and (
                drift / along <= 0.0 or float(across @ across) == 0.0):
            return -drift / along * b_hill
        return -drift / float(across @ across) * across

    def _coasting(self, t, t_end):
        """True on the coast that sharpens the combined CoM (the estimator's ``transport_com_estimate``): the body
        turns in hill at n, so an error dc of the CoM is an error n x C dc of the estimated velocity. Where that is
        worth more than COM_SHARP_FRACTION of the third condition at the first trim, the trim aims until COM_FINAL_RAD
        of orbit before the judgement at no along-track drift rather than at rest at the judgement (from a radial
        offset of metres that arc ends beyond the second condition), takes out only a drift beyond COM_WAIT_FACTOR
        times that worth, starts no transfer back and dumps only beyond the first condition: a firing ends the coast.
        Its pulses come after the coast, also because further out CW amplifies them at the judgement (an along-track
        velocity by 4 cos(n T) - 3, up to 7 half an orbit before: a 0.01 N s bit is 0.07 N s there)."""
        if self.com_worth is None and self.com_sigma_m is not None:
            worth = self.body.mass_kg * self.n * float(np.linalg.norm(self.com_sigma_m))
            self.com_worth = worth if worth > COM_SHARP_FRACTION * self.config.planner.max_momentum_error_n_s else 0.0
        return bool(self.com_worth) and self.n * (t_end - t) > COM_FINAL_RAD

    def _reference_now(self, t):
        """The trim's reference attitude (q_eci_from_body) at t."""
        t0, q0, axis, angle, rate = self.trim_slew
        return quat_multiply(quat_from_rotation_vector(min(rate * (t - t0), angle) * axis), q0)

    def _pulse(self, state, d_hill, impulse, residual_n_s=0.0):
        """(force, torque about the chaser's CoM, periods) of a trim pulse of impulse [N s] along d_hill at the
        estimated attitude: a pure force along it where every thruster the allocation fires gets at least the minimum
        impulse bit; else, with the push axis within TRIM_POINTING_RAD of it, or close enough that the impulse along
        it leaves at most residual_n_s (a small error's direction is the navigation's noise: campaign run 99 turned
        the push axis after an error of 0.013 N s for 300 s, each turn more than TRIM_POINTING_RAD off the error it
        then saw, and never fired), the thrusters along the push axis fired alike (a pure force about an estimated
        CoM a few mm off their axis would ask the others for less than a bit),
        or below a bit each the one with the least lever arm, the impulse at least one bit (their small couple the
        wheels take); None where the push axis must be turned first."""
        body = self.body
        p = self.config.planner.period_s
        bit = body.layout.min_impulse_bit_n_s
        k_len = max(1, int(np.ceil(impulse / (self.config.planner.push_force_fraction * push_axis(body)[1] * p))))
        d_body = quat_to_matrix(state.q_hill_from_body).T @ d_hill
        force = impulse / (k_len * p) * d_body
        allocation = allocate_wrench(body.layout, force, np.cross(body.com_body_m, force))
        for _ in range(PULSE_LENGTHENINGS if not self.wheels_steer else 0):
            if not allocation.saturated:
                break  # else longer: a force across the push axis needs couples several times its size
            k_len, force = 2 * k_len, 0.5 * force
            allocation = allocate_wrench(body.layout, force, np.cross(body.com_body_m, force))
        fired = allocation.thrusts_n[allocation.thrusts_n > _FIRING_N]
        if not allocation.saturated and fired.size and (float(fired.min()) * p >= bit * (1.0 + 1e-6) or (
                not self.wheels_steer and self._within_bits(allocation.thrusts_n, force, k_len))):
            return force, np.cross(body.com_body_m, force), k_len
        off_rad = max(TRIM_POINTING_RAD, 2.0 * float(np.arcsin(min(1.0, 0.5 * residual_n_s / impulse))))
        if float(d_body @ self.b_body) < np.cos(off_rad):
            return None
        along = np.flatnonzero(body.layout.force_directions_body @ self.b_body > 1.0 - 1e-9)
        if impulse < along.size * bit:
            arms = [float(np.linalg.norm(np.cross(body.layout.positions_body_m[i] - body.com_body_m, self.b_body)))
                    for i in along]
            along = along[[int(np.argmin(arms))]]
            impulse = max(impulse, bit * (1.0 + 1e-6))
        thrust = impulse / (k_len * p * along.size) * body.layout.force_directions_body[along]
        return (np.sum(thrust, axis=0), np.sum(np.cross(body.layout.positions_body_m[along], thrust), axis=0),
                k_len)

    def _within_bits(self, thrusts_n, force, k_len):
        """A pure force about the estimated combined CoM whose thrusters below the minimum impulse bit (the small
        couples that balance the CoM's few mm off the push axis), which the plant does not fire (``actuators.fire``),
        leave at most PULSE_FORCE_TOLERANCE of the force and PULSE_TORQUE_FRACTION of the first condition's angular
        momentum."""
        body = self.body
        p = self.config.planner.period_s
        firing = fire(body.layout, thrusts_n, p)
        torque_com = firing.torque_body_n_m - np.cross(body.com_body_m, firing.force_body_n)
        return (float(np.linalg.norm(firing.force_body_n - force))
                <= PULSE_FORCE_TOLERANCE * float(np.linalg.norm(force))
                and float(np.linalg.norm(torque_com)) * k_len * p
                <= PULSE_TORQUE_FRACTION * self.config.planner.max_angular_momentum_kg_m2_s)

    def _dump(self, t, state, h_wheels):
        """The dump's command: couples against the estimated angular momentum I omega + h (the wheels hold the
        attitude meanwhile), in pulses of two minimum impulse bits at the mean lever arm, that take it out by the
        dump's end (over the time left, at least DUMP_TAIL_S: a couple of h / DUMP_S throughout would leave e^-1 of
        it, and the next dump, which must halve it, would then not come: 1.6 kg m^2/s left on paper_flyby_transport)."""
        p = self.config.planner.period_s
        if t + p >= self.dumping - 1e-9:
            self.dumping = None
            self.t_check = t + self.config.replan_interval_s
            return np.zeros(3), np.zeros(3)
        h = self.body.inertia_body_kg_m2 @ state.omega_body + h_wheels
        return self._couple(-h / max(self.dumping - t - p, DUMP_TAIL_S), 0.2 * self.pulse_n_m_s)

    def _complete(self, t, state, h_wheels):
        conditions = conditions_of(self.body, state, self.goal, h_wheels)
        miss, momentum, h = (conditions[k] for k in ('position_error_m', 'momentum_error_n_s',
                                                     'angular_momentum_kg_m2_s'))
        met = not missed_conditions(conditions, self.config.planner)
        return ('OK' if met else 'WARN', 'transport_complete',
                f'transport ended at t = {t:.1f} s: {miss:.3g} m from the goal, momentum {momentum:.3g} N s, angular '
                f'momentum {h:.3g} kg m^2/s (estimated{"" if met else ", a condition missed"})',
                {**conditions, 't_arrival_s': self.t_arrival, 'goal_hill_m': self.goal})

