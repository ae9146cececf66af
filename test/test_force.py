"""--out and --force (DESIGN §11): a run's directory is replaced only when it holds a run of ours (its
run.json, written first), never the working directory, a parent of it, / or the home directory; nothing else is
ever deleted. Through the scripts as a user runs them, refusals before any flight and a short headless run."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from flyby_mission import cli
from flyby_testing import ROOT, run_mission, with_duration, write_scenario

CLOSED_LOOP = ROOT / 'scripts' / 'closed_loop.py'


def closed_loop(*args, cwd=ROOT):
    return subprocess.run([sys.executable, str(CLOSED_LOOP), *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=120)


def one_error_line(done, *words, code=2):
    """The process ended with ``code`` and one line ``error: ...`` holding ``words`` (no traceback)."""
    assert done.returncode == code, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('error: '), done.stderr
    for word in words:
        assert word in lines[0]


@pytest.fixture
def precious(tmp_path):
    """A directory that holds no run: only precious.txt."""
    d = tmp_path / 'mine'
    d.mkdir()
    (d / 'precious.txt').write_text('keep me')
    return d


@pytest.mark.parametrize('tool', ['run_mission', 'closed_loop'])
def test_force_refuses_a_directory_that_holds_no_run(tmp_path, precious, tool):
    scenario = write_scenario(tmp_path, edit=with_duration(5.0))
    if tool == 'run_mission':
        done = run_mission('--scenario', scenario, '--out', precious, '--force', timeout=60)
    else:
        done = closed_loop('--scenario', scenario, '--out', precious, '--force')
    one_error_line(done, '--out', 'holds no run')
    assert sorted(p.name for p in precious.iterdir()) == ['precious.txt']
    assert (precious / 'precious.txt').read_text() == 'keep me'


@pytest.mark.parametrize('tool', ['run_mission', 'closed_loop'])
def test_out_refuses_a_non_empty_directory_without_force(tmp_path, precious, tool):
    scenario = write_scenario(tmp_path, edit=with_duration(5.0))
    run = run_mission if tool == 'run_mission' else closed_loop
    one_error_line(run('--scenario', scenario, '--out', precious), '--out', 'pass --force')
    assert sorted(p.name for p in precious.iterdir()) == ['precious.txt']


@pytest.mark.parametrize('tool', ['run_mission', 'closed_loop'])
def test_force_refuses_the_working_directory(tmp_path, tool):
    scenario = write_scenario(tmp_path, edit=with_duration(5.0))
    cwd = tmp_path / 'work'
    cwd.mkdir()
    (cwd / 'run.json').write_text('{}')  # even one that looks like a run
    done = subprocess.run([sys.executable, str(ROOT / 'scripts' / f'{tool}.py'), '--scenario', str(scenario),
                           '--out', '.', '--force'], capture_output=True, text=True, cwd=cwd, timeout=60)
    one_error_line(done, '--out .', 'never replaced')
    assert (cwd / 'run.json').exists()


def test_force_refuses_the_parents_of_the_working_directory_root_and_home(tmp_path, monkeypatch):
    cwd = tmp_path / 'work'
    cwd.mkdir()
    (cwd / 'run.json').write_text('{}')
    monkeypatch.chdir(cwd)
    for out in ('..', str(tmp_path), '/', str(Path.home()), str(cwd)):
        with pytest.raises(ValueError, match='never replaced'):
            cli.check_out(out, True)


def test_out_refuses_a_file_and_an_uncreatable_directory(tmp_path):
    scenario = write_scenario(tmp_path, edit=with_duration(5.0))
    one_error_line(closed_loop('--scenario', scenario, '--out', scenario), 'is not a directory')
    one_error_line(run_mission('--scenario', scenario, '--out', scenario), 'is not a directory')
    one_error_line(closed_loop('--scenario', scenario, '--out', '/proc/flyby/run'), 'cannot be made', code=1)


def test_force_replaces_a_previous_run(tmp_path):
    scenario = write_scenario(tmp_path, edit=with_duration(5.0))
    out = tmp_path / 'run'
    first = closed_loop('--scenario', scenario, '--out', out)
    assert first.returncode == 3, first.stderr  # TIME_LIMIT: safe without capture
    marker = json.loads((out / cli.RUN_MARKER).read_text())
    assert marker['mode'] == 'headless'
    (out / 'stale.txt').write_text('from the previous run')
    one_error_line(closed_loop('--scenario', scenario, '--out', out), 'pass --force')
    again = closed_loop('--scenario', scenario, '--out', out, '--force')
    assert again.returncode == 3, again.stderr
    assert sorted(p.name for p in out.iterdir()) == ['run.json', 'scenario.yaml', 'summary.json']


def test_make_run_dir_writes_run_json_before_anything_else(tmp_path):
    out = cli.make_run_dir(tmp_path / 'a' / 'b', False, {'launcher_pid': 1})
    assert [p.name for p in out.iterdir()] == ['run.json']
    with pytest.raises(ValueError, match='holds no run'):
        (out / 'run.json').unlink()
        (out / 'x').write_text('')
        cli.make_run_dir(out, True, {})
