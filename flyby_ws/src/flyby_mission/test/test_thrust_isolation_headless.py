"""A thruster off inside a trim's opposing pairs, headless: campaigns/faults_single.yaml's run 411 (paper_flyby_6dof,
method auto, thruster 9 off from 68 s into the trajectory adjustment). Its 2.3 ms trim at 727.95 s, re-allocated so
every thruster gives its minimum impulse bit, fires all twelve, thruster 9 at 7.66 N; without it the -z thrusters
push unbalanced. The thrust monitor named that their leak (``thrust_excess`` on [10, 11]), and the fault table closed
two healthy thrusters; its hypothesis per thruster (flyby_estimation.thrust_isolation) names the +z thrusters'
deficit, which the table answers without closing any (docs/faults.md). Run 103 (thruster 3 stuck on): its leak is
named on [2, 3], which the table closes; a later burn's shortfall on them is named by direction, not fitted to
healthy thrusters' leak by hypotheses that allocate over every thruster."""

from pathlib import Path

import pytest

from flyby_mission.campaign.dispersions import load_campaign
from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_msgs_py import events

REPO = Path(__file__).resolve().parents[4]


def _fly(run):
    """faults_single's run ``run`` headless: (its drawn fault, the run)."""
    campaign = load_campaign(REPO / 'campaigns' / 'faults_single.yaml', checked_draws=1)
    scenario, values = campaign.draw(run)
    return values['faults.0'], run_headless(scenario, graph=HeadlessGraph(scenario))


@pytest.mark.slow
def test_a_thruster_off_in_a_trim_is_named_its_deficit_and_no_healthy_thruster_is_closed():
    fault, run = _fly(411)
    assert (fault['type'], fault['index']) == ('thruster_off', 9)
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


@pytest.mark.slow
def test_after_a_leak_is_closed_no_later_detection_closes_healthy_thrusters():
    fault, run = _fly(103)
    assert (fault['type'], fault['index']) == ('thruster_stuck_on', 3)
    first, *later = run.summary['faults_detected']
    assert (first['kind'], first['component'], first['isolated']) == ('thrust_excess', 'thrusters [2, 3]', True)
    closed = [e['message'] for e in run.events if e['name'] == events.THRUSTERS_ISOLATED]
    assert closed == ['thrusters [2, 3] isolated: thrust_excess']
    assert later and all('by direction' in e['message'] for e in run.events if e['name'] == events.FAULT_DETECTED
                         and e['t'] > first['t_s'] and 'thrust' in e['message'][:20])
    assert run.summary['outcome'] != 'COLLISION'
