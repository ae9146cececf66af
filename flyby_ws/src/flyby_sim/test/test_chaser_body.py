"""The plant's six-degree-of-freedom chaser (chaser_body.py through Plant): conservation laws through the plant's own
integrator, time-tagged wrench, wheel and delta-v commands, fuel, the restriction sphere, the IMU, and that none of it
touches the point-mass chaser."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from rigid_body_strategies import inertia_from, principal_moments, rate, rotation_vector

from flyby_sim.chaser_body import ImuConfig, RigidChaserConfig
from flyby_sim.dynamics.actuators import allocate_wrench, default_thruster_layout, plan_burn
from flyby_sim.dynamics.attitude import kinetic_energy
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2
from flyby_sim.dynamics.orbital import mean_motion_rad_s, q_eci_from_body
from flyby_sim.dynamics.propulsion import ManeuverRejected, ThrusterConfig
from flyby_sim.dynamics.rigid_body import ChaserAttitudeState, GyrostatPropagator, ReactionWheels
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_axis_angle,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_to_matrix,
    rotation_vector_from_quat,
)
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario, scenario_from_dict
from flyby_testing import step_to

REPO = Path(__file__).resolve().parents[4]
RADIUS_M = 7.0e6
N = mean_motion_rad_s(RADIUS_M)
EXACT = ThrusterConfig(max_thrust_n=10.0, isp_s=220.0, min_impulse_bit_ns=0.0, max_delta_v_per_maneuver_mps=2.0,
                       magnitude_error_sigma=0.0, direction_error_sigma_rad=0.0)
NOISY = dataclasses.replace(EXACT, min_impulse_bit_ns=0.01, magnitude_error_sigma=0.05,
                            direction_error_sigma_rad=math.radians(1.0))
# paper_flyby: seed 000 section 5; its chaser's rigid-body keys are the schema's defaults (wheels, IMU, layout).
PAPER_FLYBY = load_scenario(REPO / 'scenarios' / 'paper_flyby.yaml')
SCHEMA_BODY = RigidChaserConfig.from_scenario(PAPER_FLYBY)


def rigid_body(**fields):
    """The schema's rigid-body chaser at rest, aligned with hill, its wheels at zero momentum, with ``fields``."""
    return dataclasses.replace(SCHEMA_BODY, **{'q_hill_from_body0': (0.0, 0.0, 0.0, 1.0),
                                               'omega_body0': (0.0, 0.0, 0.0), 'wheel_momentum0_n_m_s': None,
                                               **fields})


BODY = rigid_body(inertia=((10.0, 0.3, -0.2), (0.3, 12.0, 0.1), (-0.2, 0.1, 9.0)))
PYRAMID_AXES = ((1.0, 0.0, 1.0 / math.sqrt(2)), (0.0, 1.0, 1.0 / math.sqrt(2)), (-1.0, 0.0, 1.0 / math.sqrt(2)),
                (0.0, -1.0, 1.0 / math.sqrt(2)))


def plant_config(body=BODY, **changes):
    """Seed 000 section 5's orbit and target with a rigid-body chaser 50 m ahead on V-bar."""
    base = dict(radius_m=RADIUS_M, chaser_mass_kg=100.0, r0_hill=(50.0, 0.0, 0.0), v0_hill=(0.0, 0.0, 0.0),
                target_inertia=np.diag([1200.0, 1000.0, 2000.0]), q_hill_from_body0=(0.0, 0.0, 0.0, 1.0),
                omega_body0=(0.0, 0.0, math.radians(5.0)), thrusters=EXACT, step_s=0.05, position_sigma_m=0.01,
                attitude_sigma_rad=math.radians(1.0), restriction_sphere_radius_m=15.0, seed=1, chaser_body=body)
    base.update(changes)
    return dataclasses.replace(PlantConfig.from_scenario(PAPER_FLYBY), **base)


def inertial_momentum(sample, inertia, axes):
    """H = C_eci_from_body (I omega + A h) from a TruthSample [N m s]."""
    q_eci = q_eci_from_body(sample.t, N, sample.q_hill_from_chaser_body)
    h_body = np.asarray(inertia) @ sample.omega_chaser_body + np.asarray(axes).T @ sample.wheel_momentum_n_m_s
    return quat_rotate(quat_normalize(q_eci), h_body)


# ------------------------------------------------------------------------------------------------
# Conservation through the plant's own integrator

@settings(max_examples=3, deadline=None)
@given(principal_moments, rotation_vector, st.tuples(rate, rate, rate).filter(lambda w: np.linalg.norm(w) > 0.02),
       st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.floats(-2.0, 2.0)))
def test_seed001_eq3_torque_free_chaser_keeps_momentum_and_energy(moments, axes_rotvec, omega0, h_wheels0):
    """No command for 1000 s (20000 plant steps): the inertial angular momentum (body + wheels) and 1/2 omega.I omega
    stay to 1e-9 relative; the wheels keep their momentum."""
    inertia = inertia_from(moments, axes_rotvec)
    body = rigid_body(inertia=inertia, q_hill_from_body0=tuple(quat_normalize([0.3, -0.1, 0.5, 0.8])),
                     omega_body0=omega0, wheel_momentum0_n_m_s=h_wheels0)
    plant = Plant(plant_config(body, dynamics='cw'))
    axes = body.wheel_axes_body
    h0 = inertial_momentum(plant.truth(), inertia, axes)
    energy0 = kinetic_energy(omega0, inertia)
    worst_h = worst_energy = 0.0
    for k in range(20000):
        s = plant.step()
        if k % 50 == 49:
            worst_h = max(worst_h, float(np.linalg.norm(inertial_momentum(s, inertia, axes) - h0) / np.linalg.norm(h0)))
            worst_energy = max(worst_energy, abs(kinetic_energy(s.omega_chaser_body, inertia) - energy0) / energy0)
    assert s.t == pytest.approx(1000.0)
    assert worst_h < 1e-9
    assert worst_energy < 1e-9
    assert s.wheel_momentum_n_m_s.tolist() == list(h_wheels0)
    assert s.fuel_used_kg == 0.0 and not s.firing


@settings(max_examples=4, deadline=None)
@given(principal_moments, rotation_vector, st.tuples(rate, rate, rate),
       st.lists(st.floats(-0.1, 0.1), min_size=4, max_size=4))
def test_wheel_motor_torques_exchange_momentum_with_the_body_and_keep_the_total(moments, axes_rotvec, omega0,
                                                                                torques):
    """Four pyramid wheels under held motor torques for 100 s, past their momentum limits: the total inertial momentum
    stays to 1e-9 while the wheels' share changes; a wheel stops exactly at its limit and that is reported."""
    inertia = inertia_from(moments, axes_rotvec)
    body = rigid_body(inertia=inertia, omega_body0=omega0, wheel_axes_body=PYRAMID_AXES,
                     wheel_momentum0_n_m_s=(0.5, -0.5, 0.2, 0.0))
    plant = Plant(plant_config(body, dynamics='cw'))
    plant.command_wheels(0.0, torques)
    axes = [np.array(a) / np.linalg.norm(a) for a in PYRAMID_AXES]
    h0 = inertial_momentum(plant.truth(), inertia, axes)
    samples, events = step_to(plant, 100.0)
    drift = max(np.linalg.norm(inertial_momentum(s, inertia, axes) - h0) for s in samples) / np.linalg.norm(h0)
    assert drift < 1e-9
    h_end = samples[-1].wheel_momentum_n_m_s
    assert np.all(np.abs(h_end) <= 4.0)
    limited = {e.values['wheel'] for e in events if e.name == 'wheel_momentum_limited'}
    expected = {i for i, (h, u) in enumerate(zip((0.5, -0.5, 0.2, 0.0), torques, strict=True))
                if abs(h + u * 100.0) > 4.0}
    assert limited == expected
    for i in expected:
        assert h_end[i] == math.copysign(4.0, torques[i])  # exactly on the limit, no round-off past it
    for i in set(range(4)) - expected:  # the torque summed step by step: round-off of 1e-10 over 100 s
        assert h_end[i] == pytest.approx((0.5, -0.5, 0.2, 0.0)[i] + torques[i] * 100.0, abs=1e-9)


def test_wheel_limits_and_motion_agree_with_gyrostat_propagator():
    """Against the independent DOP853 propagator (rtol 1e-12) with the same held torques, limits included: the body
    rate and the wheel momenta agree to 1e-9 over 60 s, attitude to 1e-9 rad."""
    body = rigid_body(inertia=((10.0, 0.3, -0.2), (0.3, 12.0, 0.1), (-0.2, 0.1, 9.0)),
                     omega_body0=(0.05, -0.02, 0.03), wheel_momentum0_n_m_s=(3.5, -1.0, 0.0))
    plant = Plant(plant_config(body, dynamics='cw'))
    u = (0.1, -0.04, 0.2)  # wheel 2 is clipped to 0.1 N m; wheel 0 reaches 4 N m s at t = 5 s, wheel 2 at 40 s
    plant.command_wheels(0.0, u)
    samples, events = step_to(plant, 60.0)
    assert [(e.name, e.values.get('wheel')) for e in events] == [
        ('wheel_torque_limited', None), ('wheel_momentum_limited', 0), ('wheel_momentum_limited', 2)]
    assert [e.values['t'] for e in events[1:]] == [pytest.approx(5.0, abs=1e-9), pytest.approx(40.0, abs=1e-9)]
    wheels = ReactionWheels.orthogonal(0.1, 4.0, 0.01)
    propagator = GyrostatPropagator(body.inertia, wheels)
    state = ChaserAttitudeState(q_eci_from_body(0.0, N, body.q_hill_from_body0), np.array(body.omega_body0),
                                np.array(body.wheel_momentum0_n_m_s))
    for _ in range(60):  # 1 s steps: limits split inside, as the plant does
        state = propagator.step(state, 1.0, (0.0, 0.0, 0.0), u).state
    s = samples[-1]
    np.testing.assert_allclose(s.omega_chaser_body, state.omega_body, atol=1e-9)
    np.testing.assert_allclose(s.wheel_momentum_n_m_s, state.h_wheels_n_m_s, atol=1e-9)
    q_eci = q_eci_from_body(s.t, N, s.q_hill_from_chaser_body)
    assert np.linalg.norm(rotation_vector_from_quat(quat_multiply(quat_conjugate(state.q_inertial_from_body),
                                                                  q_eci))) < 1e-9
    np.testing.assert_allclose(s.wheel_torque_n_m, [0.0, -0.04, 0.0], rtol=1e-12)  # wheels 0 and 2 at their limits
    np.testing.assert_allclose(s.wheel_speed_rad_s, wheels.speeds_rad_s(s.wheel_momentum_n_m_s, s.omega_chaser_body))


def test_a_new_wheel_command_against_a_wheel_at_its_limit_is_reported_and_the_way_back_is_free():
    body = dataclasses.replace(BODY, wheel_momentum0_n_m_s=(4.0, 0.0, 0.0))
    plant = Plant(plant_config(body))
    plant.command_wheels(0.0, [0.05, 0.0, 0.0])  # outward: stopped
    plant.command_wheels(1.0, [-0.05, 0.0, 0.0])  # inward: free
    samples, events = step_to(plant, 2.0)
    assert [(e.name, e.values['seq'], e.values['wheel']) for e in events] == [('wheel_momentum_limited', 0, 0)]
    assert samples[19].wheel_momentum_n_m_s[0] == 4.0 and samples[19].wheel_torque_n_m[0] == 0.0
    assert samples[-1].wheel_momentum_n_m_s[0] == pytest.approx(3.95, abs=1e-12)


# ------------------------------------------------------------------------------------------------
# Thruster wrench commands

def test_wrench_command_is_reproduced_by_the_thrusters_without_errors_to_1e_9_over_its_hold():
    """A wrench held from t = 1.0 s to 2.0125 s (mid-step), then another: every step inside a hold delivers the
    commanded body force and torque to 1e-9, each thruster its allocated thrust; the step holding the change
    delivers the time-weighted mean."""
    plant = Plant(plant_config())
    first = (np.array([3.0, -2.0, 1.0]), np.array([0.2, -0.1, 0.4]))
    second = (np.array([-1.0, 0.5, 0.0]), np.array([0.0, 0.3, 0.0]))
    plant.command_wrench(1.0, *first)
    plant.command_wrench(2.0125, *second)
    samples, events = step_to(plant, 3.0)
    assert events == []
    by_t = {round(s.t, 6): s for s in samples}
    thrusts = allocate_wrench(default_thruster_layout(), *first).thrusts_n
    for k in range(21, 41):  # steps ending 1.05 ... 2.0 lie inside the first hold
        s, before = by_t[round(k * 0.05, 6)], by_t[round((k - 1) * 0.05, 6)]
        np.testing.assert_allclose(s.force_body_n, first[0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(s.torque_body_n_m, first[1], rtol=0, atol=1e-9)
        np.testing.assert_allclose(s.thruster_thrust_n, thrusts, rtol=0, atol=1e-9)
        # in hill the force turns with the body (and hill with the orbit) over the step: the mean keeps its size to
        # the square of that turn and lies within it of the end attitude's C_hill_from_body F
        turn_rad = (np.linalg.norm(s.omega_chaser_body) + N) * 0.05
        assert np.linalg.norm(s.force_hill) == pytest.approx(np.linalg.norm(first[0]), abs=4.0 * turn_rad ** 2)
        f_body_end = quat_to_matrix(s.q_hill_from_chaser_body).T @ s.force_hill
        assert math.acos(min(1.0, f_body_end @ first[0] / np.linalg.norm(f_body_end) / np.linalg.norm(first[0]))) \
            < turn_rad
        assert before.t == pytest.approx(s.t - 0.05)
        assert s.firing
    mixed = by_t[2.05]
    np.testing.assert_allclose(mixed.force_body_n, 0.25 * first[0] + 0.75 * second[0], atol=1e-9)
    np.testing.assert_allclose(mixed.torque_body_n_m, 0.25 * first[1] + 0.75 * second[1], atol=1e-9)
    np.testing.assert_allclose(by_t[3.0].torque_body_n_m, second[1], atol=1e-9)
    assert not by_t[1.0].firing and by_t[1.0].force_body_n.tolist() == [0.0, 0.0, 0.0]


def test_unachievable_wrench_is_reported_once_with_its_undelivered_part():
    plant = Plant(plant_config())
    command = plant.command_wrench(0.0, [100.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    samples, events = step_to(plant, 1.0)
    assert [e.name for e in events] == ['wrench_undelivered']
    np.testing.assert_allclose(events[0].values['undelivered_force_body_n'], [80.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(command.wrench_undelivered_body, [80.0, 0, 0, 0, 0, 0], atol=1e-9)
    np.testing.assert_allclose(samples[-1].force_body_n, [20.0, 0.0, 0.0], atol=1e-9)


def test_minimum_impulse_bit_per_step_is_reported_as_undelivered():
    """0.1 N along x is 0.05 N per thruster of the pair, 0.0025 N s per 0.05 s step: under the 0.01 N s bit."""
    plant = Plant(plant_config(thrusters=dataclasses.replace(EXACT, min_impulse_bit_ns=0.01)))
    plant.command_wrench(0.0, [0.1, 0.0, 0.0], [0.0, 0.0, 0.0])
    samples, events = step_to(plant, 0.5)
    assert [e.name for e in events] == ['wrench_undelivered']
    assert events[0].values['below_minimum_impulse'].tolist() == [0, 1]
    assert not any(s.firing for s in samples)


def test_minimum_impulse_bit_applies_over_the_hold_the_controller_announces():
    """guidance's 0.05 N m dumping couple: two thrusters at 0.1 N, 0.01 N s over its 0.1 s period (fired), half of
    that over one 0.05 s plant step (not fired, reported)."""
    for hold_s, fired in ((0.1, True), (None, False)):
        plant = Plant(plant_config(thrusters=dataclasses.replace(EXACT, min_impulse_bit_ns=0.01)))
        plant.command_wrench(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.05], hold_s=hold_s)
        samples, events = step_to(plant, 0.5)
        assert samples[-1].firing == fired
        assert [e.name for e in events] == ([] if fired else ['wrench_undelivered'])
        if fired:
            np.testing.assert_allclose(samples[-1].torque_body_n_m, [0.0, 0.0, 0.05], atol=1e-12)


def test_late_wrench_and_wheel_commands_are_applied_at_once_and_flagged():
    plant = Plant(plant_config())
    step_to(plant, 1.0)
    plant.command_wrench(0.6, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    plant.command_wheels(0.95, [0.01, 0.0, 0.0])
    events = plant.drain_events()
    assert [(e.name, e.level, e.values['command']) for e in events] == [('late_command', 'WARN', 'wrench'),
                                                                       ('late_command', 'WARN', 'wheels')]
    assert events[0].values['lateness_s'] == pytest.approx(0.4)
    assert events[1].values['lateness_s'] == pytest.approx(0.05)
    s = plant.step()
    np.testing.assert_allclose(s.force_body_n, [1.0, 0.0, 0.0], atol=1e-12)  # the whole step, from t = 1.0
    np.testing.assert_allclose(s.wheel_torque_n_m, [0.01, 0.0, 0.0], atol=1e-15)


def test_commands_apply_from_their_stamps_whenever_they_arrive():
    """Time tags: the same commands sent early or each just before its stamp give the same truth to the bit."""
    commands = [(2.0125, 'wrench', ([0.5, 0.0, -0.2], [0.0, 0.1, 0.0])), (3.0, 'wheels', ([0.02, -0.01, 0.0],)),
                (4.0, 'maneuver', ([0.05, 0.0, 0.02],)), (6.01, 'wrench', ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]))]

    def send(plant, command):
        t, kind, args = command
        getattr(plant, f'command_{kind}')(t, *args)

    early = Plant(plant_config(thrusters=NOISY))
    for c in commands:
        send(early, c)
    late = Plant(plant_config(thrusters=NOISY))
    pending = list(commands)
    a, _ = step_to(early, 8.0)
    b = []
    while late.t < 8.0 - 1e-9:
        while pending and pending[0][0] < late.t + 0.05:
            send(late, pending.pop(0))
        b.append(late.step())
    for x, y in zip(a, b, strict=True):
        assert x.r_hill.tolist() == y.r_hill.tolist() and x.v_hill.tolist() == y.v_hill.tolist()
        assert x.q_hill_from_chaser_body.tolist() == y.q_hill_from_chaser_body.tolist()
        assert x.wheel_momentum_n_m_s.tolist() == y.wheel_momentum_n_m_s.tolist()
        assert x.mass_kg == y.mass_kg


def test_point_mass_plant_refuses_wrench_and_wheel_commands():
    plant = Plant(plant_config(body=None))
    with pytest.raises(ValueError, match='point-mass chaser'):
        plant.command_wrench(0.0, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match='point-mass chaser'):
        plant.command_wheels(0.0, [0.0, 0.0, 0.0])


@pytest.mark.parametrize('args, pattern', [((math.nan, [0, 0, 0], [0, 0, 0]), 'stamp'),
                                           ((0.0, [0, 0], [0, 0, 0]), 'force_body_n'),
                                           ((0.0, [0, 0, 0], [0, math.inf, 0]), 'torque_body_n_m'),
                                           ((0.0, [0, 0, 0], [0, 0, 0], 0.0), 'hold_s')])
def test_bad_wrench_command_names_itself(args, pattern):
    with pytest.raises(ValueError, match=pattern):
        Plant(plant_config()).command_wrench(*args)


# ------------------------------------------------------------------------------------------------
# Delta-v burns by the body-fixed thrusters

def test_impulsive_maneuver_at_an_attitude_90_deg_off_delivers_the_commanded_delta_v():
    """Far from gravity (mu 1e-6), errors off, body +x turned 90 deg away from hill +x: the burn allocates the
    delta-v's body direction and the velocity changes by dv to 1e-6; no torque, so the attitude holds."""
    q0 = tuple(quat_from_axis_angle([0.0, 0.0, 1.0], math.pi / 2).tolist())  # body +x along hill +y
    body = dataclasses.replace(BODY, q_hill_from_body0=q0)
    plant = Plant(plant_config(body, mu=1e-6))
    dv = np.array([0.3, -0.2, 0.1])
    request = plant.command_maneuver(1.0, dv)
    assert request.request_s == 1.0
    v0 = plant.truth().v_hill
    samples, events = step_to(plant, 10.0)
    end = samples[-1]
    np.testing.assert_allclose(end.v_hill - v0, dv, atol=1e-6)
    assert end.dv_applied_total_mps == pytest.approx(np.linalg.norm(dv), abs=1e-9)
    assert [e.name for e in events] == ['burn_started', 'burn_ended']
    started = events[0].values
    assert started['t_start'] == 1.0
    np.testing.assert_allclose(started['direction_body'], quat_rotate(quat_conjugate(q0), dv / np.linalg.norm(dv)),
                               atol=1e-15)
    plan = plan_burn(default_thruster_layout(), started['direction_body'], np.linalg.norm(dv), 100.0, 10.0)
    assert started['force_n'] == pytest.approx(10.0, rel=1e-12)  # the point-mass chaser's thrust
    assert started['t_end'] == pytest.approx(1.0 + plan.duration_s, abs=1e-12)
    assert end.fuel_used_kg == pytest.approx(plan.fuel_kg, rel=1e-12)
    np.testing.assert_allclose(events[1].values['dv_delivered_hill'], dv, atol=1e-6)
    np.testing.assert_allclose(end.omega_chaser_body, 0.0, atol=1e-9)
    np.testing.assert_allclose(end.q_hill_from_chaser_body * np.sign(end.q_hill_from_chaser_body[3]), q0, atol=1e-9)


def test_small_burn_off_the_body_axes_delivers_its_delta_v_despite_the_minimum_impulse_bit():
    """A 0.3 mm/s trim along (1, 0.2, 0.1) (far from gravity, errors off, 0.01 N s bit): at 10 N it lasts 3 ms, so the
    least-thrust pure force would put 3 and 1.5 mN s on the y and z thrusters, below the bit, and lose a fifth of the
    delta-v's direction; the burn fires them against their opposite pairs instead and delivers the delta-v."""
    plant = Plant(plant_config(mu=1e-6, thrusters=dataclasses.replace(EXACT, min_impulse_bit_ns=0.01)))
    dv = 3e-4 * np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])
    v0 = plant.truth().v_hill
    plant.command_maneuver(0.5, dv)
    samples, events = step_to(plant, 1.0)
    np.testing.assert_allclose(samples[-1].v_hill - v0, dv, rtol=0.0, atol=1e-12)
    started, ended = (e.values for e in events)
    assert started['minimum_impulse_allocated'] and len(started['below_minimum_impulse']) == 0
    assert started['force_n'] == pytest.approx(10.0, rel=1e-9)
    assert np.count_nonzero(started['thrusts_n']) == 10
    np.testing.assert_allclose(ended['dv_delivered_hill'], dv, rtol=0.0, atol=1e-12)


def test_burn_in_orbit_with_the_attitude_held_in_hill_delivers_dv_along_its_hill_direction():
    """On the real orbit, a spherical chaser turning with hill (omega = (0, -n, 0)) holds its attitude in hill: the
    delivered thrust acceleration, integrated in hill, is dv to 1e-6 and the sum of |dv| is |dv|."""
    body = rigid_body(inertia=np.diag([10.0, 10.0, 10.0]), q_hill_from_body0=(0.0, 0.0, 1.0, 0.0),
                     omega_body0=tuple(quat_rotate((0.0, 0.0, -1.0, 0.0), (0.0, -N, 0.0))))
    plant = Plant(plant_config(body))
    dv = np.array([-0.1, 0.05, 0.2])
    plant.command_maneuver(1.0, dv)
    samples, events = step_to(plant, 5.0)
    ended = next(e for e in events if e.name == 'burn_ended')
    np.testing.assert_allclose(ended.values['dv_delivered_hill'], dv, atol=1e-6)
    assert samples[-1].dv_applied_total_mps == pytest.approx(np.linalg.norm(dv), abs=1e-9)
    started = next(e for e in events if e.name == 'burn_started')
    np.testing.assert_allclose(started.values['dv_hill'], dv, atol=1e-6)


def test_late_and_chained_burns_and_rejections_keep_their_events():
    plant = Plant(plant_config())
    step_to(plant, 2.0)
    plant.command_maneuver(1.5, [0.2, 0.0, 0.0])  # late: starts now
    plant.command_maneuver(2.05, [0.0, 0.1, 0.0])  # waits for the first to end
    with pytest.raises(ManeuverRejected, match='exceeds max_delta_v_per_maneuver_mps'):
        plant.command_maneuver(3.0, [3.0, 0.0, 0.0])
    samples, events = step_to(plant, 5.0)
    names = [e.name for e in events]
    assert names == ['maneuver_rejected', 'burn_started', 'late_maneuver', 'burn_ended', 'burn_started',
                     'late_maneuver', 'burn_ended']
    first_end = events[3].values['t_end']
    assert events[4].values['t_start'] == first_end


def test_wrench_held_during_a_burn_adds_to_it_limited_per_thruster():
    plant = Plant(plant_config())
    plant.command_maneuver(0.0, [0.3, 0.0, 0.0])  # from the default attitude: body -x, thrusters 2 and 3 at 5 N
    plant.command_wrench(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 4.0])  # a couple of 8 N on thrusters 1 and 2 (or 0 and 3)
    samples, events = step_to(plant, 0.5)
    assert 'wrench_limited_by_burn' in [e.name for e in events]
    assert np.all(samples[-1].thruster_thrust_n <= 10.0 + 1e-12)


# ------------------------------------------------------------------------------------------------
# Fuel and the restriction sphere

def test_fuel_is_the_sum_of_every_thruster_impulse_over_isp_g0():
    """Burns and attitude wrenches with thruster errors: the mass lost equals sum over steps and thrusters of the
    mean thrust x step / (Isp g0) to 1e-12 relative."""
    plant = Plant(plant_config(thrusters=NOISY))
    plant.command_maneuver(1.0, [0.1, -0.05, 0.02])
    plant.command_wrench(0.5, [0.0, 0.0, 0.0], [0.0, 0.4, 0.0])
    plant.command_wrench(3.0, [0.5, 0.5, 0.0], [0.0, 0.0, -0.3])
    plant.command_wrench(6.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    samples, _ = step_to(plant, 8.0)
    impulse = sum(float(s.thruster_thrust_n.sum()) * 0.05 for s in samples)
    fuel = impulse / (220.0 * STANDARD_GRAVITY_M_S2)
    assert samples[-1].fuel_used_kg == pytest.approx(fuel, rel=1e-12)
    assert samples[-1].mass_kg == pytest.approx(100.0 - fuel, rel=1e-15)


def test_attitude_control_firing_inside_the_restriction_sphere_is_reported_once_per_command():
    plant = Plant(plant_config(r0_hill=(10.0, 0.0, 2.0)))
    plant.command_wheels(0.0, [0.05, 0.0, 0.0])  # wheels alone: no plume
    _, events = step_to(plant, 1.0)
    assert events == []
    plant.command_wrench(1.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.2])  # a pure couple: no force, still a plume
    plant.command_wrench(2.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    plant.command_maneuver(3.0, [0.01, 0.0, 0.0])
    _, events = step_to(plant, 5.0)
    reports = [e for e in events if e.name == 'thrust_inside_restriction_sphere']
    assert [(e.level, e.values['source'], e.values['seq']) for e in reports] == [('ERROR', 'wrench', 0),
                                                                                ('ERROR', 'burn', 0)]
    assert reports[0].values['t'] == 1.0


def test_a_run_of_firing_wrench_commands_inside_the_restriction_sphere_is_reported_once():
    """Continuous control fires a new wrench every period: one event for each run of consecutive firing
    commands (seq 0-2, then seq 4-5 after a command that does not fire), not one per command."""
    plant = Plant(plant_config(r0_hill=(10.0, 0.0, 2.0)))
    for k in range(6):
        torque = [0.0, 0.0, 0.0] if k == 3 else [0.0, 0.0, 0.2]
        plant.command_wrench(0.5 * k, [0.0, 0.0, 0.0], torque)
    _, events = step_to(plant, 3.5)
    reports = [e for e in events if e.name == 'thrust_inside_restriction_sphere']
    assert [(e.values['source'], e.values['seq'], e.values['t']) for e in reports] == [('wrench', 0, 0.0),
                                                                                      ('wrench', 4, 2.0)]


# ------------------------------------------------------------------------------------------------
# The IMU

def test_imu_samples_at_its_rate_with_the_star_tracker_on_every_fifth_from_the_first():
    """10 Hz IMU, 2 Hz star tracker on samples 1, 6, 11, ... (t = 0.1, 0.6, 1.1 s, ...): the first sample carries
    one, so the estimator has an attitude from the first IMU stamp on."""
    plant = Plant(plant_config())
    imu = []
    for _ in range(400):  # 20 s
        s = plant.step()
        for m in plant.measurements():
            if m.kind == 'chaser_imu':
                assert m.t == s.t == m.value.t
                imu.append(m.value)
    assert len(imu) == 200  # 10 Hz
    with_star = [x.t for x in imu if x.q_hill_from_body is not None]
    assert len(with_star) == 40 and all(abs((t - 0.1) * 2.0 - round((t - 0.1) * 2.0)) < 1e-9 for t in with_star)
    assert imu[0].q_hill_from_body is not None and with_star[0] == imu[0].t


def test_imu_accelerometer_senses_a_burn_shorter_than_its_interval_in_full():
    """A 3 ms burn between two 10 Hz samples: the accelerometer reports the mean specific force over the 0.1 s
    interval, so its value times 0.1 s is the burn's delta-v in chaser_body (noise off); the next interval, with
    nothing firing, reads zero. The body is turned 90 deg from hill, so the increment is resolved in body axes."""
    q0 = tuple(quat_from_axis_angle([0.0, 0.0, 1.0], math.pi / 2).tolist())
    quiet = dataclasses.replace(BODY.imu, accel_noise_sigma_mps2=0.0)
    body = dataclasses.replace(BODY, q_hill_from_body0=q0, imu=quiet)
    plant = Plant(plant_config(body, mu=1e-6))
    dv = np.array([2e-4, -1e-4, 1.5e-4])
    plant.command_maneuver(0.52, dv)  # 0.52 s to 0.52 s + 2.7 ms, inside the interval (0.5, 0.6]
    imu = {}
    while plant.t < 0.75:
        plant.step()
        imu.update({round(m.t, 6): m.value for m in plant.measurements() if m.kind == 'chaser_imu'})
    dv_body = quat_rotate(quat_conjugate(plant.truth().q_hill_from_chaser_body), dv)
    np.testing.assert_allclose(imu[0.6].specific_force_body * 0.1, dv_body, rtol=0.0, atol=1e-12)
    np.testing.assert_array_equal(imu[0.5].specific_force_body, 0.0)
    np.testing.assert_array_equal(imu[0.7].specific_force_body, 0.0)


def test_imu_star_tracker_and_gyro_errors_have_the_configured_statistics():
    """Star tracker sigma 0.5 deg per body axis; gyro white noise 1e-3 rad/s about the true rate plus a bias that
    walks by sigma_bw sqrt(dt) between samples (the truth reports it); specific force is thrust / mass in body."""
    imu = ImuConfig(rate_hz=20.0, star_tracker_rate_hz=20.0, star_tracker_sigma_rad=math.radians(0.5),
                    gyro_noise_sigma_rad_s=1e-3, gyro_bias_sigma_rad_s=1e-2, gyro_bias_walk_rad_s_sqrt_s=1e-3,
                    accel_noise_sigma_mps2=1e-3)
    body = dataclasses.replace(BODY, omega_body0=(0.01, -0.02, 0.005), imu=imu)
    plant = Plant(plant_config(body, dynamics='cw'))
    plant.command_wrench(0.0, [1.0, -0.5, 0.2], [0.0, 0.0, 0.0])
    star, gyro, accel, bias_steps = [], [], [], []
    bias = plant.truth().gyro_bias_rad_s
    for _ in range(4000):
        s = plant.step()
        (m,) = [m for m in plant.measurements() if m.kind == 'chaser_imu']
        x = m.value
        star.append(rotation_vector_from_quat(quat_multiply(quat_conjugate(s.q_hill_from_chaser_body),
                                                            x.q_hill_from_body)))
        gyro.append(x.omega_body_meas - s.omega_chaser_body - s.gyro_bias_rad_s)
        accel.append(x.specific_force_body - s.force_body_n / s.mass_kg)
        bias_steps.append(s.gyro_bias_rad_s - bias)
        bias = s.gyro_bias_rad_s
    np.testing.assert_allclose(np.std(star, axis=0), math.radians(0.5), rtol=0.07)
    np.testing.assert_allclose(np.std(gyro, axis=0), 1e-3, rtol=0.07)
    np.testing.assert_allclose(np.std(accel, axis=0), 1e-3, rtol=0.07)
    np.testing.assert_allclose(np.std(bias_steps, axis=0), 1e-3 * math.sqrt(0.05), rtol=0.07)
    np.testing.assert_allclose(np.mean(gyro, axis=0), 0.0, atol=5 * 1e-3 / math.sqrt(4000))


def test_adding_the_imu_leaves_the_other_sensors_draws_unchanged():
    """Nothing fires: the rigid-body chaser's translation is the point-mass chaser's to the bit, and its relative
    position and target attitude measurements are the same numbers despite the IMU's draws."""
    rigid = Plant(plant_config())
    point = Plant(plant_config(body=None))
    for _ in range(200):
        a, b = rigid.step(), point.step()
        assert a.r_hill.tolist() == b.r_hill.tolist() and a.v_hill.tolist() == b.v_hill.tolist()
        ma = [(m.kind, m.t, m.value.tolist()) for m in rigid.measurements()
              if m.kind not in ('chaser_imu', 'wheel_speeds')]
        mb = [(m.kind, m.t, m.value.tolist()) for m in point.measurements()]
        assert ma == mb


# ------------------------------------------------------------------------------------------------
# Scenario wiring and the point-mass guarantee

def test_rigid_body_keys_leave_a_point_mass_run_identical():
    """paper_flyby with every rigid-body key set but chaser.model point_mass: the same plant configuration, and the
    same truth, measurements and events to the bit with burns commanded."""
    data = yaml.safe_load((REPO / 'scenarios' / 'paper_flyby.yaml').read_text())
    with_keys = yaml.safe_load((REPO / 'scenarios' / 'paper_flyby_6dof.yaml').read_text())
    with_keys['chaser']['model'] = 'point_mass'
    with_keys['chaser']['wheels']['initial_momentum_n_m_s'] = [1.0, -2.0, 0.5]
    with_keys['chaser']['thrusters']['layout'] = [
        {'position_m': p.tolist(), 'direction': d.tolist()}
        for p, d in zip(default_thruster_layout().positions_body_m, default_thruster_layout().force_directions_body,
                        strict=True)]
    with_keys['sensors']['chaser_imu']['gyro_noise_sigma_rad_s'] = 0.1
    with_keys['name'], with_keys['description'] = data['name'], data['description']
    a_config = PlantConfig.from_scenario(scenario_from_dict(data))
    b_config = PlantConfig.from_scenario(scenario_from_dict(with_keys))
    assert a_config == b_config and b_config.chaser_body is None
    runs = []
    for config in (a_config, b_config):
        plant = Plant(config)
        plant.command_maneuver(1.0, [0.3, -0.2, 0.1])
        samples, events = step_to(plant, 20.0)
        runs.append(([(s.r_hill.tolist(), s.v_hill.tolist(), s.mass_kg) for s in samples], events))
    assert runs[0] == runs[1]


def test_paper_flyby_6dof_builds_the_rigid_body_chaser_at_its_documented_defaults():
    sc = load_scenario(REPO / 'scenarios' / 'paper_flyby_6dof.yaml')
    config = PlantConfig.from_scenario(sc)
    body = config.chaser_body
    assert body.inertia == ((10.0, 0.0, 0.0), (0.0, 10.0, 0.0), (0.0, 0.0, 10.0))
    plant = Plant(config)
    s = plant.truth()
    np.testing.assert_allclose(quat_rotate(s.q_hill_from_chaser_body, [1.0, 0.0, 0.0]), [-1.0, 0.0, 0.0], atol=1e-15)
    assert s.omega_chaser_body.tolist() == [0.0, 0.0, 0.0]
    assert plant.chaser.layout.count == 12 and plant.chaser.wheels.count == 3
    assert body.imu == SCHEMA_BODY.imu
    # The file writes out the defaults: without the rigid-body keys it is the same chaser.
    data = yaml.safe_load((REPO / 'scenarios' / 'paper_flyby_6dof.yaml').read_text())
    for key in ('inertia_kg_m2', 'initial_attitude', 'initial_rate', 'wheels'):
        del data['chaser'][key]
    del data['sensors']['chaser_imu']
    assert PlantConfig.from_scenario(scenario_from_dict(data)) == config


def test_capture_carries_the_chaser_attitude_with_the_target():
    plant = Plant(plant_config(body=dataclasses.replace(BODY, omega_body0=(0.01, 0.0, 0.0)), r0_hill=(2.0, 0.0, 0.0)))
    plant.command_wrench(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.1])
    step_to(plant, 1.0)
    plant.capture()
    assert plant.command_wrench(1.0, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]) is None
    events = plant.drain_events()
    assert [e.name for e in events] == ['captured', 'command_ignored']
    samples, _ = step_to(plant, 5.0)
    relative = [quat_multiply(quat_conjugate(s.q_hill_from_body), s.q_hill_from_chaser_body) for s in samples]
    np.testing.assert_allclose(np.array(relative) * np.sign(np.array(relative)[:, 3:]),
                               np.tile(relative[0] * np.sign(relative[0][3]), (len(relative), 1)), atol=1e-12)
    assert not any(s.firing for s in samples)
