"""The chaser guidance commands: the rigid-body chaser's wheels and thrusters as guidance accounts them, whose
estimates the synchronized hold or else the pointing and tracking command (``RigidBodyChaser``), or a point-mass
chaser, which only translates by the fly-by's maneuvers (``PointMassChaser``).

The wheels' momentum is the guidance's own account of the torques it commanded (what the wheels received, unless a
wheel met its momentum limit, which the plant reports). The mass is counted down by the fuel of the forces
commanded.

A wheel fault's ``wheels_reallocated`` (the supervisor's ``reallocate``, docs/faults.md) takes the named wheels out of
both attitude laws (the pointing's and the synchronized hold's, ``AttitudeGuidance.take_wheels_out``) from the first
chaser estimate stamped after the event (strictly: the event carries its detection's stamp t, and the estimator's
estimate of t may go out before or after the detection, the IMU's and the tachometers' samples of t coming in either
order; so that estimate is never the one that drops the wheel, whichever reaches guidance first). Headless, the event
always comes in before any later estimate (the detection, the supervisor's answer and guidance's event are delivered
within the step that made them). In the graph nothing holds the next estimate back for the supervisor's answer: an
event reaching guidance after an estimate stamped after t applies from the first estimate after its arrival, later
than headless (``wheels_late`` counts such events; docs/faults.md). A
reallocation the law refuses (a wheel index that is no wheel, or a further wheel once the wheels left span fewer than
three axes) is answered at its arrival with an ERROR ``command_rejected`` naming it, which aborts the approach (the
supervisor's rule for a watched node's ERROR), and nothing is taken out.
"""

import collections

import numpy as np

from flyby_guidance.attitude_guidance import AttitudeGuidance
from flyby_guidance.modes.interface import GuidanceMode
from flyby_guidance.modes.synchronized import SynchronizedHold
from flyby_guidance.modes.tracking import TrackingApproach
from flyby_guidance.tracking import ReferenceTrajectory
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events
from flyby_sim.dynamics.actuators import allocate_wrench, fire
from flyby_sim.dynamics.rotation import quat_conjugate, quat_rotate

# Thruster torque only this far outside the restriction sphere (by the estimate) [m]: the estimate's error and
# one control period of motion stay well inside it.
RESTRICTION_SPHERE_MARGIN_M = 1.0


class PointMassChaser(GuidanceMode):
    """A point-mass chaser: no attitude to command, no trajectory to track."""

    def command(self, estimate, phase):
        return []

    def idle_command(self, estimate):
        """Propulsion idle (the supervisor's core raised, ``guidance_core``): nothing to command."""
        return []

    def on_phase(self, phase):
        """Nothing changes with the phase."""

    def on_trajectory(self, t_s, r_hill, v_hill, a_hill, phase):
        return [self._event(float(t_s[0]), 'ERROR', events.TRAJECTORY_IGNORED,
                            'an optimal approach needs the rigid-body chaser (continuous thrust)', {})]


class RigidBodyChaser(GuidanceMode):
    """The six-degree-of-freedom chaser (``chaser.model: rigid_body``): its accounts (module doc), and ``command``
    of each estimate by the first of its modes that has one: the synchronized hold, else the pointing and tracking."""

    def __init__(self, params, tracking, synchronized, source, targets):
        """params: the ChaserParams, tracking: the TrackingConfig, synchronized: the SyncConfig
        (flyby_guidance.params); targets: the StampedBuffer of the target estimates."""
        super().__init__(source)
        self.attitude = AttitudeGuidance(params.attitude_config(), params.inertia_kg_m2, params.wheels)
        self.h_wheels_n_m_s = params.initial_wheel_momentum_n_m_s.copy()
        self.wheel_commands = collections.deque()  # (t, wheel torques) commanded, not yet in h_wheels
        self.sphere_radius_m = params.restriction_sphere_radius_m + RESTRICTION_SPHERE_MARGIN_M
        self.mass_kg = params.mass_kg  # less the fuel of the forces commanded
        self.inertia_kg_m2 = params.inertia_kg_m2
        self.layout = params.thruster_layout
        self.force_carried_hill = np.zeros(3)  # below the thrusters' minimum impulse bit so far [N]
        self.wheels_clipped = False  # from the arm's lock on (``account_wheels``)
        self.tracking = TrackingApproach(tracking, params.mean_motion_rad_s, source, self)
        self.sync_hold = SynchronizedHold(synchronized, source, self, targets)
        self.modes = (self.sync_hold, self.tracking)
        self.wheels_out_pending = []  # (t [s], wheel indices) of wheels_reallocated not yet applied (module doc)
        self.last_estimate_t = -np.inf  # [s] the stamp of the last estimate commanded
        self.wheels_late = 0  # wheels_reallocated that came in after an estimate stamped after them (module doc)

    def on_event(self, event, phase):
        """wheels_reallocated: its wheels out from the first estimate stamped after it (module doc), or its refusal
        (an ERROR command_rejected naming why) where the attitude law would not take them."""
        if event.name != events.WHEELS_REALLOCATED:
            return []
        wheels = tuple(event_payloads.decode(event).wheels)
        promised = [i for _, pending in self.wheels_out_pending for i in pending]
        reason = self.attitude.wheels_out_refusal(wheels, also_out=promised)
        if reason is not None:
            return [self._event(event.t, 'ERROR', events.COMMAND_REJECTED, f'wheels_reallocated refused: {reason}',
                                {'wheels': list(wheels)})]
        if event.t < self.last_estimate_t:
            self.wheels_late += 1
        self.wheels_out_pending.append((event.t, wheels))
        return []

    def command(self, estimate, phase):
        self._before_command(estimate.t)
        for mode in self.modes:
            out = mode.command(estimate, phase)
            if out is not None:
                return out
        return []

    def idle_command(self, estimate):
        """The command of an estimate before the grasp once propulsion is idle (the supervisor's core raised,
        ``guidance_core``): the pointing law holds body +x on the target with the wheels alone, no force
        (``TrackingApproach.wheels_only``). Still one command every estimate: the simulator holds time for it."""
        self._before_command(estimate.t)
        return self.tracking.wheels_only(estimate)

    def _before_command(self, t):
        """The accounts before the command of the estimate of t [s]: the wheels' momentum, and the wheels whose
        wheels_reallocated is stamped before t taken out of both attitude laws (module doc)."""
        self.account_wheels(t)
        self.last_estimate_t = t
        due = [wheels for t_out, wheels in self.wheels_out_pending if t_out < t]
        if due:
            self.wheels_out_pending = [p for p in self.wheels_out_pending if p[0] >= t]
            for law in (self.attitude, self.sync_hold.sync_attitude):
                law.take_wheels_out([i for wheels in due for i in wheels])

    def drop_plan(self):
        """The tracked trajectory dropped (HOLD, RETREAT); a synchronized approach flies its own retreat meanwhile."""
        self.tracking.drop_plan()

    def on_phase(self, phase):
        """SYNC_APPROACH: stage 1's link tracked with planner.sync's bound and gain, the hold armed at its end;
        PLANNING after an approach given up: the synchronized guidance renewed."""
        if phase == c.PHASE_PLANNING and self.sync_hold.sync.stage is not None:
            self.sync_hold.renew()
        if phase == c.PHASE_SYNC_APPROACH:
            self.tracking.track_sync_link(self.sync_hold.sync.config)
            self.sync_hold.sync.arm(self.tracking.t_end())

    def on_trajectory(self, t_s, r_hill, v_hill, a_hill, phase):
        """planner/trajectory: a new trajectory to track (in a synchronized approach, the hold from its end)."""
        ref = ReferenceTrajectory(t_s, r_hill, v_hill, a_hill)
        out = self.tracking.on_trajectory(ref)
        if phase in c.SYNC_PHASES:
            self.sync_hold.sync.arm(ref.t_end)
        return out

    def account_wheels(self, t):
        """The wheels' momentum with every wheel command whose hold ended by t (module doc). After the arm's lock a
        wheel stops at its momentum limit as the plant's does (the damping drives them there: h + u dt, clipped, is
        what the wheel holds at the hold's end)."""
        period_s = self.attitude.config.control_period_s
        while self.wheel_commands and self.wheel_commands[0][0] + period_s <= t + 1e-9:
            self.h_wheels_n_m_s = self.h_wheels_n_m_s + period_s * self.wheel_commands.popleft()[1]
            if self.wheels_clipped:
                h_max = self.attitude.wheels.max_momentum_n_m_s
                self.h_wheels_n_m_s = np.clip(self.h_wheels_n_m_s, -h_max, h_max)

    def tracking_force(self, a_hill, q_hill_from_body, torque_body_n_m):
        """The force [N, chaser_body] for the thrust acceleration a_hill [m/s^2]. The thrusters fire it with
        torque_body_n_m as the plant allocates them (the nominal layout, least thrust); what a thruster below its
        minimum impulse bit leaves out is carried into the next command, so the mean force is the one commanded
        (otherwise the feedback's small corrections, about 0.1 N, are lost)."""
        force_body = quat_rotate(quat_conjugate(q_hill_from_body), self.mass_kg * a_hill + self.force_carried_hill)
        firing = fire(self.layout, allocate_wrench(self.layout, force_body, torque_body_n_m).thrusts_n,
                      self.attitude.config.control_period_s)
        self.force_carried_hill = quat_rotate(q_hill_from_body, force_body - firing.force_body_n)
        self.mass_kg -= firing.fuel_kg
        return tuple(force_body.tolist())
