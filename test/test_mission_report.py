"""scripts/mission_report.py on real runs: one cut short before any plan, one that captures, one short run of the
six-degree-of-freedom chaser through run_mission --report."""

import importlib.util
import subprocess
import sys

import numpy as np
import pytest

from flyby_msgs_py import contract as c
from flyby_testing import ROOT, read_summary, run_mission, with_duration, write_scenario

SCRIPT = ROOT / 'scripts' / 'mission_report.py'
ALL_FIGURES = ('trajectory_xz.png', 'trajectory_3d.png', 'range.png', 'maneuvers.png', 'estimation.png',
               'clearance.png')
RIGID_BODY_FIGURES = ('attitude.png', 'pointing.png', 'wheels.png', 'thrusters.png')
PNG_MAGIC = b'\x89PNG\r\n\x1a\n'


@pytest.fixture(scope='module')
def report():
    spec = importlib.util.spec_from_file_location('mission_report', SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        del sys.modules[spec.name]


def check_pngs(paths):
    for path in paths:
        data = path.read_bytes()
        assert data.startswith(PNG_MAGIC), path
        assert 10_000 < len(data) < 400_000, (path, len(data))


def test_match_stamps_pairs_the_same_instants_only(report):
    truth = np.arange(0.0, 2.0, 0.05)  # 20 Hz steps
    estimate = np.array([0.1 + 1e-9, 0.2, 0.25 + 1e-3, 1.95, 3.0])  # 10 Hz-ish, one off-grid, one beyond
    i_est, i_truth = report.match_stamps(estimate, truth)
    assert i_est.tolist() == [0, 1, 3]
    assert np.allclose(truth[i_truth], [0.1, 0.2, 1.95])


def test_report_of_a_run_cut_before_any_plan(report, tmp_path, capsys):
    """40 s: the estimator runs, the planner has not planned yet (it waits 60 s of observation), so
    there is no path, grasp or burn. What can be drawn is, the rest is said on stderr."""
    run_dir = tmp_path / 'run'
    result = run_mission('--scenario', write_scenario(tmp_path, edit=with_duration(40.0)), '--out', run_dir,
                         '--in-process')
    assert result.returncode == 3, result.stderr
    assert read_summary(run_dir)['outcome'] == 'TIME_LIMIT'

    written = report.write_report(run_dir, tmp_path / 'report')

    assert [p.name for p in written] == [n for n in ALL_FIGURES if n != 'maneuvers.png']
    assert all(p.parent == tmp_path / 'report' for p in written)
    check_pngs(written)
    err = capsys.readouterr().err
    assert 'maneuvers.png skipped: no executed burn' in err
    assert '/planner/path' in err and '/planner/grasp' in err
    assert 'failed' not in err


def test_report_of_a_captured_run_from_the_command_line(tmp_path):
    """A complete fly-by kept short (60 s estimate -> 30 s, shorter transfer and fly-by): every figure."""
    def quick_capture(data):
        data['planner'].update(min_observation_s=30.0, transfer_min_s=100.0, transfer_max_s=160.0,
                               flyby_duration_s=150.0)
    run_dir = tmp_path / 'run'
    result = run_mission('--scenario', write_scenario(tmp_path, edit=quick_capture), '--out', run_dir,
                         '--in-process')
    assert result.returncode == 0, result.stderr
    assert read_summary(run_dir)['outcome'] == 'CAPTURE'

    cli = subprocess.run([sys.executable, str(SCRIPT), str(run_dir)], capture_output=True, text=True,
                         timeout=120, cwd=ROOT)

    assert cli.returncode == 0, cli.stderr
    written = [run_dir / name for name in ALL_FIGURES]  # --out defaults to the run directory
    assert cli.stdout.split() == [str(p) for p in written]
    check_pngs(written)
    assert 'skipped' not in cli.stderr and 'failed' not in cli.stderr


def test_sphere_intervals_interpolate_entry_and_exit(report):
    t = np.arange(0.0, 10.0, 1.0)
    r = np.array([20.0, 16.0, 14.0, 12.0, 14.0, 17.0, 15.0, 13.0, 12.0, 11.0])  # in at 1.5 s, out 4.5, in 6
    intervals = report.sphere_intervals(t, np.column_stack((r, np.zeros(10), np.zeros(10))), 15.0)
    assert np.allclose(intervals, [(1.5, 4 + 1 / 3), (6.0, 9.0)])  # the last one open at the end
    assert report.sphere_intervals(t, np.full((10, 3), 20.0), 15.0) == []


def test_continuous_quaternions_undo_sign_flips(report):
    angle = np.linspace(0.0, 3.0 * np.pi, 50)  # more than a turn about z: w changes sign
    q = np.column_stack((np.zeros(50), np.zeros(50), np.sin(angle / 2), np.cos(angle / 2)))
    flipped = q * np.where(np.arange(50) % 3 == 0, -1.0, 1.0)[:, None]
    assert np.allclose(report.continuous_quaternions(flipped), q)


def test_report_of_a_rigid_body_run_from_run_mission(report, tmp_path):
    """paper_flyby_6dof cut at 40 s after 20 s of observation: the transfer burn (about 30 s) fires thrusters and
    opens the pointing window. run_mission --report writes the rigid-body figures besides the others, and the
    velocities the figures draw are in hill: the truth's range rate is the range's derivative."""
    def short(data):
        data['simulation']['duration_s'] = 40.0
        data['planner']['min_observation_s'] = 20.0
    run_dir = tmp_path / 'run'
    result = run_mission('--scenario', write_scenario(tmp_path, base='paper_flyby_6dof', edit=short), '--out',
                         run_dir, '--in-process', '--report')
    assert result.returncode == 3, result.stderr
    summary = read_summary(run_dir)
    assert summary['outcome'] == 'TIME_LIMIT' and summary['maneuvers_executed'] >= 1
    assert summary['pointing_error_p95_deg'] is not None

    written = [run_dir / name for name in ALL_FIGURES + RIGID_BODY_FIGURES]
    assert [f'report: {p}' for p in written] == [line for line in result.stderr.splitlines()
                                                  if line.startswith('report: ')]
    check_pngs(written)
    assert 'failed' not in result.stderr and 'skipped' not in result.stderr

    run = report.Run(run_dir)
    assert run.rigid_body and run.sphere == []  # 50 m out: never inside the restriction sphere
    truth = run.need(c.SIM_CHASER_ODOM)
    r, r_dot = report._range_and_rate(truth)
    coasting = np.abs(truth.t - run.burns[0].t_start) > 3.0  # the burn lasts about 1.5 s
    assert np.max(np.abs(np.gradient(r, truth.t) - r_dot)[coasting][1:-1]) < 1e-6  # [m/s]
    read_in_body_axes = truth._replace(orientation_xyzw=np.tile((0.0, 0.0, 0.0, 1.0), (len(r), 1)))
    assert np.max(np.abs(report._range_and_rate(read_in_body_axes)[1] - r_dot)) > 1e-3  # what the check catches
