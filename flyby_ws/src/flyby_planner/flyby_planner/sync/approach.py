"""The synchronized approach as the mission plans it (seed 001 section 2, DESIGN §10 ``sync``): stage 1 from the
estimates, for /planner/trajectory.

At the plan time the chaser's estimated state is carried to the start (``maneuver_lead_s`` later), the target's
motion is predicted from its estimate over the arrival window (``arrival_window``: Table 1's, or later for a plan
made late), and ``station.select_arrival`` (eq 1) chooses the arrival; a re-solve (``previous`` given) takes
``station.reselect_arrival``, the solution closest to the previous one. The link is sampled every
``planner.sync.trajectory_step_s`` for guidance to track; its end is the station at the arrival time, where
guidance turns to stages 2-4 (flyby_guidance.sync_control).

Before it is flown the plan is checked against the thrust it will need: the link's peak acceleration, and the
hold's, the acceleration of the station point fixed in the tumbling body, |omega' x x + omega x (omega x x)|
(seed 001 eq 2 with the relative gravity left out, 1e-5 of it), over the predicted motion from the arrival to
``HOLD_CHECK_S`` later (stages 2-4 of Table 1 take about 60 s), within ``HOLD_SHARE`` of the bound (the rest is the
feedback's). A target spinning too fast for the thrusters is refused with the figures (``NO_SAFE_PLAN``): a hold
the thrusters cannot give drifts off the station into the tumbling body. So is a port off the target's surface (no
outward direction to dock along), and a docking line (stages 2-4 hold the points x_port + s u of the body, u the
face's outward normal, from the station down to the final point, ``station.StationGeometry``) that brings the
chaser's envelope closer than ``planner.clearance_margin_m`` to the target's boxes (another box in the way; checked
in body axes, where the line is fixed).
"""

import dataclasses
import math

import numpy as np

from flyby_msgs_py import params
from flyby_planner.flyby.grasp_search import docking_axis
from flyby_planner.sync.station import keepout_radius, reselect_arrival, select_arrival, station_geometry
from flyby_sim.dynamics.attitude import euler_rate
from flyby_sim.dynamics.geometry import signed_distance_to_box

# The hold is checked over this much of the predicted motion after the arrival [s], ...
HOLD_CHECK_S = 60.0
# ... within this share of the acceleration bound (the rest is the tracking feedback's).
HOLD_SHARE = 0.8


@dataclasses.dataclass(frozen=True)
class SyncPlan:
    """ok; reason (one line); the arrival (station.ArrivalChoice) and the Trajectory to fly, or None."""

    ok: bool
    reason: str
    arrival: object = None
    trajectory: object = None
    peak_accel_mps2: float = None


def _boxes_body(scenario):
    """The target's boxes as (center [m], size [m]) pairs, body axes."""
    return [(b.center_m, b.size_m) for b in scenario.target.geometry]


def _accel_max_mps2(scenario):
    """planner.sync.accel_max_mps2, or two thrusters' max_thrust_n over the mass."""
    s, c = scenario.planner.sync, scenario.chaser
    return 2.0 * c.thrusters.max_thrust_n / c.mass_kg if s.accel_max_mps2 is None else s.accel_max_mps2


@params.record
class SyncParams:
    """The synchronized approach's record (planner.sync of a scenario with what it reads elsewhere): the port
    (target.grasp_point_body_m) and the target's boxes ((center, size) pairs, body axes), the station range, the
    final range planner.offset_m and the keep-out margin [m]; the first arrival window, its least transfer [s]; the
    trajectory's point spacing [s]; the re-solve's interval, cutoff and lead [s] (``resolve_due``) and the first
    plan's lead planner.maneuver_lead_s [s]; the largest acceleration [m/s^2] (``_accel_max_mps2``), the chaser's
    envelope and the clearance margin [m]; the orbit (mean motion [rad/s], radius [m]) and the target's inertia
    [kg m^2]; the category IV rate estimation.spin_rate_deg_s [deg/s] (``is_category_iv``)."""

    x_port_body_m: tuple = params.key('target.grasp_point_body_m')
    boxes_body: list = params.derived(_boxes_body)
    station_range_m: float = params.key('planner.sync.station_range_m')
    offset_m: float = params.key('planner.offset_m')
    keepout_margin_m: float = params.key('planner.sync.keepout_margin_m')
    arrival_start_s: float = params.key('planner.sync.arrival_start_s')
    arrival_end_s: float = params.key('planner.sync.arrival_end_s')
    min_transfer_s: float = params.key('planner.sync.min_transfer_s')
    trajectory_step_s: float = params.key('planner.sync.trajectory_step_s')
    resolve_interval_s: float = params.key('planner.sync.resolve_interval_s')
    resolve_cutoff_s: float = params.key('planner.sync.resolve_cutoff_s')
    resolve_lead_s: float = params.key('planner.sync.resolve_lead_s')
    maneuver_lead_s: float = params.key('planner.maneuver_lead_s')
    accel_max_mps2: float = params.derived(_accel_max_mps2)
    envelope_radius_m: float = params.key('chaser.envelope_radius_m')
    clearance_margin_m: float = params.key('planner.clearance_margin_m')
    mean_motion_rad_s: float = params.key('mean_motion_rad_s')
    orbit_radius_m: float = params.key('orbit_radius_m')
    target_inertia_kg_m2: np.ndarray = params.key('target_inertia')
    spin_rate_deg_s: float = params.key('estimation.spin_rate_deg_s')


def sync_station_geometry(sync):
    """The docking line (station.StationGeometry) of SyncParams ``sync``: its port, the outward normal there, the
    station range and the final range planner.offset_m. A ValueError names the port when it is off the target's
    surface."""
    axis = docking_axis(sync.x_port_body_m, sync.boxes_body)
    return station_geometry(sync.x_port_body_m, axis, sync.station_range_m, sync.offset_m)


def plan_sync(sync, prediction, t_start, r_start_hill, v_start_hill, previous=None):
    """SyncPlan of stage 1 with SyncParams ``sync`` from the chaser's state (r, v) at t_start [s] and the target's
    MotionPrediction (covering the arrival window); previous: the ArrivalChoice of the plan being flown (a
    re-solve)."""
    try:
        geometry = sync_station_geometry(sync)
    except ValueError as e:
        return SyncPlan(False, f'synchronized approach: {e}')
    line_m = docking_line_clearance(geometry, sync.boxes_body, sync.envelope_radius_m)
    if line_m < sync.clearance_margin_m:
        port = np.round(sync.x_port_body_m, 3).tolist()
        return SyncPlan(False, f'synchronized approach: the docking line of the port {port} comes {line_m:.3f} m '
                               f'from the target (margin {sync.clearance_margin_m:g} m)')
    keepout_m = keepout_radius(sync.boxes_body, sync.envelope_radius_m, sync.keepout_margin_m)
    n, radius = sync.mean_motion_rad_s, sync.orbit_radius_m
    window = arrival_window(sync, t_start, previous)

    def track(times):
        p = prediction.track(geometry.x_station_body, times)
        return p.r_hill, p.v_hill

    if previous is None:
        choice = select_arrival(track, t_start, r_start_hill, v_start_hill, window, n, radius, keepout_m)
    else:
        choice = reselect_arrival(track, t_start, r_start_hill, v_start_hill, window, previous.r_hill,
                                  previous.v_hill, n, radius, keepout_m)
    if choice is None:
        return SyncPlan(False, f'synchronized approach: no arrival in ({window[0]:g}, {window[1]:g}) s from '
                               f't = {t_start:.1f} s whose link keeps {keepout_m:.2f} m off the target')
    peak = choice.link.peak_acceleration(n, radius)
    accel_max = sync.accel_max_mps2
    if peak > accel_max:
        return SyncPlan(False, f'synchronized approach: the link to the arrival at {choice.t_arrival:.1f} s needs '
                               f'{peak:.3f} m/s^2 > {accel_max:.3f} m/s^2')
    hold = hold_acceleration_peak(prediction, geometry.x_station_body, sync.target_inertia_kg_m2, choice.t_arrival,
                                  choice.t_arrival + HOLD_CHECK_S)
    if hold > HOLD_SHARE * accel_max:
        return SyncPlan(False, f'synchronized approach: holding the station {geometry.station_range_m:g} m out on the '
                               f'tumbling target needs {hold:.3f} m/s^2 > {HOLD_SHARE:g} x {accel_max:.3f} m/s^2 '
                               f'(planner.sync.accel_max_mps2 or two thrusters)')
    reason = (f'synchronized approach: station {geometry.station_range_m:g} m out on the port\'s line reached at '
              f't = {choice.t_arrival:.2f} s ({"closest to the previous solution" if previous else "eq 1, least"} '
              f'delta-v {choice.delta_v_mps:.3f} m/s, peak {peak:.3f} m/s^2, {choice.feasible} of {choice.tried} '
              f'arrival times clear of the target)')
    return SyncPlan(True, reason, choice, choice.link.sample(sync.trajectory_step_s, n, radius), peak)


def arrival_window(sync, t_start, previous=None):
    """The arrival window (t_s_opt, t_f_opt) [s] of a plan starting at t_start [s]: a re-solve's is its previous
    solution's (an ArrivalChoice); a first plan's is SyncParams ``sync``'s (seed 001 Table 1: 260-370 s), moved to
    start min_transfer_s after t_start when it comes later than that (an estimate converged late), its length kept."""
    if previous is not None:
        return previous.window_s
    shift = max(0.0, t_start + sync.min_transfer_s - sync.arrival_start_s)
    return sync.arrival_start_s + shift, sync.arrival_end_s + shift


def resolve_due(t, t_plan, t_arrival, sync):
    """True when the target estimate of t [s] is due to re-solve stage 1 (seed 001 section 2), flown from the plan of
    t_plan [s] to the arrival t_arrival [s]; sync: SyncParams (or planner.sync). Due at the sooner of
    resolve_interval_s after the plan and halfway from it to the arrival, and last resolve_cutoff_s before the
    arrival (none after it, nor once the link would start, resolve_lead_s after t, past the arrival). A station
    fixed in a body spinning about its intermediate axis is predicted with an error growing e-fold every
    1 / (0.377 |omega|) (6 s at 25 deg/s; docs/synchronized.md, "How these rules were found"): each re-solve halves
    the horizon the next one corrects, and the last predicts only resolve_cutoff_s ahead."""
    t_last = t_arrival - sync.resolve_cutoff_s
    due = min(t_plan + sync.resolve_interval_s, 0.5 * (t_plan + t_arrival), t_last)
    return t_plan < t_last and due <= t < t_arrival - sync.resolve_lead_s


def docking_line_clearance(geometry, boxes, envelope_radius_m, samples=200):
    """The least gap [m] between the chaser's envelope on the docking line (station.StationGeometry: from the final
    point to the station, body axes) and the target's boxes ((center, size) pairs, body axes)."""
    s = np.linspace(geometry.final_range_m, geometry.station_offset_m, samples)
    points = geometry.x_port_body + np.outer(s, geometry.u_body)
    return float(np.min([signed_distance_to_box(points, c, z) for c, z in boxes], axis=0).min() - envelope_radius_m)


def hold_acceleration_peak(prediction, x_body, inertia, t_from, t_to, step_s=0.5):
    """The largest acceleration [m/s^2] of a point x_body fixed in the predicted tumbling body over [t_from, t_to]
    (within the prediction): |omega' x x + omega x (omega x x)|, omega' by Euler's equation (module doc)."""
    x = np.asarray(x_body, dtype=float)
    inertia = np.asarray(inertia, dtype=float)
    inertia_inv = np.linalg.inv(inertia)
    t_to = min(t_to, getattr(prediction, 't_end', t_to))
    peak = 0.0
    for t in np.arange(t_from, t_to + 1e-9, step_s):
        w = prediction.state(float(t)).omega_body
        a = np.cross(euler_rate(w, inertia, inertia_inv), x) + np.cross(w, np.cross(w, x))
        peak = max(peak, float(np.linalg.norm(a)))
    return peak


def is_category_iv(omega_body, spin_rate_deg_s):
    """Condition (a) fails: the inertial rate is at or above spin_rate_deg_s, estimation.spin_rate_deg_s
    (seed 000 §2.1)."""
    return float(np.linalg.norm(omega_body)) >= math.radians(spin_rate_deg_s)
