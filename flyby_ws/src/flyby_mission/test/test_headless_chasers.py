"""The headless loop flies one chaser: a chasers: scenario is refused naming the file and the key, never flown as its
first chaser alone (docs/two_robots.md)."""

from pathlib import Path

import pytest

from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_scenario

TWO = Path(__file__).resolve().parents[4] / 'scenarios' / 'jacobsen_two_robots.yaml'


@pytest.mark.parametrize('view', [None, 'chaser2'])
def test_headless_refuses_a_chasers_scenario(view):
    scenario = load_scenario(TWO)
    if view is not None:
        scenario = scenario.for_chaser(view)
    with pytest.raises(ScenarioError) as err:
        run_headless(scenario)
    assert err.value.key == 'chasers'
    assert str(err.value).startswith(f'{TWO}: chasers: the headless loop flies one chaser')
    assert '\n' not in str(err.value)
    with pytest.raises(ScenarioError):
        HeadlessGraph(scenario)
