"""Guidance in TRANSPORT (flyby_guidance.transport): the body it plans for from the final mass-property estimate,
the detumbling first (the body's own angular momentum, not the wheels'), the plan once detumbled and navigated and
its refusals, the closed-loop push and spin-down, the attitude held, and the judgement after the arrival (the
conditions from the estimate with its 3-sigma, held hold_s); the terminal phase in test_transport_terminal.py."""

import math

import numpy as np
import pytest
from transport_guidance_testing import (
    P,
    arrived,
    control_for,
    estimate,
    held,
    planned,
    state_at,
    until_planned,
)

from flyby_guidance.transport import push as push_module
from flyby_guidance.transport.attitude import DETUMBLED_S, TRACK_BANDWIDTH_RAD_S, WHEEL_ROOM
from flyby_guidance.transport.control import (
    NAV_SETTLE_S,
)
from flyby_guidance.transport.push import REPLAN_FRACTION, STEER_MAX_RAD, STEER_SETTLE_S, push_response
from flyby_guidance.transport.terminal import (
    AIM_FRACTION,
    NAV_SIGMAS,
    TERMINAL_ROUNDS,
    navigation_coast_s,
    settle_bound_s,
)
from flyby_msgs_py.event_payloads import decode_values
from flyby_msgs_py.events import (
    MASS_PROPERTIES_ESTIMATED,
    TRANSPORT_COMPLETE,
    TRANSPORT_CORRECTION,
    TRANSPORT_DETUMBLED,
    TRANSPORT_PLANNED,
    TRANSPORT_REFUSED,
)
from flyby_planner.transport.model import TransportRefused, TransportState, propagate
from flyby_planner.transport.terminal import HORIZONS_S
from flyby_planner.transport.thrusters import push_axis
from flyby_sim.dynamics.actuators import allocate_wrench
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.combined_body import combined_mass_properties, inertia_from_principal
from flyby_sim.dynamics.orbital import cw_accel, cw_transition_matrix, q_eci_from_body, q_hill_from_body, rk4_step
from flyby_sim.dynamics.rotation import (
    quat_from_rotation_vector,
    quat_multiply,
    quat_to_matrix,
)


def test_seed004_the_planned_body_is_the_combined_one_less_the_thrusters_firing_at_the_target():
    sc, body, _ = control_for()
    inertia_t = inertia_from_principal((1.5, 1.5, 2.0), (0.0, -0.7071067811865476, 0.0, 0.7071067811865476))
    assert inertia_t[0, 0] == pytest.approx(2.0) and inertia_t[2, 2] == pytest.approx(1.5)  # the axis along x
    props = combined_mass_properties(30.0, sc.chaser_inertia, 20.2, (0.5, 0.0, 0.0), inertia_t)
    assert body.mass_kg == pytest.approx(50.2) and body.com_body_m == pytest.approx(props.com_body_m)
    np.testing.assert_allclose(body.inertia_body_kg_m2, props.inertia_body_kg_m2)
    assert body.layout.count == 10 and not np.any(body.layout.force_directions_body[:, 0] < -0.5)


def test_transport_detumbles_then_plans_and_flies_the_pushes_on_the_estimate():
    """The damping law first (torque against the rate, the least side force the ten thrusters need, in pulses above
    the minimum impulse bit); then, at rest and navigated, the plan; a push's force is the one the estimate needs
    now along its direction, with no torque about the combined CoM."""
    sc, body, control = control_for()
    control.start(85.0, body)
    q = np.array([0.0, 0.0, 0.0, 1.0])
    r_chaser = np.array([10.0, 5.0, 5.0]) - body.com_body_m
    omega = np.array([0.0, 0.01, -0.01])
    forces, torques = [], []
    for k in range(20):
        f, tau, u, events = control.command(85.0 + 0.1 * k, r_chaser, np.zeros(3), q, omega, np.zeros(3))
        forces.append(f)
        torques.append(tau)
        assert not events and np.all(u * omega >= 0.0)  # the wheels take the rate (the body feels -u)
    fired = [tau for tau in torques if np.any(tau)]
    assert fired and all(float(tau @ omega) < 0.0 for tau in fired)  # against the rate
    assert len(fired) < len(torques)  # pulses: the small couple is carried between them
    rest = np.zeros(3)
    t = 87.0
    while control.t_detumbled is None:
        control.command(t, r_chaser, np.zeros(3), q, rest, np.zeros(3))
        t += 0.1
    assert control.plan is None
    while control.plan is None:
        *_, events = control.command(t, r_chaser, np.zeros(3), q, rest, np.zeros(3))
        t += 0.1
    assert t >= 85.0 + NAV_SETTLE_S and events[0][1] == TRANSPORT_PLANNED
    assert events[0][3]['settle_bound_s'] == control.settle_bound
    assert control.plan.conditions['position_error_m'] < 10.0
    # At the push, the state the plan predicts and the push's first period in flight: the closed-loop force is the
    # planned one (the same needed velocity, CW's coupling over the push included).
    push = next(b for b in control.plan.burns if b.purpose == 'push')
    planned_at = propagate(body, control.plan_start, [b for b in control.plan.burns if b.t_start_s < push.t_start_s],
                           push.t_start_s, control.config.planner)
    control.issued = (push.t_start_s - 0.1, push.force_body_n, push.torque_body_n_m)
    force, torque = control._closed_loop_push(push.t_start_s, planned_at, push, push.force_body_n,
                                              push.torque_body_n_m, np.zeros(3))
    np.testing.assert_allclose(torque, np.cross(body.com_body_m, force), atol=1e-12)  # none about the combined CoM
    assert not allocate_wrench(body.layout, force, torque).saturated
    np.testing.assert_allclose(force, push.force_body_n, atol=2e-3 * np.linalg.norm(push.force_body_n))
    # Without the period in flight the whole velocity is asked of the rest of the push.
    control.issued = None
    again, _ = control._closed_loop_push(push.t_start_s, planned_at, push, push.force_body_n,
                                         push.torque_body_n_m, np.zeros(3))
    np.testing.assert_allclose(again, force * push.duration_s / (push.duration_s - 0.1),
                               atol=2e-3 * np.linalg.norm(force))
    # A spin-down flown on the estimate takes out the estimated I omega + h (the wheels' included) over the burn,
    # whatever the plan said.
    stop = next(b for b in control.plan.burns if b.purpose == 'slew_stop')
    spinning = planned_at._replace(omega_body=np.array([0.0, 0.0, 0.005]))
    h_wheels = np.array([0.01, 0.0, -0.02])
    force, torque = control._closed_loop_stop(stop.t_start_s - 0.1, spinning, stop, stop.force_body_n,
                                              stop.torque_body_n_m, h_wheels)
    np.testing.assert_allclose(torque - np.cross(body.com_body_m, force),
                               -(body.inertia_body_kg_m2 @ spinning.omega_body + h_wheels) / stop.duration_s,
                               atol=1e-9)


def test_the_wheels_hold_the_plans_attitude():
    """On the reference the wheels do nothing; off it they turn the body back (the body feels -u): PD on the
    attitude error and the rate error scaled by the estimated inertia, within the wheels' torque."""
    body, control = planned()
    t_ref, q_ref, w_ref = control.reference
    q_hill = q_hill_from_body(t_ref, control.n, q_ref)
    np.testing.assert_allclose(control._track(state_at(t_ref, q_hill, omega=w_ref)), 0.0, atol=1e-12)
    tilted = quat_multiply(q_hill, quat_from_rotation_vector((0.0, 0.0, 0.01)))
    u = control._track(state_at(t_ref, tilted, omega=w_ref))
    np.testing.assert_allclose(u, body.inertia_body_kg_m2 @ (TRACK_BANDWIDTH_RAD_S ** 2 * np.array([0.0, 0.0, 0.01])),
                               rtol=1e-6, atol=1e-12)
    spinning = control._track(state_at(t_ref, q_hill, omega=w_ref + np.array([0.5, 0.0, 0.0])))
    assert spinning[0] == pytest.approx(0.1)  # the wheels' torque


def test_a_mid_course_miss_gets_one_impulse_keeping_the_last_push():
    """After the first push, the estimate's deviation from the plan's coast carried to the last push by CW: within a
    quarter of the second condition nothing; beyond it one impulse now that takes the miss out, where the thrusters
    give it; where what they give takes out less than that quarter, a new transfer to the same arrival."""
    body, control = planned()
    p = control.config.planner.period_s
    pushes = [b for b in control.plan.burns if b.purpose == 'push']
    nominal = control.push_end[round(pushes[0].t_start_s / p)]
    t = nominal.t + 30.0
    x = cw_transition_matrix(control.n, 30.0) @ np.concatenate((nominal.r_hill, nominal.v_hill))
    q_push = nominal.q_hill_from_body
    on_plan = TransportState(t, x[:3], x[3:], q_push, np.zeros(3))
    next_burn = next(b for b in control.plan.burns if b.t_start_s > t)
    assert control._correct(on_plan, pushes, next_burn, np.zeros(3)) == []
    # 5 mm/s short along the push axis: the correction is along it, the pair gives it.
    axis = quat_to_matrix(q_push)[:, 0]
    short = on_plan._replace(v_hill=x[3:] - 5e-3 * axis)
    events = control._correct(short, pushes, next_burn, np.zeros(3))
    assert events[0][1] == TRANSPORT_CORRECTION
    dv = control.pulses[0][2] * (control.pulses[0][1] - control.pulses[0][0]) / body.mass_kg
    phi = cw_transition_matrix(control.n, pushes[-1].t_start_s + 0.5 * pushes[-1].duration_s - t)
    corrected = np.concatenate((short.r_hill, short.v_hill + quat_to_matrix(q_push) @ dv)) - x
    assert np.linalg.norm((phi @ corrected)[:3]) < 0.05
    # 5 mm/s too fast, and 0.5 mm/s across as well: the correction would brake, along -x of the body, out of the
    # thrusters' reach at the attitude held; what they reach (the part across) takes out far less than a quarter of
    # the second condition: no firing (each check would fire one, each with its error), a new transfer to the same
    # arrival, its slews turning the push axis.
    control.pulses = []
    t_arrival = control.plan.t_arrival_s
    fast = on_plan._replace(v_hill=x[3:] + 5e-3 * axis + 5e-4 * quat_to_matrix(q_push)[:, 1])
    events = control._correct(fast, pushes, next_burn, np.zeros(3))
    assert events[0][1] == TRANSPORT_CORRECTION and 'out of the thrusters\' reach' in events[0][2]
    assert not control.pulses and control.plan.t_arrival_s == pytest.approx(t_arrival)
    assert control.plan_start.t > t and min(b.t_start_s for b in control.plan.burns) > t


def _coast_commands(control, body, tilt_rad, h_wheels=(0.0, 0.0, 0.0)):
    """The impulse [N m s] the thrusters' couples give about the combined CoM, and the wheels' torques, over 5 s of a
    coast after the first push, the body tilted tilt_rad about z off the plan's attitude, its wheels holding
    h_wheels [N m s]."""
    pushes = [b for b in control.plan.burns if b.purpose == 'push']
    t = pushes[0].t_start_s + pushes[0].duration_s + 5.0  # coasting to the next slew
    on_plan = propagate(body, control.plan_start, [b for b in control.plan.burns if b.t_start_s < t], t,
                        control.config.planner)
    tilted = quat_multiply(on_plan.q_hill_from_body, quat_from_rotation_vector((0.0, 0.0, tilt_rad)))
    r_point, v_point = body_point_state(quat_to_matrix(tilted), on_plan.omega_body, -body.com_body_m, control.n)
    impulse, wheels = np.zeros(3), []
    for k in range(50):
        force, torque, u, _ = control.command(t + 0.1 * k, on_plan.r_hill + r_point, on_plan.v_hill + v_point,
                                              tilted, on_plan.omega_body, np.asarray(h_wheels, dtype=float))
        impulse += 0.1 * (torque - np.cross(body.com_body_m, force))  # about the combined CoM
        wheels.append(u)
    return impulse, wheels, on_plan


def test_on_a_body_the_wheels_do_not_steer_the_thrusters_couples_hold_the_plans_attitude():
    """Where the wheels cannot turn the body (paper_flyby_transport's 0.1 N m on 3000 kg m^2) the thrusters' couples
    take an attitude error from the plan's model the wheels could not take out within their room (the open-loop
    slews had ended 12 deg off there, and the arrival push left 90 N s across), in pulses; where they can, the wheels
    do and the thrusters fire nothing at a coast: a body steered by the wheels at any error, one they do not steer
    at an error whose correction at the tracking's bandwidth fits in their room (``_wheels_hold``)."""
    body, control = planned()
    # The tilt whose correction at the tracking's bandwidth asks the wheels' room about z.
    room_rad = (1.0 - WHEEL_ROOM) * control.wheel_capacity_n_m_s / (TRACK_BANDWIDTH_RAD_S
                                                                   * float(body.inertia_body_kg_m2[2, 2]))
    for steer, tilt_rad in ((True, 1.5 * room_rad), (False, 0.5 * room_rad), (False, 1.5 * room_rad)):
        body, control = planned()
        control.wheels_steer = steer
        impulse, wheels, on_plan = _coast_commands(control, body, tilt_rad)
        if steer or tilt_rad < room_rad:
            assert not np.any(impulse) and all(float(u[2]) > 0.0 for u in wheels)  # the body feels -u
        else:
            assert impulse[2] < 0.0 and abs(impulse[2]) > 10.0 * np.linalg.norm(impulse[:2])
            np.testing.assert_allclose(wheels, [control._hold(on_plan.omega_body)] * len(wheels))  # rate only


def test_a_coast_the_thrusters_hold_empties_wheels_beyond_their_share():
    """A body the wheels do not steer, at the plan's attitude, its wheels holding 0.95 of their capacity (a push's
    misalignment torque filled them): they cannot hold it, so the thrusters' couples do, and the wheels are spun down
    at the damping law's dump rate, the couples taking what they give up, so that the wheels hold it again and a
    mid-course correction can fire; wheels within their share are not spun down."""
    for share, dumped in ((0.95, True), (0.3, False)):
        body, control = planned()
        control.wheels_steer = False
        h_z = share * control.wheel_capacity_n_m_s
        impulse, wheels, _ = _coast_commands(control, body, 0.0, (0.0, 0.0, h_z))
        if dumped:
            spin_down = control.gains.dump_rate_per_s * h_z
            assert all(float(u[2]) == pytest.approx(-spin_down, rel=0.01) for u in wheels)
            assert impulse[2] == pytest.approx(-5.0 * spin_down, rel=0.25)
        else:
            assert not np.any(impulse) and all(abs(float(u[2])) < 1e-3 * h_z for u in wheels)


def test_the_detumbling_judges_the_bodys_own_angular_momentum_not_the_wheels():
    """The detumbling ends once the body's own |I omega| (its rate averaged over DETUMBLED_S) is below half the first
    condition and the wheels keep WHEEL_ROOM of their capacity free: a body at rest whose wheels hold 0.6 N m s is
    detumbled, one turning at |I omega| = 0.08 kg m^2/s with its wheels holding the opposite (none in all) is not, nor
    one at rest whose wheels hold 0.95 of their capacity."""
    cases = ((np.zeros(3), (0.6, 0.0, 0.0), True), (None, None, False), (np.zeros(3), (0.0, 0.95, 0.0), False))
    for omega, h_wheels, detumbled in cases:
        _, body, control = control_for()
        if omega is None:
            omega = np.linalg.solve(body.inertia_body_kg_m2, [0.0, 0.0, 0.08])
            h_wheels = -body.inertia_body_kg_m2 @ omega
        control.start(85.0, body)
        r_chaser = np.array([10.0, 5.0, 5.0]) - body.com_body_m
        events = []
        for k in range(150):
            events += control.command(85.0 + k * P, r_chaser, np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), omega,
                                      np.asarray(h_wheels, dtype=float))[3]
        names = [e[1] for e in events]
        if detumbled:
            assert names == [TRANSPORT_DETUMBLED] and control.t_detumbled == pytest.approx(85.0 + DETUMBLED_S)
            assert events[0][3]['angular_momentum_kg_m2_s'] == 0.0
        else:
            assert names == [] and control.t_detumbled is None


def test_the_judgement_completes_only_once_the_conditions_held_hold_s():
    """At the rest point at rest, estimated within 3 cm and 0.02 N s at 3-sigma, with the wheels at 0.3 of their
    capacity: the conditions hold from the first judgement, an estimate with the wheels at 0.6 breaks them, and
    transport_complete (OK) comes hold_s after they hold again, with the body's own angular momentum (the wheels'
    apart), the time since the arrival and the bound stated with the plan; nothing fires meanwhile."""
    body, control, t0, q_eci = arrived()
    hold_s = control.config.hold_s
    assert hold_s == 60.0
    k_break = 300  # 30 s on, between two checks of the terminal program
    found, k = [], 0
    while not found:
        t = t0 + k * P
        force, torque, _, events = estimate(control, t, control.rest, q_hill=held(control, t, q_eci),
                                             h_wheels=(0.6 if k == k_break else 0.3, 0.0, 0.0))
        assert not np.any(force) and not np.any(torque)
        found = [e for e in events if e[1] == TRANSPORT_COMPLETE]
        assert len(events) == len(found)
        k += 1
        assert k < 2000
    level, _, message, values = found[0]
    assert t == pytest.approx(t0 + (k_break + 1) * P + hold_s)
    assert level == 'OK' and '\n' not in message and values['conditions_met'] is True
    assert values['held_s'] == pytest.approx(hold_s)
    assert values['angular_momentum_kg_m2_s'] == 0.0  # the wheels' 0.3 N m s excluded ...
    assert values['wheel_momentum_n_m_s'] == pytest.approx(0.3) and values['wheel_momentum_share'] == pytest.approx(0.3)
    assert values['position_error_m'] == pytest.approx(float(np.linalg.norm(control.rest - control.goal)))
    assert values['momentum_error_n_s'] < 1e-12
    assert values['settle_time_s'] == pytest.approx(t - control.t_arrival)
    assert values['settle_bound_s'] == control.settle_bound and values['t_arrival_s'] == control.t_arrival
    # Done: nothing more is commanded.
    force, torque, wheels, events = estimate(control, t + P, control.rest, q_hill=held(control, t + P, q_eci))
    assert not (np.any(force) or np.any(torque) or np.any(wheels) or events)


def test_conditions_that_never_hold_end_in_a_warn_at_the_deadline():
    """At the rest point at rest but estimated with 4 m of position 1-sigma (12 m at 3-sigma, beyond the second
    condition): no transport_complete before the deadline (two replan intervals before the run's end), then a WARN
    that says the conditions were not held, the estimate's own values within the bounds."""
    body, control, t0, q_eci = arrived(nav_position_sigma_m=4.0)
    deadline = control.config.duration_s - 2.0 * control.config.replan_interval_s
    t, found = t0, []
    while not found:
        events = estimate(control, t, control.rest, q_hill=held(control, t, q_eci))[3]
        found = [e for e in events if e[1] == TRANSPORT_COMPLETE]
        assert t < deadline + 1.0
        t += 1.0
    t -= 1.0
    assert deadline - 1e-9 <= t < deadline + 1.0
    level, _, message, values = found[0]
    assert level == 'WARN' and 'not held' in message and values['held_s'] == 0.0
    assert values['conditions_met'] is True and values['settle_time_s'] == pytest.approx(t - control.t_arrival)


@pytest.mark.parametrize('changes, words', [
    ({'planner': {'max_momentum_error_n_s': 0.008}},
     ("minimum impulse bit 0.01 N s exceeds the momentum bound 0.008 N s",)),
    ({'goal_hill_m': (0.0, 0.0, 5.0)}, ('[0.0, 0.0, 5.0] m is no rest point', '5 m away')),
])
def test_a_transport_the_conditions_cannot_end_is_refused_with_one_line(changes, words):
    """A minimum impulse bit above the third condition, and a goal 5 m below the reference point (its rest point,
    the reference point, beyond a quarter of the second condition): transport_refused (ERROR) with its reason in one
    line, no plan, and nothing commanded after it."""
    _, body, control = control_for(**changes)
    events = until_planned(body, control)
    assert [e[1] for e in events] == [TRANSPORT_DETUMBLED, TRANSPORT_REFUSED]
    level, _, message, values = events[-1]
    assert level == 'ERROR' and control.plan is None and control.done
    assert '\n' not in values['reason'] and values['reason'] in message and all(w in values['reason'] for w in words)
    out = control.command(200.0, np.zeros(3), np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3), np.zeros(3))
    assert not any(np.any(x) for x in out[:3]) and not out[3]


def test_a_goal_within_a_quarter_of_the_second_condition_of_its_rest_point_is_reachable():
    """2.4 m below the reference point is within a quarter of 10 m of its rest point, 2.6 m is not; 2 km ahead on
    V-bar is 0.29 m above its rest point."""
    for goal, refused in (((0.0, 0.0, 2.4), False), ((0.0, 0.0, 2.6), True), ((2000.0, 0.0, 0.0), False)):
        _, body, control = control_for(goal_hill_m=goal)
        control.start(85.0, body)
        if refused:
            with pytest.raises(TransportRefused, match='is no rest point'):
                control._check_reachable(control.t_arrival)
        else:
            control._check_reachable(control.t_arrival)


def test_too_little_time_for_the_stated_settle_bound_is_refused():
    """The run must leave the settle bound after the arrival before the deadline (two replan intervals before its
    end): a second less is refused naming the bound, a second more is planned."""
    _, body, control = control_for()
    control.start(85.0, body)
    bound, margin = control.settle_bound, 2.0 * control.config.replan_interval_s
    for extra_s, refused in ((-1.0, True), (1.0, False)):
        _, body, control = control_for(duration_s=control.t_arrival + bound + margin + extra_s)
        events = until_planned(body, control)
        assert events[-1][1] == (TRANSPORT_REFUSED if refused else TRANSPORT_PLANNED)
        if refused:
            assert events[-1][3]['reason'].startswith(f'too little time: the conditions need {bound:.0f} s after')


def test_a_transfer_time_too_short_for_the_slews_and_pushes_arrives_later_where_the_run_allows():
    """matsunaga_orbit_advance's 1 km asked in 60 s (its slews alone take longer): in a run long enough the plan
    arrives REPLAN_FRACTION of the transfer time later, as often as needed, and says so (transport_planned, WARN, the
    planner's reason); the settle time counts from that arrival. In a run too short for any later arrival and its
    settle bound, the refusal names the asked arrival's reason."""
    _, body, control = control_for(transfer_time_s=60.0)
    events = until_planned(body, control)
    level, _, message, values = events[-1]
    asked = 85.0 + 60.0
    assert events[-1][1] == TRANSPORT_PLANNED and level == 'WARN' and 'later than asked: too little time' in message
    steps = (values['t_arrival_s'] - asked) / (REPLAN_FRACTION * 60.0)
    assert steps >= 1.0 and steps == pytest.approx(round(steps), abs=1e-6)
    assert control.t_arrival == values['t_arrival_s']
    _, body, control = control_for(transfer_time_s=60.0, duration_s=asked + control.settle_bound + 60.0)
    events = until_planned(body, control)
    assert events[-1][1] == TRANSPORT_REFUSED and events[-1][3]['reason'].startswith('too little time')
    assert 'the conditions need' not in events[-1][3]['reason']


def test_a_run_too_short_for_a_whole_step_later_arrives_at_the_latest_arrival_that_fits():
    """The transfer time too short, and the run ending a second before the first later step whose plan flies: the
    plan arrives at the latest arrival whose settle bound fits (the deadline less the bound), not refused."""
    _, body, control = control_for(transfer_time_s=60.0)
    t_step = until_planned(body, control)[-1][3]['t_arrival_s']
    margin = 2.0 * control.config.replan_interval_s
    _, body, control = control_for(transfer_time_s=60.0, duration_s=t_step - 1.0 + control.settle_bound + margin)
    level, kind, message, values = until_planned(body, control)[-1]
    assert kind == TRANSPORT_PLANNED and level == 'WARN' and 'later than asked: too little time' in message
    assert values['t_arrival_s'] == pytest.approx(control.deadline - control.settle_bound)
    assert values['t_arrival_s'] == pytest.approx(t_step - 1.0)


def test_the_settle_bound_is_rounds_of_a_coast_that_learns_the_velocity_a_firing_and_a_check_then_the_hold():
    """Each of TERMINAL_ROUNDS rounds is the coast over which a constant velocity fitted to positions of 1 cm at
    10 Hz (least squares over the samples, whose slope has the variance s^2 / sum (t - t_mean)^2) is known within
    AIM_FRACTION of the third condition at NAV_SIGMAS, at least the combined CoM's period, then the shortest horizon
    and a replan interval; then the hold."""
    mass, bound, hold, replan = 50.2, 0.01, 60.0, 20.0
    total = settle_bound_s(navigation_coast_s(mass, bound, 0.01, 10.0, 0.0), hold, replan)
    coast_s = (total - hold) / TERMINAL_ROUNDS - HORIZONS_S[0] - replan
    times = np.arange(0.0, coast_s, 0.1)
    sigma_v = 0.01 / math.sqrt(float(np.sum((times - times.mean()) ** 2)))
    assert NAV_SIGMAS * mass * sigma_v == pytest.approx(AIM_FRACTION * bound, rel=0.01)
    assert navigation_coast_s(mass, bound, 0.01, 10.0, 1000.0) == 1000.0


def test_seed000_eq22_push_response_against_integrated_cw():
    """A constant body force on a body at rest inertially (turning in hill at the orbit rate), held 300 s from a
    period after the estimate, a command in flight over that period: the velocity at the push's end from CW
    (seed 000 eq 2) integrated step by step is the coast's plus G F, push_response's."""
    n = 0.0011
    mass_kg = 2000.0
    q_hill = quat_from_rotation_vector(np.array([0.3, -1.1, 0.4]))
    q_eci = q_eci_from_body(50.0, n, q_hill)
    state = TransportState(50.0, np.array([10.0, -4.0, 2.0]), np.array([0.05, 0.3, -0.07]), q_hill, np.zeros(3))
    issued, force = np.array([1.0, -2.0, 0.5]), np.array([19.0, 0.7, -7.0])
    response, x_coast = push_response(state, issued, mass_kg, n, 50.1, 300.0)

    def accel(t, y, force_body):
        c_hill_from_body = quat_to_matrix(q_hill_from_body(t, n, q_eci))
        return np.concatenate((y[3:], cw_accel(y[:3], y[3:], n, c_hill_from_body @ force_body / mass_kg)))

    y = np.concatenate((state.r_hill, state.v_hill))
    y = rk4_step(lambda t, x: accel(t, x, issued), 50.0, y, 0.1)
    t = 50.1
    for _ in range(600):
        y = rk4_step(lambda t, x: accel(t, x, force), t, y, 0.5)
        t += 0.5
    np.testing.assert_allclose(x_coast + response @ force, y, atol=1e-5)
    # CW's coupling is no small part over minutes: the velocity over the time is no push's force.
    assert np.linalg.norm(response[3:] @ force - 300.0 / mass_kg * quat_to_matrix(q_hill) @ force) > 0.05


def test_a_push_steers_its_axis_toward_the_force_wanted_by_at_most_steer_max():
    """Thrust-vector steering: the attitude tracked during a push is the estimate's turned so that the planned pure
    force points (inertially) where the force wanted points at the estimate: all of a small angle, STEER_MAX_RAD of a
    large one, in the plane of the two."""
    _, control = planned()
    q_hill = quat_from_rotation_vector(np.array([0.2, -0.4, 0.1]))
    state = state_at(500.0, q=q_hill)
    c_eci_from_body = quat_to_matrix(q_eci_from_body(500.0, control.n, q_hill))
    planned_force = np.array([12.0, 1.0, -3.0])
    b = planned_force / np.linalg.norm(planned_force)
    across = np.cross(b, [0.0, 1.0, 0.0])
    across /= np.linalg.norm(across)
    for angle in (0.02, 0.3):
        wanted = 10.0 * (math.cos(angle) * b + math.sin(angle) * across)
        control._steer(state, planned_force, wanted)
        t_ref, q_ref, w_ref = control.reference
        assert t_ref == 500.0 and not np.any(w_ref)
        steered = quat_to_matrix(q_ref) @ b
        now = c_eci_from_body @ b
        toward = c_eci_from_body @ (wanted / 10.0)
        assert math.acos(min(1.0, float(steered @ now))) == pytest.approx(min(angle, STEER_MAX_RAD), rel=1e-9)
        assert abs(float(steered @ np.cross(now, toward))) < 1e-12  # in the plane of the two
        assert float(steered @ toward) > float(now @ toward)


def test_on_a_body_the_wheels_do_not_steer_a_push_ends_with_the_body_and_the_wheels_at_rest(monkeypatch):
    """Over a push's last STEER_SETTLE_S on a body the wheels do not steer, the push's thrusters take out the body's
    angular momentum I omega and the wheels' h by its end, the wheels idle: the thrusters' hold (a PD) had left a
    210 kg pair turning at 1 kg m^2/s, which the wheels, holding the attitude after it, could not take up. Before a
    push's last STEER_SETTLE_S (here made 1 s) the wheels damp the rate and the thrusters hold the attitude."""
    body, control = planned()
    control.wheels_steer = False
    push = [b for b in control.plan.burns if b.purpose == 'push'][0]
    end = push.t_start_s + push.duration_s
    t = max(push.t_start_s, end - STEER_SETTLE_S) + 1.0
    omega = np.array([0.0, 0.002, -0.003])
    h_wheels = np.array([0.05, -0.1, 0.2])
    on_plan = propagate(body, control.plan_start, [b for b in control.plan.burns if b.t_start_s < t], t,
                        control.config.planner)
    r_point, v_point = body_point_state(quat_to_matrix(on_plan.q_hill_from_body), omega, -body.com_body_m, control.n)
    estimate_at_t = (t, on_plan.r_hill + r_point, on_plan.v_hill + v_point, on_plan.q_hill_from_body, omega,
                     h_wheels)
    force, torque, wheels, _ = control.command(*estimate_at_t)
    assert not np.any(wheels) and not allocate_wrench(body.layout, force, torque).saturated
    np.testing.assert_allclose(torque - np.cross(body.com_body_m, force),
                               -(body.inertia_body_kg_m2 @ omega + h_wheels) / (end - (t + P)), atol=1e-9)
    monkeypatch.setattr(push_module, 'STEER_SETTLE_S', 1.0)
    _, _, wheels, _ = control.command(*estimate_at_t)
    np.testing.assert_allclose(wheels, control._hold(omega))


def test_a_slew_solved_again_aims_the_last_push_through_its_own_side_forces():
    """The last slew, solved again from the estimate before it starts, turns the push axis onto the velocity the last
    push must null as it will be after the slew: its spin-up's and spin-down's side forces (a couple about the
    combined CoM comes with a force where the CoM is off the tug, and the body turns between the two) included: aimed
    at the velocity coasted without them, the push leaves six times the third condition across its axis, beyond the
    direction-limited thrusters' reach at the attitude held. Here 300 kg held 2 m off matsunaga_orbit_advance's
    tug."""
    heavy = decode_values(MASS_PROPERTIES_ESTIMATED, {
        'mass_kg': '300.0', 'mass_sigma_kg': '0.0', 'com_body_m': '[2.0, 0.4, 0.3]', 'com_sigma_m': '[0.0, 0.0, 0.0]',
        'principal_moments_kg_m2': '[100.0, 100.0, 100.0]', 'principal_moments_sigma_kg_m2': '[0.0, 0.0, 0.0]',
        'principal_axes_q': '[0.0, 0.0, 0.0, 1.0]'})
    body, control = planned(estimate=heavy)
    slews = control._slews()
    start, stop = slews[-1]
    burns_before = control.plan.burns
    t = start.t_start_s - 1.5 * P
    before = propagate(body, control.plan_start, [b for b in control.plan.burns if b.t_start_s < t], t,
                       control.config.planner)
    before = before._replace(v_hill=before.v_hill + np.array([2e-3, -1e-3, 1e-3]))  # off the plan
    assert control._resolve(before, start, stop) == []
    new_start, new_stop = control._slews()[-1]
    assert new_start.t_start_s == start.t_start_s and new_stop.t_start_s == stop.t_start_s
    sized = [b for b in control.plan.burns if b.purpose == 'push'][-1]
    t_aim = sized.t_start_s + 0.5 * sized.duration_s
    after = propagate(body, before, (new_start, new_stop), t_aim, control.config.planner)
    b_body, _ = push_axis(body)
    axis_hill = quat_to_matrix(after.q_hill_from_body) @ b_body
    coasted = (cw_transition_matrix(control.n, t_aim - t) @ np.concatenate((before.r_hill, before.v_hill)))[3:]

    def across_n_s(v, axis):  # the momentum across the push axis, which the push cannot take out
        return body.mass_kg * float(np.linalg.norm(v - (v @ axis) * axis))

    bound = control.config.planner.max_momentum_error_n_s
    assert across_n_s(after.v_hill, axis_hill) < 0.1 * bound
    assert across_n_s(after.v_hill, -coasted / np.linalg.norm(coasted)) > bound  # aimed without them
    # The last push gives at least the impulse it must (its planned one, or lengthened to it), never shortened.
    planned_push = [b for b in burns_before if b.purpose == 'push'][-1]
    impulse_n_s = float(np.linalg.norm(sized.force_body_n)) * sized.duration_s
    need_n_s = body.mass_kg * float(np.linalg.norm(after.v_hill))
    assert sized.t_start_s == planned_push.t_start_s and sized.duration_s >= planned_push.duration_s
    assert impulse_n_s >= need_n_s * (1.0 - 1e-3)
    assert control.plan.t_arrival_s == pytest.approx(sized.t_start_s + sized.duration_s)
    # 5 cm/s more to null than planned: lengthened to it at the planner's share of the largest pure force.
    _, again = planned(estimate=heavy)
    faster = before._replace(v_hill=before.v_hill + 0.05 * before.v_hill / np.linalg.norm(before.v_hill))
    assert again._resolve(faster, *again._slews()[-1]) == []
    longer = [b for b in again.plan.burns if b.purpose == 'push'][-1]
    through = propagate(body, faster, again._slews()[-1], longer.t_start_s + 0.5 * longer.duration_s,
                        again.config.planner)
    assert longer.duration_s > planned_push.duration_s
    assert float(np.linalg.norm(longer.force_body_n)) * longer.duration_s == pytest.approx(
        body.mass_kg * float(np.linalg.norm(through.v_hill)), rel=1e-3)
    assert float(np.linalg.norm(longer.force_body_n)) <= max(
        float(np.linalg.norm(planned_push.force_body_n)), again.config.planner.push_force_fraction * push_axis(body)[1])
