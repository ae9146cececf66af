"""Tests of flyby_planner.flyby.families: the coasting path families of seed 000 sections 3.2-3.3 (Fig. 5-8)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from flyby_planner.flyby.families import SEED000_CASES, SEED000_SPEEDS_M_S, seed000_family, time_grid
from flyby_sim.dynamics.orbital import mean_motion_rad_s

N = mean_motion_rad_s(7.0e6)  # seed 000 section 5 orbit
T_S = time_grid()  # [-300, 300] s, 0.05 s steps within 10 s of the grasp
SPEEDS = np.array(SEED000_SPEEDS_M_S)
AWAY = T_S != 0.0


@pytest.fixture(scope='module')
def in_plane():
    return seed000_family('in_plane', N, T_S)[0]


@pytest.fixture(scope='module')
def out_of_plane():
    return seed000_family('out_of_plane', N, T_S)[0]


def _eq2(_t, state):
    """Seed 000 eq 2a-2c, A = 0, written out independently of flyby_sim.dynamics.orbital."""
    x, y, z, vx, vy, vz = state
    return (vx, vy, vz, 2.0 * N * vz, -N * N * y, -2.0 * N * vx + 3.0 * N * N * z)


@pytest.mark.parametrize('case', sorted(SEED000_CASES))
def test_paths_pass_through_target_and_solve_eq2(case):
    family = seed000_family(case, N, T_S)[0]
    _, r_target, v_direction = SEED000_CASES[case]
    i0 = int(np.flatnonzero(T_S == 0.0)[0])
    for k, v in enumerate(SPEEDS):
        v_target = v * np.asarray(v_direction)
        np.testing.assert_allclose(family.r_hill[k, i0], r_target, atol=1e-12)
        np.testing.assert_allclose(family.v_hill[k, i0], v_target, atol=1e-12)
        state0 = np.concatenate((r_target, v_target))
        for t_half in (T_S[T_S >= 0.0], T_S[T_S <= 0.0][::-1]):  # escape forward, approach backward
            sol = solve_ivp(_eq2, (0.0, t_half[-1]), state0, t_eval=t_half, method='DOP853',
                            rtol=1e-12, atol=1e-12)
            i = np.searchsorted(T_S, t_half)
            np.testing.assert_allclose(family.r_hill[k, i], sol.y[:3].T, rtol=0.0, atol=1e-7)
            np.testing.assert_allclose(family.v_hill[k, i], sol.y[3:].T, rtol=0.0, atol=1e-9)


@pytest.mark.parametrize('case', sorted(SEED000_CASES))
def test_approach_and_escape_mirror_each_other(case):
    family = seed000_family(case, N, T_S)[0]
    # With x0 = 0 (in-plane) or z0 = 0 (out-of-plane) the CW flow is time-reversal symmetric.
    for view in (family.inertial, family.hill_fixed):
        np.testing.assert_allclose(view.distance_m, view.distance_m[:, ::-1], atol=1e-9)


def test_in_plane_paths_stay_outside_with_minimum_at_grasp(in_plane):
    """Section 3.2: spin +z, X_i on the rim, V_i along +x -- no path enters the cylinder."""
    for view in (in_plane.inertial, in_plane.hill_fixed):
        assert np.all(view.distance_m >= -1e-9)
        assert np.all(view.distance_m[:, AWAY] > 0.0)
        assert np.all(T_S[np.argmin(view.distance_m, axis=1)] == 0.0)


def test_in_plane_paths_are_convex_away_from_the_face(in_plane):
    """'Approaches from and escapes to the safer zone': beyond the face plane z = -1.5 on both sides.

    Paper's picture (axis fixed in hill): the gap is (1 - cos nt)(4.5 + 2 v / n) exactly, mostly
    the Coriolis term 2 v / n. With the axis fixed in inertial space (a torque-free target) the axis
    turns by n t in hill, which cancels the Coriolis bend to leading order: the gap left is the
    tidal 1.5 (n t)^2 + v n^3 t^4 / 4, under 6 % of the paper's.
    """
    theta = N * T_S
    gap_hill = in_plane.hill_fixed.axial_gap_m
    np.testing.assert_allclose(gap_hill, (1.0 - np.cos(theta)) * (4.5 + 2.0 * SPEEDS[:, None] / N), atol=1e-9)
    gap_inertial = in_plane.inertial.axial_gap_m
    assert np.all(gap_inertial[:, AWAY] > 0.0)
    assert np.all(gap_inertial[:, AWAY] < 0.06 * gap_hill[:, AWAY])
    i60 = int(np.flatnonzero(T_S == 60.0)[0])
    series = 1.5 * theta[i60] ** 2 + SPEEDS * N**3 * 60.0**4 / 4.0
    np.testing.assert_allclose(gap_inertial[:, i60], series, rtol=0.02)


def test_out_of_plane_paths_stay_outside_and_axis_picture_does_not_matter(out_of_plane):
    """Section 3.3: spin +y (orbit anti-normal, inertially fixed) -- both pictures are one."""
    np.testing.assert_allclose(out_of_plane.inertial.distance_m, out_of_plane.hill_fixed.distance_m, atol=1e-12)
    d = out_of_plane.inertial.distance_m
    assert np.all(d >= -1e-9)
    assert np.all(d[:, AWAY] > 0.0)
    assert np.all(T_S[np.argmin(d, axis=1)] == 0.0)


def test_out_of_plane_curvature_is_perpendicular_to_the_spin_axis(out_of_plane):
    """The axial motion is eq 2b alone, the same for every speed: Coriolis bends only in x-z.

    'Slightly closer to the collision region than the target position': the paths enter the axial
    slab |y| < 1.5 by 1.5 (1 - cos nt) (8 cm at 300 s), speed-independent. The x-z bend is toward the
    axis: the radial distance grows slower than along the straight line X_i + V_i t until
    t = sqrt(4.5 / (n v)) (289 s at 0.05 m/s, 46 s at 2 m/s).
    """
    drift = np.broadcast_to(1.5 * (1.0 - np.cos(N * T_S)), (SPEEDS.size, T_S.size))
    np.testing.assert_allclose(out_of_plane.r_hill[..., 1], -1.5 + drift, atol=1e-12)
    gap = out_of_plane.inertial.axial_gap_m
    np.testing.assert_allclose(gap, -drift, atol=1e-12)
    assert np.all(gap[:, AWAY] < 0.0)
    assert gap.min() == pytest.approx(-0.0778, abs=1e-4)
    radial_straight = np.hypot(1.5, SPEEDS[:, None] * T_S)
    crossover_s = np.sqrt(4.5 / (N * SPEEDS))
    for k, t_cross in enumerate(crossover_s):
        inner = AWAY & (np.abs(T_S) < 0.98 * t_cross)
        outer = np.abs(T_S) > 1.02 * t_cross
        assert np.all(out_of_plane.inertial.radial_m[k, inner] < radial_straight[k, inner])
        assert np.all(out_of_plane.inertial.radial_m[k, outer] > radial_straight[k, outer])
