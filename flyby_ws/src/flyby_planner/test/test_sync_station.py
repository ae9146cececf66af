"""Stage 1 of the synchronized approach (flyby_planner.sync.station, seed 001 section 2 and eq 1): the station point,
the phase-space link, the arrival time of least delta-v against brute force, the re-solve closest to the previous
solution."""

import collections
import copy
import math
import types
from pathlib import Path

import numpy as np
import pytest

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import prediction_from_estimate
from flyby_msgs_py.schema import ScenarioError
from flyby_planner.flyby.grasp_search import capture_target_body
from flyby_planner.sync.approach import SyncParams, resolve_due, sync_station_geometry
from flyby_planner.sync.station import (
    PhaseSpaceLink,
    keepout_radius,
    reselect_arrival,
    select_arrival,
    station_geometry,
)
from flyby_sim.dynamics.geometry import outward_normal
from flyby_sim.dynamics.orbital import nonlinear_relative_accel
from flyby_sim.dynamics.rotation import quat_from_axis_angle, quat_multiply
from flyby_sim.scenario import load_scenario, load_yaml_mapping, scenario_from_dict

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
SCENARIO = load_scenario(SCENARIOS / 'seweryn_tumbling.yaml')
N, RADIUS = SCENARIO.mean_motion_rad_s, SCENARIO.orbit_radius_m
SYNC = SyncParams.from_scenario(SCENARIO)
GEOMETRY = sync_station_geometry(SYNC)
KEEPOUT = keepout_radius([(b.center_m, b.size_m) for b in SCENARIO.target.geometry], SCENARIO.chaser.envelope_radius_m,
                         0.1)
R0, V0, T0 = np.array((-1000.0, 0.0, 0.0)), np.zeros(3), 65.0
WINDOW = (260.0, 370.0)


def _track(q_hill_from_body0, omega_body0):
    prediction = prediction_from_estimate(ErrorStateDynamics(SCENARIO.target_inertia), N, 0.0, q_hill_from_body0,
                                          omega_body0, 400.0)

    def track(times):
        p = prediction.track(GEOMETRY.x_station_body, times)
        return p.r_hill, p.v_hill
    return track


TRUTH_TRACK = _track(SCENARIO.q_hill_from_body0, SCENARIO.omega_body0_rad_s)


def test_station_geometry_is_on_the_ports_outward_line():
    geo = station_geometry((1.0, 0.0, 0.0), (1.0, 0.0, 0.0), 5.0, 1.0)
    assert geo.x_station_body == pytest.approx((5.0, 0.0, 0.0)) and geo.x_final_body == pytest.approx((2.0, 0, 0))
    off_axis = station_geometry((1.0, 2.0, 2.0), (1.0, 0.0, 0.0), 6.0, 1.0)  # a port on the +x face, off its middle
    assert off_axis.x_final_body == pytest.approx((2.0, 2.0, 2.0))
    assert off_axis.station_range_m == pytest.approx(6.0)
    assert off_axis.x_station_body[1:] == pytest.approx((2.0, 2.0)) and off_axis.station_offset_m > 1.0
    with pytest.raises(ValueError, match='station_range_m 1.5 m must exceed'):
        station_geometry((1.0, 0.0, 0.0), (1.0, 0.0, 0.0), 1.5, 1.0)
    with pytest.raises(ValueError, match='a unit vector'):
        station_geometry((1.0, 0.0, 0.0), (2.0, 0.0, 0.0), 5.0, 1.0)


def test_outward_normal_of_the_surface_at_the_port():
    """A face's normal; the bisector on an edge; None off the surface or on a face buried in another box."""
    bus = ((0.0, 0.0, 0.0), (2.0, 4.0, 4.0))
    panel = ((0.0, 3.0, 0.0), (0.1, 2.0, 1.0))  # against the +y face
    assert outward_normal((1.0, -0.4, 1.6), [bus]) == pytest.approx((1.0, 0.0, 0.0))
    assert outward_normal((-0.3, 0.2, -2.0), [bus, panel]) == pytest.approx((0.0, 0.0, -1.0))
    assert outward_normal((1.0, 2.0, 0.0), [bus]) == pytest.approx(np.array((1.0, 1.0, 0.0)) / math.sqrt(2.0))
    assert outward_normal((0.5, 0.0, 0.0), [bus]) is None and outward_normal((1.2, 0.0, 0.0), [bus]) is None
    assert outward_normal((0.0, 2.0, 0.0), [bus, panel]) is None  # under the panel's root
    assert outward_normal((0.8, 2.0, 1.5), [bus, panel]) == pytest.approx((0.0, 1.0, 0.0))  # beside it


def test_link_meets_both_phase_space_points_and_its_thrust_is_what_eq2_lacks():
    link = PhaseSpaceLink(10.0, (-100.0, 2.0, 3.0), (0.1, 0.0, -0.2), 110.0, (4.0, -1.0, 2.0), (0.5, 0.3, -0.4))
    r, v, ddr = link.states(np.array((10.0, 110.0)))
    assert r[0] == pytest.approx((-100.0, 2.0, 3.0)) and v[0] == pytest.approx((0.1, 0.0, -0.2))
    assert r[1] == pytest.approx((4.0, -1.0, 2.0)) and v[1] == pytest.approx((0.5, 0.3, -0.4))
    t = 37.3
    (r_t,), (v_t,), (a_t,) = link.states(np.array((t,)))
    h = 1e-3
    numeric = (link.states(np.array((t + h,)))[1][0] - link.states(np.array((t - h,)))[1][0]) / (2 * h)
    assert a_t == pytest.approx(numeric, abs=1e-9)
    thrust = link.thrust_acceleration(np.array((t,)), N, RADIUS)[0]
    assert thrust + nonlinear_relative_accel(r_t, v_t, N, RADIUS) == pytest.approx(a_t, abs=1e-15)
    # the delta-v integral against a dense midpoint sum
    grid = np.linspace(10.0, 110.0, 200001)
    mid = 0.5 * (grid[1:] + grid[:-1])
    dense = float(np.sum(np.linalg.norm(link.thrust_acceleration(mid, N, RADIUS), axis=1)) * (grid[1] - grid[0]))
    assert link.delta_v(N, RADIUS) == pytest.approx(dense, rel=1e-5)


def test_seed001_eq1_optimum_by_brute_force():
    """Table 1's tumbler, the chaser 1 km behind at rest from 65 s: the arrival in (260, 370) s of least link
    delta-v against every time 0.02 s apart."""
    choice = select_arrival(TRUTH_TRACK, T0, R0, V0, WINDOW, N, RADIUS, KEEPOUT)
    times = np.arange(WINDOW[0], WINDOW[1] + 1e-9, 0.02)
    r, v = TRUTH_TRACK(times)
    costs = []
    for t, r_s, v_s in zip(times, r, v, strict=True):
        link = PhaseSpaceLink(T0, R0, V0, t, r_s, v_s)
        costs.append(link.delta_v(N, RADIUS) if link.closest_approach_m() >= KEEPOUT else math.inf)
    k = int(np.argmin(costs))
    assert choice.delta_v_mps <= costs[k] + 1e-6
    assert choice.t_arrival == pytest.approx(times[k], abs=0.05)
    assert choice.closest_m >= KEEPOUT
    # eq 1's spread: the velocity to match makes the worst time in the window far dearer than the best
    assert max(c for c in costs if math.isfinite(c)) > 1.5 * choice.delta_v_mps
    # the station's velocity at the chosen time is that of a point 5 m out on a 21 deg/s tumbler
    assert np.linalg.norm(choice.r_hill) == pytest.approx(5.0)
    assert np.linalg.norm(choice.v_hill) < 5.0 * np.linalg.norm(SCENARIO.omega_body0_rad_s) + 0.01


def test_seed001_resolve_keeps_closest_to_the_previous_solution():
    """A newer estimate (attitude 2 deg off, rate 0.05 deg/s off) moves the station's motion; the re-solve picks the
    arrival whose station state is closest to the previous one, against brute force."""
    first = select_arrival(TRUTH_TRACK, T0, R0, V0, WINDOW, N, RADIUS, KEEPOUT)
    q_new = quat_multiply(SCENARIO.q_hill_from_body0, quat_from_axis_angle((0.3, 1.0, -0.2), math.radians(2.0)))
    new_track = _track(q_new, SCENARIO.omega_body0_rad_s + math.radians(0.05) * np.array((1.0, -1.0, 0.5)))
    t_now = 125.0
    (r_now,), (v_now,), _ = first.link.states(np.array((t_now,)))
    again = reselect_arrival(new_track, t_now, r_now, v_now, WINDOW, first.r_hill, first.v_hill, N, RADIUS, KEEPOUT)
    times = np.arange(WINDOW[0], WINDOW[1] + 1e-9, 0.02)
    r, v = new_track(times)
    distance = np.sum((r - first.r_hill) ** 2, axis=1) + np.sum((v - first.v_hill) ** 2, axis=1)
    k = int(np.argmin(distance))
    assert again.t_arrival == pytest.approx(times[k], abs=0.05)
    assert abs(again.t_arrival - first.t_arrival) < 5.0  # the same pass of the station, not another
    # no farther from the previous solution than keeping its arrival time would be
    r_kept, v_kept = new_track(np.array((first.t_arrival,)))
    kept = float(np.sum((r_kept[0] - first.r_hill) ** 2) + np.sum((v_kept[0] - first.v_hill) ** 2))
    assert np.sum((again.r_hill - first.r_hill) ** 2) + np.sum((again.v_hill - first.v_hill) ** 2) <= kept + 1e-9


def test_no_arrival_when_every_link_cuts_the_keepout_sphere():
    assert select_arrival(TRUTH_TRACK, T0, R0, V0, WINDOW, N, RADIUS, keepout_radius_m=6.0) is None
    assert select_arrival(TRUTH_TRACK, 380.0, R0, V0, WINDOW, N, RADIUS, KEEPOUT) is None  # the window is past


def test_the_hold_check_against_the_closed_form_and_a_spinner_too_fast_for_the_thrusters():
    """approach.hold_acceleration_peak: a principal spin (omega' = 0) needs omega^2 times the distance from the spin
    axis, r omega^2 (0.7 m/s^2 at 5 m and 21.4 deg/s); a plan whose hold needs more than HOLD_SHARE of the bound is
    refused with the figures (the thrusters could not keep the chaser on the station)."""
    from flyby_planner.flyby.config import truth_prediction
    from flyby_planner.sync.approach import HOLD_SHARE, hold_acceleration_peak, plan_sync

    state = collections.namedtuple('State', 'omega_body')
    w = math.radians(21.4)

    class Spin:
        t_end = 100.0

        def state(self, t):
            return state(np.array((0.0, 0.0, w)))

    inertia = np.diag((4069.0, 12030.0, 11029.0))
    peak = hold_acceleration_peak(Spin(), (3.0, 4.0, 7.0), inertia, 0.0, 60.0)  # 5 m from the z axis
    assert peak == pytest.approx(5.0 * w * w, rel=1e-12)
    d = copy.deepcopy(load_yaml_mapping(SCENARIOS / 'seweryn_tumbling.yaml'))
    d['target']['initial_rate']['omega_body_rad_s'] = [0.0, 0.0, math.radians(30.0)]  # 1.37 m/s^2 at 5 m
    sc = scenario_from_dict(d, name='seweryn 30 deg/s')
    plan = plan_sync(SyncParams.from_scenario(sc), truth_prediction(sc, 500.0), 80.0, np.array((-1000.0, 0.0, 0.0)),
                     np.zeros(3))
    bound = 2.0 * sc.chaser.thrusters.max_thrust_n / sc.chaser.mass_kg
    assert not plan.ok and 'holding the station 5 m out' in plan.reason
    assert f'> {HOLD_SHARE:g} x {bound:.3f} m/s^2' in plan.reason


def test_a_port_off_the_middle_of_a_face_docks_along_the_faces_normal():
    """The docking line (from the final point 1 m out from the port to the station) against the bus, envelope
    0.75 m: Table 1's port in the middle of the +y face leaves 1 - 0.75 = 0.25 m. A port off the middle of the +x face
    (the campaign's run 6): 1 m out along its radial line x_port / |x_port| (seed 001's) the envelope would reach
    0.06 m into the box; along the face's normal +x it keeps 0.25 m, and the plan is flown."""
    from flyby_planner.flyby.config import truth_prediction
    from flyby_planner.sync.approach import docking_line_clearance, plan_sync

    bus = [((0.0, 0.0, 0.0), (2.0, 4.0, 4.0))]
    y = np.array((0.0, 1.0, 0.0))
    assert docking_line_clearance(station_geometry((0.0, 2.0, 0.0), y, 5.0, 1.0), bus, 0.75) == pytest.approx(0.25)
    port = np.array((1.0, -0.409, 1.636))
    radial_final = port + port / np.linalg.norm(port)
    assert float(np.linalg.norm(np.maximum(np.abs(radial_final) - (1.0, 2.0, 2.0), 0.0))) - 0.75 < -0.05
    x = np.array((1.0, 0.0, 0.0))
    assert docking_line_clearance(station_geometry(port, x, 5.0, 1.0), bus, 0.75) == pytest.approx(0.25)
    d = copy.deepcopy(load_yaml_mapping(SCENARIOS / 'seweryn_tumbling.yaml'))
    d['target']['grasp_point_body_m'] = port.tolist()
    sc = scenario_from_dict(d, name='seweryn, a port off the middle of a face')
    plan = plan_sync(SyncParams.from_scenario(sc), truth_prediction(sc, 500.0), 80.0, np.array((-1000.0, 0.0, 0.0)),
                     np.zeros(3))
    assert plan.ok, plan.reason
    geometry = sync_station_geometry(SyncParams.from_scenario(sc))
    assert geometry.u_body == pytest.approx(x) and geometry.x_final_body == pytest.approx(port + x)
    assert geometry.x_final_body == pytest.approx(capture_target_body('sync', port, 1.0, bus))  # DESIGN §10's point
    d['target']['grasp_point_body_m'] = [0.5, 0.0, 0.0]  # inside the bus: refused at load
    with pytest.raises(ScenarioError, match='target.grasp_point_body_m: must lie on the surface'):
        scenario_from_dict(d, name='seweryn, a port inside the bus')


def test_a_late_plan_moves_the_arrival_window_and_a_resolve_keeps_it():
    """Table 1's window (260, 370) s for a plan starting at 90 s; an estimate converged late (the campaign's run 3
    planned at 383 s, past the window, and was refused) moves it to start min_transfer_s (150 s) after the plan's
    start, 110 s long; a re-solve keeps its previous solution's window; the late plan is flown."""
    from flyby_planner.flyby.config import truth_prediction
    from flyby_planner.sync.approach import arrival_window, plan_sync

    assert arrival_window(SYNC, 90.0) == (260.0, 370.0)
    assert arrival_window(SYNC, 383.2) == pytest.approx((533.2, 643.2))
    late = plan_sync(SYNC, truth_prediction(SCENARIO, 720.0), 383.2, R0, V0)
    assert late.ok, late.reason
    assert 533.2 <= late.arrival.t_arrival <= 643.2 and late.arrival.window_s == pytest.approx((533.2, 643.2))
    assert arrival_window(SYNC, 420.0, late.arrival) == pytest.approx((533.2, 643.2))


def test_resolves_halve_the_horizon_down_to_the_cutoff():
    """resolve_due: every interval, then halfway to the arrival, the last one the cutoff before it; none after it,
    nor when the link would start (lead after the estimate) past the arrival."""
    sync = SCENARIO.planner.sync
    campaign = types.SimpleNamespace(resolve_interval_s=30.0, resolve_cutoff_s=5.0, resolve_lead_s=2.0)

    def schedule(s, t_plan, t_arrival, step_s=0.1):
        times, t0 = [], t_plan
        for k in range(int(round((t_arrival - t0) / step_s)) + 1):
            t = round(t0 + k * step_s, 6)
            if resolve_due(t, t_plan, t_arrival, s):
                times.append(t)
                t_plan = t  # the re-solve keeps the arrival (the planner's reselect may move it)
        return times

    assert schedule(campaign, 200.0, 360.0) == [230.0, 260.0, 290.0, 320.0, 340.0, 350.0, 355.0]
    # Table 1's settings: every 30 s while the arrival is farther than 60 s, then once at the cutoff
    assert schedule(sync, 76.0, 361.2) == [106.0, 136.0, 166.0, 196.0, 226.0, 256.0, 286.0, 301.2]
    assert not resolve_due(359.0, 300.0, 360.0, campaign)  # past the last, and the link would start after 360 s
    assert not resolve_due(356.0, 355.0, 360.0, campaign)  # the plan flown is the last
