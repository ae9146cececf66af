"""The link between a topic's publisher and one receiver under the scenario's topic faults (docs/faults.md).

A ``topic_delay`` makes the messages of one topic stamped in the fault's window reach the receiver ``value`` s after
their stamp, by the receiver's clock; a ``topic_loss`` drops them. The fault acts on the link, not on the publisher:
the bag records what was published. Both drivers apply this one rule at the receiving side, before the message's
admission (flyby_msgs_py.admission): the node's ``AdmissionGate`` (flyby_msgs_py.node_base) in the graph, the
headless driver's dispatcher (flyby_mission.headless) without ROS, one ``LinkFaults`` per receiving node.

The receiver learns a fault from the simulator's ``fault_injected`` event (its start and duration: the window of
stamps [t_start, t_start + duration), none: to the run's end), as the drivers learn a node_crash; the rule judges
each message by its stamp. The simulator sends a step's events after its samples (both drivers), so the samples of
the window's first step, and in the graph an estimate that beats the event to its receiver, pass before the fault is
known. The link keeps each topic's order (a queue): once a message is held, the ones after it wait behind it even
past the window. A held message is admitted when it is released, at the receiver's time then: one older than
``admission.MAX_AGE_S`` would be refused there as far in the past, so a delay is bounded by it (longer is a loss).
No ROS here.
"""

import collections
import math

from flyby_msgs_py import contract as c
from flyby_msgs_py import events
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
# The health monitor's component (flyby_estimation.health) of the sensor a topic carries: what a fault's detection
# names (a loss is seen as the sensor's staleness). The estimates and the tachometers have no such monitor.
SENSOR_OF_TOPIC = {c.SENSOR_RELATIVE_POSITION: 'relative_position', c.SENSOR_TARGET_ATTITUDE: 'target_attitude'}
STAMP_TOLERANCE_S = 1e-9  # stamps are whole nanoseconds


def fault_target(topic):
    """The target text of a link fault on ``topic`` (its events' ``target``)."""
    return f'topic {topic}'


class LinkFaults:
    """One receiver's links (module doc): ``on_event`` learns the faults, ``arrive`` takes a message as it comes,
    ``due`` gives the held ones whose time has come."""

    def __init__(self):
        self.windows = collections.defaultdict(list)  # topic -> [(kind, t_start [s], t_end [s], delay [s])]
        self.held = collections.defaultdict(collections.deque)  # topic -> (release [s], sequence, item), in order
        self._sequence = 0

    def on_event(self, name, values):
        """A mission/events event (its name and values, text or numbers): a link fault's ``fault_injected`` opens its
        window. True if it was one."""
        if name != events.FAULT_INJECTED or values.get('kind') not in KINDS:
            return False
        fault = decode_values(name, values)
        t_end = math.inf if fault.duration_s is None else fault.t_start + fault.duration_s
        delay_s = fault.value if fault.kind == TOPIC_DELAY else None
        self.windows[fault.target.split(' ', 1)[1]].append((fault.kind, fault.t_start, t_end, delay_s))
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
        self.held[topic].append((release_s, self._sequence, item))
        return []

    def due(self, now_s):
        """(topic, item) of the held messages released by the receiver's time now_s [s], in their release order."""
        if not self.held:
            return []
        out = []
        for topic, queue in self.held.items():
            while queue and queue[0][0] <= now_s + STAMP_TOLERANCE_S:
                release_s, sequence, item = queue.popleft()
                out.append((release_s, sequence, topic, item))
        return [(topic, item) for _, _, topic, item in sorted(out, key=lambda x: x[:2])]
