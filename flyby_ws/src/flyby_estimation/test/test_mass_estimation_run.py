"""mass_estimation_run: the prior at the lock from the capture's estimates and the arm's deflection, and the
mass-property filter's run over the excitation on IMU samples as the plant gives them (interval means)."""

import math

import numpy as np
import pytest

from flyby_estimation.mass_estimation_run import (
    CaptureSnapshot,
    ImuSample,
    MassEstimationRun,
    mass_property_prior,
    principal_axes,
)
from flyby_estimation.mass_properties_errors import principal_axis_errors_rad
from flyby_estimation.mass_properties_excitation import excitation_firings, thruster_firings
from flyby_estimation.params import MassEstimationParams
from flyby_sim.dynamics.combined_body import (
    CombinedState,
    combined_mass_properties,
    inertia_from_principal,
    simulate_combined_body,
)
from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_multiply, quat_rotate, quat_to_matrix
from flyby_sim.scenario import load_scenario
from flyby_testing import SCENARIOS

TUG = load_scenario(SCENARIOS / 'paper_flyby_tug.yaml')
TUG_PARAMS = MassEstimationParams.from_scenario(TUG)
# The capture of paper_flyby_tug seed 1, roughly: the chaser 3.1 m off the target's CoM, the target turned.
SNAPSHOT = CaptureSnapshot(813.1, np.array([0.52, 3.07, -0.03]), quat_from_rotation_vector((0.0, 0.0, -1.4)),
                           quat_from_rotation_vector((0.3, -0.2, 0.9)), (2e-4 ** 2) * np.eye(3))


def test_principal_axes_are_a_right_handed_frame_that_rebuilds_the_inertia():
    inertia = inertia_from_principal((1000.0, 1200.0, 2000.0), quat_from_rotation_vector((0.4, -0.2, 0.3)))
    moments, q = principal_axes(inertia)
    np.testing.assert_allclose(moments, (1000.0, 1200.0, 2000.0), rtol=1e-12)
    assert np.linalg.det(quat_to_matrix(q)) == pytest.approx(1.0)
    np.testing.assert_allclose(inertia_from_principal(moments, q), inertia, atol=1e-9)


def test_the_prior_is_the_capture_moved_by_the_arm_and_the_seed_draws_its_mass_and_moments():
    """X_s = -r_chaser (chaser axes) at the capture; the arm's deflection moves the grasp handle (the target with it)
    by d and turns it by R(e) about itself: the handle ends at its old place plus d, the axes turn by R(e)."""
    still = mass_property_prior(TUG_PARAMS, SNAPSHOT)
    c_body_from_hill = quat_to_matrix(SNAPSHOT.q_hill_from_chaser).T
    np.testing.assert_allclose(still.target_com_body_m, -c_body_from_hill @ SNAPSHOT.r_chaser_hill, atol=1e-12)
    assert still == mass_property_prior(TUG_PARAMS, SNAPSHOT)  # the same draws from the seed
    assert still.target_mass_kg != TUG.target.mass_kg
    assert abs(still.target_mass_kg / TUG.target.mass_kg - 1.0) < 4 * TUG.post_capture.mass_estimation.prior_mass_sigma
    assert still.axes_sigma_rad == pytest.approx(2e-4)  # the target attitude estimate's own (the key omitted)
    d, e = np.array([0.002, -0.001, 0.003]), np.array([0.0, 0.01, -0.005])
    moved = mass_property_prior(TUG_PARAMS, SNAPSHOT, d, e)
    r_g = np.array(TUG.target.grasp_point_body_m)
    _, q_tp = principal_axes(TUG.target_inertia)
    q_ct_before = quat_multiply(still.q_body_from_principal, q_tp * np.array([-1.0, -1.0, -1.0, 1.0]))
    q_ct_after = quat_multiply(moved.q_body_from_principal, q_tp * np.array([-1.0, -1.0, -1.0, 1.0]))
    handle_before = np.array(still.target_com_body_m) + quat_rotate(q_ct_before, r_g)
    handle_after = np.array(moved.target_com_body_m) + quat_rotate(q_ct_after, r_g)
    np.testing.assert_allclose(handle_after, handle_before + d, atol=1e-12)
    np.testing.assert_allclose(quat_to_matrix(q_ct_after),
                               quat_to_matrix(quat_from_rotation_vector(e)) @ quat_to_matrix(q_ct_before), atol=1e-12)


def _samples(prior, t_start, duration_s=26.0):
    """Noise-free IMU samples of the combined body whose target is the prior's, excited by paper_flyby_tug's
    sequence from t_start as the plant fires it: gyro, the accelerometer's mean over each 0.1 s interval (the
    delta-v and the rate's change over it), a star tracker every fifth."""
    sc = TUG
    firings = thruster_firings(sc.thruster_layout, excitation_firings('table1', t_start), 0.1)
    props = combined_mass_properties(sc.chaser.mass_kg, sc.chaser_inertia, prior.target_mass_kg,
                                     prior.target_com_body_m, inertia_from_principal(
                                         prior.principal_moments_kg_m2, prior.q_body_from_principal))
    t = t_start - 2.0 + 0.1 * np.arange(int(round((duration_s + 2.0) / 0.1)) + 1)
    state0 = CombinedState(np.zeros(3), np.zeros(3), quat_from_rotation_vector((0.1, 0.2, 0.3)), np.zeros(3))
    truth, _, _ = simulate_combined_body(props, state0, firings, t)
    p = -props.com_body_m
    out = []
    for k in range(1, len(t)):
        q, w, w0 = truth[k, 6:10], truth[k, 10:13], truth[k - 1, 10:13]
        dv_body = quat_rotate(q * np.array([-1.0, -1.0, -1.0, 1.0]), truth[k, 3:6] - truth[k - 1, 3:6])
        accel = dv_body / 0.1 + np.cross((w - w0) / 0.1, p) + np.cross(w, np.cross(w, p))
        out.append(ImuSample(float(t[k]), q, w, accel, q if k % 5 == 0 else None))
    return out


def test_the_run_takes_the_samples_from_the_excitations_start_whenever_that_is_announced():
    """Samples that came before guidance's announcement wait; the estimates are the same either way, the last one
    final window_s after the start, and on noise-free samples of the prior's own body they stay on it."""
    prior = mass_property_prior(TUG_PARAMS, SNAPSHOT)
    t_start = 1012.7
    samples = _samples(prior, t_start)
    late, early = MassEstimationRun(TUG_PARAMS, 100.0), MassEstimationRun(TUG_PARAMS, 100.0)
    out_late = [e for s in samples[:30] for e in late.on_sample(s)] + late.start(t_start, (0.0, 0.0, 0.0), prior)
    out_early = early.start(t_start, (0.0, 0.0, 0.0), prior)
    out_late += [e for s in samples[30:] for e in late.on_sample(s)]
    out_early += [e for s in samples for e in early.on_sample(s)]
    assert [e.t for e in out_late] == [e.t for e in out_early]
    assert out_late[-1].final and out_late[-1].t == pytest.approx(t_start + TUG.post_capture.mass_estimation.window_s)
    assert sum(e.final for e in out_late) == 1 and late.on_sample(samples[-1]) == []
    a, b = out_late[-1].estimate, out_early[-1].estimate
    assert a.target_mass_kg == b.target_mass_kg
    assert late.filter.imu_counts['outlier'] == 0
    assert a.target_mass_kg == pytest.approx(prior.target_mass_kg, rel=2e-3)
    np.testing.assert_allclose(a.principal_moments_kg_m2, prior.principal_moments_kg_m2, rtol=5e-3)
    np.testing.assert_allclose(a.target_com_body_m, prior.target_com_body_m, atol=5e-3)
    assert math.degrees(principal_axis_errors_rad(a.q_body_from_principal, prior.q_body_from_principal).max()) < 0.1
