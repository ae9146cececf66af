"""The plant's configurations of a validated scenario (``flyby_sim.scenario.Scenario``)."""

import math

from flyby_sim.chaser_body import ImuConfig, RigidChaserConfig
from flyby_sim.dynamics.propulsion import ThrusterConfig
from flyby_sim.plant.config import GraspConfig, PlantConfig


def plant_config_from_scenario(scenario):
    """The plant configuration of a validated scenario (``flyby_sim.scenario.Scenario``)."""
    sc = scenario
    th = sc.chaser.thrusters
    return PlantConfig(
        radius_m=sc.orbit_radius_m,
        mu=sc.orbit.mu_m3_s2,
        chaser_mass_kg=sc.chaser.mass_kg,
        r0_hill=tuple(sc.chaser.initial_position_hill_m),
        v0_hill=tuple(sc.chaser.initial_velocity_hill_mps),
        target_inertia=tuple(map(tuple, sc.target_inertia)),
        q_hill_from_body0=tuple(sc.q_hill_from_body0),
        omega_body0=tuple(sc.omega_body0_rad_s),
        thrusters=ThrusterConfig(
            max_thrust_n=th.max_thrust_n, isp_s=th.isp_s,
            min_impulse_bit_ns=th.min_impulse_bit_ns,
            max_delta_v_per_maneuver_mps=th.max_delta_v_per_maneuver_mps,
            magnitude_error_sigma=th.magnitude_error_sigma,
            direction_error_sigma_rad=math.radians(th.direction_error_sigma_deg)),
        dynamics=sc.simulation.dynamics,
        step_s=sc.simulation.step_s,
        position_sigma_m=sc.sensors.relative_position.noise_sigma_m,
        position_rate_hz=sc.sensors.relative_position.rate_hz,
        attitude_sigma_rad=math.radians(sc.sensors.target_attitude.noise_sigma_deg),
        attitude_rate_hz=sc.sensors.target_attitude.rate_hz,
        restriction_sphere_radius_m=sc.planner.restriction_sphere_radius_m,
        seed=sc.seed,
        chaser_body=rigid_chaser_config_from_scenario(sc) if sc.chaser.model == 'rigid_body' else None,
        grasp=None if sc.post_capture is None else grasp_config_from_scenario(sc),
    )


def grasp_config_from_scenario(scenario):
    """The GraspConfig of a validated scenario with a post_capture section."""
    pc = scenario.post_capture
    g = pc.grasp
    attachment = pc.attachment
    return GraspConfig(scenario.arm_impedance, scenario.target.mass_kg, tuple(scenario.target.grasp_point_body_m),
                       g.velocity_tolerance_mps, g.rate_tolerance_rad_s, g.max_duration_s,
                       None if attachment is None else tuple(attachment.target_com_chaser_body_m),
                       None if attachment is None else tuple(scenario.q_chaser_from_target_attached),
                       None if pc.transport is None else pc.transport.plume_cone_deg)


def rigid_chaser_config_from_scenario(scenario):
    """The RigidChaserConfig of a validated scenario's chaser (its rigid-body keys, whatever chaser.model says)."""
    sc = scenario
    chaser = sc.chaser
    layout = chaser.thrusters.layout
    wheels = chaser.wheels
    imu = sc.sensors.chaser_imu
    return RigidChaserConfig(
        inertia=tuple(map(tuple, sc.chaser_inertia.tolist())),
        q_hill_from_body0=tuple(sc.q_hill_from_chaser_body0.tolist()),
        omega_body0=tuple(sc.omega_chaser_body0_rad_s.tolist()),
        thruster_positions_body_m=None if layout is None else tuple(tuple(x.position_m.tolist()) for x in layout),
        thruster_directions_body=None if layout is None else tuple(tuple(x.direction.tolist()) for x in layout),
        wheel_axes_body=tuple(map(tuple, wheels.axes.tolist())),
        wheel_max_torque_n_m=wheels.max_torque_n_m,
        wheel_max_momentum_n_m_s=wheels.max_momentum_n_m_s,
        wheel_spin_inertia_kg_m2=wheels.spin_inertia_kg_m2,
        wheel_momentum0_n_m_s=None if wheels.initial_momentum_n_m_s is None else tuple(
            wheels.initial_momentum_n_m_s.tolist()),
        imu=ImuConfig(rate_hz=imu.rate_hz, star_tracker_rate_hz=imu.star_tracker_rate_hz,
                      star_tracker_sigma_rad=math.radians(imu.star_tracker_sigma_deg),
                      gyro_noise_sigma_rad_s=imu.gyro_noise_sigma_rad_s,
                      gyro_bias_sigma_rad_s=imu.gyro_bias_sigma_rad_s,
                      gyro_bias_walk_rad_s_sqrt_s=imu.gyro_bias_walk_rad_s_sqrt_s,
                      accel_noise_sigma_mps2=imu.accel_noise_sigma_mps2),
    )
