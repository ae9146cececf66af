"""relative_nav.py: the chaser relative-navigation filter driven by the pure Plant (paper_flyby).

Truth is flyby_sim.plant.Plant with the scenario's nonlinear dynamics, 1 cm position noise at 10 Hz
and the scenario's thruster execution errors (1 % magnitude, 0.5 deg direction). Figures are printed
(pytest -s) so the numbers quoted in docs/estimation.md can be reproduced.
"""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad_vec, solve_ivp

from flyby_estimation.filter_interface import UPDATE_KINDS, EstimationFilter
from flyby_estimation.params import RelativeNavParams
from flyby_estimation.relative_nav import (
    ManeuverRejected,
    RelativeNavFilter,
)
from flyby_sim.dynamics.orbital import cw_accel, cw_transition_matrix, mean_motion_rad_s
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario, scenario_from_dict
from flyby_sim.thrusters import ThrusterModel

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
PAPER = load_scenario(SCENARIOS / 'paper_flyby.yaml')
# Maneuvers (stamp [s], commanded dv_hill [m/s]) of 0.05-0.2 m/s, every 60 s.
MANEUVERS = ((60.0, (-0.1, 0.0, 0.05)), (120.0, (0.0, 0.2, 0.0)), (180.0, (0.05, 0.0, -0.1)),
             (240.0, (0.1, 0.1, 0.1)), (300.0, (-0.05, 0.0, 0.0)))
CONVERGED_S = 30.0  # errors are counted from here on


def scenario(seed=1, **sensor_changes):
    """paper_flyby with 1 cm position noise at 10 Hz (set explicitly) and the given seed."""
    data = PAPER.to_dict()
    data['sensors']['relative_position'].update({'noise_sigma_m': 0.01, 'rate_hz': 10.0, **sensor_changes})
    data['seed'] = seed
    return scenario_from_dict(data, name='paper_flyby (test)')


def bare_config(n, **overrides):
    """A RelativeNavConfig at mean motion n [rad/s], 1 cm position noise, CW, no thrusters: the scenario schema's
    estimation defaults (paper_flyby's) otherwise."""
    values = dict(mean_motion_rad_s=n, position_sigma_m=0.01, radius_m=None, thrusters=None, chaser_mass_kg=None)
    return RelativeNavParams.from_scenario(PAPER).config(**{**values, **overrides})


def run(seed=1, t_end_s=360.0, maneuvers=MANEUVERS, lead_s=1.0, **filter_overrides):
    """Plant and filter side by side; maneuvers commanded lead_s before their stamp to both.

    Returns rows (t, error r (3), error v (3), NEES) at every measurement, and the filter.
    """
    sc = scenario(seed)
    plant = Plant(PlantConfig.from_scenario(sc))
    nav = RelativeNavFilter(RelativeNavParams.from_scenario(sc).config(**filter_overrides))
    pending = list(maneuvers)
    rows = []
    while plant.t < t_end_s - 1e-9:
        while pending and pending[0][0] - lead_s <= plant.t:
            t_stamp, dv = pending.pop(0)
            plant.command_maneuver(t_stamp, dv)
            nav.add_maneuver(t_stamp, dv)
        truth = plant.step()
        for m in plant.measurements():
            if m.kind != 'relative_position':
                continue
            result = nav.update(m.t, m.value)
            assert result.kind in ('initialized', 'accepted', 'outlier'), result  # gate: 1e-4 false alarms
            s = nav.state()
            err = np.concatenate((s.r_hill - truth.r_hill, s.v_hill - truth.v_hill))
            rows.append((m.t, *err, float(err @ np.linalg.solve(s.covariance, err))))
    return np.array(rows), nav


def after_burns(rows, width_s):
    mask = np.zeros(len(rows), dtype=bool)
    for t_stamp, _ in MANEUVERS:
        mask |= (rows[:, 0] >= t_stamp) & (rows[:, 0] < t_stamp + width_s)
    return mask


# --------------------------------------------------------------------------------------------------
# Accuracy and consistency against the plant

def test_steady_state_accuracy_through_maneuvers():
    rows, nav = run(seed=1)
    a = rows[rows[:, 0] >= CONVERGED_S]
    pos_rms_axis = np.sqrt(np.mean(a[:, 1:4] ** 2, axis=0))
    vel_rms_axis = np.sqrt(np.mean(a[:, 4:7] ** 2, axis=0))
    vel_rms_norm = math.sqrt(np.mean(np.sum(a[:, 4:7] ** 2, axis=1)))
    pos_rms_norm = math.sqrt(np.mean(np.sum(a[:, 1:4] ** 2, axis=1)))
    near = a[after_burns(a, 10.0)]
    vel_near_norm = math.sqrt(np.mean(np.sum(near[:, 4:7] ** 2, axis=1)))
    pos_near_norm = math.sqrt(np.mean(np.sum(near[:, 1:4] ** 2, axis=1)))
    print(f'\n[relative_nav] 360 s, 5 maneuvers 0.05-0.2 m/s, after {CONVERGED_S:.0f} s: '
          f'position RMS per axis {np.round(pos_rms_axis * 1e3, 3)} mm (norm {pos_rms_norm * 1e3:.3f} mm), '
          f'velocity RMS per axis {np.round(vel_rms_axis * 1e3, 3)} mm/s (norm {vel_rms_norm * 1e3:.3f} mm/s); '
          f'first 10 s after each burn start: position {pos_near_norm * 1e3:.3f} mm, '
          f'velocity {vel_near_norm * 1e3:.3f} mm/s (norms); max |v err| {np.abs(a[:, 4:7]).max() * 1e3:.2f} mm/s')
    assert nav.counts['outlier'] <= 1e-3 * len(rows) and nav.counts['reset'] == 0
    assert np.all(pos_rms_axis < 0.01) and pos_rms_norm < 0.01
    assert np.all(vel_rms_axis < 1e-3) and vel_rms_norm < 1e-3


def test_nees_consistency_over_seeded_runs():
    """Mean NEES (6 states, expected 6) over 6 seeds; the filter is mildly conservative (text)."""
    nees_run, nees_post = [], []
    for seed in range(1, 7):
        rows, _ = run(seed=seed, t_end_s=300.0, maneuvers=MANEUVERS[:4])
        a = rows[rows[:, 0] >= CONVERGED_S]
        nees_run.append(a[:, 7].mean())
        nees_post.append(a[after_burns(a, 10.0), 7].mean())
    mean_nees = float(np.mean(nees_run))
    print(f'\n[relative_nav] mean NEES over 6 seeded runs: {mean_nees:.2f} (per run '
          f'{np.round(nees_run, 2).tolist()}); in the 10 s after burn starts {np.mean(nees_post):.2f}')
    assert 2.0 < mean_nees < 9.0
    assert 2.0 < np.mean(nees_post) < 12.0


def test_finite_burn_model_beats_impulse_models():
    """The finite-burn model leaves mm-level errors; an impulse at the stamp or midpoint does not."""
    def velocity_rms_after_burns(maneuver_model):
        sc = scenario(1)
        plant = Plant(PlantConfig.from_scenario(sc))
        nav = RelativeNavFilter(RelativeNavParams.from_scenario(sc).config())
        pending = list(MANEUVERS[:3])
        errors = []
        while plant.t < 200.0 - 1e-9:
            if pending and pending[0][0] - 1.0 <= plant.t:
                t_stamp, dv = pending.pop(0)
                burn = plant.command_maneuver(t_stamp, dv)
                if maneuver_model == 'finite':
                    nav.add_maneuver(t_stamp, dv)
                elif maneuver_model == 'impulse_mid':
                    nav.add_maneuver(0.5 * (burn.start_s + burn.end_s), dv, burn_duration_s=0.0)
                else:
                    nav.add_maneuver(t_stamp, dv, burn_duration_s=0.0)
            truth = plant.step()
            for m in plant.measurements():
                if m.kind == 'relative_position':
                    nav.update(m.t, m.value)
                    if any(0.0 <= m.t - ts < 10.0 for ts, _ in MANEUVERS[:3]):
                        errors.append(nav.state().v_hill - truth.v_hill)
        return math.sqrt(np.mean(np.sum(np.square(errors), axis=1)))

    figures = {model: velocity_rms_after_burns(model) for model in ('finite', 'impulse_mid', 'impulse_start')}
    print('\n[relative_nav] velocity error RMS (norm) in the 10 s after burn starts: '
          + ', '.join(f'{k} {v * 1e3:.2f} mm/s' for k, v in figures.items()))
    assert figures['finite'] < 3e-3  # the transient right after the burns; the run's RMS is below 1 mm/s
    assert figures['finite'] < 0.5 * figures['impulse_mid'] < figures['impulse_start']


def test_cw_model_vs_plant_truth_coasting():
    """Prediction only over 60 s from the true state: CW (eq 22) and nonlinear options vs the plant."""
    sc = scenario(1)
    config = dataclasses.replace(PlantConfig.from_scenario(sc), v0_hill=(0.01, 0.005, -0.01))
    plant = Plant(config)
    while plant.t < 60.0 - 1e-9:
        plant.step()
    truth = plant.truth()
    figures = {}
    for dynamics in ('cw', 'nonlinear'):
        nav = RelativeNavFilter(RelativeNavParams.from_scenario(sc).config(dynamics=dynamics))
        nav.initialize(0.0, config.r0_hill, config.v0_hill)
        s = nav.predict(truth.t)
        figures[dynamics] = (np.linalg.norm(s.r_hill - truth.r_hill), np.linalg.norm(s.v_hill - truth.v_hill))
    print('\n[relative_nav] 60 s prediction from truth at 50 m: '
          + ', '.join(f'{k} |dr| {v[0] * 1e6:.3f} um, |dv| {v[1] * 1e9:.3f} nm/s' for k, v in figures.items()))
    assert figures['cw'][0] < 2e-5 and figures['cw'][1] < 1e-6  # linearization: micrometres
    assert figures['nonlinear'][0] < 1e-9 and figures['nonlinear'][1] < 1e-11  # same model as the plant


def test_burn_prediction_matches_plant_without_execution_errors():
    """Finite burns (chained when they overlap) predicted open-loop equal the plant's to 1e-9 m."""
    sc = scenario(1)
    config = PlantConfig.from_scenario(sc)
    exact = dataclasses.replace(config.thrusters, magnitude_error_sigma=0.0, direction_error_sigma_rad=0.0)
    plant = Plant(dataclasses.replace(config, thrusters=exact))
    nav = RelativeNavFilter(RelativeNavParams.from_scenario(sc).config(dynamics='nonlinear'))
    nav.initialize(0.0, config.r0_hill)
    for t_stamp, dv in ((10.0, (-0.1, 0.0, 0.05)), (20.0, (0.0, 0.2, 0.0)), (21.0, (0.05, 0.0, -0.1))):
        plant.command_maneuver(t_stamp, dv)
        nav.add_maneuver(t_stamp, dv)
    for t in (10.5, 20.3, 22.5, 40.0):
        while plant.t < t - 1e-9:
            plant.step()
        nav.propagate_to(plant.t)
        s = nav.state()
        assert np.allclose(s.r_hill, plant.truth().r_hill, atol=1e-9, rtol=0.0)
        assert np.allclose(s.v_hill, plant.truth().v_hill, atol=1e-11, rtol=0.0)
    assert nav.mass_kg == pytest.approx(plant.truth().mass_kg, abs=1e-12)


def test_late_maneuver_is_applied_retroactively():
    """A command stamped before the filter time adds the CW response of its past part."""
    sc = scenario(1)
    nav = RelativeNavFilter(RelativeNavParams.from_scenario(sc).config())
    ref = RelativeNavFilter(RelativeNavParams.from_scenario(sc).config())
    for f in (nav, ref):
        f.initialize(0.0, (50.0, 0.0, 0.0))
    ref.add_maneuver(10.0, (-0.1, 0.0, 0.05))
    nav.propagate_to(10.7)  # half-way through the 1.1 s burn
    nav.add_maneuver(10.0, (-0.1, 0.0, 0.05))
    a, b = nav.predict(30.0), ref.predict(30.0)
    assert np.allclose(a.r_hill, b.r_hill, atol=1e-9) and np.allclose(a.v_hill, b.v_hill, atol=1e-12)
    # The execution-error covariance is injected at 10.7 s instead of 10 s and propagated: equal up to
    # the CW coupling over 0.7 s that the injection neglects.
    assert np.allclose(a.covariance, b.covariance, rtol=1e-5, atol=1e-6)


def test_maneuvers_added_out_of_stamp_order_chain_as_in_stamp_order_and_as_the_plant():
    """Two overlapping commands added in reverse stamp order: the filter equals the one told in stamp order,
    and its burns start and end when the plant's ThrusterModel (no execution errors) runs them."""
    sc = scenario(1)
    commands = ((20.0, (0.0, 0.2, 0.0)), (20.5, (-0.1, 0.0, 0.05)))  # the second waits for the first's end
    in_order, reverse = (RelativeNavFilter(RelativeNavParams.from_scenario(sc).config()) for _ in range(2))
    for nav, sequence in ((in_order, commands), (reverse, commands[::-1])):
        nav.initialize(0.0, (50.0, 0.0, 0.0))
        nav.propagate_to(10.0)
        for t_cmd, dv in sequence:
            nav.add_maneuver(t_cmd, dv)
    times = [(b.t_cmd_s, b.start_s, b.end_s) for b in reverse.burns]
    assert times == [(b.t_cmd_s, b.start_s, b.end_s) for b in in_order.burns]
    assert [t_cmd for t_cmd, _, _ in times] == [20.0, 20.5] and times[1][1] == times[0][2] > 20.5
    assert reverse.mass_kg == in_order.mass_kg

    exact = dataclasses.replace(PlantConfig.from_scenario(sc).thrusters, magnitude_error_sigma=0.0,
                                direction_error_sigma_rad=0.0)
    thrusters = ThrusterModel(exact, np.random.default_rng(0))
    for t_cmd, dv in commands[::-1]:
        thrusters.schedule(t_cmd, dv, 10.0, sc.chaser.mass_kg)
    plant_burns = []
    while thrusters.next_burn is not None:
        plant_burns.append(thrusters.start_next())
        thrusters.finish_active()
    assert [b.t_cmd_s for b in plant_burns] == [20.0, 20.5]
    for ours, plant in zip(reverse.burns, plant_burns, strict=True):
        assert ours.start_s == pytest.approx(plant.start_s, abs=1e-12)
        assert ours.end_s == pytest.approx(plant.end_s, abs=1e-12)
        assert ours.mass_end_kg == pytest.approx(plant.mass_end_kg, abs=1e-12)

    for t in (20.7, 40.0):
        a, b = reverse.predict(t), in_order.predict(t)
        np.testing.assert_array_equal(a.r_hill, b.r_hill)
        np.testing.assert_array_equal(a.v_hill, b.v_hill)
        np.testing.assert_array_equal(a.covariance, b.covariance)


def test_a_burn_begun_before_initialization_belongs_to_the_initial_state():
    """Initialized mid-burn with the state then, the filter models only the rest of the burn."""
    config = RelativeNavParams.from_scenario(scenario(1)).config()
    ref, late = RelativeNavFilter(config), RelativeNavFilter(config)
    ref.initialize(0.0, (50.0, 0.0, 0.0))
    for nav in (ref, late):
        nav.add_maneuver(5.0, (0.0, 0.0, 0.1))  # about 1 s
    mid = ref.predict(5.5)
    late.initialize(5.5, mid.r_hill, mid.v_hill, mid.covariance)
    assert [b.start_s for b in late.burns] == [5.0]
    a, b = late.predict(20.0), ref.predict(20.0)
    assert np.allclose(a.r_hill, b.r_hill, atol=1e-9, rtol=0.0)
    assert np.allclose(a.v_hill, b.v_hill, atol=1e-11, rtol=0.0)
    assert np.allclose(a.covariance, b.covariance, rtol=1e-9, atol=0.0)


def test_process_noise_is_the_white_acceleration_integral():
    """Q(dt) equals int_0^dt Phi B q B' Phi' dtau (eq 22, B = [0; I]) to O(n dt) at dt = 0.1 s."""
    n = mean_motion_rad_s(7.0e6)
    q, dt = 1e-9, 0.1
    nav = RelativeNavFilter(bare_config(n, accel_psd_m2_s3=q))
    nav.initialize(0.0, (50.0, 0.0, 0.0), covariance=np.zeros((6, 6)))
    b = np.vstack((np.zeros((3, 3)), np.eye(3)))
    exact, _ = quad_vec(lambda tau: cw_transition_matrix(n, tau) @ b @ b.T @ cw_transition_matrix(n, tau).T * q,
                        0.0, dt)
    assert np.allclose(nav.predict(dt).covariance, exact, rtol=0.0, atol=2.0 * n * dt * np.abs(exact).max())


def test_time_updates_reusing_a_step_length_equal_fresh_ones_to_the_bit():
    """The (Phi, Q) kept per step length give the numbers computed afresh. Stamps k * 0.05 s as the
    plant's, every 0.1 s: dt takes a few values around 0.1 s, one per rounding."""
    config = RelativeNavParams.from_scenario(scenario(1)).config()
    cached, fresh = RelativeNavFilter(config), RelativeNavFilter(config)
    for nav in (cached, fresh):
        nav.add_maneuver(30.0, (0.0, 0.05, -0.02))
    rng = np.random.default_rng(4)
    for k in range(0, 2400, 2):
        t = k * 0.05
        z = np.array((50.0 - 0.01 * t, 0.0, 0.0)) + rng.normal(0.0, 0.01, 3)
        fresh._transitions.clear()  # every time update computes Phi and Q
        assert cached.update(t, z).kind == fresh.update(t, z).kind
    a, b = cached.state(), fresh.state()
    assert a.r_hill.tolist() == b.r_hill.tolist() and a.v_hill.tolist() == b.v_hill.tolist()
    assert a.covariance.tolist() == b.covariance.tolist()
    assert len(cached._transitions) < 20


# --------------------------------------------------------------------------------------------------
# Rejections

def test_rejections_are_counted_and_the_filter_continues():
    sc = scenario(2)
    plant = Plant(PlantConfig.from_scenario(sc))
    nav = RelativeNavFilter(RelativeNavParams.from_scenario(sc).config())
    kinds = []
    while plant.t < 60.0 - 1e-9:
        truth = plant.step()
        for m in plant.measurements():
            if m.kind != 'relative_position':
                continue
            kinds.append(nav.update(m.t, m.value).kind)
            if abs(m.t - 20.0) < 1e-9:
                bad = nav.update(m.t + 0.01, m.value + np.array([0.5, 0.0, 0.0]))  # 50 cm outlier
                assert bad.kind == 'outlier' and not bad.accepted and bad.nis > nav.gate_threshold
                assert nav.update(m.t + 0.02, [math.nan, 0.0, 0.0]).kind == 'non_finite'
                assert nav.update(m.t + 0.02, [0.0, 0.0]).kind == 'non_finite'
                assert nav.update(math.inf, m.value).kind == 'non_finite'
                stale = nav.update(m.t - 0.05, m.value)
                assert stale.kind == 'stale' and 'before the filter time' in stale.reason
    assert nav.counts == {'initialized': 1, 'accepted': len(kinds) - 1, 'reset': 0,
                          'non_finite': 3, 'non_unit': 0, 'stale': 1, 'outlier': 1}
    s = nav.state()
    assert np.linalg.norm(s.r_hill - truth.r_hill) < 0.01
    assert np.linalg.norm(s.v_hill - truth.v_hill) < 1e-3
    # chi2(3) survival function in closed form: 1 - erf(sqrt(x/2)) + sqrt(2x/pi) exp(-x/2) = 1e-4.
    x = nav.gate_threshold
    assert 1.0 - math.erf(math.sqrt(x / 2)) + math.sqrt(2 * x / math.pi) * math.exp(-x / 2) == pytest.approx(1e-4)


def test_the_nth_consecutive_outlier_restarts_the_filter_from_that_measurement():
    """max_consecutive_outliers = N: a jump's rejected samples agree, and the Nth restarts the filter
    (filter_interface.RejectedRun)."""
    n_outliers = 10  # filter_interface.MIN_RUN_SAMPLES
    nav = RelativeNavFilter(RelativeNavParams.from_scenario(scenario(1)).config(max_consecutive_outliers=n_outliers))
    nav.initialize(0.0, (50.0, 0.0, 0.0), covariance=np.diag([1e-4] * 3 + [1e-8] * 3))
    jumped = np.array([52.0, 0.0, 0.0])  # 2 m away: an unmodelled event
    results = [nav.update(0.1 * (k + 1), jumped) for k in range(n_outliers + 1)]
    assert [r.kind for r in results] == ['outlier'] * (n_outliers - 1) + ['reset', 'accepted']
    assert not any(r.accepted for r in results[:-2]) and results[-2].accepted
    assert results[-2].nis > nav.gate_threshold and f'{n_outliers} consecutive outliers' in results[-2].reason
    np.testing.assert_allclose(results[-2].innovation, jumped - (50.0, 0.0, 0.0), atol=1e-3)
    assert np.allclose(nav.state().r_hill, jumped, atol=0.01)
    assert nav.counts['reset'] == 1 and nav.counts['outlier'] == n_outliers - 1


def test_unexecutable_maneuver_is_rejected_like_the_plant():
    nav = RelativeNavFilter(RelativeNavParams.from_scenario(scenario(1)).config())
    with pytest.raises(ManeuverRejected, match='exceeds max_delta_v_per_maneuver_mps'):
        nav.add_maneuver(10.0, (3.0, 0.0, 0.0))
    assert nav.burns == [] and nav.mass_kg == 100.0


@pytest.mark.parametrize('name', ['paper_flyby', 'seweryn_tumbling'])
def test_filter_and_plant_configs_agree(name):
    """RelativeNavParams reads the scenario itself; every number it shares with the plant's
    configuration is the same."""
    sc = load_scenario(SCENARIOS / f'{name}.yaml')
    ours, plant = RelativeNavParams.from_scenario(sc).config(), PlantConfig.from_scenario(sc)
    assert ours.mean_motion_rad_s == Plant(plant).mean_motion_rad_s
    assert ours.radius_m == plant.radius_m
    assert ours.position_sigma_m == plant.position_sigma_m
    assert ours.chaser_mass_kg == plant.chaser_mass_kg
    assert ours.thrusters == plant.thrusters  # every ThrusterConfig field


def test_config_errors_name_the_field():
    n = mean_motion_rad_s(7.0e6)
    with pytest.raises(ValueError, match='position_sigma_m'):
        bare_config(n, position_sigma_m=0.0)
    with pytest.raises(ValueError, match='radius_m is required'):
        bare_config(n, dynamics='nonlinear')
    with pytest.raises(ValueError, match='gate_probability'):
        bare_config(n, gate_probability=1.0)
    assert bare_config(n).accel_psd_m2_s3 == PAPER.estimation.accel_psd_m2_s3


def test_predict_leaves_the_filter_unchanged_and_propagate_to_moves_it():
    nav = RelativeNavFilter(RelativeNavParams.from_scenario(scenario(1)).config())
    assert isinstance(nav, EstimationFilter) and set(nav.counts) == set(UPDATE_KINDS)
    first = nav.update(0.0, (50.0, 0.0, 0.0))
    assert first.kind == 'initialized' and first.accepted and math.isnan(first.nis) and first.innovation is None
    nav.add_maneuver(5.0, (0.0, 0.0, 0.1))
    ahead = nav.predict(20.0)
    assert nav.t == 0.0 and len(nav.burns) == 1
    assert ahead.t == 20.0 and ahead.v_hill[2] == pytest.approx(0.1, abs=1e-3)
    nav.propagate_to(20.0)
    assert nav.t == 20.0 and nav.burns == []
    np.testing.assert_array_equal(nav.state().r_hill, ahead.r_hill)
    np.testing.assert_array_equal(nav.state().covariance, ahead.covariance)
    for verb in (nav.propagate_to, nav.predict):
        with pytest.raises(ValueError, match='before the filter time'):
            verb(19.0)


# --------------------------------------------------------------------------------------------------
# Covariance invariants

@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**31 - 1),
       dv=st.lists(st.floats(-0.2, 0.2).filter(lambda v: abs(v) > 0.01), min_size=3, max_size=3),
       t_burn=st.floats(5.0, 25.0))
def test_covariance_stays_symmetric_positive_definite(seed, dv, t_burn):
    rng = np.random.default_rng(seed)
    sc = scenario(seed)
    plant = Plant(PlantConfig.from_scenario(sc))
    nav = RelativeNavFilter(RelativeNavParams.from_scenario(sc).config())
    plant.command_maneuver(t_burn, dv)
    nav.add_maneuver(t_burn, dv)
    while plant.t < 40.0 - 1e-9:
        plant.step()
        for m in plant.measurements():
            if m.kind != 'relative_position':
                continue
            z = m.value + (rng.normal(0.0, 0.5, 3) if rng.random() < 0.05 else 0.0)  # some outliers
            nav.update(m.t, z)
            p = nav.state().covariance
            assert np.array_equal(p, p.T)
            assert np.linalg.eigvalsh(p).min() > 0.0


def test_a_measured_thrust_error_is_a_constant_acceleration_over_its_interval():
    """add_thrust_error against independent computation: an acceleration error a_err held over [t0, t1] moves the
    state at t1 by [a_err T^2 / 2; a_err T] (CW coupling over 0.1 s: O(n T) relative) and, the filter later, by
    the CW transition of that; the covariance grows by G C G'."""
    n = 0.0011
    nav = RelativeNavFilter(bare_config(n))
    nav.initialize(0.0, (10.0, 0.0, 0.0))
    nav.propagate_to(0.3)
    before = nav.state()
    a_err = np.array((1e-3, -2e-3, 5e-4))
    cov = np.diag((1e-10, 2e-10, 3e-10))
    nav.add_thrust_error(0.1, 0.2, a_err * 0.1, cov)
    after = nav.state()
    g = cw_transition_matrix(n, 0.1) @ np.vstack((0.05 * np.eye(3), np.eye(3)))
    np.testing.assert_allclose(np.concatenate((after.r_hill, after.v_hill))
                               - np.concatenate((before.r_hill, before.v_hill)), g @ (a_err * 0.1), atol=1e-15)
    np.testing.assert_allclose(after.covariance - before.covariance, g @ cov @ g.T, atol=1e-20)
    # Independent: the same acceleration integrated in the CW equations over [0.1, 0.2], coasted to 0.3.
    def cw(t, y, a):
        return np.concatenate((y[3:], cw_accel(y[:3], y[3:], n, a)))

    y = solve_ivp(cw, (0.1, 0.2), np.zeros(6), args=(a_err,), rtol=1e-12, atol=1e-15).y[:, -1]
    y = solve_ivp(cw, (0.2, 0.3), y, args=(np.zeros(3),), rtol=1e-12, atol=1e-15).y[:, -1]
    np.testing.assert_allclose(g @ (a_err * 0.1), y, rtol=3.0 * n * 0.1, atol=1e-12)  # O(n T): 2 n T here
    with pytest.raises(ValueError, match='after the filter time'):
        nav.add_thrust_error(0.3, 0.4, a_err, cov)
