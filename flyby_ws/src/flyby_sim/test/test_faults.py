"""Injected faults (flyby_sim.faults, plant.faults): each kind's effect on the truth and the samples, its schedule,
its events, its draws, and the scenario's refusals."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from flyby_mission.run_events import plant_faults
from flyby_msgs_py import events as ev
from flyby_msgs_py.wire import wire_event
from flyby_sim.chaser_body import RigidChaserConfig
from flyby_sim.dynamics.propulsion import ThrusterConfig
from flyby_sim.faults import FaultSpec
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import ScenarioError, load_scenario, scenario_from_dict
from flyby_testing import step_to

REPO = Path(__file__).resolve().parents[4]
HOLD_S = 0.05
EXACT = ThrusterConfig(max_thrust_n=10.0, isp_s=220.0, min_impulse_bit_ns=0.0, max_delta_v_per_maneuver_mps=2.0,
                       magnitude_error_sigma=0.0, direction_error_sigma_rad=0.0)
PAPER_FLYBY = load_scenario(REPO / 'scenarios' / 'paper_flyby.yaml')


def _plant(*faults):
    """Seed 000 section 5's orbit and target, the schema's rigid-body chaser (exact thrusters, the default 12) at
    rest 50 m ahead on V-bar, with the faults."""
    body = dataclasses.replace(RigidChaserConfig.from_scenario(PAPER_FLYBY), q_hill_from_body0=(0.0, 0.0, 0.0, 1.0),
                               omega_body0=(0.0, 0.0, 0.0), wheel_momentum0_n_m_s=None,
                               inertia=((10.0, 0.0, 0.0), (0.0, 12.0, 0.0), (0.0, 0.0, 9.0)))
    return Plant(dataclasses.replace(PlantConfig.from_scenario(PAPER_FLYBY), chaser_mass_kg=100.0,
                                     r0_hill=(50.0, 0.0, 0.0), v0_hill=(0.0, 0.0, 0.0), thrusters=EXACT,
                                     position_sigma_m=0.01, seed=1, chaser_body=body, faults=tuple(faults)))


def _fire(plant, force_body, t_end, torque=(0.0, 0.0, 0.0)):
    """Hold the wrench from now to t_end; the step samples and events."""
    plant.command_wrench(plant.t, force_body, torque, hold_s=HOLD_S)
    return step_to(plant, t_end)


def _mean_force(samples):
    return np.mean([s.force_body_n for s in samples], axis=0)


def test_a_thruster_off_gives_nothing_and_its_wrench_is_short_by_its_share():
    """+x force from the two +x pushers (thrusters 0 and 1 of the default layout): with thruster 0 off the body gets
    half, and a torque the healthy pair cancels."""
    healthy, _ = _fire(_plant(), (4.0, 0.0, 0.0), 2.0)
    faulty, events = _fire(_plant(FaultSpec('thruster_off', index=0, start_s=0.0)), (4.0, 0.0, 0.0), 2.0)
    np.testing.assert_allclose(_mean_force(healthy), [4.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(_mean_force(faulty), [2.0, 0.0, 0.0], atol=1e-9)
    assert faulty[-1].thruster_thrust_n[0] == 0.0
    assert np.linalg.norm(np.mean([s.torque_body_n_m for s in faulty], axis=0)) > 0.1
    assert [e.name for e in events if e.name.startswith('fault')] == [ev.FAULT_INJECTED]


def test_a_degraded_thruster_gives_its_share_and_a_stuck_one_leaks_with_nothing_commanded():
    degraded, _ = _fire(_plant(FaultSpec('thruster_degraded', index=0, start_s=0.0, value=0.25)), (4.0, 0.0, 0.0),
                        1.0)
    np.testing.assert_allclose(degraded[-1].thruster_thrust_n[:2], [0.5, 2.0], atol=1e-9)
    leak = _plant(FaultSpec('thruster_stuck_on', index=3, start_s=1.0, duration_s=2.0, value=0.2))
    samples, events = step_to(leak, 5.0)
    thrust = np.array([s.thruster_thrust_n[3] for s in samples])
    t = np.array([s.t for s in samples])
    np.testing.assert_allclose(thrust[(t > 1.0 + 1e-9) & (t < 3.0 - 1e-9)], 0.2 * 10.0, atol=1e-9)
    assert not thrust[t <= 1.0 + 1e-9].any() and not thrust[t > 3.0 + 1e-9].any()
    assert np.linalg.norm(samples[-1].v_hill) > 1e-3  # 2 N for 2 s on 100 kg
    assert [(e.name, round(e.t, 6)) for e in events if e.name.startswith('fault')] == [
        (ev.FAULT_INJECTED, 1.0), (ev.FAULT_ENDED, 3.0)]


def test_a_misaligned_thruster_turns_its_force_by_the_angle_about_the_axis():
    fault = FaultSpec('thruster_misaligned', index=0, start_s=0.0, value=10.0, axis=(0.0, 0.0, 1.0))
    plant = _plant(fault)
    plant.command_wrench(0.0, (2.0, 0.0, 0.0), (0.0, 0.0, 0.0), hold_s=HOLD_S)
    samples, _ = step_to(plant, 1.0)
    healthy_share = 1.0  # the pair shares 2 N: thruster 0's 1 N turned 10 deg about z
    expected = np.array([1.0 + healthy_share * math.cos(math.radians(10.0)),
                         healthy_share * math.sin(math.radians(10.0)), 0.0])
    np.testing.assert_allclose(_mean_force(samples), expected, atol=1e-9)


def test_a_failed_wheel_gives_no_torque_and_a_limited_one_its_share_of_the_limit():
    for fault, share in ((FaultSpec('wheel_failed', index=2, start_s=0.0), 0.0),
                         (FaultSpec('wheel_torque_limited', index=2, start_s=0.0, value=0.3), 0.3)):
        plant = _plant(fault)
        plant.command_wheels(0.0, (0.0, 0.0, 0.1))  # the schema's limit
        samples, events = step_to(plant, 2.0)
        assert samples[-1].wheel_momentum_n_m_s[2] == pytest.approx(share * 0.1 * 2.0, abs=1e-9)
        assert not any(e.name == ev.WHEEL_MOMENTUM_LIMITED for e in events)


def test_a_relative_position_dropout_stops_its_samples_for_the_window_only():
    plant = _plant(FaultSpec('sensor_dropout', sensor='relative_position', start_s=1.0, duration_s=2.0))
    times = []
    while plant.t < 5.0 - 1e-9:
        plant.step()
        times += [m.t for m in plant.measurements() if m.kind == 'relative_position']
    times = np.array(times)
    assert not ((times > 1.0 + 1e-9) & (times < 3.0 - 1e-9)).any()
    assert (times < 1.0 + 1e-9).sum() == 10 and (times > 3.0 - 1e-9).sum() >= 19


def test_outliers_are_off_by_their_value_in_sigmas_and_the_other_draws_stay():
    """The fault stream is its own: the plant's sensor noise outside the fault's window is the same draw for draw. A
    fault acts on the steps that begin within its window: the samples stamped in (start, end]."""
    fault = FaultSpec('sensor_outliers', sensor='relative_position', start_s=1.0, duration_s=1.0, value=50.0)
    runs = []
    for faults in ((), (fault,)):
        plant = _plant(*faults)
        rows = []
        while plant.t < 3.0 - 1e-9:
            s = plant.step()
            rows += [(m.t, np.linalg.norm(m.value - s.r_hill)) for m in plant.measurements()
                     if m.kind == 'relative_position']
        runs.append(np.array(rows))
    nominal, faulty = runs
    inside = (faulty[:, 0] > 1.0 + 1e-9) & (faulty[:, 0] < 2.0 + 1e-9)
    assert faulty[inside, 1] == pytest.approx(50.0 * 0.01, rel=0.2)
    np.testing.assert_array_equal(faulty[~inside], nominal[~inside])


def test_a_gyro_bias_jump_steps_the_bias_and_a_star_tracker_dropout_leaves_the_gyro():
    jump = FaultSpec('gyro_bias_jump', start_s=1.0, value=2e-3, axis=(0.0, 1.0, 0.0))
    dropout = FaultSpec('sensor_dropout', sensor='star_tracker', start_s=0.0)
    plant = _plant(jump, dropout)
    before = plant.truth().gyro_bias_rad_s
    imu = []
    while plant.t < 2.0 - 1e-9:
        plant.step()
        imu += [m.value for m in plant.measurements() if m.kind == 'chaser_imu']
    step = plant.truth().gyro_bias_rad_s - before
    assert step[1] == pytest.approx(2e-3, abs=1e-5) and abs(step[0]) < 1e-5
    assert imu and all(x.q_hill_from_body is None for x in imu)


def test_a_fault_at_a_phase_starts_after_its_delay_from_the_transitions_stamp_and_the_summary_reads_it_back():
    """The phase message reaches the plant at 1.0 s, the transition is stamped 0.8 s: the fault is due from 1.3 s."""
    plant = _plant(FaultSpec('thruster_off', index=5, start_phase='FLYBY', delay_s=0.5, duration_s=1.0))
    step_to(plant, 1.0)
    plant.on_phase('FLYBY', 0.8)
    _, events = step_to(plant, 4.0)
    faults = plant_faults([wire_event(e)._asdict() | {'hardware_id': 'sim'} for e in events])
    assert faults == [dict(fault=0, kind='thruster_off', target='thruster 5', t_start_s=1.3,
                           t_end_s=pytest.approx(2.3), value=None)]


def _with_faults(base, faults):
    d = yaml.safe_load((REPO / 'scenarios' / base).read_text())
    d['faults'] = faults
    return scenario_from_dict(d, name=base)


@pytest.mark.parametrize('fault, key, words', [
    ({'type': 'thruster_off', 'index': 12, 'start_s': 1.0}, 'faults[0].index', '0 to 11'),
    ({'type': 'wheel_failed', 'start_s': 1.0}, 'faults[0].index', 'wheel'),
    ({'type': 'thruster_off', 'index': 1}, 'faults[0]', 'exactly one of start_s and start_phase'),
    ({'type': 'thruster_off', 'index': 1, 'start_s': 1.0, 'delay_s': 2.0}, 'faults[0].delay_s', 'start_phase'),
    ({'type': 'sensor_dropout', 'start_s': 1.0}, 'faults[0].sensor', 'required'),
    ({'type': 'thruster_off', 'index': 1, 'sensor': 'imu', 'start_s': 1.0}, 'faults[0].sensor', 'not thruster_off'),
    ({'type': 'sensor_dropout', 'sensor': 'imu', 'index': 0, 'start_s': 1.0}, 'faults[0].index', 'not sensor'),
    ({'type': 'thruster_degraded', 'index': 1, 'start_s': 1.0, 'value': 1.0}, 'faults[0].value', '[0, 1)'),
    ({'type': 'thruster_off', 'index': 1, 'start_s': 1.0, 'value': 1.0}, 'faults[0].value', 'no value'),
    ({'type': 'wheel_failed', 'index': 0, 'start_s': 1.0, 'axis': [1, 0, 0]}, 'faults[0].axis', 'not wheel_failed'),
    ({'type': 'gyro_bias_jump', 'start_s': 1.0, 'axis': [0, 0, 0]}, 'faults[0].axis', 'nonzero'),
    ({'type': 'sensor_dropout', 'sensor': 'gps', 'start_s': 1.0}, 'faults[0].sensor', 'must be one of'),
    ({'type': 'thruster_off', 'index': 1, 'start_phase': 'LUNCH'}, 'faults[0].start_phase', 'must be one of'),
    ({'type': 'node_crash', 'start_s': 1.0}, 'faults[0].node', 'required for node_crash'),
    ({'type': 'thruster_off', 'index': 1, 'node': 'planner', 'start_s': 1.0}, 'faults[0].node', 'not thruster_off'),
    ({'type': 'node_crash', 'node': 'flyby_sim', 'start_s': 1.0}, 'faults[0].node', 'must be one of'),
])
def test_a_bad_fault_is_refused_in_one_line_naming_its_key(fault, key, words):
    with pytest.raises(ScenarioError) as err:
        _with_faults('paper_flyby_6dof.yaml', [fault])
    assert err.value.key == key and words in err.value.problem and '\n' not in str(err.value)


def test_hardware_faults_need_the_rigid_body_chaser_and_outliers_a_noisy_sensor():
    with pytest.raises(ScenarioError, match='needs chaser.model rigid_body'):
        _with_faults('paper_flyby.yaml', [{'type': 'sensor_dropout', 'sensor': 'imu', 'start_s': 1.0}])
    d = yaml.safe_load((REPO / 'scenarios' / 'paper_flyby.yaml').read_text())
    d.setdefault('sensors', {}).setdefault('relative_position', {})['noise_sigma_m'] = 0.0
    d['faults'] = [{'type': 'sensor_outliers', 'sensor': 'relative_position', 'start_s': 1.0}]
    with pytest.raises(ScenarioError, match='has no noise'):
        scenario_from_dict(d)
    ok = _with_faults('paper_flyby.yaml', [{'type': 'sensor_dropout', 'sensor': 'relative_position',
                                            'start_phase': 'TERMINAL_APPROACH', 'duration_s': 10.0}])
    assert ok.faults[0].start_phase == 'TERMINAL_APPROACH'


def test_isolated_thrusters_stop_their_leak_and_are_left_out_of_the_allocation():
    plant = _plant(FaultSpec('thruster_stuck_on', index=0, start_s=0.0, value=0.3))
    step_to(plant, 1.0)
    plant.isolate_thrusters([0])
    samples, events = _fire(plant, (0.0, 4.0, 0.0), 2.0)
    assert samples[-1].thruster_thrust_n[0] == 0.0
    np.testing.assert_allclose(_mean_force(samples), [0.0, 4.0, 0.0], atol=1e-9)  # the others give it whole
    assert [e.name for e in events if e.name == ev.THRUSTERS_CLOSED] == [ev.THRUSTERS_CLOSED]
    _, again = _fire(plant, (3.0, 0.0, 0.0), 3.0)  # +x without thruster 0: thruster 1 alone, a torque undelivered
    assert any(e.name == ev.WRENCH_UNDELIVERED for e in again)


def test_a_burn_the_thrusters_left_cannot_give_is_refused_not_crashed():
    """With both -x pushers (2 and 3) closed no pure force points along body -x: the burn is not flown, an ERROR
    event says why, and the plant steps on."""
    plant = _plant()
    plant.isolate_thrusters([2, 3])
    plant.command_maneuver(0.5, (-0.01, 0.0, 0.0))  # body -x: the chaser is aligned with hill
    samples, events = step_to(plant, 2.0)
    rejected = [e for e in events if e.name == ev.MANEUVER_REJECTED]
    assert len(rejected) == 1 and 'no pure force' in rejected[0].message
    assert not any(s.thruster_thrust_n.any() for s in samples)
