"""The chasers: list of a scenario (DESIGN §10 "Several chasers", flyby_sim.chasers)."""

from pathlib import Path

import pytest
import yaml

from flyby_msgs_py.schema import ScenarioError
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario, scenario_from_dict

ROOT = Path(__file__).resolve().parents[4]
TWO = ROOT / 'scenarios' / 'jacobsen_two_robots.yaml'
ONE = ROOT / 'scenarios' / 'jacobsen_optimal.yaml'


def _data():
    return yaml.safe_load(TWO.read_text())


def test_two_robot_scenario_views():
    sc = load_scenario(TWO)
    assert sc.chaser_names == ('chaser1', 'chaser2')
    one, two = sc.for_chaser('chaser1'), sc.for_chaser('chaser2')
    assert sc is one and one.chaser_name == 'chaser1' and two.chaser_name == 'chaser2'
    assert list(one.chaser.initial_position_hill_m) == [50.0, 0.0, 0.0]
    assert list(two.chaser.initial_position_hill_m) == [-50.0, 0.0, 0.0]
    assert list(two.target.grasp_point_body_m) == [-1.5, 0.0, -1.5]
    # the first chaser keeps the seed, the second draws its own
    assert one.seed == 1 and two.seed not in (0, 1)
    with pytest.raises(KeyError, match='chaser3'):
        sc.for_chaser('chaser3')


def test_single_chaser_scenario_unchanged():
    sc = load_scenario(ONE)
    assert sc.chaser_names == () and sc.chaser_name is None


def test_first_chaser_draws_as_alone():
    """chaser1 of the two-robot file is jacobsen_optimal's chaser with the same seed: the same plant, to the bit."""
    one = load_scenario(TWO).for_chaser('chaser1')
    alone = load_scenario(ONE)
    a, b = Plant(PlantConfig.from_scenario(one)), Plant(PlantConfig.from_scenario(alone))
    for _ in range(40):
        sa, sb = a.step(), b.step()
        assert (sa.r_hill == sb.r_hill).all() and (sa.q_hill_from_body == sb.q_hill_from_body).all()
        assert [m.value.tolist() if hasattr(m.value, 'tolist') else m.value for m in a.measurements()
                if m.kind != 'chaser_imu'] == [m.value.tolist() if hasattr(m.value, 'tolist') else m.value
                                               for m in b.measurements() if m.kind != 'chaser_imu']


def test_target_truth_is_the_same_in_every_chasers_plant():
    sc = load_scenario(TWO)
    plants = [Plant(PlantConfig.from_scenario(sc.for_chaser(n))) for n in sc.chaser_names]
    for _ in range(100):
        s1, s2 = (p.step() for p in plants)
        assert (s1.q_hill_from_body == s2.q_hill_from_body).all() and (s1.omega_body == s2.omega_body).all()


@pytest.mark.parametrize('edit, key', [
    (lambda d: d.update(chaser=d['chasers'][0]), 'chasers'),
    (lambda d: d['chasers'][1].update(name='chaser1'), 'chasers[1].name'),
    (lambda d: d['chasers'][1].update(name='Chaser 2'), 'chasers[1].name'),
    (lambda d: d['chasers'][1].update(mass_kg=-5.0), 'chasers[1].mass_kg'),
    (lambda d: d['chasers'][0].update(colour='red'), 'chasers[0].colour'),
    (lambda d: d['chasers'][1].update(grasp_point_body_m=[1.0, 2.0]), 'chasers[1].grasp_point_body_m'),
    (lambda d: d.update(chasers=d['chasers'][:1]), 'chasers'),
])
def test_errors_name_the_entry_key(edit, key):
    data = _data()
    edit(data)
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(data, name='two.yaml')
    assert err.value.key == key and str(err.value).startswith(f'two.yaml: {key}: ')
