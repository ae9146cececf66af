"""scripts/plan_capture.py as a user runs it: JSON on stdout, figures, exit codes 0 / 3 / 2."""

import json
import subprocess
import sys

import pytest

from flyby_testing import ROOT, SCENARIOS, write_scenario

PLAN_CAPTURE = ROOT / 'scripts' / 'plan_capture.py'
FIGURES = ('plan_xz.png', 'plan_3d.png', 'plan_clearance.png')


def plan_capture(*args):
    return subprocess.run([sys.executable, str(PLAN_CAPTURE), *map(str, args)], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)


@pytest.fixture(scope='module')
def paper_run(tmp_path_factory):
    plot_dir = tmp_path_factory.mktemp('figures')
    return plan_capture('--scenario', SCENARIOS / 'paper_flyby.yaml', '--plot', plot_dir), plot_dir


def test_paper_flyby_plan_is_found_and_safe(paper_run):
    done, _ = paper_run
    assert done.returncode == 0, done.stderr
    plan = json.loads(done.stdout)
    assert plan['ok'] and plan['scenario'] == 'paper_flyby'
    assert plan['planning_time_ms'] > 0.0
    selected = plan['selected']
    assert selected['status'] == 'selected'
    assert abs(selected['v_g_hill_mps'][1]) < 1e-3  # eq 13
    assert selected['clearance_approach_m'] >= plan['clearance_margin_m']
    assert selected['clearance_escape_m'] >= plan['clearance_margin_m']
    # The top-level summary repeats the selected candidate; the rejected ones say why.
    assert plan['t_grasp_s'] == selected['t_grasp_s'] and plan['x_ft_hill_m'] == selected['x_ft_hill_m']
    assert plan['dv_total_mps'] == selected['dv_total_mps']
    assert plan['rejected'] and all(r['reasons'] for r in plan['rejected'])
    assert [c['name'] for c in plan['keep_out']['cylinders']] == ['bus', 'panel_plus_y', 'panel_minus_y']


def test_plot_writes_the_three_figures(paper_run):
    done, plot_dir = paper_run
    assert done.returncode == 0, done.stderr
    for name in FIGURES:
        size = (plot_dir / name).stat().st_size
        assert 0 < size < 400_000, (name, size)


def test_a_later_plan_time_starts_from_the_coasted_chaser():
    done = plan_capture('--scenario', SCENARIOS / 'paper_flyby.yaml', '--t-plan', 100)
    assert done.returncode == 0, done.stderr
    plan = json.loads(done.stdout)
    assert plan['t_plan_s'] == 100.0
    assert plan['t_ti_s'] == pytest.approx(110.0)  # maneuver_lead_s after the plan time
    assert plan['t_grasp_s'] > 100.0 + 460.0  # the search window starts lead + fly-by + transfer_min_s later


def test_tumbler_is_refused_by_condition_a():
    done = plan_capture('--scenario', SCENARIOS / 'seweryn_tumbling.yaml')
    assert done.returncode == 3, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and 'condition (a)' in lines[0]
    plan = json.loads(done.stdout)
    assert not plan['ok'] and plan['selected'] is None


def test_bad_key_is_one_line_naming_it(tmp_path):
    scenario = write_scenario(tmp_path, edit=lambda d: d['planner'].__setitem__('offset_m', -1.0))
    done = plan_capture('--scenario', scenario)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert 'planner.offset_m' in lines[0] and str(scenario) in lines[0]
    assert 'Traceback' not in done.stderr and done.stdout == ''


def test_missing_file_is_one_line(tmp_path):
    done = plan_capture('--scenario', tmp_path / 'absent.yaml')
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [f'error: {tmp_path / "absent.yaml"}: file not found']
