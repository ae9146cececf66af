"""PlannerCore: plans at the first target estimate at or after the request, from the chaser estimate
carried to that stamp along CW, and publishes the grasp guidance re-aims at."""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import prediction_from_estimate
from flyby_msgs_py import contract as c
from flyby_msgs_py.wire import Event, wire_event
from flyby_planner.flyby.search import plan_capture
from flyby_planner.methods import FlybyMethod, Refusal
from flyby_planner.params import PlannerParams
from flyby_planner.plan_outputs import AimUpdate, PlanMarkers, PlanPublished
from flyby_planner.planner_core import PlannerCore
from flyby_sim.dynamics.orbital import cw_accel
from flyby_sim.scenario import load_scenario
from flyby_testing import envelope_run_323

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'


def _planning_event(t):
    return wire_event(Event(t, 'OK', 'phase_changed', 'ESTIMATION -> PLANNING: converged',
                            {'from': c.PHASE_ESTIMATION, 'to': c.PHASE_PLANNING}, 'flyby_supervisor'))


def test_plan_at_the_first_target_estimate_after_the_request_from_the_coasted_chaser():
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    n = sc.mean_motion_rad_s
    core = PlannerCore(PlannerParams.from_scenario(sc))
    core.on_phase(c.PHASE_PLANNING)  # mission/phase: its request is served in PLANNING
    q0, w0 = sc.q_hill_from_body0, sc.omega_body0_rad_s
    r_c, v_c = np.array((50.0, 0.1, -0.2)), np.array((0.001, 0.0, -0.002))
    assert core.on_chaser_estimate(59.9, r_c, v_c) == []
    assert core.on_target_estimate(59.9, q0, w0) == []
    assert core.on_event(_planning_event(59.95)) == []  # no target estimate at or after the request yet
    assert core.on_target_estimate(60.0, q0, w0) == []  # the chaser estimates up to 60.0 s are not in
    out = core.on_chaser_estimate(60.05, r_c, v_c)
    published = [o for o in out if isinstance(o, PlanPublished)]
    names = [o.name for o in out if isinstance(o, Event)]
    assert len(published) == 1 and names[-1] == 'plan_selected' and 'plan_candidate' in names
    plan = published[0]
    assert plan.t_plan == 60.0
    # The same plan from the chaser state integrated (eq 2) from 59.9 s to the plan time.
    y = solve_ivp(lambda _t, s: np.concatenate((s[3:], cw_accel(s[:3], s[3:], n))), (59.9, 60.0),
                  np.concatenate((r_c, v_c)), rtol=1e-12, atol=1e-12).y[:, -1]
    prediction = prediction_from_estimate(ErrorStateDynamics(sc.target_inertia), n, 60.0, q0, w0,
                                          60.0 + core.params.flyby.prediction_span_s(w0))
    expected = plan_capture(prediction, y[:3], y[3:], 60.0, core.params.flyby).selected
    assert plan.t_f == pytest.approx(expected.t_grasp, abs=1e-6)
    assert plan.x_fi == pytest.approx(expected.x_fi, abs=1e-6)
    assert plan.grasp.x_g == pytest.approx(expected.x_g, abs=1e-9)
    selected = [o for o in out if isinstance(o, Event) and o.name == 'plan_selected'][0]
    assert selected.values['t_grasp_s'] == plan.t_f and selected.values['t_i_s'] == plan.t_i


def test_a_re_aimed_grasp_is_published_again():
    core = PlannerCore(PlannerParams.from_scenario(load_scenario(SCENARIOS / 'paper_flyby.yaml')))
    core.on_phase(c.PHASE_PLANNING)  # mission/phase: its request is served in PLANNING
    refined = wire_event(Event(733.0, 'OK', 'target_refined', 'grasp re-solved', {
        't_grasp_s': 813.004, 'shift_m': 0.002, 'x_g_hill_m': np.array((0.3, 2.0, 0.1)),
        'v_g_hill_mps': np.array((0.0, 0.01, 0.13)), 'x_ft_hill_m': np.array((0.45, 3.0, 0.15)),
        'v_ft_hill_mps': np.array((0.0, 0.015, 0.19)), 'q_hill_from_body': np.array((0.0, 0.0, 0.0, 1.0)),
        'omega_body_rad_s': np.array((0.0, 0.0, 0.087))}, 'flyby_guidance'))
    (aim,) = core.on_event(refined)
    assert isinstance(aim, AimUpdate) and aim.grasp.t == 813.004
    assert aim.x_ft == pytest.approx((0.45, 3.0, 0.15)) and aim.grasp.omega_body[2] == 0.087
    # Guidance keeping its aim (no convex grasp found) publishes nothing new.
    assert core.on_event(refined._replace(values={})) == []


def test_a_plan_in_the_extended_window_publishes_the_grasp_of_its_own_motion():
    """Envelope run 323 (a 6 deg/s tumbler) planned at 60 s from the truth: the plan's grasp lies in the extended
    window, past the prediction PlannerCore made (the grasp window's), and the published grasp attitude and body
    rate are those of the motion the plan carried on to it, the truth's to 1e-6."""
    import copy

    import yaml

    from flyby_planner.flyby.config import truth_prediction
    from flyby_sim.scenario import scenario_from_dict
    d = copy.deepcopy(yaml.safe_load((SCENARIOS / 'paper_flyby.yaml').read_text()))
    envelope_run_323(d)
    sc = scenario_from_dict(d, name='envelope run 323 (test)')
    truth = truth_prediction(sc, 3000.0)
    core = PlannerCore(PlannerParams.from_scenario(sc))
    core.on_phase(c.PHASE_PLANNING)  # mission/phase: its request is served in PLANNING
    s60 = truth.state(60.0)
    r_c = np.array(sc.chaser.initial_position_hill_m)
    core.on_chaser_estimate(60.0, r_c, np.zeros(3))
    core.on_event(_planning_event(60.0))
    out = core.on_target_estimate(60.0, s60.q_hill_from_body, s60.omega_body)
    (plan,) = [o for o in out if isinstance(o, PlanPublished)]
    assert plan.t_f > 60.0 + core.params.flyby.prediction_span_s(s60.omega_body)
    at_grasp = truth.state(plan.t_f)
    assert abs(np.dot(plan.grasp.q_hill_from_body, at_grasp.q_hill_from_body)) == pytest.approx(1.0, abs=1e-9)
    assert plan.grasp.omega_body == pytest.approx(at_grasp.omega_body, abs=1e-8)


def test_the_plan_starts_from_the_published_covariance_of_its_estimate():
    """estimation/target/odom's attitude covariance about hill axes and rate covariance in body axes reach the
    fly-by planner as the 6x6 body covariance of the plan's estimate (target_motion.covariance_from_published), for
    the re-aim check (flyby.reaim.ReaimModel); an estimate published without them plans with no re-aim check (None)."""
    from flyby_estimation.target_motion import covariance_from_published

    class _RecordingFlyby(FlybyMethod):
        def plan(self, core, t, q_hill_from_body, omega_body, why, covariance_body, reason):
            core.received = (t, covariance_body)
            return [], Refusal('recorded', PlanMarkers(0.0, ()), 0.0)

    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    q0, w0 = sc.q_hill_from_body0, sc.omega_body0_rad_s
    attitude_hill = np.diag((1e-6, 2e-6, 3e-6)) + 1e-7
    rate_body = np.diag((4e-8, 5e-8, 6e-8))
    for blocks, expected in (((attitude_hill, rate_body), covariance_from_published(q0, attitude_hill, rate_body)),
                             ((), None)):
        core = PlannerCore(PlannerParams.from_scenario(sc))
        core.on_phase(c.PHASE_PLANNING)  # mission/phase: its request is served in PLANNING
        core.methods['flyby'] = _RecordingFlyby()
        core.on_chaser_estimate(60.05, np.array((50.0, 0.1, -0.2)), np.zeros(3))
        core.on_event(_planning_event(59.95))
        core.on_target_estimate(59.9, q0, w0, 9.0 * attitude_hill, 9.0 * rate_body)  # before the request
        core.on_target_estimate(60.0, q0, w0, *blocks)
        t, covariance_body = core.received
        assert t == 60.0
        if expected is None:
            assert covariance_body is None
        else:
            assert np.array_equal(covariance_body, expected)
