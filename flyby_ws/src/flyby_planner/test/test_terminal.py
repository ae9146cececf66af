"""transport.terminal: the goal's rest point against an independent integration of exact two-body gravity, the
terminal ball's slabs, the program's predicted end against an independent propagation of its firings, its firings'
bounds, the firing periods, and the direction limit that leaves every horizon's end beyond the margins
(docs/transport.md)."""

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.optimize import milp
from scipy.spatial.transform import Rotation

from flyby_planner.transport import terminal
from flyby_sim.dynamics.actuators import default_thruster_layout
from flyby_sim.dynamics.combined_body import combined_mass_properties
from flyby_sim.dynamics.orbital import mean_motion_rad_s, nonlinear_relative_accel, q_eci_from_body
from flyby_sim.dynamics.rotation import quat_from_rotation_vector

RADIUS_M = 7.0e6  # seed 004 §3.2's orbit
N = mean_motion_rad_s(RADIUS_M)
BIT_N_S = 0.01
MOMENTUM_BOUND_N_S = 0.01  # seed 004 §3.2's third condition in scenarios/matsunaga_orbit_advance.yaml
IMPULSE_ERROR = 0.09  # 3 sigma of the least command error guidance assumes (transport_navigation.command_error)
WHEEL_ROOM_N_M_S = 0.9  # 1 - WHEEL_ROOM of the TugRobot scenario's wheels (1 N m s)


def _tugrobot():
    """Seed 004 §3.1's combined body (TugRobot 30 kg diag(2, 3, 3), target 20 kg diag(2, 1.5, 1.5) at (0.5, 0, 0) m)
    and its scenario's thrusters (faces 0.2 m, pairs 0.15 m) less the -x pair, whose exhaust hits the target:
    (mass, inertia, directions, couples about the combined CoM)."""
    props = combined_mass_properties(30.0, np.diag([2.0, 3.0, 3.0]), 20.0, (0.5, 0.0, 0.0), np.diag([2.0, 1.5, 1.5]))
    layout = default_thruster_layout(face_m=0.2, lever_arm_m=0.15, min_impulse_bit_n_s=BIT_N_S)
    keep = layout.force_directions_body[:, 0] > -0.5
    directions = layout.force_directions_body[keep]
    couples = np.cross(layout.positions_body_m[keep] - props.com_body_m, directions)
    return props.mass_kg, props.inertia_body_kg_m2, directions, couples


def _problem(x0, q_hill_from_body=(0.0, 0.0, 0.0, 1.0), t0=1500.0, h0=(0.0, 0.0, 0.0), wheels=(0.4, WHEEL_ROOM_N_M_S)):
    """The program of the TugRobot's body at t0 with the margins guidance gives it on
    matsunaga_orbit_advance's bounds (2.5 m, half the momentum bound, 0.4 N m s of wheel momentum at the end, its
    wheels' room: ``wheels``)."""
    mass, inertia, directions, couples = _tugrobot()
    q_eci = q_eci_from_body(t0, N, np.asarray(q_hill_from_body, dtype=float))
    return terminal.TerminalProblem(
        mass, directions, couples, np.full(len(directions), 10.0), BIT_N_S, N, t0, np.asarray(x0, dtype=float),
        q_eci, np.asarray(h0, dtype=float), 2.5, 0.5 * MOMENTUM_BOUND_N_S * terminal.BALL_SLAB_FACTOR, 60.0, *wheels,
        terminal.couple_limit(inertia, 0.1), IMPULSE_ERROR)


# States of the combined CoM off the rest point [m, m/s] that the program fires for, in and out of the push cone.
FIRING_STATES = (
    ((0.0, 0.0, 0.0, -1e-3, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
    ((1.0, 0.5, -0.3, -5e-4, -3e-4, 5e-4), (0.0, 0.0, 0.0, 1.0)),
    ((0.0, 0.0, 0.0, 0.0, 2e-3, -1e-3), tuple(quat_from_rotation_vector((0.1, -0.2, 0.3)))),
    ((0.5, 0.2, -0.1, -3e-4, 1e-4, -1e-4), (0.0, 0.0, 0.0, 1.0)),  # a longer horizon: the cone turns in hill
    ((-2.0, 1.0, 1.5, 0.0, 0.0, 0.0), tuple(quat_from_rotation_vector((0.0, 0.0, 0.5)))),
)


def test_rest_point_is_an_equilibrium_of_seed000_eq1():
    """A body at rest in hill at the rest point of a goal 2 km ahead on V-bar stays within a millimetre over 1000 s
    of exact two-body gravity (seed 000 eq 1, integrated independently), where one at rest at the Cartesian goal
    drifts by decimetres (it is 0.29 m above the orbit's circle)."""
    goal = np.array([2000.0, 0.0, 0.0])
    rest = terminal.rest_point(goal, RADIUS_M)
    assert np.linalg.norm(rest - goal) == pytest.approx(RADIUS_M * (1.0 - math.cos(2000.0 / RADIUS_M)), rel=1e-3)

    def rates(_, y):
        return np.concatenate((y[3:], nonlinear_relative_accel(y[:3], y[3:], N, RADIUS_M)))

    def drift(r0):
        sol = solve_ivp(rates, (0.0, 1000.0), np.concatenate((r0, np.zeros(3))), method='DOP853', rtol=1e-12,
                        atol=1e-12, dense_output=True)
        return max(float(np.linalg.norm(sol.sol(t)[:3] - r0)) for t in np.linspace(0.0, 1000.0, 51))
    assert drift(rest) < 1e-3
    assert drift(goal) > 0.2
    np.testing.assert_allclose(terminal.rest_point(rest, RADIUS_M), rest, atol=1e-9)  # on the circle: itself


def _ball_vertices():
    """The vertices of the polytope |a_i . x| <= BALL_SLAB_FACTOR (every triple of the directions' planes that meet
    in a point within all the slabs)."""
    a, rho = terminal.BALL_DIRECTIONS, terminal.BALL_SLAB_FACTOR
    vertices = []
    for rows in itertools.combinations(range(len(a)), 3):
        m = a[list(rows)]
        if abs(np.linalg.det(m)) < 1e-9:
            continue
        for signs in itertools.product((-1.0, 1.0), repeat=3):
            x = np.linalg.solve(m, rho * np.array(signs))
            if np.all(np.abs(a @ x) <= rho * (1.0 + 1e-12)):
                vertices.append(x)
    return np.array(vertices)


def test_a_vector_within_every_slab_is_within_the_unit_ball():
    """The slabs' polytope is convex, so its farthest point from the centre is a vertex: every vertex within the unit
    ball (it is within 0.92), and the directions unit."""
    np.testing.assert_allclose(np.linalg.norm(terminal.BALL_DIRECTIONS, axis=1), 1.0, atol=1e-15)
    vertices = _ball_vertices()
    assert len(vertices) >= 8 and float(np.max(np.linalg.norm(vertices, axis=1))) <= 1.0


@settings(max_examples=300)
@given(st.tuples(*[st.floats(-1.0, 1.0, allow_nan=False)] * 3).filter(lambda u: np.linalg.norm(u) > 1e-3))
def test_along_any_direction_the_slabs_end_within_the_unit_ball(u):
    """Along a direction u the slabs end at BALL_SLAB_FACTOR / max_i |a_i . u|: within 1."""
    u = np.asarray(u) / np.linalg.norm(u)
    extent = terminal.BALL_SLAB_FACTOR / float(np.max(np.abs(terminal.BALL_DIRECTIONS @ u)))
    assert extent <= 1.0


def _hill_from_eci(t):
    """C_hill_from_eci at t, from the target's circular orbit (at R (1, 0, 0) at t = 0, moving toward +y): hill x
    along its velocity, z toward Earth's centre, y = z x x."""
    position = np.array((math.cos(N * t), math.sin(N * t), 0.0))
    velocity = np.array((-math.sin(N * t), math.cos(N * t), 0.0))
    z = -position
    return np.vstack((velocity, np.cross(z, velocity), z))


def _cw_flow(t):
    """exp(A t) of seed 000 eq 2 (CW), A written out: the state [r; v] of hill."""
    a = np.zeros((6, 6))
    a[:3, 3:] = np.eye(3)
    a[3, 5], a[5, 3] = 2.0 * N, -2.0 * N
    a[4, 1], a[5, 2] = -N * N, 3.0 * N * N
    return expm(a * t)


def _propagated(problem, solution):
    """The end state of the solution's impulses applied at their slots, propagated slot by slot (independent of the
    module: CW by the matrix exponential, the hill directions from the quaternion by scipy)."""
    c_eci_from_body = Rotation.from_quat(problem.q_eci_from_body).as_matrix()
    x, t = np.array(problem.x0, dtype=float), problem.t0
    for t_k, u_k in zip(solution.slot_times_s, solution.impulses_n_s, strict=True):
        x = _cw_flow(t_k - t) @ x
        x[3:] += _hill_from_eci(t_k) @ c_eci_from_body @ (problem.directions_body.T @ u_k) / problem.mass_kg
        t = t_k
    return _cw_flow(problem.t0 + solution.horizon_s - t) @ x


@pytest.mark.parametrize('x0, q_hill', FIRING_STATES)
def test_the_predicted_end_is_the_firings_propagated_and_within_the_margins(x0, q_hill):
    """solve's predicted end equals the impulses propagated independently; it and the momentum hold_s later lie within
    the margins' slabs, and with the firings' error within a stage's; the wheels' momentum within theirs and each
    slot's couple within the limit; the slots now and then on a grid fixed in time."""
    problem = _problem(x0, q_hill)
    solution = terminal.solve(problem, terminal.HORIZONS_S)
    assert solution is not None and np.any(solution.impulses_n_s) and solution.excess == (0.0, 0.0)
    spacing = solution.horizon_s / terminal.SLOTS
    assert solution.slot_times_s[0] == problem.t0
    later = solution.slot_times_s[1:]
    np.testing.assert_allclose(later / spacing, np.round(later / spacing), atol=1e-9)
    assert np.all(later > problem.t0) and np.all(later < problem.t0 + solution.horizon_s)
    end = _propagated(problem, solution)
    np.testing.assert_allclose(solution.predicted, end, rtol=0.0, atol=1e-9)
    a, tol = terminal.BALL_DIRECTIONS, 1e-7
    assert np.all(np.abs(a @ end[:3]) <= problem.rho_position_m + tol)
    held = _cw_flow(problem.hold_s) @ end
    # With the error: the margin, or a share of the momentum the state would end with unfired where that is more.
    free = _cw_flow(solution.horizon_s) @ np.asarray(x0, dtype=float)
    unfired_n_s = problem.mass_kg * max(np.linalg.norm(free[3:]), np.linalg.norm((_cw_flow(problem.hold_s) @ free)[3:]))
    stage = max(problem.rho_momentum_n_s, terminal.STAGE_FRACTION * unfired_n_s * terminal.BALL_SLAB_FACTOR)
    for v in (end[3:], held[3:]):
        assert np.all(np.abs(a @ (problem.mass_kg * v)) <= problem.rho_momentum_n_s + tol)
        assert np.all(np.abs(a @ (problem.mass_kg * v)) <= stage + tol)
    couples = solution.impulses_n_s @ problem.couples_body_m  # (K, 3)
    h_end = problem.h_wheels_body_n_m_s + couples.sum(axis=0)
    np.testing.assert_allclose(solution.h_wheels_body_n_m_s, h_end, atol=1e-12)
    assert np.all(np.abs(h_end) <= problem.rho_wheels_n_m_s + tol)
    assert np.all(np.abs(couples) <= problem.couple_max_n_m_s + tol)


def test_kept_excess_of_a_plan_is_the_programs_excess_and_grows_off_it():
    """kept_excess of a solution's own firings from its own state is the program's excess beyond the margins (0
    within them, and a plan beyond them its own); from a state 2 mm/s off, its firings end beyond; the slots already
    past left out, the rest from a later state on the plan's trajectory as the whole from the first."""
    for x0 in ((0.3, -0.2, 0.1, -4e-4, 1e-4, 0.0), (0.0, 0.0, 0.0, 1e-3, 0.0, 0.0)):
        problem = _problem(x0)
        solution = terminal.solve(problem, terminal.HORIZONS_S)
        t_end = problem.t0 + solution.horizon_s
        kept = terminal.kept_excess(problem, solution.slot_times_s, solution.impulses_n_s, t_end)
        assert kept == pytest.approx(solution.excess[1], abs=1e-6)
    problem = _problem(FIRING_STATES[3][0])  # a longer horizon, its firings in more than one slot
    solution = terminal.solve(problem, terminal.HORIZONS_S)
    assert np.count_nonzero(solution.impulses_n_s.sum(axis=1)) > 1
    t_end = problem.t0 + solution.horizon_s
    off = problem._replace(x0=problem.x0 + np.array([0.0, 0.0, 0.0, 0.0, 2e-3, 0.0]))
    assert terminal.kept_excess(off, solution.slot_times_s, solution.impulses_n_s, t_end) > 1.0
    # Later, on the plan's trajectory (the first slot fired), the rest ends where the whole did.
    later = 0.5 * (solution.slot_times_s[0] + solution.slot_times_s[1])
    x = _cw_flow(solution.slot_times_s[0] - problem.t0) @ problem.x0
    x[3:] += _hill_from_eci(solution.slot_times_s[0]) @ Rotation.from_quat(problem.q_eci_from_body).as_matrix() @ (
        problem.directions_body.T @ solution.impulses_n_s[0]) / problem.mass_kg
    x = _cw_flow(later - solution.slot_times_s[0]) @ x
    on_plan = problem._replace(t0=later, x0=x)
    rest = terminal.kept_excess(on_plan, solution.slot_times_s[1:], solution.impulses_n_s[1:], t_end)
    assert rest == pytest.approx(solution.excess[1], abs=1e-6)


@pytest.mark.parametrize('x0, q_hill', FIRING_STATES)
def test_every_firing_is_at_least_the_bit_and_within_its_slots_thrust(x0, q_hill):
    problem = _problem(x0, q_hill)
    solution = terminal.solve(problem, terminal.HORIZONS_S)
    fired = solution.impulses_n_s[solution.impulses_n_s > 0.0]
    assert fired.size and np.all(solution.impulses_n_s >= 0.0)
    assert float(fired.min()) >= terminal.BIT_MARGIN * BIT_N_S * (1.0 - 1e-6)
    slot_s = min(terminal.MAX_PULSE_S, 0.5 * solution.horizon_s / terminal.SLOTS / len(problem.max_thrust_n))
    assert np.all(solution.impulses_n_s <= problem.max_thrust_n * slot_s * (1.0 + 1e-6))


def test_the_program_is_bounded_by_its_nodes_not_by_wall_time(monkeypatch):
    """Every mixed-integer solve hands HiGHS a node limit and no time limit: a wall-clock limit makes what a loaded
    machine returns differ from an idle one's (a feasible point at the limit, or none), and a replayed run fly other
    firings. Presolve is off: its transformed solutions HiGHS repairs with a message on standard output."""
    seen = []

    def recording_milp(*args, **kwargs):
        seen.append((kwargs.get('integrality') is not None, dict(kwargs.get('options') or {})))
        return milp(*args, **kwargs)

    monkeypatch.setattr(terminal, 'milp', recording_milp)
    terminal.solve(_problem((0.0, 0.0, 0.0, 1e-3, 0.0, 0.0)), terminal.HORIZONS_S)  # every horizon tried
    assert any(integer for integer, _ in seen)
    assert all(o == {'node_limit': terminal.MILP_NODE_LIMIT, 'presolve': False} for integer, o in seen if integer)
    assert all('time_limit' not in o for _, o in seen)


def test_a_state_at_rest_at_the_rest_point_fires_nothing():
    """At the rest point at rest, and a few decimetres off it and 0.1 mm/s moving (within the margins over the
    shortest horizon and the hold), the program fires nothing over the shortest horizon."""
    for x0 in (np.zeros(6), np.array([0.3, -0.2, 0.1, 1e-5, 0.0, -1e-5])):
        solution = terminal.solve(_problem(x0), terminal.HORIZONS_S)
        assert solution.horizon_s == terminal.HORIZONS_S[0] and not np.any(solution.impulses_n_s)
        np.testing.assert_allclose(solution.predicted, _cw_flow(solution.horizon_s) @ x0, atol=1e-12)


@pytest.mark.parametrize('x0', ((0.0, 0.0, 0.2, 0.0, 0.0, 0.0), (0.0, 0.3, 0.0, 0.0, 0.0, 0.0)))
def test_a_body_off_its_rest_point_is_brought_to_it_where_the_judgements_window_asks(x0):
    """At rest 0.2 m radially or 0.3 m cross-track off the rest point, the momentum stays within its margin over the
    shortest horizon and the hold (CW's drift, 3 n^2 m and n^2 m per metre, is a few millinewton seconds a minute on
    the TugRobot's 50 kg), but not over a judgement's window of 1000 s: with the window the program transfers the
    body to within a fifth of the offset across V-bar and keeps the momentum within its margin over the window (CW
    from the predicted end, integrated independently: within the margins' ball at the program's WINDOW_TIMES, within
    twice it between them), without it fires for the hold alone."""
    window_s = 1000.0

    def window_momentum_n_s(solution, mass, count):
        return max(mass * float(np.linalg.norm((_cw_flow(t) @ solution.predicted)[3:]))
                   for t in np.linspace(0.0, window_s, count))

    x0 = np.asarray(x0)
    unwindowed = terminal.solve(_problem(x0), terminal.HORIZONS_S)
    problem = _problem(x0)._replace(window_s=window_s)
    solution = terminal.solve(problem, terminal.HORIZONS_S)
    assert unwindowed.horizon_s == terminal.HORIZONS_S[0] and solution.horizon_s > terminal.HORIZONS_S[0]
    assert solution.excess == (0.0, 0.0) and solution.window_excess == pytest.approx(0.0, abs=1e-6)
    assert window_momentum_n_s(unwindowed, problem.mass_kg, 41) > 3.0 * problem.rho_momentum_n_s
    rho_ball = problem.rho_momentum_n_s / terminal.BALL_SLAB_FACTOR
    assert window_momentum_n_s(solution, problem.mass_kg, terminal.WINDOW_TIMES + 1) <= rho_ball * (1.0 + 1e-6)
    assert window_momentum_n_s(solution, problem.mass_kg, 41) <= 2.0 * rho_ball
    # Cross-track and radial, whose offsets drift (along V-bar is a rest point too).
    assert float(np.linalg.norm(solution.predicted[1:3])) < 0.2 * float(np.linalg.norm(x0[1:3]))
    np.testing.assert_allclose(solution.predicted, _propagated(problem, solution), atol=1e-9)


def test_a_force_outside_the_thrusters_cone_reaches_no_margin_over_the_shortest_horizon():
    """The body's +x along hill x and no thruster pushing along -x: 1 mm/s along +x needs a force against the push
    axis, which the side thrusters give over 60 s only through CW's coupling: the program's best end lies beyond the
    margins (its excess, with and without the error) and it fires nothing; the same velocity the other way is taken
    out at once by the push axis's pair."""
    beyond = terminal.solve(_problem((0.0, 0.0, 0.0, 1e-3, 0.0, 0.0)), (terminal.HORIZONS_S[0],))
    assert min(beyond.excess) > 1.0 and not np.any(beyond.impulses_n_s)
    solution = terminal.solve(_problem((0.0, 0.0, 0.0, -1e-3, 0.0, 0.0)), (terminal.HORIZONS_S[0],))
    assert solution.excess == (0.0, 0.0)
    assert float(solution.impulses_n_s.sum()) == pytest.approx(_tugrobot()[0] * 1e-3)


def test_a_plan_whose_execution_error_exceeds_a_stage_is_reported_beyond_it():
    """1 mm/s along the push axis's blocked direction (0.05 N s): without execution errors the side thrusters reach
    the margins over a longer horizon through CW's coupling at several times the momentum in impulse; with the
    thrusters' 3-sigma error of 9 % on every impulse no plan ends within a stage of it, and the program says by how
    much (its first excess), its end still nearer than the state's unfired. A far state is brought within
    STAGE_FRACTION of its momentum, error included."""
    global IMPULSE_ERROR
    x0 = (0.0, 0.0, 0.0, 1e-3, 0.0, 0.0)
    saved, IMPULSE_ERROR = IMPULSE_ERROR, 0.0
    try:
        costly = terminal.solve(_problem(x0), terminal.HORIZONS_S)
    finally:
        IMPULSE_ERROR = saved
    assert costly.excess == (0.0, 0.0) and float(costly.impulses_n_s.sum()) > 5.0 * 0.05
    beyond = terminal.solve(_problem(x0), terminal.HORIZONS_S)
    assert beyond.excess[0] > 0.0
    unfired = _cw_flow(beyond.horizon_s) @ np.asarray(x0)
    assert np.linalg.norm(beyond.predicted[3:]) < np.linalg.norm(unfired[3:])
    far = _problem((0.0, 0.0, 0.0, -0.02, 0.0, 0.0))  # 1 N s along the push axis
    staged = terminal.solve(far, terminal.HORIZONS_S)
    assert staged.excess == (0.0, 0.0)
    p_end = far.mass_kg * np.linalg.norm(staged.predicted[3:])
    assert p_end + IMPULSE_ERROR * staged.impulses_n_s.sum() <= terminal.STAGE_FRACTION * 1.0 + 1e-9


def test_couple_limit_is_the_couple_the_wheels_stop_within_the_turn():
    """A body given the couple impulse h about its least principal axis turns h^2 / (2 I tau) while the wheels'
    torque tau stops it: TURN_RAD at couple_limit."""
    inertia = np.diag([4.0, 7.5, 7.5])
    h = terminal.couple_limit(inertia, 0.1)
    assert h * h / (2.0 * 4.0 * 0.1) == pytest.approx(terminal.TURN_RAD, rel=1e-12)


@settings(max_examples=200)
@given(impulses=st.lists(st.one_of(st.just(0.0), st.floats(BIT_N_S, 20.0)), min_size=1, max_size=10),
       thrust_n=st.floats(0.5, 20.0), period_s=st.sampled_from((0.05, 0.1, 0.2)))
def test_firing_periods_deliver_each_impulse_one_thruster_a_period_none_below_the_bit(impulses, thrust_n, period_s):
    max_thrust = np.full(len(impulses), thrust_n)
    thrusts = terminal.firing_periods(impulses, max_thrust, BIT_N_S, period_s)
    assert thrusts.shape[1] == len(impulses)
    np.testing.assert_allclose(thrusts.sum(axis=0) * period_s, impulses, rtol=1e-12, atol=1e-15)
    assert np.all(np.count_nonzero(thrusts, axis=1) == 1)  # one thruster a period, no idle period
    fired = thrusts[thrusts > 0.0]
    assert np.all(fired * period_s >= BIT_N_S * (1.0 - 1e-9)) and np.all(fired <= thrust_n * (1.0 + 1e-9))
    # As few periods as the thrust allows: each thruster's count the least at full thrust.
    counts = np.count_nonzero(thrusts, axis=0)
    np.testing.assert_array_equal(counts, [math.ceil(u / (thrust_n * period_s) - 1e-9) if u > 0.0 else 0
                                           for u in impulses])


def _c_hill_from_body(problem):
    """C_hill_from_body at the problem's t0, independent of the module: the quaternion by scipy, hill by
    ``_hill_from_eci``."""
    return _hill_from_eci(problem.t0) @ Rotation.from_quat(problem.q_eci_from_body).as_matrix()


# Attitudes held (hill from body at t0): the body's axes along hill's, and turned about the push axis (body +x), which
# keeps the push axis along hill x and turns the side thrusters' directions off hill's axes.
CORRECTION_ATTITUDES = ((0.0, 0.0, 0.0, 1.0), tuple(quat_from_rotation_vector((0.4, 0.0, 0.0))))
# Turned off the push axis: the direction limit's half-space no longer has a hill axis for its normal.
OFF_AXIS_ATTITUDE = tuple(quat_from_rotation_vector((0.1, -0.2, 0.3)))


@pytest.mark.parametrize('q_hill', (*CORRECTION_ATTITUDES, OFF_AXIS_ATTITUDE))
@pytest.mark.parametrize('dv_body_mps', ((2e-3, 1e-3, -5e-4), (4e-3, -2e-3, 0.0), (0.0, 0.0, -3e-3)))
def test_impulses_for_gives_a_delta_v_within_the_cone_exactly(q_hill, dv_body_mps):
    """A delta-v the allowed thrusters give at the attitude held (no component against the push axis, each thruster's
    share above the bit, the couple within its limit) is given to 1e-9, and the delta-v returned is D u / m of the
    impulses with D from the quaternion and the orbit's hill axes (scipy, ``_hill_from_eci``)."""
    problem = _problem(np.zeros(6), q_hill, t0=2300.0)
    c = _c_hill_from_body(problem)
    dv_hill = c @ np.asarray(dv_body_mps)
    impulses, given = terminal.impulses_for(dv_hill, problem)
    np.testing.assert_allclose(given, c @ (problem.directions_body.T @ impulses) / problem.mass_kg, rtol=0.0,
                               atol=1e-12 * np.linalg.norm(dv_hill))
    assert np.linalg.norm(given - dv_hill) <= 1e-9 * np.linalg.norm(dv_hill)
    assert np.all(impulses >= 0.0) and np.any(impulses)


def _assert_the_reachable_part(q_hill, dv_body_mps):
    """A delta-v with a component against the push axis: the delta-v given has none along the push axis (its component
    along the unreachable direction, -push, >= 0 where the thrusters give only >= 0 along +push) and misses by no
    more than the unreachable component: the rest is given as wanted."""
    problem = _problem(np.zeros(6), q_hill, t0=2300.0)
    c = _c_hill_from_body(problem)
    dv_hill = c @ np.asarray(dv_body_mps)
    unreachable_hill = -c[:, 0]  # the push axis is body +x; no thruster pushes along -x
    unreachable_mps = max(0.0, float(dv_hill @ unreachable_hill))
    assert unreachable_mps > 0.0
    _, given = terminal.impulses_for(dv_hill, problem)
    tol = 1e-9 * np.linalg.norm(dv_hill)
    assert float(given @ unreachable_hill) >= -tol
    assert np.linalg.norm(given - dv_hill) <= unreachable_mps + tol


@pytest.mark.parametrize('q_hill', CORRECTION_ATTITUDES)
@pytest.mark.parametrize('dv_body_mps', ((-2e-3, 1e-3, 5e-4), (-3e-3, -1e-3, 1e-3), (-1e-3, 0.0, 0.0)))
def test_impulses_for_a_delta_v_against_the_push_axis_gives_the_part_within_reach(q_hill, dv_body_mps):
    _assert_the_reachable_part(q_hill, dv_body_mps)


@pytest.mark.parametrize('q_hill', (OFF_AXIS_ATTITUDE, tuple(quat_from_rotation_vector((0.3, 0.4, -0.6)))))
def test_impulses_for_off_the_push_axis_gives_the_part_within_reach(q_hill):
    _assert_the_reachable_part(q_hill, (-2e-3, 1e-3, 5e-4))


# Wanted delta-vs [m/s, body] for the bounds: a side component below the bit, a total below it, one beyond the
# thrusters' MAX_PULSE_S, ones the couple limit cuts.
BOUND_CASES = ((2e-3, 1e-4, 0.0), (1e-4, 0.0, 0.0), (20.0, 0.0, 0.0), (5e-2, 2e-2, 1e-2), (1e-2, 5e-2, 0.0),
               (0.0, 0.0, 0.2), (-1e-2, 0.1, -0.1))


@pytest.mark.parametrize('q_hill', (*CORRECTION_ATTITUDES, OFF_AXIS_ATTITUDE))
@pytest.mark.parametrize('dv_body_mps', BOUND_CASES)
def test_impulses_for_fires_at_least_the_bit_within_max_pulse(q_hill, dv_body_mps):
    problem = _problem(np.zeros(6), q_hill, t0=2300.0)
    impulses, given = terminal.impulses_for(_c_hill_from_body(problem) @ np.asarray(dv_body_mps), problem)
    fired = impulses[impulses > 0.0]
    assert np.all(impulses >= 0.0)
    assert np.all(fired >= terminal.BIT_MARGIN * BIT_N_S)
    assert np.all(impulses <= problem.max_thrust_n * terminal.MAX_PULSE_S * (1.0 + 1e-12))
    if float(np.linalg.norm(dv_body_mps)) * problem.mass_kg < BIT_N_S:  # below a bit: nothing
        assert not np.any(impulses) and not np.any(given)
    if dv_body_mps[0] * problem.mass_kg > 2.0 * float(problem.max_thrust_n[0]) * terminal.MAX_PULSE_S:
        assert float(impulses.max()) == pytest.approx(float(problem.max_thrust_n[0]) * terminal.MAX_PULSE_S)


@pytest.mark.parametrize('q_hill', (*CORRECTION_ATTITUDES, OFF_AXIS_ATTITUDE))
def test_impulses_for_keeps_the_couple_within_its_limit(q_hill):
    """|C u|_inf <= couple_max for every case; along body +y the limit binds (the +y pair's couples are both -0.2 m
    about z, which only a force along x or -y would cancel: at most couple_max / 0.2 N s, 0.013 m/s on 50 kg) and
    0.05 m/s is not given."""
    problem = _problem(np.zeros(6), q_hill, t0=2300.0)
    c = _c_hill_from_body(problem)
    for dv_body in BOUND_CASES:
        impulses, _ = terminal.impulses_for(c @ np.asarray(dv_body), problem)
        assert np.all(np.abs(problem.couples_body_m.T @ impulses) <= problem.couple_max_n_m_s * (1.0 + 1e-9))
    dv_hill = c @ np.array([0.0, 0.05, 0.0])
    impulses, given = terminal.impulses_for(dv_hill, problem)
    assert float(np.max(np.abs(problem.couples_body_m.T @ impulses))) == pytest.approx(problem.couple_max_n_m_s,
                                                                                          rel=1e-6)
    assert np.linalg.norm(given - dv_hill) > 0.5 * np.linalg.norm(dv_hill)


def _wheels_after_slots(problem, solution):
    """(K, 3) the wheels' momentum after each slot of a plan [N m s]."""
    return problem.h_wheels_body_n_m_s + np.cumsum(solution.impulses_n_s @ problem.couples_body_m, axis=0)


SMALL_WHEELS = (0.02, 0.03)  # wheels of a twentieth of the TugRobot's: share at the end, room [N m s]


# States whose plan, with the wheels bounded at the end only, takes them beyond their room between its slots.
WHEEL_FILLING = (((0.07, -0.1, 0.43, 1.75e-3, -1.1e-4, -6.9e-4), (-0.022, -0.007, -0.005)),
                 ((0.76, -0.76, -1.23, 4.7e-4, -1.03e-3, 6.7e-4), (-0.003, -0.008, -0.023)),
                 ((0.25, -0.32, -0.12, 1.87e-3, -9.7e-4, -3.0e-4), (-0.019, 0.01, 0.004)))


@pytest.mark.parametrize('x0, h0', (*((x0, (0.0, 0.0, 0.025)) for x0, _ in FIRING_STATES), *WHEEL_FILLING))
def test_the_wheels_stay_within_their_room_after_every_slot(x0, h0):
    """Between the slots the wheels hold what each slot's couples gave them: within their room after every slot,
    not only within their share at the end (saturated, they would no longer hold the attitude the program fires at)."""
    problem = _problem(x0, h0=h0, wheels=SMALL_WHEELS)
    solution = terminal.solve(problem, terminal.HORIZONS_S)
    assert solution is not None
    room = np.maximum(SMALL_WHEELS[1], np.abs(problem.h_wheels_body_n_m_s))
    assert np.all(np.abs(_wheels_after_slots(problem, solution)) <= room + 1e-6)


@pytest.mark.parametrize('q_hill', CORRECTION_ATTITUDES)
def test_impulses_for_leaves_the_wheels_within_their_room(q_hill):
    """A correction along body +y gives couples about z (the +y pair's are both -0.2 m): with the wheels near their
    room about z on that side it is cut to what they take, and with them as far on the other side it is not."""
    dv_body = np.array([0.0, 2e-3, 0.0])
    full = None
    for h_z in (0.899, -0.899):
        problem = _problem(np.zeros(6), q_hill, t0=2300.0, h0=(0.0, 0.0, h_z))
        impulses, given = terminal.impulses_for(_c_hill_from_body(problem) @ dv_body, problem)
        h_after = problem.h_wheels_body_n_m_s + problem.couples_body_m.T @ impulses
        assert np.all(np.abs(h_after) <= np.maximum(WHEEL_ROOM_N_M_S, np.abs(problem.h_wheels_body_n_m_s)) + 1e-9)
        if full is None:
            full = float(np.linalg.norm(given))
    assert float(np.linalg.norm(given)) < 0.5 * full


def test_wheels_beyond_their_share_that_no_couple_brings_back_leave_a_plan_taking_them_no_further():
    """Thrusters whose couples all turn one way (each couple's sign made positive) cannot bring wheels holding 0.6
    N m s about x back within the 0.4 of their share: the program still plans (the end within its margins), and its
    plan takes the wheels no further on any axis."""
    x0, q_hill = FIRING_STATES[0]
    problem = _problem(x0, q_hill, h0=(0.6, 0.0, 0.0))
    problem = problem._replace(couples_body_m=np.abs(problem.couples_body_m))
    solution = terminal.solve(problem, terminal.HORIZONS_S)
    assert solution is not None and np.any(solution.impulses_n_s)
    assert max(solution.excess) <= terminal.EXCESS_TOLERANCE
    bound = np.maximum(problem.rho_wheels_n_m_s, np.abs(problem.h_wheels_body_n_m_s))
    assert np.all(np.abs(solution.h_wheels_body_n_m_s) <= bound + 1e-9)
