"""Guidance after the capture (``flyby_guidance.damping.PostCaptureControl``): nothing is commanded while the arm's
impedance damps the contact, nor after it lets go (``grasp_released``: the plant takes no command, the chaser drifts
off); from the simulator's ``grasp_damped`` (the arm locked) every chaser estimate stamped at or after its stamp (from
t = 0 in a run that starts attached, which skips the damping) gets the damping law's command, then the excitation's,
each applied one control period later (the simulator holds time for them as before the capture). The estimates that
come before that event are kept until it does (the topics race), so the commands are the same at any pace.
"""

import collections

import numpy as np

from flyby_guidance.damping import PostCaptureControl, inertia_upper_bound
from flyby_guidance.modes.interface import AttitudeCommandStamped, GuidanceMode
from flyby_msgs_py import contract as c
from flyby_msgs_py import events
from flyby_msgs_py.wire import STAMP_TOLERANCE_S

# The phases in which the chaser holds the target (its estimates wait for the arm's lock).
ATTACHED_PHASES = (c.PHASE_CAPTURE,) + c.POST_CAPTURE_PHASES


class NotCaptured(GuidanceMode):
    """A scenario without a post_capture section: no estimate is this mode's."""

    def command(self, estimate, phase):
        return None


class DampingMode(GuidanceMode):
    """The damping and the excitation after the arm's lock (module doc): ``command`` takes the estimates from the
    arm's lock on (or in the attached phases, to wait for it) and gives the commands they release, None before."""

    def __init__(self, params, source, chaser):
        """params: the DampingParams (flyby_guidance.params); chaser: the RigidBodyChaser whose wheels and
        thrusters it commands."""
        super().__init__(source)
        self.params = params
        self.chaser = chaser
        self.post = PostCaptureControl(params.post, float(chaser.attitude.wheels.max_torque_n_m.min()))
        self.t_locked = None  # the arm's lock (the simulator's grasp_damped) [s]
        # Between the two CoMs [m]: the chaser estimate's distance from the target's after a capture, the
        # attachment's when the run starts attached (locked from t = 0; its position estimate is not measured).
        self.distance_m = None
        if params.attached_distance_m is not None:
            self._lock(0.0)
            self.distance_m = params.attached_distance_m
        self.released = False  # the arm let go (grasp_released)
        # (t, r_hill, v_hill, q_hill_from_body, omega_body) not yet commanded
        self.waiting = collections.deque()

    def command(self, estimate, phase):
        if self.released:
            return []
        if self.t_locked is not None or phase in ATTACHED_PHASES:
            t, r_hill, v_hill, q_hill_from_body, omega_body = estimate
            self.waiting.append((t, r_hill, v_hill, np.asarray(q_hill_from_body, dtype=float),
                                 np.asarray(omega_body, dtype=float)))
            return self._commands(phase)
        return None

    def on_event(self, event, phase):
        """The arm's lock or release (module doc), then the estimator's events (``_on_estimator_event``)."""
        if event.name == events.GRASP_DAMPED and self.t_locked is None:
            self._lock(event.t)
            return self._commands(phase)
        if event.name == events.GRASP_RELEASED:
            self.released = True  # the plant takes no command after the arm let go: the chaser drifts off
            self.waiting.clear()
        return self._on_estimator_event(event, phase)

    def _lock(self, t):
        """The arm locked at t: the chaser's wheels stop at their momentum limit from then on."""
        self.t_locked = t
        self.chaser.wheels_clipped = True

    def _on_estimator_event(self, event, phase):
        """Nothing of the estimator's moves the damping."""
        return []

    def _waits(self, t):
        """True for an estimate whose command depends on an estimate of the estimator still on its way: none here."""
        return False

    def _transport_command(self, t, r_hill, v_hill, q_hill_from_body, omega_body, h_wheels_body_n_m_s):
        """The transport's PostCaptureCommand of the estimate, or None where the damping's rules command it."""
        return None

    def _commands(self, phase):
        """The commands of the chaser estimates after the capture, from the arm's lock on (module doc)."""
        chaser = self.chaser
        out = []
        while self.t_locked is not None and self.waiting and phase != c.PHASE_COMPLETE:
            t, r_hill, v_hill, q_hill_from_body, omega_body = self.waiting[0]
            if self._waits(t):
                break  # the estimator's final estimate, stamped at this estimate's, is still on its way
            self.waiting.popleft()
            if t < self.t_locked - STAMP_TOLERANCE_S:
                continue  # the arm's impedance had it
            chaser.account_wheels(t)
            period_s = chaser.attitude.config.control_period_s
            wheels = chaser.attitude.wheels
            axes = wheels.axis_matrix
            h_settled = np.clip(chaser.h_wheels_n_m_s + period_s * sum((u for _, u in chaser.wheel_commands),
                                                                        np.zeros(wheels.count)),
                                -wheels.max_momentum_n_m_s, wheels.max_momentum_n_m_s)
            cmd = self._transport_command(t, r_hill, v_hill, q_hill_from_body, omega_body,
                                          axes @ chaser.h_wheels_n_m_s)
            if cmd is None:
                p = self.params
                bound = inertia_upper_bound(p.chaser_inertia_kg_m2, p.target_inertia_kg_m2, p.chaser_mass_kg,
                                            p.target_mass_kg, float(np.linalg.norm(r_hill))
                                            if self.distance_m is None else self.distance_m)
                cmd = self.post.command(t, omega_body, axes @ chaser.h_wheels_n_m_s, axes @ h_settled, bound)
            wheel_torque = np.linalg.pinv(axes) @ cmd.wheel_torque_body_n_m
            chaser.wheel_commands.append((t + period_s, wheel_torque))
            out.append(AttitudeCommandStamped(t + period_s, period_s, wheel_torque, cmd.torque_body_n_m,
                                              tuple(cmd.force_body_n.tolist())))
            out += [self._event(t, *e) for e in cmd.events]
        return out
