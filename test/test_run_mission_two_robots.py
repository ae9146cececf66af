"""Two robots in the graph (seed 003 Fig 12, issue 14 item 4, docs/two_robots.md): one simulator, each chaser's
estimator, planner, guidance and supervisor under its namespace, the second chaser's planner planning after the
first's decision and around its published trajectory; real processes over Fast DDS, a ROS domain of the run's own,
full speed, the bag read back. A short variant of scenarios/jacobsen_two_robots.yaml (from 25 m, 10 s of
observation, a 40 s approach, 2 s attached) so that it ends within about a minute of wall time on a quiet machine."""

import subprocess
import sys

import pytest

from flyby_msgs_py import contract as c
from flyby_msgs_py.bag import read_bag
from flyby_testing import ROOT, analyze_bag, fly_variant, read_summary

pytestmark = pytest.mark.slow

PHASES = [c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_OPTIMAL_APPROACH, c.PHASE_CAPTURE, c.PHASE_COMPLETE]


def _short(data):
    data['planner']['min_observation_s'] = 10.0
    data['planner']['optimal']['approach_time_s'] = 40.0
    for chaser, x in zip(data['chasers'], (25.0, -25.0), strict=True):
        chaser['initial_position_hill_m'] = [x, 0.0, 0.0]
        chaser['initial_attitude']['body_axis_along_hill']['hill'] = [-x, 0.0, 0.0]
    data['supervisor'] = {**data.get('supervisor', {}), 'capture_hold_s': 2.0}
    data['simulation']['duration_s'] = 90.0


@pytest.fixture(scope='module')
def run(tmp_path_factory):
    return fly_variant(tmp_path_factory.mktemp('two_robots'), 'jacobsen_two_robots', 'two_robots_short', _short)[0]


def test_both_chasers_capture_apart_from_each_other_and_the_target(run):
    s = read_summary(run)
    assert s['outcome'] == c.OUTCOME_CAPTURE
    assert set(s['chasers']) == {'chaser1', 'chaser2'}
    for name, chaser in s['chasers'].items():
        assert chaser['outcome'] == c.OUTCOME_CAPTURE, name
        assert chaser['phase_sequence'] == PHASES, name
        assert chaser['min_clearance_m'] > 0.0, name
    assert s['min_separation_m'] > 0.0 and s['separation_pair'] == ['chaser1', 'chaser2']
    assert s['min_clearance_m'] > 0.0


def test_the_second_chaser_plans_at_the_first_ones_stamp_around_its_trajectory(run):
    topics = [c.absolute(c.MISSION_EVENTS, f'/{name}') for name in ('chaser1', 'chaser2')]
    bag = read_bag(run / 'bag', topics=topics)
    first = [e for e in bag[topics[0]] if e["name"] == "plan_selected"][0]
    events = bag[topics[1]]
    (waiting,) = [e for e in events if e['name'] == 'waiting_for_leaders']
    second, *reaims = [e for e in events if e['name'] == 'plan_selected']
    assert waiting['values']['leaders'] == 'chaser1'
    assert second['t'] >= first['t'] and second['values']['request'] == 'phase PLANNING'
    # A re-aim (10 s of observation leave the predicted end point moving) plans around chaser1 again.
    assert all(e['values']['request'].startswith('re-aim') for e in reaims)
    for plan in (second, *reaims):
        assert plan['values']['separation_from'] == 'chaser1'
        assert float(plan['values']['separation_m']) > 0.1  # planner.clearance_margin_m, the check before flying


def test_analyze_bag_recomputes_every_figure_of_both_chasers(run):
    done = analyze_bag(run)
    assert done.returncode == 0 and 'every figure agrees' in done.stdout, done.stdout + done.stderr
    for row in ('chaser1.capture_position_error_m', 'chaser2.min_clearance_m', 'min_separation_m'):
        assert row in done.stdout


def test_the_report_draws_both_chasers_and_their_separation(run, tmp_path):
    script = ROOT / 'scripts' / 'mission_report.py'
    done = subprocess.run([sys.executable, str(script), str(run), '--out', str(tmp_path)], capture_output=True,
                          text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert [p.name for p in tmp_path.glob('*.png')] == ['chasers.png']
