"""A run directory replays its run (flyby_mission.replay): scenario.yaml holds the seed flown (--seed overriding the
file's), the user's comments kept, and run.json the command that flies it again; that command, headless and in the
graph, gives the same summary but the wall-clock figures. The report's titles name the run's seed."""

import json
import shlex
import subprocess

import pytest
import yaml

from flyby_mission import replay
from flyby_mission.report.loading import run_title
from flyby_sim.scenario import load_scenario, scenario_from_dict
from flyby_testing import ROOT, SCENARIOS, read_summary, run_mission

WALL_CLOCK_KEYS = ('wall_time_s', 'real_time_factor', 'planning_time_s')


def replayed(run_dir, extra=()):
    """Run the replay command of run_dir's run.json from the repository's root; its run directory."""
    command = json.loads((run_dir / 'run.json').read_text())[replay.REPLAY_KEY]
    args = shlex.split(command)
    assert args[0] == replay.PYTHON and args[args.index('--scenario') + 1] == str(run_dir / 'scenario.yaml')
    done = subprocess.run(args + list(extra), capture_output=True, text=True, cwd=ROOT, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    return run_dir.parent / f'{run_dir.name}-replay'


def same_but_wall_clock(first, second, also=()):
    ignored = set(WALL_CLOCK_KEYS) | set(also)
    assert {k: v for k, v in first.items() if k not in ignored} == {k: v for k, v in second.items()
                                                                     if k not in ignored}


def test_the_seed_line_alone_changes_and_the_comments_stay():
    source = SCENARIOS / 'paper_flyby.yaml'
    text = replay.scenario_text(source, 7)
    original = source.read_text().splitlines()
    changed = [(a, b) for a, b in zip(original, text.splitlines(), strict=True) if a != b]
    assert changed == [('seed: 1', 'seed: 7')]
    assert load_scenario(source, seed=7) == scenario_from_dict(yaml.safe_load(text))
    assert replay.scenario_text(source, 1) == source.read_text()  # the file's own seed: the file as it is


def test_a_seed_with_a_comment_or_in_a_flow_mapping_is_set_too(tmp_path):
    data = yaml.safe_load((SCENARIOS / 'paper_flyby.yaml').read_text())
    commented = tmp_path / 'commented.yaml'
    commented.write_text((SCENARIOS / 'paper_flyby.yaml').read_text().replace('seed: 1', 'seed: 1   # the paper\'s'))
    assert "seed: 12   # the paper's" in replay.scenario_text(commented, 12)
    flow = tmp_path / 'flow.yaml'
    flow.write_text(yaml.safe_dump(data, default_flow_style=True))
    assert yaml.safe_load(replay.scenario_text(flow, 12)) == {**data, 'seed': 12}


@pytest.mark.slow
def test_a_headless_run_with_seed_7_replays_from_its_directory(tmp_path):
    out = tmp_path / 'run'
    done = subprocess.run([replay.PYTHON, 'scripts/closed_loop.py', '--scenario', str(SCENARIOS / 'paper_flyby.yaml'),
                           '--seed', '7', '--out', str(out)], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert done.returncode == 0, done.stderr
    assert load_scenario(out / 'scenario.yaml').seed == 7
    first = read_summary(out)
    assert first['seed'] == 7
    second = read_summary(replayed(out))
    same_but_wall_clock(first, second)
    assert run_title(out, load_scenario(out / 'scenario.yaml'), first) == 'paper_flyby, seed 7: CAPTURE'


def test_the_report_titles_name_the_seed_of_the_summary_before_the_scenario_files():
    scenario = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    assert run_title('x', scenario, {'seed': 7, 'outcome': 'ESCAPE'}) == 'paper_flyby, seed 7: ESCAPE'
    assert run_title('x', scenario, {}) == 'paper_flyby, seed 1'
    assert run_title(ROOT / 'runs' / 'r', None, {'seed': 3}) == 'r, seed 3'


@pytest.mark.slow
def test_a_graph_run_with_seed_7_replays_from_its_directory(tmp_path):
    """The graph's replay flies the same truth: the same summary but its timings and the stop after COMPLETE (the
    launcher stops the graph at its own pace: sim_time_s, and the zero thrust samples it adds to delta-v and fuel)."""
    out = tmp_path / 'run'
    done = run_mission('--scenario', SCENARIOS / 'paper_flyby.yaml', '--seed', 7, '--out', out, '--in-process')
    assert done.returncode == 0, done.stderr[-3000:]
    assert load_scenario(out / 'scenario.yaml').seed == 7
    assert ' --in-process' in json.loads((out / 'run.json').read_text())[replay.REPLAY_KEY]
    first = read_summary(out)
    second = read_summary(replayed(out, ['--quiet']))
    assert first['seed'] == second['seed'] == 7
    same_but_wall_clock(first, second, also=('sim_time_s', 'delta_v_total_mps', 'fuel_used_kg'))
    for key in ('delta_v_total_mps', 'fuel_used_kg'):
        assert second[key] == pytest.approx(first[key], rel=1e-12)
