"""Scenario values the types allow but physics does not: each refused at load in one line naming the file
and the key, never a traceback later (flyby_sim.scenario.plausibility and the direction checks)."""

import copy
import re
from pathlib import Path

import pytest
import yaml

from flyby_msgs_py.schema import ScenarioError
from flyby_sim.dynamics.actuators import default_thruster_layout
from flyby_sim.scenario import load_scenario, scenario_from_dict
from flyby_testing import scenario_error_of as error_of
from flyby_testing import write_yaml as write

REPO = Path(__file__).resolve().parents[4]


def load_yaml(path):
    return yaml.safe_load(Path(path).read_text())


def _one_line(msg, path, key):
    """One line naming the file and the key (or one of its components, where a range refuses a component)."""
    assert '\n' not in msg
    assert re.match(rf'{re.escape(str(path))}: {re.escape(key)}(\[\d+\])*: ', msg), msg


@pytest.mark.parametrize('radius, what', [(1e300, "above the Earth's equatorial radius"), (1e-300, 'at least 1e-30'),
                                          (1000.0, "above the Earth's equatorial radius"),
                                          (2e9, "above the Earth's equatorial radius")])
def test_refuses_an_orbit_inside_the_earth_or_beyond_1e9_m(tmp_path, radius, what):
    p, msg = error_of(tmp_path, lambda d: d['orbit'].update(radius_m=radius))
    _one_line(msg, p, 'orbit.radius_m')
    assert what in msg


def test_refuses_an_altitude_beyond_1e9_m(tmp_path):
    def mutate(d):
        d['orbit'] = {'altitude_m': 1e300}
    p, msg = error_of(tmp_path, mutate)
    _one_line(msg, p, 'orbit.altitude_m')


@pytest.mark.parametrize('mu', [1e-300, 1e300])
def test_refuses_a_mu_of_no_moon_or_planet(tmp_path, mu):
    p, msg = error_of(tmp_path, lambda d: d['orbit'].update(mu_m3_s2=mu))
    _one_line(msg, p, 'orbit.mu_m3_s2')


def test_refuses_a_quaternion_whose_norm_underflows(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['target'].update(initial_attitude={'q_hill_from_body': [1e-200, 0, 0, 0]}))
    _one_line(msg, p, 'target.initial_attitude.q_hill_from_body')
    assert 'norm 1e-200' in msg


@pytest.mark.parametrize('end', ['body', 'hill'])
def test_refuses_a_body_axis_along_hill_whose_norm_underflows(tmp_path, end):
    p, msg = error_of(tmp_path, lambda d: d['target']['initial_attitude']['body_axis_along_hill'].update(
        {end: [1e-200, 0.0, 0.0]}))
    _one_line(msg, p, f'target.initial_attitude.body_axis_along_hill.{end}')


def test_refuses_a_direction_whose_norm_overflows(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['planner'].update(sun_direction_hill=[1e300, 1e300, 0.0]))
    _one_line(msg, p, 'planner.sun_direction_hill')


def _six_dof(tmp_path, mutate):
    return error_of(tmp_path, mutate, base='paper_flyby_6dof')


def test_refuses_a_thruster_direction_whose_norm_underflows(tmp_path):
    def mutate(d):
        d['chaser']['thrusters']['layout'] = [{'position_m': [0.0, 0.0, 0.0], 'direction': [1e-300, 0.0, 0.0]}]
    p, msg = _six_dof(tmp_path, mutate)
    _one_line(msg, p, 'chaser.thrusters.layout[0].direction')


def test_refuses_a_thruster_beyond_ten_envelope_radii(tmp_path):
    layout = default_thruster_layout()
    items = [{'position_m': p.tolist(), 'direction': u.tolist()}
             for p, u in zip(layout.positions_body_m, layout.force_directions_body, strict=True)]
    items[3]['position_m'] = [1e300, 0.0, 0.0]
    p, msg = _six_dof(tmp_path, lambda d: d['chaser']['thrusters'].update(layout=items))
    _one_line(msg, p, 'chaser.thrusters.layout[3].position_m')


def test_refuses_parallel_wheel_axes(tmp_path):
    p, msg = _six_dof(tmp_path, lambda d: d['chaser'].setdefault('wheels', {}).update(
        axes=[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    _one_line(msg, p, 'chaser.wheels.axes')
    assert 'must span 3 axes' in msg


def test_refuses_wheel_axes_whose_norm_underflows(tmp_path):
    p, msg = _six_dof(tmp_path, lambda d: d['chaser'].setdefault('wheels', {}).update(
        axes=[[1e-300, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))
    _one_line(msg, p, 'chaser.wheels.axes')
    assert 'row 0' in msg


@pytest.mark.parametrize('point, what', [([0.0, 0.0, 0.0], 'inside box'), ([0.5, 0.0, 0.5], 'inside box'),
                                         ([100.0, 0.0, 0.0], 'from the nearest box')])
def test_refuses_a_grasp_point_at_the_com_inside_the_bus_or_off_every_surface(tmp_path, point, what):
    p, msg = error_of(tmp_path, lambda d: d['target'].update(grasp_point_body_m=point))
    _one_line(msg, p, 'target.grasp_point_body_m')
    assert what in msg


def test_accepts_a_grasp_point_within_the_tolerance_of_a_face(tmp_path):
    data = load_yaml(REPO / 'scenarios' / 'paper_flyby.yaml')
    data['target']['grasp_point_body_m'] = [1.55, 0.0, 1.0]
    scenario_from_dict(data)


@pytest.mark.parametrize('moment', [1e-300, 1e9])
def test_refuses_a_target_inertia_out_of_range_of_its_mass_and_size(tmp_path, moment):
    p, msg = error_of(tmp_path, lambda d: d['target'].update(
        inertia_kg_m2=[[moment, 0, 0], [0, moment, 0], [0, 0, moment]]))
    _one_line(msg, p, 'target.inertia_kg_m2')
    assert 'mass * L^2 / 12' in msg


def test_refuses_a_chaser_inertia_out_of_range_of_its_mass_and_envelope(tmp_path):
    p, msg = _six_dof(tmp_path, lambda d: d['chaser'].update(inertia_kg_m2=[[1e6, 0, 0], [0, 1e6, 0], [0, 0, 1e6]]))
    _one_line(msg, p, 'chaser.inertia_kg_m2')


@pytest.mark.parametrize('who', ['target', 'chaser'])
@pytest.mark.parametrize('mass', [1e-300, 1e300])
def test_refuses_a_mass_out_of_range(tmp_path, who, mass):
    p, msg = error_of(tmp_path, lambda d: d[who].update(mass_kg=mass))
    _one_line(msg, p, f'{who}.mass_kg')


@pytest.mark.parametrize('start', [[1.0, 0.0, 0.0], [0.0, 0.0, 2.5], [0.0, 2.0, 0.0]])
def test_refuses_a_chaser_start_inside_the_target_or_within_its_envelope(tmp_path, start):
    p, msg = error_of(tmp_path, lambda d: d['chaser'].update(initial_position_hill_m=start))
    _one_line(msg, p, 'chaser.initial_position_hill_m')
    assert 'outside the target' in msg


@pytest.mark.parametrize('start', [[1e300, 0.0, 0.0], [1e-300, 0.0, 0.0], [2e6, 0.0, 0.0]])
def test_refuses_a_chaser_start_at_the_target_com_or_beyond_1e6_m(tmp_path, start):
    p, msg = error_of(tmp_path, lambda d: d['chaser'].update(initial_position_hill_m=start))
    _one_line(msg, p, 'chaser.initial_position_hill_m')


def test_refuses_a_chaser_start_velocity_above_1000_mps(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['chaser'].update(initial_velocity_hill_mps=[1e300, 0.0, 0.0]))
    _one_line(msg, p, 'chaser.initial_velocity_hill_mps')


@pytest.mark.parametrize('radius', [1e-300, 1e300])
def test_refuses_an_envelope_radius_out_of_range(tmp_path, radius):
    p, msg = error_of(tmp_path, lambda d: d['chaser'].update(envelope_radius_m=radius))
    _one_line(msg, p, 'chaser.envelope_radius_m')


@pytest.mark.parametrize('name', ['size_m', 'center_m'])
def test_refuses_a_geometry_box_beyond_1000_m(tmp_path, name):
    p, msg = error_of(tmp_path, lambda d: d['target']['geometry'][0].update({name: [1e300, 1.0, 1.0]}))
    _one_line(msg, p, f'target.geometry[0].{name}')


def test_refuses_a_target_rate_above_one_turn_a_second(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['target'].update(initial_rate={'omega_body_deg_s': [1e300, 0.0, 0.0]}))
    _one_line(msg, p, 'target.initial_rate.omega_body_deg_s')


def test_refuses_a_chaser_rate_above_one_turn_a_second(tmp_path):
    p, msg = _six_dof(tmp_path, lambda d: d['chaser'].update(initial_rate={'omega_body_rad_s': [7.0, 0.0, 0.0]}))
    _one_line(msg, p, 'chaser.initial_rate.omega_body_rad_s')


def test_refuses_a_step_finer_than_a_millisecond(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['simulation'].update(step_s=1e-9))
    _one_line(msg, p, 'simulation.step_s')


@pytest.mark.parametrize('duration, what', [(0.01, 'at least one'), (9e5, 'at most 1e+07 steps'),
                                            (1e300, 'must be in (0, 1e6]')])
def test_refuses_a_duration_shorter_than_a_step_or_longer_than_1e7_steps(tmp_path, duration, what):
    p, msg = error_of(tmp_path, lambda d: d['simulation'].update(duration_s=duration))
    _one_line(msg, p, 'simulation.duration_s')
    assert what in msg


def test_refuses_a_sensor_rate_above_the_step_rate(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['sensors']['relative_position'].update(rate_hz=100.0))
    _one_line(msg, p, 'sensors.relative_position.rate_hz')


# ------------------------------------------------------------------------------------------------
# Angles, rates, times and distances within the bound of their unit (schema.UNIT_BOUNDS); numbers within 1e30; seeds
# within 32 bits

@pytest.mark.parametrize('rpy', [[1e300, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, -7.0, 0.0]])
def test_refuses_an_attitude_angle_beyond_one_turn(tmp_path, rpy):
    p, msg = error_of(tmp_path, lambda d: d['target'].update(initial_attitude={'rpy_rad': rpy}))
    _one_line(msg, p, 'target.initial_attitude.rpy_rad')
    assert 'must be in [-6.3, 6.3]' in msg and 'one turn' in msg


def test_accepts_attitude_angles_within_one_turn(tmp_path):
    data = load_yaml(REPO / 'scenarios' / 'paper_flyby.yaml')
    data['target']['initial_attitude'] = {'rpy_rad': [3.2, -6.28, 6.0]}
    assert list(load_scenario(write(tmp_path, data)).target.initial_attitude.rpy_rad) == [3.2, -6.28, 6.0]


@pytest.mark.parametrize('section, key, value', [
    ('planner', 'flyby_duration_s', 1e300), ('guidance', 'command_lead_s', 2e6), ('supervisor', 'watchdog_s', 1e7),
    ('planner', 'restriction_sphere_radius_m', 1e300), ('estimation', 'injected_rate_error_deg_s', [1e300, 0, 0]),
    ('estimation', 'spin_rate_deg_s', 1e4), ('guidance', 'adjust_velocity_tolerance_mps', 1e5),
])
def test_refuses_a_time_distance_speed_or_rate_beyond_the_bound_of_its_unit(tmp_path, section, key, value):
    p, msg = error_of(tmp_path, lambda d: d.setdefault(section, {}).update({key: value}))
    _one_line(msg, p, f'{section}.{key}')
    assert msg.endswith(')'), msg  # the bound's reason


def test_refuses_a_positive_value_of_1e_minus_300(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d['chaser']['thrusters'].update(isp_s=1e-300))
    _one_line(msg, p, 'chaser.thrusters.isp_s')
    assert 'must be at least 1e-30' in msg


def test_refuses_1e300_where_no_unit_bounds_it(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d.setdefault('post_capture', {}).update(
        grasp={'stiffness_n_per_m': 1e300}))
    _one_line(msg, p, 'post_capture.grasp.stiffness_n_per_m')
    assert 'must be at most 1e+30 in magnitude' in msg


def test_refuses_a_count_of_midcourse_corrections_beyond_100(tmp_path):
    p, msg = error_of(tmp_path, lambda d: d.setdefault('guidance', {}).update(midcourse_corrections=10**9))
    _one_line(msg, p, 'guidance.midcourse_corrections')


@pytest.mark.parametrize('seed', [2**32, 10**23])
def test_refuses_a_seed_beyond_32_bits(tmp_path, seed):
    p, msg = error_of(tmp_path, lambda d: d.update(seed=seed))
    _one_line(msg, p, 'seed')
    assert 'must be in [0, 4294967295]' in msg
    with pytest.raises(ScenarioError, match=r'seed: must be in \[0, 4294967295\].*\(from the seed argument\)$'):
        load_scenario(REPO / 'scenarios' / 'paper_flyby.yaml', seed=seed)


# ------------------------------------------------------------------------------------------------
# Two chasers: the top-level grasp point is validated, a chaser's own is reported under its key

def _fleet_error(tmp_path, mutate):
    return error_of(tmp_path, mutate, base='jacobsen_two_robots')


def test_refuses_a_nan_in_a_chasers_own_grasp_point_under_its_key(tmp_path):
    p, msg = _fleet_error(tmp_path, lambda d: d['chasers'][1].update(grasp_point_body_m=[float('nan'), 0.0, 0.0]))
    _one_line(msg, p, 'chasers[1].grasp_point_body_m[0]')


def test_refuses_a_chasers_own_grasp_point_inside_the_bus_under_its_key(tmp_path):
    p, msg = _fleet_error(tmp_path, lambda d: d['chasers'][1].update(grasp_point_body_m=[0.0, 0.0, 0.0]))
    _one_line(msg, p, 'chasers[1].grasp_point_body_m')


@pytest.mark.parametrize('value', [float('nan'), 'abc', [100.0, 0.0, 0.0], 'DELETE'])
def test_refuses_a_bad_top_level_grasp_point_of_a_two_chaser_file(tmp_path, value):
    def mutate(d):
        assert all(c.get('grasp_point_body_m') is not None for c in d['chasers'])
        if value == 'DELETE':
            del d['target']['grasp_point_body_m']
        else:
            d['target']['grasp_point_body_m'] = copy.deepcopy(value)
    p, msg = _fleet_error(tmp_path, mutate)
    _one_line(msg, p, 'target.grasp_point_body_m')


# ------------------------------------------------------------------------------------------------
# Every shipped scenario passes every rule

@pytest.mark.parametrize('path', sorted((REPO / 'scenarios').glob('*.yaml')), ids=lambda p: p.name)
def test_every_shipped_scenario_is_plausible(path):
    load_scenario(path)
