"""The terminal part of guidance in TRANSPORT (``control.TransportControl``'s methods on its state): after the
transfer's last burn the wheels hold the body's attitude fixed in inertial space, and at every check the terminal
program (``flyby_planner.transport.terminal``) chooses, from the estimate, the impulses that bring the body to rest
at the goal's rest point with the wheels' momentum within their share, or nearest it; its firings are flown at their
times and the program solved again after the last. Where its best end lies far beyond the margins at the attitude
held (the side force it needs lies outside the direction-limited thrusters' cone) a new transfer is flown (off the
rest point, or on a body the wheels do not steer) or the push axis turned onto it; nearer, a body the wheels steer
turns, one they do not waits for a check whose program helps. The judgement: the three conditions and the wheels'
share, from the estimate with its 3-sigma, held for ``hold_s``."""

import math

import numpy as np

from flyby_guidance.transport.attitude import WHEEL_ROOM, WHEEL_SPINUP_S
from flyby_msgs_py import events
from flyby_planner.transfer import terminal_impulses
from flyby_planner.transport import terminal
from flyby_planner.transport.thrusters import torque_wrench
from flyby_sim.dynamics.orbital import cw_transition_matrix, hill_axes_in_eci, q_eci_from_body
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    quat_rotate,
    quat_shortest_arc,
    rotation_vector_from_quat,
)

NAV_SIGMAS = 3.0  # the estimate's margin: the conditions are judged, and the program aims, this many sigma inside
AIM_FRACTION = 0.5  # the program aims within this share of each bound, the margin for the estimate's error ...
POSITION_AIM_FRACTION = 0.25  # ... and of the position bound (a rest point drifts off it no more than this) ...
WHEEL_AIM_FRACTION = 0.8  # ... and of the wheels' share (their momentum is measured, not estimated)
TERMINAL_ROUNDS = 3  # the settle bound: this many rounds of navigation and firing after the arrival
MIN_TURN_RAD = math.radians(1.0)  # a push axis this near CW's first impulse is not turned: the impulse is fired
FALLBACK_EXCESS = 10.0  # the program's best end this many margins beyond them: a turn or a new transfer first
KEPT_EXCESS = 0.5  # a plan flown is solved again once its firings to come end this many margins further beyond
#                    them than it said: the estimate's noise near a margin's edge does not move its firings later
TURN_PROBE_N_M = 0.01  # the couple at which a turn's side force per couple is found (within any thrusters' reach)


def navigation_coast_s(mass_kg, bound_n_s, position_sigma_m, position_rate_hz, com_period_s):
    """The coast [s] over which the navigation learns the velocity within AIM_FRACTION of the third condition at
    NAV_SIGMAS (a constant velocity from positions of 1-sigma s at f Hz over T: sigma_v = s sqrt(12 / (f T^3))), at
    least one period of the combined CoM's estimate."""
    sigma_v = AIM_FRACTION * bound_n_s / (NAV_SIGMAS * mass_kg)
    return max((12.0 * position_sigma_m**2 / (position_rate_hz * sigma_v**2)) ** (1.0 / 3.0), com_period_s)


def settle_bound_s(coast_s, hold_s, replan_interval_s):
    """The time after the arrival the conditions need, stated before the flight [s]: TERMINAL_ROUNDS rounds, each the
    navigation's coast (``navigation_coast_s``), then the shortest horizon's firings and a check; and the hold."""
    return TERMINAL_ROUNDS * (coast_s + terminal.HORIZONS_S[0] + replan_interval_s) + hold_s


class TransportTerminal:
    """The terminal rules of ``TransportControl`` (the state they read and set is its)."""

    def _enter_terminal(self, state):
        """From the plan's last burn on, the wheels hold the attitude the body has (inertially)."""
        self.hold = q_eci_from_body(state.t, self.n, state.q_hill_from_body)
        self.turning = None
        self.t_terminal = state.t
        self.t_check = state.t if self.t_check is None else max(self.t_check, state.t)  # a scheduled check is kept

    def _velocity_sigma_mps(self, t):
        """The navigation's velocity 1-sigma at t [m/s]: the last estimate's (with the combined CoM's error's,
        ``TransportNavigation.velocity_sigma_mps``) and the command error of every terminal firing since (a known
        input to the navigation); None before the first, and before the first after a burn or a thrusters' turn
        (``_burned_since``)."""
        if self.nav_sigma is None or self._burned_since(self.nav_sigma[0], t):
            return None
        t_sigma, _, sigma_v = self.nav_sigma
        fired_n_s = sum(float(np.linalg.norm(force)) * (b - a) for a, b, force, _ in self.pulses
                        if t_sigma - 1e-9 <= a < t)
        return math.hypot(sigma_v, self.command_error * fired_n_s / self.body.mass_kg)

    def _burned_since(self, t_from, t_to):
        """True where a burn of the plan, or a turn by the thrusters' couples, fired between t_from and t_to [s]: the
        navigation's sigma from before it says nothing of after it (the accelerometer's noise over the burn, the side
        forces of the couples; transport_envelope draw 17's estimate was 15-47 of that sigma off after a transfer
        flown again and after a turn)."""
        p = self.config.planner.period_s
        if self.plan is not None and any(b.t_start_s < t_to and b.t_start_s + b.duration_s + p > t_from
                                         for b in self.plan.burns):
            return True
        if self.turning is None or self.wheels_steer:
            return False
        return self.turning[0] < t_to and self._turn_end_s() > t_from

    def _terminal(self, state, h_wheels):
        """At a check with nothing firing: the terminal program from the estimate (module doc); its firings
        scheduled, or, far beyond the margins at the attitude held, a new transfer or the push axis turned."""
        cfg = self.config
        self.t_check = state.t + cfg.replan_interval_s
        sigma_v = self._velocity_sigma_mps(state.t)
        if sigma_v is None:
            return []  # the navigation's first estimate in TRANSPORT is still to come
        problem = self._terminal_problem(state, h_wheels, self._momentum_margin(sigma_v))
        horizon_max_s = self.deadline - cfg.hold_s - problem.t0
        horizons = [h for h in terminal.HORIZONS_S if h <= horizon_max_s + 1e-9]
        if not horizons:
            return []  # no time left for a firing to settle before the judgement
        solution = terminal.solve(problem, horizons)
        planned = [] if solution is None else [k for k in range(len(solution.slot_times_s))
                                                if np.any(solution.impulses_n_s[k])]
        excess = math.inf if solution is None else sum(solution.excess)
        if excess > FALLBACK_EXCESS or (not planned and excess > 0.0 and self.wheels_steer):
            # Far beyond the margins at the attitude held, or beyond them on a body the wheels turn and no firing
            # brings it nearer: off the rest point beyond the margin, or on a body the wheels do not steer (its
            # thrusters' turn is a slew whose side force the planner's transfer takes into account), a new transfer;
            # else the push axis turned. Nearer, a body the wheels do not steer waits: its residual and the cone
            # of its pure forces turn in hill at different rates, so a later check finds a firing that helps.
            if not self.wheels_steer or float(np.max(np.abs(problem.x0[:3]))) > problem.rho_position_m:
                again = self._transfer_again(state)
                if again is not None:
                    return again
            return self._turn(state) or self._nearest_firing(state, problem)
        if not planned:
            return []
        # The whole plan flown, then a new solve after its last firing: a plan of a few bits is a sequence (a start
        # and a stop, a pair that nets less than a bit), and solved again after each part it would be another one.
        self._fire(self._pulses_of_plan(solution), solution)
        impulse = float(solution.impulses_n_s.sum())
        predicted_n_s = self.body.mass_kg * float(np.linalg.norm(solution.predicted[3:]))
        predicted_m = float(np.linalg.norm(solution.predicted[:3]))
        beyond = f', {sum(solution.excess):.2g} margins beyond' if sum(solution.excess) > 0.0 else ''
        return [('OK', events.TRANSPORT_TERMINAL,
                 f'terminal firings of {impulse:.3g} N s in {len(planned)} slots over {solution.horizon_s:.0f} s: '
                 f'predicted {predicted_m:.3g} m, {predicted_n_s:.3g} N s at its end{beyond}',
                 {'impulse_n_s': impulse, 'horizon_s': solution.horizon_s,
                  'predicted_momentum_n_s': predicted_n_s, 'predicted_position_m': predicted_m})]

    def _fire(self, pulses, kept=None):
        """Fly the terminal firings (``_pulses_of``'s periods). A program's plan (kept, its TerminalSolution) is
        checked at the checks while its later firings wait (``_monitor``); other firings, the next solve a replan
        interval after the last."""
        self.pulses, self.kept = pulses, kept
        self.t_fired = pulses[-1][1]
        if kept is None:
            self.t_check = self.t_fired + self.config.replan_interval_s

    def _momentum_margin(self, sigma_v):
        """rho_p [N s]: the program aims within AIM_FRACTION of the third condition's bound, or within what the
        navigation knows (NAV_SIGMAS m sigma_v) where that is more: a firing finer than the estimate's error would
        chase its noise."""
        return max(AIM_FRACTION * self.config.planner.max_momentum_error_n_s,
                   NAV_SIGMAS * self.body.mass_kg * sigma_v)

    def _monitor(self, state, h_wheels):
        """A check while a plan's later firings wait (none firing within two periods): the plan kept where, from the
        estimate, its firings to come still end within KEPT_EXCESS margins of where it said
        (``terminal.kept_excess``); else those dropped and the program solved again now. A plan of an hour flown
        blind had met its end beyond the margins with no time left to take that out; solved again at every check, a
        plan moves its later firings later."""
        self.t_check = state.t + self.config.replan_interval_s
        sigma_v = self._velocity_sigma_mps(state.t)
        if sigma_v is None:
            return []
        kept = self.kept
        problem = self._terminal_problem(state, h_wheels, self._momentum_margin(sigma_v))
        later = kept.slot_times_s >= problem.t0 - 1e-9
        t_end = kept.slot_times_s[0] + kept.horizon_s
        if terminal.kept_excess(problem, kept.slot_times_s[later], kept.impulses_n_s[later],
                                t_end) <= kept.excess[1] + KEPT_EXCESS:
            return []
        self.pulses = [pulse for pulse in self.pulses if pulse[0] < state.t]
        self.kept = None
        return self._terminal(state, h_wheels)

    def monitoring(self, t):
        """True where a kept plan's later firings wait and none fires within the next two control periods."""
        p = self.config.planner.period_s
        return self.kept is not None and not any(a <= t + 2.0 * p and b > t for a, b, _, _ in self.pulses)

    def _pulses_of_plan(self, solution):
        """``_pulses_of`` of each slot of a TerminalSolution that fires, each slot's from its time or from the end of
        the slot's before where that is later (the first slot, at a check, may lie within a firing of the grid's next
        time, and a period has one command: the later slot's firings were lost)."""
        pulses = []
        for t_slot, impulses in zip(solution.slot_times_s, solution.impulses_n_s, strict=True):
            if np.any(impulses):
                pulses += self._pulses_of(impulses, max(t_slot, pulses[-1][1] if pulses else -math.inf))
        return pulses

    def _pulses_of(self, impulses_n_s, t_first):
        """[(t_start, t_end, force_body_n, torque_body_n_m)] of the control periods from t_first [s] that fire the
        thrusters' impulses [N s] one after another (``terminal.firing_periods``), the torque about the chaser's CoM."""
        p = self.config.planner.period_s
        layout = self.body.layout
        thrusts = terminal.firing_periods(impulses_n_s, layout.max_thrust_n, layout.min_impulse_bit_n_s, p)
        k0 = round(t_first / p)
        wrench = layout.wrench_matrix
        return [((k0 + i) * p, (k0 + i + 1) * p, wrench[:3] @ row, wrench[3:] @ row) for i, row in enumerate(thrusts)]

    def _terminal_problem(self, state, h_wheels, rho_p):
        """The TerminalProblem of the estimate: the deviation from the rest point coasted to the first slot (two
        periods on: the first a command of this estimate reaches)."""
        cfg, body = self.config, self.body
        t0 = state.t + 2.0 * cfg.planner.period_s
        x0 = cw_transition_matrix(self.n, t0 - state.t) @ np.concatenate((state.r_hill - self.rest, state.v_hill))
        layout = body.layout
        couples = np.cross(layout.positions_body_m - body.com_body_m, layout.force_directions_body)
        position_sigma_m = 0.0 if self.nav_sigma is None else self.nav_sigma[1]
        rho_r = max(POSITION_AIM_FRACTION * cfg.planner.max_position_error_m, NAV_SIGMAS * position_sigma_m)
        return terminal.TerminalProblem(
            body.mass_kg, layout.force_directions_body, couples, layout.max_thrust_n, layout.min_impulse_bit_n_s,
            self.n, t0, x0, q_eci_from_body(state.t, self.n, state.q_hill_from_body),
            self._held_momentum(state, h_wheels),
            rho_r, rho_p * terminal.BALL_SLAB_FACTOR, cfg.hold_s,
            cfg.wheel_momentum_share * self.wheel_capacity_n_m_s * WHEEL_AIM_FRACTION,
            (1.0 - WHEEL_ROOM) * self.wheel_capacity_n_m_s,
            terminal.couple_limit(body.inertia_body_kg_m2, self.wheel_max_torque_n_m), NAV_SIGMAS * self.command_error,
            self.coast_s + cfg.hold_s)

    def _transfer_impulse(self, state):
        """The first impulse [m/s, hill] of CW's transfer to the rest point over the longest horizon left (seed 000
        eq 28-29)."""
        horizon_s = min(terminal.HORIZONS_S[-1], max(self.deadline - self.config.hold_s - state.t,
                                                     terminal.HORIZONS_S[0]))
        dv_hill, _ = terminal_impulses(state.r_hill - self.rest, state.v_hill, np.zeros(3), np.zeros(3), horizon_s,
                                       self.n)
        return dv_hill

    def _nearest_firing(self, state, problem):
        """Where the program's best end lies far beyond the margins and no turn is made (the push axis lies along
        CW's first impulse already, or the turn the thrusters' side force affords would end after the judgement):
        that impulse as near as the thrusters give it at the attitude held (``terminal.impulses_for``), fired now;
        none where they give none, or where it would end the shortest horizon no nearer the margins than no firing
        (``terminal.kept_excess``: near the judgement, a transfer's first impulse to a rest point the body is already
        near is momentum it cannot take out again)."""
        impulses, _ = terminal.impulses_for(self._transfer_impulse(state), problem)
        pulses = self._pulses_of(impulses, problem.t0)
        horizon_s = terminal.HORIZONS_S[0]
        t_end = problem.t0 + horizon_s
        if not pulses or terminal.kept_excess(problem, [problem.t0], [impulses], t_end) >= terminal.kept_excess(
                problem, [], [], t_end):
            return []
        self._fire(pulses)
        impulse = float(impulses.sum())
        predicted = terminal.firings_end(problem, [problem.t0], [impulses], t_end)
        momentum_n_s = self.body.mass_kg * float(np.linalg.norm(predicted[3:]))
        position_m = float(np.linalg.norm(predicted[:3]))
        return [('OK', events.TRANSPORT_TERMINAL, f'the terminal program far beyond its margins, the push axis along '
                                                  f'the transfer: firings of {impulse:.3g} N s toward the rest point: '
                                                  f'predicted {position_m:.3g} m, {momentum_n_s:.3g} N s '
                                                  f'{horizon_s:.0f} s on',
                 {'impulse_n_s': impulse, 'horizon_s': horizon_s, 'predicted_momentum_n_s': momentum_n_s,
                  'predicted_position_m': position_m})]

    def _turn(self, state):
        """The wheels turn the push axis onto the first impulse of CW's transfer to the rest point over the longest
        horizon (seed 000 eq 28-29), at the rate their share of momentum gives the body (the thrusters' couples at the
        slews' rate, where the wheels do not steer it, or slower: ``_affordable_turn_rate``), from the attitude held;
        no turn (none) where it lies within MIN_TURN_RAD of it already or where the affordable turn would not end
        before the judgement's latest time."""
        t = state.t
        dv_hill = self._transfer_impulse(state)
        if not np.any(dv_hill):
            return []
        q_now = self._held(t)
        d_eci = hill_axes_in_eci(t, self.n) @ (dv_hill / float(np.linalg.norm(dv_hill)))
        q_goal = quat_multiply(quat_shortest_arc(quat_rotate(q_now, self.b_body), d_eci), q_now)
        arc = rotation_vector_from_quat(quat_multiply(q_goal, quat_conjugate(q_now)))
        angle = float(np.linalg.norm(arc))
        if angle <= MIN_TURN_RAD:
            return []
        rate = self.turn_rate_rad_s
        if not self.wheels_steer:
            rate = min(rate, self._affordable_turn_rate(q_now, arc / angle, self.body.mass_kg * float(
                np.linalg.norm(dv_hill))))
            if rate <= 0.0:
                return []
        t_check = t + angle / rate + WHEEL_SPINUP_S
        if not self.wheels_steer and t_check > self.deadline - self.config.hold_s:
            return []
        self.turning = (t, q_now, arc / angle, angle, rate)
        self.t_check = t_check
        by = 'wheels' if self.wheels_steer else 'thrusters\' couples'
        return [('OK', events.TRANSPORT_TURN, f'no terminal firing reaches rest at the attitude held: the {by} turn '
                                              f'the push axis {math.degrees(angle):.1f} deg at {rate:.3g} rad/s',
                 {'angle_rad': angle, 'rate_rad_s': rate})]

    def _affordable_turn_rate(self, q_eci_from_body, axis_eci, corrected_n_s):
        """The fastest rate [rad/s] of a turn by the thrusters' couples about axis_eci whose side force, spinning the
        body up and down (the least side force per couple, ``torque_wrench``), adds at most STAGE_FRACTION of the
        momentum the turn is for: about a CoM metres off the tug a couple comes with a force, and a turn of a heavy
        body at the slews' rate (0.01 rad/s of 1000 kg m^2: some 100 N s of side force) to correct centinewton
        seconds leaves more than it corrects. 0 where the thrusters give no couple about that axis."""
        axis_body = quat_rotate(quat_conjugate(q_eci_from_body), axis_eci)
        momentum = self.body.inertia_body_kg_m2 @ axis_body  # per rad/s of the turn's rate [N m s]
        size = float(np.linalg.norm(momentum))
        wrench = torque_wrench(self.body, self.config.planner, TURN_PROBE_N_M * momentum / size)  # the LP is linear
        if wrench is None:
            return 0.0
        # Its spin-up and its spin-down: a side force per couple times the angular impulse, twice.
        side_n_s_per_rad_s = 2.0 * size * float(np.linalg.norm(wrench[0])) / TURN_PROBE_N_M
        return terminal.STAGE_FRACTION * corrected_n_s / side_n_s_per_rad_s if side_n_s_per_rad_s > 0.0 else math.inf

    def _turn_end_s(self):
        """The end [s] of the turn under way or last made: its angle at its rate and the wheels' spin-down after it
        (its check); None without one."""
        if self.turning is None:
            return None
        t0, _, _, angle, rate = self.turning
        return t0 + angle / rate + WHEEL_SPINUP_S

    def _turn_under_way(self, t):
        """True from a turn's start until its check (``_turn_end_s``)."""
        return self.turning is not None and t < self._turn_end_s() - 1e-9

    def _held(self, t):
        """The attitude the wheels hold at t (q_eci_from_body): the hold, or where it is along a turn."""
        if self.turning is None:
            return self.hold
        t0, q0, axis, angle, rate = self.turning
        return quat_multiply(quat_from_rotation_vector(min(rate * (t - t0), angle) * axis), q0)

    def _judge(self, state, h_wheels):
        """The three conditions and the wheels' share from the estimate, its 3-sigma inside each bound (the rate its
        mean over the detumbling's window): True where all hold."""
        cfg = self.config.planner
        sigma_v = self._velocity_sigma_mps(state.t)
        if sigma_v is None:
            return False
        position_sigma = self.nav_sigma[1]
        miss = float(np.linalg.norm(state.r_hill - self.goal)) + NAV_SIGMAS * position_sigma
        momentum = self.body.mass_kg * (float(np.linalg.norm(state.v_hill)) + NAV_SIGMAS * sigma_v)
        return (self.body_momentum < cfg.max_angular_momentum_kg_m2_s and miss < cfg.max_position_error_m
                and momentum < cfg.max_momentum_error_n_s
                and self._wheel_share(h_wheels) <= self.config.wheel_momentum_share)

    def _wheel_share(self, h_wheels):
        """The wheels' momentum as a share of their capacity, the largest per body axis."""
        return float(np.max(np.abs(h_wheels))) / self.wheel_capacity_n_m_s

    def pulses_pending(self, t):
        """True while a terminal firing is under way or still to come."""
        return bool(self.pulses) and t < self.pulses[-1][1] + self.config.planner.period_s
