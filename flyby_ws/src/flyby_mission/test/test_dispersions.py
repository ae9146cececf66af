"""Dispersions of a campaign (flyby_mission.campaign.dispersions): each law against its statement, per-run
reproducibility, one-of replacement, and every refusal's one-line message.

Sample tests draw N = 20 000 values from a fixed seed and test them with a Kolmogorov-Smirnov or chi-square
statistic at p > 1e-3: for a correct law the test would fail one seed in a thousand, and the seed is fixed,
so it either always passes or the law is wrong; means use 5 standard errors.
"""

from pathlib import Path

import numpy as np
import pytest
import scipy.stats
import yaml

from flyby_mission.campaign.dispersions import CampaignError, Dispersion, load_campaign
from flyby_sim.scenario import Boxes, load_scenario

ROOT = Path(__file__).resolve().parents[4]
BASE = ROOT / 'scenarios' / 'paper_flyby.yaml'
N = 20_000
P_MIN = 1e-3


@pytest.fixture(scope='module')
def base():
    return load_scenario(BASE)


def _draws(spec, base_value=None, boxes=None, n=N, seed=12):
    d = Dispersion('x', spec, 'test.yaml', boxes=boxes, base_value=base_value)
    rng = np.random.default_rng(seed)
    return np.array([d.draw(rng, base_value) for _ in range(n)], dtype=float)


def _campaign(tmp_path, dispersions, **extra):
    path = tmp_path / 'c.yaml'
    path.write_text(yaml.safe_dump({'base_scenario': str(BASE), 'seed': 3, 'runs': 10,
                                    'dispersions': dispersions, **extra}))
    return path


def test_uniform_scalar_and_per_component():
    x = _draws({'kind': 'uniform', 'low': 2.0, 'high': 5.0})
    assert x.min() >= 2.0 and x.max() < 5.0
    assert scipy.stats.kstest(x, scipy.stats.uniform(2.0, 3.0).cdf).pvalue > P_MIN
    v = _draws({'kind': 'uniform', 'low': [40.0, -1.0, 0.0], 'high': [60.0, 1.0, 0.0]}, base_value=[50.0, 0.0, 0.0])
    assert v.shape == (N, 3)
    assert scipy.stats.kstest(v[:, 0], scipy.stats.uniform(40.0, 20.0).cdf).pvalue > P_MIN
    assert scipy.stats.kstest(v[:, 1], scipy.stats.uniform(-1.0, 2.0).cdf).pvalue > P_MIN
    assert np.all(v[:, 2] == 0.0)  # low == high: a constant component
    # Scalar bounds on a vector value: each component drawn alike and independently.
    w = _draws({'kind': 'uniform', 'low': 0.0, 'high': 1.0}, base_value=[0.0, 0.0, 0.0])
    assert w.shape == (N, 3) and abs(np.corrcoef(w[:, 0], w[:, 1])[0, 1]) < 5.0 / np.sqrt(N)


def test_normal_mean_and_sigma():
    x = _draws({'kind': 'normal', 'mean': [1.0, -2.0, 0.0], 'sigma': [0.5, 2.0, 0.0]}, base_value=[0.0, 0.0, 0.0])
    for k, (mean, sigma) in enumerate(((1.0, 0.5), (-2.0, 2.0))):
        assert abs(x[:, k].mean() - mean) < 5.0 * sigma / np.sqrt(N)  # 5 standard errors of the mean
        assert scipy.stats.kstest(x[:, k], scipy.stats.norm(mean, sigma).cdf).pvalue > P_MIN
    assert np.all(x[:, 2] == 0.0)


def test_direction_is_uniform_on_the_sphere():
    u = _draws({'kind': 'direction'})
    np.testing.assert_allclose(np.linalg.norm(u, axis=1), 1.0, atol=1e-12)
    # Archimedes: every coordinate of a uniform unit vector is uniform on [-1, 1].
    for k in range(3):
        assert scipy.stats.kstest(u[:, k], scipy.stats.uniform(-1.0, 2.0).cdf).pvalue > P_MIN


def test_direction_never_in_the_excluded_cone_and_uniform_elsewhere():
    u = _draws({'kind': 'direction', 'exclude_cone': {'axis': [0, 2, 0], 'half_angle_deg': 10, 'both_ways': True}})
    c = np.cos(np.radians(10.0))
    assert np.all(np.abs(u[:, 1]) < c)  # never within 10 deg of +y or -y
    # Outside the cone(s) the axis coordinate stays uniform (Archimedes), on (-cos 10, cos 10).
    assert scipy.stats.kstest(u[:, 1], scipy.stats.uniform(-c, 2.0 * c).cdf).pvalue > P_MIN
    one_way = _draws({'kind': 'direction', 'exclude_cone': {'axis': [1, 0, 0], 'half_angle_deg': 60}})
    assert one_way[:, 0].max() < 0.5 and one_way[:, 0].min() < -0.99


def test_direction_magnitude_nested_and_number():
    v = _draws({'kind': 'direction', 'magnitude': {'kind': 'uniform', 'low': 3.0, 'high': 8.0}})
    r = np.linalg.norm(v, axis=1)
    assert scipy.stats.kstest(r, scipy.stats.uniform(3.0, 5.0).cdf).pvalue > P_MIN
    np.testing.assert_allclose(np.linalg.norm(_draws({'kind': 'direction', 'magnitude': 2.5}, n=50), axis=1), 2.5)


def test_direction_axis_probability_mixes_signed_axes_with_the_sphere():
    """axis_probability 0.3: 30 % of the draws (binomial, 5 standard errors) along one of +-x, +-y, +-z, equally
    often (chi-square); the rest uniform on the sphere (a coordinate uniform on [-1, 1]); the magnitude kept."""
    v = _draws({'kind': 'direction', 'axis_probability': 0.3, 'magnitude': 2.0})
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 2.0, atol=1e-12)
    on_axis = np.count_nonzero(v, axis=1) == 1
    assert abs(on_axis.mean() - 0.3) < 5.0 * np.sqrt(0.3 * 0.7 / N)
    axes = np.argmax(np.abs(v[on_axis]), axis=1) * 2 + (v[on_axis].sum(axis=1) > 0)
    assert scipy.stats.chisquare(np.bincount(axes, minlength=6)).pvalue > P_MIN
    assert scipy.stats.kstest(v[~on_axis, 0] / 2.0, scipy.stats.uniform(-1.0, 2.0).cdf).pvalue > P_MIN
    with pytest.raises(CampaignError, match=r'x.axis_probability: must be a number in \[0, 1\], got 1.5'):
        Dispersion('x', {'kind': 'direction', 'axis_probability': 1.5}, 'test.yaml')


def test_box_surface_points_lie_on_faces_in_proportion_to_area():
    # Three separated boxes of unequal faces (no face shared, so each point lies on exactly one face).
    boxes = Boxes(('a', 'b', 'c'), np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, -10.0, 0.0]]),
                  np.array([[3.0, 3.0, 3.0], [2.0, 6.0, 0.05], [1.0, 2.0, 4.0]]))
    p = _draws({'kind': 'box_surface_point'}, boxes=boxes)
    faces = np.zeros((len(boxes), 6), dtype=int)
    areas = np.zeros((len(boxes), 6))
    for i in range(len(boxes)):
        half = 0.5 * boxes.size_m[i]
        q = p - boxes.center_body_m[i]
        inside = np.all(np.abs(q) <= half + 1e-12, axis=1)
        for axis in range(3):
            for side, sign in enumerate((-1.0, 1.0)):
                on = inside & np.isclose(q[:, axis], sign * half[axis], rtol=0, atol=1e-12)
                faces[i, 2 * axis + side] = on.sum()
                areas[i, 2 * axis + side] = np.prod(np.delete(boxes.size_m[i], axis))
    assert faces.sum() == N  # every point on exactly one face
    assert scipy.stats.chisquare(faces.ravel(), N * areas.ravel() / areas.sum()).pvalue > P_MIN
    named = _draws({'kind': 'box_surface_point', 'boxes': ['c']}, boxes=boxes, n=200) - boxes.center_body_m[2]
    assert np.all(np.any(np.isclose(np.abs(named), 0.5 * boxes.size_m[2], rtol=0, atol=1e-12), axis=1))
    assert np.all(np.abs(named) <= 0.5 * boxes.size_m[2] + 1e-12)


def test_box_surface_points_of_the_scenario_boxes(base):
    boxes = base.boxes
    p = _draws({'kind': 'box_surface_point'}, boxes=boxes, n=2000)
    on_some_face = np.zeros(len(p), dtype=bool)
    for center, size in zip(boxes.center_body_m, boxes.size_m, strict=True):
        q = np.abs(p - center)
        on_some_face |= np.all(q <= 0.5 * size + 1e-12, axis=1) & np.any(np.isclose(q, 0.5 * size, atol=1e-12), axis=1)
    assert on_some_face.all()


def test_choice_with_weights():
    x = _draws({'kind': 'choice', 'values': [1.0, 2.0, 3.0], 'weights': [1, 2, 7]})
    counts = [np.sum(x == v) for v in (1.0, 2.0, 3.0)]
    assert scipy.stats.chisquare(counts, N * np.array([0.1, 0.2, 0.7])).pvalue > P_MIN


def test_scale_multiplies_the_base_value():
    x = _draws({'kind': 'scale', 'factor': {'kind': 'uniform', 'low': 0.5, 'high': 3.0}}, base_value=0.01)
    assert scipy.stats.kstest(x, scipy.stats.uniform(0.005, 0.025).cdf).pvalue > P_MIN
    v = _draws({'kind': 'scale', 'factor': 2.0}, base_value=[1.0, -2.0, 0.5], n=3)
    np.testing.assert_array_equal(v, [[2.0, -4.0, 1.0]] * 3)



def test_a_choice_of_a_section_sets_its_keys_together_and_keeps_the_rest(tmp_path):
    """A choice over the section chaser draws one mapping and sets its keys (dotted below the section) together;
    the keys it leaves out keep the base's; a choice over a list (target.geometry) sets the whole list."""
    pairs = [{'mass_kg': 80.0, 'manipulator.reach_m': 1.6}, {'mass_kg': 120.0, 'manipulator.reach_m': 1.8}]
    cube = [{'name': 'cube', 'center_m': [0.0, 0.0, 0.0], 'size_m': [2.0, 2.0, 2.0]}]
    path = _campaign(tmp_path, {'chaser': {'kind': 'choice', 'values': pairs},
                                'target.geometry': {'kind': 'choice', 'values': [cube]},
                                'target.grasp_point_body_m': {'kind': 'choice', 'values': [[1.0, 0.0, 0.0]]}},
                     runs=20)
    campaign = load_campaign(path)
    base = load_scenario(BASE)
    drawn = [campaign.draw(i) for i in range(20)]
    assert {sc.chaser.mass_kg for sc, _ in drawn} == {80.0, 120.0}
    for scenario, values in drawn:
        assert values['chaser'] in pairs
        assert (scenario.chaser.mass_kg, scenario.chaser.manipulator.reach_m) == \
            (values['chaser']['mass_kg'], values['chaser']['manipulator.reach_m'])
        assert scenario.chaser.envelope_radius_m == base.chaser.envelope_radius_m
        assert scenario.chaser.manipulator.position_tolerance_m == base.chaser.manipulator.position_tolerance_m
        assert scenario.boxes.names == ('cube',)


def test_a_matrix_is_drawn_per_element_and_scaled_whole(tmp_path):
    """An inertia (3x3) dispersed: uniform draws each element between its bounds (a zero-width bound keeps it), scale
    multiplies the whole matrix; the run's scenario holds the drawn matrix."""
    low, high = [[1.6, 0.0, 0.0], [0.0, 1.2, 0.0], [0.0, 0.0, 1.2]], [[2.4, 0.0, 0.0], [0.0, 1.8, 0.0], [0.0, 0.0, 1.8]]
    m = _draws({'kind': 'uniform', 'low': low, 'high': high}, base_value=np.eye(3).tolist(), n=2000)
    assert m.shape == (2000, 3, 3)
    assert np.all(m >= np.array(low)) and np.all(m <= np.array(high))
    assert np.all(m[:, 0, 1] == 0.0) and np.ptp(m[:, 1, 1]) > 0.5 and np.corrcoef(m[:, 1, 1], m[:, 2, 2])[0, 1] < 0.1
    s = _draws({'kind': 'scale', 'factor': 2.0}, base_value=low, n=2)
    np.testing.assert_array_equal(s, [2.0 * np.array(low)] * 2)
    path = _campaign(tmp_path, {'target.inertia_kg_m2': {'kind': 'scale', 'factor': {'kind': 'uniform', 'low': 0.8,
                                                                                     'high': 1.2}}})
    scenario, values = load_campaign(path).draw(0)
    np.testing.assert_allclose(scenario.target.inertia_kg_m2, values['target.inertia_kg_m2'])
    factor = values['target.inertia_kg_m2'][0][0] / load_scenario(BASE).target.inertia_kg_m2[0][0]
    assert 0.8 <= factor <= 1.2

def test_run_drawn_alone_equals_run_drawn_in_sequence(tmp_path):
    path = _campaign(tmp_path, {
        'target.initial_rate.omega_body_deg_s': {'kind': 'uniform', 'low': [0, 0, 3], 'high': [0, 0, 8]},
        'chaser.initial_position_hill_m': {'kind': 'direction', 'magnitude': {'kind': 'normal', 'mean': 50,
                                                                              'sigma': 5}},
        'sensors.relative_position.noise_sigma_m': {'kind': 'scale', 'factor': {'kind': 'uniform', 'low': 0.5,
                                                                                'high': 2}},
    })
    sequence = load_campaign(path)
    drawn = [sequence.draw(i) for i in range(8)]
    alone = load_campaign(path, checked_draws=0).draw(7)
    assert alone[0] == drawn[7][0] and alone[1] == drawn[7][1]
    assert alone[0].seed == drawn[7][0].seed != drawn[6][0].seed
    assert drawn[7][0].sensors.relative_position.noise_sigma_m == drawn[7][1]['sensors.relative_position.noise_sigma_m']


def test_an_alternative_of_a_one_of_group_replaces_the_others(tmp_path):
    path = _campaign(tmp_path, {'target.initial_rate.omega_hill_deg_s': {
        'kind': 'direction', 'magnitude': 5.0}})
    scenario, values = load_campaign(path).draw(0)
    assert set(scenario.to_dict()['target']['initial_rate']) == {'omega_hill_deg_s'}
    omega_hill = scenario.rotation_hill_from_body0.apply(scenario.omega_body0_rad_s)
    np.testing.assert_allclose(np.degrees(omega_hill), values['target.initial_rate.omega_hill_deg_s'], atol=1e-12)


@pytest.mark.parametrize('dispersions, key, problem', [
    ({'chaser.mass_kg': {'kind': 'gaussian', 'mean': 1, 'sigma': 1}}, 'dispersions.chaser.mass_kg.kind',
     "unknown dispersion kind 'gaussian'"),
    ({'chaser.mass_kilograms': {'kind': 'normal', 'mean': 1, 'sigma': 1}}, 'dispersions.chaser.mass_kilograms',
     'not a key of the scenario'),
    ({'target.geometry.7.size_m': {'kind': 'scale', 'factor': 2}}, 'dispersions.target.geometry.7.size_m',
     'not in the base scenario'),
    ({'target.initial_attitude.rpy_rad.roll': {'kind': 'normal', 'mean': 0, 'sigma': 1}},
     'dispersions.target.initial_attitude.rpy_rad.roll', 'not a key of the scenario'),
    ({'chaser.mass_kg': {'kind': 'uniform', 'low': 120, 'high': 80}}, 'dispersions.chaser.mass_kg', 'low > high'),
    ({'chaser.mass_kg': {'kind': 'normal', 'mean': 100, 'sigma': -1}}, 'dispersions.chaser.mass_kg.sigma',
     'must be >= 0'),
    ({'chaser.mass_kg': {'kind': 'normal', 'mean': 100}}, 'dispersions.chaser.mass_kg', "normal needs 'sigma'"),
    ({'chaser.mass_kg': {'kind': 'uniform', 'low': 1, 'high': 2, 'width': 3}}, 'dispersions.chaser.mass_kg.width',
     'unknown parameter of uniform'),
    ({'simulation.dynamics': {'kind': 'choice', 'values': ['cw', 'nonlinear'], 'weights': [1]}},
     'dispersions.simulation.dynamics.weights', 'one weight per value (2)'),
    ({'target.grasp_point_body_m': {'kind': 'box_surface_point', 'boxes': ['antenna']}},
     'dispersions.target.grasp_point_body_m.boxes', "no target box named 'antenna'"),
    ({'chaser.initial_position_hill_m': {'kind': 'uniform', 'low': [1, 2], 'high': [3, 4]}},
     'dispersions.chaser.initial_position_hill_m', 'gives 2 components, the scenario value has 3'),
    ({'seed': {'kind': 'choice', 'values': [1]}}, 'dispersions.seed', 'set by the campaign'),
    ({'chaser.wheels': {'kind': 'scale', 'factor': 2}}, 'dispersions.chaser.wheels',
     'names a section or a list, not a value'),
    ({'chaser': {'kind': 'choice', 'values': [{'mass_kg': 80.0}, 90.0]}}, 'dispersions.chaser.values',
     'a choice of the section chaser takes mappings of its keys, got item 1: 90.0'),
    ({'chaser': {'kind': 'choice', 'values': [{'mass_kilograms': 80.0}]}}, 'dispersions.chaser.mass_kilograms',
     'not a key of the scenario'),
    ({'chaser': {'kind': 'choice', 'values': [{'mass_kg': -80.0}]}}, 'dispersions.chaser.mass_kg',
     'run 0 draws an invalid scenario: must be > 0'),
    # Valid dispersion, invalid scenario: the ScenarioError of the draw, with the campaign file named.
    ({'chaser.mass_kg': {'kind': 'normal', 'mean': -5, 'sigma': 1}}, 'dispersions.chaser.mass_kg',
     'run 0 draws an invalid scenario: must be > 0'),
])
def test_refusals_name_the_file_and_the_key(tmp_path, dispersions, key, problem):
    path = _campaign(tmp_path, dispersions)
    with pytest.raises(CampaignError) as err:
        load_campaign(path)
    message = str(err.value)
    assert '\n' not in message
    assert message.startswith(f'{path}: {key}: '), message
    assert problem in message, message


def test_refusals_of_the_campaign_keys(tmp_path):
    with pytest.raises(CampaignError, match=r'c\.yaml: dispersion: unknown campaign key'):
        load_campaign(_campaign(tmp_path, {}, dispersion={}))
    path = tmp_path / 'c.yaml'
    path.write_text(yaml.safe_dump({'base_scenario': 'missing.yaml', 'seed': 1, 'dispersions': {}}))
    with pytest.raises(CampaignError, match=r'c\.yaml: base_scenario: .*missing\.yaml: file not found'):
        load_campaign(path)
    path.write_text(yaml.safe_dump({'base_scenario': str(BASE), 'seed': -1, 'dispersions': {}}))
    with pytest.raises(CampaignError, match=r'c\.yaml: seed: must be an integer in \[0, 4294967295\], got -1'):
        load_campaign(path)


def test_the_smoke_campaign_loads():
    campaign = load_campaign(ROOT / 'campaigns' / 'smoke.yaml', checked_draws=20)
    assert campaign.runs == 20
    for i in range(20):
        scenario, values = campaign.draw(i)
        axis = np.asarray(values['target.initial_attitude.body_axis_along_hill.hill'])
        assert abs(axis[1]) < np.cos(np.radians(10.0))
        assert 3.0 <= values['target.initial_rate.omega_body_deg_s'][2] <= 8.0
        assert 40.0 <= values['chaser.initial_position_hill_m'][0] <= 60.0


def test_overrides_fix_values_of_the_base_before_the_draws(tmp_path):
    path = _campaign(tmp_path, {'chaser.mass_kg': {'kind': 'scale', 'factor': 2.0}},
                     overrides={'planner.sun_direction_hill': None, 'chaser.mass_kg': 150.0})
    campaign = load_campaign(path)
    assert campaign.base.planner.sun_direction_hill is None
    scenario, values = campaign.draw(3)
    assert scenario.planner.sun_direction_hill is None
    assert values['chaser.mass_kg'] == scenario.chaser.mass_kg == 300.0  # scaled from the overridden base


@pytest.mark.parametrize('overrides, key, problem', [
    ({'planner.sun_direction': [1.0, 0.0, 0.0]}, 'overrides.planner.sun_direction', 'not a key of the scenario'),
    ({'chaser.mass_kg': -3.0}, 'overrides.chaser.mass_kg', 'must be > 0'),
    ({'planner.offset_m': 1.45}, 'overrides.planner.offset_m', 'reach_m - position_tolerance_m'),
])
def test_refusals_of_overrides_name_the_key(tmp_path, overrides, key, problem):
    path = _campaign(tmp_path, {}, overrides=overrides)
    with pytest.raises(CampaignError) as err:
        load_campaign(path)
    message = str(err.value)
    assert message.startswith(f'{path}: {key}: ') and problem in message, message


def test_the_envelope_campaign_flies_without_the_lighting_condition():
    campaign = load_campaign(ROOT / 'campaigns' / 'flyby_envelope.yaml')
    assert campaign.runs == 1000 and campaign.base.planner.sun_direction_hill is None


def test_the_transport_envelope_campaign_draws_sizes_and_goals_together():
    """Every run of campaigns/transport_envelope.yaml is valid (checked at load); each draws a goal with its own
    transfer time, a tug whose wheels grow with its mass and a CoM 0.2-3 m off within 20 deg of the tug's +x."""
    campaign = load_campaign(ROOT / 'campaigns' / 'transport_envelope.yaml')
    assert campaign.runs >= 200
    pairs = {(v['goal_hill_m'][0], v['transfer_time_s'])
             for v in next(d for d in campaign.dispersions if d.key == 'post_capture.transport').spec['values']}
    for i in range(campaign.runs):
        scenario, values = campaign.draw(i)
        transport = scenario.post_capture.transport
        assert (transport.goal_hill_m[0], transport.transfer_time_s) in pairs
        chaser = scenario.chaser
        assert 20.0 <= chaser.mass_kg <= 200.0 and 10.0 <= scenario.target.mass_kg <= 2000.0
        assert chaser.wheels.max_momentum_n_m_s == pytest.approx(chaser.mass_kg / 40.0, rel=1e-2)
        com = np.asarray(values['post_capture.attachment.target_com_chaser_body_m'])
        assert 0.2 <= np.linalg.norm(com) <= 3.0 and com[0] >= np.cos(np.radians(20.0)) * np.linalg.norm(com)
