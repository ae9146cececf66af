"""combined_body: seed 004 §2.2's combined mass properties against a hand case, and the combined body's motion."""

import numpy as np
import pytest

from flyby_sim.dynamics.combined_body import (
    CombinedState,
    Firing,
    angular_momentum_inertial,
    combined_mass_properties,
    inertia_from_principal,
    parallel_axis,
    simulate_combined_body,
    specific_force_body,
    wrench_about_chaser,
)
from flyby_sim.dynamics.rotation import quat_from_axis_angle


def test_seed004_table1_combined_mass_properties_by_hand():
    """TugRobot 30 kg diag(2, 3, 3) and material satellite 20 kg diag(2, 1.5, 1.5) at X_s = (0.5, 0, 0): the
    combined CoM is 20/50 * 0.5 = 0.2 m along x; the TugRobot sits 0.2 m, the target 0.3 m from it, adding
    30 * 0.04 = 1.2 and 20 * 0.09 = 1.8 kg m^2 about y and z: diag(4, 7.5, 7.5)."""
    props = combined_mass_properties(30.0, np.diag([2.0, 3.0, 3.0]), 20.0, (0.5, 0.0, 0.0), np.diag([2.0, 1.5, 1.5]))
    assert props.mass_kg == 50.0
    np.testing.assert_allclose(props.com_body_m, [0.2, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(props.inertia_body_kg_m2, np.diag([4.0, 7.5, 7.5]), atol=1e-14)


def test_parallel_axis_of_an_offset_point_mass_is_its_inertia_about_the_origin():
    """m (r.r U - r r^T) = sum m (|x|^2 U - x x^T) for one point: the diagonal is m (r_j^2 + r_k^2)."""
    r = np.array([1.0, 2.0, -3.0])
    i = parallel_axis(2.0, r)
    np.testing.assert_allclose(np.diag(i), 2.0 * np.array([13.0, 10.0, 5.0]))
    np.testing.assert_allclose(i[0, 1], -2.0 * 2.0)


def test_rotated_principal_axes_keep_the_moments():
    q = quat_from_axis_angle((1.0, 2.0, 3.0), 0.7)
    i = inertia_from_principal((2.0, 1.5, 1.2), q)
    np.testing.assert_allclose(np.sort(np.linalg.eigvalsh(i)), [1.2, 1.5, 2.0], rtol=1e-13)


def test_unphysical_inputs_are_refused_by_name():
    with pytest.raises(ValueError, match='target_mass_kg'):
        combined_mass_properties(30.0, np.eye(3), -1.0, (0, 0, 0), np.eye(3))
    with pytest.raises(ValueError, match='target_com_body_m'):
        combined_mass_properties(30.0, np.eye(3), 1.0, (0, 0), np.eye(3))


def _props():
    i_s = inertia_from_principal((2.0, 1.5, 1.2), quat_from_axis_angle((0.0, 0.0, 1.0), 0.3))
    return combined_mass_properties(30.0, np.diag([2.0, 3.0, 3.0]), 20.0, (0.5, 0.1, -0.05), i_s)


def test_angular_momentum_is_kept_without_firings_and_unchanged_by_a_force_through_the_combined_com():
    props = _props()
    state0 = CombinedState(np.zeros(3), np.zeros(3), quat_from_axis_angle((1.0, 1.0, 0.0), 0.4),
                           np.array([0.05, -0.1, 0.2]))
    # A force along the line through the combined CoM: no torque about it.
    d = np.array([0.3, 0.8, 0.52])
    firing = Firing(1.0, 2.0, tuple(props.com_body_m - 0.4 * d), tuple(5.0 * d))
    t = np.linspace(0.0, 10.0, 11)
    states, _, _ = simulate_combined_body(props, state0, (firing,), t)
    h = [angular_momentum_inertial(props, CombinedState(*np.split(s, [3, 6, 10]))) for s in states]
    np.testing.assert_allclose(h, np.repeat(h[:1], len(h), axis=0), atol=1e-9)


def test_a_firing_changes_linear_momentum_by_its_impulse_when_the_body_does_not_turn():
    props = combined_mass_properties(30.0, np.eye(3), 20.0, (0.5, 0.0, 0.0), np.eye(3))
    state0 = CombinedState(np.zeros(3), np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3))
    firing = Firing(0.5, 1.5, tuple(props.com_body_m - (1.0, 0.0, 0.0)), (10.0, 0.0, 0.0))
    states, _, _ = simulate_combined_body(props, state0, (firing,), np.array([0.0, 3.0]))
    np.testing.assert_allclose(props.mass_kg * states[-1, 3:6], [15.0, 0.0, 0.0], atol=1e-9)


def test_accelerometer_reads_the_force_over_the_mass_at_the_combined_com_and_the_centripetal_term_elsewhere():
    props = _props()
    force = np.array([1.0, -2.0, 0.5])
    np.testing.assert_allclose(specific_force_body(props, np.zeros(3), np.zeros(3), force, props.com_body_m),
                               force / props.mass_kg)
    w = np.array([0.0, 0.0, 0.3])
    a = specific_force_body(props, w, np.zeros(3), np.zeros(3), props.com_body_m + (1.0, 0.0, 0.0))
    np.testing.assert_allclose(a, [-0.09, 0.0, 0.0], atol=1e-15)


def test_wrench_about_the_chaser_holds_on_the_half_open_interval():
    f = Firing(1.0, 0.5, (0.0, 1.0, 0.0), (2.0, 0.0, 0.0))
    assert np.allclose(wrench_about_chaser((f,), 0.999)[0], 0.0)
    force, moment = wrench_about_chaser((f,), 1.0)
    np.testing.assert_allclose(force, [2.0, 0.0, 0.0])
    np.testing.assert_allclose(moment, [0.0, 0.0, -2.0])
    assert np.allclose(wrench_about_chaser((f,), 1.5)[0], 0.0)
