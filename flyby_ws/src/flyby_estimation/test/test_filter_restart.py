"""filter_interface's restart rule (RejectedRun) in the three filters it serves: a burst of random outliers, as the
fault injection draws them (flyby_sim.plant.faults, sensor_outliers), never restarts a filter, which comes out of
it converged; a genuine jump, whose rejected samples agree with each other, restarts it at its 20th consecutive
rejection (max_consecutive_outliers, 2 s at 10 Hz)."""

import copy
import functools
import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chi2

from flyby_estimation.chaser_attitude_filter import ChaserAttitudeFilter
from flyby_estimation.filter_interface import MIN_RUN_SAMPLES, RejectedRun, quadratic_fit_chi2
from flyby_estimation.params import ChaserAttitudeFilterParams, RelativeNavParams, TargetFilterParams
from flyby_estimation.relative_nav import RelativeNavFilter
from flyby_estimation.target_filter import ConvergenceThresholds, TargetAttitudeFilter
from flyby_sim.dynamics.orbital import quat_eci_from_hill
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_axis_angle,
    quat_from_rotation_vector,
    quat_multiply,
    rotation_vector_from_quat,
)
from flyby_sim.faults import random_unit
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario, scenario_from_dict

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
DEG = math.radians(1.0)
N_RUN = 20  # max_consecutive_outliers, the filters' default
BURST_S = (150.0, 160.0)  # the injected burst: 10 s from 150 s, both targets' filters converged by then
CONVERGED = ConvergenceThresholds.from_scenario(load_scenario(SCENARIOS / 'paper_flyby.yaml'))


def scenario(name, fault_sensor=None, value=20.0):
    """The shipped scenario, relative position at 1 cm and 10 Hz, and a sensor_outliers burst of BURST_S on
    fault_sensor (None: no fault)."""
    data = load_scenario(SCENARIOS / f'{name}.yaml').to_dict()
    data['sensors']['relative_position'].update({'noise_sigma_m': 0.01, 'rate_hz': 10.0})
    if fault_sensor is not None:
        data['faults'] = [{'type': 'sensor_outliers', 'sensor': fault_sensor, 'start_s': BURST_S[0],
                           'duration_s': BURST_S[1] - BURST_S[0], 'value': value}]
    return scenario_from_dict(data, name=f'{name} (test_filter_restart)')


def samples(plant, kind, t_end_s):
    """The plant's samples of kind up to t_end_s [s], stepping it."""
    while plant.t < t_end_s - 1e-9:
        plant.step()
        yield from (m for m in plant.measurements() if m.kind == kind)


def target_errors(f, plant):
    """(attitude error [rad], rate error [rad/s]) of the target filter's estimate from the plant's truth."""
    truth, s = plant.truth(), f.state()
    q_true = quat_multiply(quat_eci_from_hill(truth.t, plant.mean_motion_rad_s), truth.q_hill_from_body)
    e = rotation_vector_from_quat(quat_multiply(quat_conjugate(s.q_eci_from_body), q_true))
    return float(np.linalg.norm(e)), float(np.linalg.norm(s.omega_body - truth.omega_body))


def converged_target(name, fault_sensor=None):
    """(plant, target filter) after the vision samples up to the burst's start, the filter converged."""
    sc = scenario(name, fault_sensor)
    plant, f = Plant(PlantConfig.from_scenario(sc)), TargetAttitudeFilter(TargetFilterParams.from_scenario(sc).config())
    for m in samples(plant, 'target_attitude', BURST_S[0] - 0.01):
        f.update(m.t, m.value)
    assert f.convergence(CONVERGED)
    return plant, f


# -- the fit and the run ---------------------------------------------------------------------------------------------
def test_quadratic_fit_chi2_is_zero_on_a_quadratic_and_chi_square_on_noise():
    rng = np.random.default_rng(4)
    t = 60.0 + 0.1 * np.arange(N_RUN)
    quadratic = np.outer(t - 61.0, (0.3, -1.0, 2.0)) + np.outer((t - 61.0) ** 2, (0.5, 0.0, -4.0)) + (7.0, 8.0, 9.0)
    assert quadratic_fit_chi2(t, quadratic, 0.01) < 1e-12
    sums = [quadratic_fit_chi2(t, quadratic + 0.01 * rng.standard_normal((N_RUN, 3)), 0.01) for _ in range(2000)]
    assert np.mean(sums) == pytest.approx(3 * (N_RUN - 3), rel=0.03)  # chi2(51): mean 51, its mean's sigma 0.2
    assert np.mean(np.array(sums) > chi2.ppf(0.9999, 51)) < 2e-3


def test_a_run_needs_min_run_samples_and_tests_from_the_nth():
    with pytest.raises(ValueError, match=f'max_consecutive_outliers must be an integer >= {MIN_RUN_SAMPLES}'):
        RejectedRun(MIN_RUN_SAMPLES - 1, 0.01, 0.9999, ('hill',), rotation=False)
    run = RejectedRun(MIN_RUN_SAMPLES, 0.01, 0.9999, ('hill',), rotation=False)
    assert run.threshold == pytest.approx(chi2.ppf(0.9999, 3 * (MIN_RUN_SAMPLES - 3)))
    added = [run.add(0.1 * k, (np.array((0.5, 0.0, 0.0)),)) for k in range(MIN_RUN_SAMPLES + 1)]
    assert added == [False] * (MIN_RUN_SAMPLES - 1) + [True, True]
    assert 'agreeing in the hill frame' in run.agreement
    run.clear()
    assert not run.add(1.0, (np.zeros(3),))


def test_random_outliers_never_agree_at_the_shortest_run():
    """MIN_RUN_SAMPLES random outliers of 5 and 20 sigma (each off in its own direction, as the injection draws them):
    none of 1000 runs agrees (at 4 samples 42 % of 5-sigma runs did)."""
    rng = np.random.default_rng(40)
    sigma_m = 0.01
    for n_sigma in (5.0, 20.0):
        agreed = 0
        for _ in range(1000):
            run = RejectedRun(MIN_RUN_SAMPLES, sigma_m, 0.9999, ('hill',), rotation=False)
            for k in range(MIN_RUN_SAMPLES):
                direction = rng.normal(size=3)
                error = direction / np.linalg.norm(direction) * n_sigma * sigma_m + rng.normal(scale=sigma_m, size=3)
                agreed += run.add(0.1 * k, (error,))
        assert agreed == 0, n_sigma


# -- target attitude -------------------------------------------------------------------------------------------------
@pytest.mark.parametrize('name', ['paper_flyby', 'seweryn_tumbling'])
def test_a_10_s_burst_of_20_sigma_outliers_leaves_the_converged_target_filter_converged(name):
    """The injection's burst (each sample turned by 20 sigma about a direction drawn per sample) on a converged
    filter: every sample of the burst an outlier, no restart (the count rule restarted at each 20th), and after
    it the filter takes the samples again, converged, its estimate within its 3-sigma bounds of the truth."""
    plant, f = converged_target(name, 'target_attitude')
    burst = [f.update(m.t, m.value) for m in samples(plant, 'target_attitude', BURST_S[1] + 0.05)]
    assert len(burst) == 100 and all(r.kind == 'outlier' for r in burst if r.t >= BURST_S[0])
    after = [f.update(m.t, m.value) for m in samples(plant, 'target_attitude', BURST_S[1] + 10.0)]
    assert sum(r.kind == 'accepted' for r in after) >= len(after) - 1 and f.counts['reset'] == 0
    attitude_error, rate_error = target_errors(f, plant)
    attitude_3sigma, rate_3sigma = f.three_sigma()
    assert f.convergence(CONVERGED) and attitude_error < attitude_3sigma and rate_error < rate_3sigma


def jumped(q_hill_from_body, t, n, turn, frame):
    """The sample of an attitude turned by turn: in the body frame (q turn, a mis-tracked body) or the inertial
    frame (turn q_eci_from_body: the attitude jumped, its body rates kept)."""
    if frame == 'body':
        return quat_multiply(q_hill_from_body, turn)
    q_eci_from_hill = quat_eci_from_hill(t, n)
    return quat_multiply(quat_conjugate(q_eci_from_hill), quat_multiply(turn, quat_multiply(q_eci_from_hill,
                                                                                           q_hill_from_body)))


@pytest.mark.parametrize('name', ['paper_flyby', 'seweryn_tumbling'])
@pytest.mark.parametrize('frame', ['body', 'inertial'])
def test_a_30_deg_jump_restarts_the_target_filter_at_its_20th_rejection(name, frame):
    """From 150 s on every vision sample (noise included) is the attitude turned by 30 deg, in the body or the
    inertial frame: the samples agree with each other, and the 20th consecutive rejection restarts the filter
    from itself (the bound: max_consecutive_outliers). After an inertial jump (body rates kept: a torque-free
    motion) the filter then follows the jumped attitude; a body-frame turn of the asymmetric tumbler is no
    torque-free motion of the known inertia, which the filter cannot follow for long (it restarts again)."""
    plant, f = converged_target(name)
    n, turn = plant.mean_motion_rad_s, quat_from_axis_angle([1.0, 1.0, 0.0], 30 * DEG)
    measurements = samples(plant, 'target_attitude', BURST_S[0] + 10.0)
    run = [(m.t, jumped(m.value, m.t, n, turn, frame)) for m in itertools.islice(measurements, N_RUN)]
    results = [f.update(t, q) for t, q in run]
    assert [r.kind for r in results] == ['outlier'] * (N_RUN - 1) + ['reset']
    assert f'{N_RUN} consecutive outliers agreeing in the' in results[-1].reason
    assert np.allclose(f.state().q_hill_from_body, run[-1][1], atol=1e-12) and f.counts['reset'] == 1
    if frame == 'inertial':
        after = [f.update(m.t, jumped(m.value, m.t, n, turn, frame)) for m in measurements]
        assert len(after) == 80 and all(r.kind == 'accepted' for r in after)
        truth = plant.truth()
        q_jumped = jumped(truth.q_hill_from_body, truth.t, n, turn, frame)
        e = rotation_vector_from_quat(quat_multiply(quat_conjugate(f.state().q_hill_from_body), q_jumped))
        assert np.linalg.norm(e) < DEG


@functools.cache
def converged_paper_target():
    return converged_target('paper_flyby')[1]


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), sigmas=st.floats(5.0, 200.0), count=st.integers(N_RUN, 150))
def test_property_random_outlier_bursts_never_restart_the_target_filter(seed, sigmas, count):
    """Bursts of count samples at 10 Hz, each the filter's predicted attitude with its noise turned by sigmas
    times the sensor's sigma about a direction drawn per sample (the injection's outliers): no restart, and
    a clean sample after the burst is accepted."""
    f = copy.deepcopy(converged_paper_target())
    rng, sigma = np.random.default_rng(seed), f.config.attitude_sigma_rad
    t0 = f.t
    for k in range(1, count + 1):
        t = t0 + 0.1 * k
        noisy = quat_multiply(f.predict(t).q_hill_from_body, quat_from_rotation_vector(sigma * rng.standard_normal(3)))
        result = f.update(t, quat_multiply(noisy, quat_from_rotation_vector(sigmas * sigma * random_unit(rng))))
        assert result.kind in ('outlier', 'accepted') and result.kind != 'reset'
    t = t0 + 0.1 * (count + 1)
    assert f.update(t, f.predict(t).q_hill_from_body).kind == 'accepted' and f.counts['reset'] == 0


# -- relative position -----------------------------------------------------------------------------------------------
def navigation(fault_sensor=None):
    """(plant, relative navigation filter) of paper_flyby after the position samples up to the burst's start."""
    sc = scenario('paper_flyby', fault_sensor)
    plant, nav = Plant(PlantConfig.from_scenario(sc)), RelativeNavFilter(RelativeNavParams.from_scenario(sc).config())
    for m in samples(plant, 'relative_position', BURST_S[0] - 0.01):
        nav.update(m.t, m.value)
    return plant, nav


def test_a_10_s_burst_of_20_sigma_position_outliers_does_not_restart_the_navigation_filter():
    plant, nav = navigation('relative_position')
    burst = [nav.update(m.t, m.value) for m in samples(plant, 'relative_position', BURST_S[1] + 0.05)]
    assert len(burst) == 100 and all(r.kind == 'outlier' for r in burst if r.t >= BURST_S[0])
    after = [nav.update(m.t, m.value) for m in samples(plant, 'relative_position', BURST_S[1] + 10.0)]
    assert all(r.kind == 'accepted' for r in after) and nav.counts['reset'] == 0
    s, truth = nav.state(), plant.truth()
    sigma_r, sigma_v = np.sqrt(np.diag(s.covariance)[:3]), np.sqrt(np.diag(s.covariance)[3:])
    assert np.all(np.abs(s.r_hill - truth.r_hill) < 4 * sigma_r)
    assert np.all(np.abs(s.v_hill - truth.v_hill) < 4 * sigma_v)


@pytest.mark.parametrize('jump_m, drift_mps', [((0.3, -0.2, 0.1), (0.0, 0.0, 0.0)),
                                               ((0.0, 0.0, 0.0), (0.0, 0.05, 0.0))])
def test_a_position_jump_or_an_unknown_velocity_change_restarts_the_navigation_filter(jump_m, drift_mps):
    """From 150 s on the samples (noise included) are off by jump_m [m] plus drift_mps [m/s] times the time since:
    a jump restarts the filter at the 20th rejection; an unknown velocity change, whose first samples may pass
    the gate, at the 20th consecutive one (3.1 s after the change here); the samples after it are accepted."""
    plant, nav = navigation()
    results = [nav.update(m.t, m.value + np.asarray(jump_m) + np.asarray(drift_mps) * (m.t - BURST_S[0]))
               for m in samples(plant, 'relative_position', BURST_S[0] + 10.0)]
    kinds = [r.kind for r in results]
    first = kinds.index('reset')
    assert kinds[first - N_RUN + 1:first] == ['outlier'] * (N_RUN - 1) and results[first].t < BURST_S[0] + 3.5
    assert f'{N_RUN} consecutive outliers agreeing in the hill frame' in results[first].reason
    if not any(drift_mps):
        assert first == N_RUN - 1
    assert all(k == 'accepted' for k in kinds[first + 1:]) and nav.counts['reset'] == 1


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), sigmas=st.floats(5.0, 200.0), count=st.integers(N_RUN, 150))
def test_property_random_outlier_bursts_never_restart_the_navigation_filter(seed, sigmas, count):
    """As the target filter's property, on a navigation filter holding station at 50 m (1 cm noise)."""
    config = RelativeNavParams.from_scenario(scenario('paper_flyby')).config()
    nav, rng = RelativeNavFilter(config), np.random.default_rng(seed)
    nav.initialize(0.0, (50.0, 0.0, 0.0), covariance=np.diag([1e-4] * 3 + [1e-8] * 3))
    for k in range(1, count + 1):
        t = 0.1 * k
        z = nav.predict(t).r_hill + config.position_sigma_m * (rng.standard_normal(3) + sigmas * random_unit(rng))
        assert nav.update(t, z).kind != 'reset'
    t = 0.1 * (count + 1)
    assert nav.update(t, nav.predict(t).r_hill).kind == 'accepted' and nav.counts['reset'] == 0


# -- chaser attitude (star tracker) ----------------------------------------------------------------------------------
def test_a_10_s_burst_of_20_sigma_star_tracker_outliers_does_not_restart_the_chaser_attitude_filter():
    """paper_flyby_6dof's IMU (star tracker at 2 Hz, 0.01 deg) with the injection's burst on the star tracker:
    every burst sample an outlier, no restart, the samples after it accepted, the estimate within 4 sigma of the
    truth."""
    data = load_scenario(SCENARIOS / 'paper_flyby_6dof.yaml').to_dict()
    data['faults'] = [{'type': 'sensor_outliers', 'sensor': 'star_tracker', 'start_s': BURST_S[0],
                       'duration_s': BURST_S[1] - BURST_S[0]}]
    sc = scenario_from_dict(data, name='paper_flyby_6dof (test_filter_restart)')
    plant = Plant(PlantConfig.from_scenario(sc))
    f = ChaserAttitudeFilter(ChaserAttitudeFilterParams.from_scenario(sc).config())
    results = [f.on_imu(m.t, m.value.omega_body_meas, m.value.q_hill_from_body)[1]
               for m in samples(plant, 'chaser_imu', BURST_S[1] + 20.0)]
    star = [r for r in results if r is not None]
    burst = [r for r in star if BURST_S[0] <= r.t < BURST_S[1]]
    assert len(burst) == 20 and all(r.kind == 'outlier' for r in burst) and f.counts['reset'] == 0
    assert all(r.kind == 'accepted' for r in star if r.t >= BURST_S[1])
    e, q_true = f.estimate(), plant.truth().q_hill_from_chaser_body
    error = rotation_vector_from_quat(quat_multiply(quat_conjugate(e.q_hill_from_body), q_true))
    assert np.all(np.abs(error) < 4.0 * e.attitude_sigma_rad)
