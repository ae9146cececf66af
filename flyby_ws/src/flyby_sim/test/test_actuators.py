"""actuators.py: thruster layout authority, wrench allocation (exact or saturated), execution errors and fuel."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from flyby_sim.dynamics.actuators import (
    ThrusterLayout,
    allocate_force_with_minimum_impulse,
    allocate_max_force,
    allocate_wrench,
    default_thruster_layout,
    draw_thruster_errors,
    fire,
    is_positively_spanning,
    plan_burn,
)
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2
from flyby_sim.dynamics.propulsion import delta_v_for_fuel_mps

LAYOUT = default_thruster_layout()
B = LAYOUT.wrench_matrix
LEVER_M = float(np.mean(np.linalg.norm(B[3:], axis=0)))
WEIGHT = np.concatenate((np.ones(3), np.full(3, 1.0 / LEVER_M)))  # allocate_wrench's residual weights

thrust_vectors = st.lists(st.floats(0.0, 10.0), min_size=12, max_size=12).map(np.array)


def test_default_layout_is_full_rank_and_positively_spanning():
    assert B.shape == (6, 12)
    assert np.linalg.matrix_rank(B) == 6
    assert is_positively_spanning(B)
    # Every wrench direction has non-negative thrusts: the unit wrenches and their negatives.
    for w in np.vstack((np.eye(6), -np.eye(6))):
        assert not allocate_wrench(LAYOUT, w[:3], w[3:]).saturated
    # Each thruster is needed: without any one of them some wrench direction is lost.
    for i in range(12):
        assert not is_positively_spanning(np.delete(B, i, axis=1))
    assert np.all(np.linalg.norm(LAYOUT.positions_body_m, axis=1) < 0.5)  # inside the 0.5 m envelope


def test_positive_spanning_is_more_than_rank():
    """Six thrusters pushing along +x, +y, +z from two points: rank 6, yet no thrust pushes along -x."""
    positions = [[0.0, 0.3, 0.0], [0.0, -0.3, 0.3], [0.3, 0.0, -0.3], [0.0, 0.0, 0.3], [0.3, 0.0, 0.0],
                 [0.0, 0.3, 0.3]]
    directions = [[1, 0, 0], [1, 0, 0], [0, 1, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1]]
    b = ThrusterLayout(positions, directions, 1.0, 200.0, 0.0).wrench_matrix
    assert np.linalg.matrix_rank(b) == 6
    assert not is_positively_spanning(b)


@settings(max_examples=60, deadline=None)
@given(thrust_vectors)
def test_allocation_reproduces_every_achievable_wrench_to_1e_9(thrusts_drawn):
    """w = B f for f within bounds: the allocation delivers w to 1e-9 (N, N m) with no more total thrust."""
    w = B @ thrusts_drawn
    allocation = allocate_wrench(LAYOUT, w[:3], w[3:])
    assert not allocation.saturated
    assert np.max(np.abs(allocation.wrench_delivered_body - w)) < 1e-9
    assert np.array_equal(allocation.wrench_undelivered_body, w - allocation.wrench_delivered_body)
    assert np.all(allocation.thrusts_n >= 0.0) and np.all(allocation.thrusts_n <= 10.0)
    assert allocation.total_thrust_n <= thrusts_drawn.sum() + 1e-9  # least total thrust (the LP's objective)


@settings(max_examples=30, deadline=None)
@given(thrust_vectors, st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)).filter(
    lambda u: np.linalg.norm(u) > 0.1))
def test_allocation_reports_the_saturated_part_of_an_unachievable_wrench(thrusts_drawn, direction):
    """A force of 200 N more than the twelve 10 N thrusters' sum: saturated, delivered + undelivered =
    commanded, thrusts in bounds, and no worse (weighted 1-norm) than the thrusts it was built from."""
    extra = 200.0 * np.asarray(direction) / np.linalg.norm(direction)
    w = B @ thrusts_drawn + np.concatenate((extra, np.zeros(3)))
    allocation = allocate_wrench(LAYOUT, w[:3], w[3:])
    assert allocation.saturated
    assert np.allclose(allocation.wrench_delivered_body + allocation.wrench_undelivered_body, w, rtol=0.0, atol=1e-12)
    assert np.allclose(allocation.wrench_delivered_body, B @ allocation.thrusts_n, rtol=0.0, atol=1e-12)
    assert np.all(allocation.thrusts_n >= 0.0) and np.all(allocation.thrusts_n <= 10.0)
    residual = np.abs(WEIGHT * allocation.wrench_undelivered_body).sum()
    assert residual <= np.abs(WEIGHT * (w - B @ thrusts_drawn)).sum() + 1e-8


def test_saturated_pure_force_delivers_the_two_thrusters_along_it():
    """100 N along +x: the two +x thrusters at full thrust (20 N, no torque), 80 N reported undelivered."""
    allocation = allocate_wrench(LAYOUT, [100.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    assert allocation.saturated
    assert np.allclose(allocation.wrench_delivered_body, [20.0, 0, 0, 0, 0, 0], rtol=0.0, atol=1e-9)
    assert np.allclose(allocation.wrench_undelivered_body, [80.0, 0, 0, 0, 0, 0], rtol=0.0, atol=1e-9)
    assert np.allclose(allocation.thrusts_n, [10.0, 10.0] + [0.0] * 10, rtol=0.0, atol=1e-9)


def test_pure_torque_fires_a_couple_with_the_least_thrust():
    """1 N m about z from the x thrusters (lever arm 0.25 m): 2 N each on one crosswise pair, no force."""
    allocation = allocate_wrench(LAYOUT, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    assert allocation.total_thrust_n == pytest.approx(4.0, abs=1e-9)
    assert np.allclose(allocation.wrench_delivered_body, [0, 0, 0, 0, 0, 1.0], rtol=0.0, atol=1e-12)


def test_execution_errors_come_from_the_generator_passed_in():
    """4 draws per thruster, the same for the same seed, none from the global state; zero sigma: nominal."""
    errors = draw_thruster_errors(LAYOUT, np.random.default_rng(7), 0.01, math.radians(0.5))
    again = draw_thruster_errors(LAYOUT, np.random.default_rng(7), 0.01, math.radians(0.5))
    assert np.array_equal(errors.magnitude_factors, again.magnitude_factors)
    assert np.array_equal(errors.force_directions_body, again.force_directions_body)
    rng = np.random.default_rng(7)
    draw_thruster_errors(LAYOUT, rng, 0.0, 0.0)
    reference = np.random.default_rng(7)
    reference.standard_normal(4 * LAYOUT.count)
    assert rng.standard_normal() == reference.standard_normal()
    nominal = draw_thruster_errors(LAYOUT, np.random.default_rng(7), 0.0, 0.0)
    assert np.array_equal(nominal.magnitude_factors, np.ones(12))
    assert np.allclose(nominal.force_directions_body, LAYOUT.force_directions_body, rtol=0.0, atol=0.0)
    # The misaligned directions stay unit vectors, a few tenths of a degree off.
    assert np.allclose(np.linalg.norm(errors.force_directions_body, axis=1), 1.0, rtol=0.0, atol=1e-15)
    angles = np.arccos(np.clip(np.sum(errors.force_directions_body * LAYOUT.force_directions_body, axis=1), -1, 1))
    assert 0.0 < angles.max() < math.radians(0.5 * 6)


def test_fire_applies_errors_and_the_minimum_impulse_bit():
    thrusts = np.zeros(12)
    thrusts[0], thrusts[5] = 4.0, 0.05  # 0.05 N for 0.1 s = 0.005 N s, below the 0.01 N s bit
    errors = draw_thruster_errors(LAYOUT, np.random.default_rng(1), 0.02, math.radians(1.0))
    firing = fire(LAYOUT, thrusts, 0.1, errors)
    assert firing.below_minimum_impulse.tolist() == [i == 5 for i in range(12)]
    assert firing.thrusts_n[5] == 0.0 and firing.thrusts_n[0] == 4.0 * errors.magnitude_factors[0]
    d, r = errors.force_directions_body[0], LAYOUT.positions_body_m[0]
    assert np.allclose(firing.force_body_n, firing.thrusts_n[0] * d, rtol=0.0, atol=1e-15)
    assert np.allclose(firing.torque_body_n_m, np.cross(r, firing.thrusts_n[0] * d), rtol=0.0, atol=1e-15)
    assert firing.impulses_n_s[0] == pytest.approx(0.4 * errors.magnitude_factors[0], rel=1e-15)


def test_fuel_from_impulse_agrees_with_the_rocket_equation():
    """One 10 N thruster for 60 s from 100 kg: fuel = impulse / (Isp g0); integrating m_dot = -F/(Isp g0),
    v_dot = F/m independently gives the rocket equation's delta-v for that fuel (propulsion)."""
    thrusts = np.zeros(12)
    thrusts[0] = 10.0
    firing = fire(LAYOUT, thrusts, 60.0)
    ve = 220.0 * STANDARD_GRAVITY_M_S2
    assert firing.fuel_kg == pytest.approx(600.0 / ve, rel=1e-15)
    end = solve_ivp(lambda _t, y: [-10.0 / ve, 10.0 / y[0]], (0.0, 60.0), [100.0, 0.0], rtol=1e-12, atol=1e-12).y[:, -1]
    assert 100.0 - end[0] == pytest.approx(firing.fuel_kg, rel=1e-10)
    assert end[1] == pytest.approx(delta_v_for_fuel_mps(100.0, firing.fuel_kg, ve), rel=1e-10)


def test_bad_inputs_name_themselves():
    with pytest.raises(ValueError, match='force_body_n'):
        allocate_wrench(LAYOUT, [1.0, math.inf, 0.0], [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match='torque_body_n_m'):
        allocate_wrench(LAYOUT, [1.0, 0.0, 0.0], [0.0, 0.0])
    with pytest.raises(ValueError, match='outside'):
        fire(LAYOUT, np.full(12, 11.0), 0.1)
    with pytest.raises(ValueError, match='period_s'):
        fire(LAYOUT, np.zeros(12), 0.0)
    with pytest.raises(ValueError, match='zero direction'):
        ThrusterLayout([[0.0, 0.0, 0.0]], [[0.0, 0.0, 0.0]], 1.0, 200.0, 0.0)
    with pytest.raises(ValueError, match='max_thrust_n'):
        ThrusterLayout([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [1.0, 2.0], 200.0, 0.0)
    with pytest.raises(ValueError, match='isp_s'):
        default_thruster_layout(isp_s=0.0)
    with pytest.raises(ValueError, match='misalignment_sigma_rad'):
        draw_thruster_errors(LAYOUT, np.random.default_rng(0), 0.0, -1.0)


@settings(max_examples=30, deadline=None)
@given(st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)).filter(
    lambda u: np.linalg.norm(u) > 1e-3))
def test_largest_pure_force_along_a_direction_is_the_default_layouts_closed_form(direction):
    """Each axis's pair gives at most 20 N along it and nothing else, so the largest pure force along the unit u is
    20 / max|u_k| N, with no torque and nothing across u, from sum f = 20 sum|u_k| / max|u_k| (no opposing
    thruster fires)."""
    u = np.array(direction) / np.linalg.norm(direction)
    allocation = allocate_max_force(LAYOUT, direction)
    expected_n = 20.0 / np.abs(u).max()
    assert allocation.force_n == pytest.approx(expected_n, rel=2e-9)
    np.testing.assert_allclose(allocation.force_body_n, allocation.force_n * u, atol=1e-8)
    np.testing.assert_allclose(allocation.torque_body_n_m, 0.0, atol=1e-9)
    assert allocation.total_thrust_n == pytest.approx(expected_n * np.abs(u).sum(), rel=1e-8)


def test_burn_plan_pushes_with_the_given_force_where_the_layout_gives_more():
    """Capped at 10 N along the diagonal (34.6 N possible): the same thrusters scaled, so the burn the navigation
    filter models at the point-mass thrust; above the largest force the cap changes nothing."""
    full = plan_burn(LAYOUT, [1.0, 1.0, 1.0], 0.3, 100.0)
    capped = plan_burn(LAYOUT, [1.0, 1.0, 1.0], 0.3, 100.0, max_force_n=10.0)
    assert capped.allocation.force_n == 10.0
    np.testing.assert_allclose(capped.allocation.thrusts_n, full.allocation.thrusts_n * 10.0 / full.allocation.force_n,
                               rtol=1e-15)
    np.testing.assert_allclose(capped.allocation.torque_body_n_m, 0.0, atol=1e-12)
    assert capped.fuel_kg == pytest.approx(full.fuel_kg, rel=1e-12)  # same effective exhaust velocity
    assert capped.duration_s == pytest.approx(full.duration_s * full.allocation.force_n / 10.0, rel=1e-12)
    above = plan_burn(LAYOUT, [1.0, 0.0, 0.0], 0.3, 100.0, max_force_n=50.0)
    assert above.allocation.force_n == pytest.approx(20.0, rel=2e-9)
    assert above.duration_s == plan_burn(LAYOUT, [1.0, 0.0, 0.0], 0.3, 100.0).duration_s


def test_burn_plan_follows_the_rocket_equation_with_the_effective_exhaust_velocity():
    """A diagonal delta-v of 0.3 m/s from 100 kg: integrating m_dot = -sum f / (Isp g0), v_dot = F / m over the planned
    duration gives 0.3 m/s and the planned fuel (independent integration, solve_ivp)."""
    plan = plan_burn(LAYOUT, [1.0, 1.0, 1.0], 0.3, 100.0)
    ve = 220.0 * STANDARD_GRAVITY_M_S2
    force, total = plan.allocation.force_n, plan.allocation.total_thrust_n
    assert force == pytest.approx(20.0 * math.sqrt(3.0), rel=2e-9) and total == pytest.approx(60.0, rel=2e-9)
    end = solve_ivp(lambda _t, y: [-total / ve, force / y[0]], (0.0, plan.duration_s), [100.0, 0.0], rtol=1e-12,
                    atol=1e-12).y[:, -1]
    assert end[1] == pytest.approx(0.3, rel=1e-10)
    assert 100.0 - end[0] == pytest.approx(plan.fuel_kg, rel=1e-10)
    assert plan.mass_flow_kg_s == pytest.approx(total / ve, rel=1e-15)


@settings(max_examples=15, deadline=None)
@given(st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)).filter(
    lambda u: np.linalg.norm(u) > 1e-3), st.floats(5e-5, 2e-3))
def test_small_burn_fires_every_thruster_at_least_its_minimum_impulse_bit_and_delivers_the_delta_v(direction, dv):
    """Trims of 0.05-2 mm/s from 100 kg at the point-mass chaser's 10 N (0.005-0.2 N s in all): no firing thruster is
    below the 0.01 N s bit over the burn (fire() leaves none off), the force is the planned one along the direction
    (to 1e-6 rad: smaller components are dropped) with no torque, and the rocket equation over the planned duration
    gives the delta-v."""
    u = np.array(direction) / np.linalg.norm(direction)
    plan = plan_burn(LAYOUT, direction, dv, 100.0, 10.0)
    f = plan.allocation.thrusts_n
    held = fire(LAYOUT, f, plan.duration_s)
    assert not held.below_minimum_impulse.any()
    assert np.all(f[f > 0.0] * plan.duration_s >= LAYOUT.min_impulse_bit_n_s)
    wrench = B @ f
    assert np.linalg.norm(wrench[:3]) == pytest.approx(plan.allocation.force_n, rel=1e-9)
    assert np.linalg.norm(np.cross(wrench[:3], u)) <= 1.01e-6 * plan.allocation.force_n  # components < 1e-6 dropped
    np.testing.assert_allclose(wrench[3:], 0.0, atol=1e-9)
    assert 0.0 < plan.allocation.force_n <= 10.0 * (1.0 + 1e-12)
    ve = 220.0 * STANDARD_GRAVITY_M_S2
    mass_flow = f.sum() / ve
    assert plan.allocation.force_n / mass_flow * math.log(100.0 / (100.0 - mass_flow * plan.duration_s)) == \
        pytest.approx(dv, rel=1e-9)


def test_small_burn_is_reallocated_where_the_linear_program_leaves_components_below_the_bit():
    """0.3 mm/s along (1, 0.2, 0.1) from 100 kg at 10 N lasts 3 ms: the least-thrust pure force puts 0.98 N (y) and
    0.49 N (z) on its pairs, 3 and 1.5 mN s each, below the 0.01 N s bit, which would lose the y and z parts; the
    re-allocation fires the y and z pairs against their opposite pairs, each at least 0.01 N s, for the same 10 N
    and duration. A 0.1 m/s burn along it keeps the linear program's thrusts."""
    direction = np.array([1.0, 0.2, 0.1])
    lp = allocate_max_force(LAYOUT, direction)
    plan = plan_burn(LAYOUT, direction, 3e-4, 100.0, 10.0)
    lp_thrusts = lp.thrusts_n * (10.0 / lp.force_n)
    assert fire(LAYOUT, lp_thrusts, plan.duration_s).below_minimum_impulse.sum() == 4
    assert plan.minimum_impulse_allocated and plan.allocation.force_n == pytest.approx(10.0, rel=1e-9)
    assert plan.duration_s == pytest.approx(100.0 * 3e-4 / 10.0, rel=1e-5)
    assert np.count_nonzero(plan.allocation.thrusts_n) == 10  # the y and z pairs against their opposite pairs
    large = plan_burn(LAYOUT, direction, 0.1, 100.0, 10.0)
    assert not large.minimum_impulse_allocated
    np.testing.assert_array_equal(large.allocation.thrusts_n, lp_thrusts)


def test_burn_too_short_for_the_bit_at_its_force_is_lengthened():
    """0.05 mm/s nearly along y: at 10 N the burn would last 0.5 ms and every firing thruster would need 20 N; the
    force is halved until an allocation meets the bit (2.5 N, 2 ms)."""
    plan = plan_burn(LAYOUT, [0.01, 1.0, 0.0], 5e-5, 100.0, 10.0)
    assert plan.minimum_impulse_allocated and plan.allocation.force_n == pytest.approx(2.5, rel=1e-9)
    f = plan.allocation.thrusts_n
    assert np.all(f[f > 0.0] * plan.duration_s >= LAYOUT.min_impulse_bit_n_s)


def test_force_with_a_thrust_floor_is_none_where_no_thruster_reaches_the_floor_and_refuses_bad_inputs():
    assert allocate_force_with_minimum_impulse(LAYOUT, [1.0, 0.0, 0.0], 10.5) is None
    floored = allocate_force_with_minimum_impulse(LAYOUT, [1.0, 0.0, 0.0], 3.0)
    np.testing.assert_allclose(floored.thrusts_n[:4], [3.5, 3.5, 3.0, 3.0], atol=1e-9)  # +x pair against -x pair
    with pytest.raises(ValueError, match='force_body_n'):
        allocate_force_with_minimum_impulse(LAYOUT, [0.0, 0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match='floor_n'):
        allocate_force_with_minimum_impulse(LAYOUT, [1.0, 0.0, 0.0], 0.0)


def test_max_force_of_a_direction_rejects_a_zero_direction():
    with pytest.raises(ValueError, match='direction_body'):
        allocate_max_force(LAYOUT, [0.0, 0.0, 0.0])
