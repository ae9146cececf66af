"""The estimation filters configured from a scenario, for the estimator node and one-process loops (no ROS)."""

import math

from flyby_estimation.motion_category import MotionThresholds
from flyby_estimation.relative_nav import RelativeNavFilter, relative_nav_config_from_scenario
from flyby_estimation.target_filter import (
    ConvergenceThresholds,
    TargetAttitudeFilter,
    target_filter_config_from_scenario,
)


def filters_from_scenario(scenario):
    """The two filters and the target thresholds, configured from ``scenario.estimation``."""
    est = scenario.estimation
    rad = math.radians
    target = TargetAttitudeFilter(target_filter_config_from_scenario(
        scenario, gate_probability=est.gate_probability,
        rate_sigma0_rad_s=rad(est.initial_rate_sigma_deg_s), torque_psd=est.torque_psd_n2m2s,
        check_window_max_samples=est.batch_check_max_samples))
    nav = RelativeNavFilter(relative_nav_config_from_scenario(
        scenario, gate_probability=est.gate_probability, accel_psd_m2_s3=est.accel_psd_m2_s3,
        initial_velocity_sigma_mps=est.initial_velocity_sigma_mps))
    convergence = ConvergenceThresholds(rad(est.convergence_attitude_3sigma_deg),
                                        rad(est.convergence_rate_3sigma_deg_s))
    motion = MotionThresholds(
        spin_rate_rad_s=rad(est.spin_rate_deg_s), hill_fixed_rate_rad_s=rad(est.hill_fixed_rate_deg_s),
        inertial_hold_rate_rad_s=rad(est.inertial_hold_rate_deg_s),
        controlled_rate_rad_s=rad(est.controlled_rate_deg_s),
        controlled_excursion_rad=rad(est.controlled_excursion_deg))
    return target, nav, convergence, motion
