"""Tests of flyby_planner.plan: the seed 000 fly-by plan of paper_flyby, its safety, selection and refusals."""

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from flyby_planner.plan import avoidance_burn, plan_capture, planner_config_from_scenario, truth_prediction
from flyby_sim.dynamics.geometry import clearance
from flyby_sim.dynamics.orbital import cw_transition_matrix, nonlinear_relative_accel, rk4_step
from flyby_sim.scenario import load_scenario, scenario_from_dict

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
PAPER_DICT = yaml.safe_load((SCENARIOS / 'paper_flyby.yaml').read_text())


def _scenario(edit=None):
    d = copy.deepcopy(PAPER_DICT)
    if edit:
        edit(d)
    return scenario_from_dict(d, name='paper_flyby (test)')


def _plan(sc, **config_overrides):
    cfg = planner_config_from_scenario(sc)
    if config_overrides:
        cfg = type(cfg)(**{**cfg.__dict__, **config_overrides})
    pred = truth_prediction(sc, cfg.search_window[1])
    return plan_capture(pred, np.array(sc.chaser.initial_position_hill_m),
                        np.array(sc.chaser.initial_velocity_hill_mps), 0.0, cfg), cfg


@pytest.fixture(scope='module')
def paper_plan():
    return _plan(load_scenario(SCENARIOS / 'paper_flyby.yaml'))


def test_paper_flyby_plan_meets_the_issue_figures(paper_plan):
    plan, cfg = paper_plan
    assert plan.ok, plan.reason
    c = plan.selected
    assert abs(c.v_g[1]) < 1e-3  # grasp y velocity < 1 mm/s (eq 13)
    assert c.convex_value > 0.0  # the safe convex condition, eq 15
    assert c.clearance_approach_m >= cfg.clearance_margin_m
    assert c.clearance_escape_m >= cfg.clearance_margin_m
    assert np.linalg.norm(c.x_fi) > cfg.restriction_sphere_radius_m
    assert c.t_sphere_entry > c.t_i  # the adjusting phase has time outside the sphere
    # The grasp is 2.1213 m from the CoM with |v_g| = 0.131 m/s (seed 000 section 5) at every candidate.
    assert np.linalg.norm(c.x_g) == pytest.approx(math.hypot(1.5, 1.5), abs=1e-6)
    assert np.linalg.norm(c.v_g) == pytest.approx(0.131, abs=0.002)
    # Eq 20-21: X_Ft is the grasp point pushed out radially by delta r.
    np.testing.assert_allclose(c.x_ft, c.x_g * (1.0 + cfg.offset_m / np.linalg.norm(c.x_g)))
    # Eq 23: X_Fi coasts (CW) onto X_Ft in flyby_duration_s.
    arrived = cw_transition_matrix(cfg.mean_motion_rad_s, cfg.flyby_duration_s) @ np.concatenate((c.x_fi, c.v_fi))
    np.testing.assert_allclose(arrived, np.concatenate((c.x_ft, c.v_ft)), atol=1e-9)


def test_selection_is_the_cheapest_safe_candidate(paper_plan):
    plan, cfg = paper_plan
    safe = [c for c in plan.candidates if c.status in ('safe', 'selected')]
    assert len(safe) >= 2
    assert plan.selected.dv_total_mps == min(c.dv_total_mps for c in safe)
    # Every rejected candidate says why; the non-convex roots of each turn are among them (eq 17).
    rejected = [c for c in plan.candidates if c.status == 'rejected']
    assert rejected and all(c.reasons for c in rejected)
    assert any('not convex' in c.reasons[0] for c in rejected)
    assert [c.status for c in plan.candidates].count('selected') == 1


def test_ties_go_to_the_larger_clearance():
    plan, _ = _plan(load_scenario(SCENARIOS / 'paper_flyby.yaml'), delta_v_tie_mps=10.0)
    safe = [c for c in plan.candidates if c.status in ('safe', 'selected')]
    assert plan.selected.clearance_min_m == max(c.clearance_min_m for c in safe)


def test_passive_path_clears_the_real_target_independently(paper_plan):
    """Fly the selected X_Fi, V_Fi with the simulator's RK4 and nonlinear dynamics past the truly rotating
    target boxes (flyby_sim.dynamics.geometry): the real clearance is at least the planned one, over one orbit."""
    plan, cfg = paper_plan
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    c = plan.selected
    n, radius = cfg.mean_motion_rad_s, cfg.orbit_radius_m
    span = cfg.flyby_duration_s + cfg.escape_duration_s
    truth = truth_prediction(sc, c.t_i + span)
    y = np.concatenate((c.x_fi, c.v_fi))
    f = lambda _, s: np.concatenate((s[3:], nonlinear_relative_accel(s[:3], s[3:], n, radius)))  # noqa: E731
    boxes = list(zip(sc.boxes.center_body_m, sc.boxes.size_m, strict=True))
    h = 0.25
    least = math.inf
    for k in range(int(span / h)):
        t = c.t_i + k * h
        if abs(t - c.t_grasp) < 120.0 or k % 40 == 0:  # fine near the passage, every 10 s elsewhere
            q = truth.state(t).q_hill_from_body
            least = min(least, float(clearance(y[:3], q, boxes, cfg.envelope_radius_m)[0]))
        y = rk4_step(f, 0.0, y, h)
    assert least >= cfg.clearance_margin_m
    assert least >= min(c.clearance_approach_m, c.clearance_escape_m) - 1e-3
    # The published path passes X_Ft at the grasp time.
    i = int(np.argmin(np.abs(plan.path_t - c.t_grasp)))
    assert np.linalg.norm(plan.path_r_hill[i] - c.x_ft) < 0.01


def test_plan_json_round_trips(paper_plan):
    plan, _ = paper_plan
    d = json.loads(json.dumps(plan.to_dict()))
    assert d['ok'] and d['selected']['status'] == 'selected'
    assert len(d['candidates']) == len(plan.candidates)
    assert [c['name'] for c in d['keep_out']['cylinders']] == ['bus', 'panel_plus_y', 'panel_minus_y']


def test_spin_axis_along_hill_y_is_refused():
    """Seed 000 section 3.3: the singular case. The axis stays along hill y (it is the orbit normal)."""
    sc = _scenario(lambda d: d['target']['initial_attitude']['body_axis_along_hill'].update(hill=[0.0, 1.0, 0.0]))
    plan, _ = _plan(sc)
    assert not plan.ok
    assert 'condition (b)' in plan.reason and 'section 3.3' in plan.reason


def test_spin_axis_near_hill_y_fails_condition_b_per_candidate():
    sc = _scenario(lambda d: d['target']['initial_attitude']['body_axis_along_hill'].update(hill=[0.1, 1.0, 0.0]))
    plan, _ = _plan(sc)
    assert not plan.ok
    assert plan.candidates and all(any('condition (b)' in r for r in c.reasons) for c in plan.candidates)


def test_faster_than_category_iii_is_refused():
    sc = _scenario(lambda d: d['target']['initial_rate'].update(omega_body_deg_s=[0.0, 0.0, 20.0]))
    plan, _ = _plan(sc)
    assert not plan.ok and not plan.candidates
    assert plan.reason.startswith('condition (a): target rate 20 deg/s >= 18 deg/s')


def test_a_target_at_rest_is_refused():
    sc = _scenario(lambda d: d['target']['initial_rate'].update(omega_body_deg_s=[0.0, 0.0, 0.0]))
    plan, _ = _plan(sc)
    assert not plan.ok and 'no rotation' in plan.reason


def test_seed001_tumbler_is_refused_as_category_iv():
    sc = load_scenario(SCENARIOS / 'seweryn_tumbling.yaml')
    plan, _ = _plan(sc)
    assert not plan.ok and 'category IV' in plan.reason


def test_bad_lighting_rejects_every_convex_candidate():
    sc = _scenario(lambda d: d['planner'].update(sun_direction_hill=[1.0, 0.0, 0.0]))
    plan, _ = _plan(sc)
    assert not plan.ok and plan.reason.startswith('all 8 candidates rejected')
    convex = [c for c in plan.candidates if c.convex_value > 0.0]
    assert convex and all(any('condition (c)' in r for r in c.reasons) for c in convex)


def test_too_small_an_offset_is_unsafe():
    """delta r = 0.2 m puts the 0.5 m chaser envelope into the swept bus: every candidate is rejected."""
    sc = _scenario(lambda d: d['planner'].update(offset_m=0.2))
    plan, _ = _plan(sc)
    assert not plan.ok
    convex = [c for c in plan.candidates if c.convex_value > 0.0]
    assert convex and all('clearance' in c.reasons[-1] and c.clearance_approach_m < 0.1 for c in convex)


def test_a_short_flyby_puts_x_fi_inside_the_sphere():
    sc = _scenario(lambda d: d['planner'].update(flyby_duration_s=60.0))
    plan, _ = _plan(sc)
    assert not plan.ok
    assert all(any('restriction sphere' in r for r in c.reasons) for c in plan.candidates)


def test_prediction_must_cover_the_window():
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    cfg = planner_config_from_scenario(sc)
    with pytest.raises(ValueError, match='needs it up to'):
        plan_capture(truth_prediction(sc, 100.0), np.ones(3), np.zeros(3), 0.0, cfg)
    with pytest.raises(ValueError, match='chaser state'):
        plan_capture(truth_prediction(sc, cfg.search_window[1]), np.array((np.nan, 0.0, 0.0)), np.zeros(3), 0.0, cfg)


def test_avoidance_burn_only_when_the_coast_is_unsafe(paper_plan):
    plan, cfg = paper_plan
    c = plan.selected
    # On the planned fly-by the coast is passively safe: no burn.
    dv, before, after = avoidance_burn(c.x_fi, c.v_fi, c.t_i, plan.region, cfg, 0.05)
    assert dv is None and before == after >= cfg.clearance_margin_m
    # Falling onto the bus along the spin axis from 20 m: a burn, and its coast is safe.
    axis = plan.region.axis_hill(c.t_i, cfg.mean_motion_rad_s)
    dv, before, after = avoidance_burn(20.0 * axis, -0.2 * axis, c.t_i, plan.region, cfg, 0.05)
    assert dv is not None and before < 0.0 and after >= cfg.clearance_margin_m
    np.testing.assert_allclose(dv, 0.25 * axis, atol=1e-12)  # the retreat: stop the 0.2 m/s fall, 0.05 m/s away
