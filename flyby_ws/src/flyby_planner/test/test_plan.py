"""Tests of flyby_planner.flyby.search: the seed 000 fly-by plan of paper_flyby, its safety, selection and refusals."""

import copy
import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import MotionPrediction
from flyby_planner.flyby.avoidance import avoidance_burn
from flyby_planner.flyby.candidates import _transfer_spread_m
from flyby_planner.flyby.config import PlannerConfig, truth_prediction
from flyby_planner.flyby.passive_safety import check_passage, predicted_gaps
from flyby_planner.flyby.search import plan_capture
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
    cfg = PlannerConfig.from_scenario(sc)
    if config_overrides:
        cfg = type(cfg)(**{**cfg.__dict__, **config_overrides})
    pred = truth_prediction(sc, cfg.prediction_span_s(sc.omega_body0_rad_s))
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
    assert not plan.ok and plan.reason.startswith('all ') and 'condition (c), lighting' in plan.reason
    convex = [c for c in plan.candidates if c.convex_value > 0.0]
    assert convex and all(any('condition (c)' in r for r in c.reasons) for c in convex)


def test_lighting_angle_is_the_same_at_every_convex_instant_of_a_principal_spin():
    """With the sun and the spin axis fixed in inertial space, the convex grasp velocity (eq 19) is
    along +-(e_y x omega), fixed in inertial space too: condition (c) holds at every grasp instant of a
    principal-axis spin or at none, however long the window (docs/campaigns.md)."""
    from flyby_sim.dynamics.orbital import hill_axes_in_eci
    def edit(d):
        d['planner'].update(transfer_max_s=2000.0)
        d['simulation'].update(duration_s=4000.0)  # the mission lasts past the window
    sc = _scenario(edit)
    cfg = PlannerConfig.from_scenario(sc)
    plan = plan_capture(truth_prediction(sc, cfg.prediction_span_s(sc.omega_body0_rad_s)),
                        np.array(sc.chaser.initial_position_hill_m), np.zeros(3), 0.0, cfg)
    convex = [c for c in plan.candidates if c.convex_value > 0.0]
    assert convex[-1].t_grasp - convex[0].t_grasp > 1800.0  # a third of an orbit: the hill frame turned 110 deg
    v_eci = np.array([hill_axes_in_eci(c.t_grasp, cfg.mean_motion_rad_s) @ c.v_g / np.linalg.norm(c.v_g)
                      for c in convex])
    assert np.degrees(np.arccos(np.clip(v_eci @ v_eci[0], -1.0, 1.0))).max() < 2.0


def test_the_offset_search_steps_out_of_an_unsafe_preferred_offset():
    """delta r = 0.2 m puts the 0.5 m chaser envelope into the bus; searched up to the reach less the
    tolerance the planner takes the nearest safe offset, and says why the preferred one failed."""
    sc = _scenario(lambda d: d['planner'].update(offset_m=0.2, offset_min_m=0.2))
    plan, cfg = _plan(sc)
    assert cfg.offsets_m[0] == 0.2 and max(cfg.offsets_m) == pytest.approx(1.4)
    assert plan.ok and plan.selected.offset_m > 0.2
    np.testing.assert_allclose(np.linalg.norm(plan.selected.x_ft) - np.linalg.norm(plan.selected.x_g),
                               plan.selected.offset_m)
    assert not any(c.offset_m == 0.2 for c in plan.candidates if c.status != 'rejected')


def test_a_blocked_grasp_point_is_refused_at_every_offset():
    """Only delta r = 0.2 m: the fly-by target point is in the bus's reach at any grasp time: refused at once."""
    sc = _scenario(lambda d: d['planner'].update(offset_m=0.2, offset_min_m=0.2, offset_max_m=0.2))
    plan, _ = _plan(sc)
    assert not plan.ok and plan.reason.startswith('no offset reaches the grasp point')
    assert 'the bus blocks' in plan.reason


def test_a_grasp_point_under_a_panel_is_refused_naming_the_panel():
    sc = _scenario(lambda d: d['target'].update(grasp_point_body_m=[0.2, 1.5, 0.15]))
    plan, _ = _plan(sc)
    assert not plan.ok and 'the panel_plus_y blocks the grasp point' in plan.reason


def test_a_short_flyby_puts_x_fi_inside_the_sphere():
    sc = _scenario(lambda d: d['planner'].update(flyby_duration_s=60.0, flyby_duration_max_s=60.0))
    plan, _ = _plan(sc)
    assert not plan.ok
    assert all(any('restriction sphere' in r for r in c.reasons) for c in plan.candidates if c.convex_value > 0.0)


def test_the_duration_search_lengthens_a_flyby_that_starts_inside_the_sphere():
    sc = _scenario(lambda d: d['planner'].update(flyby_duration_s=60.0, flyby_duration_max_s=400.0))
    plan, cfg = _plan(sc)
    assert cfg.flyby_durations_s == (60.0, 90.0, 120.0, 180.0, 30.0)  # the preferred, longer, then half
    assert plan.ok and plan.selected.flyby_duration_s > 60.0
    assert np.linalg.norm(plan.selected.x_fi) > cfg.restriction_sphere_radius_m


def test_issue12_oblique_spin_grasp_off_the_axis_is_planned():
    """Issue 12's example: 8 deg/s about an oblique axis, grasp at body [1.5, -1.0, 1.2] m, the chaser off
    the orbit plane. At delta r = 1 m every candidate missed the keep-out margin (0.071 m against 0.1 m)
    and the run aborted; the predicted-geometry check and the offset search find a safe fly-by."""
    def edit(d):
        d['target']['initial_rate']['omega_body_deg_s'] = [0.0, 0.0, 8.0]
        d['target']['initial_attitude']['body_axis_along_hill']['hill'] = [1.0, -0.6, 0.4]
        d['target']['grasp_point_body_m'] = [1.5, -1.0, 1.2]
        d['chaser']['initial_position_hill_m'] = [40.0, 25.0, -15.0]
    plan, cfg = _plan(_scenario(edit))
    assert plan.ok, plan.reason
    assert plan.selected.clearance_min_m >= cfg.clearance_margin_m


def test_predicted_geometry_admits_a_grasp_point_inside_the_panels_sweep():
    """A grasp point on the +x face in the plane of 3 m panels lies inside the disc the panels sweep: the
    swept region alone refuses every fly-by, the predicted geometry finds the gap between the panels,
    and the passive path clears the true target by the margin (checked here on an independent RK4
    coast against the true attitude)."""
    def edit(d):
        d['target']['grasp_point_body_m'] = [1.5, 0.3, 0.0]
        for panel, y in ((d['target']['geometry'][1], 3.0), (d['target']['geometry'][2], -3.0)):
            panel.update(center_m=[0.0, y, 0.0], size_m=[2.0, 3.0, 0.05])
    sc = _scenario(edit)
    swept_only, _ = _plan(sc, geometry_window_s=0.0)
    assert not swept_only.ok and 'passive clearance' in swept_only.reason
    plan, cfg = _plan(sc)
    assert plan.ok, plan.reason
    c = plan.selected
    assert c.closest != 'swept region' or c.clearance_min_m >= cfg.clearance_margin_m
    n = cfg.mean_motion_rad_s
    truth = truth_prediction(sc, c.t_grasp + 200.0)
    state = np.concatenate((c.x_ft, c.v_ft))
    for direction in (-1.0, 1.0):  # back to X_Fi's side and on into the escape, 0.01 s steps for 150 s
        x, gaps = state.copy(), []
        for k in range(15000):
            t = c.t_grasp + direction * 0.01 * k
            q = truth.state(t).q_hill_from_body
            gaps.append(float(clearance(x[:3][None, :], q, list(zip(sc.boxes.center_body_m, sc.boxes.size_m,
                                                                             strict=True)), 0.5)[0]))
            x = rk4_step(lambda _t, y: np.concatenate((y[3:], nonlinear_relative_accel(y[:3], y[3:], n,
                                                                                       cfg.orbit_radius_m))),
                         t, x, direction * 0.01)
        assert min(gaps) >= cfg.clearance_margin_m


def test_prediction_must_cover_the_window():
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    cfg = PlannerConfig.from_scenario(sc)
    with pytest.raises(ValueError, match='needs it up to'):
        plan_capture(truth_prediction(sc, 100.0), np.ones(3), np.zeros(3), 0.0, cfg)
    with pytest.raises(ValueError, match='chaser state'):
        plan_capture(truth_prediction(sc, cfg.prediction_span_s(sc.omega_body0_rad_s)), np.array((np.nan, 0.0, 0.0)),
                     np.zeros(3), 0.0, cfg)


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


def test_check_passage_passes_the_planned_arc_and_fails_one_through_the_bus(paper_plan):
    """Guidance's gate on a re-aimed arc (plan.check_passage) is the planner's step 4 without the chaser's own
    dispersion (the gate re-aims the arc the chaser is on): the selected arc keeps at least the clearance the plan
    found, more by the chaser's 3 sigma at the grasp; the same arc aimed 1.5 m closer (through the bus) does not."""
    plan, cfg = paper_plan
    c = plan.selected
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    pred = truth_prediction(sc, c.t_grasp + cfg.geometry_window_s)
    ok = check_passage(pred, c.x_ft, c.v_ft, c.t_grasp, c.t_i, cfg)
    assert ok.safe and c.clearance_min_m <= ok.gap_m <= c.clearance_min_m + c.miss_3sigma_m
    inside = c.x_g * (1.0 - 0.5 / np.linalg.norm(c.x_g))  # 0.5 m under the grasp point: in the bus
    hit = check_passage(pred, inside, c.v_ft, c.t_grasp, c.t_i, cfg)
    assert not hit.safe and hit.gap_m < 0.0
    # With the estimate's own covariance (guidance's gate) the allowance is 3 sigma of it, here 0.05 deg
    # and 0.0005 deg/s against the planner's 2 deg + 0.02 deg/s: the same arc keeps more.
    s0 = pred.state(c.t_i)
    p0 = np.diag([np.radians(0.05) ** 2] * 3 + [np.radians(0.0005) ** 2] * 3)
    tight = MotionPrediction(ErrorStateDynamics(sc.target_inertia), cfg.mean_motion_rad_s, c.t_i, s0.q_eci_from_body,
                             s0.omega_body, p0, pred.t_end)
    gated = check_passage(tight, c.x_ft, c.v_ft, c.t_grasp, c.t_i, cfg, 0.0)
    assert gated.safe and gated.gap_m >= ok.gap_m
    at_grasp = (c.x_ft[None, :], np.array([c.t_grasp]), c.t_grasp, cfg)
    planner_gap, gate_gap = predicted_gaps(pred, *at_grasp)[0][0], predicted_gaps(tight, *at_grasp)[0][0]
    sigma = tight.attitude_sigma_rad([c.t_grasp])[0]
    assert gate_gap - planner_gap == pytest.approx(np.linalg.norm(c.x_ft) * (cfg.geometry_attitude_margin_rad
                                                                             - 3.0 * sigma), rel=1e-9)
    assert abs(hit.t_min_gap - c.t_grasp) < 5.0


def test_transfer_spread_bounds_dispersed_impulses():
    """The planner's 3-sigma spread of a transfer (candidates._transfer_spread_m) against 4000 impulses drawn with
    the thrusters' magnitude and pointing errors and coasted by the CW transition matrix: before the
    midcourse correction fewer than 1 % leave it (the 3-sigma norm of a 3-D error), and it grows with
    the impulse and the error."""
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    cfg = dataclasses.replace(PlannerConfig.from_scenario(sc), impulse_error_sigma=math.hypot(0.03, math.radians(1.5)))
    n, span = cfg.mean_motion_rad_s, 400.0
    taus = np.linspace(0.0, span, 41)
    stm = cw_transition_matrix(n, taus)
    dv = np.array([0.15, -0.05, 0.1])
    spread = _transfer_spread_m(taus, stm, span, float(np.linalg.norm(dv)), cfg)
    rng = np.random.default_rng(12)
    size = 1.0 + 0.03 * rng.standard_normal(4000)
    tilt = np.radians(1.5) * rng.standard_normal((4000, 3))
    tilt -= np.outer(tilt @ dv, dv) / (dv @ dv)  # pointing error: a small rotation about an axis across dv
    executed = size[:, None] * (dv + np.cross(tilt, dv))
    error = executed - dv
    deviation = np.linalg.norm(np.einsum('mij,kj->kmi', stm[:, :3, 3:], error), axis=2)  # (4000, M)
    before_mid = taus <= span / 2.0
    assert np.mean(deviation[:, before_mid] > spread[before_mid]) < 0.01
    assert spread[0] == 0.0 and spread[-1] == pytest.approx(0.0, abs=1e-12)
    assert np.argmax(spread) == np.flatnonzero(before_mid)[-1]
