"""The event payload records: every one round-trips through the wire's text, and every name is an event."""

import dataclasses
import typing

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_msgs_py import event_payloads as ep
from flyby_msgs_py import events
from flyby_msgs_py.wire import Event, wire_event

_FLOATS = st.floats(allow_nan=False)
_KINDS = {float: _FLOATS, int: st.integers(), str: st.text(), bool: st.booleans(),
          ep.Vector: st.lists(_FLOATS, min_size=1, max_size=4).map(tuple)}


def _record(cls):
    fields = {}
    for f in dataclasses.fields(cls):
        hint = typing.get_type_hints(cls)[f.name]
        optional = type(None) in typing.get_args(hint)
        strategy = _KINDS[ep._kind(cls, f.name)]
        fields[f.name] = st.none() | strategy if optional else strategy
    return st.builds(cls, **fields)


@pytest.mark.parametrize('cls', sorted(set(ep.PAYLOADS.values()), key=lambda c: c.NAME))
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_round_trip_through_the_wire(cls, data):
    record = data.draw(_record(cls))
    wired = wire_event(Event(12.5, 'OK', cls.NAME, 'a message', ep.encode(record), 'a_node'))
    assert ep.decode(wired) == record


def test_every_payload_names_an_event():
    assert set(ep.PAYLOADS) <= events.ALL
    assert all(ep.PAYLOADS[name].NAME == name for name in ep.PAYLOADS)


def test_extra_keys_pass_through_after_the_fields():
    record = ep.PhaseChanged('PLANNING', 'TERMINAL_APPROACH')
    values = ep.encode(record, {'t_grasp_s': 813.0, 'note': 'kept'})
    assert list(values) == ['from', 'to', 't_grasp_s', 'note']
    assert ep.decode_values(events.PHASE_CHANGED, values) == record
    with pytest.raises(ValueError):
        ep.encode(record, {'to': 'ESCAPE'})


def test_the_text_is_the_emitters():
    """Numpy values encode to the text the emitter's own values have; decode reads text or numbers."""
    raw = {'com_body_m': np.array([0.1, -0.2, 0.3]), 'com_sigma_m': np.float64(0.01) * np.ones(3), 'coast_s': 0}
    record = ep.TransportComEstimate(**raw)
    assert wire_event(Event(1.0, 'OK', record.NAME, '', ep.encode(record), 'n')).values == \
        wire_event(Event(1.0, 'OK', record.NAME, '', raw, 'n')).values
    assert ep.decode_values(events.TRANSPORT_COM_ESTIMATE, raw) == record


def test_a_missing_required_key_is_an_error():
    with pytest.raises(KeyError):
        ep.decode_values(events.EXCITATION_SCHEDULED, {'excitation': 'wheels'})
