"""The push part of guidance in TRANSPORT (``control.TransportControl``'s methods on its state): the plan from the
estimate to the goal, its pushes and slews' spin-downs flown closed loop on the estimates, each slew solved again
from the estimate before it starts, and the mid-course correction between the first push and the next slew."""

import dataclasses
import math

import numpy as np

from flyby_guidance.transport.attitude import TRACK_BANDWIDTH_RAD_S
from flyby_msgs_py import events
from flyby_planner.transfer import terminal_impulses
from flyby_planner.transport import terminal
from flyby_planner.transport.model import TOO_LITTLE_TIME, TransportRefused, TransportState, propagate
from flyby_planner.transport.plan import plan_transport
from flyby_planner.transport.slew import resolve_slew
from flyby_planner.transport.thrusters import nearest_wrench, torque_wrench
from flyby_sim.dynamics.actuators import allocate_wrench
from flyby_sim.dynamics.orbital import cw_transition_matrix, hill_axes_in_eci, q_eci_from_body
from flyby_sim.dynamics.rotation import (
    quat_from_rotation_vector,
    quat_multiply,
    quat_shortest_arc,
    quat_to_matrix,
    rotation_vector_from_quat,
)

PUSH_FORCE_MARGIN = 1.3  # a closed-loop push asks at most this much more force than planned: a bad estimate stays mild
ARRIVAL_SIGMAS = 3.0  # the arrival push stops short of rest by this many sigma of its expected error along the push
CORRECTION_FRACTION = 0.25  # a miss at the last push beyond this share of the second condition is corrected
REPLAN_FRACTION = 0.5  # a transfer again after the arrival takes this share of the first's time, and an arrival
#                        the transfer time leaves too little time for is tried this share of it later
SLEW_RATE_DOUBLINGS = 3  # a plan short of time for the configured slew rate doubles it at most this often
RESOLVE_ROUNDS = 3  # a slew solved again aims at the push through its own side forces: this many fixed-point rounds
STEER_MAX_RAD = 0.05  # a push steers its axis toward the force wanted by at most this much at a time [rad] ...
STEER_SETTLE_S = 4.0 / TRACK_BANDWIDTH_RAD_S  # ... and not over its last this long: the attitude settles first [s]
_PUSH_NODES = np.polynomial.legendre.leggauss(8)  # the push's response integrated by Gauss-Legendre on its rest


def push_response(state, issued_force_body_n, mass_kg, n, t_from, duration_s):
    """(G (6, 3) [s^2/kg; s/kg], x_coast (6,)): the state [r_hill; v_hill] at the end of a constant body force F
    held over [t_from, t_from + duration_s] by a body at rest inertially (turning in hill at the orbit rate) is
    x_coast + G F, by CW's transition (seed 000 eq 22): G = int Phi[:, v](t_end - s) C_hill_from_body(s) ds / m, and
    x_coast the state's coast to the end (the command already issued acting over [state.t, t_from] at the estimated
    attitude). A push of minutes turns a third of a radian in hill and CW's coupling moves its velocity by as much as
    the thrust does: the velocity's difference divided by the time is no push's force."""
    c_hill_from_body = quat_to_matrix(state.q_hill_from_body)
    c_eci_from_body = hill_axes_in_eci(state.t, n) @ c_hill_from_body
    lead_s = t_from - state.t
    issued_hill = c_hill_from_body @ np.asarray(issued_force_body_n, dtype=float) / mass_kg
    x_from = cw_transition_matrix(n, lead_s) @ np.concatenate((state.r_hill, state.v_hill)) + np.concatenate(
        (0.5 * lead_s ** 2 * issued_hill, lead_s * issued_hill))
    t_end = t_from + duration_s
    nodes, weights = _PUSH_NODES
    response = np.zeros((6, 3))
    for x, w in zip(nodes, weights, strict=True):
        s = t_from + 0.5 * duration_s * (x + 1.0)
        response += (0.5 * duration_s * w) * cw_transition_matrix(n, t_end - s)[:, 3:] @ hill_axes_in_eci(s, n).T \
            @ c_eci_from_body
    return response / mass_kg, cw_transition_matrix(n, duration_s) @ x_from


class TransportPush:
    """The plan and push rules of ``TransportControl`` (the state they read and set is its)."""

    def _plan(self, state, t_arrival):
        """The transport's plan from the estimated state to the goal arriving at t_arrival, or later where that
        leaves too little time for its slews and pushes (``_plan_arriving``; ``transport_planned``, WARN where
        later); a refusal ends the transport, the body held where it is."""
        cfg = self.config
        first = state.t + 2.0 * cfg.planner.period_s  # the first period a command of this estimate can still reach
        start = TransportState(first, *state[1:])
        try:
            plan, asked = self._plan_arriving(start, t_arrival)
        except TransportRefused as err:
            self.done = True
            return [('ERROR', events.TRANSPORT_REFUSED, f'no transport plan meets the conditions: {err.reason}',
                     {'reason': err.reason})]
        self._fly_plan(plan, start, state)
        self.t_arrival = plan.t_arrival_s
        c = plan.conditions
        message = (f'transport to {np.round(self.goal, 2).tolist()} m in {len(plan.burns)} burns, '
                   f'{plan.fuel_kg * 1e3:.1f} g, arrival at t = {plan.t_arrival_s:.1f} s; predicted '
                   f'{c["position_error_m"]:.3g} m, {c["momentum_error_n_s"]:.3g} N s, '
                   f'{c["angular_momentum_kg_m2_s"]:.3g} kg m^2/s; the conditions within {self.settle_bound:.0f} s '
                   f'after the arrival')
        if asked is not None:
            message += f' ({plan.t_arrival_s - t_arrival:.0f} s later than asked: {asked})'
        return [('OK' if asked is None else 'WARN', events.TRANSPORT_PLANNED, message,
                 {'t_arrival_s': plan.t_arrival_s, 'burns': len(plan.burns), 'fuel_kg': plan.fuel_kg,
                  'predicted_position_error_m': c['position_error_m'],
                  'predicted_momentum_error_n_s': c['momentum_error_n_s'],
                  'predicted_angular_momentum_kg_m2_s': c['angular_momentum_kg_m2_s'],
                  'settle_bound_s': self.settle_bound})]

    def _plan_arriving(self, start, t_arrival):
        """(the plan arriving at t_arrival, None); where the transfer time leaves too little time for its slews and
        pushes (a long detumbling, a slow push), the first of the later arrivals (``_arrivals``) that gives them
        time: (that plan, why the arrival asked was refused). The run's duration,
        not the transfer time, bounds what is refused (TransportRefused, the asked arrival's reason)."""
        self._check_reachable(t_arrival)
        asked = None
        for t_try in self._arrivals(t_arrival):
            try:
                return self._plan_with_faster_slews(start, t_try), asked and asked.reason
            except TransportRefused as err:
                if not err.reason.startswith(TOO_LITTLE_TIME):
                    raise
                asked = asked or err
        raise asked

    def _arrivals(self, t_arrival):
        """The arrivals a plan is tried for: the one asked, then each REPLAN_FRACTION of the transfer time later
        whose settle bound fits the run, and last the latest that fits (a plan a few seconds short of time is not
        refused for want of a whole step)."""
        t_latest = self.deadline - self.settle_bound
        t_try = t_arrival
        while t_try < t_latest - 1e-9:
            yield t_try
            t_try += REPLAN_FRACTION * self.config.transfer_time_s
        yield t_latest

    def _fly_plan(self, plan, start, state):
        """Fly a plan made from the TransportState start (the estimate state's, two periods on)."""
        cfg = self.config
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

    def _transfer_again(self, state, t_arrival=None, miss_m=None):
        """A new transfer by the planner, whose slews turn the push axis for each push, arriving at t_arrival (the
        plan's own, a mid-course miss out of the thrusters' reach at the attitude held), or where the terminal program
        finds no horizon and the body is off its rest point by more than its position margin (an arrival far off, a
        drift while the push axis turned) REPLAN_FRACTION of the transfer time later if the settle bound still fits
        before the judgement's latest time (``transport_correction``); else None."""
        cfg = self.config
        mid_course = t_arrival is not None
        if not mid_course:
            t_arrival = state.t + REPLAN_FRACTION * cfg.transfer_time_s
            miss_m = float(np.linalg.norm(state.r_hill - self.rest))
        if t_arrival + self.settle_bound > self.deadline:
            return None
        start = TransportState(state.t + 2.0 * cfg.planner.period_s, *state[1:])
        try:
            plan = self._plan_with_faster_slews(start, t_arrival)
        except TransportRefused:
            return None
        self._fly_plan(plan, start, state)
        self.t_terminal = self.hold = self.turning = self.kept = None
        self.pulses = []
        where = ('at the last push and out of the thrusters\' reach at the attitude held' if mid_course else
                 'off the goal\'s rest point and out of the terminal program\'s reach')
        return [('OK', events.TRANSPORT_CORRECTION, f'{miss_m:.3g} m {where}: a new transfer in {len(plan.burns)} '
                                                   f'burns arriving at t = {t_arrival:.1f} s',
                 {'miss_m': miss_m, 'impulse_n_s': plan.fuel_kg * self.body.layout.exhaust_velocity_mps})]

    def _check_reachable(self, t_arrival):
        """TransportRefused where the conditions cannot be met: the thrusters' minimum impulse bit above the third
        condition, a goal whose rest point (``terminal.rest_point``) lies beyond a quarter of the second, or too
        little of the run left after the arrival for the settle bound the planner states."""
        cfg = self.config.planner
        bit = self.body.layout.min_impulse_bit_n_s
        if bit > cfg.max_momentum_error_n_s:
            raise TransportRefused(f'the thrusters\' minimum impulse bit {bit:.4g} N s exceeds the momentum bound '
                                   f'{cfg.max_momentum_error_n_s:.4g} N s')
        off_m = float(np.linalg.norm(self.rest - self.goal))
        if off_m > CORRECTION_FRACTION * cfg.max_position_error_m:
            raise TransportRefused(f'the goal {np.round(self.goal, 2).tolist()} m is no rest point: the nearest on the '
                                   f'reference orbit is {off_m:.3g} m away (a body at rest there drifts)')
        if t_arrival + self.settle_bound > self.deadline:
            raise TransportRefused(f'{TOO_LITTLE_TIME}: the conditions need {self.settle_bound:.0f} s after the '
                                   f'arrival at t = {t_arrival:.0f} s, and they are judged at the latest at t = '
                                   f'{self.deadline:.0f} s (the run ends at {self.config.duration_s:.0f} s)')

    def _plan_with_faster_slews(self, start, t_arrival):
        """plan_transport, and where the slews at the configured rate leave too little time, again with the rate
        doubled (at most SLEW_RATE_DOUBLINGS times)."""
        planner = self.config.planner
        for _ in range(SLEW_RATE_DOUBLINGS):
            try:
                return plan_transport(self.body, start, self.goal, t_arrival, planner)
            except TransportRefused as err:
                if not err.reason.startswith(TOO_LITTLE_TIME):
                    raise
                planner = dataclasses.replace(planner, slew_rate_rad_s=2.0 * planner.slew_rate_rad_s)
        return plan_transport(self.body, start, self.goal, t_arrival, planner)

    def _resolve(self, state, start, stop):
        """The slew about to start solved again from the estimate (``slew.resolve_slew``), to aim the push axis
        where the push after it must go from the trajectory the body is really on: the first impulse of eq 28-29 at
        that push, or at the last push the velocity it must null, the last push lengthened to it (``_sized_push``): the
        estimate propagated to the push's middle through the slew's own burns (``_through_slew``), whose side forces
        (a couple about a CoM metres off the tug comes with a force, and the body turns between the spin-up and the
        spin-down) the push, within the direction-limited thrusters' cone, could not take out across its axis."""
        burns = list(self.plan.burns)
        i = next(k for k, b in enumerate(burns) if b is stop)
        push = burns[i + 1]
        last = push is [b for b in burns if b.purpose == 'push'][-1]
        slew, aimed = (start, stop), None
        try:
            for _ in range(RESOLVE_ROUNDS):
                t_aim = push.t_start_s + 0.5 * push.duration_s
                r, v = self._through_slew(state, slew, t_aim)
                if last:
                    u_hill = -v
                    push = self._sized_push(push, self.body.mass_kg * float(np.linalg.norm(v)))
                else:
                    u_hill, _ = terminal_impulses(r, v, self.goal, np.zeros(3), self.plan.t_arrival_s - t_aim, self.n)
                slew = resolve_slew(self.body, self.config.planner, state, start, stop, u_hill,
                                    push.t_start_s + 0.5 * push.duration_s, self.plan.t_arrival_s)
                aimed = (*slew, push)
        except TransportRefused as err:
            if aimed is None:
                self.resolved.add(start.t_start_s)
                return [('WARN', events.TRANSPORT_SLEW_KEPT, f'the slew at {start.t_start_s:.1f} s flown as planned: '
                                                            f'{err.reason}', {'reason': err.reason})]
        burns[i - 1: i + 2] = aimed
        self.plan = self.plan._replace(burns=tuple(burns))
        if last:
            self.plan = self.plan._replace(t_arrival_s=aimed[2].t_start_s + aimed[2].duration_s)
        self.resolved.add(aimed[0].t_start_s)
        self._set_reference(state)
        return []

    def _sized_push(self, push, impulse_n_s):
        """The last push lengthened from its start over the whole control periods that give impulse_n_s [N s] at its
        planned force or the planner's share of the largest pure force (``push_force_fraction``), whichever is more,
        where the planned push gives less: the closed-loop push asks at most PUSH_FORCE_MARGIN of the planned force,
        and the velocity at the arrival is what the estimate and the slews made it, not what the plan had (its end,
        the arrival, moves by the periods added). Never shortened: a push of minutes that ends earlier stops the body
        short of the goal by the distance it would have covered (a 300 s push of 2000 kg ended 200 m off)."""
        planned_n_s = float(np.linalg.norm(push.force_body_n)) * push.duration_s
        if impulse_n_s <= planned_n_s:
            return push
        p = self.config.planner.period_s
        force_n = max(float(np.linalg.norm(push.force_body_n)),
                      self.config.planner.push_force_fraction * self.push_force_max_n)
        periods = max(1, math.ceil(impulse_n_s / force_n / p - 1e-9))
        force = impulse_n_s / (periods * p) * self.b_body
        return push._replace(duration_s=periods * p, force_body_n=force,
                             torque_body_n_m=np.cross(self.body.com_body_m, force))

    def _through_slew(self, state, slew, t_aim):
        """(r_hill, v_hill) at t_aim of the estimate propagated by the planner's model through the slew's burns."""
        end = propagate(self.body, state, slew, t_aim, self.config.planner)
        return end.r_hill, end.v_hill

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

    def _closed_loop_push(self, t, state, burn, force, torque, h_wheels, hold_com=None):
        """A push flown on the estimate (module doc): a constant body force over the rest of the burn, by CW's
        response over it (``push_response``), that puts the body where the plan has it at the last push (a push
        before the last, ``_aimed_force``) or brings it to the goal's rest (the last, short by its expected error);
        its axis steered toward that force until its last STEER_SETTLE_S (``_steer``); with no torque about the
        combined CoM but the one that takes out the angular momentum the wheels gained by the push's end where they
        hold the body, or else the thrusters' hold of the attitude (hold_com); where the thrusters cannot give that
        wrench (a direction out of their cone of pure forces, a couple beyond them beside the push), the nearest
        wrench they give, the torque first."""
        p = self.config.planner.period_s
        t_from = t + p
        remaining_s = burn.t_start_s + burn.duration_s - t_from
        hold_com = np.zeros(3) if hold_com is None else np.asarray(hold_com, dtype=float)
        if remaining_s < 0.5 * p:
            return force, torque + hold_com
        issued_force, _ = self._in_flight(t)
        response, x_coast = push_response(state, issued_force, self.body.mass_kg, self.n, t_from, remaining_s)
        pushes = [b for b in self.plan.burns if b.purpose == 'push']
        if burn is pushes[-1]:
            # To rest, short by its expected error along the push: what it leaves is then taken out along the push
            # axis, within the direction-limited thrusters' reach at the attitude held (``terminal``).
            dv_hill = self.push_end[round(burn.t_start_s / p)].v_hill - x_coast[3:]
            need = float(np.linalg.norm(dv_hill))
            short = ARRIVAL_SIGMAS * self._arrival_sigma_mps(burn)
            dv_hill = dv_hill * max(0.0, 1.0 - short / need) if need > 0.0 else dv_hill
            force_body = np.linalg.solve(response[3:], dv_hill)
        else:
            force_body = self._aimed_force(burn, pushes[-1], response, x_coast)
        if remaining_s > STEER_SETTLE_S:
            self._steer(state, force, force_body)
        limit = PUSH_FORCE_MARGIN * float(np.linalg.norm(force))
        if float(np.linalg.norm(force_body)) > limit:
            force_body = force_body * (limit / float(np.linalg.norm(force_body)))
        # The body at rest on the plan between slews: where the wheels hold it, the push's thrusters take out the
        # angular momentum the wheels gained (the thrusters' misalignment and the CoM's error make a torque), by the
        # push's end.
        torque_com = hold_com
        if self.wheels_steer or self._push_stopping(t, burn):
            torque_com = -(self.body.inertia_body_kg_m2 @ state.omega_body + h_wheels) / remaining_s
        torque_body = torque_com + np.cross(self.body.com_body_m, force_body)  # about the chaser's CoM
        if allocate_wrench(self.body.layout, force_body, torque_body).saturated:
            return nearest_wrench(self.body, self.config.planner, force_body, torque_com)
        return force_body, torque_body

    def _push_stopping(self, t, burn):
        """True where the command of the estimate at t falls in the push's last STEER_SETTLE_S on a body the wheels do
        not steer: its thrusters then take the total angular momentum I omega + h, the body's and the wheels', to
        nil by the push's end, the wheels idle (the body still at the end, the wheels' momentum dumped). The
        thrusters' hold (a PD against the misalignment's torque, metres from the CoM) left the body turning at the
        push's end (1 kg m^2/s on a 210 kg pair), which the wheels, holding the attitude after it, could not take
        up (transport_envelope run 5)."""
        remaining_s = burn.t_start_s + burn.duration_s - (t + self.config.planner.period_s)
        return not self.wheels_steer and remaining_s <= STEER_SETTLE_S

    def _steer(self, state, planned_force_body, force_body):
        """Thrust-vector steering: the attitude the push is held at, the estimate's turned so that the planned pure
        force's direction goes toward the force wanted (by at most STEER_MAX_RAD). About a CoM metres off the tug the
        thrusters' pure forces lie in a narrow cone about it: a force wanted across it is the body's to turn to,
        not the thrusters' to give (their nearest wrench gives up the force, not the torque)."""
        if not np.any(force_body):
            return
        delta = rotation_vector_from_quat(quat_shortest_arc(planned_force_body, force_body))
        angle = float(np.linalg.norm(delta))
        if angle > STEER_MAX_RAD:
            delta = delta * (STEER_MAX_RAD / angle)
        self.reference = (state.t, quat_multiply(q_eci_from_body(state.t, self.n, state.q_hill_from_body),
                                                 quat_from_rotation_vector(delta)), np.zeros(3))

    def _aimed_force(self, burn, last, response, x_coast):
        """The constant body force over the rest of a push before the last that puts the body, coasting from the
        push's end, where the plan has it at the last push's middle (its state at the push's end coasted by CW):
        the transfer's aim, not the push's end velocity (a push of minutes flown to a velocity still misses by the
        position its force's profile made: 287 m on 2000 kg; the mid-course correction measures the same miss)."""
        t_end = burn.t_start_s + burn.duration_s
        phi_r = cw_transition_matrix(self.n, last.t_start_s + 0.5 * last.duration_s - t_end)[:3]
        return np.linalg.solve(phi_r @ response, self._aim(burn, last) - phi_r @ x_coast)

    def _aim(self, push, last):
        """The plan's position [m, hill] at the last push's middle: its state at the end of push coasted there by CW
        (seed 000 eq 22); what a push before the last aims at and the mid-course correction measures a miss from."""
        nominal = self.push_end[round(push.t_start_s / self.config.planner.period_s)]
        return (cw_transition_matrix(self.n, last.t_start_s + 0.5 * last.duration_s - nominal.t)
                @ np.concatenate((nominal.r_hill, nominal.v_hill)))[:3]

    def _arrival_sigma_mps(self, burn):
        """The expected error [m/s] of the velocity at the end of a closed-loop push, its delta-v measured by the
        accelerometer: the accelerometer's noise over the push's samples and the star tracker's pointing of the push,
        with a minimum impulse bit."""
        cfg = self.config
        p = cfg.planner.period_s
        dv_mps = float(np.linalg.norm(burn.force_body_n)) * burn.duration_s / self.body.mass_kg
        noise = cfg.accel_noise_sigma_mps2 * p * np.sqrt(burn.duration_s / p)
        pointing = np.radians(cfg.star_tracker_sigma_deg) * dv_mps
        return float(np.hypot(noise, pointing)) + self.body.layout.min_impulse_bit_n_s / self.body.mass_kg

    def _slews(self):
        """(start, stop) burn pairs of the plan: the body turns between them."""
        starts = [b for b in self.plan.burns if b.purpose == 'slew_start']
        stops = [b for b in self.plan.burns if b.purpose == 'slew_stop']
        return list(zip(starts, stops, strict=True))

    def _correct(self, state, pushes, next_burn, h_wheels):
        """The mid-course correction, keeping the last push (it nulls the velocity at the arrival, closed loop): the
        estimate's deviation from the plan's coast after the first push (its state at the push's end coasted by CW,
        seed 000 eq 22) carried to the last push's middle; beyond CORRECTION_FRACTION of the second condition there,
        the one impulse now that takes it out (Phi_rv dv = -miss), as near as the thrusters give it at the attitude
        held (``terminal.impulses_for``: the part the direction limit leaves out waits for a later check), fired one
        thruster a period where it ends before the next burn; where what the thrusters reach takes out less than a
        miss worth correcting (the direction limit), a new transfer to the same arrival, its slews turning the push
        axis (``_transfer_again``; each check firing a little, each with its error, moved nothing); none on a body
        the wheels do not hold at the time (``_wheels_hold``)."""
        first, last = pushes[0], pushes[-1]
        phi = cw_transition_matrix(self.n, last.t_start_s + 0.5 * last.duration_s - state.t)
        miss = (phi @ np.concatenate((state.r_hill, state.v_hill)))[:3] - self._aim(first, last)
        miss_m = float(np.linalg.norm(miss))
        if miss_m <= CORRECTION_FRACTION * self.config.planner.max_position_error_m or not (
                self.wheels_steer or self._wheels_hold(state, h_wheels)):
            return []  # within reach, or not at an attitude the wheels hold (the thrusters' hold would undo it)
        problem = self._terminal_problem(state, h_wheels, 0.0)
        impulses, dv_given = terminal.impulses_for(-np.linalg.solve(phi[:3, 3:], miss), problem)
        left_m = float(np.linalg.norm(miss + phi[:3, 3:] @ dv_given))
        pulses = self._pulses_of(impulses, problem.t0)
        if miss_m - left_m < CORRECTION_FRACTION * self.config.planner.max_position_error_m:
            return self._transfer_again(state, self.t_arrival, miss_m) or []
        if not pulses or pulses[-1][1] > next_burn.t_start_s - 1e-9:
            return []
        self.pulses = pulses
        impulse = float(impulses.sum())
        return [('OK', events.TRANSPORT_CORRECTION, f'{miss_m:.3g} m off at the last push: a correction of '
                                                   f'{impulse:.3g} N s leaves {left_m:.3g} m',
                 {'miss_m': miss_m, 'impulse_n_s': impulse})]
