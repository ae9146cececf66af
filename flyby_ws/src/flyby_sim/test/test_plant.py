"""plant.py: truth against independent integrations, exact burn timing, events, determinism."""

import dataclasses
import math
import re
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad_vec, solve_ivp

from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.constants import MU_EARTH_M3_S2, STANDARD_GRAVITY_M_S2
from flyby_sim.dynamics.orbital import (
    cw_transition_matrix,
    eci_from_relative,
    hill_axes_in_eci,
    mean_motion_rad_s,
    nonlinear_relative_accel,
    q_eci_from_body,
    q_hill_from_body,
    relative_from_eci,
    rk4_step,
    target_eci_state,
)
from flyby_sim.dynamics.propulsion import ManeuverRejected, ThrusterConfig
from flyby_sim.dynamics.rotation import quat_from_axis_angle, quat_multiply, quat_normalize, quat_to_matrix
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
RADIUS_M = 7.0e6
N = mean_motion_rad_s(RADIUS_M)
PERIOD_S = 2 * math.pi / N
EXACT_THRUSTERS = ThrusterConfig(max_thrust_n=10.0, isp_s=220.0, min_impulse_bit_ns=0.01,
                                 max_delta_v_per_maneuver_mps=2.0, magnitude_error_sigma=0.0,
                                 direction_error_sigma_rad=0.0)
NOISY_THRUSTERS = dataclasses.replace(EXACT_THRUSTERS, magnitude_error_sigma=0.01,
                                      direction_error_sigma_rad=math.radians(0.5))
# Seed 000 section 5 / scenarios/paper_flyby.yaml: 50 m ahead on V-bar, 5 deg/s spin about body z (here with body z
# along hill z), the thrusters exact; what is not given is the scenario's (mu, nonlinear dynamics, 10 Hz sensors).
PAPER = dataclasses.replace(PlantConfig.from_scenario(load_scenario(SCENARIOS / 'paper_flyby.yaml')),
                            radius_m=RADIUS_M, chaser_mass_kg=100.0, r0_hill=(50.0, 0.0, 0.0), v0_hill=(0.0, 0.0, 0.0),
                            target_inertia=np.diag([1200.0, 1000.0, 2000.0]),
                            q_hill_from_body0=(0.0, 0.0, 0.0, 1.0), omega_body0=(0.0, 0.0, math.radians(5.0)),
                            thrusters=EXACT_THRUSTERS, step_s=0.05, position_sigma_m=0.01,
                            attitude_sigma_rad=math.radians(1.0), restriction_sphere_radius_m=15.0, seed=1)


def coarse(step_s, **changes):
    """PAPER with a longer step (sensors at one sample per step) and the given changes."""
    return dataclasses.replace(PAPER, step_s=step_s, position_rate_hz=min(10.0, 1.0 / step_s),
                               attitude_rate_hz=min(10.0, 1.0 / step_s), **changes)


def run(plant, t_end):
    """Step to t_end, returning every TruthSample including the initial one."""
    samples = [plant.truth()]
    while plant.t < t_end - 1e-9:
        samples.append(plant.step())
    return samples


def two_body_reference(r0_hill, v0_hill, times):
    """Both spacecraft integrated directly in ECI (seed 000 eq 5), then taken to hill."""
    r_t0, v_t0 = target_eci_state(0.0, RADIUS_M, N)
    r_c0, v_c0 = eci_from_relative(r0_hill, v0_hill, r_t0, v_t0)

    def rhs(t, y):
        out = np.empty(12)
        for k in (0, 6):
            r = y[k:k + 3]
            out[k:k + 3] = y[k + 3:k + 6]
            out[k + 3:k + 6] = -MU_EARTH_M3_S2 * r / np.dot(r, r) ** 1.5
        return out

    sol = solve_ivp(rhs, (0.0, times[-1]), np.concatenate((r_t0, v_t0, r_c0, v_c0)), method='DOP853',
                    t_eval=times, rtol=1e-13, atol=1e-9)
    return [relative_from_eci(y[6:9], y[9:], y[:3], y[3:6]) for y in sol.y.T]


@pytest.mark.parametrize('r0, v0, step_s', [
    ((50.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.05),
    ((-30.0, 8.0, 12.0), (0.05, -0.02, 0.03), 0.25),
], ids=['paper_vbar_50m', 'velocity_and_out_of_plane'])
def test_seed000_eq1_nonlinear_plant_matches_eci_two_body_over_one_orbit(r0, v0, step_s):
    plant = Plant(coarse(step_s, r0_hill=r0, v0_hill=v0, omega_body0=(0.0, 0.0, 0.0)))
    samples = run(plant, math.ceil(PERIOD_S / step_s) * step_s)[::int(round(50.0 / step_s))]
    reference = two_body_reference(r0, v0, np.array([s.t for s in samples]))
    position_err = max(np.linalg.norm(s.r_hill - r) for s, (r, _) in zip(samples, reference, strict=True))
    velocity_err = max(np.linalg.norm(s.v_hill - v) for s, (_, v) in zip(samples, reference, strict=True))
    print(f'max error over one orbit: position {position_err:.2e} m, velocity {velocity_err:.2e} m/s')
    assert position_err < 1e-3
    assert velocity_err < 1e-6


def test_seed000_eq22_cw_plant_matches_transition_matrix_over_one_orbit():
    x0 = np.array([-30.0, 8.0, 12.0, 0.05, -0.02, 0.03])
    plant = Plant(coarse(0.25, dynamics='cw', r0_hill=x0[:3], v0_hill=x0[3:], omega_body0=(0.0, 0.0, 0.0)))
    samples = run(plant, math.ceil(PERIOD_S / 0.25) * 0.25)[::200]
    errors = [np.linalg.norm(s.r_hill - (cw_transition_matrix(N, s.t) @ x0)[:3]) for s in samples]
    print(f'cw plant vs eq 22 over one orbit: max position error {max(errors):.2e} m')
    assert max(errors) < 1e-3


def test_inertially_fixed_target_turns_at_plus_n_about_hill_y():
    """The hill frame turns at -n about y (seed 000 eq 11), so a non-rotating target appears to turn at +n."""
    q0 = quat_normalize([0.2, -0.1, 0.4, 0.9])
    plant = Plant(coarse(1.0, q_hill_from_body0=q0, omega_body0=(0.0, 0.0, 0.0)))
    np.testing.assert_allclose(plant.truth().q_hill_from_body, q0, atol=1e-15)
    for sample in run(plant, 600.0)[::100]:
        expected = quat_multiply(quat_from_axis_angle([0.0, 1.0, 0.0], N * sample.t), q0)
        np.testing.assert_allclose(sample.q_hill_from_body, expected, atol=1e-12)


def test_stable_spin_reports_body_rate_and_turns_about_the_spin_axis():
    plant = Plant(PAPER)
    sample = run(plant, 18.0)[-1]  # 90 deg about body z at 5 deg/s
    np.testing.assert_allclose(sample.omega_body, PAPER.omega_body0, atol=1e-15)
    expected = quat_multiply(quat_from_axis_angle([0.0, 1.0, 0.0], N * 18.0),
                             quat_from_axis_angle([0.0, 0.0, 1.0], math.pi / 2))
    np.testing.assert_allclose(sample.q_hill_from_body, expected, atol=1e-12)


@pytest.mark.parametrize('stamp', [10.0123, 10.0])
def test_burn_starts_exactly_at_its_stamp(stamp):
    plant = Plant(PAPER)
    burn = plant.command_maneuver(stamp, [0.2, 0.0, 0.1])
    assert burn.start_s == stamp and not burn.late
    samples = run(plant, 20.0)
    forces = {round(s.t / 0.05): np.linalg.norm(s.force_hill) for s in samples}
    first = math.floor(stamp / 0.05 + 1e-9) + 1  # index of the step that contains the start
    assert forces[first - 1] == 0.0
    assert forces[first] == pytest.approx(10.0 * (first * 0.05 - stamp) / 0.05, rel=1e-9)
    last = math.ceil(burn.end_s / 0.05 - 1e-9)
    assert forces[last] == pytest.approx(10.0 * (burn.end_s - (last - 1) * 0.05) / 0.05, rel=1e-9)
    assert forces[last + 1] == 0.0
    assert all(forces[k] == pytest.approx(10.0, rel=1e-12) for k in range(first + 1, last))
    events = plant.drain_events()
    assert [e.name for e in events] == ['burn_started', 'burn_ended']
    assert float(events[0].values['t_start']) == stamp


@pytest.mark.parametrize('thrusters', [EXACT_THRUSTERS, NOISY_THRUSTERS], ids=['exact', 'with_errors'])
def test_achieved_delta_v_equals_errored_command_far_from_gravity(thrusters):
    """Far out (n ~ 1e-15 rad/s) the burning plant minus its coasting twin is the delta-v itself."""
    config = dataclasses.replace(PAPER, radius_m=1e15, thrusters=thrusters, omega_body0=(0.0, 0.0, 0.0))
    dv_cmd = np.array([0.8, -0.3, 1.1])
    plant, twin = Plant(config), Plant(config)
    burn = plant.command_maneuver(5.0, dv_cmd)
    end = run(plant, 40.0)[-1]
    end_twin = run(twin, 40.0)[-1]
    achieved = end.v_hill - end_twin.v_hill
    print(f'achieved dv {achieved}, errored command {burn.dv_hill}, command {dv_cmd}')
    np.testing.assert_allclose(achieved, burn.dv_hill, rtol=1e-9)
    if thrusters is EXACT_THRUSTERS:
        np.testing.assert_allclose(achieved, dv_cmd, rtol=1e-6)
    else:
        assert np.linalg.norm(achieved - dv_cmd) > 1e-5
    assert end.dv_applied_total_mps == pytest.approx(np.linalg.norm(burn.dv_hill), rel=1e-12)
    # Fuel: m dv / (Isp g0) within 1 %, and exactly the rocket-equation figure of the burn.
    assert end.fuel_used_kg == pytest.approx(burn.fuel_kg, rel=1e-9)
    assert end.fuel_used_kg == pytest.approx(100.0 * burn.dv_mps / (220.0 * STANDARD_GRAVITY_M_S2), rel=0.01)
    assert end.mass_kg == pytest.approx(100.0 - burn.fuel_kg, rel=1e-15)


def test_cw_burn_response_matches_forced_eq22_convolution():
    """On orbit, plant minus twin = integral of Phi(t - tau) [0; F u / m(tau)] d tau (eq 2 is linear)."""
    config = dataclasses.replace(PAPER, dynamics='cw', omega_body0=(0.0, 0.0, 0.0))
    plant, twin = Plant(config), Plant(config)
    burn = plant.command_maneuver(3.0, [1.5, 0.0, -1.0])
    t_end = 60.0
    diff = run(plant, t_end)[-1], run(twin, t_end)[-1]
    achieved = np.concatenate((diff[0].r_hill - diff[1].r_hill, diff[0].v_hill - diff[1].v_hill))
    u = np.array(burn.direction_hill)
    mdot = 10.0 / (220.0 * STANDARD_GRAVITY_M_S2)
    expected, _ = quad_vec(lambda tau: cw_transition_matrix(N, t_end - tau)[:, 3:] @ u
                           * 10.0 / (100.0 - mdot * (tau - burn.start_s)), burn.start_s, burn.end_s,
                           epsabs=1e-14, epsrel=1e-13)
    np.testing.assert_allclose(achieved, expected, rtol=1e-9, atol=1e-12)


def test_nonlinear_burn_matches_independent_eci_integration():
    """Finite burn on orbit: thrust along fixed hill axes, integrated in ECI with scipy."""
    config = dataclasses.replace(PAPER, omega_body0=(0.0, 0.0, 0.0))
    plant = Plant(config)
    burn = plant.command_maneuver(4.02, [-1.2, 0.4, 0.9])
    end = run(plant, 120.0)[-1]
    u = np.array(burn.direction_hill)
    mdot = 10.0 / (220.0 * STANDARD_GRAVITY_M_S2)

    def rhs(t, y, thrusting):
        r = y[:3]
        a = -MU_EARTH_M3_S2 * r / np.dot(r, r) ** 1.5
        if thrusting:
            a = a + hill_axes_in_eci(t, N) @ u * 10.0 / (100.0 - mdot * (t - burn.start_s))
        return np.concatenate((y[3:], a))

    r_t0, v_t0 = target_eci_state(0.0, RADIUS_M, N)
    y = np.concatenate(eci_from_relative(config.r0_hill, config.v0_hill, r_t0, v_t0))
    for t0, t1, thrusting in ((0.0, burn.start_s, False), (burn.start_s, burn.end_s, True),
                              (burn.end_s, 120.0, False)):
        y = solve_ivp(rhs, (t0, t1), y, method='DOP853', args=(thrusting,), rtol=1e-13, atol=1e-10).y[:, -1]
    r_hill, v_hill = relative_from_eci(y[:3], y[3:], *target_eci_state(120.0, RADIUS_M, N))
    np.testing.assert_allclose(end.r_hill, r_hill, atol=1e-6)
    np.testing.assert_allclose(end.v_hill, v_hill, atol=1e-8)


def test_late_command_starts_at_once_and_is_reported():
    plant = Plant(PAPER)
    run(plant, 10.0)
    burn = plant.command_maneuver(5.0, [0.1, 0.0, 0.0])
    assert burn.late and burn.start_s == plant.t == pytest.approx(10.0)
    sample = plant.step()
    assert sample.firing and np.linalg.norm(sample.force_hill) == pytest.approx(10.0, rel=1e-12)
    events = {e.name: e for e in plant.drain_events()}
    assert events['late_maneuver'].level == 'WARN'
    assert float(events['late_maneuver'].values['lateness_s']) == pytest.approx(5.0)


def test_overlapping_command_starts_when_the_previous_burn_ends():
    plant = Plant(PAPER)
    first = plant.command_maneuver(1.0, [1.0, 0.0, 0.0])
    second = plant.command_maneuver(2.0, [0.0, 0.0, 0.5])
    assert second.late and second.start_s == first.end_s
    run(plant, 60.0)
    names = [e.name for e in plant.drain_events()]
    assert names == ['burn_started', 'burn_ended', 'burn_started', 'late_maneuver', 'burn_ended']


@pytest.mark.parametrize('dv, pattern', [
    ([math.nan, 0.0, 0.0], 'non-finite'),
    ([3.0, 0.0, 0.0], r'\|dv_hill\| = 3 m/s exceeds'),
    ([1e-5, 0.0, 0.0], 'below min_impulse_bit_ns'),
])
def test_rejected_command_raises_and_is_reported(dv, pattern):
    plant = Plant(PAPER)
    with pytest.raises(ManeuverRejected, match=pattern):
        plant.command_maneuver(1.0, dv)
    (event,) = plant.drain_events()
    assert event.level == 'ERROR' and event.name == 'maneuver_rejected'
    assert re.search(pattern, event.message)


def test_thrust_inside_restriction_sphere_is_reported_once_per_burn():
    plant = Plant(dataclasses.replace(PAPER, r0_hill=(5.0, 0.0, 0.0)))
    plant.command_maneuver(1.0, [0.5, 0.0, 0.0])
    plant.command_maneuver(20.0, [-0.5, 0.0, 0.0])
    run(plant, 40.0)
    events = [e for e in plant.drain_events() if e.name == 'thrust_inside_restriction_sphere']
    assert len(events) == 2 and all(e.level == 'ERROR' for e in events)
    assert float(events[0].values['range_m']) == pytest.approx(5.0, abs=1e-6)
    outside = Plant(PAPER)
    outside.command_maneuver(1.0, [0.5, 0.0, 0.0])
    run(outside, 20.0)
    assert 'thrust_inside_restriction_sphere' not in [e.name for e in outside.drain_events()]


def test_sensor_samples_follow_the_schedule():
    plant = Plant(PAPER)
    position, attitude = [], []
    for _ in range(2000):
        truth = plant.step()
        for m in plant.measurements():
            assert m.t == truth.t
            if m.kind == 'relative_position':
                position.append(m.value - truth.r_hill)
            else:
                attitude.append(m)
    assert len(position) == len(attitude) == 1000  # 10 Hz for 100 s
    assert np.std(position) == pytest.approx(0.01, rel=0.1)


def random_commands_truth(config, early):
    """Truth and sensor samples with two commands, sent at t = 0 (early) or one step before their stamps."""
    plant = Plant(config)
    commands = [(20.0, [0.3, -0.1, 0.2]), (40.0, [-0.2, 0.0, 0.4])]
    if early:
        for stamp, dv in commands:
            plant.command_maneuver(stamp, dv)
    truth, measurements = [], []
    while plant.t < 60.0 - 1e-9:
        for stamp, dv in commands:
            if not early and abs(plant.t - (stamp - config.step_s)) < 1e-9:
                plant.command_maneuver(stamp, dv)
        sample = plant.step()
        truth.append(np.concatenate((sample.r_hill, sample.v_hill, sample.q_hill_from_body, sample.omega_body,
                                     sample.force_hill, [sample.mass_kg, sample.dv_applied_total_mps])))
        measurements.extend(np.concatenate(([m.t], m.value)) for m in plant.measurements())
    return np.array(truth), np.concatenate(measurements)


def test_determinism_does_not_depend_on_command_arrival_time():
    config = dataclasses.replace(PAPER, thrusters=NOISY_THRUSTERS,
                                 target_inertia=np.diag([4069.0, 12030.0, 11029.0]), omega_body0=(0.3, 0.2, 0.1))
    truth_early, meas_early = random_commands_truth(config, early=True)
    truth_late, meas_late = random_commands_truth(config, early=False)
    assert np.array_equal(truth_early, truth_late)
    assert np.array_equal(meas_early, meas_late)
    # Sensor settings use their own streams: the truth, thruster errors included, does not move.
    quieter = dataclasses.replace(config, position_sigma_m=0.5, attitude_rate_hz=5.0)
    assert np.array_equal(random_commands_truth(quieter, early=True)[0], truth_early)
    # A different seed changes the thruster errors.
    assert not np.array_equal(random_commands_truth(dataclasses.replace(config, seed=2), early=True)[0],
                              truth_early)


@pytest.mark.parametrize('field, value, pattern', [
    ('dynamics', 'kepler', 'dynamics'),
    ('step_s', -0.05, 'step_s'),
    ('r0_hill', (1.0, 2.0), 'r0_hill'),
    ('position_rate_hz', 50.0, 'position_rate_hz'),
    ('target_inertia', np.diag([1.0, 0.0, 1.0]), 'target_inertia'),
    ('q_hill_from_body0', (0.0, 0.0, 0.0, 0.0), 'q_hill_from_body0'),
    ('seed', -1, 'seed'),
])
def test_config_errors_name_the_field(field, value, pattern):
    with pytest.raises(ValueError, match=pattern):
        dataclasses.replace(PAPER, **{field: value})


def test_truth_equals_one_step_at_a_time_numpy_integration_to_the_bit():
    """The plant's float RK4 and its attitude evaluated a chunk of steps at once give the numbers of the
    plain formulation: numpy RK4 of eq 1 and the attitude's dense output asked step by step."""
    config = dataclasses.replace(PAPER, r0_hill=(-30.0, 8.0, 12.0), v0_hill=(0.05, -0.02, 0.03),
                                 target_inertia=np.diag([4069.0, 12030.0, 11029.0]), omega_body0=(0.3, 0.2, 0.1))
    plant = Plant(config)
    attitude = AttitudePropagator(q_eci_from_body(0.0, N, quat_normalize(config.q_hill_from_body0)),
                                  config.omega_body0, config.target_inertia)

    def rhs(t, y):
        return np.concatenate((y[3:], nonlinear_relative_accel(y[:3].tolist(), y[3:].tolist(), N, RADIUS_M)))

    y = np.array(config.r0_hill + config.v0_hill)
    for k in range(1, 260):  # across chunk boundaries
        sample = plant.step()
        y = rk4_step(rhs, (k - 1) * config.step_s, y, k * config.step_s - (k - 1) * config.step_s)
        q_eci, omega_body = attitude.state_at(k * config.step_s)
        assert sample.t == k * config.step_s
        assert sample.r_hill.tolist() == y[:3].tolist() and sample.v_hill.tolist() == y[3:].tolist()
        assert sample.q_hill_from_body.tolist() == q_hill_from_body(sample.t, N, q_eci).tolist()
        assert sample.omega_body.tolist() == omega_body.tolist()


def test_coasting_step_cost():
    plant = Plant(dataclasses.replace(PAPER, target_inertia=np.diag([4069.0, 12030.0, 11029.0]),
                                      omega_body0=(0.3, 0.2, 0.1)))
    start = time.perf_counter()
    for _ in range(4000):
        plant.step()
        plant.measurements()
    per_step_us = (time.perf_counter() - start) / 4000 * 1e6
    print(f'coasting step() with the seed 001 tumbler and both sensors at 10 Hz: {per_step_us:.0f} us')
    assert per_step_us < 1000.0  # budget 300 us; generous for a loaded machine


def test_capture_attaches_the_chaser_to_the_target_and_drops_maneuvers():
    """After capture the chaser stays at its body-frame point (moves with the tumbling target, eq 8-9)."""
    sc = load_scenario(Path(__file__).resolve().parents[4] / 'scenarios' / 'paper_flyby.yaml')
    plant = Plant(PlantConfig.from_scenario(sc))
    for _ in range(20):
        plant.step()
    plant.command_maneuver(plant.t + 5.0, (0.01, 0.0, 0.0))
    plant.capture()
    r_body = quat_to_matrix(plant.truth().q_hill_from_body).T @ plant.truth().r_hill
    assert [e.name for e in plant.drain_events()] == ['captured']
    with pytest.raises(ManeuverRejected, match='attached'):
        plant.command_maneuver(plant.t + 1.0, (0.01, 0.0, 0.0))
    for _ in range(400):
        s = plant.step()
    assert not s.firing and s.dv_applied_total_mps == 0.0
    c_hill_from_body = quat_to_matrix(s.q_hill_from_body)
    np.testing.assert_allclose(s.r_hill, c_hill_from_body @ r_body, atol=1e-9)  # eq 8
    # eq 9 written independently, as the rotation relative to hill: (omega^H - Omega^H) x x^H
    omega_rel_hill = c_hill_from_body @ s.omega_body - np.array((0.0, -plant.mean_motion_rad_s, 0.0))
    np.testing.assert_allclose(s.v_hill, np.cross(omega_rel_hill, s.r_hill), atol=1e-12)


# -- after the capture with a grasp (scenario post_capture) -----------------------------------------------------------

TUG = Path(__file__).resolve().parents[4] / 'scenarios' / 'paper_flyby_tug.yaml'


def _at_the_flyby_target_point(**grasp_changes):
    """A plant of paper_flyby_tug whose chaser starts at the fly-by target point of eq 20-21 (delta r 1 m) moving as
    it does, body +x at the target's CoM, at rest in inertial space (the rate mismatch loads the wrist)."""
    from flyby_sim.dynamics.attitude import body_point_state
    from flyby_sim.dynamics.rotation import quat_shortest_arc

    config = PlantConfig.from_scenario(load_scenario(TUG))
    c = quat_to_matrix(config.q_hill_from_body0)
    x_g = np.array(config.grasp.grasp_point_body_m)
    x_ft_body = x_g * (1.0 + 1.0 / np.linalg.norm(x_g))
    r0, v0 = body_point_state(c, np.array(config.omega_body0), x_ft_body, N)
    body = dataclasses.replace(config.chaser_body, q_hill_from_body0=tuple(quat_shortest_arc((1.0, 0.0, 0.0), -r0)),
                               omega_body0=(0.0, 0.0, 0.0))
    grasp = dataclasses.replace(config.grasp, impedance=dataclasses.replace(config.grasp.impedance, **grasp_changes))
    return Plant(dataclasses.replace(config, r0_hill=tuple(r0), v0_hill=tuple(v0), chaser_body=body, grasp=grasp,
                                     position_sigma_m=0.0, attitude_sigma_rad=0.0))


def _angular_momentum_about_com(plant, s):
    """|H| [kg m^2/s] of chaser (wheels included) and target about their common CoM, from a TruthSample, in the
    inertial frame whose axes are hill's at s.t (grasp.momentum)."""
    from flyby_sim.dynamics.grasp import Body, momentum

    omega_hill = np.array([0.0, -plant.mean_motion_rad_s, 0.0])
    cfg = plant.config
    r_t = np.zeros(3) if s.r_target_hill is None else s.r_target_hill
    v_t = np.zeros(3) if s.v_target_hill is None else s.v_target_hill
    axes = np.array(cfg.chaser_body.wheel_axes_body)
    bodies = (Body(s.mass_kg, np.array(cfg.chaser_body.inertia), s.r_hill, s.v_hill + np.cross(omega_hill, s.r_hill),
                   s.q_hill_from_chaser_body, s.omega_chaser_body, axes.T @ s.wheel_momentum_n_m_s),
              Body(cfg.grasp.target_mass_kg, np.array(cfg.target_inertia), r_t, v_t + np.cross(omega_hill, r_t),
                   s.q_hill_from_body, s.omega_body))
    p, h = momentum(bodies)
    r_cm = sum(b.mass_kg * b.r_m for b in bodies) / sum(b.mass_kg for b in bodies)
    return float(np.linalg.norm(h - np.cross(r_cm, p)))


def test_momentum_is_kept_through_the_grasp_and_the_lock_without_firing():
    """Seed 000 §2.2 (5): the arm's impedance is internal, then the two are one rigid body with the momentum they
    carried (grasp.weld); no thruster fires. The angular momentum about the common CoM is that of the two free bodies
    at the contact, to the integrators' accuracy, through the grasp and 20 s of the combined body after it."""
    plant = _at_the_flyby_target_point()
    h0 = _angular_momentum_about_com(plant, plant.truth())
    plant.capture()
    assert plant.mode == 'grasp' and [e.name for e in plant.drain_events()] == ['captured']
    momenta, names = [], []
    while plant.mode == 'grasp':
        momenta.append(_angular_momentum_about_com(plant, plant.step()))
        names += [e.name for e in plant.drain_events()]
    locked = plant.t
    for _ in range(400):
        s = plant.step()
        momenta.append(_angular_momentum_about_com(plant, s))
        assert not s.firing
    assert names == ['grasp_damped'] and plant.mode == 'combined' and locked < 20.0
    assert h0 > 100.0  # the target's spin: 2000 kg m^2 x 5 deg/s and the chaser's orbit about the common CoM
    np.testing.assert_allclose(momenta, h0, rtol=1e-7)
    # The chaser holds the target where the arm locked: the target CoM fixed in chaser_body.
    s = plant.truth()
    x_s = quat_to_matrix(s.q_hill_from_chaser_body).T @ (s.r_target_hill - s.r_hill)
    assert np.linalg.norm(x_s) == pytest.approx(3.12, abs=0.02)


def test_the_grasp_lets_go_beyond_the_arms_limits_and_both_fly_on():
    """A force limit below the arm's first push (the handle slides past the chaser-fixed point at ~6 cm/s: ~9 N on
    the 150 N s/m damper): released at once, the momentum kept, no command acts on the chaser, both fly freely."""
    plant = _at_the_flyby_target_point(max_force_n=2.0)
    h0 = _angular_momentum_about_com(plant, plant.truth())
    plant.capture()
    events = plant.drain_events()
    assert [e.name for e in events] == ['captured', 'grasp_released'] and plant.mode == 'released'
    assert '|F|' in events[1].message and events[1].values['peak_force_n'] > 2.0
    assert plant.command_wrench(plant.t + 0.1, (0.0, 0.0, 0.0), (0.1, 0.0, 0.0)) is None
    samples = [plant.step() for _ in range(200)]
    assert not any(s.firing for s in samples)
    # Free again, the two bodies feel the orbit's tidal acceleration (3 n^2 r on ~3 m: ~1e-5 m/s^2), a torque on
    # the pair about their CoM; until the release (the first sample) the momentum is the contact's.
    momenta = [_angular_momentum_about_com(plant, s) for s in samples]
    assert momenta[0] == pytest.approx(h0, rel=1e-9)
    np.testing.assert_allclose(momenta, h0, rtol=2e-5)
    # Let go at the first contact, before any impulse: the target's CoM stays on the hill origin, the chaser drifts
    # off on the fly-by's passive arc (the grasp point's velocity less the rotation it did not follow).
    gap = [np.linalg.norm(s.r_hill - s.r_target_hill) for s in samples]
    assert gap[-1] > gap[0] + 0.5 and np.all(samples[-1].r_target_hill == 0.0)


def test_the_combined_body_takes_commands_from_one_imu_period_after_the_lock_and_its_accelerometer_sees_it_turn():
    """Commands stamped before the lock plus one IMU period are ignored (from before the capture); a pure force held
    on the combined body reads at the chaser's accelerometer as F/(m + M) + omega_dot x p + omega x (omega x p),
    p = -c (seed 004 §2.2, combined_body.specific_force_body)."""
    from flyby_sim.dynamics.combined_body import CombinedMassProperties, specific_force_body

    plant = _at_the_flyby_target_point()
    plant.capture()
    while plant.mode == 'grasp':
        plant.step()
    plant.drain_events()
    t_lock, period = plant.t, 1.0 / plant.config.chaser_body.imu.rate_hz
    assert plant.command_wrench(t_lock + 0.5 * period, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)) is None
    assert [e.name for e in plant.drain_events()] == ['command_ignored']
    t_on = t_lock + 2.0 * period
    assert plant.command_wrench(t_on, (10.0, 0.0, 0.0), (0.0, 1.0, -1.0), hold_s=10.0) is not None
    imu = []
    while plant.t < t_on + 2.0 - 1e-9:
        s = plant.step()
        imu += [(m.t, m.value) for m in plant.measurements() if m.kind == 'chaser_imu']
    body = plant._body
    props = CombinedMassProperties(body.mass_kg, plant._com_body, np.array(body.config.inertia))
    (t0, a), (t1, b) = [(t, v) for t, v in imu if t > t_on + 0.5][:2]
    omega_dot = (b.omega_body_meas - a.omega_body_meas) / (t1 - t0)  # the gyro's noise 1e-5 rad/s: ~1e-4 rad/s^2
    force = s.force_body_n  # with the thrusters' errors
    expected = specific_force_body(props, b.omega_body_meas, omega_dot, force)
    assert np.linalg.norm(force) == pytest.approx(10.0, rel=0.05)
    np.testing.assert_allclose(b.specific_force_body, expected, atol=1e-3)  # noise 1e-4 m/s^2 and the gyro's
    assert abs(b.specific_force_body[1]) > 1e-3  # omega_dot x p: the turn the force's moment about c gives


TUGROBOT = Path(__file__).resolve().parents[4] / 'scenarios' / 'matsunaga_tugrobot.yaml'


def test_seed004_section31_the_run_starts_attached_as_one_rigid_body():
    """matsunaga_tugrobot: at t = 0 the chaser is where the scenario puts it and the target's CoM X_s from it in its
    axes, both turning at the TugRobot's rate; with no command the combined body keeps its angular momentum about
    the common CoM and X_s stays fixed in chaser_body; commands are taken from one IMU period on."""
    plant = Plant(PlantConfig.from_scenario(load_scenario(TUGROBOT)))
    assert plant.mode == 'combined' and plant.captured
    assert [(e.name, e.t) for e in plant.drain_events()] == [('attached', 0.0)]
    s = plant.truth()
    np.testing.assert_allclose(s.r_hill, (10.0, 5.0, 5.0), atol=1e-12)
    np.testing.assert_allclose(s.v_hill, (0.0, 0.1, 0.0), atol=1e-12)
    np.testing.assert_allclose(s.omega_chaser_body, (0.0, 0.0, 0.1), atol=1e-12)
    np.testing.assert_allclose(quat_to_matrix(s.q_hill_from_chaser_body).T @ (s.r_target_hill - s.r_hill),
                               (0.5, 0.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(s.q_hill_from_body, s.q_hill_from_chaser_body, atol=1e-12)
    h0 = _angular_momentum_about_com(plant, s)
    assert h0 == pytest.approx((3.0 + 1.5 + 30.0 * 20.0 / 50.0 * 0.25) * 0.1, rel=1e-9)  # I_z of the pair x 0.1
    assert plant.command_wrench(0.05, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)) is None
    momenta = []
    for _ in range(400):
        s = plant.step()
        momenta.append(_angular_momentum_about_com(plant, s))
        assert not s.firing
    # Over 20 s the orbit's tidal torque on a 0.5 m pair is ~1e-9 of it; the integrators' error likewise.
    np.testing.assert_allclose(momenta, h0, rtol=1e-7)
    np.testing.assert_allclose(quat_to_matrix(s.q_hill_from_chaser_body).T @ (s.r_target_hill - s.r_hill),
                               (0.5, 0.0, 0.0), atol=1e-9)
    assert plant.command_wrench(plant.t + 0.1, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)) is not None


ORBIT_ADVANCE = Path(__file__).resolve().parents[4] / 'scenarios' / 'matsunaga_orbit_advance.yaml'


def test_seed004_transport_fires_only_the_thrusters_whose_exhaust_misses_the_target():
    """Seed 004 §2.3's direction-limited thrusters: from TRANSPORT on the TugRobot's two -x pushers (exhaust along +x,
    at the satellite 0.5 m ahead) are blocked, so a body -x force is not delivered and none of them fires; before it
    the same command is (the detumbling and the excitation use every thruster)."""
    plant = Plant(PlantConfig.from_scenario(load_scenario(ORBIT_ADVANCE)))
    plant.drain_events()
    t = plant.t + 0.1
    assert plant.command_wrench(t, (-1.0, 0.0, 0.0), (0.0, 0.0, 0.0), hold_s=0.1) is not None
    while plant.t < t + 0.1 - 1e-9:
        s = plant.step()
    assert s.thruster_thrust_n[[2, 3]].sum() > 0.0 and not plant.drain_events()
    mask = plant.start_transport()
    assert np.flatnonzero(~mask).tolist() == [2, 3]
    assert [e.name for e in plant.drain_events()] == ['transport_thrusters']
    t = plant.t + 0.1
    plant.command_wrench(t, (-1.0, 0.0, 0.0), (0.0, 0.0, 0.0), hold_s=0.1)
    assert [e.name for e in plant.drain_events()] == ['wrench_undelivered']
    while plant.t < t + 0.1 - 1e-9:
        s = plant.step()
    assert s.thruster_thrust_n[[2, 3]].sum() == 0.0
    assert np.array_equal(plant.start_transport(), mask)  # idempotent
