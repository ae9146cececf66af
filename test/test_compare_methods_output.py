"""scripts/compare_methods.py writes its figure under runs/ of the working directory unless told where, never over the
tracked docs/figures/seed003_fig14_methods.png; a --figure it cannot write is refused in one line (exit code 2)."""

import subprocess
import sys

from flyby_testing import ROOT, with_duration, write_scenario

COMPARE = ROOT / 'scripts' / 'compare_methods.py'
TRACKED = ROOT / 'docs' / 'figures' / 'seed003_fig14_methods.png'


def compare(cwd, *args):
    return subprocess.run([sys.executable, str(COMPARE), *map(str, args)], capture_output=True, text=True,
                          timeout=300, cwd=cwd)


def test_the_figure_goes_under_runs_of_the_working_directory_by_default(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby_6dof', edit=with_duration(5.0))  # both runs: TIME_LIMIT
    tracked_before = TRACKED.stat().st_mtime_ns if TRACKED.exists() else None
    done = compare(tmp_path, '--scenario', scenario)
    assert done.returncode == 0, done.stderr
    figure = tmp_path / 'runs' / 'compare_methods' / 'seed003_fig14_methods.png'
    assert figure.stat().st_size > 10_000
    assert f'figure: {figure.relative_to(tmp_path)}' in done.stdout
    assert (TRACKED.stat().st_mtime_ns if TRACKED.exists() else None) == tracked_before


def test_a_figure_in_a_missing_directory_is_refused_in_one_line(tmp_path):
    done = compare(tmp_path, '--figure', tmp_path / 'missing' / 'fig.png')
    assert done.returncode == 2
    assert done.stderr == f'error: --figure {tmp_path / "missing" / "fig.png"}: its directory does not exist\n'
    done = compare(tmp_path, '--figure', tmp_path)
    assert done.returncode == 2 and done.stderr == f'error: --figure {tmp_path}: is a directory (give a .png file)\n'
