"""The independent monitor's target attitude (flyby_mission.cam_attitude): a torque-free fit to noisy vision
attitudes predicts a nutating tumbler 3.5 s ahead within a degree, where the vision sensor's noise is 2.5 deg."""

import math

import numpy as np
import pytest

from flyby_mission.cam_attitude import TargetAttitudeFit
from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.orbital import q_hill_from_body_many
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    rotation_vector_from_quat,
)

INERTIA = ((1200.0, 0.0, 0.0), (0.0, 1000.0, 0.0), (0.0, 0.0, 2000.0))
N = 0.00108  # 7000 km


@pytest.mark.parametrize('seed', range(4))
def test_a_nutating_tumbler_is_predicted_three_and_a_half_seconds_ahead_within_a_degree(seed):
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    omega0 = math.radians(12.0) * axis / np.linalg.norm(axis)  # off every principal axis: it nutates
    times = np.arange(0.1, 40.05, 0.1)
    q_eci, _ = AttitudePropagator((0.0, 0.0, 0.0, 1.0), omega0, INERTIA).states_at(np.append(times, 43.5))
    q_hill = q_hill_from_body_many(np.append(times, 43.5), N, q_eci)
    fit = TargetAttitudeFit(INERTIA, N)
    for t, q in zip(times, q_hill[:-1], strict=True):
        noise = quat_from_rotation_vector(math.radians(2.5) * rng.standard_normal(3))
        fit.add(t, quat_multiply(noise, q))
    predicted = fit.q_hill_at(40.0, np.array([43.5]))[0]
    error = rotation_vector_from_quat(quat_multiply(predicted, quat_conjugate(q_hill[-1])))
    assert math.degrees(np.linalg.norm(error)) < 1.0
