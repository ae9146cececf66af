"""Scenario loading: the shipped files, derived values, target boxes in hill, seed override, the docs table,
the rigid-body chaser's and the post-capture keys (the error classes: test_scenario_errors.py)."""

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_msgs_py.markers import marker_array, target_box_markers
from flyby_msgs_py.schema import ScenarioError
from flyby_sim.dynamics.constants import EARTH_RADIUS_M
from flyby_sim.scenario import SCHEMA, Boxes, Scenario, load_scenario, scenario_from_dict, schema_markdown
from flyby_testing import paper_dict
from flyby_testing import scenario_error_of as error_of
from flyby_testing import write_yaml as write

REPO = Path(__file__).resolve().parents[4]
PAPER = REPO / 'scenarios' / 'paper_flyby.yaml'
SEWERYN = REPO / 'scenarios' / 'seweryn_tumbling.yaml'


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def quat_matrix(q):
    """Rotation matrix of a unit quaternion (x, y, z, w), written out independently of scipy."""
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


# ------------------------------------------------------------------------------------------------
# The shipped scenarios

def test_paper_flyby_loads_with_derived_values():
    sc = load_scenario(PAPER)
    assert sc.name == 'paper_flyby' and sc.seed == 1
    assert sc.orbit_radius_m == 7000000.0
    assert sc.mean_motion_rad_s == pytest.approx(math.sqrt(3.986004418e14 / 7e6 ** 3), rel=1e-15)
    q = sc.q_hill_from_body0
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-15) and q[3] >= 0.0
    # DESIGN §6: the spin axis (body z) points along [1, 1, 1]/sqrt(3) in hill at t = 0.
    np.testing.assert_allclose(quat_matrix(q) @ [0, 0, 1], np.ones(3) / math.sqrt(3), atol=1e-15)
    np.testing.assert_allclose(sc.omega_body0_rad_s, [0.0, 0.0, math.radians(5.0)], atol=1e-15)
    np.testing.assert_array_equal(sc.target_inertia, np.diag([1200.0, 1000.0, 2000.0]))
    boxes = sc.boxes
    assert boxes.names == ('bus', 'panel_plus_y', 'panel_minus_y')
    assert boxes.center_body_m.shape == (3, 3) and boxes.size_m.shape == (3, 3)
    np.testing.assert_array_equal(boxes.size_m[1], [2.0, 6.0, 0.05])
    np.testing.assert_array_equal(sc.target.grasp_point_body_m, [1.5, 0.0, 1.5])
    assert sc.chaser.thrusters.isp_s == 220.0
    assert sc.simulation.dynamics == 'nonlinear'
    assert sc.path == PAPER


def test_seweryn_tumbling_loads_with_derived_values():
    sc = load_scenario(SEWERYN)
    assert sc.orbit_radius_m == 6578137.0
    assert sc.orbit.altitude_m == 200000.0 and sc.orbit.radius_m is None
    roll, pitch, yaw = 0.5, 0.01, 0.2
    np.testing.assert_allclose(quat_matrix(sc.q_hill_from_body0), rz(yaw) @ ry(pitch) @ rx(roll), atol=1e-15)
    np.testing.assert_allclose(sc.omega_body0_rad_s, [0.3, 0.2, 0.1], atol=0)
    np.testing.assert_allclose(sc.rotation_hill_from_body0.as_matrix(), rz(yaw) @ ry(pitch) @ rx(roll),
                               atol=1e-15)


def test_defaults_are_filled_and_to_dict_reloads_equal(tmp_path):
    d = paper_dict()
    for key in ('planner', 'guidance', 'sensors', 'description'):
        del d[key]
    del d['chaser']['initial_velocity_hill_mps']
    del d['chaser']['thrusters']['magnitude_error_sigma']
    del d['orbit']
    d['orbit'] = {'altitude_m': 400000.0}
    sc = load_scenario(write(tmp_path, d))
    assert sc.planner.offset_m == 1.0
    assert sc.planner.flyby_duration_s == 300.0
    assert sc.planner.restriction_sphere_radius_m == 15.0
    assert sc.guidance.adjust_interval_s == 20.0
    assert sc.sensors.target_attitude.rate_hz == 10.0
    assert sc.description == ''
    assert sc.orbit.mu_m3_s2 == 3.986004418e14
    assert sc.chaser.thrusters.magnitude_error_sigma == 0.0
    np.testing.assert_array_equal(sc.chaser.initial_velocity_hill_mps, [0.0, 0.0, 0.0])
    assert sc.orbit_radius_m == EARTH_RADIUS_M + 400000.0
    assert 'planner' not in sc.raw
    resolved = sc.to_dict()
    assert resolved['planner']['offset_m'] == 1.0 and resolved['planner']['flyby_duration_s'] == 300.0
    assert resolved['planner']['sun_direction_hill'] is None  # optional: lighting not checked
    again = load_scenario(write(tmp_path, sc.to_yaml(), 'again.yaml'))
    assert again == sc and again.to_dict() == resolved


def test_scenario_is_read_only():
    sc = load_scenario(PAPER)
    with pytest.raises(AttributeError):
        sc.seed = 3
    with pytest.raises(AttributeError):
        sc.chaser.mass_kg = 3.0
    with pytest.raises(ValueError):
        sc.chaser.initial_position_hill_m[0] = 1.0
    with pytest.raises(AttributeError, match="chaser has no key 'mass'"):
        sc.chaser.mass  # noqa: B018 - reading the key is what raises
    sc.raw['seed'] = 99  # a copy
    assert sc.raw['seed'] == 1
    sc.q_hill_from_body0[0] = 5.0  # a fresh array
    assert sc.q_hill_from_body0[0] != 5.0


def test_pickle_and_deepcopy_keep_the_scenario():
    import pickle
    sc = load_scenario(PAPER, seed=5)
    for other in (pickle.loads(pickle.dumps(sc)), copy.deepcopy(sc)):
        assert other == sc and other.seed == 5 and other.path == PAPER and other.raw == sc.raw
        assert other.orbit.altitude_m is None
        np.testing.assert_array_equal(other.q_hill_from_body0, sc.q_hill_from_body0)
        assert other.target.geometry[1].name == 'panel_plus_y'


def test_integer_accepted_for_float_and_yaml12_exponent(tmp_path):
    text = PAPER.read_text().replace('mass_kg: 100.0', 'mass_kg: 100').replace(
        'radius_m: 7000000.0', 'radius_m: 7e6')
    sc = load_scenario(write(tmp_path, text))
    assert sc.chaser.mass_kg == 100.0 and isinstance(sc.chaser.mass_kg, float)
    assert sc.orbit_radius_m == 7e6


def test_null_section_means_all_defaults(tmp_path):
    text = PAPER.read_text().replace('guidance:\n  adjust_interval_s: 20.0\n', 'guidance:\n')
    assert load_scenario(write(tmp_path, text)).guidance.adjust_interval_s == 20.0


# ------------------------------------------------------------------------------------------------
# Target boxes in hill (markers)

def test_box_centers_in_hill_follow_the_attitude():
    # Body z along hill x: a quarter turn about hill y. q = (0, sin 45, 0, cos 45); target CoM at hill [0, 0, 1].
    s = math.sqrt(0.5)
    boxes = Boxes(('bus', 'panel_plus_y', 'antenna'), np.array([[0.0, 0.0, 0.0], [0.0, 4.5, 0.0], [0.0, 0.0, 2.0]]),
                  np.ones((3, 3)))
    centers = boxes.centers_hill_m([0.0, s, 0.0, s], r_com_hill_m=[0.0, 0.0, 1.0])
    np.testing.assert_allclose(centers, [[0.0, 0.0, 1.0], [0.0, 4.5, 1.0], [2.0, 0.0, 1.0]], atol=1e-15)


def test_target_markers_from_the_scenario_geometry():
    sc = load_scenario(PAPER)
    q = sc.q_hill_from_body0
    boxes = sc.boxes
    arr = marker_array(target_box_markers(0.0, q, boxes.centers_hill_m(q), boxes.size_m, boxes.names))
    assert [m.id for m in arr.markers] == [0, 1, 2]
    p = arr.markers[1].pose.position  # panel_plus_y at body [0, 4.5, 0]
    np.testing.assert_allclose([p.x, p.y, p.z], sc.rotation_hill_from_body0.apply([0.0, 4.5, 0.0]), atol=1e-12)
    assert arr.markers[1].color.b > arr.markers[1].color.r


# ------------------------------------------------------------------------------------------------
# Attitude and rate conventions

@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 1e-3),
       st.lists(st.floats(-1, 1), min_size=3, max_size=3))
def test_quaternion_and_hill_rate_conventions(q, omega_hill):
    d = paper_dict()
    d['target']['initial_attitude'] = {'q_hill_from_body': q}
    d['target']['initial_rate'] = {'omega_hill_rad_s': omega_hill}
    sc = scenario_from_dict(d)
    qn = np.array(q) / np.linalg.norm(q)
    q0 = sc.q_hill_from_body0
    assert abs(np.linalg.norm(q0) - 1.0) < 1e-14
    assert min(np.linalg.norm(q0 - qn), np.linalg.norm(q0 + qn)) < 1e-12
    # omega_hill = R_hill_from_body omega_body
    np.testing.assert_allclose(quat_matrix(qn) @ sc.omega_body0_rad_s, omega_hill, atol=1e-12)


def test_hill_rate_in_degrees():
    d = paper_dict()
    d['target']['initial_rate'] = {'omega_hill_deg_s': [5.0, 5.0, 5.0]}
    sc = scenario_from_dict(d)
    # The spin axis along [1, 1, 1]/sqrt(3) in hill is body z.
    np.testing.assert_allclose(sc.omega_body0_rad_s, [0.0, 0.0, math.radians(5.0) * math.sqrt(3)], atol=1e-15)


@pytest.mark.parametrize('body,hill', [([0, 0, 1], [0, 0, -2]), ([1, 0, 0], [-1, 0, 0]), ([0, 1, 0], [0, 3, 0]),
                                       ([1, 2, 3], [-3, 1, 0.5])])
def test_body_axis_along_hill_is_a_minimal_rotation(body, hill):
    d = paper_dict()
    d['target']['initial_attitude'] = {'body_axis_along_hill': {'body': body, 'hill': hill}}
    sc = scenario_from_dict(d)
    r = quat_matrix(sc.q_hill_from_body0)
    b, h = np.array(body, float) / np.linalg.norm(body), np.array(hill, float) / np.linalg.norm(hill)
    np.testing.assert_allclose(r @ b, h, atol=1e-14)
    angle = math.acos(max(-1.0, min(1.0, (np.trace(r) - 1) / 2)))
    assert angle == pytest.approx(math.acos(max(-1.0, min(1.0, float(b @ h)))), abs=1e-7)


# ------------------------------------------------------------------------------------------------
# Seed override

def test_seed_override():
    sc = load_scenario(PAPER, seed=42)
    assert sc.seed == 42 and sc.to_dict()['seed'] == 42 and sc.raw['seed'] == 1
    assert load_scenario(PAPER, seed=np.int64(3)).seed == 3
    for seed in (-1, 2**32):
        with pytest.raises(ScenarioError, match=rf'paper_flyby.yaml: seed: must be in \[0, 4294967295\], got {seed} '
                                                r'\(.*\) \(from the seed argument\)$'):
            load_scenario(PAPER, seed=seed)
    with pytest.raises(ScenarioError,
                       match=r': seed: must be an integer, got true \(bool\) \(from the seed argument\)$'):
        load_scenario(PAPER, seed=True)
    with pytest.raises(ScenarioError, match=r': seed: must be an integer, got 2.0'):
        load_scenario(PAPER, seed=2.0)


def test_scenario_from_dict_names_the_source():
    d = paper_dict()
    d['chaser']['mass_kg'] = 0
    with pytest.raises(ScenarioError, match=r'^<dict>: chaser.mass_kg: must be > 0, got 0.0$'):
        scenario_from_dict(d)
    assert isinstance(scenario_from_dict(paper_dict()), Scenario)
    assert scenario_from_dict(copy.deepcopy(paper_dict())).seed == 1


# ------------------------------------------------------------------------------------------------
# The docs page is generated from the schema

def test_docs_page_holds_the_generated_key_table():
    text = (REPO / 'docs' / 'scenario.md').read_text()
    begin, end = '<!-- BEGIN GENERATED KEY TABLE -->\n', '<!-- END GENERATED KEY TABLE -->'
    assert begin in text and end in text
    table = text.split(begin, 1)[1].split(end, 1)[0]
    assert table == schema_markdown(), \
        'regenerate with: .venv/bin/python -m flyby_sim.scenario --schema-markdown'


def test_every_schema_key_has_a_description():
    def walk(section, prefix):
        for k, node in section.fields.items():
            assert getattr(node, 'desc', ''), f'{prefix}{k} has no description'
            inner = getattr(node, 'item', node)
            if hasattr(inner, 'fields'):
                walk(inner, f'{prefix}{k}.')
    walk(SCHEMA, '')


def test_the_fly_by_offsets_stay_within_the_manipulator_reach(tmp_path):
    _, msg = error_of(tmp_path, lambda d: d['planner'].update(offset_m=1.45))
    assert msg.endswith(': planner.offset_m: must be <= chaser.manipulator.reach_m - position_tolerance_m = 1.4 '
                        '(the grasp point out of reach at the fly-by target point), got 1.45')
    _, msg = error_of(tmp_path, lambda d: d['planner'].update(offset_max_m=0.9))
    assert msg.endswith(': planner.offset_max_m: must be >= planner.offset_m = 1.0, got 0.9')
    d = paper_dict()
    d['chaser']['manipulator']['reach_m'] = 2.0
    assert scenario_from_dict(d).offset_max_m == pytest.approx(1.9)
    assert load_scenario(REPO / 'scenarios' / 'paper_flyby.yaml').offset_max_m == pytest.approx(1.4)


# ------------------------------------------------------------------------------------------------
# The six-degree-of-freedom chaser's keys (chaser.model rigid_body; docs/chaser_6dof.md)

SIX_DOF = REPO / 'scenarios' / 'paper_flyby_6dof.yaml'


def test_chaser_rigid_body_defaults_point_body_x_at_the_target_from_rest():
    """Omitted: inertia 2/5 m r^2 of the envelope sphere, body +x along -r0 (minimal rotation), zero rate, three
    orthogonal wheels of 0.1 N m, 4 N m s, 0.01 kg m^2 without momentum, the default thruster layout, the IMU's
    documented noise; a point-mass scenario resolves to point_mass."""
    sc = load_scenario(PAPER)
    assert sc.chaser.model == 'point_mass'
    np.testing.assert_array_equal(sc.chaser_inertia, 0.4 * 100.0 * 0.5 ** 2 * np.eye(3))
    np.testing.assert_allclose(quat_matrix(sc.q_hill_from_chaser_body0) @ [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0],
                               atol=1e-15)
    assert sc.omega_chaser_body0_rad_s.tolist() == [0.0, 0.0, 0.0]
    wheels = sc.chaser.wheels
    assert wheels.axes.tolist() == np.eye(3).tolist() and wheels.initial_momentum_n_m_s is None
    assert (wheels.max_torque_n_m, wheels.max_momentum_n_m_s, wheels.spin_inertia_kg_m2) == (0.1, 4.0, 0.01)
    assert sc.chaser.thrusters.layout is None and sc.chaser.initial_attitude is None
    imu = sc.sensors.chaser_imu
    assert (imu.rate_hz, imu.star_tracker_rate_hz, imu.star_tracker_sigma_deg, imu.gyro_noise_sigma_rad_s,
            imu.gyro_bias_sigma_rad_s, imu.gyro_bias_walk_rad_s_sqrt_s, imu.accel_noise_sigma_mps2) == \
        (10.0, 2.0, 0.01, 1e-5, 1e-4, 1e-7, 1e-4)


def test_chaser_attitude_and_rate_take_the_targets_forms(tmp_path):
    """The chaser's initial_attitude and initial_rate are the target's sections: rpy and a rate in hill axes."""
    d = paper_dict()
    d['chaser'].update(model='rigid_body', initial_attitude={'rpy_rad': [0.5, 0.01, 0.2]},
                       initial_rate={'omega_hill_deg_s': [1.0, -2.0, 0.5]},
                       inertia_kg_m2=[[13.0, 0.0, 0.0], [0.0, 38.0, 0.0], [0.0, 0.0, 35.0]])
    sc = load_scenario(write(tmp_path, d))
    c = quat_matrix(sc.q_hill_from_chaser_body0)
    np.testing.assert_allclose(c, rz(0.2) @ ry(0.01) @ rx(0.5), atol=1e-15)
    np.testing.assert_allclose(c @ sc.omega_chaser_body0_rad_s, np.radians([1.0, -2.0, 0.5]), atol=1e-15)
    assert sc.chaser_inertia.tolist() == [[13.0, 0.0, 0.0], [0.0, 38.0, 0.0], [0.0, 0.0, 35.0]]
    assert SCHEMA.fields['chaser'].fields['initial_attitude'].fields == \
        SCHEMA.fields['target'].fields['initial_attitude'].fields
    again = load_scenario(write(tmp_path, sc.to_yaml(), 'again.yaml'))  # optional sections null in to_dict
    assert again == sc and load_scenario(write(tmp_path, load_scenario(PAPER).to_yaml(), 'pm.yaml')) == \
        load_scenario(PAPER)


def test_paper_flyby_6dof_is_paper_flyby_with_the_rigid_body_chaser():
    a, b = load_scenario(PAPER).to_dict(), load_scenario(SIX_DOF).to_dict()
    assert b['chaser']['model'] == 'rigid_body'
    for d in (a, b):
        for key in ('name', 'description'):
            del d[key]
        d['chaser']['model'] = 'point_mass'
    b['chaser'].update(inertia_kg_m2=None, initial_attitude=None, initial_rate=None)
    b['chaser']['wheels']['initial_momentum_n_m_s'] = None
    assert a == b


def test_error_chaser_rigid_body_keys_name_themselves(tmp_path):
    cases = [
        (lambda d: d['chaser'].update(model='rigid'), "chaser.model: must be one of ['point_mass', 'rigid_body']"),
        (lambda d: d['chaser'].update(wheels={'max_torque_nm': 0.1}),
         "chaser.wheels.max_torque_nm: unknown key (did you mean 'max_torque_n_m'?)"),
        (lambda d: d['chaser'].update(wheels={'max_momentum_n_m_s': -1.0}),
         'chaser.wheels.max_momentum_n_m_s: must be > 0, got -1.0'),
        (lambda d: d['chaser'].update(wheels={'axes': [[1, 0, 0], [0, 0, 0]]}),
         'chaser.wheels.axes: row 1 must be nonzero'),
        (lambda d: d['chaser'].update(wheels={'axes': []}),
         'chaser.wheels.axes: must be a non-empty list of 3-vectors'),
        (lambda d: d['chaser'].update(wheels={'initial_momentum_n_m_s': [0.0, 1.0]}),
         'chaser.wheels.initial_momentum_n_m_s: must give one value per wheel axis of chaser.wheels.axes (3), got 2'),
        (lambda d: d['chaser'].update(wheels={'initial_momentum_n_m_s': [0.0, 5.0, 0.0]}),
         'chaser.wheels.initial_momentum_n_m_s[1]: must be within +-max_momentum_n_m_s = 4.0, got 5.0'),
        (lambda d: d['chaser'].update(inertia_kg_m2=[[10, 0, 0], [0, 10, 0], [0, 0, 30]]),
         'chaser.inertia_kg_m2: principal moments'),
        (lambda d: d['chaser'].update(initial_attitude={'rpy_rad': [0, 0, 0], 'q_hill_from_body': [0, 0, 0, 1]}),
         "chaser.initial_attitude: exactly one of"),
        (lambda d: d['chaser']['thrusters'].update(layout=[{'position_m': [0, 0, 0], 'direction': [0, 0, 0]}]),
         'chaser.thrusters.layout[0].direction: must be nonzero'),
        (lambda d: d['sensors'].update(chaser_imu={'star_tracker_rate_hz': 3.0}),
         'sensors.chaser_imu.star_tracker_rate_hz: must divide sensors.chaser_imu.rate_hz = 10.0'),
        (lambda d: d['sensors'].update(chaser_imu={'rate_hz': 40.0}),
         'sensors.chaser_imu.rate_hz: must be <= 1/simulation.step_s = 20 Hz'),
        (lambda d: d['sensors'].update(chaser_imu={'gyro_bias_walk_rad_s_sqrt_s': -1e-7}),
         'sensors.chaser_imu.gyro_bias_walk_rad_s_sqrt_s: must be >= 0'),
    ]
    for mutate, expected in cases:
        _, msg = error_of(tmp_path, mutate)
        assert expected in msg, (expected, msg)


def test_error_thruster_layout_without_full_authority(tmp_path):
    """Eleven of the default twelve thrusters: rank 6 but not positively spanning (docs/chaser_6dof.md)."""
    from flyby_sim.dynamics.actuators import default_thruster_layout
    layout = default_thruster_layout()
    items = [{'position_m': p.tolist(), 'direction': u.tolist()}
             for p, u in zip(layout.positions_body_m, layout.force_directions_body, strict=True)]
    _, msg = error_of(tmp_path, lambda d: d['chaser']['thrusters'].update(layout=items[1:]))
    assert msg.endswith(': chaser.thrusters.layout: the 11 thrusters must give every body force and torque (rank 6 '
                        'and positively spanning), got rank 6 but not positively spanning')
    _, msg = error_of(tmp_path, lambda d: d['chaser']['thrusters'].update(layout=items[:4]))
    assert 'got rank 2' in msg
    d = paper_dict()
    d['chaser']['thrusters']['layout'] = items
    assert len(scenario_from_dict(d).chaser.thrusters.layout) == 12


# ------------------------------------------------------------------------------------------------
# After the capture (docs/post_capture.md)

TUG = REPO / 'scenarios' / 'paper_flyby_tug.yaml'


def test_post_capture_is_optional_and_paper_flyby_tug_is_paper_flyby_6dof_with_it():
    assert load_scenario(SIX_DOF).post_capture is None and load_scenario(PAPER).post_capture is None
    a, b = load_scenario(SIX_DOF).to_dict(), load_scenario(TUG).to_dict()
    pc = b.pop('post_capture')
    for d in (a, b):
        for key in ('name', 'description'):
            del d[key]
    del a['post_capture']
    assert a == b
    assert pc['damping']['momentum_threshold_kg_m2_s'] == 0.1 and pc['mass_estimation']['excitation'] == 'table1'
    d = yaml.safe_load(SIX_DOF.read_text())
    d['post_capture'] = {}  # every key at its default
    sc = scenario_from_dict(d)
    assert sc.post_capture.grasp.max_force_n == 50.0 and sc.post_capture.damping.inertia_lower_bound_kg_m2 is None


def test_error_post_capture_keys_name_themselves(tmp_path):
    def rigid(update):
        def mutate(d):
            d['chaser']['model'] = 'rigid_body'
            d['post_capture'] = {}
            update(d['post_capture'])
        return mutate
    cases = [
        (lambda d: d.update(post_capture={}), 'post_capture: needs chaser.model rigid_body'),
        (rigid(lambda p: p.update(grasp={'stiffness_n_m': 200.0})),
         "post_capture.grasp.stiffness_n_m: unknown key (did you mean 'stiffness_n_per_m'?)"),
        (rigid(lambda p: p.update(grasp={'max_force_n': 0.0})), 'post_capture.grasp.max_force_n: must be > 0, got 0.0'),
        (rigid(lambda p: p.update(damping={'momentum_threshold_kg_m2_s': -0.1})),
         'post_capture.damping.momentum_threshold_kg_m2_s: must be > 0, got -0.1'),
        (rigid(lambda p: p.update(damping={'wheel_share': 1.0})),
         'post_capture.damping.wheel_share: must be in (0, 1)'),
        (rigid(lambda p: p.update(mass_estimation={'excitation': 'table2'})),
         "post_capture.mass_estimation.excitation: must be one of ['table1', 'chosen'], got 'table2'"),
        (rigid(lambda p: p.update(mass_estimation={'window_s': 10.0})),
         'post_capture.mass_estimation.window_s: must be in [20, 600], got 10.0'),
        (rigid(lambda p: p.update(mass_estimation={'prior_mass_sigma': 0.0})),
         'post_capture.mass_estimation.prior_mass_sigma: must be in (0, 0.5), got 0.0'),
        (rigid(lambda p: p.update(transport={})), 'post_capture.transport.goal_hill_m: missing required key'),
        (rigid(lambda p: p.update(transport={'goal_hill_m': [100.0, 0.0, 0.0], 'transfer_time_s': 600.0,
                                             'plume_cone_deg': 90.0})),
         'post_capture.transport.plume_cone_deg: must be in [0, 90), got 90.0'),
    ]
    for mutate, expected in cases:
        _, msg = error_of(tmp_path, mutate)
        assert expected in msg, (expected, msg)


TUGROBOT = REPO / 'scenarios' / 'matsunaga_tugrobot.yaml'


def test_seed004_section31_tugrobot_starts_attached_with_the_target_turning_with_it():
    """Seed 004 Table 1 read into matsunaga_tugrobot: the target's attitude and rate are the TugRobot's (attitude angles
    (0, 0, 0) relative to it), its attitude angles (20, 10, 0) deg successive body x, y, z rotations."""
    from scipy.spatial.transform import Rotation

    sc = load_scenario(TUGROBOT)
    assert sc.post_capture.start == 'attached' and sc.target.initial_attitude is None
    q_tug = Rotation.from_euler('XYZ', (20.0, 10.0, 0.0), degrees=True).as_quat()
    np.testing.assert_allclose(sc.q_hill_from_chaser_body0, q_tug, atol=1e-8)
    np.testing.assert_allclose(sc.q_hill_from_body0, q_tug, atol=1e-8)
    np.testing.assert_allclose(sc.omega_body0_rad_s, (0.0, 0.0, 0.1), atol=1e-15)
    np.testing.assert_allclose(sc.q_chaser_from_target_attached, (0.0, 0.0, 0.0, 1.0), atol=1e-15)
    d = yaml.safe_load(TUGROBOT.read_text())
    d['post_capture']['attachment']['target_rpy_in_chaser_rad'] = [0.0, 0.0, math.pi / 2]
    turned = scenario_from_dict(d)  # target x along the chaser's y: its rate in target axes is the chaser's turned
    np.testing.assert_allclose(turned.omega_body0_rad_s, (0.0, 0.0, 0.1), atol=1e-15)
    np.testing.assert_allclose(quat_matrix(turned.q_chaser_from_target_attached) @ (1.0, 0.0, 0.0), (0.0, 1.0, 0.0),
                               atol=1e-15)


def test_error_start_attached_keys_name_themselves(tmp_path):
    base = yaml.safe_load(TUGROBOT.read_text())
    cases = [
        (lambda d: d['target'].update(initial_rate={'omega_body_rad_s': [0.0, 0.0, 0.1]}),
         'target.initial_rate: must be omitted when post_capture.start is attached'),
        (lambda d: d['post_capture'].pop('attachment'),
         'post_capture.attachment: is required when post_capture.start is attached'),
        (lambda d: d['post_capture']['mass_estimation'].pop('prior_axes_sigma_deg'),
         'post_capture.mass_estimation.prior_axes_sigma_deg: is required when post_capture.start is attached'),
        (lambda d: d['post_capture'].update(start='capture'), 'target.initial_attitude: is required'),
        (lambda d: d['post_capture'].update(start='docked'), "post_capture.start: must be one of ['capture', "
                                                             "'attached'], got 'docked'"),
    ]
    for mutate, expected in cases:
        d = copy.deepcopy(base)
        mutate(d)
        p = write(tmp_path, d)
        with pytest.raises(ScenarioError) as info:
            load_scenario(p)
        assert expected in str(info.value), (expected, str(info.value))
    d = paper_dict()
    d['chaser']['model'] = 'rigid_body'
    d['post_capture'] = {'attachment': {'target_com_chaser_body_m': [0.5, 0.0, 0.0]}}
    _, msg = error_of(tmp_path, lambda x: x.update(d))
    assert "post_capture.attachment: is only for post_capture.start attached, got start 'capture'" in msg
