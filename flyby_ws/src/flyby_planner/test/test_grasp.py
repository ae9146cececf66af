"""Tests of flyby_planner.flyby.grasp_search: seed 000 section 4.3 / 4.5 (eq 12-23) and the section 5 grasp values."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import MotionPrediction
from flyby_planner.flyby.grasp_search import (
    GraspCandidate,
    convex_condition_closed_form,
    convex_condition_value,
    convex_grasp_closed_form,
    flyby_initial_point,
    flyby_target_point,
    grasp_candidates,
    grasp_point_closed_form,
    refine_grasp,
)
from flyby_sim.dynamics.orbital import cw_transition_matrix, mean_motion_rad_s, quat_eci_from_hill
from flyby_sim.dynamics.rotation import quat_from_axis_angle, quat_from_matrix, quat_multiply, quat_rotate

# Seed 000 section 5 (DESIGN §6, scenarios/paper_flyby.yaml).
N_PAPER = mean_motion_rad_s(7000e3)
OMEGA_T = math.radians(5.0)
AXIS_HILL = np.ones(3) / math.sqrt(3.0)
X_GRASP_BODY = np.array((1.5, 0.0, 1.5))  # 2.1213 m from the CoM, 45 deg from body z (the spin axis)
X_NORM = float(np.linalg.norm(X_GRASP_BODY))
XI = math.radians(45.0)
PAPER_X_G = np.array((0.2537, 2.0908, 0.2537))
PAPER_V_G = np.array((-0.0926, 0.0, 0.0926))
PERIOD_S = 2.0 * math.pi / OMEGA_T  # 72 s


def _constant_spin_in_hill(axis, rate, x0):
    """Grasp point source t -> (x, v, omega) for a spin constant in (non-rotating) hill axes.

    The section 4.3 idealization: x(t) = R(axis, rate t) x0, v = omega x x (eq 13).
    """
    w = rate * np.asarray(axis, dtype=float)

    def source(t):
        x = quat_rotate(quat_from_axis_angle(axis, rate * t), x0)
        return x, np.cross(w, x), w
    return source


def _x0_on_cone(axis, norm, xi):
    """A point at distance norm and angle xi from the unit axis (an arbitrary phase)."""
    axis = np.asarray(axis, dtype=float)
    u = np.cross(axis, np.eye(3)[int(np.argmin(np.abs(axis)))])
    u /= np.linalg.norm(u)
    return norm * (math.cos(xi) * np.asarray(axis) + math.sin(xi) * u)


def _axisymmetric_prediction(n, t_end):
    """flyby_estimation MotionPrediction of the scenario target: inertially constant spin.

    Axisymmetric inertia spinning about its symmetry (major) axis body z, which points along
    [1, 1, 1]/sqrt(3) in hill at t = 0. The spin is constant in inertial space; in hill axes it
    turns at n about -y.
    """
    z_b = AXIS_HILL
    x_b = np.cross((0.0, 1.0, 0.0), z_b)
    x_b /= np.linalg.norm(x_b)
    c_hill_from_body = np.column_stack((x_b, np.cross(z_b, x_b), z_b))
    q_eci_from_body0 = quat_multiply(quat_eci_from_hill(0.0, n), quat_from_matrix(c_hill_from_body))
    dyn = ErrorStateDynamics(np.diag((100.0, 100.0, 150.0)))
    return MotionPrediction(dyn, n, 0.0, q_eci_from_body0, (0.0, 0.0, OMEGA_T), np.eye(6) * 1e-10, t_end)


def _the_convex(candidates):
    convex = [c for c in candidates if c.convex]
    assert len(convex) == 1, candidates
    return convex[0]


def test_seed000_section5_grasp_values():
    """Seed 000 section 5: x_g = [0.2537, 2.0908, 0.2537] m, v_g = [-0.0926, 0, 0.0926] m/s.

    Kinematics as in section 4.3 (spin constant in hill, the hill rotation neglected over a turn);
    eq 15 evaluated with the section 5 orbit rate (it is identically zero for n = 0).
    """
    source = _constant_spin_in_hill(AXIS_HILL, OMEGA_T, _x0_on_cone(AXIS_HILL, X_NORM, XI))
    candidates = grasp_candidates(source, None, 0.0, 1.1 * PERIOD_S, N_PAPER)
    within_turn = [c for c in candidates if c.t_grasp < PERIOD_S]
    assert len(within_turn) == 2  # eq 14: phi = +pi/2 and -pi/2
    assert sum(c.convex for c in within_turn) == 1
    best = _the_convex(within_turn)
    assert isinstance(best, GraspCandidate)
    np.testing.assert_allclose(best.x_g, PAPER_X_G, atol=1e-4)
    np.testing.assert_allclose(best.v_g, PAPER_V_G, atol=1e-4)
    assert abs(best.v_g[1]) < 1e-6
    assert abs(source(best.t_grasp)[1][1]) < 1e-6
    # The closed form (eq 18a, 19a: xi < 90 deg selects phi = +pi/2) agrees with the search.
    x_cf, v_cf = convex_grasp_closed_form(OMEGA_T * AXIS_HILL, X_NORM, XI)
    np.testing.assert_allclose(x_cf, PAPER_X_G, atol=1e-4)
    np.testing.assert_allclose(v_cf, PAPER_V_G, atol=1e-4)
    np.testing.assert_allclose(best.x_g, x_cf, atol=1e-9)
    np.testing.assert_allclose(best.v_g, v_cf, atol=1e-9)
    # The rejected root is eq 18b / 19b's phi = -pi/2 point.
    other = next(c for c in within_turn if not c.convex)
    x_m, v_m = grasp_point_closed_form(OMEGA_T * AXIS_HILL, X_NORM, XI, -1)
    np.testing.assert_allclose(other.x_g, x_m, atol=1e-9)
    np.testing.assert_allclose(other.v_g, v_m, atol=1e-9)
    assert other.convex_value < 0.0 < best.convex_value
    # Eq 20-23 on this grasp: eq 23 round trip through eq 22.
    x_ft, v_ft = flyby_target_point(best.x_g, best.v_g, 1.0)
    x_fi, v_fi = flyby_initial_point(x_ft, v_ft, 300.0, N_PAPER)
    back = cw_transition_matrix(N_PAPER, 300.0) @ np.concatenate((x_fi, v_fi))
    np.testing.assert_allclose(back, np.concatenate((x_ft, v_ft)), atol=1e-9)


def test_seed000_section5_with_estimator_prediction_n0():
    """The same values from flyby_estimation's MotionPrediction with n = 0 in its kinematics.

    A torque-free axisymmetric body spinning about its symmetry axis: the spin is exactly constant,
    and with n = 0 hill is inertial, which is the section 4.3 assumption.
    """
    prediction = _axisymmetric_prediction(0.0, 1.1 * PERIOD_S)
    candidates = grasp_candidates(prediction, X_GRASP_BODY, 0.0, 1.1 * PERIOD_S, N_PAPER)
    best = _the_convex([c for c in candidates if c.t_grasp < PERIOD_S])
    np.testing.assert_allclose(best.x_g, PAPER_X_G, atol=1e-4)
    np.testing.assert_allclose(best.v_g, PAPER_V_G, atol=1e-4)
    assert abs(prediction.body_point_in_hill(X_GRASP_BODY, best.t_grasp).v_hill[1]) < 1e-6


def test_hill_rotation_effect_on_seed000_grasp():
    """With the hill frame rotating (n of the 7000 km orbit) the grasp state moves: 7 mm, 2.6 mm/s.

    The velocity relative to hill is (omega^H - Omega^H) x x (eq 9 with its sign settled in
    flyby_estimation); the closed forms eq 18-19 then hold exactly with that relative rate and the
    angle xi between it and x_g at t_grasp.
    """
    t_end = 1.1 * PERIOD_S
    prediction = _axisymmetric_prediction(N_PAPER, t_end)
    candidates = grasp_candidates(prediction, X_GRASP_BODY, 0.0, t_end, N_PAPER)
    best = _the_convex([c for c in candidates if c.t_grasp < PERIOD_S])
    assert abs(best.v_g[1]) < 1e-6
    omega_rel = best.omega_hill - np.array((0.0, -N_PAPER, 0.0))
    xi = math.acos(best.x_g @ omega_rel / np.linalg.norm(best.x_g) / np.linalg.norm(omega_rel))
    x_cf, v_cf = convex_grasp_closed_form(omega_rel, np.linalg.norm(best.x_g), xi)
    np.testing.assert_allclose(best.x_g, x_cf, atol=1e-7)
    np.testing.assert_allclose(best.v_g, v_cf, atol=1e-8)
    # The effect of neglecting the hill rotation (measured: 6.9e-3 m and 2.6e-3 m/s, 2 % of |v_g|).
    dx = np.linalg.norm(best.x_g - PAPER_X_G)
    dv = np.linalg.norm(best.v_g - PAPER_V_G)
    assert 1e-3 < dx < 5e-2
    assert 1e-4 < dv < 5e-3


@settings(max_examples=200, deadline=None)
@given(w=st.tuples(*[st.floats(-0.5, 0.5)] * 3).filter(lambda v: np.linalg.norm(v) > 1e-3),
       x_norm=st.floats(0.1, 10.0), xi=st.floats(0.0, math.pi), sign=st.sampled_from((1, -1)),
       n=st.floats(0.0, 2e-3))
def test_seed000_eq16_equals_eq15_at_closed_form(w, x_norm, xi, sign, n):
    """Eq 16 (as printed) is eq 15 evaluated at the eq 18 / 19 grasp state."""
    x_gt, v_gt = grasp_point_closed_form(w, x_norm, xi, sign)
    np.testing.assert_allclose(v_gt, np.cross(w, x_gt), atol=1e-12)  # eq 19 = omega x x_gt
    assert abs(v_gt[1]) < 1e-12  # eq 13
    np.testing.assert_allclose(np.linalg.norm(x_gt), x_norm, rtol=1e-12)
    cos_xi = x_gt @ w / np.linalg.norm(w) / x_norm
    assert cos_xi == pytest.approx(math.cos(xi), abs=1e-9)
    assert convex_condition_closed_form(w, x_norm, xi, sign, n) == pytest.approx(
        convex_condition_value(w, x_gt, v_gt, n), rel=1e-9, abs=1e-15)


def test_seed000_eq16_second_term_misprint():
    """Eq 16 as printed (cos(psi) in its second term) fails for a spin along +y; sin(psi) is right.

    omega along +y, xi = 0: x_g = |x| e_y, v_g = 0, so eq 15 = x_g . [0, -n^2 y, 0] = -n^2 |x|^2,
    while every printed term carries cos(psi) = 0.
    """
    n, x_norm = 1e-3, 2.0
    w = (0.0, 0.1, 0.0)
    x_gt, v_gt = grasp_point_closed_form(w, x_norm, 0.0, 1)
    exact = convex_condition_value(w, x_gt, v_gt, n)
    assert exact == pytest.approx(-n * n * x_norm**2, rel=1e-12)
    psi, xi = math.pi / 2, 0.0
    printed_second_term = -n * n * x_norm**2 * math.cos(xi) * math.sin(psi + xi) * math.cos(psi)
    assert abs(printed_second_term) < 1e-20  # the printed eq 16 would give ~0, not -n^2 |x|^2
    assert convex_condition_closed_form(w, x_norm, xi, 1, n) == pytest.approx(exact, rel=1e-12)


@settings(max_examples=100, deadline=None)
@given(axis=st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(
           lambda v: np.linalg.norm(v) > 0.1 and abs(v[1]) / np.linalg.norm(v) < 0.98),
       rate_deg_s=st.floats(1.0, 18.0), xi_deg=st.floats(5.0, 175.0).filter(lambda d: abs(d - 90) > 2))
def test_search_matches_closed_form_for_constant_spin(axis, rate_deg_s, xi_deg):
    """For any constant spin (away from +-y and xi = 90 deg) the search's convex root is eq 18-19's."""
    a = np.asarray(axis) / np.linalg.norm(axis)
    rate = math.radians(rate_deg_s)
    xi = math.radians(xi_deg)
    source = _constant_spin_in_hill(a, rate, _x0_on_cone(a, 2.0, xi))
    period = 2.0 * math.pi / rate
    candidates = grasp_candidates(source, None, 0.0, period, N_PAPER)
    assert 1 <= len(candidates) <= 3
    x_cf, v_cf = convex_grasp_closed_form(rate * a, 2.0, xi)
    matching = [c for c in candidates if np.linalg.norm(c.x_g - x_cf) < 1e-8]
    assert matching
    for c in candidates:
        assert abs(c.v_g[1]) < 1e-9
    for c in matching:
        np.testing.assert_allclose(c.v_g, v_cf, atol=1e-8)
    # Where eq 16's first term outweighs the n^2 terms' bound, eq 17 decides alone: its pick is the
    # only convex root. (Otherwise eq 15 in full may accept both roots, or neither.)
    cos_psi = math.sqrt(max(0.0, 1.0 - a[1] ** 2))
    if 2.0 * rate * math.sin(xi) * cos_psi > 1.25 * N_PAPER * (abs(a[1]) + 3.0 * cos_psi):
        assert all(c.convex for c in matching)
        assert all(not c.convex for c in candidates if not any(c is m for m in matching))


def test_flyby_target_point_is_radial_offset():
    """Eq 20-21: X_Ft is delta r farther from the CoM along x_g, V_Ft scaled by the same factor."""
    x_g, v_g = PAPER_X_G, PAPER_V_G
    x_ft, v_ft = flyby_target_point(x_g, v_g, 1.0)
    assert np.linalg.norm(x_ft) == pytest.approx(np.linalg.norm(x_g) + 1.0, rel=1e-12)
    np.testing.assert_allclose(np.cross(x_ft, x_g), 0.0, atol=1e-12)
    k = 1.0 + 1.0 / np.linalg.norm(x_g)
    np.testing.assert_allclose(v_ft, k * v_g, rtol=1e-12)
    with pytest.raises(ValueError, match='x_g'):
        flyby_target_point((0.0, 0.0, 0.0), v_g, 1.0)
    with pytest.raises(ValueError, match='offset_m'):
        flyby_target_point(x_g, v_g, -5.0)


@settings(max_examples=100, deadline=None)
@given(state=st.tuples(*[st.floats(-10.0, 10.0)] * 3, *[st.floats(-1.0, 1.0)] * 3),
       duration=st.floats(0.0, 3000.0))
def test_seed000_eq23_round_trip(state, duration):
    """Eq 23: propagating X_Fi, V_Fi with eq 22 over the duration returns X_Ft, V_Ft."""
    x_ft, v_ft = np.array(state[:3]), np.array(state[3:])
    x_fi, v_fi = flyby_initial_point(x_ft, v_ft, duration, N_PAPER)
    back = cw_transition_matrix(N_PAPER, duration) @ np.concatenate((x_fi, v_fi))
    np.testing.assert_allclose(back, np.concatenate((x_ft, v_ft)), atol=1e-9)


def test_input_errors_name_the_input():
    source = _constant_spin_in_hill(AXIS_HILL, OMEGA_T, _x0_on_cone(AXIS_HILL, X_NORM, XI))
    with pytest.raises(ValueError, match='t_start'):
        grasp_candidates(source, None, 10.0, 5.0, N_PAPER)
    with pytest.raises(ValueError, match='n must'):
        grasp_candidates(source, None, 0.0, 5.0, -1.0)
    with pytest.raises(TypeError, match='prediction_or_callable'):
        grasp_candidates(42, None, 0.0, 5.0, N_PAPER)
    with pytest.raises(ValueError, match='duration_s'):
        flyby_initial_point(PAPER_X_G, PAPER_V_G, -1.0, N_PAPER)
    with pytest.raises(ValueError, match='n must'):
        flyby_initial_point(PAPER_X_G, PAPER_V_G, 10.0, 0.0)
    with pytest.raises(ValueError, match='eq 17 vanishes'):
        convex_grasp_closed_form(OMEGA_T * AXIS_HILL, X_NORM, math.pi / 2)


def test_spin_along_y_gives_no_candidates():
    """Eq 14 case (a): a spin along hill y keeps v_y = 0, so nothing to bracket (section 4.4 (b))."""
    axis = np.array((0.0, 1.0, 0.0))
    source = _constant_spin_in_hill(axis, OMEGA_T, _x0_on_cone(axis, X_NORM, XI))
    assert grasp_candidates(source, None, 0.0, PERIOD_S, N_PAPER) == []


def test_refine_grasp_prefers_the_convex_root_and_else_follows_the_planned_one():
    """refine_grasp: a convex root within 0.4 turn wins; without one, the root within 0.1 turn of the
    planned grasp time is followed even though eq 15 calls it not convex (envelope run 515)."""
    prediction = _axisymmetric_prediction(N_PAPER, 400.0)
    roots = grasp_candidates(prediction, X_GRASP_BODY, 50.0, 300.0, N_PAPER)
    convex = next(c for c in roots if c.convex)
    other = next(c for c in roots if not c.convex)
    turn_s = 2.0 * math.pi / float(np.linalg.norm(other.omega_hill - np.array((0.0, -N_PAPER, 0.0))))
    # Roots of eq 13 alternate half a turn apart: around a non-convex root the window holds no convex one.
    assert not any(c.convex for c in roots if abs(c.t_grasp - other.t_grasp) < 0.4 * turn_s)
    followed = refine_grasp(prediction, X_GRASP_BODY, other.t_grasp + 0.05 * turn_s, N_PAPER)
    assert followed is not None and followed.t_grasp == pytest.approx(other.t_grasp, abs=1e-6)
    assert not followed.convex
    kept = refine_grasp(prediction, X_GRASP_BODY, convex.t_grasp + 0.3 * turn_s, N_PAPER)
    assert kept.convex and kept.t_grasp == pytest.approx(convex.t_grasp, abs=1e-6)
    # A non-convex root 0.2 turn from the planned time is another root, not the planned one.
    assert refine_grasp(prediction, X_GRASP_BODY, other.t_grasp + 0.2 * turn_s, N_PAPER,
                        t_latest=other.t_grasp + 0.25 * turn_s) is None
