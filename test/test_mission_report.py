"""scripts/mission_report.py on real runs: one cut short before any plan, one that captures."""

import importlib.util
import subprocess
import sys

import numpy as np
import pytest

from flyby_testing import ROOT, read_summary, run_mission, with_duration, write_scenario

SCRIPT = ROOT / 'scripts' / 'mission_report.py'
ALL_FIGURES = ('trajectory_xz.png', 'trajectory_3d.png', 'range.png', 'maneuvers.png', 'estimation.png',
               'clearance.png')
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
