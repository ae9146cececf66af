"""Faults in the graph (docs/faults.md), judged from the truth in the bag: a thruster stuck on during
paper_flyby_6dof's terminal approach is detected, its thrusters closed and the approach aborted, and a chaser
coasting into the target with the planner and guidance out of the graph is turned away by the independent
monitor's CAM alone; a wheel failed in the approach is named from its tachometer and reallocated, the approach going
on; a planner
killed and respawned by the launcher is found silent by the watchdog, answered continue, and seen back; an estimator
killed in ESTIMATION holds standby until its successor has converged and observed anew; a relative position lost in
the approach retreats and plans again, as headless."""

import pytest

from flyby_mission.headless import run_headless
from flyby_msgs_py.bag import read_bag
from flyby_sim.scenario import load_scenario
from flyby_testing import analyze_bag, read_summary, run_mission, write_scenario

pytestmark = pytest.mark.slow


def _coast_into_the_target(data):
    data['chaser']['initial_position_hill_m'] = [12.0, 1.0, 0.5]
    data['chaser']['initial_velocity_hill_mps'] = [-0.3, 0.0, 0.0]  # contact near t = 35 s without a CAM
    data['simulation']['duration_s'] = 45.0


def _stuck_thruster(data):
    data['faults'] = [{'type': 'thruster_stuck_on', 'index': 3, 'start_phase': 'TERMINAL_APPROACH', 'delay_s': 100.0,
                       'value': 0.1}]
    data['simulation']['duration_s'] = 300.0


def test_the_cam_fires_with_the_planner_and_guidance_out_of_the_graph(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby_6dof', name='coast_in', edit=_coast_into_the_target)
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run', '--without', 'flyby_planner',
                       '--without', 'flyby_guidance')
    summary = read_summary(tmp_path / 'run')
    assert summary['cam_fired'] and 25.0 < summary['t_cam_s'] < 34.0, done.stdout[-2000:]
    assert summary['outcome'] == 'ABORTED' and summary['min_clearance_m'] > 0.1
    checked = analyze_bag(tmp_path / 'run')
    assert checked.returncode == 0, checked.stdout[-2000:] + checked.stderr[-2000:]


def test_a_thruster_stuck_on_in_the_approach_is_closed_and_the_chaser_escapes(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby_6dof', name='stuck', edit=_stuck_thruster)
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run', '--report')
    summary = read_summary(tmp_path / 'run')
    assert (tmp_path / 'run' / 'faults_timeline.png').stat().st_size > 10_000
    first = summary['faults_detected'][0]
    assert (first['kind'], first['fault'], first['isolated']) == ('thrust_excess', 0, True), done.stdout[-2000:]
    assert first['delay_s'] < 2.0
    assert summary['fault_responses'][0]['response'] == 'isolate_abort'
    assert summary['outcome'] == 'ABORTED' and not summary['cam_fired'] and summary['min_clearance_m'] > 10.0
    checked = analyze_bag(tmp_path / 'run')
    assert checked.returncode == 0, checked.stdout[-2000:] + checked.stderr[-2000:]


def _failed_wheel(data):
    data['faults'] = [{'type': 'wheel_failed', 'index': 2, 'start_phase': 'TERMINAL_APPROACH', 'delay_s': 10.0}]
    data['simulation']['duration_s'] = 150.0


def test_a_wheel_failed_in_the_approach_is_named_from_its_tachometer_within_two_seconds_and_reallocated(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby_6dof', name='wheel', edit=_failed_wheel)
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run')
    summary = read_summary(tmp_path / 'run')
    first = summary['faults_detected'][0]
    assert (first['kind'], first['component'], first['isolated']) == ('wheel_torque_deficit', 'wheels [2]', True), \
        done.stdout[-2000:]
    assert first['delay_s'] < 2.0 and summary['fault_responses'][0]['response'] == 'reallocate'
    # the approach goes on to the run's 150 s on the wheels left and the thrusters (the capture is at 813 s)
    assert summary['outcome'] == 'TIME_LIMIT' and summary['final_phase'] != 'ABORTED' and not summary['cam_fired']
    wheels = read_bag(tmp_path / 'run' / 'bag', topics=['/guidance/wheels'])['/guidance/wheels']
    after = wheels.t > first['t_s'] + 0.2  # the commands of the estimates from the detection's stamp on
    assert after.any() and not wheels.effort[after, 2].any() and wheels.effort[~after, 2].any()


def _crash(node, start_phase, delay_s, run_s):
    """The scenario edit of a node_crash of ``node`` delay_s into start_phase for 20 s, in a run of run_s."""
    def edit(data):
        data['faults'] = [{'type': 'node_crash', 'node': node, 'start_phase': start_phase, 'delay_s': delay_s,
                           'duration_s': 20.0}]
        data['simulation']['duration_s'] = run_s
    return edit


def test_a_planner_killed_and_respawned_by_the_launcher_is_lost_answered_and_seen_back(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby', name='crash',
                              edit=_crash('planner', 'TERMINAL_APPROACH', 10.0, 120.0))
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run', '--in-process')
    summary = read_summary(tmp_path / 'run')
    [detected] = summary['faults_detected']
    assert (detected['kind'], detected['component'], detected['isolated']) == ('node_lost', 'flyby_planner', True), \
        done.stdout[-2000:]
    assert 4.4 < detected['delay_s'] < 6.0  # silent for watchdog_s since its last heartbeat (every 0.5 s)
    assert summary['fault_responses'][0]['response'] == 'continue'
    assert summary['outcome'] == 'TIME_LIMIT'
    events = read_bag(tmp_path / 'run' / 'bag', topics=['/mission/events'])['/mission/events']
    back = [e for e in events if e['name'] == 'fault_recovered' and e['values'].get('component') == 'flyby_planner']
    assert back and back[0]['t'] >= detected['t_s'], 'the respawned planner never reported'
    # The successor, fed the events' history, does not plan again from the PLANNING long past.
    assert len([e for e in events if e['name'] == 'plan_selected']) == 1
    checked = analyze_bag(tmp_path / 'run')
    assert checked.returncode == 0, checked.stdout[-2000:] + checked.stderr[-2000:]


def test_an_estimator_killed_in_estimation_holds_standby_until_its_successor_has_converged(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby', name='held', edit=_crash('estimator', 'ESTIMATION', 20.0,
                                                                                      150.0))
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run', '--in-process')
    summary = read_summary(tmp_path / 'run')
    assert [r['response'] for r in summary['fault_responses']] == ['hold'], done.stdout[-2000:]
    assert summary['phase_sequence'][:5] == ['ESTIMATION', 'HOLD', 'ESTIMATION', 'PLANNING', 'TERMINAL_APPROACH']
    events = read_bag(tmp_path / 'run' / 'bag', topics=['/mission/events'])['/mission/events']
    respawned = next(e['t'] for e in events if e['name'] == 'fault_ended')
    converged = [e['t'] for e in events if e['name'] == 'target_converged']
    planned = [e['t'] for e in events if e['name'] == 'plan_selected']
    assert len(converged) == 2 and converged[1] > respawned  # the successor's own convergence
    assert len(planned) == 1 and planned[0] >= respawned + 60.0  # min_observation_s of the successor's estimates
    checked = analyze_bag(tmp_path / 'run')
    assert checked.returncode == 0, checked.stdout[-2000:] + checked.stderr[-2000:]


def _position_lost_in_the_approach(data):
    data['faults'] = [{'type': 'topic_loss', 'topic': 'sensors/chaser/relative_position',
                       'start_phase': 'TERMINAL_APPROACH', 'delay_s': 10.0, 'duration_s': 10.0}]
    data['simulation']['duration_s'] = 150.0


def test_a_relative_position_lost_in_the_approach_retreats_and_plans_again_as_headless(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby', name='retreat', edit=_position_lost_in_the_approach)
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run', '--in-process')
    summary = read_summary(tmp_path / 'run')
    headless = run_headless(load_scenario(scenario)).summary
    assert [r['response'] for r in summary['fault_responses']] == ['retreat'], done.stdout[-2000:]
    assert summary['phase_sequence'] == headless['phase_sequence'] == [
        'ESTIMATION', 'PLANNING', 'TERMINAL_APPROACH', 'RETREAT', 'ESTIMATION', 'PLANNING', 'TERMINAL_APPROACH']
    events = read_bag(tmp_path / 'run' / 'bag', topics=['/mission/events'])['/mission/events']
    assert len([e for e in events if e['name'] == 'plan_selected']) == 2
    checked = analyze_bag(tmp_path / 'run')
    assert checked.returncode == 0, checked.stdout[-2000:] + checked.stderr[-2000:]
