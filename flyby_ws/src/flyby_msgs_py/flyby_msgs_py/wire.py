"""What crosses a topic, as the cores see it: the event record and what a message does to values.

A core (plant, estimator, planner, guidance, supervisor) returns ``Event`` records; a node publishes
them with ``convert.event``, the headless driver hands them to the other cores through ``wire_event``,
which does to them what the message does. Values travel as text (``value_text``): floats with repr
precision, so a float read back with ``float()`` is the same number, sequences as JSON lists. A stamp
carries whole nanoseconds (``wire_time``). With both applied the cores receive the same numbers from
the headless driver as from the graph, to the bit. No ROS here.
"""

import json
from typing import NamedTuple

import numpy as np

OK = 'OK'
WARN = 'WARN'
ERROR = 'ERROR'
STALE = 'STALE'
LEVELS = (OK, WARN, ERROR, STALE)  # an event's level, least severe first


class Event(NamedTuple):
    """A decision, warning or fault: sim time t [s], level (LEVELS), name (the kind of event, e.g.
    'late_maneuver'), a one-line message, values (key -> value; text once it has travelled) and the
    source (the emitting node's name)."""

    t: float
    level: str
    name: str
    message: str
    values: dict
    source: str = ''


def value_text(v):
    """The text of one event value: floats by repr, bools 'true'/'false', sequences as JSON lists."""
    if isinstance(v, str):
        return v
    if isinstance(v, (bool, np.bool_)):
        return 'true' if v else 'false'
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, (list, tuple)):
        return json.dumps([float(x) if isinstance(x, (np.floating, np.integer)) else x for x in v])
    return str(v)


def values_text(values):
    """Every value of an event as text (value_text), keys as str."""
    return {str(k): value_text(v) for k, v in (values or {}).items()}


# Stamps closer than this are one instant: wire stamps are whole nanoseconds, sim times sums of steps [s].
STAMP_TOLERANCE_S = 1e-6


def wire_time(t):
    """The time [s] a stamp of sim time t carries: rounded to the nearest nanosecond (convert.sec_to_stamp)."""
    return round(t * 1e9) / 1e9


def wire_event(event):
    """The event as a subscriber reads it from mission/events: stamp in nanoseconds, values as text."""
    return event._replace(t=wire_time(event.t), values=values_text(event.values))
