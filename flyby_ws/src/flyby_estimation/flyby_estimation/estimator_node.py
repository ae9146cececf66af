"""The estimator node: target attitude-motion filter and chaser relative navigation (seed 000 §2.2 (1)).

Subscribes the vision attitude, the relative-position measurements and the commanded maneuvers
(known inputs of the navigation filter); publishes ``estimation/target/odom`` and
``estimation/chaser/odom`` with covariances at each measurement, and on ``mission/events`` the
convergence of the target estimate (with, at the first, the batch maximum-likelihood check of the
filter, ``batch``), its motion category (seed 000 §2.1) and every rejected
measurement with the running count of its kind. The filters live in ``target_filter`` and
``relative_nav`` (no ROS); this node converts messages and calls them.

Odometry covariances: target pose orientation block = attitude error about hill axes, twist angular
block = rate error in body axes (the twist is in child_frame_id, target_body); chaser pose position
block and twist linear block from the navigation filter (the position-velocity cross terms are not
representable in Odometry).
"""

import collections
import math

import numpy as np
from rclpy.node import Node

from flyby_estimation.filters import filters_from_scenario
from flyby_estimation.target_filter import MeasurementRejected
from flyby_msgs_py import contract as c
from flyby_msgs_py import qos
from flyby_msgs_py import convert
from flyby_msgs_py.runtime import main_for, publish_event, scenario_of
from flyby_sim.dynamics.propulsion import ManeuverRejected


# The category is re-evaluated this often once converged (it scans the attitude history).
CLASSIFY_PERIOD_S = 10.0


def _block_diag_6(a3, b3):
    cov = np.zeros((6, 6))
    cov[:3, :3] = a3
    cov[3:, 3:] = b3
    return cov


class EstimatorNode(Node):
    """Target and chaser estimation; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_estimator', **kwargs)
        self.scenario = scenario_of(self)
        self.target, self.nav, self.convergence, self.motion = filters_from_scenario(self.scenario)
        self.converged = False
        self.checked = False  # the batch check runs at the first convergence
        self.category = None
        self.t_classified = -math.inf
        self.rejected = collections.Counter()
        # A fault to inject (tests of the escape): the published rate is off, the filter itself is not.
        self.rate_error = np.radians(self.scenario.estimation.injected_rate_error_deg_s)

        def pub(topic):
            return self.create_publisher(c.message_class(c.TOPIC_TYPES[topic]), topic,
                                         qos.qos_for(topic))
        self.pub_target, self.pub_chaser, self.pub_events = (
            pub(c.EST_TARGET_ODOM), pub(c.EST_CHASER_ODOM), pub(c.MISSION_EVENTS))
        for topic, callback in ((c.SENSOR_TARGET_ATTITUDE, self.on_attitude),
                                (c.SENSOR_RELATIVE_POSITION, self.on_position),
                                (c.GUIDANCE_MANEUVER, self.on_maneuver)):
            self.create_subscription(c.message_class(c.TOPIC_TYPES[topic]), topic, callback,
                                     qos.QOS_STREAM)
        self.attached = False  # captured: the free-flyer navigation model no longer holds
        self.create_subscription(c.message_class(c.TOPIC_TYPES[c.MISSION_PHASE]), c.MISSION_PHASE,
                                 self.on_phase, qos.QOS_LATCHED)

    def on_phase(self, msg):
        if convert.string_to_str(msg) == c.PHASE_CAPTURE and not self.attached:
            self.attached = True
            t = self.nav.t if self.nav.initialized else 0.0
            self.emit(t, 'OK', 'navigation_suspended', 'captured: the chaser moves with the target, '
                      'its free-flight navigation filter stops', {})

    # -- target -------------------------------------------------------------------------------
    def on_attitude(self, msg):
        t, q_meas = convert.quaternion_stamped_to_numpy(msg)
        try:
            self.target.update(t, q_meas)
        except MeasurementRejected as err:
            self.reject(t, 'target_attitude', err.kind, err.reason)
            return
        s = self.target.state()
        self.pub_target.publish(convert.odometry(
            s.t, c.FRAME_HILL, c.FRAME_TARGET_BODY, (0.0, 0.0, 0.0), s.q_hill_from_body,
            (0.0, 0.0, 0.0), s.omega_body + self.rate_error,
            pose_covariance=_block_diag_6(np.zeros((3, 3)), s.covariance_hill[:3, :3]),
            twist_covariance=_block_diag_6(np.zeros((3, 3)), s.covariance[3:, 3:])))
        self.check_convergence(s.t)

    def check_convergence(self, t):
        converged = self.target.convergence(self.convergence)
        attitude_3s, rate_3s = self.target.three_sigma()
        bounds = {'attitude_3sigma_deg': f'{math.degrees(attitude_3s):.4g}',
                  'rate_3sigma_deg_s': f'{math.degrees(rate_3s):.4g}'}
        if converged != self.converged:
            self.converged = converged
            if converged and not self.checked:
                self.checked = True
                bounds.update(self.batch_check(t))
            self.emit(t, 'OK' if converged else 'WARN',
                      'target_converged' if converged else 'target_diverged',
                      f'target estimate {"within" if converged else "outside"} the convergence '
                      f'bounds', bounds)
        if converged and t >= self.t_classified + CLASSIFY_PERIOD_S:
            self.t_classified = t
            motion = self.target.classify_motion(self.motion)
            if motion.category != self.category:
                self.category = motion.category
                self.emit(t, 'OK', 'target_category', motion.reason,
                          {'category': motion.category,
                           'inertial_rate_deg_s': f'{math.degrees(motion.inertial_rate_rad_s):.4g}',
                           'hill_relative_rate_deg_s':
                               f'{math.degrees(motion.hill_relative_rate_rad_s):.4g}'})

    def batch_check(self, t):
        """The filter against the batch maximum-likelihood fit of its measurements (batch.FilterCheck):
        its figures for the converged event, and a WARN target_filter_check if they disagree."""
        try:
            check = self.target.batch_check()
        except (RuntimeError, ValueError) as err:
            self.emit(t, 'WARN', 'target_filter_check', f'batch check not done: {err}', {})
            return {}
        values = {'ml_gap_sigma': f'{check.gap_sigma:.3g}', 'crb_ratio_min': f'{check.ratio_min:.3g}',
                  'crb_ratio_max': f'{check.ratio_max:.3g}', 'chi2_per_dof': f'{check.chi2_per_dof:.4g}',
                  'window_samples': str(check.fit.samples)}
        if not check.consistent:
            self.emit(t, 'WARN', 'target_filter_check', 'the filter differs from the batch maximum-likelihood '
                      f'fit of its measurements (gap {check.gap_sigma:.3g} sigma, covariance '
                      f'{check.ratio_min:.3g}-{check.ratio_max:.3g} x the Cramer-Rao bound)', values)
        return values

    # -- chaser -------------------------------------------------------------------------------
    def on_position(self, msg):
        if self.attached:
            return
        t, r_meas = convert.point_stamped_to_numpy(msg)
        result = self.nav.update(t, r_meas)
        if not result.accepted:
            self.reject(t, 'relative_position', result.kind, result.reason)
            return
        s = self.nav.state()
        self.pub_chaser.publish(convert.odometry(
            s.t, c.FRAME_HILL, c.FRAME_CHASER_BODY, s.r_hill, (0.0, 0.0, 0.0, 1.0), s.v_hill,
            (0.0, 0.0, 0.0),
            pose_covariance=_block_diag_6(s.covariance[:3, :3], np.zeros((3, 3))),
            twist_covariance=_block_diag_6(s.covariance[3:, 3:], np.zeros((3, 3)))))

    def on_maneuver(self, msg):
        t, dv_hill = convert.vector3_stamped_to_numpy(msg)
        try:
            self.nav.add_maneuver(t, dv_hill)
        except (ManeuverRejected, ValueError) as err:
            # The simulator rejects it too; the filter must not expect it.
            self.emit(t, 'WARN', 'maneuver_ignored', f'not a known input of the navigation '
                      f'filter: {err}', {'t_stamp': repr(t)})

    # -- events -------------------------------------------------------------------------------
    def reject(self, t, sensor, kind, reason):
        self.rejected[(sensor, kind)] += 1
        self.emit(t, 'WARN', 'measurement_rejected', reason,
                  {'sensor': sensor, 'kind': kind, 'count': str(self.rejected[(sensor, kind)]),
                   'total': str(sum(self.rejected.values()))})

    def emit(self, t, level, name, message, values):
        publish_event(self, self.pub_events, t, level, name, message, values)


def main(args=None):
    main_for(EstimatorNode, args)


if __name__ == '__main__':
    main()
