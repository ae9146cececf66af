"""grasp: the arm's impedance between end effector and grasp point keeps momentum, only dissipates, damps the
residual capture errors or lets go beyond the arm's limits; weld keeps the momentum."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from flyby_sim.dynamics.combined_body import angular_momentum_inertial
from flyby_sim.dynamics.grasp import Body, Impedance, momentum, simulate_grasp, weld
from flyby_sim.dynamics.rotation import quat_from_axis_angle, quat_rotate
from flyby_sim.scenario import load_scenario

# The arm of paper_flyby_tug (the schema's post_capture.grasp).
ARM = Impedance.from_scenario(load_scenario(Path(__file__).resolve().parents[4] / 'scenarios'
                                            / 'paper_flyby_tug.yaml'))

_R_EE = np.array([0.8, 0.0, 0.0])
_R_G = np.array([-0.5, 0.0, 0.0])


def _bodies(dv_mps=(0.0, 0.0, 0.001), dr_m=(0.005, 0.003, 0.0), target_rate_deg_s=3.0):
    """A 100 kg chaser at rest and a 20 kg target turning at 3 deg/s whose grasp point is dr_m from the end
    effector and closes at dv_mps (residual capture errors)."""
    chaser = Body(100.0, np.diag([10.0, 12.0, 9.0]), np.zeros(3), np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]),
                  np.zeros(3))
    q_t = quat_from_axis_angle((0.2, 0.3, 1.0), 0.4)
    r_t = _R_EE + np.asarray(dr_m) - quat_rotate(q_t, _R_G)
    omega_t = np.radians(target_rate_deg_s) * np.array([0.0, 0.6, 0.8])
    target = Body(20.0, np.diag([2.0, 1.5, 1.2]), r_t, np.asarray(dv_mps, dtype=float), q_t, omega_t)
    return chaser, target


def test_momentum_is_kept_through_the_contact_and_the_weld():
    chaser, target = _bodies()
    p0, h0 = momentum((chaser, target))
    res = simulate_grasp(chaser, target, ARM, _R_EE, _R_G, 8.0, output_step_s=0.05)
    p1, h1 = momentum((res.chaser, res.target))
    np.testing.assert_allclose(p1, p0, atol=1e-9)
    np.testing.assert_allclose(h1, h0, atol=1e-9)
    props, state = weld(res.chaser, res.target)
    np.testing.assert_allclose(props.mass_kg * state.v_mps, p0, atol=1e-9)
    h_weld = angular_momentum_inertial(props, state) + np.cross(state.r_m, props.mass_kg * state.v_mps)
    np.testing.assert_allclose(h_weld, h0, atol=1e-6)


def test_the_impedance_only_dissipates_and_its_work_balances_the_energy():
    res = simulate_grasp(*_bodies(), ARM, _R_EE, _R_G, 8.0, output_step_s=0.05)
    assert np.all(np.diff(res.energy_j) <= 1e-9)
    np.testing.assert_allclose(res.energy_j[0] - res.energy_j, res.dissipated_j, rtol=1e-6, atol=1e-9)
    assert res.dissipated_j[-1] > 0.0


def test_residual_errors_within_the_arms_limits_are_damped():
    res = simulate_grasp(*_bodies(), ARM, _R_EE, _R_G, 8.0, output_step_s=0.05)
    assert not res.released
    assert res.peak_force_n < ARM.max_force_n
    assert 0.0 < res.damping_time_s < 8.0
    # The first push: the damper meets the closing speed, the wrist the rate mismatch.
    assert res.peak_torque_n_m == pytest.approx(40.0 * math.radians(3.0), rel=0.05)


def test_the_grasp_lets_go_when_the_error_exceeds_the_arms_limits():
    res = simulate_grasp(*_bodies(dv_mps=(0.0, 0.0, 0.5)), ARM, _R_EE, _R_G, 8.0, output_step_s=0.05)
    assert res.released and '|F|' in res.release_reason
    assert res.t_release_s == 0.0 and math.isnan(res.damping_time_s)
    weak = dataclasses.replace(ARM, max_torque_n_m=1.0)
    res = simulate_grasp(*_bodies(), weak, _R_EE, _R_G, 8.0, output_step_s=0.05)
    assert res.released and '|tau|' in res.release_reason


def test_impedance_values_are_checked_by_name():
    with pytest.raises(ValueError, match='max_force_n'):
        dataclasses.replace(ARM, max_force_n=0.0)
