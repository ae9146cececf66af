"""estimator_core.py: the estimator's rules, fed by the pure Plant as the headless driver feeds them."""

from pathlib import Path

import numpy as np

from flyby_estimation.estimator_core import ChaserEstimate, EstimatorCore
from flyby_estimation.params import EstimatorParams
from flyby_msgs_py.wire import wire_time
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'


def test_rigid_body_estimator_gives_one_chaser_estimate_per_imu_sample_from_the_first():
    """DESIGN §10 determinism: the graph's simulator holds time at every IMU stamp + one control period until
    guidance's command for it arrives, so every IMU sample, the first included, must give exactly one
    ChaserEstimate stamped with it (the first IMU sample carries a star-tracker reading; the relative position of
    the same stamp, handled first, initializes the navigation filter). 20 s with a burn in it."""
    scenario = load_scenario(SCENARIOS / 'paper_flyby_6dof.yaml')
    plant = Plant(PlantConfig.from_scenario(scenario))
    estimator = EstimatorCore(EstimatorParams.from_scenario(scenario))
    imu_stamps, estimate_stamps = [], []
    first_imu = None
    dv = np.array([-0.02, 0.0, 0.01])
    plant.command_maneuver(5.0, dv)
    estimator.on_maneuver(5.0, dv)
    while plant.t < 20.0:
        plant.step()
        for m in plant.measurements():
            t = wire_time(m.t)
            if m.kind == 'relative_position':
                out = estimator.on_position(t, m.value)
                # the rigid-body chaser's estimate comes with the IMU (the health monitors' statuses may come here)
                assert not [o for o in out if isinstance(o, ChaserEstimate)]
            elif m.kind == 'chaser_imu':
                if first_imu is None:
                    first_imu = m.value
                imu_stamps.append(t)
                out = estimator.on_imu(t, m.value.q_hill_from_body, m.value.omega_body_meas)
                estimates = [o for o in out if isinstance(o, ChaserEstimate)]
                assert len(estimates) == 1, (t, out)
                estimate_stamps.append(estimates[0].t)
                assert estimates[0].q_hill_from_body is not None and estimates[0].omega_body is not None
    assert first_imu is not None and first_imu.q_hill_from_body is not None  # a star-tracker reading
    assert imu_stamps[0] == wire_time(1.0 / scenario.sensors.chaser_imu.rate_hz)
    assert len(imu_stamps) == 200  # 10 Hz over 20 s
    np.testing.assert_array_equal(estimate_stamps, imu_stamps)


def _step_and_estimate(plant, estimator, accelerometer=True):
    """One plant step, its measurements fed to the estimator as the headless driver feeds them: the chaser
    estimates of its IMU samples (the accelerometer's specific force left out unless ``accelerometer``)."""
    plant.step()
    out = []
    for m in plant.measurements():
        t = wire_time(m.t)
        if m.kind == 'relative_position':
            estimator.on_position(t, m.value)
        elif m.kind == 'chaser_imu':
            f = m.value.specific_force_body if accelerometer else None
            out += [o for o in estimator.on_imu(t, m.value.q_hill_from_body, m.value.omega_body_meas, f)
                    if isinstance(o, ChaserEstimate)]
    return out


def test_point_mass_estimator_gives_a_chaser_estimate_at_every_position_its_prediction_at_an_outlier():
    """The point-mass chaser's estimate comes with each relative position: its update, or at an outlier (2 m off) the
    prediction to its stamp, so its consumers judge its age by its sensor's period (flyby_mission.estimate_age)."""
    scenario = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    plant = Plant(PlantConfig.from_scenario(scenario))
    estimator = EstimatorCore(EstimatorParams.from_scenario(scenario))
    stamps, estimates, outliers, measured = [], [], [], {}
    while plant.t < 20.0:
        plant.step()
        for m in plant.measurements():
            if m.kind != 'relative_position':
                continue
            t = wire_time(m.t)
            value = np.asarray(m.value) + ((2.0, 0.0, 0.0) if 15.0 <= t < 15.35 else 0.0)
            out = estimator.on_position(t, value)
            stamps.append(t)
            measured[t] = value
            estimates += [o for o in out if isinstance(o, ChaserEstimate)]
            outliers += [t for o in out if getattr(o, 'name', '') == 'measurement_rejected']
    assert len(outliers) == 4
    np.testing.assert_array_equal([e.t for e in estimates], stamps)
    for e in (e for e in estimates if e.t in outliers):  # the prediction, not the measurement 2 m off
        assert np.linalg.norm(e.r_hill + (2.0, 0.0, 0.0) - measured[e.t]) < 0.1


def test_a_commanded_force_is_a_known_input_of_the_navigation_filter():
    """guidance/wrench's force (an optimal approach's tracking) held from its stamp for one IMU period: the filter
    adds it as a constant acceleration turned into hill by the attitude estimate of the command's own estimate (one
    period before the stamp); a force below the minimum impulse bit is left out, as the thrusters leave it."""
    from flyby_sim.dynamics.rotation import quat_rotate

    scenario = load_scenario(SCENARIOS / 'jacobsen_optimal.yaml')
    plant = Plant(PlantConfig.from_scenario(scenario))
    estimator = EstimatorCore(EstimatorParams.from_scenario(scenario))
    estimates = []
    while plant.t < 2.0:
        estimates += _step_and_estimate(plant, estimator)
    last = estimates[-1]
    t_cmd = wire_time(last.t + 0.1)
    force_body = np.array((10.0, 0.0, 0.0))  # 0.1 m/s^2 along body +x for 0.1 s: 1 cm/s
    before = estimator.nav.predict(t_cmd + 0.1)
    assert estimator.on_wrench(t_cmd, force_body) == []
    after = estimator.nav.predict(t_cmd + 0.1)
    dv_hill = quat_rotate(last.q_hill_from_body, force_body) * 0.1 / scenario.chaser.mass_kg
    np.testing.assert_allclose(after.v_hill - before.v_hill, dv_hill, atol=5e-6)  # CW over the hold: 1e-6
    burns = len(estimator.nav.burns)
    assert estimator.on_wrench(t_cmd + 0.1, (0.05, 0.0, 0.0)) == []  # 0.005 N s < the 0.01 N s bit
    assert len(estimator.nav.burns) == burns


def _fly_constant_force(accelerometer, late_commands=False, duration_s=20.0):
    """jacobsen_optimal's chaser (thruster errors x5, drawn once) pushed by 10 N along body +x, one force command
    per IMU period held from the next IMU stamp, as guidance's tracking sends them; the estimator fed as the
    headless driver feeds it. Returns (truth v_hill, the estimate) at the last IMU stamp."""
    from flyby_sim.scenario import load_yaml_mapping, scenario_from_dict

    raw = load_yaml_mapping(SCENARIOS / 'jacobsen_optimal.yaml')
    raw['chaser']['thrusters']['magnitude_error_sigma'] = 0.05
    raw['chaser']['thrusters']['direction_error_sigma_deg'] = 2.5
    raw.setdefault('estimation', {})['accel_psd_m2_s3'] = 1e-9  # the default: no process noise to follow a bias with
    scenario = scenario_from_dict(raw, name='jacobsen_optimal x5 thruster errors')
    plant = Plant(PlantConfig.from_scenario(scenario))
    estimator = EstimatorCore(EstimatorParams.from_scenario(scenario))
    force_body = np.array((10.0, 0.0, 0.0))
    estimate, t_start, late = None, None, []
    while plant.t < duration_s:
        for estimate in _step_and_estimate(plant, estimator, accelerometer):
            t = estimate.t
            for t_cmd in late:
                estimator.on_wrench(t_cmd, force_body)
            late = []
            t_start = t_start or wire_time(t + 1.0)
            if t >= t_start:
                t_cmd = wire_time(t + 0.1)
                plant.command_wrench(t_cmd, force_body, (0.0, 0.0, 0.0))
                if late_commands:
                    late.append(t_cmd)  # heard after the IMU sample that measured it
                else:
                    estimator.on_wrench(t_cmd, force_body)
    return plant.truth().v_hill, estimate


def test_the_accelerometer_measures_the_thrusters_errors_under_continuous_thrust():
    """The thrusters' errors are drawn once per run, so under a steady force command they are an acceleration bias
    (here 5 % and 2.5 deg per thruster: up to about 7 mm/s^2 on 0.1 m/s^2). Taken as the commanded force with an
    independent error per command, the navigation filter lags the truth; with each IMU interval's measured delta-v
    (estimator_core module doc) it follows it within its own covariance."""
    v_true, with_accel = _fly_constant_force(accelerometer=True)
    err = with_accel.v_hill - v_true
    sigma = np.sqrt(np.diag(with_accel.covariance)[3:])
    assert np.linalg.norm(err) < 1e-3, err
    assert np.all(np.abs(err) < 4.0 * sigma), (err, sigma)
    v_true_blind, blind = _fly_constant_force(accelerometer=False)
    np.testing.assert_array_equal(v_true_blind, v_true)  # the same flight: the estimate does not steer it
    assert np.linalg.norm(blind.v_hill - v_true) > 5.0 * np.linalg.norm(err)


def test_a_force_command_heard_after_its_accelerometer_sample_is_taken_as_measured():
    """In the graph guidance's force command and the simulator's IMU sample come on different topics; a command
    that arrives after the sample that measured its interval is added with the measured delta-v, so the estimate
    is the one of the command heard first to the integration's rounding."""
    _, in_order = _fly_constant_force(accelerometer=True, duration_s=4.0)
    _, late = _fly_constant_force(accelerometer=True, late_commands=True, duration_s=4.0)
    np.testing.assert_allclose(late.v_hill, in_order.v_hill, atol=1e-6)
    np.testing.assert_allclose(late.r_hill, in_order.r_hill, atol=1e-6)


def test_a_non_finite_accelerometer_sample_is_refused_and_reaches_neither_the_navigation_nor_the_thrust_monitor():
    scenario = load_scenario(SCENARIOS / 'paper_flyby_6dof.yaml')
    plant = Plant(PlantConfig.from_scenario(scenario))
    estimator = EstimatorCore(EstimatorParams.from_scenario(scenario))
    while plant.t < 5.0:
        _step_and_estimate(plant, estimator)
    pending = estimator.health.book.pending
    assert pending is not None
    imu = None
    while imu is None:
        plant.step()
        imu = next((m for m in plant.measurements() if m.kind == 'chaser_imu'), None)
    out = estimator.on_imu(wire_time(imu.t), imu.value.q_hill_from_body, imu.value.omega_body_meas,
                           np.array([np.nan, 0.0, 0.0]))
    assert any('non_finite' in repr(o) for o in out)
    assert estimator.health.book.pending is pending
