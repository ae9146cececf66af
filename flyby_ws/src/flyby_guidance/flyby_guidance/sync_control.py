"""Stages 2-4 of the synchronized approach (seed 001 section 2, Fig 2-3, eq 2-3) and its abort, no ROS.

After stage 1 (the phase-space link to the station, ``flyby_planner.sync.station``, flown by ``tracking``) the
chaser lives in the target's body frame: its reference is a point x(t) = x_port + s(t) u of that frame, u the
docking port's outward direction (the face's normal, flyby_planner.sync.station), turned into hill by the target's
attitude PREDICTED from the latest estimate to the command's time (the target of seed 001 Table 1 is not in a
principal spin: its rate moves in the body, so the prediction integrates Euler's equation, not a constant rate):

* stage 2, attitude synchronization (``ATTITUDE_SYNC``): x at the station (``station_range_m`` from the centre of
  mass); the attitude goal is the target's attitude times a fixed relative orientation (chaser +x along -u, at
  the port; chosen at the stage's start as the smallest rotation from the chaser's relative orientation then), its
  rate and acceleration the target's:
  ``attitude_control``'s tracking law on the wheels (seed 001 eq 3 with the wheels' momentum). Done when the
  estimated relative attitude and rate errors stay within their tolerances for ``settle_s``: the configured ones
  added in quadrature to the target estimate's own 3 sigma (the largest eigenvalue of its published attitude and
  rate covariance; the goal is that estimate, which moves by its error from sample to sample, and the chaser cannot
  sit closer to it than that: 0.3 deg and 0.07 deg/s for a 25 deg/s tumbler seen with 1.8 deg of vision noise,
  1.1 deg and 0.5 deg/s for a spin about the intermediate axis); not done within
  ``attitude_sync_max_s`` of the arrival, a fault (ERROR ``attitude_sync_timeout``: the supervisor aborts) and the
  retreat (a target estimated too coarsely to synchronize with holds the station for nothing);
* stage 3, orbiting (``ORBITING``): the same hold for ``orbiting_fraction`` of a rotation cycle 2 pi / |omega|
  (seed 001: half);
* stage 4, docking (``DOCKING``): s(t) from the station to the final range (planner.offset_m from the port)
  along a quintic with zero rate and acceleration at both ends over ``docking_duration_s``: a straight line in the
  body frame (seed 001: radial), a spiral in hill (Fig 3); then the final point is held until the capture.

The translation law (seed 001 eq 2 with the control force): with the reference r_ref, v_ref, a_ref of the body
point (``flyby_sim.dynamics.attitude.moving_body_point_state``: x'' + 2 w x x' + w' x x + w x (w x x) in the body,
turned into hill), the thrust acceleration held over a control period is

    a = [a_ref - f(r_ref, v_ref)] at the hold's midpoint + w_c^2 (r_ref - r) + 2 w_c (v_ref - v) at the estimate,

f the relative motion without thrust (``nonlinear_relative_accel``), w_c the feedback's natural frequency
(critically damped), then bounded by ``accel_max_mps2``. Holding a point at r from the spin axis of a body
turning at |omega| takes r |omega|^2 (0.67 m/s^2 at 5 m and 21 deg/s).

**Abort** (any stage): retreat along the port's outward direction (the chaser sits on that line in stages 2-4; in
stage 1, or when the hold has lost its point (``HOLD_ERROR_MAX_M``, ERROR ``station_lost``), along the line of sight
away from the target's centre of mass) at the bound until the outward speed reaches
``retreat_speed_mps`` (a rigid rotation moves the body point under the chaser across the line of sight, not
along it), at most ``retreat_max_s``; then nothing: the chaser drifts away on a line that leaves the target's circle.

Frames and units: hill of flyby_sim.dynamics.orbital; quaternions (x, y, z, w); angular velocities inertial, in
the axes of their own frame; SI.
"""

import dataclasses
import math

import numpy as np

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import prediction_from_estimate
from flyby_guidance.attitude_guidance import AttitudeGuidanceConfig, PointingGoal
from flyby_msgs_py import event_payloads, events, params
from flyby_planner.sync.approach import SyncParams, sync_station_geometry
from flyby_sim.dynamics.attitude import euler_rate, moving_body_point_state
from flyby_sim.dynamics.orbital import nonlinear_relative_accel
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_multiply,
    quat_rotate,
    quat_shortest_arc,
    quat_to_matrix,
    rotation_vector_from_quat,
)

# The attitude law's settings from stage 2 on. The hold's 140 N, fixed in the synchronized chaser's body, leaves a
# constant torque of 0.1-0.3 N m from the thrusters' errors (0.5 deg, 1 %) that no command foresees; the law's
# stiffness omega_n^2 J turns it into a steady error: 1.3 deg at omega_n 0.6 rad/s (the headless run and a
# simulation with the one-period command delay agree), 0.09 deg at 2.5 rad/s, still stable with that delay
# (docs/synchronized.md).
SYNC_ATTITUDE = AttitudeGuidanceConfig(natural_frequency_rad_s=2.5, max_rate_rad_s=0.1, dump_start_n_m_s=2.0,
                                       dump_stop_n_m_s=0.5, dump_gain_per_s=0.1, dump_max_torque_n_m=1.0,
                                       integral_time_s=10.0)

# A hold whose estimate is farther than this from its reference [m] is a fault: the reference moved (a newer
# estimate of an unstable tumble, whose prediction to the arrival was wrong) and the feedback's straight pull could
# cross the body. Stages 2-4 hold within centimetres.
HOLD_ERROR_MAX_M = 1.0

STAGE_APPROACH = 'approach'
STAGE_ATTITUDE_SYNC = 'attitude_sync'
STAGE_ORBITING = 'orbiting'
STAGE_DOCKING = 'docking'
STAGE_RETREAT = 'retreat'
STAGE_DRIFT = 'drift'


def _sync_geometry(scenario):
    """The docking line (flyby_planner.sync.station.StationGeometry); None without a port on the target's surface,
    for which the planner refuses the synchronized approach (plan_sync)."""
    try:
        return sync_station_geometry(SyncParams.from_scenario(scenario))
    except ValueError:
        return None


def _sync_accel_max_mps2(scenario):
    """planner.sync.accel_max_mps2 (omitted: two thrusters' max_thrust_n over the mass, the default layout's weakest
    direction) less 3 sigma of the thrusters' magnitude error."""
    s, th = scenario.planner.sync, scenario.chaser.thrusters
    accel = 2.0 * th.max_thrust_n / scenario.chaser.mass_kg if s.accel_max_mps2 is None else s.accel_max_mps2
    return accel * (1.0 - 3.0 * th.magnitude_error_sigma)


@params.record
class SyncConfig:
    """The synchronized approach's settings (planner.sync, docs/synchronized.md): the synchronized mode's record
    (``flyby_msgs_py.params``)."""

    geometry: object = params.derived(_sync_geometry)
    docking_duration_s: float = params.key('planner.sync.docking_duration_s')
    orbiting_fraction: float = params.key('planner.sync.orbiting_fraction')  # of a rotation cycle 2 pi / |omega|
    # the translation feedback's natural frequency
    frequency_rad_s: float = params.key('planner.sync.tracking_frequency_rad_s')
    accel_max_mps2: float = params.derived(_sync_accel_max_mps2)
    attitude_tolerance_rad: float = params.key('planner.sync.attitude_tolerance_deg', math.radians)
    rate_tolerance_rad_s: float = params.key('planner.sync.rate_tolerance_deg_s', math.radians)
    settle_s: float = params.key('planner.sync.settle_s')
    attitude_sync_max_s: float = params.key('planner.sync.attitude_sync_max_s')
    retreat_speed_mps: float = params.key('planner.sync.retreat_speed_mps')
    retreat_max_s: float = params.key('planner.sync.retreat_max_s')
    n: float = params.key('mean_motion_rad_s')  # mean motion [rad/s]
    radius_m: float = params.key('orbit_radius_m')  # orbit radius [m]
    target_inertia: np.ndarray = params.key('target_inertia', lambda inertia: np.asarray(inertia, dtype=float))


def docking_profile(t, t_start, duration_s, rho_from_m, rho_to_m):
    """(rho [m], rho' [m/s], rho'' [m/s^2]) along the docking line: the quintic 10 s^3 - 15 s^4 + 6 s^5 from
    rho_from_m at t_start to rho_to_m after duration_s (zero rate and acceleration at both ends), constant outside."""
    s = min(max((t - t_start) / duration_s, 0.0), 1.0)
    d = rho_to_m - rho_from_m
    inside = 0.0 < s < 1.0
    shape = s ** 3 * (10.0 - 15.0 * s + 6.0 * s * s)
    rate = 30.0 * s * s * (1.0 - s) ** 2 / duration_s if inside else 0.0
    accel = 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / duration_s ** 2 if inside else 0.0
    return rho_from_m + d * shape, d * rate, d * accel


def body_point_reference(q_hill_from_body, omega_body, inertia, x0_body, u_body, rho, rho_dot, rho_ddot, n):
    """(r_hill [m], v_hill [m/s], a_hill [m/s^2]) of the point x0_body + rho u_body of a torque-free body moving
    along u_body at rho' and rho'' (seed 001 eq 3 with no torque for the target's omega')."""
    w = np.asarray(omega_body, dtype=float)
    w_dot = euler_rate(w, inertia, np.linalg.inv(inertia))
    u = np.asarray(u_body, dtype=float)
    return moving_body_point_state(quat_to_matrix(q_hill_from_body), w, w_dot, np.asarray(x0_body, dtype=float)
                                   + rho * u, rho_dot * u, rho_ddot * u, n)


def hold_acceleration(ref_estimate, ref_mid, r_hill, v_hill, config):
    """The thrust acceleration [m/s^2, hill] of the module doc's law: feed-forward of ref_mid (r, v, a at the
    hold's midpoint), feedback on the estimate (r_hill, v_hill) against ref_estimate (r, v at its time), bounded."""
    r_mid, v_mid, a_mid = ref_mid
    a_ff = a_mid - nonlinear_relative_accel(r_mid, v_mid, config.n, config.radius_m)  # eq 2: what thrust must add
    w = config.frequency_rad_s
    a = a_ff + w * w * (ref_estimate[0] - r_hill) + 2.0 * w * (ref_estimate[1] - v_hill)
    norm = float(np.linalg.norm(a))
    return a * (config.accel_max_mps2 / norm) if norm > config.accel_max_mps2 else a


def relative_goal_orientation(q_hill_from_target, q_hill_from_chaser, u_body):
    """q_target_from_goal: the chaser's orientation relative to the target now, turned by the smallest rotation
    that puts its +x along -u_body (at the port)."""
    q_target_from_chaser = quat_multiply(quat_conjugate(q_hill_from_target), q_hill_from_chaser)
    x_now = quat_rotate(q_target_from_chaser, (1.0, 0.0, 0.0))
    return quat_multiply(quat_shortest_arc(x_now, -np.asarray(u_body, dtype=float)), q_target_from_chaser)


def sync_goal(q_hill_from_target, omega_target_body, omega_dot_target_body, q_target_from_goal, u_body):
    """PointingGoal of stage 2-4: the target's attitude times the fixed relative orientation, with the target's
    inertial rate and acceleration in goal axes."""
    q_goal_from_target = quat_conjugate(q_target_from_goal)
    q_hill_from_goal = quat_multiply(q_hill_from_target, q_target_from_goal)
    return PointingGoal(q_hill_from_goal, quat_rotate(q_goal_from_target, omega_target_body),
                        quat_rotate(q_goal_from_target, omega_dot_target_body),
                        quat_rotate(q_hill_from_target, -np.asarray(u_body, dtype=float)), 0.0)


def settling_tolerances(config, covariance):
    """(attitude [rad], rate [rad/s]) tolerances of stage 2's end (module doc): config's added in quadrature to
    the 3 sigma of the target estimate's covariance, (attitude [rad^2], rate [rad^2/s^2]) 3x3 blocks in any axes
    (their largest eigenvalue); config's alone without one."""
    if covariance is None:
        return config.attitude_tolerance_rad, config.rate_tolerance_rad_s
    three_sigma = [3.0 * math.sqrt(max(float(np.linalg.eigvalsh(np.asarray(p, dtype=float))[-1]), 0.0))
                   for p in covariance]
    return (math.hypot(config.attitude_tolerance_rad, three_sigma[0]),
            math.hypot(config.rate_tolerance_rad_s, three_sigma[1]))


def attitude_errors(goal, q_hill_from_chaser, omega_chaser_body):
    """(relative attitude error [rad], rate error [rad/s]) of the chaser against a PointingGoal."""
    angle = float(np.linalg.norm(rotation_vector_from_quat(
        quat_multiply(quat_conjugate(goal.q_hill_from_goal), q_hill_from_chaser))))
    q_body_from_goal = quat_multiply(quat_conjugate(q_hill_from_chaser), goal.q_hill_from_goal)
    rate = float(np.linalg.norm(np.asarray(omega_chaser_body, dtype=float)
                                - quat_rotate(q_body_from_goal, goal.omega_goal)))
    return angle, rate


@dataclasses.dataclass(frozen=True)
class SyncCommand:
    """What stages 2-4 (or the retreat) ask for over one hold: the thrust acceleration [m/s^2, hill] (None: no
    force), the attitude goal (None: the caller's own pointing), and events as (level, name, message, values)."""

    a_hill: np.ndarray
    goal: PointingGoal
    events: tuple = ()


class SyncGuidance:
    """The stage machine of stages 2-4 and the abort (module doc). ``arm(t_arrival)`` at the station's arrival time
    of the plan flown (stage 1 ends there); ``command`` once per control period."""

    def __init__(self, config):
        self.config = config
        self.geometry = config.geometry
        self.dynamics = ErrorStateDynamics(config.target_inertia)
        self.stage = None
        self.t_arrival = None
        self.q_target_from_goal = None
        self.t_settled = None  # since when the attitude errors are within tolerance
        self.t_docking = self.t_grasp = None
        self.t_retreat = None
        self.retreat_from_hold = False  # the abort came in stages 2-4, on the port's line
        self.peak_accel_mps2 = {}  # by stage: the largest commanded thrust acceleration

    @property
    def holding(self):
        """True from the arrival on (the body-frame hold, stages 2-4)."""
        return self.stage in (STAGE_ATTITUDE_SYNC, STAGE_ORBITING, STAGE_DOCKING)

    def arm(self, t_arrival):
        """Stage 1 is flown and ends at t_arrival [s] (a re-solve moves it)."""
        if self.stage in (None, STAGE_APPROACH):
            self.stage, self.t_arrival = STAGE_APPROACH, float(t_arrival)

    def abort(self, t):
        """An abort at t: retreat (once)."""
        if self.stage is not None and self.stage not in (STAGE_RETREAT, STAGE_DRIFT):
            self.retreat_from_hold, self.stage, self.t_retreat = self.holding, STAGE_RETREAT, t

    def command(self, t, t_apply, hold_s, r_hill, v_hill, q_hill_from_chaser, omega_chaser_body, target):
        """SyncCommand for the estimate of t applied over [t_apply, t_apply + hold_s], or None in stage 1 before the
        arrival (the trajectory's tracking flies it) and after the retreat. target: (t, q_hill_from_body,
        omega_body, (attitude covariance [rad^2], rate covariance [rad^2/s^2]) or None) of the latest target
        estimate."""
        if self.stage is None or self.stage == STAGE_DRIFT:
            return None
        if self.stage == STAGE_APPROACH and t_apply < self.t_arrival:
            return None
        emitted = []
        if self.stage == STAGE_APPROACH:
            self.stage = STAGE_ATTITUDE_SYNC
            emitted.append(('OK', events.STATION_REACHED, f'station reached at t = {self.t_arrival:.2f} s: attitude '
                                                          'synchronization',
                            event_payloads.encode(event_payloads.StationReached(self.t_arrival))))
        t_mid = t_apply + 0.5 * hold_s
        t_t, q_t, w_t, covariance = target
        prediction = prediction_from_estimate(self.dynamics, self.config.n, t_t, q_t, w_t, max(t_mid, t_t))
        now, mid = prediction.state(max(t, t_t)), prediction.state(max(t_mid, t_t))
        if self.stage == STAGE_RETREAT:
            return self._retreat(t, r_hill, v_hill, now)
        cfg, geo = self.config, self.geometry
        if self.q_target_from_goal is None:
            self.q_target_from_goal = relative_goal_orientation(now.q_hill_from_body, q_hill_from_chaser, geo.u_body)
        # the error at the estimate's time, the target's acceleration fed forward at the hold's midpoint
        w_dot_mid = euler_rate(mid.omega_body, cfg.target_inertia, np.linalg.inv(cfg.target_inertia))
        goal = sync_goal(now.q_hill_from_body, now.omega_body, w_dot_mid, self.q_target_from_goal, geo.u_body)
        if self.stage == STAGE_ATTITUDE_SYNC:
            emitted += self._check_synchronized(t, t_apply, q_hill_from_chaser, omega_chaser_body, now, covariance)
            if self.stage == STAGE_RETREAT:
                retreat = self._retreat(t, r_hill, v_hill, now)
                return dataclasses.replace(retreat, events=tuple(emitted) + retreat.events)
        if self.stage == STAGE_ORBITING and t_apply >= self.t_docking:
            self.stage = STAGE_DOCKING
            emitted.append(('OK', events.DOCKING_STARTED, f'docking from {geo.station_offset_m:.3g} m to the final '
                                                          f'range {geo.final_range_m:g} m from the port by t = '
                                                          f'{self.t_grasp:.2f} s',
                           event_payloads.encode(event_payloads.DockingStarted(self.t_docking, self.t_grasp,
                                                                               geo.final_range_m))))
        profile = (lambda s: docking_profile(s, self.t_docking, cfg.docking_duration_s, geo.station_offset_m,
                                             geo.final_range_m)) if self.stage == STAGE_DOCKING else \
            (lambda s: (geo.station_offset_m, 0.0, 0.0))
        ref_now = body_point_reference(now.q_hill_from_body, now.omega_body, cfg.target_inertia, geo.x_port_body,
                                       geo.u_body, *profile(t), cfg.n)
        ref_mid = body_point_reference(mid.q_hill_from_body, mid.omega_body, cfg.target_inertia, geo.x_port_body,
                                       geo.u_body, *profile(t_mid), cfg.n)
        miss_m = float(np.linalg.norm(ref_now[0] - np.asarray(r_hill, dtype=float)))
        if miss_m > HOLD_ERROR_MAX_M:
            self.abort(t)
            self.retreat_from_hold = False  # off the port's line: away from the centre of mass
            retreat = self._retreat(t, r_hill, v_hill, now)
            return dataclasses.replace(retreat, events=tuple(emitted) + (
                ('ERROR', events.STATION_LOST, f'{miss_m:.2f} m from the body point held (> {HOLD_ERROR_MAX_M:g} m): '
                                               'retreating', {'miss_m': miss_m}),) + retreat.events)
        a = hold_acceleration(ref_now, ref_mid, np.asarray(r_hill, float), np.asarray(v_hill, float), cfg)
        self.peak_accel_mps2[self.stage] = max(self.peak_accel_mps2.get(self.stage, 0.0), float(np.linalg.norm(a)))
        return SyncCommand(a, goal, tuple(emitted))

    def _check_synchronized(self, t, t_apply, q_hill_from_chaser, omega_chaser_body, now, covariance):
        """Stage 2's end (module doc): the errors of the estimate of t against the goal of t, within the tolerances
        of the target estimate's covariance (settling_tolerances)."""
        cfg = self.config
        w_dot = euler_rate(now.omega_body, cfg.target_inertia, np.linalg.inv(cfg.target_inertia))
        goal_now = sync_goal(now.q_hill_from_body, now.omega_body, w_dot, self.q_target_from_goal, self.geometry.u_body)
        angle, rate = attitude_errors(goal_now, q_hill_from_chaser, omega_chaser_body)
        angle_tol, rate_tol = settling_tolerances(cfg, covariance)
        if angle > angle_tol or rate > rate_tol:
            self.t_settled = None
            if t_apply - self.t_arrival > cfg.attitude_sync_max_s:
                self.abort(t)
                return [('ERROR', events.ATTITUDE_SYNC_TIMEOUT,
                         f'attitude not synchronized {cfg.attitude_sync_max_s:g} s after the arrival (relative '
                         f'attitude {math.degrees(angle):.3f} deg, rate {math.degrees(rate):.4f} deg/s; tolerances '
                         f'{math.degrees(angle_tol):.3f} deg, {math.degrees(rate_tol):.4f} deg/s): retreating',
                         {'attitude_error_deg': math.degrees(angle), 'rate_error_deg_s': math.degrees(rate),
                          'attitude_tolerance_deg': math.degrees(angle_tol),
                          'rate_tolerance_deg_s': math.degrees(rate_tol)})]
            return []
        if self.t_settled is None:
            self.t_settled = t
        if t - self.t_settled < cfg.settle_s:
            return []
        period_s = 2.0 * math.pi / float(np.linalg.norm(now.omega_body))
        self.stage = STAGE_ORBITING
        self.t_docking = t_apply + cfg.orbiting_fraction * period_s
        self.t_grasp = self.t_docking + cfg.docking_duration_s
        return [('OK', events.ATTITUDE_SYNCHRONIZED,
                 f'relative attitude {math.degrees(angle):.3f} deg, rate {math.degrees(rate):.4f} deg/s for '
                 f'{cfg.settle_s:g} s (tolerances {math.degrees(angle_tol):.3f} deg, {math.degrees(rate_tol):.4f} '
                 f'deg/s): orbiting {cfg.orbiting_fraction:g} of a {period_s:.2f} s rotation cycle, '
                 f'docking at t = {self.t_docking:.2f} s',
                 event_payloads.encode(event_payloads.AttitudeSynchronized(
                     math.degrees(angle), math.degrees(rate), math.degrees(angle_tol), math.degrees(rate_tol),
                     period_s, self.t_docking, self.t_grasp)))]

    def _retreat(self, t, r_hill, v_hill, now):
        """The retreat's thrust (module doc); the stage turns to drift when it is done."""
        cfg = self.config
        r = np.asarray(r_hill, dtype=float)
        dist = float(np.linalg.norm(r))
        u = quat_rotate(now.q_hill_from_body, self.geometry.u_body) if self.retreat_from_hold or dist == 0.0 else \
            r / dist
        outward = float(np.asarray(v_hill, dtype=float) @ u)
        if outward >= cfg.retreat_speed_mps or t - self.t_retreat >= cfg.retreat_max_s:
            self.stage = STAGE_DRIFT
            return SyncCommand(None, None, (('WARN', events.RETREAT_ENDED,
                                             f'outward speed {outward:.3f} m/s at {dist:.2f} m: drifting',
                                             {'outward_speed_mps': outward, 'range_m': dist}),))
        return SyncCommand(cfg.accel_max_mps2 * u, None)
