"""The wheels' tachometers' staleness (flyby_estimation.health, docs/faults.md): the rigid-body chaser's tachometer
stream, whose only reader is the wheel monitor, is judged like every sensor's: silent or late for five periods of the
IMU's rate it comes at, ``sensor_stale`` naming ``tachometers``, cleared at its first sample after a loss; the
estimator core feeds it every tachometer sample it takes."""

import math
from pathlib import Path

import numpy as np

from flyby_estimation.estimator_core import EstimatorCore
from flyby_estimation.health import HealthMonitor
from flyby_estimation.params import EstimatorParams, HealthParams
from flyby_sim.dynamics.actuators import default_thruster_layout
from flyby_sim.dynamics.rigid_body import ReactionWheels
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'


def _params(rigid=True):
    return HealthParams(position_rate_hz=10.0, attitude_rate_hz=10.0, rigid_body=rigid, imu_rate_hz=10.0,
                        star_tracker_rate_hz=2.0, accel_sigma_mps2=1e-4, thrust_magnitude_sigma=0.01,
                        thrust_misalignment_sigma_rad=math.radians(0.5),
                        thruster_layout=default_thruster_layout(10.0, 220.0, 0.0), min_impulse_bit_ns=0.01,
                        wheels=ReactionWheels.orthogonal(0.1, 4.0, 0.01), tachometer_sigma_rad_s=0.01,
                        gyro_sigma_rad_s=1e-5)


def _fly(monitor, seconds, tachometers_at):
    """Every sensor's samples at 10 Hz over (0, seconds], the tachometers' only where tachometers_at(t) holds (the
    star tracker's at its 2 Hz); the detections, as (kind, component, detected, t)."""
    found = []
    for k in range(1, round(10 * seconds) + 1):
        t = round(0.1 * k, 9)
        for sensor in ('relative_position', 'target_attitude'):
            monitor.on_sample(sensor, t, nis=3.0)
        monitor.on_sample('imu', t)
        if k % 5 == 0:
            monitor.on_sample('star_tracker', t, nis=3.0)
        if tachometers_at(t):
            monitor.on_sample('tachometers', t)
        found += [(d.kind, d.component, d.detected, round(d.t, 3)) for d in monitor.judge(t)[0]]
    return found


def test_tachometers_lost_are_stale_and_back_at_their_first_sample_and_nominal_ones_raise_nothing():
    assert _fly(HealthMonitor(_params()), 30.0, lambda t: True) == []
    found = _fly(HealthMonitor(_params()), 30.0, lambda t: not 10.0 < t < 20.0)
    # Silent since 10.0: judged stale at the first input beyond five IMU periods.
    assert found == [('sensor_stale', 'tachometers', True, 10.6), ('sensor_stale', 'tachometers', False, 20.0)]
    assert 'tachometers' not in HealthMonitor(_params(rigid=False)).sensors


def test_the_estimator_core_feeds_the_tachometers_staleness_each_sample_it_takes():
    core = EstimatorCore(EstimatorParams.from_scenario(load_scenario(SCENARIOS / 'paper_flyby_6dof.yaml')))
    core.on_wheel_speeds(0.1, np.zeros(3))
    assert core.health.sensors['tachometers'].t_arrival == 0.1
