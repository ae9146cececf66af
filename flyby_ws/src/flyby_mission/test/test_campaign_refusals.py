"""Campaign files that would crash, hang or be misread are refused at load, in one line naming the file and the
key: strings and booleans where numbers are due, parameters of different lengths, an excluded cone
that leaves no direction, unknown kinds, alias chains, and a run whose draw is not a valid scenario."""

import time
from pathlib import Path

import pytest
import yaml

from flyby_mission.campaign.dispersions import MAX_RUNS, CampaignError, load_campaign

ROOT = Path(__file__).resolve().parents[4]
BASE = ROOT / 'scenarios' / 'paper_flyby.yaml'
HILL = 'target.initial_attitude.body_axis_along_hill.hill'
OMEGA = 'target.initial_rate.omega_body_deg_s'


def _campaign(tmp_path, dispersions, runs=10):
    path = tmp_path / 'c.yaml'
    path.write_text(yaml.safe_dump({'base_scenario': str(BASE), 'seed': 3, 'runs': runs,
                                    'dispersions': dispersions}))
    return path


def _refusal(path):
    with pytest.raises(CampaignError) as err:
        load_campaign(path)
    message = str(err.value)
    assert '\n' not in message
    return message


def _cone(**cone):
    return {HILL: {'kind': 'direction', 'exclude_cone': {'axis': [0, 1, 0], **cone}}}


@pytest.mark.parametrize('dispersions, key, problem', [
    (_cone(half_angle_deg='abc'), f'dispersions.{HILL}.exclude_cone.half_angle_deg',
     "must be a finite number (at most 1e+30 in magnitude), got string 'abc'"),
    (_cone(half_angle_deg='10'), f'dispersions.{HILL}.exclude_cone.half_angle_deg',
     "must be a finite number (at most 1e+30 in magnitude), got string '10'"),
    (_cone(half_angle_deg=True), f'dispersions.{HILL}.exclude_cone.half_angle_deg',
     'must be a finite number (at most 1e+30 in magnitude), got true (bool)'),
    (_cone(half_angle_deg=10, both_ways='no'), f'dispersions.{HILL}.exclude_cone.both_ways',
     "must be true or false, got string 'no'"),
    ({HILL: {'kind': 'direction', 'axis_probability': True}}, f'dispersions.{HILL}.axis_probability',
     'must be a number in [0, 1], got true (bool)'),
    ({OMEGA: {'kind': 'uniform', 'low': [0, 0], 'high': [1, 1, 1]}}, f'dispersions.{OMEGA}',
     'parameters have different lengths'),
    ({OMEGA: {'kind': 'uniform', 'low': ['0', 0, 0], 'high': [1, 1, 1]}}, f'dispersions.{OMEGA}.low',
     "low must be a finite number (at most 1e+30 in magnitude, as every scenario number), a list of them"),
    ({'chaser.mass_kg': {'kind': 'normal', 'mean': 100, 'sigma': True}}, 'dispersions.chaser.mass_kg.sigma',
     'sigma must be a finite number'),
    ({'chaser.mass_kg': {'kind': 'scale', 'factor': True}}, 'dispersions.chaser.mass_kg.factor',
     "must be a mapping with a 'kind'"),
    ({'chaser.mass_kg': {'kind': 7}}, 'dispersions.chaser.mass_kg.kind', 'unknown dispersion kind 7'),
    ({'chaser.mass_kg': {'kind': ['uniform']}}, 'dispersions.chaser.mass_kg.kind',
     "unknown dispersion kind ['uniform']"),
])
def test_campaign_refuses_strings_bools_and_mismatched_parameters(tmp_path, dispersions, key, problem):
    path = _campaign(tmp_path, dispersions)
    message = _refusal(path)
    assert message.startswith(f'{path}: {key}: ') and problem in message, message


@pytest.mark.parametrize('cone, bound', [
    ({'half_angle_deg': 90, 'both_ways': True}, '89.43'),
    ({'half_angle_deg': 89.9, 'both_ways': True}, '89.43'),
    ({'half_angle_deg': 180}, '168.52'),
    ({'half_angle_deg': 179.99}, '168.52'),
    ({'half_angle_deg': -1}, '168.52'),
])
def test_campaign_refuses_an_exclusion_cone_that_leaves_no_direction(tmp_path, cone, bound):
    path = _campaign(tmp_path, _cone(**cone))
    message = _refusal(path)
    assert message.startswith(f'{path}: dispersions.{HILL}.exclude_cone.half_angle_deg: must be in [0, {bound}]')


def test_campaign_draws_directions_outside_the_widest_allowed_cone(tmp_path):
    campaign = load_campaign(_campaign(tmp_path, _cone(half_angle_deg=89.4, both_ways=True), runs=20))
    for run in range(20):
        assert abs(campaign.draw(run)[1][HILL][1]) < 0.0105  # cos 89.4 deg


def _laughs_campaign(tmp_path, where):
    chain = ['l0: &l0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    chain += [f'  l{i}: &l{i} [' + ','.join([f'*l{i - 1}'] * 9) + ']' for i in range(1, 10)]
    spec = {'low': '{kind: uniform, low: *l9, high: 1}', 'kind': '{kind: *l9, low: 0, high: 1}'}[where]
    path = tmp_path / 'c.yaml'
    path.write_text(f'base_scenario: {BASE}\nseed: 3\ndescription:\n  ' + '\n'.join(chain) +
                    f'\ndispersions:\n  chaser.mass_kg: {spec}\n')
    return path


@pytest.mark.parametrize('where', ['low', 'kind'])
def test_campaign_refuses_a_billion_laughs_alias_chain_fast(tmp_path, where):
    path = _laughs_campaign(tmp_path, where)
    start = time.perf_counter()
    message = _refusal(path)
    assert time.perf_counter() - start < 1.0
    assert message == (f'{path}: YAML error: aliases (*name) expand the document by more than 100000 values '
                       f'(at dispersions.chaser.mass_kg.{where})')


def test_campaign_refuses_a_run_beyond_the_first_five_that_draws_an_invalid_scenario(tmp_path):
    """Every run is validated at load: a mass of mean 60 and sigma 20 draws a negative one in some run of 500."""
    path = _campaign(tmp_path, {'chaser.mass_kg': {'kind': 'normal', 'mean': 60, 'sigma': 20}}, runs=500)
    message = _refusal(path)
    assert message.startswith(f'{path}: dispersions.chaser.mass_kg: run ')
    run = int(message.split(': run ')[1].split()[0])
    assert run >= 5 and 'draws an invalid scenario: must be > 0' in message


def test_campaign_refuses_more_runs_than_it_can_validate(tmp_path):
    message = _refusal(_campaign(tmp_path, {}, runs=MAX_RUNS + 1))
    assert message.endswith(f'runs: must be an integer in [1, {MAX_RUNS}], got {MAX_RUNS + 1}')
    with pytest.raises(CampaignError, match=r'runs: must be at most 10000, got 10001 \(from the runs argument\)'):
        load_campaign(_campaign(tmp_path, {}), checked_draws=MAX_RUNS + 1)


def test_campaign_refuses_a_name_that_is_not_a_string(tmp_path):
    path = tmp_path / 'c.yaml'
    path.write_text(yaml.safe_dump({'base_scenario': str(BASE), 'seed': 3, 'name': [1], 'dispersions': {}}))
    assert _refusal(path) == f'{path}: name: must be a non-empty string, got a list of length 1'


@pytest.mark.parametrize('seed', [-1, 2**32, 10**23])
def test_campaign_refuses_a_seed_beyond_32_bits(tmp_path, seed):
    path = tmp_path / 'c.yaml'
    path.write_text(yaml.safe_dump({'base_scenario': str(BASE), 'seed': seed, 'dispersions': {}}))
    assert _refusal(path) == f'{path}: seed: must be an integer in [0, 4294967295], got {seed}'


def test_campaign_refuses_a_box_surface_point_chaser_start_inside_the_target(tmp_path):
    """A chaser start drawn on the target's faces is within its envelope of the target: refused at load."""
    path = _campaign(tmp_path, {'chaser.initial_position_hill_m': {'kind': 'box_surface_point'}})
    message = _refusal(path)
    assert message.startswith(f'{path}: dispersions.chaser.initial_position_hill_m: run 0 draws an invalid scenario: ')


def test_campaign_refuses_a_dispersion_into_a_section_the_base_leaves_out(tmp_path):
    """matsunaga_orbit_advance starts attached: its target has no initial_rate section to disperse."""
    path = tmp_path / 'c.yaml'
    path.write_text(yaml.safe_dump({'base_scenario': str(ROOT / 'scenarios' / 'matsunaga_orbit_advance.yaml'),
                                    'seed': 3, 'dispersions': {OMEGA: {'kind': 'direction'}}}))
    assert _refusal(path) == (f'{path}: dispersions.{OMEGA}: not in the base scenario (its section is absent or the '
                              f'index is out of range)')
