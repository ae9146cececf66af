"""Tests of flyby_planner.optimal.spline and .baseline: the parabolic-spline path (seed 003 eq 3) and the paper's
Nelder-Mead planner with its growing-waypoint stop rule (section 4.1)."""

import numpy as np
import pytest

from flyby_planner.optimal.baseline import NelderMeadSettings, plan_nelder_mead
from flyby_planner.optimal.cost import plan_terms, total_cost
from flyby_planner.optimal.problem import ApproachProblem, Chaser, FixedTerminal
from flyby_planner.optimal.spline import parabolic_path
from flyby_sim.dynamics.orbital import cw_accel

N = 1.08e-3
CHASER = Chaser(mass_kg=100.0, isp_s=220.0, accel_max_mps2=0.138, envelope_radius_m=0.5)


@pytest.mark.parametrize('waypoints', [0, 1, 4])
def test_seed003_spline_boundary_conditions(waypoints):
    """Parabolic splines with an additional section meet position and velocity at both ends, pass the waypoints
    at their knots, and are C1 at every knot."""
    rng = np.random.default_rng(14)
    r0, v0 = rng.normal(size=3) * 20.0, rng.normal(size=3) * 0.3
    r_f, v_f = rng.normal(size=3) * 3.0, rng.normal(size=3) * 0.2
    w = rng.normal(size=(waypoints, 3)) * 10.0
    path = parabolic_path(r0, v0, w, r_f, v_f, 60.0, N, t0_s=5.0)
    r, v, _ = path.kinematics(np.array([0.0, 60.0]))
    np.testing.assert_allclose(r, [r0, r_f], atol=1e-9)
    np.testing.assert_allclose(v, [v0, v_f], atol=1e-9)
    h = 60.0 / (waypoints + 1)
    np.testing.assert_allclose(path.kinematics(np.arange(1, waypoints + 1) * h)[0], w.reshape(-1, 3), atol=1e-9)
    eps = 1e-7
    for knot in path.knots_s[1:-1]:
        before, after = path.kinematics(np.array([knot - eps])), path.kinematics(np.array([knot + eps]))
        np.testing.assert_allclose(before[0], after[0], atol=1e-5)
        np.testing.assert_allclose(before[1], after[1], atol=1e-5)
    # the thrust acceleration is what the thrusters add to the CW motion
    traj = path.sample(np.array([12.3]))
    r1, v1, acc = path.kinematics(np.array([12.3]))
    np.testing.assert_allclose(traj.a_hill[0], acc[0] - cw_accel(r1[0], v1[0], N))
    assert traj.t_s[0] == pytest.approx(17.3)


def _free_problem():
    return ApproachProblem(np.array([30.0, 0.0, 0.0]), np.zeros(3), 0.0,
                           FixedTerminal([0.0, 0.0, 5.0], [0.0, 0.0, 0.0]), None, CHASER, N, plume_radius_m=0.0)


def test_seed003_growing_waypoints_stop_rule():
    """'This process is repeated while the addition of waypoints significantly improves the total cost': every
    stage but the last improved on the best so far by at least the tolerance, the last did not (or the limit
    was reached), and the plan is the best stage's."""
    problem = _free_problem()
    settings = NelderMeadSettings(waypoints_max=6, tolerance=0.02, max_evaluations=800, samples=100)
    result = plan_nelder_mead([problem], settings, duration_s=50.0)
    costs = [c for _, c in result.stages]
    assert [n for n, _ in result.stages] == list(range(1, len(costs) + 1))
    best = np.minimum.accumulate(costs)
    for k in range(1, len(costs) - 1):
        assert best[k - 1] - costs[k] >= settings.tolerance
    assert len(costs) == settings.waypoints_max or best[-2] - costs[-1] < settings.tolerance
    assert total_cost([problem], result.plans, settings.samples) == pytest.approx(min(costs))
    # a tolerance above any improvement stops after the second stage
    coarse = plan_nelder_mead([problem], NelderMeadSettings(waypoints_max=6, tolerance=1e3, max_evaluations=300,
                                                            samples=100), duration_s=50.0)
    assert len(coarse.stages) == 2


def test_seed003_nelder_mead_lowers_the_cost_of_its_start():
    problem = _free_problem()
    settings = NelderMeadSettings(waypoints_max=2, max_evaluations=600, samples=100)
    start = parabolic_path(problem.r0_hill, problem.v0_hill, [[15.0, 0.0, 2.5]], [0.0, 0.0, 5.0], np.zeros(3), 50.0, N)
    result = plan_nelder_mead([problem], settings, duration_s=50.0)
    assert plan_terms(problem, result.plans[0]).total < plan_terms(problem, start).total
    # with T free, T moves within its bounds and the time term is k_t T^2
    free_t = plan_nelder_mead([problem], settings, duration0_s=80.0)
    terms = plan_terms(problem, free_t.plans[0])
    assert problem.duration_min_s <= terms.duration_s <= problem.duration_max_s
    assert terms.time == pytest.approx(problem.weights.time * terms.duration_s ** 2)
