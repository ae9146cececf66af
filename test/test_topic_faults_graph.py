"""A topic fault in the graph (docs/faults.md, flyby_msgs_py.link_faults): the relative position lost for a window
in paper_flyby's estimation is found stale by the estimator's monitor at the stamp the headless driver finds it, and
answered the same; the bag, which records what was published, holds every sample."""

import pytest

from flyby_mission.headless import run_headless
from flyby_msgs_py.bag import read_bag
from flyby_sim.scenario import load_scenario
from flyby_testing import analyze_bag, read_summary, run_mission, write_scenario

pytestmark = pytest.mark.slow


def _position_lost(data):
    data['faults'] = [{'type': 'topic_loss', 'topic': 'sensors/chaser/relative_position', 'start_phase': 'ESTIMATION',
                       'delay_s': 10.0, 'duration_s': 5.0}]
    data['simulation']['duration_s'] = 20.0


def test_a_relative_position_lost_in_estimation_is_found_stale_as_headless(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby', name='position_lost', edit=_position_lost)
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run', '--in-process')
    summary = read_summary(tmp_path / 'run')
    headless = run_headless(load_scenario(scenario)).summary
    keys = ('kind', 'component', 'fault', 'isolated')
    [detected] = summary['faults_detected']
    assert [tuple(d[k] for k in keys) for d in headless['faults_detected']] == [tuple(detected[k] for k in keys)] \
        == [('sensor_stale', 'relative_position', 0, True)], done.stdout[-2000:]
    assert detected['t_s'] == pytest.approx(headless['faults_detected'][0]['t_s'])
    assert [r['response'] for r in summary['fault_responses']] == ['continue']
    samples = read_bag(tmp_path / 'run' / 'bag', topics=['/sensors/chaser/relative_position'])
    assert len(samples['/sensors/chaser/relative_position'].t) == 200  # 10 Hz over 20 s: none lost in the record
    checked = analyze_bag(tmp_path / 'run')
    assert checked.returncode == 0, checked.stdout[-2000:] + checked.stderr[-2000:]
