"""Topic faults headless (flyby_msgs_py.link_faults in flyby_mission.headless): the relative position lost for a
window in estimation is found stale by the estimator's monitor and answered from the fault table, the plant's samples
untouched; a short delay holds each sample for its time on every receiver's link and the fly-by still captures."""

from pathlib import Path

import pytest
import yaml

from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_mission.run_events import fault_detections, fault_responses
from flyby_msgs_py import contract as c
from flyby_msgs_py import wiring
from flyby_sim.scenario import scenario_from_dict

REPO = Path(__file__).resolve().parents[4]
POSITION = c.SENSOR_RELATIVE_POSITION


def _scenario(fault, duration_s=None):
    d = yaml.safe_load((REPO / 'scenarios' / 'paper_flyby.yaml').read_text())
    d['faults'] = [fault]
    if duration_s is not None:
        d['simulation']['duration_s'] = duration_s
    return scenario_from_dict(d, name=fault['type'])


def _fly(scenario, until_s):
    graph = HeadlessGraph(scenario)
    graph.start()
    while graph.plant.t < until_s - 1e-9:
        graph.step()
    return graph


def test_a_relative_position_lost_in_estimation_is_found_stale_and_held_until_it_is_back():
    loss = {'type': 'topic_loss', 'topic': POSITION, 'start_phase': 'ESTIMATION', 'delay_s': 10.0,
            'duration_s': 5.0}
    graph = _fly(_scenario(loss), 20.0)
    [detected] = fault_detections(graph.events)
    assert (detected['kind'], detected['component'], detected['fault'], detected['isolated']) == \
        ('sensor_stale', 'relative_position', 0, True)
    assert detected['delay_s'] == pytest.approx(0.6)  # 5 periods of 10 Hz, judged at the next input after them
    assert [(r['response'], r['phase']) for r in fault_responses(graph.events)] == [('hold', 'ESTIMATION')]
    back = [e for e in graph.events if e['name'] == 'fault_recovered']
    assert back and 15.0 <= back[0]['t'] < 15.5
    assert graph.phases == [c.PHASE_ESTIMATION, c.PHASE_HOLD, c.PHASE_ESTIMATION]  # held until it was back
    # Both receivers lost the window's 49 samples (the first one of it passed before its event: link_faults' doc).
    admitted = {node: graph.admissions[node].admitted[POSITION] for node in (wiring.ESTIMATOR, wiring.CAM)}
    assert admitted[wiring.ESTIMATOR] == admitted[wiring.CAM] == 200 - 49


def test_a_short_delay_holds_each_sample_for_its_time_and_the_fly_by_still_captures():
    delay = {'type': 'topic_delay', 'topic': POSITION, 'start_phase': 'ESTIMATION', 'delay_s': 10.0,
             'duration_s': 30.0, 'value': 0.3}
    graph = _fly(_scenario(delay), 20.0)
    for node in (wiring.ESTIMATOR, wiring.CAM):
        held = [release for release, _, message in graph.links[node].held[POSITION]]
        assert len(held) == 3 and held[0] == pytest.approx(20.1)  # 19.8, 19.9 and 20.0 on their way
    run = run_headless(_scenario(delay))
    assert run.summary['outcome'] == c.OUTCOME_CAPTURE
    assert run.summary['faults_detected'] == []
    assert not [e for e in run.events if e['name'] == 'message_rejected']
