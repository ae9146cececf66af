"""The link between a topic's publisher and one receiver under the scenario's topic faults (docs/faults.md).

A ``topic_delay`` makes the messages of one topic stamped in the fault's window reach the receiver ``value`` s after
their stamp, by the receiver's clock; a ``topic_loss`` drops them. The fault acts on the link, not on the publisher:
the bag records what was published. Both drivers apply this one rule at the receiving side, before the message's
admission (flyby_msgs_py.admission): the node's ``AdmissionGate`` (flyby_msgs_py.node_base) in the graph, the
headless driver's dispatcher (flyby_mission.headless) without ROS, one ``LinkFaults`` per receiving node.

The receiver learns a fault from the simulator's ``fault_injected`` event (its start and duration: the window of stamps
[t_start, t_start + duration), none: to the run's end), as the drivers learn a node_crash; the rule judges each message
by its stamp. An event of a link fault that cannot be read as one (a key missing or no number, a target that is no topic
of ``TOPICS``, a delay outside (0, ``admission.MAX_AGE_S``]) is refused here, for both drivers alike: one line in the
receiver's log naming it, no window opened, no exception. The simulator sends a step's events after its samples (both
drivers), so the samples of the window's first step, and in the graph an estimate that beats the event to its receiver,
pass before the fault is known. The link keeps each topic's order (a queue): once a message is held, the ones after it
wait behind it even past the window. A held message is admitted when it is released, at the receiver's time then: one
older than ``admission.MAX_AGE_S`` would be refused there as far in the past, so a delay is bounded by it (longer is a
loss).
No ROS here.
"""

import collections
import logging
import math

from flyby_msgs_py import contract as c
from flyby_msgs_py import events
from flyby_msgs_py.admission import MAX_AGE_S
from flyby_msgs_py.event_payloads import decode_values

TOPIC_DELAY = 'topic_delay'
TOPIC_LOSS = 'topic_loss'
KINDS = (TOPIC_DELAY, TOPIC_LOSS)
# The topics a link fault may act on: each stamped at its sending (a sample's or an estimate's time; a burn's and a
# plan's stamps are planned times, which a delay by stamp would misread) and taken by flight-software nodes only (the
# simulator's commands hold its lockstep: a lost one would stop the graph). The clock, mission/phase and
# mission/events carry the run itself.
TOPICS = (c.SENSOR_RELATIVE_POSITION, c.SENSOR_TARGET_ATTITUDE, c.SENSOR_CHASER_WHEELS, c.EST_TARGET_ODOM,
          c.EST_CHASER_ODOM)
# The component a detection of a topic's loss or delay names (its staleness): the sensor a sensor topic carries (the
# estimator's monitors, flyby_estimation.health), the estimate an estimate topic carries (the supervisor's estimate-age
# monitor, flyby_mission.estimate_age). The summary counts such a detection as the topic fault's (run_events).
COMPONENT_OF_TOPIC = {c.SENSOR_RELATIVE_POSITION: 'relative_position', c.SENSOR_TARGET_ATTITUDE: 'target_attitude',
                      c.SENSOR_CHASER_WHEELS: 'tachometers', c.EST_TARGET_ODOM: 'target_estimate',
                      c.EST_CHASER_ODOM: 'chaser_estimate'}
STAMP_TOLERANCE_S = 1e-9  # stamps are whole nanoseconds
TARGET_PREFIX = 'topic '


def fault_target(topic):
    """The target text of a link fault on ``topic`` (its events' ``target``)."""
    return f'{TARGET_PREFIX}{topic}'


def watches(faults, topics):
    """Whether a receiver of ``topics`` has a link fault among the scenario's ``faults`` (its list, or None): only
    such a receiver hears the simulator's events for its link, in both drivers (a refused event is logged by it)."""
    return any(f.type in KINDS and f.topic in topics for f in faults or ())


def _window(values):
    """(topic, (kind, t_start [s], t_end [s], delay [s] or None)) of a link fault's fault_injected values; raises
    ValueError saying why for values that are no such fault (module doc)."""
    try:
        fault = decode_values(events.FAULT_INJECTED, values)
    except KeyError as err:
        raise ValueError(f'no {err.args[0]}') from None
    except (ValueError, TypeError) as err:
        raise ValueError(f'a value is no number ({err})') from None
    topic = fault.target[len(TARGET_PREFIX):] if fault.target.startswith(TARGET_PREFIX) else None
    if topic not in TOPICS:
        raise ValueError(f'target {fault.target!r} is no {TARGET_PREFIX!r} of {", ".join(TOPICS)}')
    if not math.isfinite(fault.t_start) or not (fault.duration_s is None or fault.duration_s >= 0.0):
        raise ValueError(f't_start {fault.t_start!r} and duration_s {fault.duration_s!r} are no window')
    delay_s = None
    if fault.kind == TOPIC_DELAY:
        delay_s = fault.value
        if delay_s is None or not 0.0 < delay_s <= MAX_AGE_S:
            raise ValueError(f'delay {delay_s!r} s is not in (0, {MAX_AGE_S:g}]')
    t_end = math.inf if fault.duration_s is None else fault.t_start + fault.duration_s
    return topic, (fault.kind, fault.t_start, t_end, delay_s)


class LinkFaults:
    """One receiver's links (module doc): ``on_event`` learns the faults, ``arrive`` takes a message as it comes,
    ``due`` gives the held ones whose time has come. ``log(line)`` takes a refused event's line (module doc): the
    node's logger in the graph, this module's Python logger by default (headless)."""

    def __init__(self, log=None):
        self.windows = collections.defaultdict(list)  # topic -> [(kind, t_start [s], t_end [s], delay [s])]
        self.held = {}  # topic -> deque of (release [s], sequence, item), in order; a topic holding none has none
        self.log = log or logging.getLogger(__name__).warning
        self._sequence = 0

    def on_event(self, name, values):
        """A mission/events event (its name and values, text or numbers): a link fault's ``fault_injected`` opens its
        window. True if it opened one; a link fault's event that is no such fault is refused (module doc)."""
        if name != events.FAULT_INJECTED or values.get('kind') not in KINDS:
            return False
        try:
            topic, window = _window(values)
        except ValueError as why:
            self.log(f'link faults: {name} {dict(values)} refused: {why}')
            return False
        self.windows[topic].append(window)
        return True

    def concerns(self, topic):
        """Whether a message of ``topic`` may be held or lost here (else ``arrive`` passes it on at once)."""
        return topic in self.windows

    def arrive(self, topic, t_stamp_s, item):
        """The items to hand on now for a message of ``topic`` stamped t_stamp_s [s] that reached the receiver: itself,
        or none (lost, or held until its release)."""
        if topic not in self.windows:
            return [item]
        release_s = t_stamp_s
        for kind, t_start, t_end, delay_s in self.windows[topic]:
            if t_start - STAMP_TOLERANCE_S <= t_stamp_s < t_end - STAMP_TOLERANCE_S:
                if kind == TOPIC_LOSS:
                    return []
                release_s = max(release_s, t_stamp_s + delay_s)
        queue = self.held.get(topic)
        if release_s == t_stamp_s and not queue:
            return [item]
        if queue:
            release_s = max(release_s, queue[-1][0])  # behind the messages held before it
        self._sequence += 1
        self.held.setdefault(topic, collections.deque()).append((release_s, self._sequence, item))
        return []

    def due(self, now_s):
        """(topic, item) of the held messages released by the receiver's time now_s [s], in their release order. A
        topic whose queue empties leaves ``held``: with nothing held this is one test, as on every step of a run."""
        if not self.held:
            return []
        out = []
        for topic, queue in list(self.held.items()):
            while queue and queue[0][0] <= now_s + STAMP_TOLERANCE_S:
                release_s, sequence, item = queue.popleft()
                out.append((release_s, sequence, topic, item))
            if not queue:
                del self.held[topic]
        return [(topic, item) for _, _, topic, item in sorted(out, key=lambda x: x[:2])]
