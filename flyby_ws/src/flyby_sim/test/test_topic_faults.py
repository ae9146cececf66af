"""Topic faults (flyby_msgs_py.link_faults, flyby_sim.faults): the link's rule on one receiver (a delayed message
handed on at its stamp plus the delay, a lost one never, nothing changed outside the window, the topic's order kept,
nothing left held once released), the window learnt from the simulator's event as the plant reports it, an event that
is no link fault refused in one logged line, and the scenario's one-line refusals."""

import dataclasses
from pathlib import Path

import pytest
import yaml

from flyby_msgs_py import contract as c
from flyby_msgs_py import events as ev
from flyby_msgs_py.link_faults import TOPIC_DELAY, TOPIC_LOSS, LinkFaults
from flyby_msgs_py.wire import wire_event
from flyby_sim.faults import FaultSpec
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import ScenarioError, load_scenario, scenario_from_dict

REPO = Path(__file__).resolve().parents[4]
POSITION = c.SENSOR_RELATIVE_POSITION


def _injected(kind, t_start, duration_s, value=None, topic=POSITION):
    """The values of the simulator's fault_injected for a link fault, as they reach a node (text)."""
    values = {'fault': '0', 'kind': kind, 'target': f'topic {topic}', 't_start': repr(t_start),
              'duration_s': repr(duration_s) if duration_s is not None else '', 'value': repr(value) if value else ''}
    return {k: v for k, v in values.items() if v != ''}


def _link(kind, t_start=10.0, duration_s=5.0, value=None):
    link = LinkFaults()
    assert link.on_event(ev.FAULT_INJECTED, _injected(kind, t_start, duration_s, value))
    return link


def _stream(link, stamps, topic=POSITION):
    """Each message stamped t arrives at t, after the release of what is due by then: (delivery time, stamp)."""
    out = []
    for t in stamps:
        out += [(t, s) for _, s in link.due(t)]
        out += [(t, s) for s in link.arrive(topic, t, t)]
    return out


STAMPS = [round(0.1 * k, 1) for k in range(80, 200)]  # 8 s to 20 s at 10 Hz


def test_a_lost_message_never_arrives_and_outside_the_window_nothing_changes():
    got = _stream(_link(TOPIC_LOSS), STAMPS)
    assert [s for _, s in got] == [t for t in STAMPS if not 10.0 <= t < 15.0]
    assert all(at == s for at, s in got)  # at once, outside the window
    assert _stream(_link(TOPIC_LOSS), STAMPS, topic=c.SENSOR_TARGET_ATTITUDE) == [(t, t) for t in STAMPS]


def test_a_delayed_message_arrives_at_its_stamp_plus_the_delay_and_the_topic_keeps_its_order():
    got = _stream(_link(TOPIC_DELAY, value=0.3), STAMPS)
    assert [s for _, s in got] == STAMPS  # every one, in order
    for at, s in got:
        if s < 10.0:
            assert at == s
        elif s < 15.0:
            assert at == pytest.approx(s + 0.3)  # the receiver's first time at or after stamp + delay
        else:  # behind the held ones: a queue drains the delay after the window
            assert s <= at <= max(s, 15.0 + 0.3)
    assert max(at - s for at, s in got) == pytest.approx(0.3)


def test_a_permanent_loss_and_events_that_are_no_link_fault():
    link = _link(TOPIC_LOSS, duration_s=None)
    assert [s for _, s in _stream(link, STAMPS)] == [t for t in STAMPS if t < 10.0]
    other = LinkFaults()
    assert not other.on_event(ev.FAULT_INJECTED, {'fault': '0', 'kind': 'sensor_dropout', 'target': 'imu',
                                                  't_start': '1.0'})
    assert not other.on_event(ev.FAULT_ENDED, _injected(TOPIC_LOSS, 1.0, 2.0))
    assert not other.concerns(POSITION) and other.arrive(POSITION, 1.5, 'm') == ['m']


def test_a_released_topic_leaves_held_so_that_an_idle_link_is_one_test():
    link = _link(TOPIC_DELAY, value=0.3)
    assert link.arrive(POSITION, 10.0, 'a') == [] and link.arrive(POSITION, 10.1, 'b') == []
    assert link.due(10.35) == [(POSITION, 'a')] and POSITION in link.held
    assert link.due(10.4) == [(POSITION, 'b')]
    assert link.held == {}


@pytest.mark.parametrize('change, why', [
    ({'t_start': None}, 'no t_start'),
    ({'t_start': 'soon'}, 'is no number'),
    ({'t_start': 'nan'}, 'are no window'),
    ({'duration_s': '-1.0'}, 'are no window'),
    ({'target': 'topic'}, "target 'topic' is no"),
    ({'target': f'sensor {POSITION}'}, 'is no'),
    ({'target': 'topic clock'}, 'is no'),
    ({'value': None}, 'delay None s is not in (0, 60]'),
    ({'value': '0.0'}, 'delay 0.0 s is not in (0, 60]'),
    ({'value': '61.0'}, 'delay 61.0 s is not in (0, 60]'),
])
def test_a_link_fault_event_that_is_no_such_fault_is_refused_in_one_logged_line(change, why):
    lines = []
    link = LinkFaults(log=lines.append)
    values = {k: v for k, v in {**_injected(TOPIC_DELAY, 10.0, 5.0, 1.0), **change}.items() if v is not None}
    assert not link.on_event(ev.FAULT_INJECTED, values)
    [line] = lines
    assert line.startswith(f'link faults: {ev.FAULT_INJECTED} ') and 'refused' in line and why in line
    assert not link.windows and link.arrive(POSITION, 11.0, 'm') == ['m']


def test_the_plant_reports_a_link_fault_whose_event_opens_the_window_on_the_receiver():
    sc = load_scenario(REPO / 'scenarios' / 'paper_flyby.yaml')
    spec = FaultSpec(TOPIC_DELAY, topic=POSITION, start_s=2.0, duration_s=3.0, value=0.5)
    plant = Plant(dataclasses.replace(PlantConfig.from_scenario(sc), faults=(spec,)))
    events = []
    while plant.t < 6.0:
        plant.step()
        events += [wire_event(e) for e in plant.drain_events()]
    injected = [e for e in events if e.name == ev.FAULT_INJECTED]
    assert [e.values['target'] for e in injected] == [f'topic {POSITION}']
    assert any(e.name == ev.FAULT_ENDED for e in events)
    link = LinkFaults()
    assert link.on_event(injected[0].name, injected[0].values)
    assert link.arrive(POSITION, 2.1, 'm') == [] and link.due(2.5) == [] and link.due(2.6) == [(POSITION, 'm')]


def _with_faults(base, faults):
    d = yaml.safe_load((REPO / 'scenarios' / base).read_text())
    d['faults'] = faults
    return scenario_from_dict(d, name=base)


@pytest.mark.parametrize('base, fault, key, words', [
    ('paper_flyby.yaml', {'type': 'topic_loss', 'start_s': 1.0}, 'faults[0].topic', 'is required for topic_loss'),
    ('paper_flyby.yaml', {'type': 'topic_delay', 'topic': 'clock', 'start_s': 1.0}, 'faults[0].topic',
     'must be one of'),
    ('paper_flyby.yaml', {'type': 'topic_loss', 'topic': 'mission/events', 'start_s': 1.0}, 'faults[0].topic',
     'must be one of'),
    ('paper_flyby.yaml', {'type': 'topic_delay', 'topic': POSITION, 'start_s': 1.0, 'value': 0.0},
     'faults[0].value', '(0, 60]'),
    ('paper_flyby.yaml', {'type': 'topic_delay', 'topic': POSITION, 'start_s': 1.0, 'value': 61.0},
     'faults[0].value', '(0, 60]'),
    ('paper_flyby.yaml', {'type': 'topic_loss', 'topic': POSITION, 'start_s': 1.0, 'value': 1.0},
     'faults[0].value', 'takes no value'),
    ('paper_flyby.yaml', {'type': 'sensor_dropout', 'sensor': 'relative_position', 'topic': POSITION,
                          'start_s': 1.0}, 'faults[0].topic', 'is for topic_delay and topic_loss'),
    ('paper_flyby.yaml', {'type': 'topic_loss', 'topic': c.SENSOR_CHASER_WHEELS, 'start_s': 1.0},
     'faults[0].topic', 'needs chaser.model rigid_body'),
    ('paper_flyby_6dof.yaml', {'type': 'topic_loss', 'topic': c.EST_CHASER_ODOM, 'start_s': 1.0},
     'faults[0].topic', 'would stop the graph'),
])
def test_a_bad_topic_fault_is_refused_in_one_line_naming_its_key(base, fault, key, words):
    with pytest.raises(ScenarioError) as err:
        _with_faults(base, [fault])
    assert err.value.key == key and words in err.value.problem and '\n' not in str(err.value)


def test_a_topic_fault_of_each_target_is_taken():
    for base, topic in (('paper_flyby.yaml', POSITION), ('paper_flyby.yaml', c.EST_CHASER_ODOM),
                        ('paper_flyby_6dof.yaml', c.SENSOR_CHASER_WHEELS),
                        ('paper_flyby_6dof.yaml', c.EST_TARGET_ODOM)):
        sc = _with_faults(base, [{'type': 'topic_delay', 'topic': topic, 'start_phase': 'ESTIMATION',
                                  'duration_s': 5.0, 'value': 60.0}])
        assert sc.faults[0].topic == topic
