"""``StampedBuffer``: the recent values of one stream by stamp (sim time [s]); docs/runtime.md.

No rclpy: the node cores use it.
"""

import collections
import math

from flyby_msgs_py.wire import STAMP_TOLERANCE_S


class StampedBuffer:
    """The recent values of one stream by stamp, for decisions that must not depend on the order in
    which messages of *different* topics arrive (which varies with the pace of the run).

    A node that decides at "the first target estimate stamped at or after t" gets the same estimate
    at any real-time factor; "the latest target estimate when the chaser estimate came" it would not.
    """

    def __init__(self, maxlen=600):
        self._items = collections.deque(maxlen=maxlen)

    def add(self, t, value):
        self._items.append((t, value))

    @property
    def latest(self):
        """(stamp, value) of the newest item, or None."""
        return self._items[-1] if self._items else None

    @property
    def latest_t(self):
        return self._items[-1][0] if self._items else -math.inf

    def first_at_or_after(self, t):
        """(stamp, value) of the first item stamped >= t, or None."""
        return next(((ti, v) for ti, v in self._items if ti >= t), None)

    def last_at_or_before(self, t):
        """(stamp, value) of the last item stamped <= t, or None."""
        return next(((ti, v) for ti, v in reversed(self._items) if ti <= t), None)


def stamp_key(t):
    """A stamp [s] as a dictionary key, to the stamps' rounding (``wire.STAMP_TOLERANCE_S``)."""
    return round(t / STAMP_TOLERANCE_S)


def put_bounded(stamped, key, value, kept=16):
    """stamped[key] = value, the oldest entries dropped beyond ``kept`` (commands and samples that never found their
    pair)."""
    stamped[key] = value
    while len(stamped) > kept:
        stamped.pop(next(iter(stamped)))
