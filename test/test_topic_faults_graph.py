"""A topic fault in the graph (docs/faults.md, flyby_msgs_py.link_faults): the relative position lost for a window
in paper_flyby's estimation is found stale by the estimator's monitor at the stamp the headless driver finds it, and
answered the same; the bag, which records what was published, holds every sample. First, without a run, a link
fault's event that is no such fault: each driver refuses it the same way (one line in the receiving node's log naming
it, no window, no exception)."""

import logging

import pytest
from fault_testing import assert_found_stale_as_headless

from flyby_mission.headless import HeadlessGraph
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, events, wiring
from flyby_msgs_py.bag import read_bag
from flyby_msgs_py.node_base import AdmissionGate
from flyby_sim.scenario import load_scenario
from flyby_testing import analyze_bag, read_summary, run_mission, write_scenario

MALFORMED = {'fault': '0', 'kind': 'topic_delay', 'target': 'topic', 't_start': '10.0', 'value': '1.0'}


class _Logger:
    """The node's logger a gate logs to: its warnings kept."""

    def __init__(self):
        self.lines = []

    def warning(self, line):
        self.lines.append(line)


class _Node:
    def __init__(self):
        self.logger = _Logger()

    def get_logger(self):
        return self.logger


def test_a_malformed_link_fault_event_is_refused_alike_by_both_drivers(tmp_path, caplog):
    node = _Node()
    gate = AdmissionGate(node, lambda: 10.0, lambda event: None)
    gate.on_link_events(convert.event(10.0, 'OK', events.FAULT_INJECTED, 'topic fault', MALFORMED, wiring.SIM))
    scenario = write_scenario(tmp_path, base='paper_flyby', name='position_lost', edit=_position_lost)
    sc = load_scenario(scenario)
    graph = HeadlessGraph(sc)
    # The receivers of the faulted topic, whose gates watch in the graph (CoreNode.subscribe_inputs), and no other.
    assert set(graph.watching) == set(wiring.subscribers(c.SENSOR_RELATIVE_POSITION, sc))
    with caplog.at_level(logging.WARNING):
        assert not graph.links[wiring.ESTIMATOR].on_event(events.FAULT_INJECTED, MALFORMED)
    [graph_line] = node.logger.lines
    [headless_line] = [r.getMessage() for r in caplog.records]
    assert headless_line == f'{wiring.ESTIMATOR}: {graph_line}'
    assert graph_line.startswith(f'link faults: {events.FAULT_INJECTED} ') and "'topic'" in graph_line
    assert not gate.link.windows and not graph.links[wiring.ESTIMATOR].windows
    assert gate.link.arrive(c.SENSOR_RELATIVE_POSITION, 10.5, 'm') == ['m']


def _position_lost(data):
    data['faults'] = [{'type': 'topic_loss', 'topic': 'sensors/chaser/relative_position', 'start_phase': 'ESTIMATION',
                       'delay_s': 10.0, 'duration_s': 5.0}]
    data['simulation']['duration_s'] = 20.0


@pytest.mark.slow
def test_a_relative_position_lost_in_estimation_is_found_stale_as_headless(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby', name='position_lost', edit=_position_lost)
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run', '--in-process')
    summary = read_summary(tmp_path / 'run')
    assert_found_stale_as_headless(summary, scenario, done.stdout[-2000:])
    samples = read_bag(tmp_path / 'run' / 'bag', topics=['/sensors/chaser/relative_position'])
    assert len(samples['/sensors/chaser/relative_position'].t) == 200  # 10 Hz over 20 s: none lost in the record
    checked = analyze_bag(tmp_path / 'run')
    assert checked.returncode == 0, checked.stdout[-2000:] + checked.stderr[-2000:]
