"""The estimator node: target attitude-motion filter and chaser relative navigation (seed 000 §2.2 (1)).

Converts messages for ``flyby_estimation.estimator_core.EstimatorCore`` (no ROS): the vision attitude,
the relative-position measurements, the commanded maneuvers (known inputs of the navigation filter)
and the mission phase in; ``estimation/target/odom`` and ``estimation/chaser/odom`` with covariances
at each measurement, and the convergence, category and rejection events on ``mission/events``, out.

Odometry covariances: target pose orientation block = attitude error about hill axes, twist angular
block = rate error in body axes (the twist is in child_frame_id, target_body); chaser pose position
block and twist linear block from the navigation filter (the position-velocity cross terms are not
representable in Odometry).

With the six-degree-of-freedom chaser the IMU (``sensors/chaser/imu``) comes in too, and the chaser estimate is
published at its samples: pose.orientation = the estimated chaser_body in hill with its attitude covariance
about hill axes, twist in chaser_body axes (nav_msgs' rule): the velocity (its covariance turned into body
axes) and the inertial body rate with its covariance. The relative positions and the IMU samples go to the core
in the plant's order (``measurement_order``), however DDS interleaves the two topics; a sample not in by the clock
of its stamp (a sensor's dropout, a topic's loss or delay) is waited for no longer, so the node then reads
``/clock`` every step (``on_clock``) instead of the progress tick. The force guidance
commands on ``guidance/wrench`` (an optimal approach's tracking) is a known input of the navigation filter.

With a post_capture section (DESIGN §10) the events of ``mission/events`` come in too (the capture's stamp, the arm's
lock, guidance's ``damping_complete``), and the mass-property filter's estimates go out on
``estimation/target/inertia`` (geometry_msgs/InertiaStamped, frame chaser_body: the target's mass, its CoM from the
chaser's CoM, its inertia about its CoM), their 1-sigma on ``mission/events``.
"""

import numpy as np

from flyby_estimation.estimator_core import ChaserEstimate, EstimatorCore, TargetEstimate
from flyby_estimation.health import Diagnostics
from flyby_estimation.mass_estimation_run import TargetInertiaEstimate
from flyby_estimation.measurement_order import MeasurementOrder
from flyby_estimation.params import EstimatorParams
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert
from flyby_msgs_py.node_base import CoreNode
from flyby_msgs_py.runtime import main_for, publish_event
from flyby_sim.dynamics.rotation import quat_conjugate, quat_rotate, quat_to_matrix
from flyby_sim.scenario import scenario_of

_ZERO3 = np.zeros((3, 3))


def _block_diag_6(a3, b3):
    cov = np.zeros((6, 6))
    cov[:3, :3] = a3
    cov[3:, 3:] = b3
    return cov


class EstimatorNode(CoreNode):
    """Target and chaser estimation; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_estimator', **kwargs)
        scenario = scenario_of(self)
        self.core = EstimatorCore(EstimatorParams.from_scenario(scenario), self.get_name())
        self.pub_target, self.pub_chaser, self.pub_events = (
            self.publisher(c.EST_TARGET_ODOM), self.publisher(c.EST_CHASER_ODOM), self.publisher(c.MISSION_EVENTS))
        self.pub_diagnostics = self.publisher(c.DIAGNOSTICS)
        self.order = None
        if scenario.chaser.model == 'rigid_body':
            self.order = MeasurementOrder(scenario.simulation.step_s,
                                          [('position', scenario.sensors.relative_position.rate_hz),
                                           ('imu', scenario.sensors.chaser_imu.rate_hz)])
            # The run loop's ProgressReporter then reads /clock and calls on_clock at every step (only then: the
            # point-mass chaser's estimator has nothing to do at a clock).
            self.on_clock = self._on_clock
        if scenario.post_capture is not None:
            self.pub_inertia = self.publisher(c.EST_TARGET_INERTIA)
        # The measurements come as CDR bytes (convert.*_cdr_to_numpy: no Python messages on the hot path).
        self.subscribe_inputs(scenario, {
            c.SENSOR_CHASER_IMU: (self.on_imu, True), c.GUIDANCE_WRENCH: (self.on_wrench, True),
            c.SENSOR_TARGET_ATTITUDE: (self.on_attitude, True), c.SENSOR_RELATIVE_POSITION: (self.on_position, True),
            c.SENSOR_CHASER_WHEELS: (self.on_wheel_speeds, True), c.GUIDANCE_WHEELS: (self.on_wheels, True),
            c.GUIDANCE_MANEUVER: self.on_maneuver, c.MISSION_PHASE: self.on_phase_message, c.SAFETY_CAM: self.on_cam,
            c.MISSION_EVENTS: self.on_events_message})

    def on_attitude(self, data):
        self.publish(self.core.on_attitude(*convert.quaternion_stamped_cdr_to_numpy(data)))

    def on_position(self, data):
        t, r_hill = convert.point_stamped_cdr_to_numpy(data)
        if self.order is None:
            self.publish(self.core.on_position(t, r_hill))
        else:
            self._in_order(self.order.push('position', t, r_hill))

    def on_imu(self, data):
        imu = convert.imu_cdr_to_numpy(data)
        self._in_order(self.order.push('imu', imu.t, imu))

    def _on_clock(self, t):
        """The simulator's clock of t [s]: the samples a measurement of a step up to t that never came held back."""
        self._in_order(self.order.clock(t))

    def _in_order(self, samples):
        for kind, t, value in samples:
            if kind == 'position':
                self.publish(self.core.on_position(t, value))
            else:
                self.publish(self.core.on_imu(t, value.orientation_xyzw, value.angular_velocity,
                                              value.linear_acceleration))

    def on_wrench(self, data):
        w = convert.wrench_stamped_cdr_to_numpy(data)
        self.publish(self.core.on_wrench(w.t, w.force, w.torque))

    def on_wheel_speeds(self, data):
        wheels = convert.joint_state_cdr_to_numpy(data)
        self.publish(self.core.on_wheel_speeds(wheels.t, wheels.velocity))

    def on_wheels(self, data):
        wheels = convert.joint_state_cdr_to_numpy(data)
        self.publish(self.core.on_wheels(wheels.t, wheels.effort))

    def on_cam(self, msg):
        self.publish(self.core.on_cam(convert.vector3_stamped_to_numpy(msg)[0]))

    def on_maneuver(self, msg):
        self.publish(self.core.on_maneuver(*convert.vector3_stamped_to_numpy(msg)))

    def publish(self, outputs):
        for out in outputs:
            if isinstance(out, TargetEstimate):
                self.pub_target.publish(convert.odometry_cdr(
                    out.t, c.FRAME_HILL, c.FRAME_TARGET_BODY, (0.0, 0.0, 0.0), out.q_hill_from_body,
                    (0.0, 0.0, 0.0), out.omega_body,
                    pose_covariance=_block_diag_6(_ZERO3, out.attitude_covariance_hill),
                    twist_covariance=_block_diag_6(_ZERO3, out.rate_covariance_body)))
            elif isinstance(out, ChaserEstimate) and out.q_hill_from_body is not None:
                c_body_from_hill = quat_to_matrix(quat_conjugate(out.q_hill_from_body))
                velocity_cov_body = c_body_from_hill @ out.covariance[3:, 3:] @ c_body_from_hill.T
                self.pub_chaser.publish(convert.odometry_cdr(
                    out.t, c.FRAME_HILL, c.FRAME_CHASER_BODY, out.r_hill, out.q_hill_from_body,
                    quat_rotate(quat_conjugate(out.q_hill_from_body), out.v_hill), out.omega_body,
                    pose_covariance=_block_diag_6(out.covariance[:3, :3], out.attitude_covariance_hill),
                    twist_covariance=_block_diag_6(velocity_cov_body, out.rate_covariance_body)))
            elif isinstance(out, TargetInertiaEstimate):
                self.pub_inertia.publish(convert.inertia_stamped(out.t, c.FRAME_CHASER_BODY, out.mass_kg,
                                                                 out.com_body_m, out.inertia_body_kg_m2))
            elif isinstance(out, ChaserEstimate):
                self.pub_chaser.publish(convert.odometry_cdr(
                    out.t, c.FRAME_HILL, c.FRAME_CHASER_BODY, out.r_hill, (0.0, 0.0, 0.0, 1.0), out.v_hill,
                    (0.0, 0.0, 0.0),
                    pose_covariance=_block_diag_6(out.covariance[:3, :3], _ZERO3),
                    twist_covariance=_block_diag_6(out.covariance[3:, 3:], _ZERO3)))
            elif isinstance(out, Diagnostics):
                self.pub_diagnostics.publish(convert.diagnostics(
                    out.t, [(s.name, s.level, s.message, s.values) for s in out.statuses], self.get_name()))
            else:
                publish_event(self, self.pub_events, out)


def main(args=None):
    main_for(EstimatorNode, args)


if __name__ == '__main__':
    main()
