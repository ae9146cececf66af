"""An estimate stream lost headless (flyby_mission.estimate_age in the supervisor's core, flyby_msgs_py.link_faults
on its link): paper_flyby_6dof's target estimate lost for 30 s from TERMINAL_APPROACH is found stale 0.85 s after
its last estimate (8 periods of 10 Hz, judged at the next step), counted as that topic fault's detection, answered
continue, and recovered at its first estimate after the window."""

from pathlib import Path

import pytest
import yaml

from flyby_mission.headless import HeadlessGraph
from flyby_mission.run_events import fault_detections, fault_responses
from flyby_msgs_py import contract as c
from flyby_sim.scenario import scenario_from_dict

REPO = Path(__file__).resolve().parents[4]


def test_a_target_estimate_lost_in_the_terminal_approach_is_found_stale_answered_and_recovered():
    d = yaml.safe_load((REPO / 'scenarios' / 'paper_flyby_6dof.yaml').read_text())
    d['faults'] = [{'type': 'topic_loss', 'topic': c.EST_TARGET_ODOM, 'start_phase': 'TERMINAL_APPROACH',
                    'duration_s': 30.0}]
    graph = HeadlessGraph(scenario_from_dict(d, name='target_estimate_lost'))
    graph.start()
    while graph.plant.t < 91.0 - 1e-9:  # the window and its first estimate after: the run's first 91 s
        graph.step()
    [injected] = [e for e in graph.events if e['name'] == 'fault_injected']
    t_start = float(injected['values']['t_start'])
    [detected] = fault_detections(graph.events)
    assert (detected['kind'], detected['component'], detected['fault'], detected['isolated']) == \
        ('estimate_stale', 'target_estimate', 0, True)
    assert detected['delay_s'] == pytest.approx(0.85)
    assert [(r['response'], r['phase']) for r in fault_responses(graph.events)] == [
        ('continue', c.PHASE_TERMINAL_APPROACH)]
    [back] = [e for e in graph.events if e['name'] == 'fault_recovered']
    assert back['values']['component'] == 'target_estimate' and float(back['t']) == pytest.approx(t_start + 30.0)
    assert graph.phase not in (c.PHASE_ABORTED, c.PHASE_ESCAPE)
