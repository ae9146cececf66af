"""Guidance in TRANSPORT after the arrival (flyby_guidance.transport.terminal): the terminal program's firings, a
turning body damped first, a turn or a new transfer where the program has no horizon, the couple's pulse."""

import numpy as np
import pytest
from scipy.optimize import linprog
from transport_guidance_testing import (
    P,
    arrived,
    estimate,
    held,
    planned,
)

from flyby_guidance.transport.attitude import DETUMBLED_S, TRACK_BANDWIDTH_RAD_S, TRACK_DAMPING, WHEEL_SPINUP_S
from flyby_guidance.transport.control import (
    PULSE_BITS,
    PULSE_BOUND_FRACTION,
    transport_pulse_n_m_s,
)
from flyby_guidance.transport.push import REPLAN_FRACTION
from flyby_guidance.transport.terminal import AIM_FRACTION, FALLBACK_EXCESS
from flyby_msgs_py.events import (
    TRANSPORT_CORRECTION,
    TRANSPORT_TERMINAL,
    TRANSPORT_TURN,
)
from flyby_planner.transfer import terminal_impulses
from flyby_planner.transport import terminal as planner_terminal
from flyby_planner.transport.model import TransportBody, TransportState
from flyby_planner.transport.terminal import HORIZONS_S, solve
from flyby_sim.dynamics.actuators import default_thruster_layout
from flyby_sim.dynamics.orbital import hill_axes_in_eci, q_hill_from_body
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    quat_rotate,
    quat_to_matrix,
)


def test_after_the_arrival_the_terminal_program_fires_one_thruster_a_period():
    """1 mm/s along -x at the rest point, the push axis along hill x: the terminal program's firings
    (transport_terminal) are one allowed thruster a period from the first period this estimate's command reaches, at
    least a minimum impulse bit each, together the momentum along +x; guidance commands them at their periods."""
    body, control, t0, q_eci = arrived()
    v_com = (-1e-3, 0.0, 0.0)
    force, _, _, events = estimate(control, t0, control.rest, v_com=v_com, q_hill=held(control, t0, q_eci))
    assert not np.any(force) and [e[1] for e in events] == [TRANSPORT_TERMINAL]
    values = events[0][3]
    assert values['horizon_s'] == 60.0 and values['impulse_n_s'] == pytest.approx(body.mass_kg * 1e-3, rel=1e-3)
    assert values['predicted_momentum_n_s'] < 0.5 * control.config.planner.max_momentum_error_n_s
    directions = body.layout.force_directions_body
    impulse = np.zeros(3)
    assert control.pulses[0][0] == pytest.approx(t0 + 2.0 * P)
    for t_a, t_b, force, torque in control.pulses:
        assert t_b - t_a == pytest.approx(P)
        thrust = float(np.linalg.norm(force))
        assert thrust * P >= body.layout.min_impulse_bit_n_s * (1.0 - 1e-9)
        wrenches = [np.concatenate((thrust * d, np.cross(r, thrust * d)))
                    for r, d in zip(body.layout.positions_body_m, directions, strict=True)]
        assert any(np.allclose(np.concatenate((force, torque)), w, rtol=0.0, atol=1e-12) for w in wrenches)
        impulse += force * P
        commanded = estimate(control, t_a - P, control.rest, v_com=v_com, q_hill=held(control, t_a - P, q_eci))
        np.testing.assert_allclose(commanded[0], force, atol=1e-12)
    np.testing.assert_allclose(impulse, [values['impulse_n_s'], 0.0, 0.0], atol=1e-12)


def test_where_no_horizon_is_feasible_the_wheels_turn_the_push_axis_onto_the_transfers_first_impulse():
    """2 mm/s along the push axis (+x), with time left for the shortest horizon only: the program has no
    firing (the thrusters push no -x), and the wheels turn the body at the rate their share of momentum gives it until
    the push axis lies along the first impulse of CW's transfer to the rest point (transport_turn)."""
    body, control, t0, q_eci = arrived()
    estimate(control, t0, control.rest, q_hill=held(control, t0, q_eci))  # the terminal from here
    t = control.deadline - control.config.hold_s - 2.0 * P - 100.0  # time for the 60 s horizon only
    q_hill = held(control, t, q_eci)  # the push axis turned in hill at n since the hold began
    v_hill = quat_to_matrix(q_hill) @ np.array([2e-3, 0.0, 0.0])
    state = TransportState(t, control.rest.copy(), v_hill, q_hill, np.zeros(3))
    events = control._terminal(state, np.zeros(3))
    assert [e[1] for e in events] == [TRANSPORT_TURN] and not control.pulses
    t_turn, _, axis, angle, rate = control.turning
    inertia_max = float(np.max(np.linalg.eigvalsh(body.inertia_body_kg_m2)))
    assert rate == pytest.approx(control.config.wheel_momentum_share * 1.0 / inertia_max)
    assert control.t_check == pytest.approx(t + angle / rate + WHEEL_SPINUP_S)
    horizon_s = control.deadline - control.config.hold_s - t
    dv_hill, _ = terminal_impulses(np.zeros(3), state.v_hill, np.zeros(3), np.zeros(3), horizon_s, control.n)
    b_eci = quat_rotate(control._held(t + angle / rate), control.b_body)
    np.testing.assert_allclose(b_eci, hill_axes_in_eci(t, control.n) @ dv_hill / np.linalg.norm(dv_hill), atol=1e-9)
    assert angle > 1.0


def test_where_no_horizon_is_feasible_and_the_push_axis_lies_along_the_transfer_its_impulse_is_fired(monkeypatch):
    """No horizon feasible (the program's None) at the rest point, 2 mm/s against the push axis: CW's first impulse
    to the rest point is along the push axis already, so there is nothing to turn (the wheels' turn of 0 deg every
    check never ended on tug_box_transport); the impulse is fired now as near as the thrusters give it
    (transport_terminal), the body's mass times 2 mm/s along the push axis, and the next check after it."""
    body, control, t0, q_eci = arrived()
    estimate(control, t0, control.rest, q_hill=held(control, t0, q_eci))  # the terminal from here
    t = control.deadline - control.config.hold_s - 2.0 * P - 100.0  # no time for a new transfer
    q_hill = held(control, t, q_eci)
    v_hill = quat_to_matrix(q_hill) @ (-2e-3 * control.b_body)
    monkeypatch.setattr(planner_terminal, 'solve', lambda problem, horizons: None)
    events = control._terminal(TransportState(t, control.rest.copy(), v_hill, q_hill, np.zeros(3)), np.zeros(3))
    assert [e[1] for e in events] == [TRANSPORT_TERMINAL] and control.turning is None and control.pulses
    impulse = sum(force * (t_b - t_a) for t_a, t_b, force, _ in control.pulses)
    assert float(impulse @ control.b_body) == pytest.approx(body.mass_kg * 2e-3, rel=0.02)
    assert np.linalg.norm(impulse - (impulse @ control.b_body) * control.b_body) < 0.05 * np.linalg.norm(impulse)
    assert control.t_check == pytest.approx(control.pulses[-1][1] + control.config.replan_interval_s)


def test_a_nearest_firing_that_ends_no_nearer_than_none_is_not_fired(monkeypatch):
    """The same fallback at rest at the rest point, CW's first impulse made 5 mm/s along the push axis: fired, it
    would end the shortest horizon further beyond the margins than no firing (near the judgement, a transfer's first
    impulse to a rest point the body is already near), so nothing is fired."""
    body, control, t0, q_eci = arrived()
    estimate(control, t0, control.rest, q_hill=held(control, t0, q_eci))
    t = control.deadline - control.config.hold_s - 2.0 * P - 100.0
    q_hill = held(control, t, q_eci)
    monkeypatch.setattr(planner_terminal, 'solve', lambda problem, horizons: None)
    monkeypatch.setattr(type(control), '_transfer_impulse',
                        lambda self, state: quat_to_matrix(q_hill) @ (5e-3 * control.b_body))
    control.pulses = []
    events = control._terminal(TransportState(t, control.rest.copy(), np.zeros(3), q_hill, np.zeros(3)), np.zeros(3))
    assert events == [] and not control.pulses


def _same_attitude(q_a, q_b):
    """True where two quaternions are one attitude (q and -q)."""
    return abs(float(np.dot(q_a, q_b))) == pytest.approx(1.0, abs=1e-12)


def test_a_body_turning_in_the_terminal_phase_is_damped_then_held_again_at_its_new_attitude():
    """In the terminal phase, nothing firing and no turn under way, a body turning at |I omega| = 0.95 kg m^2/s (more
    than 1 - WHEEL_ROOM of the wheels' 1 N m s: they could not hold it still): the capture's damping law (the wheels
    and the thrusters' couple against the rate), the hold dropped, no terminal firing; at rest again
    within DETUMBLED_S the terminal phase holds the attitude the body then has (not the one it held before)."""
    body, control, t0, q_eci = arrived()
    estimate(control, t0, control.rest, q_hill=held(control, t0, q_eci))  # the terminal from here
    assert control.t_terminal == t0 and control.hold is not None and not control.pulses
    omega = np.linalg.solve(body.inertia_body_kg_m2, [0.0, 0.0, 0.95])
    window = round(DETUMBLED_S / P)
    couples = []
    for k in range(1, window + 11):
        t = t0 + k * P
        force, torque, u, events = estimate(control, t, control.rest, q_hill=held(control, t, q_eci), omega=omega)
        assert not events and not control.pulses
        if k > window:  # the window's mean is the rate
            assert control.body_momentum == pytest.approx(0.95) and control.hold is None
        if control.hold is None:
            np.testing.assert_allclose(u, control.gains.wheel_gain_n_m_s * omega, rtol=1e-12)  # the body feels -u
            couples.append(torque - np.cross(body.com_body_m, force))  # about the combined CoM
    fired = [c for c in couples if np.any(c)]
    assert fired and all(float(c @ omega) < 0.0 for c in fired)
    # At rest, 0.05 rad about z off the attitude held before: held anew once the window's mean is below the bound.
    q_turned = quat_multiply(q_eci, quat_from_rotation_vector((0.0, 0.0, 0.05)))
    t_rest = t + P
    for k in range(window + 10):
        t = t_rest + k * P
        force, torque, u, events = estimate(control, t, control.rest, q_hill=held(control, t, q_turned))
        assert not events
        if control.hold is not None:
            break
    assert t - t_rest <= DETUMBLED_S and control.t_terminal == t and control.turning is None
    assert _same_attitude(control.hold, q_turned) and not _same_attitude(control.hold, q_eci)
    np.testing.assert_allclose(u, 0.0, atol=1e-12)  # on the new hold: the wheels track it
    t_again, hold = t, control.hold
    for k in range(1, window + 1):
        t = t_again + k * P
        force, torque, u, events = estimate(control, t, control.rest, q_hill=held(control, t, q_turned))
        assert not (events or np.any(force) or np.any(torque)) and control.hold is hold


def _turning(control, q_eci, speed_mps=2e-3, left_s=100.0):
    """control, its terminal entered at rest at the rest point, turned by the wheels (``_terminal`` with speed_mps
    along the push axis, left_s before the judgement's latest time: the shortest horizon only by default): the
    turn's (t0, q0_eci, axis_eci, angle, rate)."""
    t0 = control.t_terminal
    t = control.deadline - control.config.hold_s - 2.0 * P - left_s
    q_hill = held(control, t, q_eci)
    v_hill = quat_to_matrix(q_hill) @ np.array([speed_mps, 0.0, 0.0])
    events = control._terminal(TransportState(t, control.rest.copy(), v_hill, q_hill, np.zeros(3)), np.zeros(3))
    assert [e[1] for e in events] == [TRANSPORT_TURN] and control.t_terminal == t0
    return control.turning


def test_a_turn_under_way_is_not_damped_the_wheels_keep_turning_the_body():
    """While the wheels turn the push axis the body's own angular momentum is the turn's (above half the first
    condition): no damping law, the hold and the turn kept, the wheels on the turn's rate (a rate error of 1 mrad/s
    gets the PD's rate term and nothing else), nothing fired."""
    body, control, t0, q_eci = arrived()
    estimate(control, t0, control.rest, q_hill=held(control, t0, q_eci))
    turn = _turning(control, q_eci)
    t_turn, _, axis, angle, rate = turn
    delta = np.array([0.0, 0.0, 1e-3])
    window = round(DETUMBLED_S / P)
    assert (window + 10) * P < angle / rate
    for k in range(1, window + 11):
        t = t_turn + k * P
        q_ref = control._held(t)
        w_turn = quat_rotate(quat_conjugate(q_ref), axis * rate)  # body axes
        force, torque, u, events = estimate(control, t, control.rest, q_hill=q_hill_from_body(t, control.n, q_ref),
                                             omega=w_turn + delta)
        assert not (events or np.any(force) or np.any(torque))
        np.testing.assert_allclose(u, body.inertia_body_kg_m2 @ (2.0 * TRACK_DAMPING * TRACK_BANDWIDTH_RAD_S * delta),
                                   atol=1e-9)
    assert control.body_momentum > 0.05 and control.hold is not None and control.turning == turn


def test_a_body_the_wheels_do_not_steer_turns_by_the_thrusters_couples_at_the_slews_rate(monkeypatch):
    """Where the wheels cannot turn the body (a heavy one: their share of momentum would take hours), a terminal turn
    (at the transfer's slew rate, ``start``, where its side force is affordable) is the thrusters' couples' (in
    pulses, against the PD's torque from the turning reference): at rest at the turn's start the couple fired is
    along the turn's axis."""
    body, control, t0, q_eci = arrived(duration_s=20000.0)
    control.wheels_steer = False
    control.turn_rate_rad_s = control.config.planner.slew_rate_rad_s
    estimate(control, t0, control.rest, q_hill=held(control, t0, q_eci))
    monkeypatch.setattr(planner_terminal, 'solve', lambda problem, horizons: None)
    monkeypatch.setattr(control, '_transfer_again', lambda state: None)
    t_turn, _, axis, _, rate = _turning(control, q_eci, speed_mps=1.0, left_s=2000.0)
    assert rate == control.config.planner.slew_rate_rad_s
    impulse = np.zeros(3)
    for k in range(1, 31):
        t = t_turn + k * P
        force, torque, _, events = estimate(control, t, control.rest, q_hill=held(control, t, q_eci))
        assert not events
        impulse += (torque - np.cross(body.com_body_m, force)) * P  # about the combined CoM, body axes
    axis_body = quat_rotate(quat_conjugate(q_eci), axis)
    assert np.linalg.norm(impulse) > 0.0 and float(impulse @ axis_body) > 0.9 * np.linalg.norm(impulse)


def test_a_turn_by_the_thrusters_couples_adds_at_most_a_quarter_of_the_momentum_it_corrects():
    """A couple about a CoM metres off the tug comes with a force: a terminal turn by the thrusters' couples goes no
    faster than the rate at which its spin-up's and spin-down's side force is STAGE_FRACTION of the momentum it is
    for (a 1149 kg pair turned 145 deg at 0.01 rad/s to correct 0.035 N s ended with 43 N s: transport_envelope run
    1). The TugRobot's pair has a pure couple about its x and y axes, none about z (its CoM 0.2 m along x): the side
    force per couple about z by an independent LP of the thrusters' wrenches about the combined CoM."""
    body, control, t0, q_eci = arrived()
    corrected_n_s = 0.05
    for axis_body in np.eye(3)[:2]:
        assert control._affordable_turn_rate(q_eci, quat_rotate(q_eci, axis_body), corrected_n_s) == np.inf
    layout = control.body.layout
    arms = layout.positions_body_m - body.com_body_m
    couples = np.cross(arms, layout.force_directions_body).T  # (3, J) per newton
    forces = layout.force_directions_body.T
    count = forces.shape[1]
    # min sum s  s.t.  couples f = z, -s <= forces f <= s, 0 <= f: the least side force per N m about z
    result = linprog(np.concatenate((np.zeros(count), np.ones(3))),
                     A_ub=np.block([[forces, -np.eye(3)], [-forces, -np.eye(3)]]), b_ub=np.zeros(6),
                     A_eq=np.hstack((couples, np.zeros((3, 3)))), b_eq=[0.0, 0.0, 1.0],
                     bounds=[(0.0, None)] * (count + 3), method='highs')
    side_n_per_n_m = np.linalg.norm(forces @ result.x[:count])
    momentum_per_rad_s = np.linalg.norm(body.inertia_body_kg_m2 @ [0.0, 0.0, 1.0])
    rate = control._affordable_turn_rate(q_eci, quat_rotate(q_eci, [0.0, 0.0, 1.0]), corrected_n_s)
    assert side_n_per_n_m > 1.0
    assert rate == pytest.approx(planner_terminal.STAGE_FRACTION * corrected_n_s
                                 / (2.0 * momentum_per_rad_s * side_n_per_n_m), rel=1e-3)


def test_a_turn_the_thrusters_cannot_afford_before_the_judgement_is_not_made(monkeypatch):
    """No horizon feasible, 1 mm/s against the push axis and 2 mm/s along -y, time for the shortest horizon only: on
    a body the wheels do not steer, the turn onto CW's first impulse (some 60 deg off the push axis) at the rate its
    side force affords would end after the judgement's latest time, so no turn: that impulse is fired as near as
    the thrusters give it at the attitude held (+x and +y firings)."""
    body, control, t0, q_eci = arrived()
    control.wheels_steer = False
    control.turn_rate_rad_s = control.config.planner.slew_rate_rad_s
    estimate(control, t0, control.rest, q_hill=held(control, t0, q_eci))
    t = control.deadline - control.config.hold_s - 2.0 * P - 100.0
    q_hill = held(control, t, q_eci)
    monkeypatch.setattr(planner_terminal, 'solve', lambda problem, horizons: None)
    monkeypatch.setattr(control, '_transfer_again', lambda state: None)
    state = TransportState(t, control.rest.copy(), quat_to_matrix(q_hill) @ np.array([-1e-3, -2e-3, 0.0]), q_hill,
                           np.zeros(3))
    events = control._terminal(state, np.zeros(3))
    assert control.turning is None and [e[1] for e in events] == [TRANSPORT_TERMINAL] and control.pulses
    impulse = sum(force * (t_b - t_a) for t_a, t_b, force, _ in control.pulses)
    assert impulse[0] > 0.0 and impulse[1] > 0.0


def test_after_the_turn_a_turning_body_is_damped():
    """Once the turn has reached its angle and the wheels had WHEEL_SPINUP_S to stop it (the check it scheduled), no
    turn is under way: a body turning at |I omega| = 0.95 kg m^2/s then gets the damping law, as before any turn."""
    body, control, t0, q_eci = arrived()
    estimate(control, t0, control.rest, q_hill=held(control, t0, q_eci))
    t_turn, _, _, angle, rate = _turning(control, q_eci)
    omega = np.linalg.solve(body.inertia_body_kg_m2, [0.0, 0.0, 0.95])
    t_end = t_turn + angle / rate
    for k in range(round(DETUMBLED_S / P) + 1):
        t = t_end + WHEEL_SPINUP_S + 1.0 + k * P
        estimate(control, t, control.rest, q_hill=q_hill_from_body(t, control.n, control._held(t)), omega=omega)
    assert control.body_momentum == pytest.approx(0.95) and control.hold is None


def _far_off(duration_s):
    """300 m ahead of the rest point along V-bar at rest, the body's axes along hill's, at the first estimate after
    the arrival of a run of duration_s: (control, t0, its events); every terminal horizon's best end lies beyond
    FALLBACK_EXCESS margins there."""
    _, control, t0, _ = arrived(duration_s=duration_s)
    r_com = control.rest + np.array([300.0, 0.0, 0.0])
    q = np.array([0.0, 0.0, 0.0, 1.0])
    state = TransportState(t0, r_com, np.zeros(3), q, np.zeros(3))
    rho_p = AIM_FRACTION * control.config.planner.max_momentum_error_n_s
    problem = control._terminal_problem(state, np.zeros(3), rho_p)
    horizons = [h for h in HORIZONS_S if h <= control.deadline - control.config.hold_s - problem.t0]
    assert horizons and sum(solve(problem, horizons).excess) > FALLBACK_EXCESS
    return control, t0, estimate(control, t0, r_com, q_hill=q)[3]


def test_far_off_the_rest_point_with_no_horizon_a_new_transfer_arrives_after_half_the_transfer_time():
    """300 m off with time for REPLAN_FRACTION of the transfer time and the settle bound before the deadline: a new
    plan arriving then (transport_correction), the terminal phase left until its arrival, then its burns flown."""
    control, t0, events = _far_off(2800.0)
    assert [e[1] for e in events] == [TRANSPORT_CORRECTION]
    t_arrival = t0 + REPLAN_FRACTION * control.config.transfer_time_s
    assert t_arrival + control.settle_bound <= control.deadline
    assert events[0][3]['miss_m'] == pytest.approx(300.0) and events[0][3]['impulse_n_s'] > 0.0
    assert control.plan.t_arrival_s == pytest.approx(t_arrival, abs=P)
    assert control.t_terminal is None and control.hold is None and control.turning is None and control.pulses == []
    assert control.plan_start.t == pytest.approx(t0 + 2.0 * P)
    burn = control.plan.burns[0]
    force, torque, _, _ = estimate(control, burn.t_start_s - P, control.rest + np.array([300.0, 0.0, 0.0]))
    assert np.any(torque) and control.t_terminal is None


def _at_the_rest_point_moving_along_the_push_axis(steer):
    """An arrived control in a run of 2800 s, the wheels steering the body or not, in its terminal phase, and the
    state a second on: at the rest point, 2 mm/s along the push axis held inertially: (control, state)."""
    _, control, t0, q_eci = arrived(duration_s=2800.0)
    control.wheels_steer = steer
    estimate(control, t0, control.rest, q_hill=held(control, t0, q_eci))  # the terminal from here
    t = t0 + 1.0
    q_hill = held(control, t, q_eci)
    return control, TransportState(t, control.rest.copy(), quat_to_matrix(q_hill) @ np.array([2e-3, 0.0, 0.0]),
                                   q_hill, np.zeros(3))


def test_on_a_body_the_wheels_do_not_steer_no_horizon_means_a_new_transfer():
    """At the rest point, 2 mm/s along the push axis (no horizon: the thrusters push no -x), with time for a
    transfer: where the wheels steer the body they turn the push axis; where they do not (a heavy body, its turn a
    slew by the thrusters' couples, whose side force the planner's transfer takes into account) a new transfer."""
    kinds = {}
    for steer in (True, False):
        control, state = _at_the_rest_point_moving_along_the_push_axis(steer)
        kinds[steer] = [e[1] for e in control._terminal(state, np.zeros(3))]
        assert (control.t_terminal is None) == (not steer)
    assert kinds == {True: [TRANSPORT_TURN], False: [TRANSPORT_CORRECTION]}


def test_near_the_margins_with_no_firing_that_helps_a_body_the_wheels_do_not_steer_waits(monkeypatch):
    """The program's best end a fraction of a margin beyond them with nothing fired (the residual outside the cone of
    pure forces now): where the wheels steer the body they turn the push axis; where they do not, nothing is fired,
    turned or planned again (a new transfer or a firing of CW's impulse left a heavy body newtons-seconds off), and
    the next check solves the program again."""
    kinds = {}
    for steer in (True, False):
        control, state = _at_the_rest_point_moving_along_the_push_axis(steer)

        def nothing_helps(problem, horizons):
            slots = planner_terminal.slot_times(problem.t0, horizons[0])
            none_fired = np.zeros((len(slots), len(problem.max_thrust_n)))
            return planner_terminal.TerminalSolution(horizons[0], slots, none_fired, problem.x0,
                                                     problem.h_wheels_body_n_m_s, (0.5, 0.5))

        monkeypatch.setattr(planner_terminal, 'solve', nothing_helps)
        kinds[steer] = [e[1] for e in control._terminal(state, np.zeros(3))]
        if not steer:
            assert control.turning is None and control.pulses == [] and control.t_terminal is not None
            assert control.t_check == pytest.approx(state.t + control.config.replan_interval_s)
    assert kinds == {True: [TRANSPORT_TURN], False: []}


def test_far_off_the_rest_point_with_no_horizon_and_no_time_for_a_transfer_the_push_axis_turns():
    """The same 300 m off in a run whose deadline leaves no room for a transfer and its settle bound: no new plan,
    the wheels turn the push axis (transport_turn), the terminal phase kept."""
    control, t0, events = _far_off(1800.0)
    assert t0 + REPLAN_FRACTION * control.config.transfer_time_s + control.settle_bound > control.deadline
    assert [e[1] for e in events] == [TRANSPORT_TURN]
    assert control.plan.t_arrival_s == pytest.approx(control.t_arrival) and control.t_terminal == t0
    assert control.turning is not None and control.turning[3] > 0.0


def test_a_couples_pulse_moves_the_body_by_less_than_a_quarter_of_the_first_condition():
    """A couple fired in pulses changes the body's own angular momentum by a pulse at a time: on a tug holding a body
    2.5 m off (transport_envelope run 14: 39 kg and 58 kg) ten bits at the mean arm are 0.2 N m s, twice the first
    condition, and the detumbling cycled at +-0.2 kg m^2/s for ever; the pulse is a quarter of the bound there, or two
    bits at the largest arm where that is more (the least couple the plant fires), within half the bound either way;
    ten bits at the mean arm on a tug with a finer bit holding a light body near."""
    layout = default_thruster_layout(face_m=0.2, lever_arm_m=0.15, min_impulse_bit_n_s=0.01)
    far = TransportBody(97.0, np.array([1.5, 0.0, 0.0]), np.eye(3), layout)
    fine = default_thruster_layout(face_m=0.2, lever_arm_m=0.15, min_impulse_bit_n_s=0.005)
    near = TransportBody(50.0, np.array([0.06, 0.0, 0.0]), np.eye(3), fine)
    arms = np.linalg.norm(layout.positions_body_m - far.com_body_m, axis=1)
    assert PULSE_BITS * 0.01 * np.mean(arms) > 0.1
    pulse = transport_pulse_n_m_s(far, 0.1)
    assert pulse == pytest.approx(max(PULSE_BOUND_FRACTION * 0.1, 2.0 * 0.01 * np.max(arms))) and pulse < 0.05
    arms = np.linalg.norm(fine.positions_body_m - near.com_body_m, axis=1)
    assert transport_pulse_n_m_s(near, 0.1) == pytest.approx(PULSE_BITS * 0.005 * np.mean(arms))


def test_a_plans_later_firings_are_kept_while_the_estimate_follows_it_and_solved_again_where_it_does_not():
    """While a terminal plan's later firings wait, each check predicts where they leave the estimate
    (``terminal.kept_excess``): as the plan said, the plan is kept (nothing new); 3 mm/s off it, its firings to come
    are dropped and the program solved again from the estimate."""
    body, control, t0, q_eci = arrived()
    estimate(control, t0, control.rest, q_hill=held(control, t0, q_eci))  # at rest at the rest point: nothing
    assert not control.pulses
    j = int(np.argmax(body.layout.force_directions_body[:, 0]))  # a +x thruster
    impulses = np.zeros((1, body.layout.count))
    impulses[0, j] = 2.0 * body.layout.min_impulse_bit_n_s
    t_slot, t_end = t0 + 400.0, t0 + 500.0
    state = TransportState(t0, control.rest.copy(), np.zeros(3), held(control, t0, q_eci), np.zeros(3))
    problem = control._terminal_problem(state, np.zeros(3), control._momentum_margin(
        control._velocity_sigma_mps(t0)))
    excess = planner_terminal.kept_excess(problem, np.array([t_slot]), impulses, t_end)
    plan = planner_terminal.TerminalSolution(t_end - t_slot, np.array([t_slot]), impulses, np.zeros(6), np.zeros(3),
                                             (0.0, excess))
    control._fire(control._pulses_of(impulses[0], t_slot), plan)
    pulses = list(control.pulses)
    t = t0 + 20.0
    control.t_check = t
    events = estimate(control, t, control.rest, q_hill=held(control, t, q_eci))[3]
    assert not events and control.pulses == pulses and control.kept is not None  # on the plan: kept
    t += control.config.replan_interval_s
    events = estimate(control, t, control.rest, v_com=(0.0, 3e-3, 0.0), q_hill=held(control, t, q_eci))[3]
    assert [e[1] for e in events] == [TRANSPORT_TERMINAL] and control.pulses != pulses
    assert control.pulses[0][0] == pytest.approx(t + 2.0 * P)  # solved again from this estimate


def test_a_plans_slots_fire_one_after_another_and_a_later_slot_within_an_earlier_ones_firing_waits_for_its_end():
    """A plan's first slot (at the check) whose firing reaches past the grid's next time: the next slot's firing starts
    at its end, one command a period, every impulse delivered (before, the periods both claimed fired the first's)."""
    body, control, t0, _ = arrived()
    layout = body.layout
    impulses = np.zeros((2, layout.count))
    impulses[0, 0] = 3.0 * layout.max_thrust_n[0] * P  # three periods at full thrust
    impulses[1, 1] = 2.0 * layout.min_impulse_bit_n_s
    t_first = round(t0 / P) * P
    plan = planner_terminal.TerminalSolution(100.0, np.array([t_first, t_first + P]), impulses, np.zeros(6),
                                             np.zeros(3), (0.0, 0.0))
    pulses = control._pulses_of_plan(plan)
    starts = [a for a, _, _, _ in pulses]
    ends = [b for _, b, _, _ in pulses]
    assert starts == sorted(starts) and all(b <= c + 1e-9 for b, c in zip(ends[:-1], starts[1:], strict=True))
    delivered = sum(float(np.linalg.norm(force)) * (b - a) for a, b, force, _ in pulses)  # one thruster a period
    assert delivered == pytest.approx(impulses.sum(), rel=1e-6)
    assert starts[3] == pytest.approx(t_first + 3.0 * P)


def test_the_navigations_sigma_from_before_a_burn_is_not_taken_after_it():
    """A sigma reported before the plan's last burn says nothing of the estimate after it (the accelerometer's noise
    over the burn): none until the next report after the burn, which is taken."""
    _, control = planned()
    last = max(control.plan.burns, key=lambda b: b.t_start_s)
    t_after = last.t_start_s + last.duration_s + 10.0
    control.refine_com(last.t_start_s - 5.0, control.body.com_body_m.tolist(), 0.01, 1e-5)
    control._take_com(t_after)
    assert control._velocity_sigma_mps(t_after) is None
    control.refine_com(t_after, control.body.com_body_m.tolist(), 0.01, 1e-5)
    control._take_com(t_after)
    assert control._velocity_sigma_mps(t_after) == pytest.approx(1e-5)
