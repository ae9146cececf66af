"""GuidanceCore: the plan's first burn t_Ti, stepping on the chaser estimates, silence after the fly-by."""

from pathlib import Path

import numpy as np
import pytest

from flyby_estimation.transport_navigation import COM_PERIOD_S
from flyby_guidance.guidance import Maneuver
from flyby_guidance.guidance_core import GuidanceCore
from flyby_guidance.modes.interface import AttitudeCommandStamped
from flyby_guidance.params import GuidanceParams
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.wire import Event
from flyby_planner.flyby.grasp_search import flyby_target_from_attitude
from flyby_planner.transfer import terminal_impulses
from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.orbital import cw_transition_matrix, q_eci_from_body, q_hill_from_body
from flyby_sim.dynamics.rotation import quat_from_axis_angle
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
X_FI, V_FI = np.array((-20.0, 0.0, 30.0)), np.array((0.05, 0.0, -0.1))
X_FT, V_FT = np.array((0.5, 2.9, 0.1)), np.array((0.0, 0.01, 0.19))


def _started(sc, t_plan=60.0):
    core = GuidanceCore(GuidanceParams.from_scenario(sc))
    assert core.on_flyby_target(813.0, X_FT, V_FT) == [] and core.on_flyby_initial(513.0, X_FI, V_FI) == []
    (started,) = core.on_path(t_plan)
    assert isinstance(started, Event) and started.name == 'guidance_started'
    return core


def test_first_burn_is_the_maneuver_lead_after_the_plan_time():
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    core = _started(sc)
    t_ti = 60.0 + sc.planner.maneuver_lead_s
    assert core.flyby.guidance.target.t_ti == t_ti
    assert core.on_path(60.0) == []  # the same plan again starts nothing
    r, v = np.array((50.0, 0.0, 0.0)), np.zeros(3)
    lead = sc.guidance.command_lead_s
    assert core.on_chaser_estimate(t_ti - lead - 0.1, r, v) == []
    out = core.on_chaser_estimate(t_ti - lead, r, v)
    (burn,) = [o for o in out if isinstance(o, Maneuver)]
    assert burn.kind == 'transfer' and burn.t == t_ti
    # Eq 28 from the estimate carried to t_Ti (CW, eq 22), to X_Fi at t_i.
    state = cw_transition_matrix(sc.mean_motion_rad_s, lead) @ np.concatenate((r, v))
    dv, _ = terminal_impulses(state[:3], state[3:], X_FI, V_FI, 513.0 - t_ti, sc.mean_motion_rad_s)
    assert burn.dv_hill == pytest.approx(dv, abs=1e-12)
    assert [o.name for o in out if isinstance(o, Event)] == ['maneuver_commanded']


def test_nothing_is_commanded_after_the_fly_by():
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    core = _started(sc)
    core.on_phase(c.PHASE_ESCAPE)
    assert core.on_chaser_estimate(70.0, np.array((50.0, 0.0, 0.0)), np.zeros(3)) == []


def _aimed_at_paper_flyby(offset_m, aim_error_m):
    """(guidance core on paper_flyby's fly-by, aimed at the grasp point offset_m out at 741 s, off by aim_error_m
    along each hill axis; n; the target's true attitude and rate at 400 s)."""
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    n = sc.mean_motion_rad_s
    truth = AttitudePropagator(q_eci_from_body(0.0, n, sc.q_hill_from_body0), sc.omega_body0_rad_s, sc.target_inertia)
    q, w = truth.state_at(400.0)
    q_g, w_g = truth.state_at(741.0)
    x_ft, v_ft = flyby_target_from_attitude(q_hill_from_body(741.0, n, q_g), w_g, sc.target.grasp_point_body_m,
                                            offset_m, n)
    core = GuidanceCore(GuidanceParams.from_scenario(sc))
    core.on_flyby_target(741.0, x_ft + aim_error_m, v_ft)
    core.on_flyby_initial(441.0, X_FI, V_FI)
    core.on_path(60.0)
    return core, n, q, w


def test_a_re_aim_keeps_the_offset_of_the_plan():
    """The plan flies delta r = 1.3 m (|X_Ft| - |x_g|, eq 20); the grasp re-solved from a newer estimate is
    offset by the same 1.3 m, not by the scenario's preferred planner.offset_m."""
    core, n, q, w = _aimed_at_paper_flyby(1.3, 0.0)
    (refined,) = core.flyby._refine(400.0, (400.0, (q_hill_from_body(400.0, n, q), w, None)))
    assert refined.name == 'target_refined'
    offset = np.linalg.norm(refined.values['x_ft_hill_m']) - np.linalg.norm(refined.values['x_g_hill_m'])
    assert offset == pytest.approx(1.3, abs=1e-9) and refined.values['shift_m'] < 1e-6


def test_after_the_capture_the_commands_key_on_the_locks_stamp_whatever_came_first():
    """After the capture: nothing for the estimates before the simulator's grasp_damped stamp, the damping law's command
    for each one from it on, one control period later; the same commands whether the event came before or after the
    estimates (the topics race in the graph), and none after the arm lets go."""

    sc = load_scenario(SCENARIOS / 'paper_flyby_tug.yaml')
    q, omega, r = np.array((0.0, 0.0, 0.0, 1.0)), np.array((0.01, -0.02, 0.03)), np.array((0.5, 3.07, 0.0))
    stamps = [round(820.0 + 0.1 * k, 6) for k in range(6)]
    locked = Event(820.2, 'OK', 'grasp_damped', 'the arm locks', {}, 'flyby_sim')

    def commands(event_first):
        core = GuidanceCore(GuidanceParams.from_scenario(sc))
        core.on_phase(c.PHASE_CAPTURE)
        out = core.on_event(locked) if event_first else []
        for t in stamps:
            out += core.on_chaser_estimate(t, r, np.zeros(3), q, omega)
        out += [] if event_first else core.on_event(locked)
        return [o for o in out if isinstance(o, AttitudeCommandStamped)]

    first, late = commands(True), commands(False)
    assert [cmd.t for cmd in first] == pytest.approx([t + 0.1 for t in stamps[2:]])
    for a, b in zip(first, late, strict=True):
        np.testing.assert_array_equal(a.thruster_torque_body_n_m, b.thruster_torque_body_n_m)
        np.testing.assert_array_equal(a.wheel_torque_n_m, b.wheel_torque_n_m)
    assert np.all(first[0].thruster_torque_body_n_m * omega < 0.0)  # against the rate
    core = GuidanceCore(GuidanceParams.from_scenario(sc))
    core.on_phase(c.PHASE_CAPTURE)
    core.on_event(Event(820.0, 'WARN', 'grasp_released', 'the arm lets go', {}, 'flyby_sim'))
    assert core.on_chaser_estimate(820.1, r, np.zeros(3), q, omega) == []


def test_a_re_aim_takes_only_a_converged_estimate_with_a_spin_axis():
    """fd_s8 run 59: 20 target-attitude outliers in a row restarted the target filter (omega zero, the initial
    covariance); the re-aim raised on it (no spin axis), guidance and the supervisor died and the mission idled to its
    time limit. Such an estimate, or any the estimator would not call converged, keeps the aim and says so; a
    converged one re-aims."""
    core, n, q, w = _aimed_at_paper_flyby(1.0, 0.01)
    aimed = np.array(core.flyby.guidance.target.x_ft, dtype=float)
    q_hb = q_hill_from_body(400.0, n, q)
    small = (np.eye(3) * np.radians(0.1) ** 2, np.eye(3) * np.radians(0.005) ** 2)  # 3-sigma 0.3 deg, 0.015 deg/s
    large = (np.eye(3) * np.radians(0.1) ** 2, np.eye(3) * np.radians(0.05) ** 2)  # 3-sigma 0.15 deg/s > 0.05
    for omega, blocks, why in ((np.zeros(3), small, 'has no spin axis'), ([np.nan] * 3, None, 'has no spin axis'),
                               (w, large, 'not converged')):
        (kept,) = core.flyby._refine(400.0, (400.0, (q_hb, np.asarray(omega), blocks)))
        assert kept.name == 'target_refined' and kept.level == 'WARN' and why in kept.message
        assert event_payloads.decode(kept).t_grasp_s is None  # the supervisor keeps its grasp time
        assert core.flyby.guidance.target.x_ft == pytest.approx(aimed, abs=0.0)
    (refined,) = core.flyby._refine(400.0, (400.0, (q_hb, w, small)))
    assert refined.level == 'OK' and refined.values['shift_m'] > 0.005
    assert core.flyby.guidance.target.x_ft == pytest.approx(refined.values['x_ft_hill_m'], abs=1e-9)


def test_in_transport_an_estimate_on_the_com_grid_waits_for_the_refined_com_whatever_came_first():
    """In TRANSPORT the estimator gives the combined CoM at every stamp of its grid after the final estimate
    (``transport_navigation.on_com_grid``), before the chaser estimate of that stamp, but the topics race in the graph:
    guidance keeps the estimate of a grid stamp until the CoM of that stamp has come, and flies the body of that CoM
    from then on; the same commands whichever came first."""

    sc = load_scenario(SCENARIOS / 'paper_flyby_transport.yaml')
    q, omega, r = np.array((0.0, 0.0, 0.0, 1.0)), np.array((0.001, -0.002, 0.003)), np.array((0.5, 3.07, 0.0))
    t_e = 1026.3
    grid = COM_PERIOD_S * np.ceil(t_e / COM_PERIOD_S)
    stamps = [round(grid - 0.2 + 0.1 * k, 6) for k in range(5)]
    estimated = Event(t_e, 'OK', 'mass_properties_estimated', 'final', {
        'mass_kg': 1480.0, 'com_body_m': [3.12, 0.0, 0.0], 'principal_moments_kg_m2': [1000.0, 1200.0, 2000.0],
        'principal_axes_q': [0.0, 0.0, 0.0, 1.0], 'mass_sigma_kg': 1.0, 'com_sigma_m': [0.01, 0.01, 0.01],
        'principal_moments_sigma_kg_m2': [10.0, 10.0, 10.0]}, 'flyby_estimator')
    refined = Event(grid, 'OK', 'transport_com_estimate', 'refined', {
        'com_body_m': [2.9, 0.004, 0.0], 'com_sigma_m': [0.001, 0.001, 0.001], 'coast_s': 300.0}, 'flyby_estimator')

    def commands(event_first):
        core = GuidanceCore(GuidanceParams.from_scenario(sc))
        core.on_phase(c.PHASE_CAPTURE)
        core.on_event(Event(820.0, 'OK', 'grasp_damped', 'the arm locks', {}, 'flyby_sim'))
        core.capture.post.t_excitation = 990.0
        core.on_event(estimated)
        out, waited = core.on_event(refined) if event_first else [], None
        for t in stamps:
            out += core.on_chaser_estimate(t, r, np.zeros(3), q, omega)
            if t == grid and not event_first:
                waited = [o for o in out if isinstance(o, AttitudeCommandStamped)][-1].t
        out += [] if event_first else core.on_event(refined)
        np.testing.assert_array_equal(core.capture.transport.body.com_body_m, [2.9, 0.004, 0.0])
        return [o for o in out if isinstance(o, AttitudeCommandStamped)], waited

    (first, _), (late, waited) = commands(True), commands(False)
    assert waited == pytest.approx(grid)  # the last command before the grid stamp's estimate: the one of grid - 0.1
    assert [cmd.t for cmd in first] == pytest.approx([t + 0.1 for t in stamps])
    for a, b in zip(first, late, strict=True):
        assert a.t == b.t
        np.testing.assert_array_equal(a.thruster_torque_body_n_m, b.thruster_torque_body_n_m)
        np.testing.assert_array_equal(a.force_body_n, b.force_body_n)


def _reallocated(wheels, t=100.2):
    return Event(t, 'WARN', events.WHEELS_REALLOCATED, f'wheels {list(wheels)} out',
                 event_payloads.encode(event_payloads.WheelsReallocated(tuple(wheels))), 'flyby_supervisor')


def _attitude_commands(sc, arrivals, stamps):
    """The attitude commands of paper_flyby_6dof's guidance on the estimates at ``stamps`` (50 m out on V-bar,
    outside the sphere, body +x 3 deg off the line of sight), with each event of ``arrivals`` (estimate index ->
    events) delivered just before that estimate; and what guidance answered the events."""
    r, q = np.array((50.0, 0.0, 0.0)), quat_from_axis_angle((0.0, 0.0, 1.0), np.pi + 0.05)
    core = GuidanceCore(GuidanceParams.from_scenario(sc))
    core.on_phase(c.PHASE_ESTIMATION)
    out, answers = [], []
    for k, t in enumerate(stamps):
        for event in arrivals.get(k, ()):
            answers += core.on_event(event)
        out += core.on_chaser_estimate(t, r, np.zeros(3), q, np.zeros(3))
    return [o for o in out if isinstance(o, AttitudeCommandStamped)], answers, core


def test_a_wheel_reallocated_is_commanded_nothing_after_the_events_stamp_whenever_it_came_before_that():
    """The supervisor's wheels_reallocated (wheel 2, stamped 100.2 s, its detection's stamp): the estimates up to its
    stamp command wheel 2 as before, from the next on wheel 2 gets nothing and its axis's torque goes to the
    thrusters; the same commands whether the event came first, just before its stamp's estimate, or just after it
    (as headless, where the estimator publishes that estimate before its detection). Later still it applies from its
    arrival, counted late (modes.chaser's module doc)."""
    sc = load_scenario(SCENARIOS / 'paper_flyby_6dof.yaml')
    stamps = [round(100.0 + 0.1 * k, 6) for k in range(10)]
    runs = {at: _attitude_commands(sc, {at: [_reallocated((2,))]}, stamps) for at in (0, 2, 3, 5)}
    first = runs[0][0]
    assert len(first) == len(stamps)
    for at in (2, 3):
        assert runs[at][1] == [] and runs[at][2].chaser.wheels_late == 0
        for a, b in zip(first, runs[at][0], strict=True):
            np.testing.assert_array_equal(a.wheel_torque_n_m, b.wheel_torque_n_m)
            np.testing.assert_array_equal(a.thruster_torque_body_n_m, b.thruster_torque_body_n_m)
    assert all(cmd.wheel_torque_n_m[2] != 0.0 for cmd in first[:3])
    assert all(cmd.wheel_torque_n_m[2] == 0.0 for cmd in first[3:])
    assert any(cmd.thruster_torque_body_n_m[2] != 0.0 for cmd in first[3:])
    late, _, core = runs[5]
    assert core.chaser.wheels_late == 1
    assert late[4].wheel_torque_n_m[2] != 0.0 and all(cmd.wheel_torque_n_m[2] == 0.0 for cmd in late[5:])


@pytest.mark.parametrize('second, reason', [
    ((0,), 'wheels [0] cannot be taken out: the wheels left [0, 1] already span fewer than three axes'),
    ((3,), 'wheel index 3 is not one of the 3 wheels (0 to 2)'),
])
def test_a_reallocation_the_law_cannot_take_is_an_error_event_and_takes_nothing_out(second, reason):
    """After wheel 2 (paper_flyby_6dof's three orthogonal wheels), a second wheel or an index that is no wheel:
    guidance answers an ERROR command_rejected naming why (the supervisor aborts on a watched node's ERROR), no
    exception, and only wheel 2 is out."""
    sc = load_scenario(SCENARIOS / 'paper_flyby_6dof.yaml')
    stamps = [round(100.0 + 0.1 * k, 6) for k in range(6)]
    cmds, answers, core = _attitude_commands(sc, {0: [_reallocated((2,))], 4: [_reallocated(second, 100.3)]},
                                             stamps)
    (refused,) = answers
    assert (refused.level, refused.name, refused.t) == ('ERROR', events.COMMAND_REJECTED, 100.3)
    assert refused.message == f'wheels_reallocated refused: {reason}'
    assert core.chaser.attitude.wheels_out == {2} and core.chaser.wheels_out_pending == []
    assert all(cmd.wheel_torque_n_m[0] != 0.0 for cmd in cmds) and all(cmd.wheel_torque_n_m[2] == 0.0
                                                                        for cmd in cmds[3:])
