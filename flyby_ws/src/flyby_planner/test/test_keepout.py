"""Tests of flyby_planner.flyby.keepout: the swept region contains the rotating body, and is tight where it should
be."""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import MotionPrediction
from flyby_planner.flyby.keepout import swept_region
from flyby_sim.dynamics.geometry import clearance
from flyby_sim.dynamics.orbital import eci_vector_in_hill, quat_eci_from_hill
from flyby_sim.dynamics.rotation import quat_from_axis_angle, quat_multiply, quat_rotate
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
PAPER = load_scenario(SCENARIOS / 'paper_flyby.yaml')
N = PAPER.mean_motion_rad_s
BOXES = PAPER.boxes
BOX_PAIRS = list(zip(BOXES.center_body_m, BOXES.size_m, strict=True))
Q_HB0 = PAPER.q_hill_from_body0
Q_EB0 = quat_multiply(quat_eci_from_hill(0.0, N), Q_HB0)
SPIN_AXIS_HILL0 = quat_rotate(Q_HB0, (0.0, 0.0, 1.0))


def _paper_region():
    return swept_region(BOXES, PAPER.target_inertia, [Q_EB0], [PAPER.omega_body0_rad_s])


def _true_clearance(r_hill, spin_angle_rad, envelope=0.0):
    """Clearance from the actual boxes with the body turned by spin_angle about its spin axis (body z)."""
    q = quat_multiply(Q_HB0, quat_from_axis_angle((0.0, 0.0, 1.0), spin_angle_rad))
    return float(clearance(np.atleast_2d(r_hill), q, BOX_PAIRS, envelope)[0])


def test_paper_target_cylinders():
    region = _paper_region()
    assert region.names == ('bus', 'panel_plus_y', 'panel_minus_y')
    np.testing.assert_allclose(region.axial_min_m, (-1.5, -0.025, -0.025))
    np.testing.assert_allclose(region.axial_max_m, (1.5, 0.025, 0.025))
    np.testing.assert_allclose(region.radius_m, (math.hypot(1.5, 1.5), math.hypot(1.0, 7.5), math.hypot(1.0, 7.5)))
    np.testing.assert_allclose(region.axis_hill(0.0, N), SPIN_AXIS_HILL0, atol=1e-12)
    assert region.bounding_radius_m == pytest.approx(math.hypot(0.025, math.hypot(1.0, 7.5)))


@settings(max_examples=150, deadline=None)
@given(point=st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3), angle=st.floats(0.0, 2.0 * math.pi))
def test_region_contains_the_body_at_every_spin_angle(point, angle):
    """Conservative: the distance to the region never exceeds the distance to the real, turned body."""
    region = _paper_region()
    d_region = float(region.signed_distance(np.array(point), 0.0, N)[0])
    assert d_region <= _true_clearance(point, angle) + 1e-9


def test_region_is_tight_above_the_bus_and_beyond_the_panel_rim():
    """Where the nearest feature is a swept rim or face, the region distance is the least distance over a turn."""
    region = _paper_region()
    axis = SPIN_AXIS_HILL0
    radial = np.cross(axis, (0.0, 1.0, 0.0))
    radial /= np.linalg.norm(radial)
    angles = np.linspace(0.0, 2.0 * math.pi, 3601)
    for p in (2.7 * axis + 2.2 * radial,  # above the bus rim (the fly-by target point's neighbourhood)
              0.3 * axis + 8.5 * radial):  # beside the panels' rim
        least = min(_true_clearance(p, a) for a in angles)
        assert float(region.signed_distance(p, 0.0, N)[0]) == pytest.approx(least, abs=2e-3)


def test_region_axis_turns_with_the_inertial_frame_in_hill():
    region = _paper_region()
    t = np.array((0.0, 600.0, 3000.0))
    np.testing.assert_allclose(region.axis_hill(t, N), eci_vector_in_hill(region.axis_eci, t, N))
    # The clearance of a point at time t is that of the rotated point at t = 0.
    p = np.array((2.0, 2.5, 1.0))
    back = eci_vector_in_hill(quat_rotate(quat_eci_from_hill(600.0, N), p), 0.0, N)
    assert region.clearance(p, 600.0, N, 0.5)[0] == pytest.approx(region.clearance(back, 0.0, N, 0.5)[0], abs=1e-12)


def test_tumbler_region_contains_every_sampled_corner():
    """seed 001 tumbler: every box corner, at every sampled time, lies inside the region about H."""
    sc = load_scenario(SCENARIOS / 'seweryn_tumbling.yaml')
    n = sc.mean_motion_rad_s
    q0 = quat_multiply(quat_eci_from_hill(0.0, n), sc.q_hill_from_body0)
    pred = MotionPrediction(ErrorStateDynamics(sc.target_inertia), n, 0.0, q0, sc.omega_body0_rad_s, None, 120.0,
                            with_covariance=False)
    states = [pred.state(t) for t in np.linspace(0.0, 120.0, 64)]
    region = swept_region(sc.boxes, sc.target_inertia, [s.q_eci_from_body for s in states],
                          [s.omega_body for s in states])
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    corners_body = sc.boxes.center_body_m[0] + 0.5 * signs * sc.boxes.size_m[0]
    for t in np.linspace(0.0, 120.0, 37):
        s = pred.state(t)
        corners_hill = np.array([quat_rotate(s.q_hill_from_body, c) for c in corners_body])
        assert np.all(region.signed_distance(corners_hill, np.full(8, t), n) <= 1e-9)
    # Nutation widens the bus's axial band beyond a pure spin's.
    assert region.axial_max_m[0] - region.axial_min_m[0] > 2.0


def test_swept_region_input_errors():
    with pytest.raises(ValueError, match='angular momentum'):
        swept_region(BOXES, PAPER.target_inertia, [Q_EB0], [np.zeros(3)])
    with pytest.raises(ValueError, match='not one torque-free motion'):
        swept_region(BOXES, PAPER.target_inertia, [Q_EB0, Q_EB0], [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0)])
