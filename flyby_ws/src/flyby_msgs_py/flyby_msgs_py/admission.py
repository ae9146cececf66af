"""Admission of the messages a node takes: what a subscriber refuses before its core sees it (docs/runtime.md).

Any process on the ROS domain may publish on a contract topic. A message that no node of ours could have sent
(a NaN or an infinite number, a quaternion that is not a rotation, a stamp that is no time of this run or that
goes back on a stream, a frame the contract does not give the topic) must not reach a core: an estimator fed one
NaN, or one measurement stamped a day ahead, is lost for the rest of the run. Every subscriber checks every message
against the rules of its topic (``RULES``, next to the contract: ``flyby_msgs_py.contract``) and counts what it
refuses by topic and reason; the node (``flyby_msgs_py.node_base``) reports the first refusal of each kind on
mission/events (``message_rejected``) and the counts in its log at shutdown. The headless driver admits what it
routes by the same rules. A well-formed message that says something false (a valid measurement from a rogue
publisher) is beyond what a subscriber can tell from the message alone. No ROS here.
"""

import collections
import math
from typing import NamedTuple

import numpy as np

from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.wire import WARN, Event

# The reasons for a refusal, each the value of ``Admission.check`` and the ``reason`` of the event.
NAN = 'nan'
INFINITE = 'infinite'
NON_UNIT_QUATERNION = 'non_unit_quaternion'
WRONG_FRAME = 'wrong_frame_id'
FUTURE_STAMP = 'future_stamp'
PAST_STAMP = 'far_past_stamp'
OUT_OF_ORDER = 'out_of_order'
DUPLICATE_STAMP = 'duplicate_stamp'
MALFORMED = 'malformed'
REASONS = (MALFORMED, NAN, INFINITE, NON_UNIT_QUATERNION, WRONG_FRAME, FUTURE_STAMP, PAST_STAMP, OUT_OF_ORDER,
           DUPLICATE_STAMP)

QUATERNION_NORM_TOLERANCE = 1e-3
"""|q| farther from 1 than this is no rotation. The message builders (flyby_msgs_py.convert) refuse a quaternion
this far off and normalize anything closer, so every quaternion one of our nodes sends has |q| = 1 to round-off."""

MAX_LEAD_S = 30.0
"""How far [s] the stamp of a time of the run (a measurement, an estimate, a command, a plan's time) may be ahead
of the receiving node's latest known sim time. A message may come before the /clock (or /flyby/tick) of its time:
the simulator runs at most two flow-control periods ahead of the slowest node it keeps up with (it looks every
period, and lets a node trail by one: 2 s in the launcher, 10 s at the simulator's default 5 s), a node that reads
/flyby/tick knows the time to within its period (0.5 s), and an attitude command is stamped one control period
(the IMU's) after the estimate it answers. 30 s covers the default's 10.6 s three times over."""

PLAN_HORIZON_S = 864_000.0
"""How far [s] a planned time (a burn's start, a grasp time, a trajectory's start, the time an event names) may be
ahead of the receiving node's sim time: ten days, longer than anything the methods plan (the longest, a transport
or an orbit advance, spans a few orbits, of a day at most even in geostationary orbit)."""

MAX_AGE_S = 60.0
"""How far [s] a stamp may be behind the receiving node's latest known sim time. A message of the run trails a
reader's clock by at most the simulator's lead over its slowest node (MAX_LEAD_S: at most 10.6 s); one older than
a minute comes from no live publisher of this run. A stamp before 0 (the simulator's first step) is never a time
of the run."""


class Rule(NamedTuple):
    """How a topic's messages are admitted: the header.frame_id the contract gives it; ``stream``: one publisher,
    one message per stamp, so stamps strictly increase (sensors, estimates, attitude commands), else they may repeat
    and come in any order (events of several nodes, plans that a re-aim moves back, burns of guidance and of the
    supervisor); ``planned``: the stamp names a planned time (bounded ahead by PLAN_HORIZON_S), else a time of the
    run (MAX_LEAD_S); ``quaternions``: the arrays holding unit quaternions (x, y, z, w), one a row; ``finite``: the
    arrays that must be finite (None: every one; a JointState leaves the fields it does not fill empty or NaN);
    ``unique``: a repeat of an admitted message (the same stamp and numbers) is a duplicate even off a stream (a
    burn sent twice would be flown twice)."""

    frame_id: str
    stream: bool
    planned: bool
    quaternions: tuple = ()
    finite: tuple = None
    unique: bool = False


# The topics a node takes (flyby_msgs_py.wiring) and the recorded estimates, by contract name; the arrays by the
# names of their flyby_msgs_py.convert readers. mission/phase carries no header: nothing to admit but its text.
RULES = {
    c.SENSOR_RELATIVE_POSITION: Rule(c.FRAME_HILL, stream=True, planned=False),
    c.SENSOR_TARGET_ATTITUDE: Rule(c.FRAME_HILL, stream=True, planned=False, quaternions=('value',)),
    c.SENSOR_CHASER_IMU: Rule(c.FRAME_CHASER_BODY, stream=True, planned=False, quaternions=('orientation_xyzw',)),
    c.SENSOR_CHASER_WHEELS: Rule(c.FRAME_CHASER_BODY, stream=True, planned=False, finite=('velocity',)),
    c.EST_TARGET_ODOM: Rule(c.FRAME_HILL, stream=True, planned=False, quaternions=('orientation_xyzw',)),
    c.EST_CHASER_ODOM: Rule(c.FRAME_HILL, stream=True, planned=False, quaternions=('orientation_xyzw',)),
    c.EST_TARGET_INERTIA: Rule(c.FRAME_CHASER_BODY, stream=True, planned=False),
    c.PLANNER_GRASP: Rule(c.FRAME_HILL, stream=False, planned=True, quaternions=('orientation_xyzw',)),
    c.PLANNER_FLYBY_TARGET: Rule(c.FRAME_HILL, stream=False, planned=True, quaternions=('orientation_xyzw',)),
    c.PLANNER_FLYBY_INITIAL: Rule(c.FRAME_HILL, stream=False, planned=True, quaternions=('orientation_xyzw',)),
    c.PLANNER_PATH: Rule(c.FRAME_HILL, stream=False, planned=False, quaternions=('orientations',)),
    c.PLANNER_TRAJECTORY: Rule(c.FRAME_HILL, stream=False, planned=True),
    c.GUIDANCE_MANEUVER: Rule(c.FRAME_HILL, stream=False, planned=True, unique=True),
    c.SAFETY_CAM: Rule(c.FRAME_HILL, stream=False, planned=True, unique=True),
    c.GUIDANCE_WHEELS: Rule(c.FRAME_CHASER_BODY, stream=True, planned=False, finite=('effort',)),
    c.GUIDANCE_WRENCH: Rule(c.FRAME_CHASER_BODY, stream=True, planned=False),
    c.MISSION_EVENTS: Rule('', stream=False, planned=True),  # a maneuver_commanded names its burn's start
}


def _non_finite(a):
    """NAN or INFINITE for an array with such an entry, else None."""
    if np.isfinite(a).all():
        return None
    return NAN if np.isnan(a).any() else INFINITE


def _numbers_reason(rule, arrays):
    """NAN, INFINITE or NON_UNIT_QUATERNION for a message whose arrays break the rule, else None."""
    for name, a in arrays.items():
        if a is not None and (rule.finite is None or name in rule.finite):
            reason = _non_finite(a)
            if reason is not None:
                return reason
    for name in rule.quaternions:
        q = arrays.get(name)
        if q is not None and len(q) and not _unit(q):
            return NON_UNIT_QUATERNION
    return None


_UNIT_NORM2 = ((1.0 - QUATERNION_NORM_TOLERANCE) ** 2, (1.0 + QUATERNION_NORM_TOLERANCE) ** 2)


def _unit(q):
    """Whether the quaternion (4,), or each row of (N, 4), is within QUATERNION_NORM_TOLERANCE of unit length."""
    low, high = _UNIT_NORM2
    if q.ndim == 1:
        return low <= float(q @ q) <= high
    norm2 = np.einsum('ij,ij->i', q, q)
    return bool(np.all((norm2 >= low) & (norm2 <= high)))


class Admission:
    """The admission of one subscriber's messages (module doc): ``check`` each, counts by topic (``admitted``) and
    by (topic, reason) (``rejected``), the last stamp admitted on each stream, what was admitted of a unique
    topic."""

    def __init__(self):
        self.rules = RULES
        self.last_stamp_s = {}
        self.seen = collections.defaultdict(set)
        self.admitted = collections.Counter()
        self.rejected = collections.Counter()

    def check(self, topic, t_stamp_s, frame_id, arrays=None, now_s=None):
        """None if the message is admitted, else the reason it is refused (counted). ``arrays``: name -> the
        message's numbers (None for a field it does not carry); ``now_s``: the node's latest known sim time [s],
        None if it knows none (then the stamp is checked against the topic's own past only)."""
        rule = self.rules.get(topic)
        reason = None if rule is None else self._reason(rule, topic, t_stamp_s, frame_id, arrays, now_s)
        if reason is None:
            self.admitted[topic] += 1
        else:
            self.rejected[topic, reason] += 1
        return reason

    def refuse(self, topic, reason):
        """Count a message refused before ``check`` could read it (MALFORMED)."""
        self.rejected[topic, reason] += 1

    def _reason(self, rule, topic, t, frame_id, arrays, now_s):
        if arrays:
            reason = _numbers_reason(rule, arrays)
            if reason is not None:
                return reason
        if frame_id != rule.frame_id:
            return WRONG_FRAME
        if not math.isfinite(t):
            return NAN if math.isnan(t) else INFINITE
        if now_s is not None and t - now_s > (PLAN_HORIZON_S if rule.planned else MAX_LEAD_S):
            return FUTURE_STAMP
        if t < 0.0 or (now_s is not None and t < now_s - MAX_AGE_S and topic not in c.LATCHED_TOPICS):
            return PAST_STAMP  # a latched topic's last message is its value now, however old (a late joiner's)
        if rule.stream:
            last = self.last_stamp_s.get(topic)
            if last is not None and t <= last:
                return DUPLICATE_STAMP if t == last else OUT_OF_ORDER
            self.last_stamp_s[topic] = t
        elif rule.unique and arrays:  # the numbers given (the headless driver checks stamps only)
            key = (t, *(np.asarray(v).tobytes() for _, v in sorted(arrays.items()) if v is not None))
            if key in self.seen[topic]:
                return DUPLICATE_STAMP
            self.seen[topic].add(key)
        return None

    def rejection_event(self, topic, reason, t_stamp_s, now_s):
        """The WARN ``message_rejected`` Event of the latest refusal of (topic, reason) if it is the 1st, 10th,
        100th ... of them (a flood shows on mission/events without flooding it), else None; stamped at the node's
        sim time (the refused stamp may be no time of the run: it is in the values)."""
        count = self.rejected[topic, reason]
        if str(count).rstrip('0') != '1':  # not a power of ten
            return None
        record = event_payloads.MessageRejected(topic=topic, reason=reason, count=count, t_stamp_s=float(t_stamp_s))
        return Event(0.0 if now_s is None else now_s, WARN, events.MESSAGE_REJECTED,
                     f'{topic}: message refused ({reason}, stamp {t_stamp_s!r} s), {count} so far',
                     event_payloads.encode(record))

    def summary(self):
        """One line of the counts by topic (admitted, and refused by reason), for the node's log at shutdown."""
        topics = sorted(set(self.admitted) | {topic for topic, _ in self.rejected})
        parts = []
        for topic in topics:
            refused = ', '.join(f'{reason} {n}' for (t, reason), n in sorted(self.rejected.items()) if t == topic)
            parts.append(f'{topic}: {self.admitted[topic]} admitted' + (f', refused {refused}' if refused else ''))
        return 'messages: ' + ('; '.join(parts) if parts else 'none')
