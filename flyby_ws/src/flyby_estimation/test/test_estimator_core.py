"""estimator_core.py: the estimator's rules, fed by the pure Plant as the headless driver feeds them."""

from pathlib import Path

import numpy as np

from flyby_estimation.estimator_core import ChaserEstimate, EstimatorCore
from flyby_msgs_py.wire import wire_time
from flyby_sim.plant import Plant, plant_config_from_scenario
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'


def test_rigid_body_estimator_gives_one_chaser_estimate_per_imu_sample_from_the_first():
    """DESIGN §10 determinism: the graph's simulator holds time at every IMU stamp + one control period until
    guidance's command for it arrives, so every IMU sample, the first included, must give exactly one
    ChaserEstimate stamped with it (the first IMU sample carries a star-tracker reading; the relative position of
    the same stamp, handled first, initializes the navigation filter). 20 s with a burn in it."""
    scenario = load_scenario(SCENARIOS / 'paper_flyby_6dof.yaml')
    plant = Plant(plant_config_from_scenario(scenario))
    estimator = EstimatorCore(scenario)
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
                assert out == []  # the rigid-body chaser's estimate comes with the IMU
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


def test_a_commanded_force_is_a_known_input_of_the_navigation_filter():
    """guidance/wrench's force (an optimal approach's tracking) held from its stamp for one IMU period: the filter
    adds it as a constant acceleration turned into hill by the attitude estimate of the command's own estimate (one
    period before the stamp); a force below the minimum impulse bit is left out, as the thrusters leave it."""
    from flyby_sim.dynamics.rotation import quat_rotate

    scenario = load_scenario(SCENARIOS / 'jacobsen_optimal.yaml')
    plant = Plant(plant_config_from_scenario(scenario))
    estimator = EstimatorCore(scenario)
    estimates = []
    while plant.t < 2.0:
        plant.step()
        for m in plant.measurements():
            t = wire_time(m.t)
            if m.kind == 'relative_position':
                estimator.on_position(t, m.value)
            elif m.kind == 'chaser_imu':
                estimates += [o for o in estimator.on_imu(t, m.value.q_hill_from_body, m.value.omega_body_meas)
                              if isinstance(o, ChaserEstimate)]
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
