"""sensors.py: noise statistics, independent streams, deterministic sample schedule."""

import math

import numpy as np
import pytest

from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, quat_normalize, rotation_vector_from_quat
from flyby_sim.dynamics.sampling import SampleSchedule, is_sample_step
from flyby_sim.sensors import ImuModel, SensorModel


def test_position_noise_is_gaussian_per_axis():
    sensors = SensorModel(np.random.default_rng(1), position_sigma_m=0.01, attitude_sigma_rad=0.0)
    r = np.array([50.0, -3.0, 2.0])
    errors = np.array([sensors.relative_position(r) - r for _ in range(20000)])
    np.testing.assert_allclose(errors.std(axis=0), 0.01, rtol=0.03)
    np.testing.assert_allclose(errors.mean(axis=0), 0.0, atol=4 * 0.01 / math.sqrt(20000))


def test_attitude_noise_is_a_body_frame_rotation_with_sigma_per_axis():
    sigma = math.radians(1.0)
    sensors = SensorModel(np.random.default_rng(2), position_sigma_m=0.0, attitude_sigma_rad=sigma)
    q_true = quat_normalize([0.3, -0.2, 0.5, 0.7])
    errors = []
    for _ in range(20000):
        q_meas = sensors.target_attitude(q_true)
        assert abs(np.linalg.norm(q_meas) - 1.0) < 1e-15
        errors.append(rotation_vector_from_quat(quat_multiply(quat_conjugate(q_true), q_meas)))
    np.testing.assert_allclose(np.std(errors, axis=0), sigma, rtol=0.03)


def test_sensor_streams_are_independent():
    """Drawing attitude samples does not change the position noise."""
    a = SensorModel(np.random.default_rng(9), 0.01, 0.01)
    b = SensorModel(np.random.default_rng(9), 0.01, 0.01)
    for _ in range(5):
        a.target_attitude([0.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(a.relative_position([1.0, 2.0, 3.0]), b.relative_position([1.0, 2.0, 3.0]))


def test_negative_sigma_is_rejected_by_name():
    with pytest.raises(ValueError, match='attitude_sigma_rad'):
        SensorModel(np.random.default_rng(0), 0.01, -1.0)


def test_schedule_samples_the_step_nearest_each_sample_time():
    steps = [i for i in range(1, 61) if is_sample_step(i, 10.0, 0.05)]
    assert steps == list(range(2, 61, 2))
    # 3 Hz with 50 ms steps: k / 3 s rounds to steps 7, 13, 20, 27, ...
    steps = [i for i in range(1, 1201) if is_sample_step(i, 3.0, 0.05)]
    assert steps[:4] == [7, 13, 20, 27]
    assert len(steps) == 180
    expected = [int(math.floor(k / (3.0 * 0.05) + 0.5)) for k in range(1, 181)]
    assert steps == expected
    assert all(is_sample_step(i, 20.0, 0.05) for i in range(100))


def test_schedule_rejects_more_than_one_sample_per_step():
    with pytest.raises(ValueError, match='more than one sample per step'):
        is_sample_step(3, 30.0, 0.05)
    with pytest.raises(ValueError, match='rate_hz'):
        is_sample_step(3, 0.0, 0.05)


def test_schedule_sample_index_is_the_sample_of_the_step():
    schedule = SampleSchedule(3.0, 0.05)
    indices = {i: schedule.sample_index(i) for i in range(1, 1201)}
    sampled = [i for i, k in indices.items() if k is not None]
    assert sampled == [i for i in range(1, 1201) if is_sample_step(i, 3.0, 0.05)]
    assert [indices[i] for i in (7, 13, 20, 27)] == [1, 2, 3, 4] and indices[8] is None


def test_imu_gyro_bias_starts_with_its_sigma_and_walks_with_sigma_sqrt_dt():
    """b(0) ~ N(0, sigma_b0^2) over 4000 IMUs; then b_k - b_(k-1) ~ N(0, sigma_bw^2 dt) over 20000 samples of one IMU
    whose white noise is off, read through the gyro at rest (omega_meas = b_k)."""
    rng = np.random.default_rng(11)
    biases = [ImuModel(child, 0.0, 0.0, 1e-4, 0.0, 0.0).gyro_bias_rad_s for child in rng.spawn(4000)]
    np.testing.assert_allclose(np.std(biases, axis=0), 1e-4, rtol=0.05)
    imu = ImuModel(np.random.default_rng(12), 0.0, 0.0, 1e-4, 1e-3, 0.0)
    readings = [imu.gyro_bias_rad_s]
    for k in range(1, 20001):
        sample = imu.sample(0.1 * k, False, (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        assert sample.q_hill_from_body is None
        np.testing.assert_array_equal(sample.omega_body_meas, imu.gyro_bias_rad_s)
        readings.append(sample.omega_body_meas)
    steps = np.diff(readings, axis=0)
    np.testing.assert_allclose(np.std(steps, axis=0), 1e-3 * math.sqrt(0.1), rtol=0.03)
    np.testing.assert_allclose(np.mean(steps, axis=0), 0.0, atol=4 * 1e-3 * math.sqrt(0.1) / math.sqrt(20000))


def test_imu_star_tracker_and_accelerometer_noise_and_independent_streams():
    """The star tracker's body-frame error has its sigma per axis; the accelerometer's noise its sigma; sampling the
    star tracker leaves the gyro and accelerometer draws unchanged."""
    sigma = math.radians(0.01)
    a = ImuModel(np.random.default_rng(13), sigma, 1e-5, 1e-4, 1e-7, 1e-4)
    b = ImuModel(np.random.default_rng(13), sigma, 1e-5, 1e-4, 1e-7, 1e-4)
    q_true = quat_normalize([0.3, -0.2, 0.5, 0.7])
    star, accel = [], []
    for k in range(1, 20001):
        x = a.sample(0.1 * k, True, q_true, (0.01, 0.0, 0.0), (0.1, 0.0, 0.0))
        y = b.sample(0.1 * k, False, q_true, (0.01, 0.0, 0.0), (0.1, 0.0, 0.0))
        np.testing.assert_array_equal(x.omega_body_meas, y.omega_body_meas)
        np.testing.assert_array_equal(x.specific_force_body, y.specific_force_body)
        star.append(rotation_vector_from_quat(quat_multiply(quat_conjugate(q_true), x.q_hill_from_body)))
        accel.append(x.specific_force_body - (0.1, 0.0, 0.0))
    np.testing.assert_allclose(np.std(star, axis=0), sigma, rtol=0.03)
    np.testing.assert_allclose(np.std(accel, axis=0), 1e-4, rtol=0.03)
