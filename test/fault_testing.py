"""What the graph tests of a sensor's fault check alike (test_measurement_order_graph, test_topic_faults_graph): the
graph found the relative position stale once, at the stamp the headless driver finds it, and answered it as the
fault table says. One home for the check, so that both tests hold the graph to the same headless figures."""

import pytest

from flyby_mission.headless import run_headless
from flyby_sim.scenario import load_scenario

DETECTION_KEYS = ('kind', 'component', 'fault', 'isolated')


def assert_found_stale_as_headless(summary, scenario, output=''):
    """The graph run's ``summary`` (summary.json) detected the relative position's staleness (fault 0, isolated)
    once, as the headless run of the ``scenario`` file does and at its stamp, and answered hold; ``output``
    (the run's stdout) is shown where the detections differ."""
    headless = run_headless(load_scenario(scenario)).summary
    [detected] = summary['faults_detected']
    assert [tuple(d[k] for k in DETECTION_KEYS) for d in headless['faults_detected']] \
        == [tuple(detected[k] for k in DETECTION_KEYS)] == [('sensor_stale', 'relative_position', 0, True)], output
    assert detected['t_s'] == pytest.approx(headless['faults_detected'][0]['t_s'])
    assert [r['response'] for r in summary['fault_responses']] == ['hold']
    assert summary['phase_sequence'][:3] == ['ESTIMATION', 'HOLD', 'ESTIMATION'] == headless['phase_sequence'][:3]
