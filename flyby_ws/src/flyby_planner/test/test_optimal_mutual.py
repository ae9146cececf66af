"""Mutual safety against another robot's published plan (flyby_planner.optimal.mutual; seed 003 section 4.2)."""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_planner.flyby.config import truth_prediction
from flyby_planner.optimal.approach import ApproachSettings
from flyby_planner.optimal.cost import box_contacts
from flyby_planner.optimal.mutual import MovingObstacle, least_separation, obstacle_contacts, obstacle_cost
from flyby_planner.optimal.problem import ApproachProblem, Chaser, CostWeights, FixedTerminal, approach_problem
from flyby_planner.optimal.sampler import sample_trajectory
from flyby_planner.optimal.scp import ScpSettings, ZohPlan, plan_scp
from flyby_sim.dynamics.orbital import cw_coast
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
N = 1.08e-3
CHASER = Chaser(mass_kg=100.0, isp_s=220.0, accel_max_mps2=0.138, envelope_radius_m=0.5)


def _obstacle_of(plan, name='leader', margin_m=0.5, attitude=None, step_s=0.5):
    traj = sample_trajectory(plan, step_s)
    return MovingObstacle(name, traj.t_s, traj.r_hill, traj.v_hill, 0.5, margin_m, plan.n, attitude)


def _crossing(t0_s=0.0):
    """Two robots swapping ends along V-bar in free space, 0.2 m apart across it: straight paths would touch."""
    return [ApproachProblem(np.array([10.0, 0.0, 0.0]), np.zeros(3), t0_s,
                            FixedTerminal([-10.0, 0.0, 0.0], np.zeros(3)), None, CHASER, N, 0.0),
            ApproachProblem(np.array([-10.0, 0.2, 0.0]), np.zeros(3), t0_s,
                            FixedTerminal([10.0, 0.2, 0.0], np.zeros(3)), None, CHASER, N, 0.0)]


@pytest.fixture(scope='module')
def leader_plan():
    return plan_scp(_crossing()[:1], ScpSettings(steps=20), duration_s=60.0).plans[0]


def test_obstacle_state_follows_the_plan_between_its_points(leader_plan):
    """Cubic Hermite on the trajectory's points reproduces the held-thrust arcs (quadratic up to the CW terms)."""
    obstacle = _obstacle_of(leader_plan)
    tau = np.linspace(0.0, 60.0, 1201)
    exact = leader_plan.sample(tau)
    r, v = obstacle.state(exact.t_s)
    np.testing.assert_allclose(r, exact.r_hill, atol=1e-6)
    np.testing.assert_allclose(v, exact.v_hill, atol=1e-6)


def test_obstacle_coasts_before_its_start_and_after_its_end_without_a_target(leader_plan):
    obstacle = _obstacle_of(leader_plan)
    r_before, v_before = obstacle.state([-30.0])
    np.testing.assert_allclose(cw_coast(r_before[0], v_before[0], 30.0, N),
                               np.concatenate((obstacle.r_hill[0], obstacle.v_hill[0])), atol=1e-9)
    r_after, v_after = obstacle.state([90.0])
    np.testing.assert_allclose(np.concatenate((r_after[0], v_after[0])),
                               cw_coast(obstacle.r_hill[-1], obstacle.v_hill[-1], 30.0, N), atol=1e-9)


def test_obstacle_turns_with_the_target_after_its_end(leader_plan):
    """A captured robot stays at the body point it ended at: rotation about hill z at w (relative to hill)."""
    w = 0.05

    def attitude(times):
        a = w * np.asarray(times, dtype=float)
        c = np.zeros((len(a), 3, 3))
        c[:, 0, 0], c[:, 0, 1], c[:, 1, 0], c[:, 1, 1], c[:, 2, 2] = np.cos(a), -np.sin(a), np.sin(a), np.cos(a), 1.0
        return c, np.tile((0.0, 0.0, w), (len(a), 1))
    obstacle = _obstacle_of(leader_plan, attitude=attitude)
    end = obstacle.r_hill[-1]
    r, v = obstacle.state([70.0])
    turn = w * 10.0
    expected = np.array((math.cos(turn) * end[0] - math.sin(turn) * end[1],
                         math.sin(turn) * end[0] + math.cos(turn) * end[1], end[2]))
    np.testing.assert_allclose(r[0], expected, atol=1e-9)
    np.testing.assert_allclose(v[0], np.cross((0.0, 0.0, w), expected), atol=1e-12)


def test_obstacle_rejects_bad_points():
    with pytest.raises(ValueError, match='leader: t_s'):
        MovingObstacle('leader', np.array([0.0, 0.0]), np.zeros((2, 3)), np.zeros((2, 3)), 0.5, 0.5, N)
    with pytest.raises(ValueError, match='leader: v_hill must be'):
        MovingObstacle('leader', np.array([0.0, 1.0]), np.zeros((2, 3)), np.zeros((3, 3)), 0.5, 0.5, N)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-20.0, 20.0), min_size=6, max_size=6), st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3))
def test_contacts_plane_keeps_out_of_the_sphere_and_gradient_matches_differences(coords, v):
    """A point on the far side of the supporting plane is outside the keep-out sphere, and the closing speed's
    position gradient is that of -(r - p) . (v - v_p) / |r - p| by central differences."""
    r_ref, p = np.array(coords[:3]), np.array(coords[3:])
    if np.linalg.norm(r_ref - p) < 0.5:
        return
    v_p = np.array((0.1, -0.05, 0.02))
    obstacle = MovingObstacle('o', np.array([0.0, 10.0]), np.vstack((p, p + 10.0 * v_p)), np.vstack((v_p, v_p)),
                              0.5, 0.5, 1e-12)
    v_ref = np.array(v)
    q, normal, closing, j_r = obstacle_contacts([obstacle], np.array([0.0]), r_ref[None], v_ref[None], slice(None))
    rng = np.random.default_rng(7)
    for x in r_ref + rng.normal(scale=5.0, size=(200, 3)):
        if normal[0, 0] @ x >= normal[0, 0] @ q[0, 0]:
            assert np.linalg.norm(x - p) >= obstacle.keepout_radius_m - 1e-9

    def closing_at(r):
        d = r - p
        return -d @ (v_ref - v_p) / np.linalg.norm(d)
    assert closing[0, 0] == pytest.approx(closing_at(r_ref), abs=1e-12)
    step = 1e-6
    numeric = [(closing_at(r_ref + step * e) - closing_at(r_ref - step * e)) / (2 * step) for e in np.eye(3)]
    np.testing.assert_allclose(j_r[0, 0], numeric, atol=1e-7)


def test_seed003_mutual_metric_of_a_straight_closing_pass():
    """A robot at 0.1 m/s straight at a robot at rest 10 m away for 50 s: k_s int v^2 / gap dt with gap = 10 - 0.1 t
    - (0.5 + 0.5 + 0.5) = 8.5 - 0.1 t, which is k_s 0.01 / 0.1 ln(8.5 / 3.5)."""
    n = 1e-12  # free space: straight lines
    steps = 50
    x = np.zeros((steps + 1, 6))
    x[:, 0] = 10.0 - 0.1 * np.arange(steps + 1)
    x[:, 3] = -0.1
    plan = ZohPlan(0.0, 50.0, x, np.zeros((steps, 3)), n)
    obstacle = MovingObstacle('o', np.array([-5.0, 100.0]), np.zeros((2, 3)), np.zeros((2, 3)), 0.5, 0.5, n)
    problem = ApproachProblem(x[0, :3], x[0, 3:], 0.0, FixedTerminal(x[-1, :3], x[-1, 3:]), None, CHASER, n, 0.0,
                              CostWeights(safety=2.0))
    expected = 2.0 * 0.01 / 0.1 * math.log(8.5 / 3.5)
    assert obstacle_cost([problem], [plan], [obstacle], 4000) == pytest.approx(expected, rel=1e-6)
    separation = least_separation(plan, [obstacle], 0.5)
    assert separation.distance_m == pytest.approx(10.0 - 5.0 - 1.0, abs=1e-9)  # envelopes, without the margin
    assert separation.t_s == pytest.approx(50.0) and separation.name == 'o'
    assert least_separation(plan, [], 0.5) is None


def test_seed003_mutual_safety_against_a_published_plan_separates_crossing_robots(leader_plan):
    """The follower planned alone passes through the leader's planned path; with the leader's published
    trajectory as a moving obstacle its envelope keeps the margin."""
    follower = _crossing()[1:]
    obstacle = _obstacle_of(leader_plan)
    alone = plan_scp(follower, ScpSettings(steps=20), duration_s=60.0).plans[0]
    assert least_separation(alone, [obstacle], 0.5).distance_m < 0.0
    result = plan_scp(follower, ScpSettings(steps=20), duration_s=60.0, obstacles=[obstacle])
    plan = result.plans[0]
    separation = least_separation(plan, [obstacle], 0.5)
    assert separation.distance_m > obstacle.margin_m - 0.05  # between the check points, a few cm at most
    r_f, v_f = follower[0].end_state(60.0)
    end = plan.sample([60.0])
    np.testing.assert_allclose(end.r_hill[0], r_f, atol=1e-3)
    np.testing.assert_allclose(end.v_hill[0], v_f, atol=1e-3)


def test_seed003_fig12_second_robot_planned_against_the_first():
    """Seed 003 Fig 12 planned in turn: the +V-bar robot alone, then the -V-bar robot against its plan; they pass
    on opposite sides of the spin axis and the second keeps the margin and clears the target."""
    sc = load_scenario(SCENARIOS / 'jacobsen_two_robots.yaml')
    prediction = truth_prediction(sc, 200.0)
    chaser = Chaser(mass_kg=100.0, isp_s=220.0, accel_max_mps2=0.1242, envelope_radius_m=0.5)
    settings = ApproachSettings.from_scenario(sc)
    plus = approach_problem(settings, prediction, [50.0, 0.0, 0.0], np.zeros(3), 0.0, 5.0, x_grasp_body=[1.5, 0.0, 1.5],
                            chaser=chaser)
    minus = approach_problem(settings, prediction, [-50.0, 0.0, 0.0], np.zeros(3), 0.0, 5.0,
                             x_grasp_body=[-1.5, 0.0, -1.5], chaser=chaser)
    first = plan_scp([plus], ScpSettings(), duration_s=58.9).plans[0]
    obstacle = _obstacle_of(first, 'chaser1', attitude=plus.target.attitude)
    second = plan_scp([minus], ScpSettings(), duration_s=58.9, obstacles=[obstacle]).plans[0]
    separation = least_separation(second, [obstacle], 0.5)
    assert separation.distance_m > 0.5
    tau = np.linspace(0.0, 58.9, 1179)
    a, b = first.sample(tau), second.sample(tau)
    axis = prediction.track(np.zeros(3), tau).omega_hill
    axis /= np.linalg.norm(axis, axis=1)[:, None]

    def across(r):
        return r - np.sum(r * axis, axis=1)[:, None] * axis
    assert np.max(np.sum(across(a.r_hill) * across(b.r_hill), axis=1)) < 0.0
    c, _ = minus.target.attitude(b.t_s)
    assert box_contacts(b.r_hill, c, minus.target.boxes)[0].min() > 0.5
