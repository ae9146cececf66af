"""Guidance in TRANSPORT (flyby_guidance.transport): the body it plans for from the final mass-property estimate,
the detumbling first, the plan once detumbled and navigated, the closed-loop push and spin-down."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from flyby_guidance.damping import PostCaptureConfig
from flyby_guidance.transport.attitude import TRACK_BANDWIDTH_RAD_S
from flyby_guidance.transport.control import (
    NAV_SETTLE_S,
    TransportControl,
    TransportGuidanceConfig,
    transport_body,
)
from flyby_guidance.transport.trim import (
    COAST_SLEW_MOMENTUM_FRACTION,
    COM_FINAL_RAD,
    DUMP_S,
    PULSE_LEAVE_FRACTION,
    TRIM_SLEW_RATE_RAD_S,
    TRIM_TIME_S,
    WHEEL_SPINUP_S,
)
from flyby_msgs_py.event_payloads import decode_values
from flyby_msgs_py.events import MASS_PROPERTIES_ESTIMATED
from flyby_planner.transfer import terminal_impulses
from flyby_planner.transport.model import TransportState, propagate
from flyby_sim.dynamics.actuators import allocate_wrench
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.combined_body import combined_mass_properties, inertia_from_principal
from flyby_sim.dynamics.orbital import cw_transition_matrix, hill_axes_in_eci, q_hill_from_body
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    quat_rotate,
    quat_shortest_arc,
    quat_to_matrix,
)
from flyby_sim.scenario import load_scenario

SCENARIO = Path(__file__).resolve().parents[4] / 'scenarios' / 'matsunaga_orbit_advance.yaml'
# The final estimate's values as the estimator's mass_properties_estimated event carries them (text).
ESTIMATE = decode_values(MASS_PROPERTIES_ESTIMATED, {
    'mass_kg': '20.2', 'mass_sigma_kg': '0.0', 'com_body_m': '[0.5, 0.0, 0.0]', 'com_sigma_m': '[0.0, 0.0, 0.0]',
    'principal_moments_kg_m2': '[1.5, 1.5, 2.0]', 'principal_moments_sigma_kg_m2': '[0.0, 0.0, 0.0]',
    'principal_axes_q': '[0.0, -0.7071067811865476, 0.0, 0.7071067811865476]'})


def _control():
    sc = load_scenario(SCENARIO)
    body = transport_body(ESTIMATE, sc.chaser.mass_kg, sc.chaser_inertia, sc.thruster_layout,
                          sc.post_capture.transport.plume_cone_deg)
    control = TransportControl(TransportGuidanceConfig.from_scenario(sc), sc.mean_motion_rad_s,
                               PostCaptureConfig.from_scenario(sc).gains, 0.1)
    return sc, body, control


def test_seed004_the_planned_body_is_the_combined_one_less_the_thrusters_firing_at_the_target():
    sc, body, _ = _control()
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
    sc, body, control = _control()
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
    assert t >= 85.0 + NAV_SETTLE_S and events[0][1] == 'transport_planned'
    assert control.plan.conditions['position_error_m'] < 10.0
    # At the push, the state the plan predicts: the closed-loop force is the planned one (the same needed velocity).
    push = next(b for b in control.plan.burns if b.purpose == 'push')
    planned_at = propagate(body, control.plan_start, [b for b in control.plan.burns if b.t_start_s < push.t_start_s],
                           push.t_start_s, control.config.planner)
    force, torque = control._closed_loop_push(push.t_start_s - 0.1, planned_at, push, push.force_body_n,
                                              push.torque_body_n_m)
    np.testing.assert_allclose(torque, np.cross(body.com_body_m, force), atol=1e-12)  # none about the combined CoM
    assert not allocate_wrench(body.layout, force, torque).saturated
    # Up to the Coriolis term over the push, which the closed loop takes at once: 2 n |dv| m ~ 0.14 N here.
    np.testing.assert_allclose(force, push.force_body_n, atol=0.2)
    # The push commanded at the previous estimate acts over the period the estimate has not seen yet: asked for once.
    control.issued = (push.t_start_s - 0.2, force, torque)
    again, _ = control._closed_loop_push(push.t_start_s - 0.1, planned_at, push, push.force_body_n,
                                         push.torque_body_n_m)
    np.testing.assert_allclose(again, force - force * 0.1 / push.duration_s, atol=1e-9)
    control.issued = None
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


def _planned():
    """The control of test_transport_detumbles_then_plans_and_flies_the_pushes_on_the_estimate once planned, at rest
    with the chaser's axes along hill's (the estimate it planned from)."""
    sc, body, control = _control()
    control.start(85.0, body)
    q, r_chaser, t = np.array([0.0, 0.0, 0.0, 1.0]), np.array([10.0, 5.0, 5.0]) - body.com_body_m, 85.0
    while control.plan is None:
        control.command(t, r_chaser, np.zeros(3), q, np.zeros(3), np.zeros(3))
        t += 0.1
    return body, control


def _state(t, q=(0.0, 0.0, 0.0, 1.0), r=(1000.0, 0.0, 0.0), v=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0)):
    return TransportState(t, np.asarray(r, dtype=float), np.asarray(v, dtype=float), np.asarray(q, dtype=float),
                          np.asarray(omega, dtype=float))


def test_the_wheels_hold_the_plans_attitude():
    """On the reference the wheels do nothing; off it they turn the body back (the body feels -u): PD on the
    attitude error and the rate error scaled by the estimated inertia, within the wheels' torque."""
    body, control = _planned()
    t_ref, q_ref, w_ref = control.reference
    q_hill = q_hill_from_body(t_ref, control.n, q_ref)
    np.testing.assert_allclose(control._track(_state(t_ref, q_hill, omega=w_ref)), 0.0, atol=1e-12)
    tilted = quat_multiply(q_hill, quat_from_rotation_vector((0.0, 0.0, 0.01)))
    u = control._track(_state(t_ref, tilted, omega=w_ref))
    np.testing.assert_allclose(u, body.inertia_body_kg_m2 @ (TRACK_BANDWIDTH_RAD_S ** 2 * np.array([0.0, 0.0, 0.01])),
                               rtol=1e-6, atol=1e-12)
    spinning = control._track(_state(t_ref, q_hill, omega=w_ref + np.array([0.5, 0.0, 0.0])))
    assert spinning[0] == pytest.approx(0.1)  # the wheels' torque


def test_trim_pulses_a_pure_force_in_reach_else_along_the_push_axis_else_turns_it_first():
    """After the arrival a velocity error is nulled by a pulse: a pure force along it where the allowed thrusters
    give one above the minimum impulse bit; along the push axis (+x) by its pair, or below two bits by one of them;
    where neither, the wheels turn the push axis onto it first and the pulse waits for the turn."""
    body, control = _planned()
    state = _state(2000.0)
    at_thirty = np.array([np.cos(0.5), np.sin(0.5), 0.0])
    force, torque, periods = control._pulse(state, at_thirty, 1.0)
    np.testing.assert_allclose(force, 10.0 * at_thirty, atol=1e-12)
    np.testing.assert_allclose(torque, np.cross(body.com_body_m, force), atol=1e-12)  # none about the combined CoM
    assert periods == 1
    assert control._pulse(state, np.array([-1.0, 0.0, 0.0]), 1.0) is None  # no -x thrust
    nearly_x = np.array([1.0, 0.01, 0.0]) / np.linalg.norm([1.0, 0.01, 0.0])
    force, torque, _ = control._pulse(state, nearly_x, 0.05)
    np.testing.assert_allclose(force, [0.5, 0.0, 0.0], atol=1e-12)  # the pair, 0.025 N s each
    force, torque, _ = control._pulse(state, nearly_x, 0.004)
    assert force[0] == pytest.approx(0.1, rel=1e-5) and abs(torque[2]) > 0.0  # one thruster, one bit
    # 0.2 rad off the push axis: a small error is fired along it where what is left across is within the residual
    # (its direction is the navigation's noise), a large one waits for the turn.
    off = np.array([np.cos(0.2), 0.0, np.sin(0.2)])
    assert control._pulse(state, off, 0.013) is None
    force, _, _ = control._pulse(state, off, 0.013, residual_n_s=0.005)
    np.testing.assert_allclose(force, [0.13, 0.0, 0.0], atol=1e-9)  # 0.013 * 2 sin(0.1) = 0.0026 N s left
    assert control._pulse(state, off, 0.1, residual_n_s=0.005) is None
    # A velocity along the push axis (to be nulled along -x): the wheels turn the body half round, then the pulse.
    control._track(state)  # the plan's attitude at rest after its burns
    q_held = q_hill_from_body(2000.0, control.n, control.reference[1])
    v = 1e-3 * quat_to_matrix(q_held)[:, 0]
    events = control._trim(_state(2000.0, q_held, v=v))
    assert not events and not control.pulses
    t0, q0, axis, angle, rate = control.trim_slew
    assert angle == pytest.approx(np.pi, abs=0.2) and rate == TRIM_SLEW_RATE_RAD_S  # hill turns meanwhile
    t_turned = t0 + angle / rate + WHEEL_SPINUP_S
    assert control.t_check == pytest.approx(t_turned)
    assert control._trim(_state(t_turned - 1.0, v=v)) == []  # still turning
    q_turned = q_hill_from_body(t_turned, control.n, control._reference_now(t_turned))
    x = cw_transition_matrix(control.n, t_turned - 2000.0) @ np.concatenate(([1000.0, 0.0, 0.0], v))  # coasted
    events = control._trim(_state(t_turned, q_turned, r=x[:3], v=x[3:]))
    assert events[0][1] == 'transport_pulse' and control.pulses
    force_hill = quat_to_matrix(q_turned) @ control.pulses[0][2]
    assert float(force_hill @ x[3:]) < -0.999 * np.linalg.norm(force_hill) * np.linalg.norm(x[3:])


def test_trim_dumps_the_angular_momentum_first_and_aims_at_rest_at_the_judgement():
    body, control = _planned()
    t_end = control.t_arrival + control.config.settle_s
    control.momentum = 0.05  # the estimate's, the rate averaged
    events = control._trim(_state(2000.0))
    assert events[0][1] == 'transport_dump' and control.dumping == pytest.approx(2000.0 + DUMP_S)
    force, torque = control._dump(2000.0, _state(2000.0), np.array([0.0, 0.0, 0.05]))
    assert float((torque - np.cross(body.com_body_m, force)) @ np.array([0.0, 0.0, 1.0])) <= 0.0
    control.dumping, control.momentum = None, 0.0
    # 1 m off V-bar the body is not at rest in hill: the pulse gives the velocity that coasts to rest at the
    # judgement (CW), not rest now; here along the push axis, the pair's.
    phi = cw_transition_matrix(control.n, 100.0)
    aim = -np.linalg.solve(phi[3:, 3:], phi[3:, :3] @ np.array([0.0, 0.0, 1.0]))
    q_aim = quat_shortest_arc(np.array([1.0, 0.0, 0.0]), aim / np.linalg.norm(aim))
    events = control._trim(_state(t_end - 100.0, q_aim, r=(1000.0, 0.0, 1.0)))
    assert events and events[0][1] == 'transport_pulse'
    force_hill = quat_to_matrix(q_aim) @ control.pulses[0][2]
    np.testing.assert_allclose(force_hill * 0.1 / body.mass_kg, aim, rtol=1e-6, atol=1e-12)


def test_a_dump_takes_the_angular_momentum_out_by_its_end():
    """The dump's couples aim at none left at its end, the time left shrinking (a couple of h / DUMP_S throughout leaves
    e^-1 of it, and the next dump, which must halve it, would never come). Its couples about the combined CoM,
    pulse-modulated, integrated on the body held by the wheels."""
    body, control = _planned()
    p = control.config.planner.period_s
    control.momentum = 0.09
    t = 1400.0
    assert control._trim(_state(t))[0][1] == 'transport_dump'
    h0 = np.array([0.05, -0.04, 0.06])
    h = h0.copy()
    while control.dumping is not None:
        force, torque = control._dump(t, _state(t), h)
        h = h + (torque - np.cross(body.com_body_m, force)) * p
        t += p
    assert t == pytest.approx(1400.0 + DUMP_S, abs=1.5 * p)
    assert np.linalg.norm(h) < 0.15 * np.linalg.norm(h0)


def test_a_mid_course_miss_gets_one_impulse_keeping_the_last_push():
    """After the first push, the estimate's deviation from the plan's coast carried to the last push by CW: within
    replan_position_m nothing; beyond it one impulse now that takes the miss out, where the thrusters give it."""
    body, control = _planned()
    p = control.config.planner.period_s
    pushes = [b for b in control.plan.burns if b.purpose == 'push']
    nominal = control.push_end[round(pushes[0].t_start_s / p)]
    t = nominal.t + 30.0
    x = cw_transition_matrix(control.n, 30.0) @ np.concatenate((nominal.r_hill, nominal.v_hill))
    q_push = nominal.q_hill_from_body
    on_plan = TransportState(t, x[:3], x[3:], q_push, np.zeros(3))
    next_burn = next(b for b in control.plan.burns if b.t_start_s > t)
    assert control._correct(on_plan, pushes, next_burn) == []
    # 5 mm/s short along the push axis: the correction is along it, the pair gives it.
    axis = quat_to_matrix(q_push)[:, 0]
    short = on_plan._replace(v_hill=x[3:] - 5e-3 * axis)
    events = control._correct(short, pushes, next_burn)
    assert events[0][1] == 'transport_correction'
    dv = control.pulses[0][2] * (control.pulses[0][1] - control.pulses[0][0]) / body.mass_kg
    phi = cw_transition_matrix(control.n, pushes[-1].t_start_s + 0.5 * pushes[-1].duration_s - t)
    corrected = np.concatenate((short.r_hill, short.v_hill + quat_to_matrix(q_push) @ dv)) - x
    assert np.linalg.norm((phi @ corrected)[:3]) < 0.05
    # 5 mm/s too fast: the correction brakes, along -x of the body: not now (the last push takes the velocity out).
    control.pulses = []
    fast = on_plan._replace(v_hill=x[3:] + 5e-3 * axis)
    assert control._correct(fast, pushes, next_burn) == [] and not control.pulses


def test_dumps_stop_at_the_estimates_floor_and_a_body_the_wheels_cannot_turn_trims_short_along_the_push_axis():
    """A dump that has not halved the estimated angular momentum is at the estimate's floor: no more dumps. Where the
    wheels cannot turn the body (paper_flyby_transport's), a velocity error out of reach at the attitude held is left
    (the thrusters' slews for it had left 35-110 N s each there), and a pulse in reach stops short along the push
    axis by PULSE_LEAVE_FRACTION of the error: an overshoot would need thrust against the push axis."""
    body, control = _planned()
    control.momentum = 0.05
    assert control._trim(_state(1400.0))[0][1] == 'transport_dump'
    control.dumping, control.momentum = None, 0.04  # not halved
    assert control._trim(_state(1430.0)) == [] and control.dumping is None
    control.wheels_steer = False
    control.t_check = 1450.0
    q_held = q_hill_from_body(1450.0, control.n, control.reference[1])
    x_hill = quat_to_matrix(q_held)[:, 0]
    assert control._trim(_state(1450.0, q_held, v=5e-3 * x_hill)) == []  # to be nulled along -x
    assert not control.pulses and control.trim_arrival is None
    events = control._trim(_state(1470.0, q_held, v=-5e-3 * x_hill))  # along +x
    assert [e[1] for e in events] == ['transport_pulse']
    t_a, t_b, force, _ = control.pulses[0]
    error_n_s = body.mass_kg * 5e-3
    np.testing.assert_allclose(force * (t_b - t_a), [(1.0 - PULSE_LEAVE_FRACTION) * error_n_s, 0.0, 0.0],
                               atol=1e-9)


def test_a_transfer_back_arrives_in_time_to_be_stopped_and_a_grown_momentum_is_dumped_again():
    """A transfer back starts only where it arrives trim_stop_s before the judgement, and its arrival is checked at once
    (a transfer arriving shortly before the judgement would leave its velocity there). A dump at the estimate's floor is
    not repeated, but a momentum grown beyond twice that is dumped again, where a pulse can still follow, and beyond the
    first condition whatever follows."""
    body, control = _planned()
    p = control.config.planner.period_s
    t_end = control.t_arrival + control.config.settle_s
    control.momentum = 0.0
    r_off = np.array([1003.0, 0.0, 0.0])  # beyond replan_position_m

    def aimed(t):
        """The state at t, 3 m off the goal with the push axis along the transfer back's first impulse."""
        dv1, _ = terminal_impulses(r_off, np.zeros(3), control.goal, np.zeros(3), 2.0 * p + TRIM_TIME_S, control.n)
        return _state(t, quat_shortest_arc(np.array([1.0, 0.0, 0.0]), dv1 / np.linalg.norm(dv1)), r=r_off)
    late = aimed(t_end - TRIM_TIME_S - control.trim_stop_s + 1.0)
    control.t_check = late.t
    assert not any(e[1] == 'transport_trim' for e in control._check(late)) and control.trim_arrival is None
    body, control = _planned()
    control.momentum = 0.0
    early = aimed(t_end - TRIM_TIME_S - control.trim_stop_s - 5.0)
    control.t_check = early.t
    assert [e[1] for e in control._check(early)] == ['transport_trim']
    assert control.trim_arrival == pytest.approx(early.t + 2.0 * p + TRIM_TIME_S)
    assert control.t_check == pytest.approx(early.t + control.config.replan_interval_s)
    before = control.trim_arrival - 5.0  # the last check before the arrival: the next one at the arrival
    assert control._check(early._replace(t=before)) == [] and control.t_check == control.trim_arrival
    body, control = _planned()
    control.momentum = 0.04
    assert control._trim(_state(1400.0))[0][1] == 'transport_dump'
    control.dumping, control.momentum = None, 0.035  # not halved: the floor
    assert control._trim(_state(1430.0)) == []
    control.momentum = 0.09  # a pulse's couple taken by the wheels, within the first condition
    t_end = control.t_arrival + control.config.settle_s
    late = t_end - DUMP_S - control.trim_stop_s + 1.0  # no time for a pulse after it: its couples push a little
    assert control._trim(_state(late)) == [] and control.dumping is None
    assert control._trim(_state(1460.0))[0][1] == 'transport_dump'
    control.dumping, control.dumped, control.momentum = None, 0.04, 0.12  # beyond it: dumped, late or not
    assert control._trim(_state(late))[0][1] == 'transport_dump'


def test_on_a_body_the_wheels_do_not_steer_the_thrusters_couples_hold_the_plans_attitude():
    """Where the wheels cannot turn the body (paper_flyby_transport's 0.1 N m on 3000 kg m^2) the thrusters' couples
    take the attitude error from the plan's model (the open-loop slews had ended 12 deg off there, and the arrival push
    left 90 N s across), in pulses; where they can, the wheels do and the thrusters fire nothing at a coast."""
    fired = {}
    for steer in (True, False):
        body, control = _planned()
        control.wheels_steer = steer
        pushes = [b for b in control.plan.burns if b.purpose == 'push']
        t = pushes[0].t_start_s + pushes[0].duration_s + 5.0  # coasting to the next slew
        planned = propagate(body, control.plan_start, [b for b in control.plan.burns if b.t_start_s < t], t,
                            control.config.planner)
        tilted = quat_multiply(planned.q_hill_from_body, quat_from_rotation_vector((0.0, 0.0, 0.1)))
        r_point, v_point = body_point_state(quat_to_matrix(tilted), planned.omega_body, -body.com_body_m, control.n)
        impulse, wheels = np.zeros(3), []
        for k in range(50):
            force, torque, u, _ = control.command(t + 0.1 * k, planned.r_hill + r_point, planned.v_hill + v_point,
                                                  tilted, planned.omega_body, np.zeros(3))
            impulse += 0.1 * (torque - np.cross(body.com_body_m, force))  # about the combined CoM
            wheels.append(u)
        fired[steer] = impulse
        if steer:
            assert not np.any(impulse) and all(float(u[2]) > 0.0 for u in wheels)  # the body feels -u
        else:
            assert impulse[2] < 0.0 and abs(impulse[2]) > 10.0 * np.linalg.norm(impulse[:2])
            np.testing.assert_allclose(wheels, [control._hold(planned.omega_body)] * len(wheels))  # rate only


def _refined(control, t, sigma_m):
    """The estimator's refined combined CoM (the body's own) with sigma_m, taken at t."""
    control.refine_com(t, control.body.com_body_m.tolist(), sigma_m)
    control._take_com(t)


def test_on_the_coms_coast_the_trim_takes_out_only_a_drift_and_starts_no_transfer_back():
    """The body turns in hill at n, so a CoM error dc is a velocity error n x C dc of the navigation: where the CoM's
    1-sigma is worth more than a quarter of the third condition, the trim lets the estimator's coast sharpen it until
    COM_FINAL_RAD of orbit before the judgement: it aims at no along-track drift (not at rest at the judgement, whose
    arc from a radial offset of metres ends beyond the second condition), takes out only a drift beyond three times
    that worth, and starts no transfer back; then it aims at rest at the judgement. A CoM sharp at the first trim
    changes nothing."""
    body, control = _planned()
    control.momentum = 0.0
    t_end = control.t_arrival + control.config.settle_s
    bound = control.config.planner.max_momentum_error_n_s
    final_s = COM_FINAL_RAD / control.n
    t = t_end - final_s - 500.0
    sigma = 2.0 * bound / (body.mass_kg * control.n)  # a CoM worth twice the condition
    _refined(control, t, [sigma, 0.0, 0.0])
    row = cw_transition_matrix(control.n, 2.0 * np.pi / control.n)[0]  # along-track after an orbit
    offset = np.array([0.0, 0.0, 1.0])  # 1 m radially off the goal

    def drifting(t, v_x, offset=offset):
        """Along hill x (the push axis: no turn) at v_x beyond the velocity with no drift [m/s]."""
        v0 = -(row[:3] @ offset - offset[0]) / row[3]
        return _state(t, r=control.goal + offset, v=(v0 + v_x, 0.0, 0.0))
    assert control._trim(drifting(t, 0.0)) == [] and not control.pulses  # at rest at the judgement would need a pulse
    assert control._trim(drifting(t, -5.0 * bound / body.mass_kg)) == []  # 2.5 times the worth: left
    events = control._trim(drifting(t, -7.0 * bound / body.mass_kg))
    assert [e[1] for e in events] == ['transport_pulse']
    t_a, t_b, force, _ = control.pulses[0]
    v_after = drifting(t, -7.0 * bound / body.mass_kg).v_hill + force * (t_b - t_a) / body.mass_kg
    assert abs(row @ np.concatenate((offset, v_after)) - offset[0]) < 1e-9  # no along-track drift left
    control.pulses = []
    far = np.array([0.0, 0.0, 8.0])  # beyond replan_position_m: no transfer back on the coast
    assert [e[1] for e in control._trim(drifting(t + 100.0, -7.0 * bound / body.mass_kg, far))] == ['transport_pulse']
    assert control.trim_arrival is None
    control.pulses = []
    late = drifting(t_end - final_s + 1.0, 0.0)  # no drift, but not at rest at the judgement: the wheels turn the
    assert control._trim(late) == [] and control.trim_slew[3] > 0.0  # push axis onto the error for its pulse
    body, control = _planned()
    control.momentum = 0.0
    _refined(control, t, [0.1 * sigma, 0.0, 0.0])
    assert control._trim(drifting(t, 0.0)) == [] and control.trim_slew[3] > 0.0 and control.com_worth == 0.0
    # Where the wheels do not steer, the drift is taken out along the push axis (a pulse across it needs couples
    # several times its size), here hill x turned 30 deg toward -z: along it, not along the drift's gradient.
    control.wheels_steer = False
    tilted = quat_from_rotation_vector((0.0, np.radians(30.0), 0.0))
    state = drifting(t, -7.0 * bound / body.mass_kg)._replace(q_hill_from_body=tilted)
    change = control._drift_free_change(state)
    b_hill = quat_to_matrix(tilted) @ control.b_body
    np.testing.assert_allclose(np.cross(change, b_hill), 0.0, atol=1e-12)
    assert change @ b_hill > 0.0
    assert abs(row @ np.concatenate((offset, state.v_hill + change)) - offset[0]) < 1e-9


def test_a_pulse_that_costs_more_than_twice_what_the_judgement_gains_waits():
    """Out of the orbit plane the velocity that coasts to rest at the judgement is y n tan(n T): a quarter orbit
    before it a pulse of any size changes the judged velocity by cos(n T) of itself, and waits; 100 s before, it
    fires."""
    body, control = _planned()
    control.momentum = 0.0
    t_end = control.t_arrival + control.config.settle_s
    v_y = 5.0 * control.config.planner.max_momentum_error_n_s / body.mass_kg
    quarter = t_end - 0.45 * np.pi / control.n
    q_y = quat_shortest_arc(np.array([1.0, 0.0, 0.0]), np.array([0.0, -1.0, 0.0]))  # the push axis against it
    assert control._trim(_state(quarter, q_y, v=(0.0, v_y, 0.0))) == [] and not control.pulses
    events = control._trim(_state(t_end - 100.0, q_y, v=(0.0, v_y, 0.0)))
    assert [e[1] for e in events] == ['transport_pulse']


def test_on_the_coms_coast_the_wheels_turn_the_push_axis_onto_the_change_the_last_pulses_need():
    """Where the wheels do not steer, the push axis is fixed inertially and turns in hill at n, and a drift-free
    relative orbit's velocity turns with it: a change the pulses after the coast need against the axis would stay out
    of reach. Once the drift is out, the wheels turn the
    axis onto that change (CW to the coast's end, then the velocity that coasts to rest at the judgement), at most
    COAST_SLEW_MOMENTUM_FRACTION of their momentum, and hold it there; nothing fires."""
    body, control = _planned()
    control.momentum = 0.0
    control.wheels_steer, control.wheel_max_momentum_n_m_s = False, 4.0
    control.config = dataclasses.replace(control.config, settle_s=4000.0)  # the coast after the plan's last burn
    t_end = control.t_arrival + control.config.settle_s
    bound = control.config.planner.max_momentum_error_n_s
    t = t_end - COM_FINAL_RAD / control.n - 500.0
    _refined(control, t, [2.0 * bound / (body.mass_kg * control.n), 0.0, 0.0])
    row = cw_transition_matrix(control.n, 2.0 * np.pi / control.n)[0]
    offset = np.array([0.0, 0.0, 1.0])  # 1 m radially off the goal, with no drift
    state = _state(t, r=control.goal + offset, v=(-(row[:3] @ offset - offset[0]) / row[3], 0.0, 0.0))
    events = control._trim(state)
    assert [e[1] for e in events] == ['transport_coast_slew'] and not control.pulses
    t0, q0, axis, angle, rate = control.trim_slew
    axis_body = quat_rotate(quat_conjugate(q0), axis)
    assert rate == pytest.approx(COAST_SLEW_MOMENTUM_FRACTION * 4.0 / (axis_body @ body.inertia_body_kg_m2 @ axis_body))
    t_f = t_end - COM_FINAL_RAD / control.n
    x_f = cw_transition_matrix(control.n, t_f - t) @ np.concatenate((offset, state.v_hill))
    phi_t = cw_transition_matrix(control.n, t_end - t_f)
    wanted = -np.linalg.solve(phi_t[3:, 3:], phi_t[3:, :3] @ x_f[:3]) - x_f[3:]
    b_f = quat_rotate(quat_multiply(quat_from_rotation_vector(angle * axis), q0), control.b_body)
    np.testing.assert_allclose(b_f, hill_axes_in_eci(t_f, control.n) @ (wanted / np.linalg.norm(wanted)), atol=1e-9)
    assert t + angle / rate < t_f
    force, torque, wheels, _ = control.command(t + 1.0, state.r_hill - quat_to_matrix(state.q_hill_from_body)
                                               @ body.com_body_m, state.v_hill, state.q_hill_from_body, np.zeros(3),
                                               np.zeros(3))
    assert not np.any(force) and not np.any(torque) and np.any(wheels)  # the wheels turn it, nothing fires
