"""A scenario file built to exhaust memory or time is refused fast, in one line naming the file."""

import time
from pathlib import Path

import pytest

from flyby_sim.scenario import ScenarioError, load_scenario

BASE = Path(__file__).resolve().parents[4] / 'scenarios' / 'paper_flyby.yaml'


def _laughs():
    """A 'billion laughs' alias chain: ten levels of nine aliases (9**10 strings once expanded), about 400 bytes."""
    lines = ['l0: &l0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    lines += [f'l{i}: &l{i} [' + ','.join([f'*l{i - 1}'] * 9) + ']' for i in range(1, 10)]
    return '\n'.join(lines) + '\n'


def test_scenario_refuses_a_billion_laughs_under_an_enum_key_in_well_under_a_second(tmp_path):
    path = tmp_path / 'laughs.yaml'
    path.write_text(_laughs() + BASE.read_text().replace('dynamics: nonlinear', 'dynamics: *l9'))
    start = time.perf_counter()
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert time.perf_counter() - start < 0.5
    assert str(err.value) == (f'{path}: YAML error: aliases (*name) expand the document by more than 100000 '
                              'values (at simulation.dynamics)')


def test_scenario_refuses_a_file_of_several_megabytes_fast(tmp_path):
    path = tmp_path / 'big.yaml'
    path.write_text(BASE.read_text() + 'padding: [' + ','.join(['1'] * 2_600_000) + ']\n')
    start = time.perf_counter()
    with pytest.raises(ScenarioError, match=r'big\.yaml: file is \d+ bytes, more than the 1048576 bytes'):
        load_scenario(path)
    assert time.perf_counter() - start < 0.5
