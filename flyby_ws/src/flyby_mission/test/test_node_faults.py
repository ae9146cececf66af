"""A node_crash headless (flyby_sim.faults, flyby_mission.headless): the node's core fed nothing while it is down, the
supervisor's watchdog finds it silent and the fault table answers; at its end a fresh core joins with the latched
topics and the events so far, and the watchdog sees it back."""

from pathlib import Path

import yaml

from flyby_mission.headless import HeadlessGraph
from flyby_mission.run_events import fault_detections, fault_responses
from flyby_msgs_py import contract as c
from flyby_sim.scenario import scenario_from_dict

REPO = Path(__file__).resolve().parents[4]


def _fly(node, until_s, duration_s=20.0, phase='TERMINAL_APPROACH'):
    d = yaml.safe_load((REPO / 'scenarios' / 'paper_flyby.yaml').read_text())
    d['faults'] = [{'type': 'node_crash', 'node': node, 'start_phase': phase, 'delay_s': 10.0,
                    'duration_s': duration_s}]
    graph = HeadlessGraph(scenario_from_dict(d, name=f'{node} crash'))
    graph.start()
    while graph.plant.t < until_s:
        graph.step()
    return graph


def test_a_planner_down_in_the_approach_is_lost_answered_continue_and_seen_back_fresh():
    graph = _fly('planner', 130.0)
    t_crash = next(e['t'] for e in graph.events if e['name'] == 'fault_injected')
    [detected] = fault_detections(graph.events)
    assert (detected['kind'], detected['component'], detected['isolated']) == ('node_lost', 'flyby_planner', True)
    assert 5.0 < detected['delay_s'] <= 5.0 + 2 * graph.scenario.simulation.step_s
    assert [r['response'] for r in fault_responses(graph.events)] == ['continue']
    back = [e for e in graph.events if e['name'] == 'fault_recovered']
    assert back and t_crash + 20.0 <= back[0]['t'] < t_crash + 21.0
    assert graph.phase != c.PHASE_ABORTED
    assert graph.planner is not None and graph.guards['flyby_planner'].failed is None
    # Fed the events' history, the successor does not plan again from the PLANNING long past.
    assert len([e for e in graph.events if e['name'] == 'plan_selected']) == 1


def test_guidance_or_the_cam_monitor_down_in_estimation_hold_standby_until_they_are_back():
    for node, component in (('guidance', 'flyby_guidance'), ('cam_monitor', 'flyby_cam_monitor')):
        graph = _fly(node, 100.0, phase='ESTIMATION')
        assert [(r['response'], r['component']) for r in fault_responses(graph.events)] == [('hold', component)]
        back = next(e['t'] for e in graph.events if e['name'] == 'fault_recovered')
        assert graph.phases[:4] == [c.PHASE_ESTIMATION, c.PHASE_HOLD, c.PHASE_ESTIMATION, c.PHASE_PLANNING]
        planning = [e['t'] for e in graph.events if e['name'] == 'phase_changed' and 'PLANNING' in e['message']]
        assert planning[0] >= back


def test_guidance_down_in_the_approach_retreats_and_a_crash_shorter_than_the_watchdog_goes_unseen():
    graph = _fly('guidance', 100.0)
    assert [r['response'] for r in fault_responses(graph.events)] == ['retreat']
    assert graph.phases[2:5] == [c.PHASE_TERMINAL_APPROACH, c.PHASE_RETREAT, c.PHASE_ESTIMATION]
    graph = _fly('guidance', 100.0, duration_s=3.0)
    assert fault_detections(graph.events) == [] and c.PHASE_ABORTED not in graph.phases


def test_an_estimator_down_in_the_approach_retreats_and_its_successor_plans_again():
    graph = _fly('estimator', 200.0)
    assert [r['response'] for r in fault_responses(graph.events)] == ['retreat']
    assert graph.phases == [c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH, c.PHASE_RETREAT,
                            c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH]
    safed = [e['name'] for e in graph.events if e['name'] in ('avoidance_burn', 'no_avoidance_burn')]
    assert len(safed) == 1  # the retreat's safing, as an abort's
    respawned = next(e['t'] for e in graph.events if e['name'] == 'fault_ended')
    planned = [e['t'] for e in graph.events if e['name'] == 'plan_selected']
    assert len(planned) == 2 and planned[1] >= respawned + 60.0  # the successor's own observation
