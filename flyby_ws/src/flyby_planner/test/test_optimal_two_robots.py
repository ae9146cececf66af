"""Two robots approaching together (seed 003 section 4.2, Fig 12): mutual safety in both solvers."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from flyby_planner.flyby.config import truth_prediction
from flyby_planner.optimal.approach import ApproachSettings
from flyby_planner.optimal.baseline import NelderMeadSettings, plan_nelder_mead
from flyby_planner.optimal.problem import (
    ApproachProblem,
    Chaser,
    FixedTerminal,
    approach_problem,
)
from flyby_planner.optimal.scp import ScpSettings, plan_scp
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
T_S = 58.9
CHASER = Chaser(mass_kg=100.0, isp_s=220.0, accel_max_mps2=0.138, envelope_radius_m=0.5)


@pytest.fixture(scope='module')
def pair():
    """Chasers at +50 m and -50 m V-bar at rest; grasp points on opposite corners of the bus, each 1 m out."""
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    prediction = truth_prediction(sc, 200.0)
    settings = ApproachSettings.from_scenario(sc)
    chaser = dataclasses.replace(settings.chaser, accel_max_mps2=0.138)
    plus = approach_problem(settings, prediction, [50.0, 0.0, 0.0], np.zeros(3), 0.0, 5.0, x_grasp_body=[1.5, 0.0, 1.5],
                            chaser=chaser)
    minus = approach_problem(settings, prediction, [-50.0, 0.0, 0.0], np.zeros(3), 0.0, 5.0,
                             x_grasp_body=[-1.5, 0.0, -1.5], chaser=chaser)
    return prediction, [plus, minus]


def _check_pair(prediction, problems, plans):
    tau = np.linspace(0.0, T_S, 2946)
    a, b = (plan.sample(tau) for plan in plans)
    assert np.linalg.norm(a.r_hill - b.r_hill, axis=1).min() > 1.0  # the two envelopes apart
    for problem, traj in zip(problems, (a, b), strict=True):
        r_f, v_f = problem.end_state(T_S)
        np.testing.assert_allclose(traj.r_hill[-1], r_f, atol=1e-3)
        np.testing.assert_allclose(traj.v_hill[-1], v_f, atol=1e-3)
    # opposite sides of the spin axis throughout: their components across the axis point apart
    axis = prediction.track(np.zeros(3), tau).omega_hill
    axis /= np.linalg.norm(axis, axis=1)[:, None]

    def across(r):
        return r - np.sum(r * axis, axis=1)[:, None] * axis
    assert np.max(np.sum(across(a.r_hill) * across(b.r_hill), axis=1)) < 0.0


def test_seed003_fig12_scp_two_robots(pair):
    prediction, problems = pair
    result = plan_scp(problems, ScpSettings(steps=20), duration_s=T_S)
    _check_pair(prediction, problems, result.plans)


def test_seed003_fig12_nelder_mead_two_robots(pair):
    prediction, problems = pair
    result = plan_nelder_mead(problems, NelderMeadSettings(waypoints_max=1, max_evaluations=1500, samples=120),
                              duration_s=T_S)
    _check_pair(prediction, problems, result.plans)


def _crossing():
    """Two robots swapping ends along V-bar in free space, 0.2 m apart across it: straight paths would touch."""
    n = 1.08e-3
    return [ApproachProblem(np.array([10.0, 0.0, 0.0]), np.zeros(3), 0.0, FixedTerminal([-10.0, 0.0, 0.0], np.zeros(3)),
                            None, CHASER, n, 0.0),
            ApproachProblem(np.array([-10.0, 0.2, 0.0]), np.zeros(3), 0.0, FixedTerminal([10.0, 0.2, 0.0], np.zeros(3)),
                            None, CHASER, n, 0.0)]


def _least_separation(plans):
    tau = np.linspace(0.0, 60.0, 3001)
    a, b = (plan.sample(tau) for plan in plans)
    return float(np.linalg.norm(a.r_hill - b.r_hill, axis=1).min())


@pytest.mark.parametrize('solver', ['scp', 'nelder_mead'])
def test_seed003_mutual_safety_separates_crossing_robots(solver):
    """Without the mutual term (constraint) the envelopes touch; with it they pass apart."""
    problems = _crossing()

    def plan(separate):
        if solver == 'scp':
            return plan_scp(problems, ScpSettings(steps=20), duration_s=60.0, separate=separate).plans
        return plan_nelder_mead(problems, NelderMeadSettings(waypoints_max=2, max_evaluations=800, samples=100),
                                duration_s=60.0, separate=separate).plans
    assert _least_separation(plan(False)) < 1.0
    assert _least_separation(plan(True)) > 1.0
