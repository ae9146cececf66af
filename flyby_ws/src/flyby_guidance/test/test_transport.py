"""Guidance in TRANSPORT (flyby_guidance.transport): the body it plans for from the final mass-property estimate,
the detumbling first (the body's own angular momentum, not the wheels'), the plan once detumbled and navigated and
its refusals, the closed-loop push and spin-down, the attitude held, the terminal program's firings (a turning body
damped first, a new transfer or a turn where it has no horizon) and the judgement after the arrival (the conditions
from the estimate with its 3-sigma, held hold_s)."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from flyby_guidance.damping import PostCaptureConfig
from flyby_guidance.transport.attitude import DETUMBLED_S, TRACK_BANDWIDTH_RAD_S, TRACK_DAMPING, WHEEL_SPINUP_S
from flyby_guidance.transport.control import (
    NAV_SETTLE_S,
    PULSE_BITS,
    PULSE_BOUND_FRACTION,
    TransportControl,
    TransportGuidanceConfig,
    transport_body,
    transport_pulse_n_m_s,
)
from flyby_guidance.transport.push import REPLAN_FRACTION
from flyby_guidance.transport.terminal import AIM_FRACTION, NAV_SIGMAS, TERMINAL_ROUNDS, settle_bound_s
from flyby_msgs_py.event_payloads import decode_values
from flyby_msgs_py.events import (
    MASS_PROPERTIES_ESTIMATED,
    TRANSPORT_COMPLETE,
    TRANSPORT_CORRECTION,
    TRANSPORT_DETUMBLED,
    TRANSPORT_PLANNED,
    TRANSPORT_REFUSED,
    TRANSPORT_TERMINAL,
    TRANSPORT_TURN,
)
from flyby_planner.transfer import terminal_impulses
from flyby_planner.transport.model import TransportBody, TransportRefused, TransportState, propagate
from flyby_planner.transport.terminal import HORIZONS_S, solve
from flyby_sim.dynamics.actuators import allocate_wrench, default_thruster_layout
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.combined_body import combined_mass_properties, inertia_from_principal
from flyby_sim.dynamics.orbital import cw_transition_matrix, hill_axes_in_eci, q_eci_from_body, q_hill_from_body
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    quat_rotate,
    quat_to_matrix,
)
from flyby_sim.scenario import load_scenario

SCENARIO = Path(__file__).resolve().parents[4] / 'scenarios' / 'matsunaga_orbit_advance.yaml'
# The final estimate's values as the estimator's mass_properties_estimated event carries them (text).
ESTIMATE = decode_values(MASS_PROPERTIES_ESTIMATED, {
    'mass_kg': '20.2', 'mass_sigma_kg': '0.0', 'com_body_m': '[0.5, 0.0, 0.0]', 'com_sigma_m': '[0.0, 0.0, 0.0]',
    'principal_moments_kg_m2': '[1.5, 1.5, 2.0]', 'principal_moments_sigma_kg_m2': '[0.0, 0.0, 0.0]',
    'principal_axes_q': '[0.0, -0.7071067811865476, 0.0, 0.7071067811865476]'})


def _control(planner=None, **changes):
    """matsunaga_orbit_advance's transport guidance (wheels of 0.1 N m and 1 N m s), its config's keys replaced by
    changes and its TransportConfig's by planner (a dict)."""
    sc = load_scenario(SCENARIO)
    body = transport_body(ESTIMATE, sc.chaser.mass_kg, sc.chaser_inertia, sc.thruster_layout,
                          sc.post_capture.transport.plume_cone_deg)
    config = TransportGuidanceConfig.from_scenario(sc)
    if planner:
        changes['planner'] = dataclasses.replace(config.planner, **planner)
    control = TransportControl(dataclasses.replace(config, **changes), sc.mean_motion_rad_s,
                               PostCaptureConfig.from_scenario(sc).gains, 0.1, 1.0)
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
    assert t >= 85.0 + NAV_SETTLE_S and events[0][1] == TRANSPORT_PLANNED
    assert events[0][3]['settle_bound_s'] == control.settle_bound
    assert control.plan.conditions['position_error_m'] < 10.0
    # At the push, the state the plan predicts: the closed-loop force is the planned one (the same needed velocity).
    push = next(b for b in control.plan.burns if b.purpose == 'push')
    planned_at = propagate(body, control.plan_start, [b for b in control.plan.burns if b.t_start_s < push.t_start_s],
                           push.t_start_s, control.config.planner)
    force, torque = control._closed_loop_push(push.t_start_s - 0.1, planned_at, push, push.force_body_n,
                                              push.torque_body_n_m, np.zeros(3))
    np.testing.assert_allclose(torque, np.cross(body.com_body_m, force), atol=1e-12)  # none about the combined CoM
    assert not allocate_wrench(body.layout, force, torque).saturated
    # Up to the Coriolis term over the push, which the closed loop takes at once: 2 n |dv| m ~ 0.14 N here.
    np.testing.assert_allclose(force, push.force_body_n, atol=0.2)
    # The push commanded at the previous estimate acts over the period the estimate has not seen yet: asked for once.
    control.issued = (push.t_start_s - 0.2, force, torque)
    again, _ = control._closed_loop_push(push.t_start_s - 0.1, planned_at, push, push.force_body_n,
                                         push.torque_body_n_m, np.zeros(3))
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


def _until_planned(body, control):
    """Estimates at rest with the chaser's axes along hill's from t = 85 s until the plan or its refusal: the events."""
    control.start(85.0, body)
    q, r_chaser, t = np.array([0.0, 0.0, 0.0, 1.0]), np.array([10.0, 5.0, 5.0]) - body.com_body_m, 85.0
    events = []
    while control.plan is None and not control.done:
        events += control.command(t, r_chaser, np.zeros(3), q, np.zeros(3), np.zeros(3))[3]
        t += 0.1
    return events


def _planned(**changes):
    """The control of test_transport_detumbles_then_plans_and_flies_the_pushes_on_the_estimate once planned, at rest
    with the chaser's axes along hill's (the estimate it planned from)."""
    _, body, control = _control(**changes)
    _until_planned(body, control)
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


def test_a_mid_course_miss_gets_one_impulse_keeping_the_last_push():
    """After the first push, the estimate's deviation from the plan's coast carried to the last push by CW: within a
    quarter of the second condition nothing; beyond it one impulse now that takes the miss out, where the thrusters
    give it."""
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
    assert events[0][1] == TRANSPORT_CORRECTION
    dv = control.pulses[0][2] * (control.pulses[0][1] - control.pulses[0][0]) / body.mass_kg
    phi = cw_transition_matrix(control.n, pushes[-1].t_start_s + 0.5 * pushes[-1].duration_s - t)
    corrected = np.concatenate((short.r_hill, short.v_hill + quat_to_matrix(q_push) @ dv)) - x
    assert np.linalg.norm((phi @ corrected)[:3]) < 0.05
    # 5 mm/s too fast: the correction brakes, along -x of the body: not now (the last push takes the velocity out).
    control.pulses = []
    fast = on_plan._replace(v_hill=x[3:] + 5e-3 * axis)
    assert control._correct(fast, pushes, next_burn) == [] and not control.pulses


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


P = 0.1  # guidance's control period on matsunaga_orbit_advance (the chaser IMU's 10 Hz) [s]


def _estimate(control, t, r_com, v_com=(0.0, 0.0, 0.0), q_hill=(0.0, 0.0, 0.0, 1.0), omega=(0.0, 0.0, 0.0),
              h_wheels=(0.0, 0.0, 0.0)):
    """control.command of the chaser estimate whose combined CoM is at r_com moving at v_com (hill; the chaser's
    point -c of the body by seed 000 eq 8-9)."""
    q, omega = np.asarray(q_hill, dtype=float), np.asarray(omega, dtype=float)
    r_point, v_point = body_point_state(quat_to_matrix(q), omega, -control.body.com_body_m, control.n)
    return control.command(t, np.asarray(r_com, dtype=float) + r_point, np.asarray(v_com, dtype=float) + v_point, q,
                           omega, np.asarray(h_wheels, dtype=float))


def _arrived(nav_position_sigma_m=0.01, **changes):
    """A planned control, its navigation's 1-sigma given (position_sigma_m, 10 um/s, a CoM of 0.1 mm), and the first
    estimate's stamp after its last burn and arrival on the grid: (body, control, t0, q_eci_from_body at rest there
    with the body's axes along hill's)."""
    body, control = _planned(**changes)
    last_burn_end = max(b.t_start_s + b.duration_s for b in control.plan.burns)
    t0 = P * math.ceil(max(control.plan.t_arrival_s, last_burn_end) / P + 1.0)
    control.refine_com(t0, control.body.com_body_m.tolist(), [1e-4] * 3, nav_position_sigma_m, 1e-5)
    return body, control, t0, q_eci_from_body(t0, control.n, np.array([0.0, 0.0, 0.0, 1.0]))


def _held(control, t, q_eci):
    """The attitude held inertially, in hill at t."""
    return q_hill_from_body(t, control.n, q_eci)


def test_the_detumbling_judges_the_bodys_own_angular_momentum_not_the_wheels():
    """The detumbling ends once the body's own |I omega| (its rate averaged over DETUMBLED_S) is below half the first
    condition and the wheels keep WHEEL_ROOM of their capacity free: a body at rest whose wheels hold 0.6 N m s is
    detumbled, one turning at |I omega| = 0.08 kg m^2/s with its wheels holding the opposite (none in all) is not, nor
    one at rest whose wheels hold 0.95 of their capacity."""
    cases = ((np.zeros(3), (0.6, 0.0, 0.0), True), (None, None, False), (np.zeros(3), (0.0, 0.95, 0.0), False))
    for omega, h_wheels, detumbled in cases:
        _, body, control = _control()
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
    body, control, t0, q_eci = _arrived()
    hold_s = control.config.hold_s
    assert hold_s == 60.0
    k_break = 300  # 30 s on, between two checks of the terminal program
    found, k = [], 0
    while not found:
        t = t0 + k * P
        force, torque, _, events = _estimate(control, t, control.rest, q_hill=_held(control, t, q_eci),
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
    force, torque, wheels, events = _estimate(control, t + P, control.rest, q_hill=_held(control, t + P, q_eci))
    assert not (np.any(force) or np.any(torque) or np.any(wheels) or events)


def test_conditions_that_never_hold_end_in_a_warn_at_the_deadline():
    """At the rest point at rest but estimated with 4 m of position 1-sigma (12 m at 3-sigma, beyond the second
    condition): no transport_complete before the deadline (two replan intervals before the run's end), then a WARN
    that says the conditions were not held, the estimate's own values within the bounds."""
    body, control, t0, q_eci = _arrived(nav_position_sigma_m=4.0)
    deadline = control.config.duration_s - 2.0 * control.config.replan_interval_s
    t, found = t0, []
    while not found:
        events = _estimate(control, t, control.rest, q_hill=_held(control, t, q_eci))[3]
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
    _, body, control = _control(**changes)
    events = _until_planned(body, control)
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
        _, body, control = _control(goal_hill_m=goal)
        control.start(85.0, body)
        if refused:
            with pytest.raises(TransportRefused, match='is no rest point'):
                control._check_reachable(control.t_arrival)
        else:
            control._check_reachable(control.t_arrival)


def test_too_little_time_for_the_stated_settle_bound_is_refused():
    """The run must leave the settle bound after the arrival before the deadline (two replan intervals before its
    end): a second less is refused naming the bound, a second more is planned."""
    _, body, control = _control()
    control.start(85.0, body)
    bound, margin = control.settle_bound, 2.0 * control.config.replan_interval_s
    for extra_s, refused in ((-1.0, True), (1.0, False)):
        _, body, control = _control(duration_s=control.t_arrival + bound + margin + extra_s)
        events = _until_planned(body, control)
        assert events[-1][1] == (TRANSPORT_REFUSED if refused else TRANSPORT_PLANNED)
        if refused:
            assert events[-1][3]['reason'].startswith(f'too little time: the conditions need {bound:.0f} s after')


def test_the_settle_bound_is_rounds_of_a_coast_that_learns_the_velocity_a_firing_and_a_check_then_the_hold():
    """Each of TERMINAL_ROUNDS rounds is the coast over which a constant velocity fitted to positions of 1 cm at
    10 Hz (least squares over the samples, whose slope has the variance s^2 / sum (t - t_mean)^2) is known within
    AIM_FRACTION of the third condition at NAV_SIGMAS, at least the combined CoM's period, then the shortest horizon
    and a replan interval; then the hold."""
    mass, bound, hold, replan = 50.2, 0.01, 60.0, 20.0
    total = settle_bound_s(mass, bound, 0.01, 10.0, hold, 0.0, replan)
    coast_s = (total - hold) / TERMINAL_ROUNDS - HORIZONS_S[0] - replan
    times = np.arange(0.0, coast_s, 0.1)
    sigma_v = 0.01 / math.sqrt(float(np.sum((times - times.mean()) ** 2)))
    assert NAV_SIGMAS * mass * sigma_v == pytest.approx(AIM_FRACTION * bound, rel=0.01)
    assert settle_bound_s(mass, bound, 0.01, 10.0, hold, 1000.0, replan) == pytest.approx(
        TERMINAL_ROUNDS * (1000.0 + HORIZONS_S[0] + replan) + hold)


def test_after_the_arrival_the_terminal_program_fires_one_thruster_a_period():
    """1 mm/s along -x at the rest point, the push axis along hill x: the terminal program's firings
    (transport_terminal) are one allowed thruster a period from the first period this estimate's command reaches, at
    least a minimum impulse bit each, together the momentum along +x; guidance commands them at their periods."""
    body, control, t0, q_eci = _arrived()
    v_com = (-1e-3, 0.0, 0.0)
    force, _, _, events = _estimate(control, t0, control.rest, v_com=v_com, q_hill=_held(control, t0, q_eci))
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
        commanded = _estimate(control, t_a - P, control.rest, v_com=v_com, q_hill=_held(control, t_a - P, q_eci))
        np.testing.assert_allclose(commanded[0], force, atol=1e-12)
    np.testing.assert_allclose(impulse, [values['impulse_n_s'], 0.0, 0.0], atol=1e-12)


def test_where_no_horizon_is_feasible_the_wheels_turn_the_push_axis_onto_the_transfers_first_impulse():
    """2 mm/s along the push axis (+x), with time left for the shortest horizon only: the program has no
    firing (the thrusters push no -x), and the wheels turn the body at the rate their share of momentum gives it until
    the push axis lies along the first impulse of CW's transfer to the rest point (transport_turn)."""
    body, control, t0, q_eci = _arrived()
    _estimate(control, t0, control.rest, q_hill=_held(control, t0, q_eci))  # the terminal from here
    t = control.deadline - control.config.hold_s - 2.0 * P - 100.0  # time for the 60 s horizon only
    q_hill = _held(control, t, q_eci)  # the push axis turned in hill at n since the hold began
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


def _same_attitude(q_a, q_b):
    """True where two quaternions are one attitude (q and -q)."""
    return abs(float(np.dot(q_a, q_b))) == pytest.approx(1.0, abs=1e-12)


def test_a_body_turning_in_the_terminal_phase_is_damped_then_held_again_at_its_new_attitude():
    """In the terminal phase, nothing firing and no turn under way, a body turning at |I omega| = 0.95 kg m^2/s (more
    than 1 - WHEEL_ROOM of the wheels' 1 N m s: they could not hold it still): the capture's damping law (the wheels
    and the thrusters' couple against the rate), the hold dropped, no terminal firing; at rest again
    within DETUMBLED_S the terminal phase holds the attitude the body then has (not the one it held before)."""
    body, control, t0, q_eci = _arrived()
    _estimate(control, t0, control.rest, q_hill=_held(control, t0, q_eci))  # the terminal from here
    assert control.t_terminal == t0 and control.hold is not None and not control.pulses
    omega = np.linalg.solve(body.inertia_body_kg_m2, [0.0, 0.0, 0.95])
    window = round(DETUMBLED_S / P)
    couples = []
    for k in range(1, window + 11):
        t = t0 + k * P
        force, torque, u, events = _estimate(control, t, control.rest, q_hill=_held(control, t, q_eci), omega=omega)
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
        force, torque, u, events = _estimate(control, t, control.rest, q_hill=_held(control, t, q_turned))
        assert not events
        if control.hold is not None:
            break
    assert t - t_rest <= DETUMBLED_S and control.t_terminal == t and control.turning is None
    assert _same_attitude(control.hold, q_turned) and not _same_attitude(control.hold, q_eci)
    np.testing.assert_allclose(u, 0.0, atol=1e-12)  # on the new hold: the wheels track it
    t_again, hold = t, control.hold
    for k in range(1, window + 1):
        t = t_again + k * P
        force, torque, u, events = _estimate(control, t, control.rest, q_hill=_held(control, t, q_turned))
        assert not (events or np.any(force) or np.any(torque)) and control.hold is hold


def _turning(control, q_eci):
    """control, its terminal entered at rest at the rest point, turned by the wheels (``_terminal`` with 2 mm/s along
    the push axis, time left for the shortest horizon only): the turn's (t0, q0_eci, axis_eci, angle, rate)."""
    t0 = control.t_terminal
    t = control.deadline - control.config.hold_s - 2.0 * P - 100.0
    q_hill = _held(control, t, q_eci)
    v_hill = quat_to_matrix(q_hill) @ np.array([2e-3, 0.0, 0.0])
    events = control._terminal(TransportState(t, control.rest.copy(), v_hill, q_hill, np.zeros(3)), np.zeros(3))
    assert [e[1] for e in events] == [TRANSPORT_TURN] and control.t_terminal == t0
    return control.turning


def test_a_turn_under_way_is_not_damped_the_wheels_keep_turning_the_body():
    """While the wheels turn the push axis the body's own angular momentum is the turn's (above half the first
    condition): no damping law, the hold and the turn kept, the wheels on the turn's rate (a rate error of 1 mrad/s
    gets the PD's rate term and nothing else), nothing fired."""
    body, control, t0, q_eci = _arrived()
    _estimate(control, t0, control.rest, q_hill=_held(control, t0, q_eci))
    turn = _turning(control, q_eci)
    t_turn, _, axis, angle, rate = turn
    delta = np.array([0.0, 0.0, 1e-3])
    window = round(DETUMBLED_S / P)
    assert (window + 10) * P < angle / rate
    for k in range(1, window + 11):
        t = t_turn + k * P
        q_ref = control._held(t)
        w_turn = quat_rotate(quat_conjugate(q_ref), axis * rate)  # body axes
        force, torque, u, events = _estimate(control, t, control.rest, q_hill=q_hill_from_body(t, control.n, q_ref),
                                             omega=w_turn + delta)
        assert not (events or np.any(force) or np.any(torque))
        np.testing.assert_allclose(u, body.inertia_body_kg_m2 @ (2.0 * TRACK_DAMPING * TRACK_BANDWIDTH_RAD_S * delta),
                                   atol=1e-9)
    assert control.body_momentum > 0.05 and control.hold is not None and control.turning == turn


def test_a_body_the_wheels_do_not_steer_turns_by_the_thrusters_couples_at_the_slews_rate():
    """Where the wheels cannot turn the body (a heavy one: their share of momentum would take hours), a terminal turn
    (at the transfer's slew rate, ``start``) is the thrusters' couples' (in pulses, against the PD's torque from the
    turning reference): at rest at the turn's start the couple fired is along the turn's axis."""
    body, control, t0, q_eci = _arrived()
    control.wheels_steer = False
    control.turn_rate_rad_s = control.config.planner.slew_rate_rad_s
    _estimate(control, t0, control.rest, q_hill=_held(control, t0, q_eci))
    t_turn, _, axis, _, _ = _turning(control, q_eci)
    impulse = np.zeros(3)
    for k in range(1, 31):
        t = t_turn + k * P
        force, torque, _, events = _estimate(control, t, control.rest, q_hill=_held(control, t, q_eci))
        assert not events
        impulse += (torque - np.cross(body.com_body_m, force)) * P  # about the combined CoM, body axes
    axis_body = quat_rotate(quat_conjugate(q_eci), axis)
    assert np.linalg.norm(impulse) > 0.0 and float(impulse @ axis_body) > 0.9 * np.linalg.norm(impulse)


def test_after_the_turn_a_turning_body_is_damped():
    """Once the turn has reached its angle and the wheels had WHEEL_SPINUP_S to stop it (the check it scheduled), no
    turn is under way: a body turning at |I omega| = 0.95 kg m^2/s then gets the damping law, as before any turn."""
    body, control, t0, q_eci = _arrived()
    _estimate(control, t0, control.rest, q_hill=_held(control, t0, q_eci))
    t_turn, _, _, angle, rate = _turning(control, q_eci)
    omega = np.linalg.solve(body.inertia_body_kg_m2, [0.0, 0.0, 0.95])
    t_end = t_turn + angle / rate
    for k in range(round(DETUMBLED_S / P) + 1):
        t = t_end + WHEEL_SPINUP_S + 1.0 + k * P
        _estimate(control, t, control.rest, q_hill=q_hill_from_body(t, control.n, control._held(t)), omega=omega)
    assert control.body_momentum == pytest.approx(0.95) and control.hold is None


def _far_off(duration_s):
    """300 m ahead of the rest point along V-bar at rest, the body's axes along hill's, at the first estimate after
    the arrival of a run of duration_s: (control, t0, its events); no terminal horizon feasible there."""
    _, control, t0, _ = _arrived(duration_s=duration_s)
    r_com = control.rest + np.array([300.0, 0.0, 0.0])
    q = np.array([0.0, 0.0, 0.0, 1.0])
    state = TransportState(t0, r_com, np.zeros(3), q, np.zeros(3))
    rho_p = AIM_FRACTION * control.config.planner.max_momentum_error_n_s
    problem = control._terminal_problem(state, np.zeros(3), rho_p)
    horizons = [h for h in HORIZONS_S if h <= control.deadline - control.config.hold_s - problem.t0]
    assert horizons and solve(problem, horizons) is None
    return control, t0, _estimate(control, t0, r_com, q_hill=q)[3]


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
    force, torque, _, _ = _estimate(control, burn.t_start_s - P, control.rest + np.array([300.0, 0.0, 0.0]))
    assert np.any(torque) and control.t_terminal is None


def test_on_a_body_the_wheels_do_not_steer_no_horizon_means_a_new_transfer():
    """At the rest point, 2 mm/s along the push axis (no horizon: the thrusters push no -x), with time for a
    transfer: where the wheels steer the body they turn the push axis; where they do not (a heavy body, its turn a
    slew by the thrusters' couples, whose side force the planner's transfer takes into account) a new transfer."""
    kinds = {}
    for steer in (True, False):
        _, control, t0, q_eci = _arrived(duration_s=2800.0)
        control.wheels_steer = steer
        _estimate(control, t0, control.rest, q_hill=_held(control, t0, q_eci))  # the terminal from here
        t = t0 + 1.0
        q_hill = _held(control, t, q_eci)
        state = TransportState(t, control.rest.copy(), quat_to_matrix(q_hill) @ np.array([2e-3, 0.0, 0.0]), q_hill,
                               np.zeros(3))
        kinds[steer] = [e[1] for e in control._terminal(state, np.zeros(3))]
        assert (control.t_terminal is None) == (not steer)
    assert kinds == {True: [TRANSPORT_TURN], False: [TRANSPORT_CORRECTION]}


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
