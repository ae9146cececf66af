"""The rigid-body chaser's pointing, and the tracking of a planned trajectory (an optimization-based approach, seed
003 section 4; the synchronized approach's stage 1, seed 001 section 2).

Every chaser estimate (given at the IMU's stamps, with the attitude) gives an ``AttitudeCommandStamped``: the wheel
motor torques and the thrusters' body torque of ``attitude_guidance.AttitudeGuidance`` pointing body +x at the
target's centre of mass, stamped one control period (the IMU's sample period) after the estimate and held for one
period (DESIGN §10: the simulator holds time at that stamp until the command is in). No thruster torque is asked
within ``chaser.RESTRICTION_SPHERE_MARGIN_M`` of the restriction sphere (by the estimate).

On a planned trajectory (planner/trajectory) the command also carries the force [N, chaser_body] of the tracking law
(``flyby_guidance.tracking``: feed-forward plus feedback, the plume rule, the acceleration bound; the mass counted
down by the fuel of the forces commanded), and the pointing goal's feed-forward takes the commanded thrust (the line
of sight turns with it). When the estimate leaves the trajectory by more than planner.optimal.replan_error_m guidance
asks for a re-plan (``replan_requested``, once per trajectory) and flies the old trajectory until the new one starts.
"""

import math

import numpy as np

from flyby_guidance.modes.flyby import QUIET_PHASES
from flyby_guidance.modes.interface import AttitudeCommandStamped, GuidanceMode
from flyby_guidance.tracking import TrackingConfig, tracking_acceleration
from flyby_msgs_py import events
from flyby_sim.dynamics.orbital import cw_accel


class TrackingApproach(GuidanceMode):
    """The pointing and the tracking (module doc): ``command`` gives every estimate's command (never None: the last
    of the chaser's modes)."""

    def __init__(self, tracking, n, source, chaser):
        """tracking: the TrackingConfig of planner.optimal; n: the mean motion [rad/s]; chaser: the RigidBodyChaser
        whose wheels and thrusters it commands."""
        super().__init__(source)
        self.chaser = chaser
        self.n = n
        self.tracking = tracking
        self.reference = None  # the ReferenceTrajectory flown (an optimal approach)
        self.next_reference = None  # a re-planned one, flown from its start
        self.replan_asked = False
        self.tracking_error_max_m = 0.0  # over the approach, by the estimates
        self.tracking_ended = False

    def on_trajectory(self, ref):
        """A new ReferenceTrajectory: flown at once if none is, else from its start."""
        if self.reference is None:
            self.reference = ref
        else:
            self.next_reference = ref
        return [self._event(ref.t_start, 'OK', events.GUIDANCE_STARTED,
                            f'tracking the optimal approach from t = {ref.t_start:.2f} s to {ref.t_end:.2f} s',
                            {'t_start_s': ref.t_start, 't_end_s': ref.t_end})]

    def drop_plan(self):
        """No trajectory tracked: the pointing goes on."""
        self.reference = self.next_reference = None
        self.replan_asked = self.tracking_ended = False

    def track_sync_link(self, sync_config):
        """Stage 1 of the synchronized approach: the link tracked without the plume rule, planner.sync's bound and
        gain."""
        self.tracking = TrackingConfig(sync_config.accel_max_mps2, 0.0, sync_config.frequency_rad_s, math.inf, 0.0)

    def t_end(self):
        """The end of the trajectory flown last [s]."""
        return (self.next_reference or self.reference).t_end

    def command(self, estimate, phase):
        t, r_hill, v_hill, q_hill_from_body, _ = estimate
        chaser = self.chaser
        period_s = chaser.attitude.config.control_period_s
        a_thrust_hill, emitted = self._acceleration(t, t + period_s, r_hill, v_hill, phase)
        inside = float(np.linalg.norm(r_hill)) < chaser.sphere_radius_m
        cmd = self._attitude_command(estimate, inside, a_thrust_hill)
        force_body = (0.0, 0.0, 0.0) if a_thrust_hill is None else chaser.tracking_force(
            a_thrust_hill, q_hill_from_body, cmd.thruster_torque_body_n_m)
        return [AttitudeCommandStamped(t + period_s, period_s, cmd.wheel_torque_n_m, cmd.thruster_torque_body_n_m,
                                       force_body)] + emitted

    def wheels_only(self, estimate):
        """The pointing with the wheels alone (the attitude law's command inside the restriction sphere, where the
        thruster torque is exactly zero), no force: the command once propulsion is idle (guidance_core)."""
        period_s = self.chaser.attitude.config.control_period_s
        cmd = self._attitude_command(estimate, True, None)
        return [AttitudeCommandStamped(estimate.t + period_s, period_s, cmd.wheel_torque_n_m, np.zeros(3))]

    def _attitude_command(self, estimate, inside, a_thrust_hill):
        """The attitude law's command of an estimate (inside: the restriction sphere's rule; a_thrust_hill: the
        tracked thrust acceleration or None), its wheel torques booked from the next control period."""
        t, r_hill, v_hill, q_hill_from_body, omega_body = estimate
        chaser = self.chaser
        cmd = chaser.attitude.command(t, np.asarray(q_hill_from_body, dtype=float),
                                      np.asarray(omega_body, dtype=float), chaser.h_wheels_n_m_s, r_hill, v_hill,
                                      self.n, inside,
                                      None if a_thrust_hill is None else cw_accel(r_hill, v_hill, self.n,
                                                                                  a_thrust_hill))
        chaser.wheel_commands.append((t + chaser.attitude.config.control_period_s, cmd.wheel_torque_n_m))
        return cmd

    def _acceleration(self, t, t_apply, r_hill, v_hill, phase):
        """(thrust acceleration [m/s^2, hill] of the tracking law held from t_apply, or None where nothing is
        tracked; events) for the estimate of t (module doc)."""
        if self.next_reference is not None and t_apply >= self.next_reference.t_start:
            self.reference, self.next_reference, self.replan_asked = self.next_reference, None, False
        ref = self.reference
        if ref is None or phase in QUIET_PHASES or t_apply < ref.t_start or self.tracking_ended:
            return None, []
        if t_apply >= ref.t_end:
            self.tracking_ended = True
            return None, [self._event(t, 'OK', events.TRACKING_ENDED,
                                      f'end of the trajectory at t = {ref.t_end:.2f} s; largest tracking error '
                                      f'{self.tracking_error_max_m:.3f} m (estimate)',
                                      {'tracking_error_max_m': self.tracking_error_max_m})]
        emitted = []
        error_m = ref.error(t, r_hill)
        self.tracking_error_max_m = max(self.tracking_error_max_m, error_m)
        if error_m > self.tracking.replan_error_m and not self.replan_asked \
                and t < ref.t_end - self.tracking.replan_cutoff_s:
            self.replan_asked = True
            emitted.append(self._event(t, 'WARN', events.REPLAN_REQUESTED,
                                       f'tracking error {error_m:.3f} m > {self.tracking.replan_error_m:g} m',
                                       {'tracking_error_m': error_m}))
        period_s = self.chaser.attitude.config.control_period_s
        return tracking_acceleration(ref, t_apply, period_s, t, r_hill, v_hill, self.tracking), emitted
