"""The attitude part of guidance in TRANSPORT (``control.TransportControl``'s methods on its state): the detumbling
by the capture's damping law before the plan, the wheels' hold and their tracking of the plan's attitude, and the
couples the thrusters fire in pulses about the combined CoM."""

import numpy as np

from flyby_guidance.damping import damping_command, pulse_modulated
from flyby_msgs_py import events
from flyby_planner.transport.model import attitude_at
from flyby_planner.transport.thrusters import torque_wrench
from flyby_sim.dynamics.orbital import q_eci_from_body
from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, quat_rotate, rotation_vector_from_quat

DETUMBLED_S = 5.0  # the detumbling ends once the momentum bound held this long: a whole window of the rate's mean [s]
DETUMBLE_HALVINGS = 8  # a couple beyond the thrusters is halved at most this often: no pure couple about every axis
TRACK_BANDWIDTH_RAD_S = 0.2  # the wheels' attitude tracking: natural frequency [rad/s], well below the control rate
TRACK_DAMPING = 0.7  # ... and damping ratio: no overshoot of the slews' coasts
WHEEL_ROOM = 0.1  # the share of the wheels' capacity a damped body leaves free to hold it
WHEEL_SPINUP_S = 10.0  # the wheels steer a body they spin up to the slews' rate within this long; a turn of the
#                        terminal's is planned this much longer than its angle at its rate [s]


class TransportAttitude:
    """The attitude rules of ``TransportControl`` (the state they read and set is its)."""

    def _hold(self, omega):
        """The wheels against the rate (the damping law's wheel gain), within their torque."""
        return np.clip(self.gains.wheel_gain_n_m_s * omega, -self.wheel_max_torque_n_m, self.wheel_max_torque_n_m)

    def _track(self, state, reference_error=None):
        """The wheels' torque [N m] (body axes; the body feels its opposite) that holds the estimated attitude on the
        reference (``_attitude_torque``), within the wheels' torque."""
        return np.clip(self._attitude_torque(state, reference_error), -self.wheel_max_torque_n_m,
                       self.wheel_max_torque_n_m)

    def _attitude_torque(self, state, reference_error=None):
        """The torque [N m] (body axes) against the estimated attitude's error from the reference
        (``_reference_error``, or the one given for this estimate): PD on the attitude error and the rate error,
        scaled by the estimated inertia (TRACK_BANDWIDTH_RAD_S, TRACK_DAMPING)."""
        error, w_ref = self._reference_error(state) if reference_error is None else reference_error
        return self.body.inertia_body_kg_m2 @ (TRACK_BANDWIDTH_RAD_S ** 2 * error + 2.0 * TRACK_DAMPING
                                               * TRACK_BANDWIDTH_RAD_S * (state.omega_body - w_ref))

    def _reference_error(self, state):
        """(the estimated attitude's error from the reference, its rotation vector [rad], body axes; the reference's
        rate [rad/s], body axes): the plan's model advanced to the estimate's stamp (``transport.model.attitude_at``),
        or after the last burn the attitude held and its turns (``terminal``)."""
        w_ref = np.zeros(3)
        if self.hold is not None:  # after the last burn: the attitude held, or its turn
            q_ref = self._held(state.t)
            if self.turning is not None:
                t0, _, axis, angle, rate = self.turning
                if rate * (state.t - t0) < angle:
                    w_ref = quat_rotate(quat_conjugate(q_ref), axis * rate)
        else:
            t_ref, q_ref, w_ref = self.reference
            if state.t > t_ref:
                q_ref, w_ref = attitude_at(self.body, self.config.planner, q_ref, w_ref, t_ref, state.t,
                                           self.plan.burns)
                self.reference = (state.t, q_ref, w_ref)
        q_est = q_eci_from_body(state.t, self.n, state.q_hill_from_body)
        return rotation_vector_from_quat(quat_multiply(quat_conjugate(q_ref), q_est)), w_ref

    def _wheels_hold(self, state, h_wheels, reference_error=None):
        """True where the wheels can hold the body on its reference at rest: its own angular momentum and theirs
        (``_held_momentum``), and the momentum taking out its attitude error (``_reference_error``, or the one given
        for this estimate) at the tracking's bandwidth asks, within 1 - WHEEL_ROOM of their capacity on every body
        axis (else the thrusters' couples do: a firing's couple the wheels cannot take turns the body, and the couple
        that turns it back undoes the firing's force)."""
        error, _ = self._reference_error(state) if reference_error is None else reference_error
        asked = np.abs(self._held_momentum(state, h_wheels)) + np.abs(
            self.body.inertia_body_kg_m2 @ (TRACK_BANDWIDTH_RAD_S * error))
        return float(np.max(asked)) <= (1.0 - WHEEL_ROOM) * self.wheel_capacity_n_m_s

    def _held_momentum(self, state, h_wheels):
        """The body's own angular momentum and the wheels' together [N m s], body axes: what the wheels hold once
        they hold the body still."""
        return self.body.inertia_body_kg_m2 @ state.omega_body + np.asarray(h_wheels, dtype=float)

    def _beyond_share(self, state, h_wheels):
        """True where the body's own angular momentum and the wheels' (``_held_momentum``) exceed the wheels' share
        of their capacity (``wheel_momentum_share``) on a body axis."""
        share = self.config.wheel_momentum_share * self.wheel_capacity_n_m_s
        return float(np.max(np.abs(self._held_momentum(state, h_wheels)))) > share

    def _dumped(self, wheels, couple, h_wheels):
        """(wheel torque [N m], thrusters' couple [N m]) with the wheels also spun down at the damping law's dump rate
        and the thrusters' couple taking the momentum they give up (``damping.damping_command``'s dump term), within
        the wheels' torque: a coast held by the thrusters' couples empties the wheels a push filled, so that they
        hold the body again and a mid-course correction can fire (``_wheels_hold``)."""
        spun = np.clip(wheels - self.gains.dump_rate_per_s * np.asarray(h_wheels, dtype=float),
                       -self.wheel_max_torque_n_m, self.wheel_max_torque_n_m)
        return spun, couple + (spun - wheels)

    def _set_reference(self, state):
        """The plan's model restarts from the estimate (a new plan, a slew solved again)."""
        self.reference = (state.t, q_eci_from_body(state.t, self.n, state.q_hill_from_body),
                          np.asarray(state.omega_body, dtype=float))

    def _detumble(self, t, omega, h_wheels):
        """The damping law until the body's own angular momentum (its rate averaged) is below half the condition's
        and the wheels hold no more than their share."""
        momentum = self.body_momentum
        if self._damped(h_wheels) and t - self.t_start >= DETUMBLED_S:  # the mean over a whole window
            self.t_detumbled = t
            self.carried = np.zeros(3)
            return np.zeros(3), np.zeros(3), np.zeros(3), [(
                'OK', events.TRANSPORT_DETUMBLED, f'the combined body detumbled for the transport after '
                                                 f'{t - self.t_start:.1f} s: {momentum:.3g} kg m^2/s (estimated)',
                {'angular_momentum_kg_m2_s': momentum, 'detumbling_time_s': t - self.t_start})]
        return (*self._damp(omega, h_wheels), [])

    def _damped(self, h_wheels):
        """True where the body's own angular momentum is below half the first condition's and the wheels keep
        WHEEL_ROOM of their capacity free to hold it still: the detumbling's end, and what the terminal program needs
        before it plans (the wheels' share at the end is the terminal program's to reach)."""
        return (self.body_momentum < 0.5 * self.config.planner.max_angular_momentum_kg_m2_s
                and self._wheel_share(h_wheels) <= 1.0 - WHEEL_ROOM)

    def _overfull(self, state, h_wheels):
        """True where the wheels could not hold the body still: its own angular momentum and theirs together beyond
        1 - WHEEL_ROOM of their capacity on a body axis (a firing's couple the wheels take up is not)."""
        held = self._held_momentum(state, h_wheels)
        return float(np.max(np.abs(held))) > (1.0 - WHEEL_ROOM) * self.wheel_capacity_n_m_s

    def _damp(self, omega, h_wheels):
        """(force, torque about the chaser's CoM, wheel torque) of the capture's damping law, its couple in pulses."""
        tau, u = damping_command(omega, h_wheels, self.gains, self.wheel_max_torque_n_m)
        return (*self._couple(tau, self.pulse_n_m_s), u)

    def _couple(self, tau, pulse_n_m_s):
        """(force, torque about the chaser's CoM) of a couple tau [N m] about the combined CoM fired in pulses: below
        the thrusters' minimum impulse bit a small couple is not fired at all, so its angular impulse is carried
        until it is worth pulse_n_m_s (``damping.pulse_modulated``); the least side force
        (``transport.thrusters.torque_wrench``), halved where the thrusters cannot."""
        tau, self.carried = pulse_modulated(self.carried, tau, self.config.planner.period_s, pulse_n_m_s)
        if not np.any(tau):
            return np.zeros(3), np.zeros(3)
        for _ in range(DETUMBLE_HALVINGS):  # no pure couple about every axis: the least side force, within reach
            wrench = torque_wrench(self.body, self.config.planner, tau)
            if wrench is not None:
                return wrench
            tau = 0.5 * tau
        return np.zeros(3), np.zeros(3)

