"""Time: simulation time [s] <-> integer nanoseconds <-> builtin_interfaces/Time, and rosgraph_msgs/Clock."""

import numpy as np
from builtin_interfaces.msg import Time
from rosgraph_msgs.msg import Clock

from flyby_msgs_py.convert.fields import _BOOL_TYPES, _describe, _frame, _scalar

NS_PER_S = 1_000_000_000

_INT32_MIN, _INT32_MAX = -2 ** 31, 2 ** 31 - 1


def sec_to_ns(t):
    """Simulation time [s] -> integer nanoseconds, rounded to nearest."""
    return round(_scalar(t, 't') * 1e9)


def ns_to_sec(ns):
    """Integer nanoseconds -> seconds (correctly rounded float)."""
    return _ns(ns) / 1e9


def _ns(ns):
    if not isinstance(ns, (int, np.integer)) or isinstance(ns, _BOOL_TYPES):
        raise ValueError(f'ns: must be an integer, got {_describe(ns)}')
    return int(ns)


def _stamp_into(stamp, t):
    """Write simulation time t [s] (or a Time) into an existing Time message."""
    if type(t) is not float and isinstance(t, Time):
        stamp.sec, stamp.nanosec = t.sec, t.nanosec
        return
    stamp.sec, stamp.nanosec = _stamp_parts(t)


def _stamp_parts(t):
    """(sec, nanosec) of builtin_interfaces/Time for simulation time t [s], rounded to the nanosecond."""
    if type(t) is not float:
        t = _scalar(t, 't')
    try:
        sec, nanosec = divmod(round(t * 1e9), NS_PER_S)
    except (ValueError, OverflowError):
        raise ValueError(f't: must be finite, got {t!r}') from None
    if not _INT32_MIN <= sec <= _INT32_MAX:
        raise ValueError(f't: {t!r} s does not fit builtin_interfaces/Time (int32 seconds)')
    return sec, nanosec


def ns_to_stamp(ns):
    """Integer nanoseconds -> Time, exactly (nanosec in [0, 1e9), also for negative times)."""
    sec, nanosec = divmod(_ns(ns), NS_PER_S)
    if not _INT32_MIN <= sec <= _INT32_MAX:
        raise ValueError(f'ns: {ns} does not fit builtin_interfaces/Time (int32 seconds)')
    return Time(sec=sec, nanosec=nanosec)


def stamp_to_ns(stamp):
    """Time -> integer nanoseconds, exactly."""
    return stamp.sec * NS_PER_S + stamp.nanosec


def sec_to_stamp(t):
    """Simulation time [s] -> Time, rounded to the nearest nanosecond."""
    stamp = Time()
    _stamp_into(stamp, t)
    return stamp


def stamp_to_sec(stamp):
    """Time -> seconds (the float nearest the exact nanosecond count)."""
    return (stamp.sec * NS_PER_S + stamp.nanosec) / 1e9


def clock(t, out=None):
    """rosgraph_msgs/Clock at simulation time t [s] (``out``: a message to fill instead)."""
    msg = Clock() if out is None else out
    _stamp_into(msg.clock, t)
    return msg


def clock_to_sec(msg):
    return stamp_to_sec(msg.clock)


def _with_header(msg, t, frame_id):
    """``msg`` with its header set: stamp t [s] (sim time) and frame_id."""
    _stamp_into(msg.header.stamp, t)
    msg.header.frame_id = _frame(frame_id)
    return msg
