"""The trim part of guidance in TRANSPORT (``control.TransportControl``'s methods on its state): after the arrival
and the plan's last burn, every ``replan_interval_s`` while nothing moves, a dump of the angular momentum, a CW
transfer back to the goal, or a pulse against the velocity error (where the wheels steer, after a wheel slew that
turns the push axis onto it); where the combined CoM's uncertainty matters, the coast that sharpens it first."""

import numpy as np

from flyby_msgs_py import events
from flyby_planner.transfer import terminal_impulses
from flyby_planner.transport.thrusters import push_axis
from flyby_sim.dynamics.actuators import allocate_wrench, fire
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

# The transfer back and the wheels' slews.
TRIM_TIME_S = 300.0  # a trim's transfer back arrives this long after its pulse [s]
TRIM_SLEW_RATE_RAD_S = 0.05  # a trim's wheel slew turns at most this fast [rad/s] ...
WHEEL_SPINUP_S = 10.0  # ... and reaches its rate within this long at the wheels' torque [s]
TRIM_POINTING_RAD = 0.05  # a pulse along the push axis fires with it this close to the velocity error [rad]
AIM_COST_RATIO = 2.0  # a pulse waits while it costs more than this many times what it takes off the judged error
# Pulses where the wheels do not steer: only pure forces at the attitude held.
PULSE_LEAVE_FRACTION = 0.3  # a pulse stops short along the push axis by this much of the error: no overshoot ...
PULSE_LEAVE_N_S = 0.004  # ... or by this, at least [N s] ...
PULSE_FORCE_TOLERANCE = 0.3  # ... its thrusters below the bit, not fired, may leave this much of its force ...
PULSE_TORQUE_FRACTION = 5.0  # ... and this much of the first condition's angular momentum (dumped after) ...
PULSE_LENGTHENINGS = 6  # ... made longer (its force halved) at most this often where the thrusters saturate
NAV_COAST_S = 100.0  # ... each this long after the last firing: the navigation's velocity converges [s]
# The coast that sharpens the combined CoM (``_coasting``).
COM_SHARP_FRACTION = 0.25  # where the CoM's uncertainty is worth more than this of the third condition in velocity ...
COM_WAIT_FACTOR = 3.0  # ... the trim takes out only a drift beyond this many times that worth ...
DRIFT_ALONG_FRACTION = 0.2  # ... along the push axis where it is at least this much along the drift's gradient ...
COM_FINAL_RAD = 1.2  # ... until this much of an orbit before the judgement [rad] ...
COAST_SLEW_MOMENTUM_FRACTION = 0.6  # ... meanwhile a wheel slew at this much of the wheels' momentum ...
COAST_SLEW_MARGIN_S = 300.0  # ... done this long before the coast's end [s]
# The dumps.
DUMP_FRACTION = 0.3  # an angular momentum worth this much of the first condition is dumped after the arrival
DUMP_S = 10.0  # a dump's couple takes the angular momentum out over this long [s] ...
DUMP_TAIL_S = 1.0  # ... aimed at its end, but never over less than this [s]
_FIRING_N = 1e-6  # an allocation's thrust above this fires (the LP leaves ~1e-12 N on the others) [N]


class TransportTrim:
    """The trim rules of ``TransportControl`` (the state they read and set is its)."""

    def _trim(self, state):
        """After the arrival (module doc): a dump, a transfer back, a pulse or the wheel slew before it; nothing
        while a wheel slew or a pulse is on."""
        cfg = self.config
        p = cfg.planner.period_s
        t = state.t
        if self.trim_slew is None:  # the plan's model at rest from now on: the trim's slews start there
            _, q_ref, _ = self.reference
            self.trim_slew = (t, q_ref, np.array([1.0, 0.0, 0.0]), 0.0, 0.0)
        t0, _, _, angle, rate = self.trim_slew
        coast = p if self.wheels_steer else NAV_COAST_S
        if (angle > 0.0 and t < t0 + angle / rate + WHEEL_SPINUP_S - 1e-9) or any(t < t_b + coast for _, t_b, _, _
                                                                                    in self.pulses):
            return []
        t_end = self.t_arrival + cfg.settle_s
        coasting = self._coasting(t, t_end)  # a dump ends the CoM's coast: there, beyond the first condition only
        if self._dump_due(t, t_end, coasting):
            h = self.momentum
            self.dumping, self.dumped = t + DUMP_S, h
            self.carried = np.zeros(3)
            return [('OK', events.TRANSPORT_DUMP, f'angular momentum {h:.3g} kg m^2/s dumped by couples over '
                                                  f'{DUMP_S:g} s', {'angular_momentum_kg_m2_s': h})]
        if self.trim_arrival is not None and t >= self.trim_arrival:
            self.trim_arrival = None  # the transfer back has arrived: from rest again
        if self.trim_arrival is not None and t > self.trim_arrival - 0.5 * TRIM_TIME_S:
            return []  # its last half coasts: a correction now would cost more than the miss it saves
        miss = float(np.linalg.norm(state.r_hill - self.goal))
        arrival = self.trim_arrival
        if arrival is None and miss > cfg.replan_position_m and t + TRIM_TIME_S + self.trim_stop_s < t_end \
                and not coasting:
            arrival = t + 2.0 * p + TRIM_TIME_S  # a new transfer back, if its pulse fires now
        error, impulse, judged = self._trim_error(state, arrival, coasting, t_end)
        bit = self.body.layout.min_impulse_bit_n_s
        if judged <= max(cfg.replan_momentum_n_s, 0.5 * bit, COM_WAIT_FACTOR * self.com_worth if coasting else 0.0):
            if coasting and not self.wheels_steer and not self.coast_slew:
                return self._plan_coast_slew(state, t_end)
            return []
        # A pulse that costs more than AIM_COST_RATIO times what it saves waits: CW's velocity that coasts to rest at
        # the judgement is out of all proportion a quarter orbit before it (out of plane, 1 / cos(n T)).
        if impulse > AIM_COST_RATIO * judged:
            return []
        return self._trim_fire(state, error, impulse, arrival, miss)

    def _dump_due(self, t, t_end, coasting):
        """True where the estimated angular momentum beyond DUMP_FRACTION of the first condition is dumped now: until
        a dump no longer halves it (the estimate's floor: the gyro's bias and noise on the inertia); again once it has
        grown beyond twice that (a trim pulse's couple, taken by the wheels, adds to it) where a pulse can still follow
        the dump (its couples push a little); beyond the first condition whatever follows; on the CoM's coast
        (``_coasting``) only beyond the first condition."""
        planner = self.config.planner
        h = self.momentum
        grown = h > 2.0 * self.dumped if self.dumped is not None else False
        return h > DUMP_FRACTION * planner.max_angular_momentum_kg_m2_s and (
            not coasting or h > planner.max_angular_momentum_kg_m2_s) and (
            self.dumped is None or h < 0.5 * self.dumped or (grown and t + DUMP_S + self.trim_stop_s < t_end)
            or (h > planner.max_angular_momentum_kg_m2_s and t + DUMP_S < t_end))

    def _trim_error(self, state, arrival, coasting, t_end):
        """(velocity error [m/s, hill], its impulse [N s], what the judgement sees of it if nothing fires [N s]) from
        the velocity wanted now: a transfer back's arriving at arrival (seed 000 eq 28-29), on the CoM's coast the
        nearest with no along-track drift, else the one that coasts to rest at the judgement (off the goal the body is
        not at rest in hill; CW, seed 000 eq 22)."""
        t = state.t
        if arrival is not None:
            dv1, _ = terminal_impulses(state.r_hill, state.v_hill, self.goal, np.zeros(3), arrival - t, self.n)
            aim = state.v_hill + dv1
        elif coasting:
            aim = state.v_hill + self._drift_free_change(state)
        else:
            aim, phi = self._to_rest(state.r_hill - self.goal, t_end - t)
        error = state.v_hill - aim
        impulse = self.body.mass_kg * float(np.linalg.norm(error))
        judged = impulse if arrival is not None or coasting else self.body.mass_kg * float(np.linalg.norm(
            phi[3:, 3:] @ error))
        return error, impulse, judged

    def _trim_fire(self, state, error, impulse, arrival, miss):
        """The trim's pulse against the velocity error (``transport_trim`` where it starts a transfer back arriving at
        arrival, else ``transport_pulse``), or where the wheels steer and no pulse gives it at this attitude, the
        wheel slew that turns the push axis onto it (``_turn_push_axis``)."""
        cfg = self.config
        p = cfg.planner.period_s
        t = state.t
        d_hill = -error / float(np.linalg.norm(error))
        if not self.wheels_steer:
            # Short along the push axis by PULSE_LEAVE_FRACTION of the error (at least PULSE_LEAVE_N_S): what is
            # left is then within the next pulse's reach (an overshoot would need thrust against the push axis);
            # no thrust against it (an overshoot's error: the rest, where it is most of it).
            b_hill = quat_to_matrix(state.q_hill_from_body) @ self.b_body
            wanted = -error * self.body.mass_kg - max(PULSE_LEAVE_FRACTION * impulse, PULSE_LEAVE_N_S) * b_hill
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
                return [('OK', events.TRANSPORT_TRIM, f'{miss:.3g} m from the goal: a transfer back of '
                                                      f'{impulse:.3g} N s arriving at t = {arrival:.1f} s',
                         {'position_error_m': miss, 'impulse_n_s': impulse, 't_arrival_s': arrival})]
            return [('OK', events.TRANSPORT_PULSE, f'a pulse of {impulse:.3g} N s against the velocity error',
                     {'impulse_n_s': impulse})]
        if self.wheels_steer:  # else out of reach at this attitude: the thrusters' slews would leave far more
            self._turn_push_axis(state, error, d_hill)
        return []

    def _turn_push_axis(self, state, error, d_hill):
        """The wheel slew that turns the push axis onto the velocity error, from the reference where it is now, aimed
        at the error the body will have then (CW, seed 000 eq 22; hill turns meanwhile); the next check as soon as it
        is turned."""
        t = state.t
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
            self.t_check = t + angle / self.trim_slew_rate + WHEEL_SPINUP_S

    def _plan_coast_slew(self, state, t_end):
        """Where the wheels do not steer, on the CoM's coast once its drift is out: a wheel slew that turns the push
        axis onto the velocity change the pulses after the coast need (CW, seed 000 eq 22: at rest at the judgement).
        The body is at rest inertially, so the axis turns in hill at n, and a drift-free relative orbit's velocity
        turns with it: a change against the axis at the coast's end would stay out of reach. At
        COAST_SLEW_MOMENTUM_FRACTION of the wheels' momentum (about 1e-3 rad/s on 3000 kg m^2), done COAST_SLEW_MARGIN_S
        before the coast's end, or none; the wheels then hold the attitude. Nothing fires: the CoM's coast goes on,
        and sees the CoM better for the turn."""
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
            return [('WARN', events.TRANSPORT_COAST_SLEW, f'no time on the coast for the wheels to turn the push axis '
                                                         f'{np.degrees(angle):.0f} deg at {rate:.2g} rad/s',
                     {'angle_deg': float(np.degrees(angle)), 'rate_rad_s': rate})]
        self.trim_slew = (state.t, q_est, axis, angle, rate)
        impulse = self.body.mass_kg * float(np.linalg.norm(wanted))
        return [('OK', events.TRANSPORT_COAST_SLEW, f'the wheels turn the push axis {np.degrees(angle):.0f} deg at '
                                                   f'{rate:.2g} rad/s onto the {impulse:.3g} N s the pulses after '
                                                   f'the coast need', {'angle_deg': float(np.degrees(angle)),
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
        it leaves at most residual_n_s (a small error's direction is the navigation's noise: a push axis turned after
        it each time would never fire), the thrusters along the push axis fired alike (a pure force about an estimated
        CoM a few mm off their axis would ask the others for less than a bit), or below a bit each the one with the
        least lever arm, the impulse at least one bit (their small couple the wheels take); None where the push axis
        must be turned first."""
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
        it, and the next dump, which must halve it, would then not come)."""
        p = self.config.planner.period_s
        if t + p >= self.dumping - 1e-9:
            self.dumping = None
            self.t_check = t + self.config.replan_interval_s
            return np.zeros(3), np.zeros(3)
        h = self.body.inertia_body_kg_m2 @ state.omega_body + h_wheels
        return self._couple(-h / max(self.dumping - t - p, DUMP_TAIL_S), 0.2 * self.pulse_n_m_s)
