"""The simulator's measurement streams handed on in the plant's own order, whatever order they arrive in.

The plant takes, at each step, the relative position before the chaser's IMU sample (flyby_sim.plant), and the
headless driver hands them to the estimator in that order. Over DDS each topic keeps its own order, but two
topics may interleave differently from run to run, and the chaser estimate of an IMU sample depends on
whether the position of the same stamp was in. ``MeasurementOrder`` restores the plant's order: it knows
each stream's sample steps (``flyby_sim.dynamics.sampling``), so a sample that must come first and has not
arrived is waited for, and nothing else is.

How long a sample is waited for, in stamps: until the receiver's clock (``/clock``) of its step, or a later sample of
its own stream. The simulator sends a step's clock after all of the step's samples, and a node's executor handles
its messages in arrival order (flyby_msgs_py.runtime.ProgressReporter: a node that has handled the clock of t has
handled every measurement of t), so a sample not in by then was never sent (a sensor_dropout), was dropped on its
way (a topic_loss) or is held late (a topic_delay): it is given up, and what it held back goes on. Not later: the
simulator holds its time for the attitude command each IMU sample leads to (flyby_sim.sim_node), so while a sample
is waited for, no later IMU sample comes, and with an IMU sampled every step (or a capture decision held for) no
later clock either; an estimator waiting longer would stop the graph (a relative position lost held it at 10.15 s
of paper_flyby_6dof before this bound). A given-up sample that arrives after all goes to the estimator's core as
any late message (admitted if nothing newer of its stream came first, flyby_msgs_py.admission), behind the samples
of the steps up to the one it arrived at: where the headless driver's link hands it on (after that step's samples).
"""

import collections

from flyby_sim.dynamics.sampling import SampleSchedule


class MeasurementOrder:
    """Streams (name, rate [Hz]) in the plant's order within a step (first listed first), simulation step
    step_s [s]. ``push(name, t, item)`` and ``clock(t)`` (the receiver's clock of t [s]) return the items now due,
    in order, as (name, t, item)."""

    def __init__(self, step_s, streams):
        self.step_s = float(step_s)
        self._streams = [(name, SampleSchedule(rate_hz, step_s)) for name, rate_hz in streams]
        self._queues = {name: collections.deque() for name, _ in self._streams}
        # The last step each stream has delivered (none before the first step: the plant samples after it).
        self._last_step = dict.fromkeys(self._queues, 0)
        # The step up to which each stream's samples are in or given up: its next is expected after it.
        self._settled_step = dict.fromkeys(self._queues, 0)
        self._latest_step = 0  # the latest step of a sample or a clock that came in
        self._late = collections.deque()  # given-up samples that came after all: (step handed on after, name, t, item)

    def push(self, name, t, item):
        if name not in self._queues:
            raise ValueError(f'unknown stream {name!r}; streams: {sorted(self._queues)}')
        step = round(t / self.step_s)
        if step <= self._last_step[name]:
            raise ValueError(f'{name} sample of t = {t!r} s is not after its last one (step {self._last_step[name]})')
        self._last_step[name] = step
        # Late: given up, or behind a late sample of its own stream (a topic's link releases what it held at once,
        # the samples stamped at the clock that releases them included): a stream's own order is never changed.
        late = step <= self._settled_step[name] or any(late_name == name for _s, late_name, _t, _i in self._late)
        self._settled_step[name] = max(self._settled_step[name], step)
        self._latest_step = max(self._latest_step, step)
        if late:  # behind everything of the steps that came in so far
            self._late.append((self._latest_step, name, t, item))
        else:
            self._queues[name].append((step, t, item))
        return self._due()

    def clock(self, t):
        """The receiver's clock of t [s]: every sample of a step up to t's that has not come is given up."""
        step = round(t / self.step_s)
        self._latest_step = max(self._latest_step, step)
        for name, settled in self._settled_step.items():
            self._settled_step[name] = max(settled, step)
        return self._due()

    def _due(self):
        out = []
        late_priority = len(self._streams)  # a late sample goes after every stream's sample of its step
        while True:
            first = None
            for priority, (name, schedule) in enumerate(self._streams):
                queue = self._queues[name]
                # The stream's next sample: the one queued, else the one still to come.
                step = queue[0][0] if queue else schedule.next_sample_step(self._settled_step[name])
                key = (step, priority)
                if first is None or key < first[0]:
                    first = (key, name)
            if self._late and (self._late[0][0], late_priority) < first[0]:
                _step, name, t, item = self._late.popleft()
                out.append((name, t, item))
                continue
            queue = self._queues[first[1]]
            if not queue:  # the earliest sample is still on its way
                return out
            _step, t, item = queue.popleft()
            out.append((first[1], t, item))
