"""Scenario errors: one line naming the file, the dotted key path and the problem, one test per error class."""

from pathlib import Path

import pytest

from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_scenario, scenario_from_dict
from flyby_testing import paper_dict
from flyby_testing import scenario_error_of as error_of
from flyby_testing import write_yaml as write

REPO = Path(__file__).resolve().parents[4]
PAPER = REPO / 'scenarios' / 'paper_flyby.yaml'


def test_error_out_of_range(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['chaser'].update(mass_kg=-5))
    assert msg == f'{p}: chaser.mass_kg: must be > 0, got -5.0'


def test_error_unknown_key_with_suggestion(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['target'].update(inertial_attitude=d['target'].pop('initial_attitude')))
    assert msg == f"{p}: target.inertial_attitude: unknown key (did you mean 'initial_attitude'?)"


def test_error_unknown_key_deep_and_top_level(tmp_path):
    _, msg = error_of(tmp_path, lambda d: d['chaser']['thrusters'].update(isp=200.0))
    assert ": chaser.thrusters.isp: unknown key (did you mean 'isp_s'?)" in msg
    _, msg = error_of(tmp_path, lambda d: d.update(zzz=1))
    assert ': zzz: unknown key (expected one of: name, description, seed, orbit,' in msg
    _, msg = error_of(tmp_path, lambda d: d['target']['geometry'][2].update(colour='red'))
    assert ': target.geometry[2].colour: unknown key' in msg


def test_error_missing_required_key(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['chaser']['thrusters'].pop('isp_s'))
    assert msg == f'{p}: chaser.thrusters.isp_s: missing required key'
    _, msg = error_of(tmp_path, lambda d: d.pop('chaser'))
    assert msg.endswith(': chaser: missing required key')


def test_error_enum(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['simulation'].update(dynamics='kepler'))
    assert msg == f"{p}: simulation.dynamics: must be one of ['cw', 'nonlinear'], got 'kepler'"


def test_error_file_not_found(tmp_path):
    p = tmp_path / 'nope.yaml'
    with pytest.raises(ScenarioError, match='nope.yaml: file not found$'):
        load_scenario(p)


def test_error_yaml_syntax_names_line(tmp_path):
    text = PAPER.read_text().replace('  mass_kg: 100.0', '  mass_kg: [100.0', 1)
    p = write(tmp_path, text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(p)
    msg = str(info.value)
    assert msg.startswith(f'{p}: YAML syntax error at line ') and '\n' not in msg


def test_error_duplicate_yaml_key(tmp_path):
    text = PAPER.read_text().replace('  mass_kg: 100.0\n', '  mass_kg: 100.0\n  mass_kg: 90.0\n')
    p = write(tmp_path, text)
    line = text.splitlines().index('  mass_kg: 90.0') + 1
    with pytest.raises(ScenarioError, match=f"line {line}, column 3: .*duplicate key 'mass_kg'"):
        load_scenario(p)


@pytest.mark.parametrize('text,got', [('- a\n- b\n', 'a list of length 2'), ('', 'an empty file'),
                                      ('42\n', '42')])
def test_error_top_level_not_a_mapping(tmp_path, text, got):
    p = write(tmp_path, text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(p)
    assert str(info.value) == f'{p}: top level must be a mapping of sections, got {got}'


@pytest.mark.parametrize('value,shown', [('.nan', 'nan'), ('.inf', 'inf'), ('-.inf', '-inf')])
def test_error_non_finite(tmp_path, value, shown):
    p = write(tmp_path, PAPER.read_text().replace('isp_s: 220.0', f'isp_s: {value}'))
    with pytest.raises(ScenarioError) as info:
        load_scenario(p)
    assert str(info.value) == f'{p}: chaser.thrusters.isp_s: must be finite, got {shown}'


def test_error_non_finite_vector_component(tmp_path):
    p = write(tmp_path, PAPER.read_text().replace('[1.5, 0.0, 1.5]', '[1.5, .nan, 1.5]'))
    with pytest.raises(ScenarioError, match=r': target\.grasp_point_body_m\[1\]: must be finite, got nan$'):
        load_scenario(p)


def test_error_wrong_vector_length(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['chaser'].update(initial_position_hill_m=[50.0, 0.0]))
    assert msg == f'{p}: chaser.initial_position_hill_m: must be a 3-vector [x, y, z], got a list of length 2'
    _, msg = error_of(tmp_path, lambda d: d['target']['initial_attitude'].update(
        q_hill_from_body=[0, 0, 1], body_axis_along_hill=None) or d['target']['initial_attitude'].pop(
        'body_axis_along_hill'))
    assert msg.endswith(': target.initial_attitude.q_hill_from_body: must be a quaternion [x, y, z, w], '
                        'got a list of length 3')
    _, msg = error_of(tmp_path, lambda d: d['target'].update(inertia_kg_m2=[[1, 0, 0], [0, 1, 0]]))
    assert ': target.inertia_kg_m2: must be a 3x3 matrix' in msg
    _, msg = error_of(tmp_path, lambda d: d['target'].update(inertia_kg_m2=[[1, 0, 0], [0, 1], [0, 0, 1]]))
    assert ': target.inertia_kg_m2[1]: must be a row of 3 numbers, got a list of length 2' in msg


def test_error_wrong_types(tmp_path):
    _, msg = error_of(tmp_path, lambda d: d['chaser'].update(mass_kg='100'))
    assert msg.endswith(": chaser.mass_kg: must be a number, got string '100'")
    _, msg = error_of(tmp_path, lambda d: d['chaser'].update(mass_kg=True))
    assert msg.endswith(': chaser.mass_kg: must be a number, got true (bool)')
    _, msg = error_of(tmp_path, lambda d: d['chaser'].update(mass_kg=None))
    assert msg.endswith(': chaser.mass_kg: must be a number, got null')
    _, msg = error_of(tmp_path, lambda d: d.update(seed=1.0))
    assert msg.endswith(': seed: must be an integer, got 1.0')
    _, msg = error_of(tmp_path, lambda d: d.update(name=5))
    assert msg.endswith(': name: must be a string, got 5')
    _, msg = error_of(tmp_path, lambda d: d.update(chaser=[1, 2]))
    assert msg.endswith(': chaser: must be a mapping, got a list of length 2')
    _, msg = error_of(tmp_path, lambda d: d['chaser'].update(initial_position_hill_m=[50.0, 'x', 0.0]))
    assert msg.endswith(": chaser.initial_position_hill_m[1]: must be a number, got string 'x'")


def test_error_exactly_one_of(tmp_path):
    _, msg = error_of(tmp_path, lambda d: d['orbit'].update(altitude_m=400000.0))
    assert msg.endswith(": orbit: exactly one of 'radius_m', 'altitude_m' must be given, got 'radius_m', 'altitude_m'")
    _, msg = error_of(tmp_path, lambda d: d['orbit'].pop('radius_m'))
    assert msg.endswith(": orbit: exactly one of 'radius_m', 'altitude_m' must be given, got none")
    _, msg = error_of(tmp_path, lambda d: d['target']['initial_rate'].update(omega_hill_rad_s=[0, 0, 1]))
    assert ': target.initial_rate: exactly one of ' in msg


def test_error_attitude_vectors_nonzero(tmp_path):
    _, msg = error_of(tmp_path, lambda d: d['target'].update(initial_attitude={'q_hill_from_body': [0, 0, 0, 0]}))
    assert msg.endswith(': target.initial_attitude.q_hill_from_body: must be nonzero, got [0.0, 0.0, 0.0, 0.0]')
    _, msg = error_of(tmp_path, lambda d: d['target']['initial_attitude']['body_axis_along_hill'].update(
        hill=[0, 0, 0]))
    assert msg.endswith(': target.initial_attitude.body_axis_along_hill.hill: must be nonzero, got [0.0, 0.0, 0.0]')


@pytest.mark.parametrize('inertia,problem', [
    ([[1200, 5, 0], [0, 1000, 0], [0, 0, 2000]], 'must be symmetric'),
    ([[1200, 0, 0], [0, -1000, 0], [0, 0, 2000]], 'must be positive definite'),
    ([[100, 0, 0], [0, 100, 0], [0, 0, 2000]], 'violate the triangle inequality'),
])
def test_error_inertia(tmp_path, inertia, problem):
    _, msg = error_of(tmp_path, lambda d: d['target'].update(inertia_kg_m2=inertia))
    assert ': target.inertia_kg_m2: ' in msg and problem in msg


def test_error_geometry(tmp_path):
    _, msg = error_of(tmp_path, lambda d: d['target'].update(geometry=[]))
    assert msg.endswith(': target.geometry: must be a non-empty list, got a list of length 0')
    _, msg = error_of(tmp_path, lambda d: d['target']['geometry'][1].update(size_m=[2.0, 6.0, 0.0]))
    assert ': target.geometry[1].size_m[2]: must be in (0, 1e6], got 0.0 (' in msg
    _, msg = error_of(tmp_path, lambda d: d['target']['geometry'][2].update(name='bus'))
    assert msg.endswith(": target.geometry[2].name: duplicate box name 'bus' (also at index 0)")
    _, msg = error_of(tmp_path, lambda d: d['target']['geometry'][0].pop('center_m'))
    assert msg.endswith(': target.geometry[0].center_m: missing required key')


def test_error_step_too_long_says_why(tmp_path):
    _, msg = error_of(tmp_path, lambda d: d['simulation'].update(step_s=0.1))
    assert msg.endswith(': simulation.step_s: must be in [0.001, 0.05], got 0.1 '
                        '(truth is published every step and must reach >= 20 Hz, DESIGN §4; a finer step than '
                        '0.001 s resolves nothing more and makes the run endless)')


def test_error_sensor_rate_above_step_rate(tmp_path):
    def mutate(d):
        d['simulation']['step_s'] = 0.04
        d['sensors']['target_attitude']['rate_hz'] = 30.0
    _, msg = error_of(tmp_path, mutate)
    assert msg.endswith(': sensors.target_attitude.rate_hz: must be <= 1/simulation.step_s = 25 Hz '
                        '(a sensor samples at most once per step), got 30.0')
    # Exactly the step rate is fine despite 1/0.05 not being exact in binary.
    d = paper_dict()
    d['sensors']['relative_position']['rate_hz'] = 20.0
    assert scenario_from_dict(d).sensors.relative_position.rate_hz == 20.0


def test_error_transfer_window_reversed(tmp_path):
    _, msg = error_of(tmp_path, lambda d: d['planner'].update(transfer_min_s=500.0, transfer_max_s=400.0))
    assert msg.endswith(': planner.transfer_max_s: must be >= planner.transfer_min_s = 500.0, got 400.0')


def test_error_sun_direction_zero(tmp_path):
    _, msg = error_of(tmp_path, lambda d: d['planner'].update(sun_direction_hill=[0, 0, 0]))
    assert msg.endswith(': planner.sun_direction_hill: must be nonzero, got [0.0, 0.0, 0.0]')
