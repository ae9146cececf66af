"""The simulator's measurement streams handed on in the plant's own order, whatever order they arrive in.

The plant takes, at each step, the relative position before the chaser's IMU sample (flyby_sim.plant), and the
headless driver hands them to the estimator in that order. Over DDS each topic keeps its own order, but two
topics may interleave differently from run to run, and the chaser estimate of an IMU sample depends on
whether the position of the same stamp was in. ``MeasurementOrder`` restores the plant's order: it knows
each stream's sample steps (``flyby_sim.dynamics.sampling``), so a sample that must come first and has not
arrived is waited for, and nothing else is.
"""

import collections

from flyby_sim.dynamics.sampling import SampleSchedule


class MeasurementOrder:
    """Streams (name, rate [Hz]) in the plant's order within a step (first listed first), simulation step
    step_s [s]. ``push(name, t, item)`` returns the items now due, in order, as (name, t, item)."""

    def __init__(self, step_s, streams):
        self.step_s = float(step_s)
        self._streams = [(name, SampleSchedule(rate_hz, step_s)) for name, rate_hz in streams]
        self._queues = {name: collections.deque() for name, _ in self._streams}
        # The last step each stream has delivered (none before the first step: the plant samples after it).
        self._last_step = dict.fromkeys(self._queues, 0)

    def push(self, name, t, item):
        if name not in self._queues:
            raise ValueError(f'unknown stream {name!r}; streams: {sorted(self._queues)}')
        step = round(t / self.step_s)
        if step <= self._last_step[name]:
            raise ValueError(f'{name} sample of t = {t!r} s is not after its last one (step {self._last_step[name]})')
        self._last_step[name] = step
        self._queues[name].append((step, t, item))
        return self._due()

    def _due(self):
        out = []
        while True:
            first = None
            for priority, (name, schedule) in enumerate(self._streams):
                queue = self._queues[name]
                # The stream's next sample: the one queued, else the one still to come.
                step = queue[0][0] if queue else schedule.next_sample_step(self._last_step[name])
                key = (step, priority)
                if first is None or key < first[0]:
                    first = (key, name)
            queue = self._queues[first[1]]
            if not queue:  # the earliest sample is still on its way
                return out
            _step, t, item = queue.popleft()
            out.append((first[1], t, item))
