"""flyby_msgs_py.wire does to values exactly what the messages do: the headless driver's promise that
its cores receive the graph's numbers to the bit rests on these properties."""

import json
import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from flyby_msgs_py import convert
from flyby_msgs_py.wire import Event, value_text, values_text, wire_event, wire_time

SIM_TIMES = st.floats(min_value=0.0, max_value=1.0e6, allow_nan=False)
FINITE = st.floats(allow_nan=False, allow_infinity=False, width=64)


@given(SIM_TIMES)
def test_wire_time_is_what_a_stamp_carries(t):
    assert wire_time(t) == convert.stamp_to_sec(convert.sec_to_stamp(t))


@given(st.integers(min_value=0, max_value=20_000_000))
def test_plant_step_times_survive_twice(k):
    """A stamp read back and stamped again is unchanged (a core re-publishing a received stamp)."""
    t = wire_time(k * 0.05)
    assert wire_time(t) == t


@given(FINITE, st.lists(FINITE, max_size=6))
def test_values_read_back_are_the_same_numbers(x, xs):
    assert float(value_text(x)) == x
    assert json.loads(value_text(np.array(xs))) == xs


@given(SIM_TIMES, st.dictionaries(st.text(min_size=1, max_size=8), st.one_of(FINITE, st.booleans(), st.text())))
def test_wire_event_equals_the_message_round_trip(t, values):
    event = Event(t, 'WARN', 'test_event', 'a message', values, 'flyby_test')
    (read,) = convert.events_from_msg(convert.event(t, 'WARN', 'test_event', 'a message', values, source='flyby_test'))
    wired = wire_event(event)
    assert wired.t == read['t'] and wired.values == read['values'] == values_text(values)
    assert (wired.level, wired.name, wired.message, wired.source) == (read['level'], read['name'], read['message'],
                                                                      read['source'])
    assert all(math.isfinite(float(v)) for k, v in wired.values.items() if isinstance(values[k], float))
