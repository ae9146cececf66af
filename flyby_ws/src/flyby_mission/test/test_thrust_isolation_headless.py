"""A thruster off inside a trim's opposing pairs, headless: campaigns/faults_single.yaml's run 411 (paper_flyby_6dof,
method auto, thruster 9 off from 68 s into the trajectory adjustment). Its 2.3 ms trim at 727.95 s, re-allocated so
every thruster gives its minimum impulse bit, fires all twelve, thruster 9 at 7.66 N; without it the -z thrusters
push unbalanced. The thrust monitor named that their leak (``thrust_excess`` on [10, 11]), and the fault table closed
two healthy thrusters; its hypothesis per thruster (flyby_estimation.thrust_isolation) names the +z thrusters'
deficit, which the table answers without closing any (docs/faults.md)."""

from pathlib import Path

import pytest

from flyby_mission.campaign.dispersions import load_campaign
from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_msgs_py import events

REPO = Path(__file__).resolve().parents[4]


@pytest.mark.slow
def test_a_thruster_off_in_a_trim_is_named_its_deficit_and_no_healthy_thruster_is_closed():
    campaign = load_campaign(REPO / 'campaigns' / 'faults_single.yaml', checked_draws=1)
    scenario, values = campaign.draw(411)
    assert (values['faults.0']['type'], values['faults.0']['index']) == ('thruster_off', 9)
    run = run_headless(scenario, graph=HeadlessGraph(scenario))
    summary = run.summary
    (detected,) = summary['faults_detected']
    assert (detected['kind'], detected['component'], detected['isolated']) == ('thrust_deficit', 'thrusters [8, 9]',
                                                                               True)
    assert detected['t_s'] == pytest.approx(728.8)  # the detection's time as before: only the naming changed
    (message,) = [e['message'] for e in run.events if e['name'] == events.FAULT_DETECTED]
    assert 'by hypothesis' in message
    assert [r['response'] for r in summary['fault_responses']] and not any(
        r['response'] in ('isolate', 'isolate_abort') for r in summary['fault_responses'])
    assert [e for e in run.events if e['name'] == events.THRUSTERS_ISOLATED] == []
    assert summary['outcome'] != 'COLLISION' and not summary['cam_fired']
