"""Noisy measurements of the relative position and the target attitude, and their schedule.

Quaternions are (x, y, z, w), scalar last. The attitude measurement is
q_meas = q_hill_from_body * dq, where dq's rotation vector is Gaussian with attitude_sigma_rad per
body axis (a body-frame error, as a camera fixed to the chaser sees the target's markers).

Each sensor draws from its own child stream of the generator given (Generator.spawn), so adding a
sensor, or sampling one at another rate, leaves the others' draws unchanged.
"""

import math

import numpy as np

from flyby_sim.dynamics.rotation import quat_multiply, quat_normalize, random_small_rotation


class SensorModel:
    """Relative-position and target-attitude sensors with Gaussian noise."""

    def __init__(self, rng, position_sigma_m, attitude_sigma_rad):
        """rng: numpy.random.Generator; sigmas are 1-sigma per axis [m], [rad]."""
        for name, value in (('position_sigma_m', position_sigma_m),
                            ('attitude_sigma_rad', attitude_sigma_rad)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'{name} must be finite and >= 0, got {value}')
        self.position_sigma_m = position_sigma_m
        self.attitude_sigma_rad = attitude_sigma_rad
        self._rng_position, self._rng_attitude = rng.spawn(2)

    def relative_position(self, r_hill):
        """Noisy chaser position [m] in hill: r_hill + N(0, position_sigma_m^2) per axis."""
        return np.asarray(r_hill, dtype=float) + self.position_sigma_m * self._rng_position.standard_normal(3)

    def target_attitude(self, q_hill_from_body):
        """Noisy unit quaternion q_hill_from_body * dq (module doc)."""
        dq = random_small_rotation(self._rng_attitude, self.attitude_sigma_rad)
        return quat_normalize(quat_multiply(q_hill_from_body, dq))


def is_sample_step(step_index, rate_hz, step_s):
    """True if step step_index (at t = step_index * step_s) is the step nearest some t = k / rate_hz.

    Deterministic and stateless. Requires rate_hz * step_s <= 1 (at most one sample per step), so each
    sample time k / rate_hz maps to its own step.
    """
    return SampleSchedule(rate_hz, step_s).is_sample_step(step_index)


class SampleSchedule:
    """``is_sample_step`` for one rate and step, validated once (the plant asks every step)."""

    def __init__(self, rate_hz, step_s):
        if not (math.isfinite(rate_hz) and rate_hz > 0.0):
            raise ValueError(f'rate_hz must be finite and > 0, got {rate_hz}')
        samples_per_step = rate_hz * step_s
        if not (math.isfinite(samples_per_step) and 0.0 < samples_per_step <= 1.0):
            raise ValueError(f'rate_hz {rate_hz} with step_s {step_s} gives more than one sample per step')
        self._samples_per_step = samples_per_step

    def is_sample_step(self, step_index):
        """True if step step_index is the step nearest some sample time (``is_sample_step``)."""
        samples_per_step = self._samples_per_step
        k = math.floor(step_index * samples_per_step + 0.5)  # the only sample that can round to this step
        return math.floor(k / samples_per_step + 0.5) == step_index
