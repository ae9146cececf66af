"""When a sensor samples: the simulator's steps on which a sensor of a given rate takes its sample.

The plant samples by it; the estimator node orders the streams of several sensors by it (a sample it knows is
due is waited for), so it lives with the shared dynamics (no sensor model here).
"""

import math


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

    def sample_index(self, step_index):
        """k if step step_index is the step nearest the sample time k / rate_hz, else None."""
        samples_per_step = self._samples_per_step
        k = math.floor(step_index * samples_per_step + 0.5)
        return k if math.floor(k / samples_per_step + 0.5) == step_index else None

    def next_sample_step(self, step_index):
        """The first step after step_index on which a sample is taken."""
        k = math.floor(step_index * self._samples_per_step + 0.5)  # no sample before k falls after this step
        while True:
            step = math.floor(k / self._samples_per_step + 0.5)
            if step > step_index:
                return step
            k += 1
