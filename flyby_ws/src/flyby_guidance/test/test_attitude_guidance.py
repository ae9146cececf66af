"""attitude_guidance.py: the line-of-sight goal and its feed-forward, the roll rule, the closed-loop fly-by
pointing on the wheels, momentum dumping outside the restriction sphere and none inside."""

import math

import numpy as np
import pytest

from flyby_guidance.attitude_guidance import (
    AttitudeGuidance,
    AttitudeGuidanceConfig,
    LineOfSightGoal,
    hold_goal,
    line_of_sight,
    roll_relaxation_rate,
    roll_rule_attitude,
    simulate_pointing,
)
from flyby_sim.dynamics.actuators import allocate_wrench, default_thruster_layout, fire
from flyby_sim.dynamics.orbital import cw_coast, mean_motion_rad_s, quat_eci_from_hill
from flyby_sim.dynamics.rigid_body import GyrostatPropagator, ReactionWheels
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_axis_angle,
    quat_multiply,
    quat_rotate,
    quat_to_matrix,
    rotation_vector_from_quat,
)

SEED001_SERVICER = np.diag([13.0, 38.0, 35.0])  # seed 001 Table 1, the servicing satellite [kg m^2]
WHEELS = ReactionWheels.orthogonal(max_torque_n_m=0.1, max_momentum_n_m_s=4.0, spin_inertia_kg_m2=0.01)
N = mean_motion_rad_s(7.0e6)  # paper_flyby's orbit
SPHERE_M = 15.0  # paper_flyby's restriction sphere


def flyby_path(r_closest_hill, v_closest_hill, t_closest_s):
    """t -> (r_hill, v_hill) of the CW coast through r_closest_hill, v_closest_hill at t_closest_s."""
    def path(t):
        state = cw_coast(np.asarray(r_closest_hill, float), np.asarray(v_closest_hill, float), t - t_closest_s, N)
        return state[:3], state[3:]
    return path


# 5 m from the target's CoM at 0.2 m/s, passing 11 deg from R-bar (the roll rule's singular direction) with an
# out-of-plane component: the line of sight turns at up to 2.3 deg/s near the closest approach.
R_CLOSEST = 5.0 * np.array([0.0, 1.0, -5.0]) / math.sqrt(26.0)
V_CLOSEST = 0.2 * np.array([1.0, 0.0, 0.0])
FLYBY = flyby_path(R_CLOSEST, V_CLOSEST, 150.0)


def test_line_of_sight_rate_and_acceleration_against_finite_differences():
    """omega = u x u' and its derivative from differences of u(t) along a CW coast (seed 000 eq 22)."""
    t, h = 140.0, 1e-3
    los = line_of_sight(*FLYBY(t), N)
    u = [line_of_sight(*FLYBY(t + k * h), N).u_hill for k in (-1, 0, 1)]
    u_dot = (u[2] - u[0]) / (2.0 * h)
    assert np.allclose(los.omega_hill_rad_s, np.cross(u[1], u_dot), rtol=0.0, atol=1e-9)
    omega = [line_of_sight(*FLYBY(t + k * h), N).omega_hill_rad_s for k in (-1, 1)]
    assert np.allclose(los.omega_dot_hill_rad_s2, (omega[1] - omega[0]) / (2.0 * h), rtol=0.0, atol=1e-10)
    assert 0.033 < np.linalg.norm(los.omega_hill_rad_s) < 0.035  # 1.95 deg/s, 10 s before the closest approach


def _goals(tracker, times):
    return [tracker.update(t, *FLYBY(t), N) for t in times]


@pytest.mark.parametrize('max_roll_rate', [0.0, 0.005])
def test_goal_rate_and_acceleration_are_the_inertial_motion_of_the_goal_attitude(max_roll_rate):
    """omega_goal (goal axes) against the difference of q_eci_from_goal = q_eci_from_hill(t) q_hill_from_goal(t);
    omega_dot_goal against the difference of omega_goal in ECI axes (without roll: the roll rate's own change is
    not fed forward; with it, the goal's roll over a step is the previous roll rate's, so the central difference
    trails the reported rate by half the roll rate's change over a step, 5e-7 rad/s here). Checks
    Omega = (0, -n, 0), the frames and the signs."""
    h = 0.01
    times = 145.0 + h * np.arange(5)
    tracker = LineOfSightGoal(max_roll_rate_rad_s=max_roll_rate)
    tracker.reset(quat_from_axis_angle([1.0, 2.0, 3.0], 1.0))  # a roll away from the rule's
    goals = _goals(tracker, times)
    q_eci = [quat_multiply(quat_eci_from_hill(t, N), g.q_hill_from_goal) for t, g in zip(times, goals, strict=True)]
    omega_numeric = rotation_vector_from_quat(quat_multiply(quat_conjugate(q_eci[1]), q_eci[3])) / (2.0 * h)
    assert np.allclose(goals[2].omega_goal, omega_numeric, rtol=0.0, atol=2e-8 if max_roll_rate == 0.0 else 1e-6)
    assert (goals[2].roll_rate_rad_s != 0.0) == (max_roll_rate > 0.0)
    if max_roll_rate == 0.0:
        omega_eci = [quat_rotate(q, g.omega_goal) for q, g in zip(q_eci, goals, strict=True)]
        alpha_numeric = quat_rotate(quat_conjugate(q_eci[2]), (omega_eci[3] - omega_eci[1]) / (2.0 * h))
        assert np.allclose(goals[2].omega_dot_goal, alpha_numeric, rtol=0.0, atol=1e-8)
        assert np.linalg.norm(goals[2].omega_dot_goal) > 1e-4


def test_goal_is_continuous_where_the_roll_rule_is_singular():
    """A fly-by straight over the target (the line of sight through hill +z, where 'goal z nearest hill z'
    flips): the rule's own attitude turns 180 deg about the line of sight there, the goal moves no more than the
    line of sight and the roll rate allow, and its +x is the line of sight throughout."""
    path = flyby_path([0.0, 0.0, -5.0], [0.2, 0.0, 0.0], 100.0)
    tracker = LineOfSightGoal()
    dt = 0.5
    previous = None
    for t in np.arange(0.0, 200.0, dt):
        r, v = path(t)
        goal = tracker.update(t, r, v, N)
        assert np.allclose(goal.u_hill, -r / np.linalg.norm(r), atol=1e-15)
        assert np.allclose(quat_to_matrix(goal.q_hill_from_goal)[:, 0], goal.u_hill, atol=1e-12)
        if previous is not None:
            step = np.linalg.norm(rotation_vector_from_quat(quat_multiply(quat_conjugate(previous.q_hill_from_goal),
                                                                          goal.q_hill_from_goal)))
            los_step = math.acos(min(1.0, float(previous.u_hill @ goal.u_hill)))
            assert step <= los_step + 0.005 * dt + 1e-12
        previous = goal
    before = roll_rule_attitude(-np.array(path(99.0)[0]))
    after = roll_rule_attitude(-np.array(path(101.0)[0]))
    flip = np.linalg.norm(rotation_vector_from_quat(quat_multiply(quat_conjugate(before), after)))
    assert flip > math.radians(170.0)


def test_roll_relaxes_to_the_rule():
    """At rest on V-bar (a CW equilibrium) with the goal rolled 90 deg from 'goal z along hill z': the roll turns
    back at omega_roll_max, then exponentially with tau_roll, never overshooting."""
    def at_rest(_t):
        return np.array([20.0, 0.0, 0.0]), np.zeros(3)
    rule = roll_rule_attitude([-1.0, 0.0, 0.0])
    assert np.allclose(quat_to_matrix(rule), [[-1, 0, 0], [0, -1, 0], [0, 0, 1]], atol=1e-15)
    tracker = LineOfSightGoal(roll_time_constant_s=100.0, max_roll_rate_rad_s=0.005)
    tracker.reset(quat_multiply(rule, quat_from_axis_angle([1.0, 0.0, 0.0], math.pi / 2)))
    offsets = []
    for t in np.arange(0.0, 2000.0, 1.0):
        goal = tracker.update(t, *at_rest(t), N)
        offsets.append(np.linalg.norm(rotation_vector_from_quat(quat_multiply(quat_conjugate(rule),
                                                                              goal.q_hill_from_goal))))
    offsets = np.array(offsets)
    assert offsets[0] == pytest.approx(math.pi / 2, abs=1e-12)
    assert offsets[100] == pytest.approx(math.pi / 2 - 0.5, abs=1e-9)  # 100 s at 0.005 rad/s
    assert np.all(np.diff(offsets) <= 1e-15) and offsets[-1] < 1e-5
    assert roll_relaxation_rate(rule, (0.0, 0.0, 1.0), 100.0, 0.005) == 0.0


def test_acquisition_starts_from_the_chaser_attitude_without_a_roll():
    """The first goal is the chaser's attitude turned by the smallest rotation onto the line of sight: the error
    axis is perpendicular to both body +x and the line of sight, its angle the pointing error (30 deg)."""
    r, v = FLYBY(0.0)
    u = -r / np.linalg.norm(r)
    q_body = quat_multiply(roll_rule_attitude(u), quat_from_axis_angle([0.0, 0.6, 0.8], math.radians(30.0)))
    q_body = quat_multiply(q_body, quat_from_axis_angle([1.0, 0.0, 0.0], 2.0))  # any roll of the chaser
    guidance = AttitudeGuidance(AttitudeGuidanceConfig(), SEED001_SERVICER, WHEELS)
    guidance.command(0.0, q_body, np.zeros(3), np.zeros(3), r, v, N, inside_restriction_sphere=False)
    error = rotation_vector_from_quat(quat_multiply(quat_conjugate(guidance.goal.q_hill_from_goal), q_body))
    x_body = quat_to_matrix(q_body)[:, 0]
    error_hill = quat_rotate(q_body, error)
    assert np.linalg.norm(error) == pytest.approx(math.radians(30.0), abs=1e-12)
    assert abs(error_hill @ u) < 1e-12 and abs(error_hill @ x_body) < 1e-12


def test_hold_goal_turns_with_hill():
    q = quat_from_axis_angle([0.2, -1.0, 0.4], 0.7)
    goal = hold_goal(q, N)
    assert np.allclose(quat_rotate(q, goal.omega_goal), [0.0, -N, 0.0], atol=1e-18)
    assert not goal.omega_dot_goal.any()


def test_closed_loop_flyby_points_body_x_within_1_deg():
    """Seed 001's servicer on three 0.1 N m / 4 N m s wheels coasting past the target (5 m at 0.2 m/s, the line
    of sight up to 2.3 deg/s), commands held 0.1 s and applied one period after the estimates they come from
    (attitude error 0.01 deg, rate error 1e-5 rad/s per axis), gravity gradient on: measured 95th percentile
    0.0150 deg, largest 0.0217 deg, peak wheel momentum 1.485 N m s, peak wheel torque 0.0416 N m
    (scripts/bench/benchmark_pointing.py prints them)."""
    guidance = AttitudeGuidance(AttitudeGuidanceConfig(), SEED001_SERVICER, WHEELS)
    run = simulate_pointing(guidance, GyrostatPropagator(SEED001_SERVICER, WHEELS), FLYBY, 0.0, 300.0, N,
                            rng=np.random.default_rng(13), attitude_sigma_rad=math.radians(0.01),
                            rate_sigma_rad_s=1e-5, restriction_sphere_radius_m=SPHERE_M)
    p95 = run.percentile_deg(95)
    print(f'fly-by pointing: 95th percentile {p95:.4f} deg, max {math.degrees(run.pointing_error_rad.max()):.4f} '
          f'deg, peak LOS rate {math.degrees(run.los_rate_rad_s.max()):.2f} deg/s, peak wheel momentum '
          f'{np.abs(run.h_wheels_n_m_s).max():.3f} N m s, peak wheel torque {np.abs(run.wheel_torque_n_m).max():.4f}')
    assert math.degrees(run.los_rate_rad_s.max()) > 2.0
    assert p95 <= 1.0  # the pointing's requirement
    assert p95 < 0.02 and math.degrees(run.pointing_error_rad.max()) < 0.1  # what it does (regression)
    assert run.saturated_steps == run.torque_limited_steps == run.momentum_limited_steps == 0
    assert np.abs(run.h_wheels_n_m_s).max() < 2.0 and np.abs(run.wheel_torque_n_m).max() < 0.1
    assert not run.thruster_torque_body_n_m.any()  # the wheels never needed a dump on this pass


def _held_on_v_bar(range_m, h0, duration_s=60.0):
    guidance = AttitudeGuidance(AttitudeGuidanceConfig(), SEED001_SERVICER, WHEELS)

    def at_rest(_t):
        return np.array([range_m, 0.0, 0.0]), np.zeros(3)
    run = simulate_pointing(guidance, GyrostatPropagator(SEED001_SERVICER, WHEELS), at_rest, 0.0, duration_s, N,
                            restriction_sphere_radius_m=SPHERE_M, h_wheels0_n_m_s=h0)
    return guidance, run


def test_dumping_outside_the_sphere_drains_the_wheels_while_they_hold_the_pointing():
    h0 = np.array([1.5, -1.2, 0.8])
    guidance, run = _held_on_v_bar(30.0, h0)
    # each axis drained to 0.2 N m s, then the body's turn with hill (n about body y) trades x and z a little
    h_end = run.h_wheels_n_m_s[-1]
    assert np.all(np.abs(h_end) <= 0.25) and np.linalg.norm(h_end) < 0.35 and not guidance.dumping
    thrust = run.thruster_torque_body_n_m
    fired = thrust != 0.0
    assert fired.any()
    assert np.all(np.abs(thrust[fired]) == 0.05)  # tau_min = tau_max at 0.1 s: bang-bang
    assert np.all(np.sign(thrust[fired]) == -np.sign(np.broadcast_to(h0, thrust.shape)[fired]))
    assert math.degrees(run.pointing_error_rad.max()) < 0.01 and run.saturated_steps == 0


def test_no_thruster_torque_inside_the_sphere():
    h0 = np.array([1.5, -1.2, 0.8])
    guidance, run = _held_on_v_bar(10.0, h0, duration_s=30.0)
    assert np.all(run.thruster_torque_body_n_m == 0.0) and not guidance.dumping
    # the body turns with hill at n about body y: the wheels' x and z momentum turn with it, |h| stays
    assert np.linalg.norm(run.h_wheels_n_m_s[-1]) == pytest.approx(np.linalg.norm(h0), abs=1e-3)
    assert math.degrees(run.pointing_error_rad.max()) < 0.01


def test_a_dump_under_way_stops_at_the_sphere_and_leaves_way_to_the_pointing():
    guidance = AttitudeGuidance(AttitudeGuidanceConfig(), SEED001_SERVICER, WHEELS)
    r, v = np.array([15.5, 0.0, 0.0]), np.array([-0.1, 0.0, 0.0])
    goal = LineOfSightGoal().update(0.0, r, v, N)
    q, omega = goal.q_hill_from_goal, goal.omega_goal
    h = np.array([1.0, -1.0, 0.5])
    outside = guidance.command(0.0, q, omega, h, r, v, N, inside_restriction_sphere=False)
    assert guidance.dumping and outside.thruster_torque_body_n_m.tolist() == [-0.05, 0.05, -0.05]
    # wheels: the control torque less the thruster torque
    assert np.allclose(-WHEELS.axis_matrix @ outside.wheel_torque_n_m + outside.thruster_torque_body_n_m,
                       guidance.body_torque_n_m, atol=1e-17)
    inside = guidance.command(0.1, q, omega, h, r + 0.1 * v, v, N, inside_restriction_sphere=True)
    assert inside.thruster_torque_body_n_m.tolist() == [0.0, 0.0, 0.0] and not guidance.dumping
    # far off the goal the control torque takes the wheels' whole torque: no dump (pointing first)
    off = quat_multiply(q, quat_from_axis_angle([0.0, 1.0, 1.0], 0.5))
    busy = guidance.command(0.2, off, omega + 0.02, h, r, v, N, inside_restriction_sphere=False)
    assert guidance.saturated and not busy.thruster_torque_body_n_m.any()
    assert np.max(np.abs(busy.wheel_torque_n_m)) == pytest.approx(0.1, rel=1e-12)


def test_the_default_dump_floor_is_what_the_default_thrusters_deliver():
    """The dump torque at tau_min (0.05 N m per axis) allocated to the default layout (two thrusters a couple)
    and fired for 0.1 s passes every thruster's 0.01 N s minimum impulse bit and delivers the torque; half of
    it would be commanded, compensated by the wheels, and not fired at all."""
    layout = default_thruster_layout()
    config = AttitudeGuidanceConfig()
    torque = np.array([-1.0, 1.0, -1.0]) * config.dump_min_torque_n_m
    for scale, delivered in ((1.0, torque), (0.5, np.zeros(3))):
        allocation = allocate_wrench(layout, np.zeros(3), scale * torque)
        firing = fire(layout, allocation.thrusts_n, config.control_period_s)
        assert np.allclose(firing.torque_body_n_m, delivered, atol=1e-12)
        assert np.allclose(firing.force_body_n, 0.0, atol=1e-12)


def test_bad_settings_name_themselves():
    with pytest.raises(ValueError, match='control_period_s'):
        AttitudeGuidanceConfig(control_period_s=0.0)
    with pytest.raises(ValueError, match='dump_stop_n_m_s'):
        AttitudeGuidanceConfig(dump_stop_n_m_s=2.0)
    with pytest.raises(ValueError, match='r_hill'):
        line_of_sight([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], N)


def test_a_wheel_taken_out_is_commanded_nothing_and_the_thrusters_give_its_axis_torque():
    """Wheel 2 (body z) out, on V-bar at 30 m (outside the sphere) from 2 deg off the goal about z and x: wheel 2 is
    commanded nothing, the wheels left give the x and y torque, and the thrusters' z torque, fired in pulses of
    axis_pulse_n_m_s each passing the minimum impulse bit, is the control law's z torque in the mean (what is
    carried stays under a pulse); closed loop, the pointing settles on the thrusters about z (measured: 0.022 deg at
    most over 100-200 s, the pulses' limit cycle)."""
    config = AttitudeGuidanceConfig()
    layout = default_thruster_layout()
    guidance = AttitudeGuidance(config, SEED001_SERVICER, WHEELS)
    guidance.take_wheels_out([2])
    r, v = np.array([30.0, 0.0, 0.0]), np.zeros(3)
    goal = LineOfSightGoal().update(0.0, r, v, N)
    q = quat_multiply(goal.q_hill_from_goal, quat_from_axis_angle([1.0, 0.0, 1.0], math.radians(2.0)))
    asked, fired = np.zeros(3), np.zeros(3)
    for k in range(50):  # open loop: the same state, the law's torque integrated against what the thrusters give
        cmd = guidance.command(0.1 * k, q, goal.omega_goal, np.zeros(3), r, v, N, inside_restriction_sphere=False)
        assert cmd.wheel_torque_n_m[2] == 0.0
        np.testing.assert_allclose(-WHEELS.axis_matrix[:2] @ cmd.wheel_torque_n_m, guidance.body_torque_n_m[:2],
                                   atol=1e-15)
        assert cmd.thruster_torque_body_n_m[:2].tolist() == [0.0, 0.0]
        if cmd.thruster_torque_body_n_m[2]:
            firing = fire(layout, allocate_wrench(layout, np.zeros(3), cmd.thruster_torque_body_n_m).thrusts_n,
                          config.control_period_s)
            assert not firing.below_minimum_impulse.any()
            np.testing.assert_allclose(firing.torque_body_n_m, cmd.thruster_torque_body_n_m, atol=1e-12)
        asked += guidance.body_torque_n_m * config.control_period_s
        fired += cmd.thruster_torque_body_n_m * config.control_period_s
    assert abs(asked[2]) > 5 * config.axis_pulse_n_m_s  # several pulses' worth was asked
    assert abs(asked[2] - fired[2]) < config.axis_pulse_n_m_s
    assert abs(asked[2] - fired[2]) == pytest.approx(abs(guidance.axis_carried_n_m_s[2]), abs=1e-15)

    guidance = AttitudeGuidance(config, SEED001_SERVICER, WHEELS)
    guidance.take_wheels_out([2])

    def at_rest(_t):
        return r, v
    run = simulate_pointing(guidance, GyrostatPropagator(SEED001_SERVICER, WHEELS), at_rest, 0.0, 200.0, N,
                            restriction_sphere_radius_m=SPHERE_M, q_hill_from_body0=q)
    assert np.all(run.wheel_torque_n_m[:, 2] == 0.0) and run.h_wheels_n_m_s[-1, 2] == 0.0
    assert np.any(run.thruster_torque_body_n_m[:, 2] != 0.0)
    print(f'wheel 2 out: pointing {run.percentile_deg(95, start_s=100.0):.3f} deg p95 over 100-200 s, '
          f'max {math.degrees(run.pointing_error_rad[run.t_s >= 100.0].max()):.3f} deg')
    assert math.degrees(run.pointing_error_rad[run.t_s >= 100.0].max()) < 0.05


def _wheel_out(wheels, index, range_m, tilt_axis):
    """(guidance with wheel index out, r, v, the line-of-sight goal at range_m on R-bar, an attitude 2 deg off it
    about tilt_axis)."""
    guidance = AttitudeGuidance(AttitudeGuidanceConfig(), SEED001_SERVICER, wheels)
    guidance.take_wheels_out([index])
    r, v = np.array([range_m, 0.0, 0.0]), np.zeros(3)
    goal = LineOfSightGoal().update(0.0, r, v, N)
    q = quat_multiply(goal.q_hill_from_goal, quat_from_axis_angle(tilt_axis, math.radians(2.0)))
    return guidance, r, v, goal, q


def test_inside_the_sphere_a_wheel_taken_out_leaves_its_axis_without_torque():
    """No thruster fires inside the restriction sphere: with wheel 2 out its axis gets no torque at all there."""
    guidance, r, v, goal, q = _wheel_out(WHEELS, 2, 10.0, [0.0, 0.0, 1.0])
    for k in range(20):
        cmd = guidance.command(0.1 * k, q, goal.omega_goal, np.zeros(3), r, v, N, inside_restriction_sphere=True)
        assert cmd.wheel_torque_n_m[2] == 0.0 and not cmd.thruster_torque_body_n_m.any()
    assert abs(guidance.body_torque_n_m[2]) > 0.0 and not guidance.axis_carried_n_m_s.any()


PYRAMID = ReactionWheels(np.vstack([np.eye(3), np.ones(3)]), max_torque_n_m=0.1, max_momentum_n_m_s=4.0,
                         spin_inertia_kg_m2=0.01)  # three orthogonal wheels and a skew fourth along (1, 1, 1)


def test_the_dump_drains_only_the_wheels_left_on_a_redundant_set():
    """Four wheels, wheel 3 (the skew one) out holding 2 N m s: the wheels left span the body, yet the out wheel's
    momentum (1.15 N m s on each body axis, past dump_start) is not theirs to dump, so no dump; the same momentum on
    wheel 0, a wheel left, is dumped about x."""
    r, v = np.array([30.0, 0.0, 0.0]), np.zeros(3)
    goal = LineOfSightGoal().update(0.0, r, v, N)
    for h, dumps in (([0.0, 0.0, 0.0, 2.0], False), ([2.0, 0.0, 0.0, 0.0], True)):
        guidance = AttitudeGuidance(AttitudeGuidanceConfig(), SEED001_SERVICER, PYRAMID)
        guidance.take_wheels_out([3])
        cmd = guidance.command(0.0, goal.q_hill_from_goal, goal.omega_goal, h, r, v, N,
                               inside_restriction_sphere=False)
        assert guidance.dumping is dumps and cmd.wheel_torque_n_m[3] == 0.0
        assert bool(cmd.thruster_torque_body_n_m.any()) is dumps
        if dumps:
            assert cmd.thruster_torque_body_n_m[0] < 0.0 and not cmd.thruster_torque_body_n_m[1:].any()


@pytest.mark.parametrize('wheels, first, refused, match', [
    (WHEELS, [3], None, r'wheel index 3 is not one of the 3 wheels \(0 to 2\)'),
    (WHEELS, [-1], None, r'wheel index -1 is not one of the 3 wheels'),
    (WHEELS, [1.5], None, r'wheel index 1.5 is not one of the 3 wheels'),
    (WHEELS, [2], [0], r'wheels \[0\] cannot be taken out: the wheels left \[0, 1\] already span fewer than three'),
    (PYRAMID, [3, 0], [1], r'wheels \[1\] cannot be taken out: the wheels left \[1, 2\] already span fewer than'),
])
def test_a_wheel_that_cannot_be_taken_out_is_refused_naming_it_and_nothing_changes(wheels, first, refused, match):
    """An index that is no wheel, or a further wheel once the wheels left span fewer than three axes (three
    orthogonal wheels: the second; the pyramid: the third), is a ValueError naming it, the law as it was."""
    guidance = AttitudeGuidance(AttitudeGuidanceConfig(), SEED001_SERVICER, wheels)
    if refused is None:
        bad = first
    else:
        guidance.take_wheels_out(first)
        bad = refused
    out, pinv = guidance.wheels_out, guidance.axes_pinv.copy()
    with pytest.raises(ValueError, match=match):
        guidance.take_wheels_out(bad)
    assert guidance.wheels_out == out and np.array_equal(guidance.axes_pinv, pinv)
    assert guidance.wheels_out_refusal(sorted(out)) is None  # a wheel already out again: nothing new, no refusal


def test_a_redundant_set_keeps_three_axes_on_its_wheels_after_one_loss():
    """The pyramid with wheel 3 out spans the body: no thruster torque for the control, every axis on the wheels."""
    guidance, r, v, goal, q = _wheel_out(PYRAMID, 3, 30.0, [1.0, 1.0, 1.0])
    cmd = guidance.command(0.0, q, goal.omega_goal, np.zeros(4), r, v, N, inside_restriction_sphere=False)
    assert cmd.wheel_torque_n_m[3] == 0.0 and not cmd.thruster_torque_body_n_m.any()
    np.testing.assert_allclose(-PYRAMID.axis_matrix @ cmd.wheel_torque_n_m, guidance.body_torque_n_m, atol=1e-15)
