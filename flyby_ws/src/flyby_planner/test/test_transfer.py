"""Tests of flyby_planner.transfer: the terminal-approach impulses of seed 000 eq 28-29."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from flyby_planner.transfer import terminal_impulses
from flyby_sim.dynamics.orbital import cw_accel, cw_transition_matrix, mean_motion_rad_s

N = mean_motion_rad_s(7000e3)
_vec = st.lists(st.floats(-80.0, 80.0), min_size=3, max_size=3).map(np.array)
_vel = st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3).map(np.array)


@settings(max_examples=60, deadline=None)
@given(r0=_vec, v0=_vel, r1=_vec, v1=_vel, duration=st.floats(60.0, 2500.0))
def test_seed000_eq28_29_land_exactly_on_the_target_under_cw(r0, v0, r1, v1, duration):
    dv1, dv2 = terminal_impulses(r0, v0, r1, v1, duration, N)
    arrived = cw_transition_matrix(N, duration) @ np.concatenate((r0, v0 + dv1))  # eq 27
    np.testing.assert_allclose(arrived[:3], r1, atol=1e-9)
    np.testing.assert_allclose(arrived[3:] + dv2, v1, atol=1e-12)


def test_seed000_eq28_29_against_numerical_integration_of_eq2():
    """The impulses from the section 5 start (50 m on V-bar at rest) to an X_Fi, flown with solve_ivp."""
    r0, v0 = np.array((50.0, 0.0, 0.0)), np.zeros(3)
    r1, v1 = np.array((-10.0, 25.0, -30.0)), np.array((0.05, -0.02, 0.1))
    dv1, dv2 = terminal_impulses(r0, v0, r1, v1, 420.0, N)
    sol = solve_ivp(lambda _, y: np.concatenate((y[3:], cw_accel(y[:3], y[3:], N))), (0.0, 420.0),
                    np.concatenate((r0, v0 + dv1)), method='DOP853', rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sol.y[:3, -1], r1, atol=1e-8)
    np.testing.assert_allclose(sol.y[3:, -1] + dv2, v1, atol=1e-11)


def test_a_whole_orbit_transfer_is_singular_and_says_so():
    with pytest.raises(ValueError, match='singular'):
        terminal_impulses(np.ones(3), np.zeros(3), np.zeros(3), np.zeros(3), 2 * np.pi / N, N)
    with pytest.raises(ValueError, match='duration_s'):
        terminal_impulses(np.ones(3), np.zeros(3), np.zeros(3), np.zeros(3), 0.0, N)
