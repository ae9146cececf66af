"""The launcher's library without running a graph: the node graph it starts, the faults it injects and the checks
of its inputs (scripts/run_mission.py runs it; test/test_run_mission.py flies it)."""

from pathlib import Path

import pytest

from flyby_mission.launcher import (
    OFF_CHAIN_NICE,
    OPTIONAL_NODES,
    LaunchError,
    LaunchOptions,
    NodeSpec,
    faults_from_args,
    graph_for,
    prepare,
)
from flyby_sim.sim_node import COMMAND_CHAIN

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'


def test_graph_starts_the_recorder_first_and_the_simulator_last():
    specs = graph_for('/s.yaml', 7, 0.0, '/bag')
    assert [s.name for s in specs] == ['flyby_recorder', *OPTIONAL_NODES, 'flyby_sim']
    sim = specs[-1]
    assert sim.params['wait_for_nodes'] == [s.label for s in specs[:-1]] == sim.params['keep_up_with']
    assert all(s.params['seed'] == 7 for s in specs[1:])
    supervisor = next(s for s in specs if s.name == 'flyby_supervisor')
    assert supervisor.params['watched_nodes'] == ['flyby_estimator', 'flyby_guidance']


def test_nodes_off_the_command_chain_yield_the_cpu():
    for spec in graph_for('/s.yaml', 1, 0.0, '/bag'):
        assert spec.nice == (0 if spec.name in COMMAND_CHAIN or spec.name == 'flyby_sim' else OFF_CHAIN_NICE)


def test_without_leaves_out_a_node_and_its_watch():
    specs = graph_for('/s.yaml', 1, 0.0, '/bag', without=('flyby_guidance',))
    assert 'flyby_guidance' not in [s.name for s in specs]
    supervisor = next(s for s in specs if s.name == 'flyby_supervisor')
    assert supervisor.params['watched_nodes'] == ['flyby_estimator']


def test_several_chasers_each_under_its_namespace():
    specs = graph_for('/s.yaml', 1, 0.0, '/bag', chasers=('a', 'b'))
    assert specs[0].params['namespaces'] == ['/a', '/b']
    labels = [s.label for s in specs]
    assert 'a/flyby_planner' in labels and 'b/flyby_guidance' in labels
    assert NodeSpec('n', 'm', 'C').label == 'n'


def test_faults_name_the_bad_option():
    faults = faults_from_args(LaunchOptions('s', 'o', abort_at=12.0, kill='flyby_guidance@200'))
    assert (faults.abort_at_s, faults.kill_node, faults.kill_at_s) == (12.0, 'flyby_guidance', 200.0)
    with pytest.raises(ValueError, match='--kill: expected NODE@T'):
        faults_from_args(LaunchOptions('s', 'o', kill='flyby_guidance@soon'))
    with pytest.raises(ValueError, match="'flyby_sim' is not a node that can be killed"):
        faults_from_args(LaunchOptions('s', 'o', kill='flyby_sim@3'))


def test_prepare_checks_the_inputs_in_order(tmp_path):
    scenario = str(SCENARIOS / 'paper_flyby.yaml')
    with pytest.raises(LaunchError, match='absent.yaml'):
        prepare(LaunchOptions(str(tmp_path / 'absent.yaml'), str(tmp_path / 'out'), rtf=-1.0))
    with pytest.raises(LaunchError, match='--rtf: must be a finite number >= 0'):
        prepare(LaunchOptions(scenario, str(tmp_path / 'out'), rtf=-1.0))
    (tmp_path / 'out').mkdir()
    (tmp_path / 'out' / 'old').write_text('')
    with pytest.raises(LaunchError, match='pass --force'):
        prepare(LaunchOptions(scenario, str(tmp_path / 'out')))
    with pytest.raises(LaunchError, match='holds no run'):  # --force replaces only a previous run
        prepare(LaunchOptions(scenario, str(tmp_path / 'out'), force=True))
    (tmp_path / 'out' / 'run.json').write_text('{}')
    loaded, faults, run_dir = prepare(LaunchOptions(scenario, str(tmp_path / 'out'), seed=4, force=True))
    assert (loaded.seed, faults.kill_node, run_dir) == (4, None, tmp_path / 'out')
    assert (tmp_path / 'out' / 'old').exists()  # prepare only checks: the run replaces it
