"""MeasurementOrder restores the plant's order of the measurement streams from any interleaving, and gives up a
sample not in by the clock of its step."""

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


@given(rates=st.sampled_from([(('position', 10.0), ('imu', 10.0)), (('position', 1.0), ('imu', 10.0)),
                              (('position', 20.0), ('imu', 10.0)), (('position', 10.0), ('imu', 20.0))]),
       data=st.data())
def test_nothing_is_given_up_or_reordered_when_every_sample_comes_before_the_clock_of_its_step(rates, data):
    expected = plant_order(rates, 60)
    order = MeasurementOrder(STEP_S, rates)
    out = []
    for step in range(1, 61):
        # The simulator's clock of a step follows the step's samples; those may come in any order.
        for name, t in data.draw(st.permutations([x for x in expected if round(x[1] / STEP_S) == step])):
            out += [(n, t) for n, t, _item in order.push(name, t, None)]
        out += [(n, t) for n, t, _item in order.clock(step * STEP_S)]
    assert out == expected


def test_a_sample_not_in_by_the_clock_of_its_step_is_given_up_and_what_it_held_goes_on():
    order = MeasurementOrder(STEP_S, [('position', 10.0), ('imu', 10.0)])
    assert order.push('imu', 0.1, 'i1') == []  # the position of t = 0.1 comes first
    assert order.clock(0.1) == [('imu', 0.1, 'i1')]  # it has not come by the clock of its step: given up
    # A dropout of the position: the IMU samples go on one by one, each at once.
    for k in range(2, 50):
        assert order.push('imu', k * 0.1, k) == []  # not yet: the position of its step may still come
        assert [x[2] for x in order.clock(k * 0.1)] == [k]
        assert order.clock(k * 0.1 + STEP_S) == []
    assert [x[2] for x in order.push('position', 5.0, 'p50')] == ['p50']  # the sensor back: in order again
    assert [x[2] for x in order.push('imu', 5.0, 'i50')] == ['i50']


def test_a_given_up_sample_that_comes_after_all_is_handed_on_behind_the_steps_already_in():
    order = MeasurementOrder(STEP_S, [('position', 10.0), ('imu', 10.0)])
    assert order.push('imu', 0.1, 'i1') == []
    assert [x[2] for x in order.clock(0.1)] == ['i1']
    assert order.push('imu', 0.2, 'i2') == []  # held behind the position of t = 0.2
    # The position of t = 0.1, late (a topic_delay released at the clock of t = 0.2), goes after the IMU sample of
    # t = 0.2, as the headless link hands it on after the samples of the step it is released at.
    assert order.push('position', 0.1, 'p1 late') == []
    assert [x[2] for x in order.clock(0.2)] == ['i2', 'p1 late']
    # Released at a clock with nothing held: at once.
    assert order.clock(0.3) == []
    assert [x[2] for x in order.push('position', 0.3, 'p3 late')] == ['p3 late']


def test_a_sample_behind_a_late_one_of_its_stream_is_late_too():
    order = MeasurementOrder(STEP_S, [('position', 10.0), ('imu', 10.0)])
    assert order.push('imu', 0.1, 'i1') == []
    assert [x[2] for x in order.clock(0.1)] == ['i1']
    assert order.push('imu', 0.2, 'i2') == []
    # A link releases what it held at the clock of t = 0.2, that clock's own position with it: in the stream's order,
    # all after the IMU sample of t = 0.2 (the headless link: held, then released after the step's samples).
    assert order.push('position', 0.1, 'p1 late') == []
    assert [x[2] for x in order.push('position', 0.2, 'p2 held')] == ['i2', 'p1 late', 'p2 held']
    assert order.clock(0.2) == []
    assert [x[2] for x in order.push('position', 0.3, 'p3')] == ['p3']


def test_a_later_sample_of_its_own_stream_gives_a_sample_up():
    order = MeasurementOrder(STEP_S, [('position', 10.0), ('imu', 10.0)])
    assert order.push('imu', 0.1, 'i1') == []
    assert [x[2] for x in order.push('position', 0.2, 'p2')] == ['i1', 'p2']


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
