"""Tests of flyby_mission.supervisor: the phase machine's transitions and reasons, the capture decision
from estimates carried to the grasp time, and the core the node and the headless driver run."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_mission.abort_escape import AvoidanceBurn
from flyby_mission.capture_decision import capture_decision, decide_capture
from flyby_mission.supervisor import (
    PhaseMachine,
    SupervisorCore,
    SupervisorParams,
    Transition,
)
from flyby_msgs_py import contract as c
from flyby_msgs_py.wire import Event, wire_event
from flyby_planner.flyby.grasp_search import capture_target_body, flyby_target_from_attitude
from flyby_planner.flyby.keepout import any_attitude_region, has_spin_axis, swept_region
from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.orbital import cw_accel, cw_coast, q_eci_from_body, q_hill_from_body
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'

# paper_flyby's record with the thresholds these tests are written for.
CONFIG = dataclasses.replace(SupervisorParams.from_scenario(load_scenario(SCENARIOS / 'paper_flyby.yaml')),
                             min_observation_s=60.0, restriction_sphere_radius_m=15.0, reach_m=1.5,
                             position_tolerance_m=0.10, velocity_tolerance_mps=0.01, capture_hold_s=10.0,
                             escape_observation_s=5829.0, watchdog_s=5.0, post_capture=False, start_attached=False,
                             transport=False)
FAR = np.array((40.0, 0.0, -30.0))
X_G = np.array((0.36, 2.09, 0.0))
X_FT, V_FT = X_G * (1.0 + 1.0 / np.linalg.norm(X_G)), np.array((0.0, 0.0, 0.19))  # offset 1 m (eq 20)


def _alive(core, t):
    """Both watched nodes report progress up to t (the watchdog stays quiet)."""
    for node in core.machine.watched_nodes:
        core.on_progress(node, t)


def _flyby(m):
    """Drive a machine through ESTIMATION ... FLYBY; returns the transitions."""
    out = []
    for k in range(1, 702):
        t = 0.1 * k
        out += m.clock(t) + m.target_estimate(t)
        if k == 180:
            out += m.event(t, 'OK', 'target_converged', 'flyby_estimator', {})
    out += m.event(70.3, 'OK', 'plan_selected', 'flyby_planner', {'t_i_s': '513.0', 't_grasp_s': '813.0'})
    out += m.chaser_estimate(512.9, FAR) + m.chaser_estimate(513.0, FAR)
    out += m.event(733.0, 'OK', 'target_refined', 'flyby_guidance', {'t_grasp_s': '813.004'})
    out += m.event(733.0, 'OK', 'thrusting_ended', 'flyby_guidance', {})
    return out


def test_nominal_sequence_with_reasons():
    m = PhaseMachine(CONFIG)
    out = _flyby(m)
    assert [(tr.phase_from, tr.phase_to) for tr in out] == [
        (c.PHASE_ESTIMATION, c.PHASE_PLANNING), (c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH),
        (c.PHASE_TERMINAL_APPROACH, c.PHASE_TRAJECTORY_ADJUST), (c.PHASE_TRAJECTORY_ADJUST, c.PHASE_FLYBY)]
    assert out[0].t == pytest.approx(60.1) and '60.0 s of attitude data' in out[0].reason
    assert out[2].t == 513.0 and 'injection' in out[2].reason
    # The grasp time is the refined one; the decision waits for it.
    assert not m.wants_decision(813.0) and m.wants_decision(813.1)
    decided = m.decide(813.1, capture_decision(X_FT + (0.03, 0.0, 0.0), V_FT, X_G, X_FT, V_FT, CONFIG))
    assert decided[0].phase_to == c.PHASE_CAPTURE and decided[0].values['t_grasp_s'] == 813.004
    assert m.clock(823.0) == [] and m.clock(823.2)[0].phase_to == c.PHASE_COMPLETE


def test_planning_waits_for_both_convergence_and_observation():
    m = PhaseMachine(CONFIG)
    m.target_estimate(0.1)
    assert m.event(18.0, 'OK', 'target_converged', 'flyby_estimator', {}) == []
    assert m.target_estimate(59.0) == []
    assert m.target_estimate(60.1)[0].phase_to == c.PHASE_PLANNING


def test_refused_plan_ends_in_no_safe_plan_with_the_planners_reason():
    """DESIGN §10: a refused plan is NO_SAFE_PLAN, not ABORTED; the mission is over, nothing was flown."""
    m = PhaseMachine(CONFIG)
    m.phase = c.PHASE_PLANNING
    out = m.event(60.3, 'ERROR', 'plan_refused', 'flyby_planner', {'reason': 'condition (a): too fast'})
    assert out[0].phase_to == c.PHASE_COMPLETE and out[0].reason == 'no safe plan: condition (a): too fast'
    assert out[0].values == {'no_safe_plan': True}


def test_escape_then_complete_after_the_observation():
    m = PhaseMachine(CONFIG)
    _flyby(m)
    out = m.decide(813.1, capture_decision(X_FT + (0.5, 0.0, 0.0), V_FT, X_G, X_FT, V_FT, CONFIG))
    assert out[0].phase_to == c.PHASE_ESCAPE and out[0].reason.startswith('escape: position error 0.500 m')
    assert m.clock(813.1 + 5828.0) == []
    assert m.clock(813.1 + 5829.0)[0].phase_to == c.PHASE_COMPLETE


def test_the_watchdog_detects_a_silent_node_answers_it_from_the_table_and_sees_it_back():
    """A watched node silent for watchdog_s in an active phase: node_lost, the table's retreat; the planner, once
    it has reported, then answered as in standby (hold); a node that never reported (left out of the graph) is not lost;
    each back: fault_recovered."""
    core = SupervisorCore(CONFIG)
    core.machine.phase = c.PHASE_TERMINAL_APPROACH
    _alive(core, 100.0)
    core.on_progress('flyby_planner', 100.0)
    core.on_progress('flyby_estimator', 104.0)
    out = core.on_clock(105.5)
    names = [(o.name, o.values.get('component')) for o in out if isinstance(o, Event)]
    assert ('fault_detected', 'flyby_guidance') in names and ('fault_detected', 'flyby_planner') in names
    assert ('fault_detected', 'flyby_cam_monitor') not in names
    responses = {o.values['component']: o.values['response'] for o in out if getattr(o, 'name', '') == 'fault_response'}
    assert responses == {'flyby_guidance': 'retreat', 'flyby_planner': 'hold'}  # the planner's once retreating
    retreat = [o for o in out if isinstance(o, Transition) and o.phase_to == c.PHASE_RETREAT]
    assert retreat and retreat[0].reason == 'retreat: watchdog: flyby_guidance silent for 5.5 s'
    assert core.on_clock(106.0) == []  # detected once
    core.on_progress('flyby_guidance', 106.1)
    back = core.on_clock(106.2)
    assert [(o.name, o.values['component']) for o in back] == [('fault_recovered', 'flyby_guidance')]

    m = PhaseMachine(CONFIG)
    out = m.event(50.0, 'ERROR', 'filter_diverged', 'flyby_estimator', {})
    assert out[0].phase_to == c.PHASE_ABORTED and 'fault reported by flyby_estimator' in out[0].reason
    # An ERROR from a node that is not watched (the simulator's late maneuver, say) is not a fault here.
    m = PhaseMachine(CONFIG)
    assert m.event(50.0, 'ERROR', 'maneuver_rejected', 'flyby_sim', {}) == []


def test_capture_decision_against_each_tolerance():
    ok = capture_decision(X_FT, V_FT, X_G, X_FT, V_FT, CONFIG)
    assert ok.capture and ok.values['grasp_distance_m'] == pytest.approx(1.0)
    assert not capture_decision(X_FT + (0.11, 0, 0), V_FT, X_G, X_FT, V_FT, CONFIG).capture
    slow = capture_decision(X_FT, V_FT + (0.0, 0.011, 0.0), X_G, X_FT, V_FT, CONFIG)
    assert not slow.capture and 'velocity error 11.0 mm/s > 10 mm/s' in slow.reason
    far_grasp = capture_decision(X_FT, V_FT, X_G * 0.0 - X_FT, X_FT, V_FT, CONFIG)
    assert not far_grasp.capture and 'reach' in far_grasp.reason


def test_decide_capture_carries_both_estimates_to_the_grasp_time():
    """The chaser estimate is coasted along CW and the target estimate propagated torque-free to t_g;
    checked against numerical integration of eq 2 and an independent attitude integration."""
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    n = sc.mean_motion_rad_s
    inertia = sc.target_inertia
    t_c, r_c, v_c = 812.95, np.array((1.2, 0.3, 2.4)), np.array((0.01, -0.002, 0.12))
    t_t, t_g = 812.9, 813.0041
    truth = AttitudePropagator(q_eci_from_body(0.0, n, sc.q_hill_from_body0), sc.omega_body0_rad_s, inertia)
    q_t, w_t = truth.state_at(t_t)
    decision = decide_capture((t_c, r_c, v_c), (t_t, q_hill_from_body(t_t, n, q_t), w_t), t_g,
                              ErrorStateDynamics(inertia), n, np.array(sc.target.grasp_point_body_m),
                              capture_target_body('flyby', sc.target.grasp_point_body_m, sc.planner.offset_m, ()),
                              CONFIG)
    coast = solve_ivp(lambda _t, y: np.concatenate((y[3:], cw_accel(y[:3], y[3:], n))), (t_c, t_g),
                      np.concatenate((r_c, v_c)), rtol=1e-12, atol=1e-12).y[:, -1]
    q_g, w_g = truth.state_at(t_g)
    x_ft, v_ft = flyby_target_from_attitude(q_hill_from_body(t_g, n, q_g), w_g, sc.target.grasp_point_body_m,
                                            sc.planner.offset_m, n)
    assert decision.values['position_error_m'] == pytest.approx(np.linalg.norm(coast[:3] - x_ft), abs=1e-9)
    assert decision.values['velocity_error_mps'] == pytest.approx(np.linalg.norm(coast[3:] - v_ft), abs=1e-9)


def _core_in_flyby(scenario):
    """A SupervisorCore driven to FLYBY with a plan grasping at 813.0 s (watched nodes alive)."""
    core = SupervisorCore(SupervisorParams.from_scenario(scenario))
    start = core.start()
    assert isinstance(start[0], Transition) and start[0].phase_to == c.PHASE_ESTIMATION
    for node in core.machine.watched_nodes:
        core.on_progress(node, 800.0)
    core.machine.phase, core.machine.t_grasp = c.PHASE_FLYBY, 813.0
    return core


def test_core_decides_at_the_first_chaser_estimate_after_the_grasp_with_the_target_of_its_stamp():
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    n = sc.mean_motion_rad_s
    core = _core_in_flyby(sc)
    truth = AttitudePropagator(q_eci_from_body(0.0, n, sc.q_hill_from_body0), sc.omega_body0_rad_s, sc.target_inertia)
    q, w = truth.state_at(813.1)
    x_ft, v_ft = flyby_target_from_attitude(q_hill_from_body(813.1, n, q), w, sc.target.grasp_point_body_m,
                                            sc.planner.offset_m, n)
    assert core.on_chaser_estimate(812.9, x_ft, v_ft) == []  # before t_g: no decision
    assert core.on_chaser_estimate(813.1, x_ft, v_ft) == []  # waits for the target estimate of its stamp
    out = core.on_target_estimate(813.1, q_hill_from_body(813.1, n, q), w)
    assert [o.phase_to for o in out if isinstance(o, Transition)] == [c.PHASE_CAPTURE]
    changed = [o for o in out if isinstance(o, Event)]
    assert changed[0].name == 'phase_changed' and changed[0].source == 'flyby_supervisor'
    assert changed[0].values['t_grasp_s'] == 813.0


def test_core_ignores_its_own_events_and_reads_values_as_text():
    core = SupervisorCore(SupervisorParams.from_scenario(load_scenario(SCENARIOS / 'paper_flyby.yaml')))
    core.machine.phase = c.PHASE_PLANNING
    own = wire_event(Event(70.0, 'OK', 'plan_selected', '', {'t_i_s': 513.0, 't_grasp_s': 813.0}, 'flyby_supervisor'))
    assert core.on_event(own) == []
    out = core.on_event(own._replace(source='flyby_planner'))
    assert out[0].phase_to == c.PHASE_TERMINAL_APPROACH and core.machine.t_i == 513.0


def test_core_abort_outside_the_sphere_fires_an_avoidance_burn_only_if_the_coast_is_unsafe():
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    q0 = sc.q_hill_from_body0
    # Far and drifting along V-bar: passively safe, no burn.
    core = SupervisorCore(SupervisorParams.from_scenario(sc))
    core.machine.phase, core.machine.t_i = c.PHASE_TERMINAL_APPROACH, 500.0
    core.on_target_estimate(100.0, q0, sc.omega_body0_rad_s)
    core.on_chaser_estimate(100.0, np.array((50.0, 0.0, 0.0)), np.zeros(3))
    _alive(core, 100.0)
    core.on_clock(100.0)
    aborted, out = core.abort('test')
    assert aborted and not any(isinstance(o, AvoidanceBurn) for o in out)
    assert [o.name for o in out if isinstance(o, Event)] == ['phase_changed', 'no_avoidance_burn']
    # 20 m out and heading straight at the target: a burn, stamped a command lead ahead.
    core = SupervisorCore(SupervisorParams.from_scenario(sc))
    core.machine.phase, core.machine.t_i = c.PHASE_TERMINAL_APPROACH, 500.0
    core.on_target_estimate(100.0, q0, sc.omega_body0_rad_s)
    core.on_chaser_estimate(100.0, np.array((20.0, 0.0, 0.0)), np.array((-0.2, 0.0, 0.0)))
    _alive(core, 100.0)
    core.on_clock(100.0)
    aborted, out = core.abort('test')
    burns = [o for o in out if isinstance(o, AvoidanceBurn)]
    assert aborted and len(burns) == 1 and burns[0].t == 100.0 + sc.guidance.command_lead_s
    assert burns[0].dv_hill[0] > 0.0  # it turns the chaser away from the target


def test_an_abort_on_a_restarted_target_estimate_is_published_with_its_avoidance_burn():
    """fd_s8 run 59: the target filter restarted after 20 outliers in a row (its omega zero: no spin axis), guidance
    raised on it and the supervisor, aborting on guidance's node_error, raised in the avoidance burn's keep-out
    region: its core fenced off, the ABORTED never published, the mission idled in TRAJECTORY_ADJUST to its time
    limit. The region is now swept about the last estimate that has a spin axis, or with none the region of every
    attitude; the abort and its burn are published."""
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    q0 = sc.q_hill_from_body0
    for spinning in (True, False):
        core = SupervisorCore(SupervisorParams.from_scenario(sc))
        core.machine.phase, core.machine.t_i = c.PHASE_TRAJECTORY_ADJUST, 90.0
        if spinning:
            core.on_target_estimate(99.9, q0, sc.omega_body0_rad_s)
        core.on_target_estimate(100.0, q0, np.zeros(3))  # the restarted filter
        core.on_chaser_estimate(100.0, np.array((20.0, 0.0, 0.0)), np.array((-0.2, 0.0, 0.0)))
        _alive(core, 100.0)
        core.on_clock(100.0)
        out = core.on_event(Event(100.0, 'ERROR', 'node_error', 'flyby_guidance: ValueError: no spin axis',
                                  {'node': 'flyby_guidance'}, 'flyby_guidance'))
        assert core.phase == c.PHASE_ABORTED
        assert [o.phase_to for o in out if hasattr(o, 'phase_to')] == [c.PHASE_ABORTED]
        burns = [o for o in out if isinstance(o, AvoidanceBurn)]
        assert len(burns) == 1 and burns[0].dv_hill[0] > 0.0
        (said,) = [o.message for o in out if isinstance(o, Event) and o.name == 'avoidance_burn']
        assert ('spin axis of t = 99.90 s' in said) == spinning and ('every attitude' in said) == (not spinning)


def test_the_region_of_every_attitude_holds_every_swept_region():
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    anywhere = any_attitude_region(sc.boxes)
    assert not has_spin_axis(sc.target_inertia, np.zeros(3)) and not has_spin_axis(sc.target_inertia, [np.nan] * 3)
    rng = np.random.default_rng(7)
    for _ in range(20):
        q = rng.normal(size=4)
        region = swept_region(sc.boxes, sc.target_inertia, [q / np.linalg.norm(q)], [rng.normal(size=3)])
        assert region.bounding_radius_m <= anywhere.bounding_radius_m + 1e-12
        assert np.all(region.radius_m <= anywhere.radius_m + 1e-12)
        assert np.all(region.axial_max_m <= anywhere.axial_max_m + 1e-12)
        assert np.all(region.axial_min_m >= anywhere.axial_min_m - 1e-12)


def test_core_decides_against_the_offset_of_the_plan_selected():
    """A plan at delta r = 1.3 m: the decision compares the chaser with that plan's X_Ft (eq 20), not the
    scenario's preferred 1 m, and reports the grasp point 1.3 m away."""
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    n = sc.mean_motion_rad_s
    core = SupervisorCore(SupervisorParams.from_scenario(sc))
    core.machine.phase = c.PHASE_PLANNING
    core.on_event(wire_event(Event(70.0, 'OK', 'plan_selected', '', {'t_i_s': 513.0, 't_grasp_s': 813.0,
                                                                     'offset_m': 1.3, 'flyby_duration_s': 300.0},
                                   'flyby_planner')))
    assert core.machine.offset_m == 1.3
    for node in core.machine.watched_nodes:
        core.on_progress(node, 800.0)
    core.machine.phase = c.PHASE_FLYBY
    truth = AttitudePropagator(q_eci_from_body(0.0, n, sc.q_hill_from_body0), sc.omega_body0_rad_s, sc.target_inertia)
    q, w = truth.state_at(813.0)
    x_ft, v_ft = flyby_target_from_attitude(q_hill_from_body(813.0, n, q), w, sc.target.grasp_point_body_m, 1.3, n)
    core.on_chaser_estimate(813.0, x_ft, v_ft)
    out = core.on_target_estimate(813.0, q_hill_from_body(813.0, n, q), w)
    (decided,) = [o for o in out if isinstance(o, Transition)]
    assert decided.phase_to == c.PHASE_CAPTURE
    assert decided.values['position_error_m'] < 1e-9 and decided.values['grasp_distance_m'] == pytest.approx(1.3)


def test_core_decides_with_the_target_estimate_of_the_grasp_time_not_a_later_one():
    """A 15 deg/s spin: the grasp point accelerates by |omega|^2 |x| (0.15 m/s^2), so the target estimate
    0.1 s after t_g places V_Ft 15 mm/s off. The decision carries the last estimate up to t_g forward to
    t_g: a chaser exactly at the true X_Ft, V_Ft captures with no error."""
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    n = sc.mean_motion_rad_s
    core = _core_in_flyby(sc)
    omega_body = np.array((0.0, 0.0, np.radians(15.0)))
    truth = AttitudePropagator(q_eci_from_body(0.0, n, sc.q_hill_from_body0), omega_body, sc.target_inertia)
    states = {t: truth.state_at(t) for t in (812.95, 813.0, 813.1)}
    q, w = states[813.0]
    x_ft, v_ft = flyby_target_from_attitude(q_hill_from_body(813.0, n, q), w, sc.target.grasp_point_body_m,
                                            sc.planner.offset_m, n)
    q0, w0 = states[812.95]
    assert core.on_target_estimate(812.95, q_hill_from_body(812.95, n, q0), w0) == []
    at = cw_coast(x_ft, v_ft, 0.1, n)
    assert core.on_chaser_estimate(813.1, at[:3], at[3:]) == []
    q1, w1 = states[813.1]
    out = core.on_target_estimate(813.1, q_hill_from_body(813.1, n, q1), w1)
    (decided,) = [o for o in out if isinstance(o, Transition)]
    assert decided.phase_to == c.PHASE_CAPTURE
    assert decided.values['velocity_error_mps'] < 1e-6 and decided.values['position_error_m'] < 1e-6


def _captured(post_capture=True):
    """A machine (post_capture or not) that has just decided to capture at 813.1 s."""
    m = PhaseMachine(dataclasses.replace(CONFIG, post_capture=post_capture))
    _flyby(m)
    m.decide(813.1, capture_decision(X_FT, V_FT, X_G, X_FT, V_FT, CONFIG))
    return m


def test_post_capture_phases_follow_the_arm_the_damping_and_the_estimate():
    """DESIGN §10: CAPTURE -> GRASP -> DAMPING -> MASS_ESTIMATION -> COMPLETE on the simulator's, guidance's and the
    estimator's events, each transition with its reason; no capture_hold_s timer."""
    m = _captured()
    assert m.clock(823.2) == []  # no COMPLETE after capture_hold_s
    steps = [(813.1, 'captured', 'flyby_sim', c.PHASE_GRASP), (820.05, 'grasp_damped', 'flyby_sim', c.PHASE_DAMPING),
             (1010.7, 'damping_complete', 'flyby_guidance', c.PHASE_MASS_ESTIMATION),
             (1037.7, 'mass_properties_estimated', 'flyby_estimator', c.PHASE_COMPLETE)]
    for t, name, source, phase in steps:
        before = m.phase
        assert m.event(t, 'OK', name, source, {'reason': f'{name} at {t}', 'x': '1.5'}) == [
            Transition(t, before, phase, f'{name} at {t}', {'x': '1.5'})]
        assert m.phase == phase and m.t_entered == t
    # out of order: nothing
    assert m.event(1040.0, 'OK', 'grasp_damped', 'flyby_sim', {}) == []


def test_a_grasp_that_lets_go_escapes_and_is_not_a_capture():
    from flyby_mission.summary import outcome_of
    m = _captured()
    m.event(813.1, 'OK', 'captured', 'flyby_sim', {})
    out = m.event(813.1, 'WARN', 'grasp_released', 'flyby_sim', {'reason': 'the arm lets go: |F| 77 N > 50 N'})
    assert [(tr.phase_from, tr.phase_to) for tr in out] == [(c.PHASE_GRASP, c.PHASE_ESCAPE)]
    assert 'lets go' in out[0].reason
    phases = [c.PHASE_FLYBY, c.PHASE_CAPTURE, c.PHASE_GRASP, c.PHASE_ESCAPE, c.PHASE_COMPLETE]
    assert outcome_of('phase COMPLETE', phases) == c.OUTCOME_ESCAPE
    assert outcome_of('phase COMPLETE', [c.PHASE_FLYBY, c.PHASE_CAPTURE, c.PHASE_COMPLETE]) == c.OUTCOME_CAPTURE


def test_without_post_capture_the_events_change_nothing():
    m = _captured(post_capture=False)
    assert m.event(813.1, 'OK', 'captured', 'flyby_sim', {}) == [] and m.phase == c.PHASE_CAPTURE
    assert m.clock(823.2)[0].phase_to == c.PHASE_COMPLETE
