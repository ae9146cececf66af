"""MeasurementOrder restores the plant's order of the measurement streams from any interleaving."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from flyby_estimation.measurement_order import MeasurementOrder
from flyby_sim.dynamics.sampling import SampleSchedule

STEP_S = 0.05


def plant_order(rates, n_steps):
    """(name, t) as the plant takes them: by step, then in stream order."""
    schedules = [(name, SampleSchedule(rate, STEP_S)) for name, rate in rates]
    return [(name, step * STEP_S) for step in range(1, n_steps + 1) for name, s in schedules
            if s.is_sample_step(step)]


@given(rates=st.sampled_from([(('position', 10.0), ('imu', 10.0)), (('position', 1.0), ('imu', 10.0)),
                              (('position', 10.0), ('imu', 5.0)), (('position', 3.0), ('imu', 7.0))]),
       data=st.data())
def test_any_interleaving_of_the_streams_comes_out_in_plant_order(rates, data):
    expected = plant_order(rates, 200)
    streams = {name: [x for x in expected if x[0] == name] for name, _ in rates}
    # Each stream keeps its own order (DDS per topic); the interleaving is arbitrary.
    picks = data.draw(st.permutations([name for name, _ in expected]))
    order = MeasurementOrder(STEP_S, rates)
    out = []
    for name in picks:
        sample = streams[name].pop(0)
        out += [(n, t) for n, t, _item in order.push(name, sample[1], sample)]
    assert out == expected


def test_a_due_sample_is_waited_for_and_nothing_else():
    order = MeasurementOrder(STEP_S, [('position', 10.0), ('imu', 10.0)])
    assert order.push('imu', 0.1, 'i1') == []  # the position of t = 0.1 comes first
    assert [x[2] for x in order.push('position', 0.1, 'p1')] == ['p1', 'i1']
    assert [x[2] for x in order.push('position', 0.2, 'p2')] == ['p2']
    slow = MeasurementOrder(STEP_S, [('position', 1.0), ('imu', 10.0)])
    assert [x[2] for x in slow.push('imu', 0.1, 'i1')] == ['i1']  # no position is due before t = 1 s


def test_a_sample_out_of_its_own_order_or_stream_is_refused():
    order = MeasurementOrder(STEP_S, [('position', 10.0), ('imu', 10.0)])
    order.push('position', 0.1, 'p1')
    with pytest.raises(ValueError, match='position sample of t = 0.1 s is not after its last one'):
        order.push('position', 0.1, 'p1')
    with pytest.raises(ValueError, match="unknown stream 'gps'"):
        order.push('gps', 0.2, None)
