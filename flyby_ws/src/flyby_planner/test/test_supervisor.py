"""Tests of flyby_planner.supervisor: the phase machine's transitions and reasons, the capture decision."""

import numpy as np
import pytest

from flyby_msgs_py import contract as c
from flyby_planner.supervisor import PhaseMachine, SupervisorConfig, capture_decision

CONFIG = SupervisorConfig(min_observation_s=60.0, restriction_sphere_radius_m=15.0, reach_m=1.5,
                          position_tolerance_m=0.10, velocity_tolerance_mps=0.01, capture_hold_s=10.0,
                          escape_observation_s=5829.0, watchdog_s=5.0)
FAR = np.array((40.0, 0.0, -30.0))
X_G = np.array((0.36, 2.09, 0.0))
X_FT, V_FT = X_G * (1.0 + 1.0 / np.linalg.norm(X_G)), np.array((0.0, 0.0, 0.19))  # offset 1 m (eq 20)


def _alive(m, t):
    """Both watched nodes report progress up to t (the watchdog stays quiet)."""
    for node in CONFIG.watched_nodes:
        m.node_progress(node, t)


def _flyby(m):
    """Drive a machine through ESTIMATION ... FLYBY; returns the transitions."""
    out = []
    for k in range(1, 702):
        t = 0.1 * k
        _alive(m, t)
        out += m.clock(t) + m.target_estimate(t)
        if k == 180:
            out += m.event(t, 'OK', 'target_converged', 'flyby_estimator', {})
    out += m.event(70.3, 'OK', 'plan_selected', 'flyby_planner', {'t_i_s': '513.0', 't_grasp_s': '813.0'})
    _alive(m, 513.0)
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


def test_refused_plan_aborts_with_the_planners_reason():
    m = PhaseMachine(CONFIG)
    m.phase = c.PHASE_PLANNING
    out = m.event(60.3, 'ERROR', 'plan_refused', 'flyby_planner', {'reason': 'condition (a): too fast'})
    assert out[0].phase_to == c.PHASE_ABORTED and 'condition (a)' in out[0].reason


def test_escape_then_complete_after_the_observation():
    m = PhaseMachine(CONFIG)
    _flyby(m)
    out = m.decide(813.1, capture_decision(X_FT + (0.5, 0.0, 0.0), V_FT, X_G, X_FT, V_FT, CONFIG))
    assert out[0].phase_to == c.PHASE_ESCAPE and out[0].reason.startswith('escape: position error 0.500 m')
    assert m.clock(813.1 + 5828.0) == []
    assert m.clock(813.1 + 5829.0)[0].phase_to == c.PHASE_COMPLETE


def test_watchdog_and_faults_abort_only_in_active_phases():
    m = PhaseMachine(CONFIG)
    _alive(m, 100.0)
    m.node_progress('flyby_estimator', 104.0)
    out = m.clock(105.5)
    assert out[0].phase_to == c.PHASE_ABORTED and out[0].reason == 'watchdog: flyby_guidance silent for 5.5 s'
    assert m.clock(200.0) == [] and m.abort(200.0, 'again') == []

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
