"""The synchronized approach's hold (seed 001 section 2, ``sync_control``): from the end of stage 1's trajectory (the
station's arrival) every command is ``SyncGuidance``'s: the body-frame hold, the docking and their force, and the
attitude synchronized with the target's (the attitude law with ``SYNC_ATTITUDE``'s gains); its stage events
(``station_reached``, ``attitude_synchronized``, ``docking_started``) move the supervisor's phases. After ESCAPE or an
abort it retreats along the port's outward direction, then nothing is commanded.

The command of the chaser estimate of t is computed from the target estimate stamped last *before* t (predicted to
the command's time): the estimator publishes the target estimate of t after the chaser estimate of t, and a rule on
stamps, not on which message came first, gives the same command at any pace and in the headless loop.
"""

import dataclasses

import numpy as np

from flyby_guidance.attitude_guidance import AttitudeGuidance
from flyby_guidance.modes.interface import AttitudeCommandStamped, GuidanceMode
from flyby_guidance.sync_control import SYNC_ATTITUDE, SyncGuidance
from flyby_msgs_py import contract as c
from flyby_msgs_py.wire import STAMP_TOLERANCE_S
from flyby_sim.dynamics.attitude import attitude_ahead


class SynchronizedHold(GuidanceMode):
    """Stages 2-4 and the retreat (module doc): ``command`` is None where SyncGuidance has nothing to say (no
    synchronized approach, stage 1 before the arrival, the drift after a retreat)."""

    def __init__(self, config, source, chaser, targets):
        """config: the SyncConfig of planner.sync; chaser: the RigidBodyChaser whose wheels and thrusters it commands;
        targets: the StampedBuffer of the target estimates."""
        super().__init__(source)
        self.chaser = chaser
        self.targets = targets
        self.n = config.n
        self.sync = SyncGuidance(config)
        self.sync_attitude = AttitudeGuidance(dataclasses.replace(SYNC_ATTITUDE, control_period_s=(
            chaser.attitude.config.control_period_s)), chaser.inertia_kg_m2, chaser.attitude.wheels)

    def renew(self):
        """A fresh synchronized guidance for the next approach: one given up (RETREAT) ended in its retreat or
        drift, from which it is never armed again."""
        self.sync = SyncGuidance(self.sync.config)

    def command(self, estimate, phase):
        if self.sync.stage is None:
            return None
        t, r_hill, v_hill, q_hill_from_body, omega_body = estimate
        if phase in (c.PHASE_ESCAPE, c.PHASE_ABORTED, c.PHASE_RETREAT):  # no capture: leave the final point
            self.sync.abort(t)
        target = self.targets.last_at_or_before(t - STAMP_TOLERANCE_S)  # module doc: the one before t
        if target is None:
            return None
        chaser = self.chaser
        period_s = chaser.attitude.config.control_period_s
        cmd = self.sync.command(t, t + period_s, period_s, r_hill, v_hill, q_hill_from_body, omega_body,
                                (target[0], *target[1]))
        if cmd is None:
            return None
        emitted = [self._event(t, level, name, message, values) for level, name, message, values in cmd.events]
        if cmd.goal is None:  # the retreat: body +x back on the target's centre of mass
            att = chaser.attitude.command(t, np.asarray(q_hill_from_body, dtype=float),
                                          np.asarray(omega_body, dtype=float), chaser.h_wheels_n_m_s, r_hill, v_hill,
                                          self.n, True)
        else:
            att = self.sync_attitude.track(cmd.goal, np.asarray(q_hill_from_body, dtype=float),
                                           np.asarray(omega_body, dtype=float), chaser.h_wheels_n_m_s, False)
        chaser.wheel_commands.append((t + period_s, att.wheel_torque_n_m))
        force_body = (0.0, 0.0, 0.0) if cmd.a_hill is None else chaser.tracking_force(
            cmd.a_hill, attitude_ahead(q_hill_from_body, omega_body, 1.5 * period_s, self.n),
            att.thruster_torque_body_n_m)
        return [AttitudeCommandStamped(t + period_s, period_s, att.wheel_torque_n_m, att.thruster_torque_body_n_m,
                                       force_body)] + emitted
