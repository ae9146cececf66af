"""Tests of flyby_planner.optimal.cost: the metrics of seed 003 eq 5 against hand-computed cases."""

import math

import numpy as np
import pytest

from flyby_planner.optimal.cost import (
    Trajectory,
    actuator_metric,
    box_contacts,
    eq5_terms,
    fuel_metric,
    mutual_safety_metric,
    plume_metric,
    safety_metric,
)
from flyby_planner.optimal.problem import ApproachProblem, Chaser, CostWeights, FixedTerminal
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2
from flyby_sim.dynamics.geometry import signed_distance_to_box
from flyby_sim.scenario import Boxes

CUBE = Boxes(('cube',), np.zeros((1, 3)), np.full((1, 3), 2.0))  # half size 1 m
IDENTITY = np.eye(3)[None]


def test_seed003_eq5_safety_term():
    """Fig 9: v^2 / d toward the box; only a closing speed counts, relative to the closest body point."""
    r = np.array([[5.0, 0.0, 0.0]])
    s, gap = safety_metric(r, [[-1.0, 0.0, 0.0]], IDENTITY, np.zeros((1, 3)), CUBE, 0.5)
    assert gap[0] == pytest.approx(3.5)  # 4 m to the face less the envelope
    assert s[0] == pytest.approx(1.0 ** 2 / 3.5)
    s, _ = safety_metric(r, [[1.0, 0.0, 0.0]], IDENTITY, np.zeros((1, 3)), CUBE, 0.5)
    assert s[0] == 0.0  # opening
    # A chaser at rest facing an edge that turns toward it: closest point q = (1, 1, 0), normal (4, 2, 0)/sqrt(20),
    # omega_rel = (0, 0, -0.1) moves q at omega x q = (0.1, -0.1, 0): closing speed n . v_q = 0.2 / sqrt(20).
    s, gap = safety_metric([[5.0, 3.0, 0.0]], [[0.0, 0.0, 0.0]], IDENTITY, [[0.0, 0.0, -0.1]], CUBE, 0.5)
    assert gap[0] == pytest.approx(math.sqrt(20.0) - 0.5)
    assert s[0] == pytest.approx((0.2 / math.sqrt(20.0)) ** 2 / (math.sqrt(20.0) - 0.5))
    # satellite and each panel: the terms add
    two = Boxes(('a', 'b'), np.array([[0.0, 0.0, 0.0], [0.0, 10.0, 0.0]]), np.full((2, 3), 2.0))
    s, _ = safety_metric([[0.0, 5.0, 0.0]], [[0.0, 1.0, 0.0]], IDENTITY, np.zeros((1, 3)), two, 0.5)
    assert s[0] == pytest.approx(1.0 / 3.5)  # toward b (3.5 m gap), away from a


def test_box_contacts_against_the_shared_distance():
    rng = np.random.default_rng(3)
    boxes = Boxes(('bus', 'panel'), np.array([[0.0, 0.0, 0.0], [0.0, 4.5, 0.0]]),
                  np.array([[3.0, 3.0, 3.0], [2.0, 6.0, 0.05]]))
    r = rng.uniform(-6.0, 6.0, size=(200, 3))
    c = np.repeat(IDENTITY, 200, axis=0)
    distance, q, normal = box_contacts(r, c, boxes)
    for k, (center, size) in enumerate(zip(boxes.center_body_m, boxes.size_m, strict=True)):
        np.testing.assert_allclose(distance[k], signed_distance_to_box(r, center, size), atol=1e-12)
    outside = distance > 0.0
    np.testing.assert_allclose(np.linalg.norm(r[None] - q, axis=2)[outside], distance[outside], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(normal, axis=2), 1.0, atol=1e-12)
    # inside: the face of least depth, outward
    d, q, n = box_contacts([[0.0, 0.8, 0.3]], IDENTITY, CUBE)
    assert d[0, 0] == pytest.approx(-0.2)
    np.testing.assert_allclose(n[0, 0], [0.0, 1.0, 0.0])
    np.testing.assert_allclose(q[0, 0], [0.0, 1.0, 0.3])


def test_seed003_eq5_actuator_term():
    a = np.array([[0.2, 0.0, 0.0], [0.0, 0.05, 0.0], [0.0, 0.0, -0.1]])
    np.testing.assert_allclose(actuator_metric(a, 0.1), [1.0, 0.0, 0.0])  # (0.2 / 0.1 - 1)^2, within, at


def test_seed003_eq5_fuel_term():
    """f = m |a| / (Isp g0): 100 kg at 0.1 m/s^2 with Isp 220 s."""
    f = fuel_metric(np.array([[0.06, 0.0, 0.08]]), 100.0, 220.0 * STANDARD_GRAVITY_M_S2)
    assert f[0] == pytest.approx(100.0 * 0.1 / (220.0 * 9.80665))


def test_seed003_eq5_plume_term():
    """Acceleration away from the target inside the plume radius: the exhaust points at the target."""
    r = np.array([[3.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 0.0, 6.0], [0.0, 4.0, 0.0]])
    a = np.array([[0.1, 0.05, 0.0], [-0.1, 0.05, 0.0], [0.0, 0.0, 0.1], [0.0, 0.0, 0.1]])
    np.testing.assert_allclose(plume_metric(r, a, 5.0), [0.1, 0.0, 0.0, 0.0])


def test_seed003_mutual_safety_term():
    s, gap = mutual_safety_metric([[3.0, 0.0, 0.0]], [[-0.25, 0.0, 0.0]], [[0.0, 0.0, 0.0]], [[0.25, 0.0, 0.0]],
                                  1.0)
    assert gap[0] == pytest.approx(2.0)
    assert s[0] == pytest.approx(0.5 ** 2 / 2.0)


def test_seed003_eq5_is_the_sum_of_the_weighted_terms():
    """Eq 5 (garbled in the text): sum over the steps of (k_a a + k_f f + k_s s + k_pi pi) dt, plus k_t T^2."""
    weights = CostWeights(actuator=7.0, fuel_per_kg=3.0, safety=0.0, plume=5.0, time=0.01)
    chaser = Chaser(mass_kg=50.0, isp_s=100.0, accel_max_mps2=0.1, envelope_radius_m=0.5)
    problem = ApproachProblem(np.zeros(3), np.zeros(3), 0.0, FixedTerminal(np.zeros(3), np.zeros(3)), None, chaser,
                              1e-3, plume_radius_m=10.0, weights=weights)
    m, dt = 4, 2.5
    r = np.tile([4.0, 0.0, 0.0], (m, 1))
    a = np.tile([0.2, 0.0, 0.0], (m, 1))  # twice the limit, away from the target
    terms = eq5_terms(problem, Trajectory(np.arange(m) * dt, r, np.zeros((m, 3)), a), dt, m * dt)
    fuel_rate = 50.0 * 0.2 / (100.0 * 9.80665)
    assert terms.actuator == pytest.approx(7.0 * 1.0 * m * dt)
    assert terms.fuel == pytest.approx(3.0 * fuel_rate * m * dt)
    assert terms.plume == pytest.approx(5.0 * 0.2 * m * dt)
    assert terms.time == pytest.approx(0.01 * (m * dt) ** 2)
    assert terms.total == pytest.approx(7.0 * 10.0 + 3.0 * fuel_rate * 10.0 + 5.0 * 2.0 + 1.0)
    assert terms.delta_v_mps == pytest.approx(2.0)
    assert terms.fuel_kg == pytest.approx(fuel_rate * 10.0)
