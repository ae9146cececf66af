"""Tests of the fly-by planner's uncertainty model (flyby_planner.flyby.uncertainty, the package doc's step 4): the
navigation and target estimate covariances it predicts, the predicted 3-sigma miss at the grasp, the chaser's
dispersion on the passage, and the searches it enables (the extended grasp window, the short fly-by)."""

import copy
import dataclasses
import math
import types
from pathlib import Path

import numpy as np
import pytest
import yaml

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.params import RelativeNavParams, TargetFilterParams
from flyby_estimation.relative_nav import RelativeNavFilter
from flyby_estimation.target_filter import TargetAttitudeFilter
from flyby_estimation.target_motion import MotionPrediction, prediction_from_estimate
from flyby_planner.flyby.config import PlannerConfig, truth_prediction
from flyby_planner.flyby.diagnostics import exhaustive_check
from flyby_planner.flyby.passive_safety import passive_passages, predicted_region
from flyby_planner.flyby.search import plan_capture
from flyby_planner.flyby.uncertainty import (
    EstimateAccuracy,
    TargetUncertainty,
    chaser_error_at_estimate,
    largest_eigenvalue,
    predicted_miss,
)
from flyby_sim.dynamics.orbital import cw_transition_matrix
from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_multiply, quat_to_matrix
from flyby_sim.scenario import load_scenario, scenario_from_dict
from flyby_testing import envelope_run, envelope_run_323, envelope_run_340, envelope_run_569

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
PAPER_DICT = yaml.safe_load((SCENARIOS / 'paper_flyby.yaml').read_text())


def _scenario(edit=None):
    d = copy.deepcopy(PAPER_DICT)
    if edit:
        edit(d)
    return scenario_from_dict(d, name='paper_flyby (test)')


def _plan(sc, t_plan=0.0, **config_overrides):
    cfg = PlannerConfig.from_scenario(sc)
    if config_overrides:
        cfg = type(cfg)(**{**cfg.__dict__, **config_overrides})
    pred = truth_prediction(sc, t_plan + cfg.prediction_span_s(sc.omega_body0_rad_s))
    n = cfg.mean_motion_rad_s
    state = cw_transition_matrix(n, t_plan) @ np.concatenate((sc.chaser.initial_position_hill_m,
                                                              sc.chaser.initial_velocity_hill_mps))
    return plan_capture(pred, state[:3], state[3:], t_plan, cfg), cfg, pred


@pytest.fixture(scope='module')
def paper_plan():
    return _plan(load_scenario(SCENARIOS / 'paper_flyby.yaml'))


def test_largest_eigenvalue_closed_form_matches_eigvalsh():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(500, 3, 3))
    a = a @ np.swapaxes(a, 1, 2)
    a[0], a[1], a[2] = 2.0 * np.eye(3), np.diag((1e-12, 0.0, 0.0)), np.zeros((3, 3))
    np.testing.assert_allclose(largest_eigenvalue(a), np.linalg.eigvalsh(a)[:, -1], rtol=1e-12, atol=1e-24)


def test_navigation_covariance_is_the_navigation_filters_steady_state():
    """EstimateAccuracy.navigation_covariance against flyby_estimation's RelativeNavFilter after 60 s of 10 Hz
    measurements of a chaser at rest on V-bar (a CW equilibrium)."""
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    acc = EstimateAccuracy.from_scenario(sc)
    nav = RelativeNavFilter(RelativeNavParams.from_scenario(sc).config(initial_velocity_sigma_mps=0.1))
    rng = np.random.default_rng(7)
    r0 = np.array(sc.chaser.initial_position_hill_m)
    for k in range(601):
        nav.update(0.1 * k, r0 + rng.normal(0.0, acc.position_sigma_m, 3))
    p = nav.state().covariance
    np.testing.assert_allclose(np.diag(p), np.diag(acc.navigation_covariance), rtol=2e-3)
    scale = np.sqrt(np.outer(np.diag(p), np.diag(p)))  # correlations agree to 0.02 (the CW coupling it neglects)
    np.testing.assert_allclose(p / scale, acc.navigation_covariance / scale, atol=0.02)
    # 1 cm at 10 Hz with q = 1e-9 m^2/s^3: 1.19 mm and 0.119 mm/s.
    assert math.sqrt(acc.navigation_covariance[3, 3]) == pytest.approx(1.19e-4, rel=0.01)


def test_predicted_target_covariance_follows_the_target_filter():
    """TargetUncertainty started from the target filter's covariance at 100 s of a 4.6 deg/s tumbler: after 150 s
    more of 1 deg vision at 10 Hz its filtered attitude and rate sigmas are the filter's own to 5 %, and carried
    60 s on without measurements they are the filter's prediction's."""
    sc = _scenario(lambda d: d['target']['initial_rate'].update(omega_body_deg_s=[2.0, 1.0, 4.0]))
    cfg = PlannerConfig.from_scenario(sc)
    n = cfg.mean_motion_rad_s
    truth = truth_prediction(sc, 320.0)
    filt = TargetAttitudeFilter(TargetFilterParams.from_scenario(sc).config())
    rng = np.random.default_rng(11)
    sigma = math.radians(sc.sensors.target_attitude.noise_sigma_deg)

    def feed(t0, t1):
        for t in np.arange(t0, t1 + 1e-9, 0.1):
            q = quat_multiply(truth.state(t).q_hill_from_body, quat_from_rotation_vector(rng.normal(0.0, sigma, 3)))
            filt.update(float(t), q)

    feed(0.0, 100.0)
    s0 = filt.state()
    pred = prediction_from_estimate(ErrorStateDynamics(sc.target_inertia), n, s0.t, s0.q_hill_from_body,
                                    s0.omega_body, s0.t + 220.0)
    unc = TargetUncertainty(pred, s0.t, cfg, covariance0=filt.covariance)
    feed(100.1, 250.0)

    def sigmas(p):
        return np.sqrt([np.linalg.eigvalsh(p[:3, :3])[-1], np.linalg.eigvalsh(p[3:, 3:])[-1]])

    np.testing.assert_allclose(sigmas(unc.predicted(250.0, [250.0])[0]), sigmas(filt.covariance), rtol=0.05)
    ahead = filt.prediction(310.0).state(310.0).covariance
    np.testing.assert_allclose(sigmas(unc.predicted(250.0, [310.0])[0]), sigmas(ahead), rtol=0.05)


def test_predicted_miss_matches_a_monte_carlo_of_the_last_burn_estimate(paper_plan):
    """The predicted 3-sigma miss of paper_flyby's plan against 300 draws of the chaser's state error and the
    target estimate's error at the estimate of the last burn, the target's propagated with its nonlinear
    torque-free motion (seed 000 eq 4) and X_Ft recomputed as the body point it is (eq 20): 3 sigma along the
    worst direction within 15 %, for the target's part alone too."""
    plan, cfg, pred = paper_plan
    c = plan.selected
    n = cfg.mean_motion_rad_s
    unc = TargetUncertainty(pred, 0.0, cfg)
    key = (c.t_grasp, c.offset_m)
    ps = passive_passages([key], [np.concatenate((c.x_ft, c.v_ft))], pred, predicted_region(pred, 0.0, cfg), cfg,
                   uncertainty=unc)[key]
    chaser_cov = chaser_error_at_estimate(c, ps.coast_s, cfg)
    miss, miss_v, (_, _, target_3sigma) = predicted_miss(c, ps, chaser_cov, c.unguided_coast_s, cfg)
    assert miss == pytest.approx(c.miss_3sigma_m, rel=1e-4) and miss <= cfg.position_tolerance_m
    assert miss_v <= cfg.velocity_tolerance_mps

    rng = np.random.default_rng(3)
    draws = 300
    stm = cw_transition_matrix(n, c.unguided_coast_s + cfg.command_lead_s)
    chaser = (stm @ rng.multivariate_normal(np.zeros(6), chaser_cov, draws).T).T[:, :3]
    t_est = ps.t_estimate
    at_est = pred.state(t_est)
    c_grasp = quat_to_matrix(pred.state(c.t_grasp).q_hill_from_body)
    x_ft_body = c_grasp.T @ c.x_ft
    dyn = ErrorStateDynamics(cfg.inertia_kg_m2)
    target = []
    for d in rng.multivariate_normal(np.zeros(6), unc.predicted(t_est, [t_est])[0], draws):
        q = quat_multiply(at_est.q_eci_from_body, quat_from_rotation_vector(d[:3]))  # q_true = q exp(dtheta_body)
        moved = MotionPrediction(dyn, n, t_est, q, at_est.omega_body + d[3:], None, c.t_grasp, with_covariance=False)
        target.append(quat_to_matrix(moved.state(c.t_grasp).q_hill_from_body) @ x_ft_body - c.x_ft)
    target = np.array(target)

    def sigma3(errors):
        return 3.0 * math.sqrt(np.linalg.eigvalsh(np.cov(errors.T))[-1])

    assert sigma3(target) == pytest.approx(target_3sigma, rel=0.15)
    assert sigma3(chaser - target) == pytest.approx(miss, rel=0.15)


def test_the_last_burn_is_the_injection_when_no_adjusting_burn_fits():
    """With no adjusting burn between the injection (eq 29) and the last burnable instant the injection's execution
    error is flown through the coast; each adjusting burn before the last corrects it to the thrusters' relative
    error: sigma^(k + 1) |dV_Tf| after k of them."""
    cfg = PlannerConfig.from_scenario(_scenario(lambda d: d['chaser']['thrusters'].update(
        magnitude_error_sigma=0.03, direction_error_sigma_deg=0.0)))
    c = types.SimpleNamespace(flyby_duration_s=300.0, dv_tf=np.array((0.0, 0.1, 0.0)))
    nav = cfg.accuracy.navigation_covariance
    for coast, k in ((300.0, 0), (290.0, 0), (275.0, 1), (255.0, 2)):
        cov = chaser_error_at_estimate(c, coast, cfg)
        np.testing.assert_allclose(cov[:3, :], nav[:3, :])
        np.testing.assert_allclose(cov[3:, 3:] - nav[3:, 3:], (0.03 ** (k + 1) * 0.1) ** 2 * np.eye(3), rtol=1e-9)


def test_the_chaser_dispersion_narrows_the_passage(paper_plan):
    """Near the grasp every gap of the passage is the one without the chaser's dispersion less at least 3 sigma of
    its position error (the larger of the swept-region and the predicted-geometry gap); beyond the window none."""
    plan, cfg, pred = paper_plan
    c = plan.selected
    unc = TargetUncertainty(pred, 0.0, cfg)
    key = (c.t_grasp, c.offset_m)
    ps = passive_passages([key], [np.concatenate((c.x_ft, c.v_ft))], pred, predicted_region(pred, 0.0, cfg), cfg,
                   uncertainty=unc)[key]
    zero, _ = ps.profile(np.zeros((6, 6)), cfg.mean_motion_rad_s)
    chaser_cov = chaser_error_at_estimate(c, ps.coast_s, cfg)
    gap, _ = ps.profile(chaser_cov, cfg.mean_motion_rad_s)
    at_grasp = int(np.argmin(np.abs(ps.tau)))
    stm = cw_transition_matrix(cfg.mean_motion_rad_s, c.t_grasp - ps.t_estimate)[:3]
    sigma_c = math.sqrt(np.linalg.eigvalsh(stm @ chaser_cov @ stm.T)[-1])
    assert zero[at_grasp] - gap[at_grasp] == pytest.approx(3.0 * sigma_c, rel=1e-3)
    assert np.all(gap <= zero + 1e-12)
    np.testing.assert_array_equal(gap[~ps.window], zero[~ps.window])


def test_a_slow_spin_is_refused_by_its_predicted_miss_and_planned_with_finer_navigation():
    """A 1.5 deg/s spin: its grasp point crawls through the restriction sphere and the unguided coast is 265 s or
    more; with 3 cm relative-position noise the predicted 3-sigma miss exceeds the manipulator's 0.1 m (0.137 m),
    with 3 mm it is met (0.080 m): the bound follows the navigation, not a fixed coast."""
    def slow(noise_m):
        def edit(d):
            d['target']['initial_rate']['omega_body_deg_s'] = [0.0, 0.0, 1.5]
            d['sensors']['relative_position']['noise_sigma_m'] = noise_m
        return _scenario(edit)

    refused, cfg, _ = _plan(slow(0.03))
    assert not refused.ok and 'predicted miss above the tolerance' in refused.reason
    by_miss = [c for c in refused.candidates if c.reasons and c.reasons[0].startswith('predicted 3-sigma miss')]
    assert by_miss and all(c.miss_3sigma_m > cfg.position_tolerance_m for c in by_miss)
    planned, cfg, _ = _plan(slow(0.003))
    assert planned.ok and planned.selected.miss_3sigma_m <= cfg.position_tolerance_m
    assert planned.selected.unguided_coast_s > 200.0  # beyond the old fixed bound


def test_the_exhaustive_check_confirms_a_refusal_and_finds_what_the_planner_flies():
    """plan.exhaustive_check (scripts/check_refusals.py) on the slow spin above, the grasp window and the extended
    one up to 900 s: at 3 cm of noise no candidate is both clear and within the manipulator's tolerance, at 3 mm
    some are, and a transfer flies one of them; a grasp point by a panel root has no clear offset at all."""
    def check(edit):
        sc = _scenario(edit)
        cfg = dataclasses.replace(PlannerConfig.from_scenario(sc), latest_grasp_s=900.0)
        pred = truth_prediction(sc, cfg.prediction_span_s(sc.omega_body0_rad_s, extended=True))
        return exhaustive_check(pred, sc.chaser.initial_position_hill_m, sc.chaser.initial_velocity_hill_mps, 0.0,
                                cfg), cfg

    def slow(noise_m):
        def edit(d):
            d['target']['initial_rate']['omega_body_deg_s'] = [0.0, 0.0, 1.5]
            d['sensors']['relative_position']['noise_sigma_m'] = noise_m
        return edit

    refused, cfg = check(slow(0.03))
    assert refused.candidates > 0 and refused.n_both == 0 and refused.n_flyable == 0
    assert refused.min_miss_if_clear_m is None or refused.min_miss_if_clear_m > cfg.position_tolerance_m
    flown, cfg = check(slow(0.003))
    assert flown.n_flyable >= 1 and flown.n_both >= flown.n_flyable
    assert flown.min_miss_m <= cfg.position_tolerance_m
    panel_root, _ = check(lambda d: d['target'].update(grasp_point_body_m=[-0.36, -1.5, -0.13]))
    assert panel_root.offsets_clear == 0 and panel_root.candidates == 0


def test_a_grasp_point_beside_a_panel_root_is_refused_with_the_attitude_known_exactly():
    """Envelope run 12's grasp point, on the -y face 0.13 m below the panel's plane: at every offset the radial
    fly-by target point (eq 20) puts the chaser envelope into the panel, whatever the attitude knowledge."""
    sc = _scenario(lambda d: d['target'].update(grasp_point_body_m=[-0.36, -1.5, -0.13]))
    plan, _, _ = _plan(sc)
    assert not plan.ok and plan.reason.startswith('no offset reaches the grasp point')
    assert 'with the attitude known exactly' in plan.reason and 'panel_minus_y' in plan.reason


def test_the_extended_window_ends_with_the_mission():
    """The grasp window plans as it always did, whatever the mission's end (a short test run ends on its time
    limit); the extended window, searched only when the grasp window holds no safe plan, holds no grasp after
    latest_grasp_s (simulation.duration_s less the capture hold): envelope run 323's extended plan at 2403 s is
    not made when the mission ends at 2000 s."""
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    plan, _, _ = _plan(sc, latest_grasp_s=300.0)
    assert plan.ok and plan.selected.t_grasp > 300.0 and not plan.selected.extended
    plan, cfg, _ = _plan(_scenario(envelope_run_323), t_plan=60.0, latest_grasp_s=2000.0)
    extended = [c for c in plan.candidates if c.extended]
    assert extended and all(c.t_grasp <= 2000.0 for c in extended)
    assert not plan.ok or plan.selected.t_grasp <= 2000.0


def test_the_window_search_extends_when_the_grasp_window_holds_no_safe_plan():
    """Envelope run 323 (a 6 deg/s tumbler, grasp point on the -y face by the bus edge, chaser 42 m away below and
    behind) planned from the truth at 60 s: every candidate of the grasp window fails (its transfer crosses the
    restriction sphere, or its passage meets a panel), and the extended window's transfers, up to 0.4 orbit, reach a
    grasp instant 39 minutes out whose passage keeps the margin (without the re-aim check: see below)."""
    plan, cfg, _ = _plan(_scenario(envelope_run_323), t_plan=60.0)
    assert plan.ok and plan.selected.extended
    window = [c for c in plan.candidates if not c.extended]
    assert window and all(c.reasons for c in window)
    assert any(r.startswith('transfer passes') for c in window for r in c.reasons)
    c = plan.selected
    assert c.t_grasp - c.flyby_duration_s - c.t_ti > cfg.transfer_max_for(1.0)  # longer than the window's transfers
    assert c.clearance_min_m >= cfg.clearance_margin_m and c.miss_3sigma_m <= cfg.position_tolerance_m
    assert c.t_grasp <= cfg.latest_grasp_s



def test_a_plan_without_the_estimate_covariance_has_no_reaim_check():
    """plan_capture without covariance_body (a plan from the truth, as above) checks no re-aimed passage: every
    candidate's reaim_gap_m is None and the plan is the one with the check off."""
    on, _, _ = _plan(_scenario(envelope_run_323), t_plan=60.0, reaim_check=True)
    off, _, _ = _plan(_scenario(envelope_run_323), t_plan=60.0, reaim_check=False)
    assert all(c.reaim_gap_m is None for c in on.candidates)
    assert on.ok and on.selected.to_dict() == off.selected.to_dict()


def test_envelope_run_323_from_the_convergence_bound_a_grasp_39_minutes_out_fails_the_reaimed_passage():
    """Why the re-aim check starts from the filter's covariance, not the convergence bound: from the bound (2-5 times
    the filter's sigma) the plan estimate's 3-sigma motions over 2100-2400 s move the passage guidance would re-aim
    onto by a metre or more (or take the grasp's turn out of reach), so the extended window's candidates are refused
    by the re-aimed passage and run 323, which captures from its filter's covariance, would be refused."""
    from flyby_planner.flyby.reaim import REAIM_COVARIANCE_SCALE
    sc = _scenario(envelope_run_323)
    cfg = PlannerConfig.from_scenario(sc)
    pred = truth_prediction(sc, 60.0 + cfg.prediction_span_s(sc.omega_body0_rad_s))
    state = cw_transition_matrix(cfg.mean_motion_rad_s, 60.0) @ np.concatenate(
        (sc.chaser.initial_position_hill_m, sc.chaser.initial_velocity_hill_mps))
    plan = plan_capture(pred, state[:3], state[3:], 60.0, cfg,
                        cfg.accuracy.converged_covariance / REAIM_COVARIANCE_SCALE)
    assert not plan.ok
    checked = [c for c in plan.candidates if c.reaim_gap_m is not None]
    assert checked and all(c.reasons[-1].startswith('the re-aimed passage') for c in checked)
    assert all(c.reaim_gap_m < cfg.clearance_margin_m for c in checked)
    assert max(c.t_grasp for c in checked) - 60.0 > 2000.0 and any(c.extended for c in checked)
    assert 'the re-aimed passage below the margin' in plan.reason

def test_envelope_run_340_the_extended_window_is_searched_past_its_first_stage():
    """Envelope run 340 at its plan time (60.1 s), from the estimates and the covariance the planner had in the fifth
    campaign: the grasp window and the extended window's first stage (offset 1 m) hold no safe plan, its panel sweeping
    every passage; the safe plans are at offset 1.4 m in the second stage, past 60 other candidates of that stage,
    where the search budget of 6 batches stopped (a NO_SAFE_PLAN in the campaign; docs/campaigns.md)."""
    sc = _scenario(envelope_run_340)
    cfg = PlannerConfig.from_scenario(sc)
    t_plan = 60.1
    q_hill_from_body = np.array((0.47829610276537565, 0.7952445157384633, 0.2456465105172925, -0.28013709168553214))
    omega_body = np.array((0.00698193707587852, 0.09309856268109427, 0.04322210967191846))
    chaser = np.array((-3.0894977446788876, 53.936212715136264, 57.06562820607904,
                       7.6409269687005761e-04, -3.8826089582909766e-03, 1.1812054640023715e-02))
    covariance_body = np.zeros((6, 6))
    covariance_body[:3, :3] = [[7.7218901099320218e-07, -1.9786398973535643e-07, 3.3097094752510076e-07],
                               [-1.9786398973535643e-07, 2.2982120295643774e-06, 8.5270272672590802e-08],
                               [3.3097094752510076e-07, 8.5270272672590802e-08, 1.6317957731190905e-06]]
    covariance_body[3:, 3:] = [[1.4423753979523486e-08, -9.4896497103770347e-10, -1.8943801884058187e-09],
                               [-9.4896497103770347e-10, 2.3605100746952594e-09, 2.4022763331188078e-10],
                               [-1.8943801884058187e-09, 2.4022763331188078e-10, 9.0129992413862277e-10]]
    pred = prediction_from_estimate(ErrorStateDynamics(cfg.inertia_kg_m2), cfg.mean_motion_rad_s, t_plan,
                                    q_hill_from_body, omega_body, t_plan + cfg.prediction_span_s(omega_body))
    plan = plan_capture(pred, chaser[:3], chaser[3:], t_plan, cfg, covariance_body)
    assert plan.ok, plan.reason
    chosen = plan.selected
    assert chosen.extended and chosen.offset_m == pytest.approx(1.4) and chosen.t_grasp - t_plan > 2000.0
    assert chosen.clearance_min_m >= cfg.clearance_margin_m and chosen.reaim_gap_m >= cfg.clearance_margin_m
    first_stage = [c for c in plan.candidates
                   if c.extended and (c.offset_m, c.flyby_duration_s) in cfg.search_stages[0]]
    assert first_stage and all(c.reasons for c in first_stage)
    second = sorted((c for c in plan.candidates if c.extended and c.clearance_approach_m is not None
                     and (c.offset_m, c.flyby_duration_s) in cfg.search_stages[1]), key=lambda c: c.dv_total_mps)
    assert second.index(chosen) >= 60 and all(c.reasons for c in second[:second.index(chosen)])


def test_a_fast_grasp_point_flies_half_the_preferred_flyby():
    """Envelope run 505 (a 14.5 deg/s tumbler, grasp point on the -x face, the chaser 98 m away) planned from the
    truth at 1109 s, when its estimate converged: at 300 s and longer fly-bys the grasp point's ~1 m/s puts X_Fi far
    out, and the injection beyond the thrusters' 2 m/s per maneuver or the transfer's execution spread into the
    restriction sphere; half the preferred fly-by (150 s, the last stage searched) is safe and flown."""
    def edit(d):
        t = d['target']
        t['initial_attitude']['body_axis_along_hill']['hill'] = [0.0815, 0.9168, -0.3910]
        t['initial_rate']['omega_body_deg_s'] = [5.7804, -0.8748, -13.2208]
        t['grasp_point_body_m'] = [-1.5, -1.1848, 0.8010]
        t['geometry'][1]['size_m'] = [2.0179, 6.5599, 0.05]
        t['geometry'][2]['size_m'] = [2.1314, 5.3711, 0.05]
        d['chaser']['initial_position_hill_m'] = [-24.500, -14.949, -92.993]
        d['chaser']['thrusters'].update(magnitude_error_sigma=0.0114, direction_error_sigma_deg=1.088)
        d['sensors']['relative_position']['noise_sigma_m'] = 0.0234
        d['sensors']['target_attitude']['noise_sigma_deg'] = 2.085
        d['planner']['sun_direction_hill'] = None
        d['simulation']['duration_s'] = 3000.0
    plan, cfg, _ = _plan(_scenario(edit), t_plan=1109.0)
    assert plan.ok and plan.selected.flyby_duration_s == pytest.approx(0.5 * cfg.flyby_duration_s)
    longer = [c for c in plan.candidates if c.flyby_duration_s > plan.selected.flyby_duration_s and c.convex_value > 0]
    assert longer and all(c.reasons for c in longer)
    assert {r.split()[0] for c in longer for r in c.reasons} >= {'transfer'}


def test_a_refusal_leads_with_the_latest_check_that_bound_it():
    """The refusal's first class is what bound the candidates that came furthest (the passage and the miss before
    the transfer, the transfer before X_Fi, X_Fi before the grasp instant's conditions), not the most numerous:
    a slow target's half-length fly-bys put many X_Fi inside the sphere at once (envelope runs 82, 95, 302)."""
    from flyby_planner.flyby.selection import refusal_reason

    def rejected(reason, k):
        return [types.SimpleNamespace(reasons=[reason], clearance_approach_m=None)] * k

    cfg = PlannerConfig.from_scenario(load_scenario(SCENARIOS / 'paper_flyby.yaml'))
    candidates = (rejected('X_Fi at 12.00 m is inside the restriction sphere (15 m)', 48)
                  + rejected('transfer passes 14.1 m from the target ...', 56)
                  + rejected('predicted 3-sigma miss at the grasp 0.126 m ...', 44)
                  + rejected('not convex: eq 15 value -1e-05 m^2/s^2 <= 0', 11))
    reason = refusal_reason(candidates, None, cfg)
    assert reason == ('all 159 candidates rejected: 44 predicted miss above the tolerance; 56 transfer through the '
                      'restriction sphere; 48 X_Fi inside the restriction sphere; 11 not convex (eq 15)')


def _envelope_run_569(d):
    envelope_run_569(d)
    d['simulation']['duration_s'] = 3000.0


# The estimate run 569 planned from (t = 125.1 s, 7 deg from the truth at its grasp 630 s later), the chaser's
# estimated state then (hill; m, m/s), as its headless replay recorded them, and the estimate's published covariance
# (covariance_from_published, 6x6 body, 4 digits).
_RUN_569_PLAN = (125.1, [-0.48082307293465565, -0.7153359196749034, 0.5067287115468437, 0.01815784818227692],
                 [-0.0091362953778875, -0.13995412946043953, 0.049404577488324615],
                 [35.83541297936146, -25.840796018537876, -80.54800366691838, -0.0047391399946759005,
                  0.0037330054509955, -0.03416054707719021])
_RUN_569_COVARIANCE = np.zeros((6, 6))
_RUN_569_COVARIANCE[:3, :3] = [[7.993e-07, -4.766e-08, -2.949e-07], [-4.766e-08, 3.784e-06, 9.558e-07],
                               [-2.949e-07, 9.558e-07, 4.064e-06]]
_RUN_569_COVARIANCE[3:, 3:] = [[8.404e-08, -5.547e-09, 1.970e-09], [-5.547e-09, 9.192e-10, -3.195e-10],
                               [1.970e-09, -3.195e-10, 1.219e-10]]


def _reaimed_at_truth(sc, cfg, c):
    """Least gap [m] of the chaser envelope from the TRUE target along the arc through X_Ft, V_Ft of the grasp
    re-solved from the true motion near c's grasp (what guidance flies once its estimate has converged), within
    the geometry window, by RK4 of the CW equations (independent of the planner's CW matrix)."""
    from flyby_planner.flyby.grasp_search import REFINE_HORIZON_S, flyby_target_point, refine_grasp
    from flyby_sim.dynamics.geometry import signed_distance_to_box
    n = cfg.mean_motion_rad_s
    truth = truth_prediction(sc, c.t_grasp + cfg.geometry_window_s + 1.0)
    g = refine_grasp(truth, cfg.x_grasp_body_m, c.t_grasp, n, t_latest=c.t_grasp + REFINE_HORIZON_S)
    x_ft, v_ft = flyby_target_point(g.x_g, g.v_g, c.offset_m)

    def cw(y):
        r, v = y[:3], y[3:]
        return np.concatenate((v, [2 * n * v[2], -n * n * r[1], -2 * n * v[0] + 3 * n * n * r[2]]))
    least = math.inf
    for sign in (-1.0, 1.0):
        h = 0.02 * sign
        ys = [np.concatenate((x_ft, v_ft))]
        for _ in range(int(cfg.geometry_window_s / 0.02)):
            y = ys[-1]
            k1 = cw(y)
            k2 = cw(y + 0.5 * h * k1)
            k3 = cw(y + 0.5 * h * k2)
            k4 = cw(y + h * k3)
            ys.append(y + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4))
        times = g.t_grasp + h * np.arange(len(ys))
        p_body = np.einsum('mji,mj->mi', truth.c_hill_from_body(times), np.array(ys)[:, :3])
        gaps = [signed_distance_to_box(p_body, ctr, size) for ctr, size in
                zip(cfg.boxes.center_body_m, cfg.boxes.size_m, strict=True)]
        least = min(least, float(np.min(gaps)) - cfg.envelope_radius_m)
    return least


def test_envelope_run_569_the_reaimed_passage_rejects_the_plan_it_flew_and_the_new_plan_clears_the_truth():
    """Envelope run 569 (fourth campaign, an escape): planned from its 125 s estimate, the plan flown (grasp at
    754.2 s) put the arc that guidance re-aims at the true grasp 0.3-0.4 m into the +y panel. The re-aim check
    (plan._ReaimModel) from that estimate's published covariance rejects it, and the plan it selects instead keeps
    the margin from the TRUE target once re-aimed at the true grasp."""
    sc = _scenario(_envelope_run_569)
    cfg = dataclasses.replace(PlannerConfig.from_scenario(sc), reaim_check=True)
    t, q, w, chaser = _RUN_569_PLAN
    pred = prediction_from_estimate(ErrorStateDynamics(sc.target_inertia), cfg.mean_motion_rad_s, t, q, w,
                                    t + cfg.prediction_span_s(w))
    plan = plan_capture(pred, chaser[:3], chaser[3:], t, cfg, _RUN_569_COVARIANCE)
    flown = [c for c in plan.candidates if abs(c.t_grasp - 754.2) < 0.5 and c.offset_m == 1.0
             and c.flyby_duration_s == 300.0]
    assert flown and flown[0].reasons[0].startswith('the re-aimed passage'), flown[0].reasons
    assert _reaimed_at_truth(sc, cfg, flown[0]) < 0.0  # the truth: that arc hits the target
    assert plan.ok, plan.reason
    chosen = plan.selected
    assert chosen.reaim_gap_m >= cfg.clearance_margin_m
    assert _reaimed_at_truth(sc, cfg, chosen) >= cfg.clearance_margin_m


def test_seed000_eq4_the_reaim_check_starts_from_the_plan_estimate_covariance():
    """plan._ReaimModel moves the plan estimate 3 sigma along each principal direction of the filter's own
    covariance at the plan time, inflated by REAIM_COVARIANCE_SCALE (its measured NEES): row 0 the estimate, then
    +-3 sqrt(scale lambda_k) v_k, each motion starting from its perturbed state; a covariance that is not a finite
    6x6 matrix is refused."""
    from flyby_planner.flyby.reaim import REAIM_COVARIANCE_SCALE, ReaimModel
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    cfg = dataclasses.replace(PlannerConfig.from_scenario(sc), reaim_check=True)
    pred = prediction_from_estimate(ErrorStateDynamics(sc.target_inertia), cfg.mean_motion_rad_s, 60.0,
                                    sc.q_hill_from_body0, sc.omega_body0_rad_s, 90.0)
    rng = np.random.default_rng(12)
    a = rng.normal(size=(6, 6)) * np.radians([0.1, 0.1, 0.1, 0.005, 0.005, 0.005])[:, None]
    cov = a @ a.T
    for given, expected in ((cov, REAIM_COVARIANCE_SCALE * cov), (np.diag(np.diag(cov)),
                                                                 REAIM_COVARIANCE_SCALE * np.diag(np.diag(cov)))):
        model = ReaimModel(pred, 60.0, cfg, given)
        assert np.array_equal(model.errors[0], np.zeros(6)) and len(model.motions) == 13
        plus, minus = model.errors[1::2], model.errors[2::2]
        assert np.array_equal(plus, -minus)
        # The +- pairs' outer products sum to 2 * 9 * the covariance they sample (its square-root factor).
        assert np.allclose(plus.T @ plus, 9.0 * expected, rtol=1e-9, atol=1e-18)
        e = model.errors[5]
        start = model.motions[5].state(60.0)
        q = quat_multiply(pred.state(60.0).q_eci_from_body, quat_from_rotation_vector(e[:3]))
        assert min(np.abs(start.q_eci_from_body - q).max(), np.abs(start.q_eci_from_body + q).max()) < 1e-12
        assert np.allclose(start.omega_body, sc.omega_body0_rad_s + e[3:], rtol=0.0, atol=1e-15)
    for bad in (np.eye(3), None, np.full((6, 6), np.nan)):
        with pytest.raises(ValueError, match='finite 6x6'):
            ReaimModel(pred, 60.0, cfg, bad)


# Envelope run 810: 3.6 deg/s, grasp point on the -y face, panels near 5 m.
_envelope_run_810 = envelope_run({
    'target.initial_attitude.body_axis_along_hill.hill': [0.34210046617168277, -0.9328669656531406,
                                                          0.1128117699454251],
    'target.initial_rate.omega_body_deg_s': [1.0058933703864195, -3.3115092648535747, -1.1736085803304133],
    'target.grasp_point_body_m': [0.8546060135718934, -1.5, -1.2755615393104325],
    'target.geometry.1.size_m': [2.2554451417316312, 5.06663770387962, 0.05],
    'target.geometry.2.size_m': [1.944823759184012, 5.1048826528782145, 0.05],
    'chaser.initial_position_hill_m': [-43.62854122262408, -4.552581932252293, 31.594800529198352],
    'chaser.thrusters.magnitude_error_sigma': 0.00821296991773613,
    'chaser.thrusters.direction_error_sigma_deg': 0.546034775609678,
    'sensors.relative_position.noise_sigma_m': 0.02158354599937746,
    'sensors.target_attitude.noise_sigma_deg': 2.7726502190419455,
    'simulation.duration_s': 3000.0})


# Run 810's plan: the target estimate at 60.1 s, the diagonal of its published covariance (6x6 body), and
# the chaser's estimated state (hill; m, m/s), as its headless replay with the re-aim check recorded them.
_RUN_810_PLAN = (60.1, [-0.4717359874007342, -0.1630320114719664, -0.8604131739914789, 0.1028342912085663],
                 [-0.03925677992924968, -0.04642177187896765, -0.01642492285923674],
                 np.diag([1.7877928826075353e-05, 1.3971490676471866e-05, 1.0967972648835133e-05,
                          2.7601905364582764e-08, 2.718260449686684e-08, 9.772126570520564e-09]),
                 [-43.61732798898996, -4.544125138890063, 31.791180603171043, 0.00045718925955789605,
                  0.0003246713499280142, 0.006542553162291167])


def test_envelope_run_810_the_reaim_check_refuses_where_its_motions_part():
    """Envelope run 810 with the re-aim check from its filter's covariance (x REAIM_COVARIANCE_SCALE): the estimate
    is within 0.5 sigma of the truth, yet 2288 s later, at the extended window's grasp the check used to pass
    (2348.6 s), its motion is 80 deg from the truth's and no convex grasp lies near it (flown: ESCAPE). Its 3-sigma
    motions part by more than REAIM_MAX_PARTING_RAD at every grasp the other checks pass, and the plan is refused."""
    from flyby_planner.flyby.grasp_search import REFINE_HORIZON_S, refine_grasp
    from flyby_planner.flyby.reaim import REAIM_MAX_PARTING_RAD, ReaimModel
    sc = _scenario(_envelope_run_810)
    cfg = dataclasses.replace(PlannerConfig.from_scenario(sc), reaim_check=True)
    n = cfg.mean_motion_rad_s
    t, q, w, cov, chaser = _RUN_810_PLAN
    estimate = prediction_from_estimate(ErrorStateDynamics(sc.target_inertia), n, t, q, w, 2400.0)
    truth = truth_prediction(sc, 2400.0)
    c_est, c_true = estimate.c_hill_from_body(np.array([2348.56]))[0], truth.c_hill_from_body(np.array([2348.56]))[0]
    assert math.degrees(math.acos((np.trace(c_est.T @ c_true) - 1.0) / 2.0)) > 60.0
    assert refine_grasp(estimate, cfg.x_grasp_body_m, 2348.56, n, t_latest=2348.56 + REFINE_HORIZON_S) is not None
    assert refine_grasp(truth, cfg.x_grasp_body_m, 2348.56, n, t_latest=2348.56 + REFINE_HORIZON_S) is None
    model = ReaimModel(estimate, t, cfg, cov)
    c = [m.c_hill_from_body(np.array([2348.56]))[0] for m in model.motions]
    assert max(math.acos(np.clip((np.trace(c[0].T @ ck) - 1.0) / 2.0, -1.0, 1.0)) for ck in c[1:]) \
        > REAIM_MAX_PARTING_RAD
    pred = prediction_from_estimate(ErrorStateDynamics(sc.target_inertia), n, t, q, w, t + cfg.prediction_span_s(w))
    plan = plan_capture(pred, chaser[:3], chaser[3:], t, cfg, cov)
    assert not plan.ok and 'the re-aimed passage below the margin' in plan.reason
    parted = [c for c in plan.candidates if c.reasons and 'motions part by' in c.reasons[-1]]
    assert parted and all(c.reaim_gap_m == -math.inf for c in parted)
