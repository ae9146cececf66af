"""The estimator's parameter record (``EstimatorParams``), one frozen record of every scenario key the estimator reads,
with a sub-record for each of its parts: the target attitude filter, its convergence and motion-category thresholds
(``target_filter.ConvergenceThresholds``, ``motion_category.MotionThresholds``, records themselves), the chaser's
relative navigation, the chaser attitude filter, the mass-property estimation and the transport's navigation
(``flyby_msgs_py.params``; the keys' defaults, ranges and descriptions are the scenario schema's).

A filter's config (``TargetFilterConfig``, ``RelativeNavConfig``, ``ChaserAttitudeFilterConfig``) holds the scenario's
values and the filter's own constants; ``config()`` of the matching record gives it, the constants at the filter's
defaults. No ROS here.
"""

import dataclasses
import math

import numpy as np

from flyby_estimation.chaser_attitude_filter import ChaserAttitudeFilterConfig
from flyby_estimation.motion_category import MotionThresholds
from flyby_estimation.relative_nav import RelativeNavConfig
from flyby_estimation.target_filter import ConvergenceThresholds, TargetFilterConfig
from flyby_msgs_py import params
from flyby_sim.dynamics.propulsion import ThrusterConfig


def _config(config_type, record, overrides):
    """``config_type`` of the record's fields (the same names), ``overrides`` replacing any field."""
    values = {f.name: getattr(record, f.name) for f in dataclasses.fields(record)}
    values.update(overrides)
    return config_type(**values)


@params.record
class TargetFilterParams:
    """The target attitude filter's scenario keys (``target_filter.TargetFilterConfig``)."""

    inertia: np.ndarray = params.key('target_inertia')
    mean_motion_rad_s: float = params.key('mean_motion_rad_s')
    attitude_sigma_rad: float = params.key('sensors.target_attitude.noise_sigma_deg', math.radians)
    gate_probability: float = params.key('estimation.gate_probability')
    rate_sigma0_rad_s: float = params.key('estimation.initial_rate_sigma_deg_s', math.radians)
    torque_psd: float = params.key('estimation.torque_psd_n2m2s')
    check_window_max_samples: int = params.key('estimation.batch_check_max_samples')

    def config(self, **overrides):
        """The filter's TargetFilterConfig (module doc)."""
        return _config(TargetFilterConfig, self, overrides)


@params.record
class RelativeNavParams:
    """The chaser's relative navigation filter's scenario keys (``relative_nav.RelativeNavConfig``): orbit, position
    sensor, thrusters and chaser mass, the numbers the plant is built with (test_filter_and_plant_configs_agree)."""

    mean_motion_rad_s: float = params.key('mean_motion_rad_s')
    radius_m: float = params.key('orbit_radius_m')
    position_sigma_m: float = params.key('sensors.relative_position.noise_sigma_m')
    thrusters: ThrusterConfig = params.sub(ThrusterConfig)  # the plant's own record of the thrusters
    chaser_mass_kg: float = params.key('chaser.mass_kg')
    gate_probability: float = params.key('estimation.gate_probability')
    accel_psd_m2_s3: float = params.key('estimation.accel_psd_m2_s3')
    initial_velocity_sigma_mps: float = params.key('estimation.initial_velocity_sigma_mps')

    def config(self, **overrides):
        """The filter's RelativeNavConfig (module doc)."""
        return _config(RelativeNavConfig, self, overrides)


@params.record
class ChaserAttitudeFilterParams:
    """The chaser attitude filter's scenario keys (``chaser_attitude_filter.ChaserAttitudeFilterConfig``): orbit rate,
    ``sensors.chaser_imu`` in SI units and the gate."""

    mean_motion_rad_s: float = params.key('mean_motion_rad_s')
    rate_hz: float = params.key('sensors.chaser_imu.rate_hz')
    star_tracker_rate_hz: float = params.key('sensors.chaser_imu.star_tracker_rate_hz')
    star_tracker_sigma_rad: float = params.key('sensors.chaser_imu.star_tracker_sigma_deg', math.radians)
    gyro_noise_sigma_rad_s: float = params.key('sensors.chaser_imu.gyro_noise_sigma_rad_s')
    gyro_bias_sigma_rad_s: float = params.key('sensors.chaser_imu.gyro_bias_sigma_rad_s')
    gyro_bias_walk_rad_s_sqrt_s: float = params.key('sensors.chaser_imu.gyro_bias_walk_rad_s_sqrt_s')
    gate_probability: float = params.key('estimation.gate_probability')

    def config(self, **overrides):
        """The filter's ChaserAttitudeFilterConfig (module doc)."""
        return _config(ChaserAttitudeFilterConfig, self, overrides)


@params.record
class AttachmentParams:
    """How the chaser holds the target from t = 0 (post_capture.start attached, seed 004 §3.1)."""

    target_com_chaser_body_m: tuple = params.key('post_capture.attachment.target_com_chaser_body_m')
    q_chaser_from_target: np.ndarray = params.key('q_chaser_from_target_attached')
    q_hill_from_chaser_body0: np.ndarray = params.key('q_hill_from_chaser_body0')
    chaser_position_hill0_m: tuple = params.key('chaser.initial_position_hill_m')


def _rigid_with_post_capture(scenario):
    return scenario.post_capture is not None and scenario.chaser.model == 'rigid_body'


def _starts_attached(scenario):
    return scenario.post_capture is not None and scenario.post_capture.start == 'attached'


@params.record
class MassEstimationParams:
    """The mass-property estimation after the capture (post_capture.mass_estimation, seed 004 §2.2): the prior's
    draws, the chaser and its IMU and thrusters as the filter models them, the target as the catalogue gives it."""

    seed: int = params.key('seed')
    window_s: float = params.key('post_capture.mass_estimation.window_s')
    excitation: str = params.key('post_capture.mass_estimation.excitation')
    prior_mass_sigma: float = params.key('post_capture.mass_estimation.prior_mass_sigma')
    prior_moments_sigma: float = params.key('post_capture.mass_estimation.prior_moments_sigma')
    prior_com_sigma_m: float = params.key('post_capture.mass_estimation.prior_com_sigma_m')
    prior_axes_sigma_rad: float = params.key('post_capture.mass_estimation.prior_axes_sigma_deg', math.radians)
    target_mass_kg: float = params.key('target.mass_kg')
    target_inertia: np.ndarray = params.key('target_inertia')
    grasp_point_body_m: tuple = params.key('target.grasp_point_body_m')
    chaser_inertia: np.ndarray = params.key('chaser_inertia')
    imu_rate_hz: float = params.key('sensors.chaser_imu.rate_hz')
    gyro_noise_sigma_rad_s: float = params.key('sensors.chaser_imu.gyro_noise_sigma_rad_s')
    gyro_bias_walk_rad_s_sqrt_s: float = params.key('sensors.chaser_imu.gyro_bias_walk_rad_s_sqrt_s')
    accel_noise_sigma_mps2: float = params.key('sensors.chaser_imu.accel_noise_sigma_mps2')
    star_tracker_sigma_rad: float = params.key('sensors.chaser_imu.star_tracker_sigma_deg', math.radians)
    thrust_magnitude_sigma: float = params.key('chaser.thrusters.magnitude_error_sigma')
    thrust_misalignment_sigma_rad: float = params.key('chaser.thrusters.direction_error_sigma_deg', math.radians)
    thruster_layout: object = params.key('thruster_layout')
    attachment: AttachmentParams = params.sub(AttachmentParams, when=_starts_attached)


# The combined CoM's navigation propagates the plant's own relative dynamics (two-body gravity, no drag): its white
# acceleration only covers the RK4 step and the pointing of the body's small position offsets [m^2/s^3].
TRANSPORT_NAV_ACCEL_PSD_M2_S3 = 1e-16


@params.record
class TransportNavFilterParams:
    """The combined CoM's navigation filter's scenario keys (``relative_nav.RelativeNavConfig``: no maneuver model,
    the plant's relative dynamics and TRANSPORT_NAV_ACCEL_PSD_M2_S3)."""

    mean_motion_rad_s: float = params.key('mean_motion_rad_s')
    radius_m: float = params.key('orbit_radius_m')
    position_sigma_m: float = params.key('sensors.relative_position.noise_sigma_m')
    dynamics: str = params.key('simulation.dynamics')

    def config(self, **overrides):
        """The filter's RelativeNavConfig (module doc)."""
        return _config(RelativeNavConfig, self, {'accel_psd_m2_s3': TRANSPORT_NAV_ACCEL_PSD_M2_S3, **overrides})


@params.record
class TransportNavigationParams:
    """The combined body's navigation in TRANSPORT (``transport_navigation.TransportNavigation``)."""

    nav: TransportNavFilterParams = params.sub(TransportNavFilterParams)
    dynamics: str = params.key('simulation.dynamics')
    imu_rate_hz: float = params.key('sensors.chaser_imu.rate_hz')
    gyro_noise_sigma_rad_s: float = params.key('sensors.chaser_imu.gyro_noise_sigma_rad_s')
    accel_noise_sigma_mps2: float = params.key('sensors.chaser_imu.accel_noise_sigma_mps2')
    thrust_magnitude_sigma: float = params.key('chaser.thrusters.magnitude_error_sigma')
    thrust_misalignment_sigma_rad: float = params.key('chaser.thrusters.direction_error_sigma_deg', math.radians)
    thruster_layout: object = params.key('thruster_layout')


def _is_rigid_body(scenario):
    return scenario.chaser.model == 'rigid_body'


def _has_transport(scenario):
    return _rigid_with_post_capture(scenario) and scenario.post_capture.transport is not None


@params.record
class HealthParams:
    """What the health monitors read of the scenario (``health.HealthMonitor``; the IMU's and the thrusters' keys
    are used for the rigid-body chaser only)."""

    position_rate_hz: float = params.key('sensors.relative_position.rate_hz')
    attitude_rate_hz: float = params.key('sensors.target_attitude.rate_hz')
    rigid_body: bool = params.derived(_is_rigid_body)
    imu_rate_hz: float = params.key('sensors.chaser_imu.rate_hz')
    star_tracker_rate_hz: float = params.key('sensors.chaser_imu.star_tracker_rate_hz')
    accel_sigma_mps2: float = params.key('sensors.chaser_imu.accel_noise_sigma_mps2')
    thrust_magnitude_sigma: float = params.key('chaser.thrusters.magnitude_error_sigma')
    thrust_misalignment_sigma_rad: float = params.key('chaser.thrusters.direction_error_sigma_deg', math.radians)
    thruster_layout: object = params.key('thruster_layout')
    min_impulse_bit_ns: float = params.key('chaser.thrusters.min_impulse_bit_ns')
    wheels: object = params.key('reaction_wheels')
    tachometer_sigma_rad_s: float = params.key('chaser.wheels.tachometer_sigma_rad_s')
    gyro_sigma_rad_s: float = params.key('sensors.chaser_imu.gyro_noise_sigma_rad_s')


@params.record
class EstimatorParams:
    """Everything ``estimator_core.EstimatorCore`` reads of the scenario (module doc). ``chaser_attitude`` is None
    for a point-mass chaser; ``mass_estimation`` None without a post_capture section (or a point-mass chaser);
    ``transport`` None without a transport."""

    target: TargetFilterParams = params.sub(TargetFilterParams)
    convergence: ConvergenceThresholds = params.sub(ConvergenceThresholds)
    motion: MotionThresholds = params.sub(MotionThresholds)
    nav: RelativeNavParams = params.sub(RelativeNavParams)
    chaser_attitude: ChaserAttitudeFilterParams = params.sub(ChaserAttitudeFilterParams, when=_is_rigid_body)
    mass_estimation: MassEstimationParams = params.sub(MassEstimationParams, when=_rigid_with_post_capture)
    transport: TransportNavigationParams = params.sub(TransportNavigationParams, when=_has_transport)
    health: HealthParams = params.sub(HealthParams)
    injected_rate_error_rad_s: np.ndarray = params.key('estimation.injected_rate_error_deg_s', np.radians)
    mean_motion_rad_s: float = params.key('mean_motion_rad_s')
    chaser_mass_kg: float = params.key('chaser.mass_kg')
    min_impulse_bit_ns: float = params.key('chaser.thrusters.min_impulse_bit_ns')
    imu_rate_hz: float = params.key('sensors.chaser_imu.rate_hz')
    accel_noise_sigma_mps2: float = params.key('sensors.chaser_imu.accel_noise_sigma_mps2')
