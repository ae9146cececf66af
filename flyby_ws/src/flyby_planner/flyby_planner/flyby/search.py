"""Fly-by capture task planning, seed 000 sections 4.3-4.5 and 4.7 (eq 13-23, 28-29), seed 003 section 3.

Pure numpy/scipy, no ROS. ``plan_capture`` takes the estimator's prediction of the target motion
(flyby_estimation.target_motion.MotionPrediction) and the chaser's estimated state, and returns a
``CapturePlan``: the grasp time and point, the offset delta r and the fly-by duration it chose, the
fly-by target point X_Ft (eq 20-21), the fly-by initial point X_Fi (eq 23), the terminal-transfer
impulses (eq 28-29), the predicted passive path and, for every candidate considered, why it was kept
or rejected.

Steps (seed 000 section 4.4: "multiple candidates ... over a period of rotations"):

1. Grasp-time search (grasp.grasp_candidates, eq 13-15) over the grasp times reachable with a
   terminal transfer of transfer_min_s ... transfer_max_s starting maneuver_lead_s from now and any
   searched fly-by duration; for a slow target the window is stretched to hold two turns. When that
   window holds no safe plan, the extended window is searched: transfers up to 0.4 orbit (a tumbler's
   geometry at the grasp changes with its nutation), grasps before the mission's end, and half the
   preferred fly-by for a fast grasp point (its nearer X_Fi and smaller injection).
2. Per grasp instant: condition (a) rate below the category III/IV limit, (b) spin axis away from
   hill y (no pure out-of-plane motion), the safe convex condition eq 15, (c) lighting against the
   sun direction.
3. Per grasp instant that passed, per offset delta r (section 4.3 leaves it "to be set considering
   capturing manipulation capability": searched from offset_min_m to offset_max_m, the
   manipulator's reach less its position tolerance; an offset whose X_Ft touches the target with the attitude
   known exactly is dropped at once) and per fly-by duration (flyby_duration_s and longer, up to
   flyby_duration_max_s): X_Ft, X_Fi; X_Fi outside the thruster-restriction sphere; the
   eq 28-29 impulses within the per-maneuver limit; the transfer, with its execution spread, outside the sphere.
4. Passive safety and the predicted miss, in order of total delta-v: the coast through X_Ft at the grasp time,
   backward to X_Fi and forward over escape_check_orbits orbits (nonlinear relative dynamics,
   flyby_sim.dynamics.orbital), must keep the chaser envelope clearance_margin_m from the target.
   The target is the region it sweeps about its angular momentum (keepout.SweptRegion, good for
   any timing); within geometry_window_s of the grasp, where the swept region is too coarse (a grasp
   point inside the cylinder the panels sweep), the target's *predicted* geometry at each instant
   counts instead. Both are shrunk there by the planner's uncertainty model (EstimateAccuracy,
   _TargetUncertainty): 3 sigma of the target estimate the last burn is computed from (its attitude error
   times |r|) and of the chaser's dispersion from that burn on. Guidance's last burn is where the arc is
   still LAST_BURN_SLACK_M beyond the sphere and its burn margin (or the injection); over the unguided coast
   from there the navigation estimate's error (the navigation filter's steady state), the last burn's
   execution error and the target estimate's error at X_Ft give the predicted 3-sigma miss at the grasp,
   which must be within the manipulator's tolerances (it replaces a fixed bound on the coast).
5. Selection, in stages (PlannerConfig.search_stages): the preferred offset and duration (the
   paper's choice) first, then the other offsets, then longer fly-bys; within the first stage that holds a safe
   plan, the least total delta-v of the terminal transfer, and plans within delta_v_tie_mps of it tie and the
   larger least clearance wins. Candidates checked in no stage (dearer than a safe plan, or in a later stage) have
   status 'unchecked'.
"""

import collections
import dataclasses
import functools
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import solve_discrete_are

from flyby_estimation.target_motion import (
    ErrorStateDynamics,
    MotionPrediction,
    body_point_in_hill,
    perturbed_predictions,
)
from flyby_planner.grasp import (
    REFINE_HORIZON_S,
    flyby_initial_point,
    flyby_target_point,
    grasp_candidates,
    refine_grasp,
)
from flyby_planner.keepout import swept_region
from flyby_planner.transfer import terminal_impulses
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.geometry import signed_distance_to_box
from flyby_sim.dynamics.orbital import (
    cw_coast,
    cw_transition_matrix,
    eci_vector_in_hill,
    hill_axes_in_eci,
    nonlinear_relative_accel,
    q_eci_from_body,
)

# Samples of the target motion for the swept region (a tumbler's polhode) and of the passive path.
_REGION_SAMPLES = 64
_PATH_STEP_S = 1.0
_PUBLISHED_PATH_POINTS = 1500
# Below this inertial rate (0.01 deg/s, category I's hold rate) there is no turn to time a grasp with.
_MIN_SPIN_RAD_S = math.radians(0.01)
# The searched offsets are this far apart [m]; fly-by durations are these multiples of flyby_duration_s.
_OFFSET_STEP_M = 0.2
# Half the preferred fly-by comes last: a fast grasp point's X_Fi is then nearer and its injection smaller.
_DURATION_FACTORS = (1.0, 1.5, 2.0, 3.0, 0.5)
# The grasp window holds at least this many turns of the target relative to hill; the transfer is
# kept below this fraction of an orbit (eq 28's Phi12 is singular at half an orbit, out of plane).
_WINDOW_TURNS = 2.0
_TRANSFER_CAP_ORBITS = 0.4
# The passage is sampled so that the target's surface moves at most this far between samples [m].
_FINE_STEP_M = 0.02
# Candidates checked for passive safety at once, in order of delta-v.
_BATCH = 12
# Guidance's last adjusting burn is where the passive arc is still this far beyond the restriction
# sphere and its burn margin [m] (flyby_guidance.guidance, arc law); from there the chaser coasts.
LAST_BURN_SLACK_M = 2.0
# A prediction's attitude uncertainty, where it carries its covariance, counts at this many sigma.
UNCERTAINTY_SIGMAS = 3.0
# The re-aim check's inflation of the target filter's published covariance at the plan time (_ReaimModel): over the
# fourth campaign's five failures its mean NEES was 2.1-3.4 (3 expected), the variance scaled to the worst mean. Not
# to run 569's ~10 over a stretch: at 10 / 3 the check refused envelope run 156's capture (docs/campaigns.md).
REAIM_COVARIANCE_SCALE = 3.4 / 3.0
# The re-aim check sums each principal direction's effect, a model linear in the plan estimate's error: where its
# 3-sigma motions part by more than this at the grasp it vouches for nothing and refuses (envelope run 810, an
# extended-window grasp 2288 s out: 171 deg, flown, no grasp near the planned one, ESCAPE; 323, 2343 s out: 27.5 deg;
# 569: 5.5 deg). A chosen bound, not derived.
REAIM_MAX_PARTING_RAD = math.radians(30.0)
# Points of the terminal transfer checked against the restriction sphere.
_TRANSFER_SAMPLES = 60
# The target filter's covariance is predicted over substeps that turn the body by at most this [rad] and last at
# most this [s]: against 0.1 s / 0.01 rad substeps its sigmas agree to 2 % over 600 s (envelope runs 1, 40, 43,
# 77, 95, 153, 400; docs/planner.md).
_COVARIANCE_STEP_RAD = 0.3
_COVARIANCE_STEP_S = 20.0


@dataclasses.dataclass(frozen=True)
class EstimateAccuracy:
    """What the planner predicts the estimators will know at the last burn, from their sensors and tuning
    (scenario sections sensors and estimation; module doc, step 4).

    Attributes:
        position_sigma_m, position_rate_hz: relative-position sensor, 1 sigma per hill axis [m] and rate [Hz].
        accel_psd_m2_s3: the navigation filter's white-acceleration density q [m^2/s^3].
        attitude_sigma_rad, attitude_rate_hz: vision attitude sensor, 1 sigma per body axis [rad] and rate [Hz].
        torque_psd_n2m2s: the target filter's torque-noise density [N^2 m^2 s].
        converged_attitude_3sigma_rad, converged_rate_3sigma_rad_s: the target filter's convergence bounds; the
            plan's estimate is converged, so its covariance is within them.
    """

    position_sigma_m: float
    position_rate_hz: float
    accel_psd_m2_s3: float
    attitude_sigma_rad: float
    attitude_rate_hz: float
    torque_psd_n2m2s: float
    converged_attitude_3sigma_rad: float
    converged_rate_3sigma_rad_s: float

    def __post_init__(self):
        for name in ('position_sigma_m', 'position_rate_hz', 'attitude_sigma_rad', 'attitude_rate_hz',
                     'converged_attitude_3sigma_rad', 'converged_rate_3sigma_rad_s'):
            require_positive(name, getattr(self, name))
        for name in ('accel_psd_m2_s3', 'torque_psd_n2m2s'):
            require_positive(name, getattr(self, name), allow_zero=True)

    @functools.cached_property
    def navigation_covariance(self):
        """6x6 covariance of the navigation estimate [r; v] (hill; m, m/s) between burns: the steady state (a
        posteriori) of its per-axis Kalman filter, Phi = [[1, dt], [0, 1]], Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]],
        H = [1 0], R = sigma^2 at dt = 1 / rate (flyby_estimation.relative_nav, whose CW coupling over dt is
        O(n dt) ~ 1e-4). Flown envelope runs report this sigma at their last burn to the fourth digit."""
        dt = 1.0 / self.position_rate_hz
        q = self.accel_psd_m2_s3
        phi = np.array(((1.0, dt), (0.0, 1.0)))
        h = np.array(((1.0, 0.0),))
        r = self.position_sigma_m ** 2
        prior = solve_discrete_are(phi.T, h.T, q * np.array(((dt ** 3 / 3.0, dt ** 2 / 2.0), (dt ** 2 / 2.0, dt))),
                                   np.array(((r,),)))
        axis = prior - prior @ h.T @ h @ prior / (prior[0, 0] + r)  # P+ = P- - P- H' (H P- H' + R)^-1 H P-
        cov = np.zeros((6, 6))
        for k in range(3):
            cov[np.ix_((k, k + 3), (k, k + 3))] = axis
        return cov

    @property
    def converged_covariance(self):
        """6x6 bound of the converged target estimate's covariance of [dtheta_body, domega_body]: each block's
        worst direction at its convergence bound, and twice that (a covariance is at most twice its
        block-diagonal part, whatever the attitude-rate correlation)."""
        return 2.0 * np.diag([(self.converged_attitude_3sigma_rad / 3.0) ** 2] * 3
                             + [(self.converged_rate_3sigma_rad_s / 3.0) ** 2] * 3)


@dataclasses.dataclass(frozen=True)
class PlannerConfig:
    """Everything ``plan_capture`` needs besides the prediction and the chaser state.

    Attributes (SI; angles in rad): see the ``planner`` section of docs/scenario.md for the meaning
    and the seed 000 example defaults; ``boxes`` is flyby_sim.scenario.Boxes. offset_min_m,
    offset_max_m and flyby_duration_max_s None: offset_m and flyby_duration_s only (no search).
    accuracy (EstimateAccuracy, from the sensors and estimation sections) turns on the planner's uncertainty
    model (module doc, step 4), with the manipulator's position_tolerance_m and velocity_tolerance_mps as the bound
    on the predicted miss, guidance's adjust_interval_s and command_lead_s for the last burn; None keeps the fixed
    geometry_attitude_margin_rad + geometry_rate_margin_rad_s and no miss bound. reaim_check (with accuracy and a
    covariance passed to plan_capture): check the passage guidance flies once it re-aims at 3 sigma of the plan
    estimate's covariance (_ReaimModel). A caller without the estimate's covariance (a plan from the truth) gets no
    re-aim check: the convergence bound instead is 2-5 times the filter's sigma and its motions part by more than
    REAIM_MAX_PARTING_RAD 453 s out on paper_flyby, refusing what flies (docs/campaigns.md).
    """

    mean_motion_rad_s: float
    orbit_radius_m: float
    x_grasp_body_m: np.ndarray
    boxes: object
    inertia_kg_m2: np.ndarray
    envelope_radius_m: float
    offset_m: float = 1.0
    offset_min_m: float | None = None
    offset_max_m: float | None = None
    flyby_duration_s: float = 300.0
    flyby_duration_max_s: float | None = None
    restriction_sphere_radius_m: float = 15.0
    sphere_margin_m: float = 1.0
    clearance_margin_m: float = 0.1
    escape_check_orbits: float = 1.0
    geometry_window_s: float = 300.0
    geometry_attitude_margin_rad: float = math.radians(2.0)
    geometry_rate_margin_rad_s: float = math.radians(0.02)
    max_rate_rad_s: float = math.radians(18.0)
    min_spin_axis_angle_from_orbit_normal_rad: float = math.radians(10.0)
    sun_direction_eci: np.ndarray | None = None
    max_sun_angle_from_grasp_velocity_rad: float = math.radians(100.0)
    maneuver_lead_s: float = 10.0
    transfer_min_s: float = 150.0
    transfer_max_s: float = 450.0
    delta_v_tie_mps: float = 0.001
    max_delta_v_per_maneuver_mps: float = math.inf
    impulse_error_sigma: float = 0.0
    midcourse_corrections: int = 1
    accuracy: EstimateAccuracy | None = None
    position_tolerance_m: float = math.inf
    velocity_tolerance_mps: float = math.inf
    adjust_interval_s: float = 20.0
    command_lead_s: float = 5.0
    latest_grasp_s: float = math.inf
    reaim_check: bool = True

    def __post_init__(self):
        for name in ('mean_motion_rad_s', 'orbit_radius_m', 'envelope_radius_m', 'offset_m', 'flyby_duration_s',
                     'restriction_sphere_radius_m', 'escape_check_orbits', 'max_rate_rad_s', 'maneuver_lead_s',
                     'transfer_min_s', 'transfer_max_s', 'adjust_interval_s'):
            require_positive(name, getattr(self, name))
        for name in ('max_delta_v_per_maneuver_mps', 'position_tolerance_m', 'velocity_tolerance_mps'):
            require_positive(name, getattr(self, name), allow_inf=True)
        require_positive('command_lead_s', self.command_lead_s, allow_zero=True)
        require_positive('impulse_error_sigma', self.impulse_error_sigma, allow_zero=True)
        if self.midcourse_corrections < 0:
            raise ValueError(f'midcourse_corrections must be >= 0, got {self.midcourse_corrections}')
        if self.transfer_max_s < self.transfer_min_s:
            raise ValueError(f'transfer_max_s {self.transfer_max_s} s < transfer_min_s {self.transfer_min_s} s')
        lo, hi = self.offsets_range_m
        if not 0.0 < lo <= self.offset_m <= hi:
            raise ValueError(f'need 0 < offset_min_m {lo} <= offset_m {self.offset_m} <= offset_max_m {hi} [m]')
        if self.flyby_duration_max_s is not None and self.flyby_duration_max_s < self.flyby_duration_s:
            raise ValueError(f'flyby_duration_max_s {self.flyby_duration_max_s} s < flyby_duration_s '
                             f'{self.flyby_duration_s} s')

    @property
    def offsets_range_m(self):
        """(least, largest) offset delta r searched [m]."""
        return (self.offset_m if self.offset_min_m is None else self.offset_min_m,
                self.offset_m if self.offset_max_m is None else self.offset_max_m)

    @property
    def offsets_m(self):
        """The searched offsets delta r [m], the preferred offset_m first, then by distance from it."""
        lo, hi = self.offsets_range_m
        grid = {round(float(x), 9) for x in np.arange(lo, hi + 1e-9, _OFFSET_STEP_M)} | {self.offset_m, lo, hi}
        return tuple(sorted(grid, key=lambda d: (abs(d - self.offset_m), d)))

    @property
    def flyby_durations_s(self):
        """The searched fly-by durations [s], flyby_duration_s first."""
        top = self.flyby_duration_s if self.flyby_duration_max_s is None else self.flyby_duration_max_s
        return tuple(f * self.flyby_duration_s for f in _DURATION_FACTORS if f * self.flyby_duration_s <= top + 1e-9)

    @property
    def search_stages(self):
        """Sets of (offset, duration) searched in turn until one holds a safe plan: the preferred offset
        and fly-by duration, the other offsets at that duration, then each longer duration."""
        d0, *longer = self.flyby_durations_s
        return ([{(self.offset_m, d0)}, {(dr, d0) for dr in self.offsets_m[1:]}]
                + [{(dr, d) for dr in self.offsets_m} for d in longer])

    def transfer_max_for(self, rate_rel_rad_s):
        """Longest terminal transfer searched [s]: transfer_max_s, stretched until the grasp window holds
        _WINDOW_TURNS turns of a target turning at rate_rel_rad_s relative to hill, but below
        _TRANSFER_CAP_ORBITS orbits."""
        cap = _TRANSFER_CAP_ORBITS * 2.0 * math.pi / self.mean_motion_rad_s
        need = self.transfer_min_s + _WINDOW_TURNS * 2.0 * math.pi / rate_rel_rad_s if rate_rel_rad_s > 0 else cap
        return max(self.transfer_max_s, min(need, cap))

    def reaims(self, covariance_body):
        """Whether a plan with this target covariance checks the re-aimed passage (_ReaimModel): with the estimate
        accuracy model, reaim_check on and the plan estimate's covariance given."""
        return self.accuracy is not None and self.reaim_check and covariance_body is not None

    @property
    def transfer_cap_s(self):
        """Longest terminal transfer of the extended window [s] (_TRANSFER_CAP_ORBITS orbits)."""
        return _TRANSFER_CAP_ORBITS * 2.0 * math.pi / self.mean_motion_rad_s

    def search_window(self, rate_rel_rad_s, extended=False):
        """(earliest, latest) grasp time relative to the plan time [s] for a target turning at
        rate_rel_rad_s relative to hill; extended: with the transfers up to transfer_cap_s."""
        durations = self.flyby_durations_s
        transfer = self.transfer_cap_s if extended else self.transfer_max_for(rate_rel_rad_s)
        return (self.maneuver_lead_s + self.transfer_min_s + min(durations),
                self.maneuver_lead_s + max(transfer, self.transfer_max_for(rate_rel_rad_s)) + max(durations))

    def prediction_span_s(self, omega_body_rad_s, extended=False):
        """How far past the plan time the target prediction must reach [s] for a target of inertial body
        rate omega_body_rad_s (vector or magnitude): the grasp window (extended: the extended one) and the passage
        after it. The rate relative to hill is at least |omega| - n."""
        rate = float(np.linalg.norm(omega_body_rad_s))
        return self.search_window(max(rate - self.mean_motion_rad_s, 0.0), extended)[1] + self.geometry_window_s

    @property
    def escape_duration_s(self):
        return self.escape_check_orbits * 2.0 * math.pi / self.mean_motion_rad_s


def planner_config_from_scenario(scenario):
    """PlannerConfig of a flyby_msgs_py Scenario (planner section, chaser, target, estimation.spin_rate_deg_s)."""
    p = scenario.planner
    n = scenario.mean_motion_rad_s
    sun = None
    if p.sun_direction_hill is not None:
        sun = hill_axes_in_eci(0.0, n) @ np.asarray(p.sun_direction_hill, dtype=float)
    return PlannerConfig(
        mean_motion_rad_s=n, orbit_radius_m=scenario.orbit_radius_m,
        x_grasp_body_m=np.array(scenario.target.grasp_point_body_m), boxes=scenario.boxes,
        inertia_kg_m2=scenario.target_inertia, envelope_radius_m=scenario.chaser.envelope_radius_m,
        offset_m=p.offset_m, offset_min_m=min(p.offset_min_m, p.offset_m), offset_max_m=scenario.offset_max_m,
        flyby_duration_s=p.flyby_duration_s, flyby_duration_max_s=max(p.flyby_duration_max_s, p.flyby_duration_s),
        restriction_sphere_radius_m=p.restriction_sphere_radius_m, sphere_margin_m=scenario.guidance.sphere_margin_m,
        clearance_margin_m=p.clearance_margin_m, reaim_check=p.reaim_check,
        escape_check_orbits=p.escape_check_orbits, geometry_window_s=p.geometry_window_s,
        geometry_attitude_margin_rad=math.radians(p.geometry_attitude_margin_deg),
        geometry_rate_margin_rad_s=math.radians(p.geometry_rate_margin_deg_s),
        max_rate_rad_s=math.radians(scenario.estimation.spin_rate_deg_s),
        min_spin_axis_angle_from_orbit_normal_rad=math.radians(p.min_spin_axis_angle_from_orbit_normal_deg),
        sun_direction_eci=sun,
        max_sun_angle_from_grasp_velocity_rad=math.radians(p.max_sun_angle_from_grasp_velocity_deg),
        maneuver_lead_s=p.maneuver_lead_s, transfer_min_s=p.transfer_min_s, transfer_max_s=p.transfer_max_s,
        delta_v_tie_mps=p.delta_v_tie_mps,
        max_delta_v_per_maneuver_mps=scenario.chaser.thrusters.max_delta_v_per_maneuver_mps,
        impulse_error_sigma=math.hypot(scenario.chaser.thrusters.magnitude_error_sigma,
                                       math.radians(scenario.chaser.thrusters.direction_error_sigma_deg)),
        midcourse_corrections=scenario.guidance.midcourse_corrections,
        accuracy=estimate_accuracy_from_scenario(scenario),
        position_tolerance_m=scenario.chaser.manipulator.position_tolerance_m,
        velocity_tolerance_mps=scenario.chaser.manipulator.velocity_tolerance_mps,
        adjust_interval_s=scenario.guidance.adjust_interval_s, command_lead_s=scenario.guidance.command_lead_s,
        latest_grasp_s=scenario.simulation.duration_s - scenario.supervisor.capture_hold_s)


def estimate_accuracy_from_scenario(scenario):
    """EstimateAccuracy of a scenario's sensors and estimation sections."""
    s, e = scenario.sensors, scenario.estimation
    return EstimateAccuracy(
        position_sigma_m=s.relative_position.noise_sigma_m, position_rate_hz=s.relative_position.rate_hz,
        accel_psd_m2_s3=e.accel_psd_m2_s3, attitude_sigma_rad=math.radians(s.target_attitude.noise_sigma_deg),
        attitude_rate_hz=s.target_attitude.rate_hz, torque_psd_n2m2s=e.torque_psd_n2m2s,
        converged_attitude_3sigma_rad=math.radians(e.convergence_attitude_3sigma_deg),
        converged_rate_3sigma_rad_s=math.radians(e.convergence_rate_3sigma_deg_s))


def truth_prediction(scenario, t_end):
    """MotionPrediction of the scenario's true target motion from t = 0 to t_end (zero covariance).

    The offline planner (scripts/plan_capture.py) plans from this instead of an estimate.
    """
    n = scenario.mean_motion_rad_s
    return MotionPrediction(ErrorStateDynamics(scenario.target_inertia), n, 0.0,
                            q_eci_from_body(0.0, n, scenario.q_hill_from_body0), scenario.omega_body0_rad_s,
                            None, t_end, with_covariance=False)


@dataclasses.dataclass
class Candidate:
    """One grasp instant, offset and fly-by duration, and the fly-by built on them (hill, SI;
    velocities relative to hill).

    status: 'selected', 'safe' (passed every check, not chosen), 'rejected' (see reasons) or
    'unchecked' (passed steps 2-3, not checked for passive safety: a cheaper safe plan exists).
    clearance_approach_m / clearance_escape_m: least gap between the chaser envelope and the target
    from X_Fi to the grasp and over the escape (module doc, step 4); None when not propagated.
    closest: what the least gap is to (a box name from the predicted geometry, or 'swept region').
    t_sphere_entry: when the passive path enters the restriction sphere.
    unguided_coast_s: from the last burn guidance can fly (where the arc is still LAST_BURN_SLACK_M beyond the
    sphere and its burn margin, or the injection at t_i) to the grasp.
    miss_3sigma_m, miss_3sigma_mps: the predicted 3-sigma miss at the grasp (module doc, step 4), worst direction.
    reaim_gap_m: the least gap of the passage guidance will fly once it re-aims, at 3 sigma of the plan estimate
    (_ReaimModel); reaim_checked: None without that model, False until checked (then 'unchecked' if never).
    extended: its transfer is longer than the grasp window's (PlannerConfig.transfer_max_for): searched only when
    the window holds no safe plan.
    """

    t_grasp: float
    x_g: np.ndarray
    v_g: np.ndarray
    omega_hill: np.ndarray
    convex_value: float
    offset_m: float
    flyby_duration_s: float
    x_ft: np.ndarray
    v_ft: np.ndarray
    t_i: float
    x_fi: np.ndarray
    v_fi: np.ndarray
    t_ti: float
    dv_ti: np.ndarray
    dv_tf: np.ndarray
    reasons: list
    status: str = 'rejected'
    clearance_approach_m: float | None = None
    clearance_escape_m: float | None = None
    closest: str | None = None
    t_min_clearance: float | None = None
    t_sphere_entry: float | None = None
    unguided_coast_s: float | None = None
    miss_3sigma_m: float | None = None
    miss_3sigma_mps: float | None = None
    extended: bool = False
    reaim_gap_m: float | None = None
    reaim_checked: bool | None = None

    @property
    def dv_total_mps(self):
        return float(np.linalg.norm(self.dv_ti) + np.linalg.norm(self.dv_tf))

    @property
    def clearance_min_m(self):
        if self.clearance_approach_m is None:
            return None
        return min(self.clearance_approach_m, self.clearance_escape_m)

    def to_dict(self):
        """Plain-Python summary (JSON)."""
        def vec(a):
            return [round(float(x), 6) for x in a]
        return {
            't_grasp_s': round(self.t_grasp, 4), 'status': self.status, 'reasons': list(self.reasons),
            'offset_m': round(self.offset_m, 6), 'flyby_duration_s': round(self.flyby_duration_s, 4),
            'x_g_hill_m': vec(self.x_g), 'v_g_hill_mps': vec(self.v_g),
            'convex_value_m2_s2': float(f'{self.convex_value:.6g}'),
            'x_ft_hill_m': vec(self.x_ft), 'v_ft_hill_mps': vec(self.v_ft),
            't_i_s': round(self.t_i, 4), 'x_fi_hill_m': vec(self.x_fi), 'v_fi_hill_mps': vec(self.v_fi),
            't_ti_s': round(self.t_ti, 4), 'dv_ti_hill_mps': vec(self.dv_ti), 'dv_tf_hill_mps': vec(self.dv_tf),
            'dv_total_mps': round(self.dv_total_mps, 6),
            'clearance_approach_m': _rounded(self.clearance_approach_m),
            'clearance_escape_m': _rounded(self.clearance_escape_m), 'closest': self.closest,
            't_min_clearance_s': _rounded(self.t_min_clearance),
            't_sphere_entry_s': _rounded(self.t_sphere_entry), 'unguided_coast_s': _rounded(self.unguided_coast_s),
            'miss_3sigma_m': _rounded(self.miss_3sigma_m), 'miss_3sigma_mps': _rounded(self.miss_3sigma_mps),
            'reaim_gap_m': _rounded(self.reaim_gap_m), 'extended_window': self.extended,
        }


def _rounded(x):
    return None if x is None else round(float(x), 6)


@dataclasses.dataclass
class CapturePlan:
    """Result of plan_capture. ``ok`` False means refused; ``reason`` then says why in one line.

    path_t, path_r_hill: the predicted chaser path of the selected plan -- coast to the first burn,
    the terminal transfer (CW), the passive fly-by and the escape (nonlinear) -- for /planner/path.
    prediction: the target motion the selected plan was made on (the one given, or its extension over the
    extended window: it covers the grasp).
    """

    ok: bool
    reason: str
    t_plan: float
    selected: Candidate | None
    candidates: list
    region: object = None
    path_t: np.ndarray = None
    path_r_hill: np.ndarray = None
    prediction: object = None

    def to_dict(self):
        out = {'ok': self.ok, 'reason': self.reason, 't_plan_s': self.t_plan,
               'selected': self.selected.to_dict() if self.selected else None,
               'candidates': [c.to_dict() for c in self.candidates]}
        if self.region is not None:
            out['keep_out'] = {
                'axis_eci': [round(float(x), 9) for x in self.region.axis_eci],
                'cylinders': [{'name': nm, 'axial_m': [round(float(lo), 6), round(float(hi), 6)],
                               'radius_m': round(float(r), 6)}
                              for nm, lo, hi, r in zip(self.region.names, self.region.axial_min_m,
                                                       self.region.axial_max_m, self.region.radius_m, strict=True)]}
        return out


def _refused(reason, t_plan, candidates=(), region=None):
    return CapturePlan(ok=False, reason=reason, t_plan=t_plan, selected=None, candidates=list(candidates),
                       region=region)


def _deg(rad):
    return f'{math.degrees(rad):.3g} deg'


def _angle_from_orbit_normal(omega_hill):
    """Angle between the spin vector and the hill y axis, from condition (b)'s |Omega x w| / (|Omega| |w|)."""
    w = np.asarray(omega_hill, dtype=float)
    return math.asin(min(1.0, math.hypot(w[0], w[2]) / float(np.linalg.norm(w))))


def _rate_relative_to_hill(omega_hill, n):
    """|omega^H - Omega^H| [rad/s]: the target's turn rate as the hill frame sees it (eq 11)."""
    return float(np.linalg.norm(np.asarray(omega_hill, dtype=float) - np.array((0.0, -n, 0.0))))


def _propagate_passive(states0, t_end_s, config):
    """Nonlinear coast of several hill states (K, 6) at once over [0, t_end_s] (t_end_s may be negative);
    dense solution tau -> (6, K, len(tau))."""
    k = states0.shape[0]
    n, radius = config.mean_motion_rad_s, config.orbit_radius_m

    def rate(_, y):
        s = y.reshape(6, k)
        return np.concatenate((s[3:], nonlinear_relative_accel(s[:3], s[3:], n, radius))).ravel()

    sol = solve_ivp(rate, (0.0, t_end_s), states0.T.ravel(), method='DOP853', rtol=1e-10, atol=1e-9,
                    dense_output=True)
    if not sol.success:
        raise RuntimeError(f'passive-path propagation failed: {sol.message}')
    return lambda tau: sol.sol(tau).reshape(6, k, -1)


def _passive_gaps(states0, t0s, span_s, region, config):
    """Coast the hill states (K, 6), starting at the times t0s (K,), for span_s and sample their
    clearance from the swept region every _PATH_STEP_S.

    Returns (dense, tau (M,), states (6, K, M), gaps (K, M)); dense(tau) -> (6, K, len(tau)).
    """
    dense = _propagate_passive(states0, span_s, config)
    tau = np.linspace(0.0, span_s, int(math.ceil(span_s / _PATH_STEP_S)) + 1)
    states = dense(tau)
    gaps = np.array([region.clearance(states[:3, j, :].T, t0 + tau, config.mean_motion_rad_s,
                                      config.envelope_radius_m) for j, t0 in enumerate(t0s)])
    return dense, tau, states, gaps


@dataclasses.dataclass
class _Passage:
    """The passive path through one (grasp instant, offset): X_Ft, V_Ft at t_grasp, coasted back
    over the longest fly-by and on over the escape; its clearance profile on tau = t - t_grasp.

    tau (M,) and, per sample, gap (M,) [m] (with the fixed uncertainty model, or before any chaser dispersion: the
    larger of the swept-region gap and the predicted-geometry gap less the target's uncertainty), closest (M,) what
    it is to; r_tau (M',), radius (M',) |r| [m] on the coarse samples; coast_s, the unguided coast from the last
    burn guidance can fly on this arc to the grasp (guidance.py, arc law: where the arc is still LAST_BURN_SLACK_M
    beyond the sphere and its burn margin; the whole back span if it never is).

    With the planner's uncertainty model (_TargetUncertainty) also, per sample: swept (M,) the swept-region gap,
    predicted (M,) the predicted-geometry gap before any uncertainty (-inf where not sampled), lever (M,) |r| times
    the target estimate's 1-sigma attitude error there (seen from the estimate the last burn is computed from, at
    t_estimate), window (M,) whether the sample is within geometry_window_s of the grasp; and target_miss_cov, the
    6x6 covariance of X_Ft, V_Ft at the grasp from that estimate's error (seed 000 eq 8-9 and 20-21 linearized).
    """

    t_grasp: float
    tau: np.ndarray
    gap: np.ndarray
    closest: np.ndarray
    r_tau: np.ndarray
    radius: np.ndarray
    path: object  # tau (relative to t_grasp) -> (3, len(tau)) hill positions
    coast_s: float = None
    t_estimate: float = None
    swept: np.ndarray = None
    predicted: np.ndarray = None
    lever: np.ndarray = None
    window: np.ndarray = None
    names: np.ndarray = None
    target_miss_cov: np.ndarray = None

    def profile(self, chaser_cov, n):
        """(gap (M,), closest (M,)) with the chaser's dispersion counted (module doc, step 4): chaser_cov, the 6x6
        covariance of its state error at t_estimate, carried along CW (seed 000 eq 22) to each sample of the
        window after it; gap = the larger of swept - 3 sigma_c and predicted - 3 sqrt((|r| sigma_att)^2 +
        sigma_c^2), sigma_c the chaser's 1-sigma position error along its worst direction. None (or a passage
        without the uncertainty model): the gap as computed."""
        if chaser_cov is None or self.swept is None:
            return self.gap, self.closest
        sigma_c = self.chaser_sigma(chaser_cov, n)
        swept = self.swept - UNCERTAINTY_SIGMAS * sigma_c
        predicted = self.predicted - UNCERTAINTY_SIGMAS * np.hypot(self.lever, sigma_c)
        use_predicted = predicted > swept
        return (np.where(use_predicted, predicted, swept),
                np.where(use_predicted, self.names, 'swept region').astype(object))

    def chaser_sigma(self, chaser_cov, n):
        """(M,) sigma_c [m]: the chaser's 1-sigma position error along its worst direction at each sample of the
        window (zero outside), from chaser_cov at t_estimate carried along CW (seed 000 eq 22)."""
        # On a grid of _PATH_STEP_S over the window, interpolated to the samples (it grows smoothly).
        tau = self.tau[self.window]
        sigma_c = np.zeros(len(self.tau))
        if tau.size:
            grid = np.arange(tau.min(), tau.max() + _PATH_STEP_S, _PATH_STEP_S)
            stm = cw_transition_matrix(n, np.maximum(self.t_grasp + grid - self.t_estimate, 0.0))[:, :3, :]  # eq 22
            spread = np.einsum('mij,jk,mlk->mil', stm, chaser_cov, stm)
            sigma_c[self.window] = np.interp(tau, grid, np.sqrt(_largest_eigenvalue(spread)))
        return sigma_c


class _TargetUncertainty:
    """The target estimate's covariance the planner predicts over [t0, t_end] (default: the prediction's end;
    module doc, step 4).

    An EKF's covariance depends on the trajectory, not on the measured values, so the target filter's can be
    predicted along the predicted motion: from the converged estimate's bound at t0
    (EstimateAccuracy.converged_covariance; the Riccati recursion is monotone, so a larger start gives a larger
    covariance later), each substep P <- Phi P Phi' + Qd of seed 000 eq 4 linearized
    (ErrorStateDynamics.substep_transition_many, substeps of at most _COVARIANCE_STEP_S and _COVARIANCE_STEP_RAD),
    then the substep's vision measurements (f h of them, H = [I 0], sigma per body axis) fused at its end as one of
    their information, R = sigma^2 / (f h) I. Against the target filter's own covariance at the last burn of 16
    flown envelope runs (1-15 deg/s): attitude and rate sigmas within 1-10 % for the slow targets, and above it
    (up to 2x the rate sigma of a fast tumbler planned at a tight estimate) otherwise.

    covariance0 replaces the converged bound at t0 (a test against the filter's own covariance).
    ``filtered`` holds that covariance at the substep ends (the estimate guidance re-aims with at each burn);
    ``predicted(t_from, times)`` carries the estimate of t_from on to later times without measurements (the
    estimate of the last burn, seen from the grasp and the escape).
    """

    def __init__(self, prediction, t0, config, covariance0=None, t_end=None):
        acc = config.accuracy
        self.dynamics = ErrorStateDynamics(config.inertia_kg_m2, acc.torque_psd_n2m2s)
        inertia = np.asarray(config.inertia_kg_m2, dtype=float)
        omega0 = prediction.state(t0).omega_body
        # Torque-free: |omega| <= |H| / I_min at any time (seed 000 eq 4).
        rate_max = float(np.linalg.norm(inertia @ omega0)) / float(np.linalg.eigvalsh(inertia)[0])
        t_end = prediction.t_end if t_end is None else min(t_end, prediction.t_end)
        span = t_end - t0
        steps = max(1, math.ceil(span / _COVARIANCE_STEP_S), math.ceil(span * rate_max / _COVARIANCE_STEP_RAD))
        nodes = np.linspace(t0, t_end, steps + 1)
        c_hill_from_body = prediction.c_hill_from_body(nodes)
        omega_body = np.einsum('nji,nj->ni', c_hill_from_body, prediction.track(np.zeros(3), nodes).omega_hill)
        h = np.diff(nodes)
        self.phi, self.qd = self.dynamics.substep_transition_many(omega_body[:-1], omega_body[1:], h)
        self.nodes = nodes
        p = acc.converged_covariance if covariance0 is None else np.asarray(covariance0, dtype=float)
        filtered = [p]
        for k in range(steps):
            p = self.phi[k] @ p @ self.phi[k].T + self.qd[k]  # P = Phi P Phi' + Qd
            if h[k] > 0.0:
                s = p[:3, :3] + np.eye(3) * acc.attitude_sigma_rad ** 2 / (acc.attitude_rate_hz * h[k])  # S = HPH' + R
                gain = np.linalg.solve(s, p[:3, :]).T  # K = P H' S^-1
                p = p - gain @ p[:3, :]  # P = (I - K H) P
                p = 0.5 * (p + p.T)
            filtered.append(p)
        self.filtered = np.array(filtered)

    def predicted(self, t_from, times):
        """(N, 6, 6) covariance at the times (N,) [s] of the estimate of t_from carried on without measurements
        (before t_from: the filtered one). It starts from the substep end at or before t_from (fewer
        measurements: larger) and is linear in time between substep ends (above the covariance's convex growth)."""
        t = np.atleast_1d(np.asarray(times, dtype=float))
        nodes = self.nodes
        last = len(nodes) - 1
        k0 = int(np.clip(np.searchsorted(nodes, t_from, side='right') - 1, 0, last))
        k1 = int(np.clip(np.searchsorted(nodes, t.max(), side='left'), k0, last))
        chain = np.empty((k1 - k0 + 1, 6, 6))
        chain[0] = p = self.filtered[k0]
        for k in range(k0, k1):
            chain[k - k0 + 1] = p = self.phi[k] @ p @ self.phi[k].T + self.qd[k]  # P = Phi P Phi' + Qd
        out = np.empty((len(t), 6, 6))
        before = t < nodes[k0]
        if before.any():
            out[before] = self._interpolate(self.filtered, nodes, t[before])
        out[~before] = self._interpolate(chain, nodes[k0:k1 + 1], t[~before])
        return out

    @staticmethod
    def _interpolate(table, nodes, t):
        """Linear interpolation of the matrices table (K, 6, 6) at the nodes (K,) to the times t (clamped)."""
        if len(nodes) == 1:
            return np.broadcast_to(table[0], (len(t), 6, 6))
        i = np.clip(np.searchsorted(nodes, t, side='right') - 1, 0, len(nodes) - 2)
        w = np.clip((t - nodes[i]) / (nodes[i + 1] - nodes[i]), 0.0, 1.0)[:, None, None]
        return (1.0 - w) * table[i] + w * table[i + 1]

    def attitude_sigma_rad(self, t_from, times):
        """(N,) 1-sigma attitude error [rad] along its worst direction (predicted, above)."""
        return np.sqrt(_largest_eigenvalue(self.predicted(t_from, times)[:, :3, :3]))


def _largest_eigenvalue(a):
    """Largest eigenvalue (...,) of symmetric 3x3 matrices a (..., 3, 3), >= 0 (covariances), in closed form
    (the trigonometric solution of the characteristic cubic, O. K. Smith, Comm. ACM 4 (1961) 168), which is
    much faster than numpy's eigvalsh on many small matrices."""
    a = np.asarray(a, dtype=float)
    q = np.trace(a, axis1=-2, axis2=-1) / 3.0
    off = a[..., 0, 1] ** 2 + a[..., 0, 2] ** 2 + a[..., 1, 2] ** 2
    p = np.sqrt(((a[..., 0, 0] - q) ** 2 + (a[..., 1, 1] - q) ** 2 + (a[..., 2, 2] - q) ** 2 + 2.0 * off) / 6.0)
    safe = np.where(p > 0.0, p, 1.0)
    b = (a - q[..., None, None] * np.eye(3)) / safe[..., None, None]
    r = np.clip(np.linalg.det(b) / 2.0, -1.0, 1.0)
    return np.maximum(np.where(p > 0.0, q + 2.0 * p * np.cos(np.arccos(r) / 3.0), q), 0.0)


def _runs(mask):
    """(start, stop) index pairs of the runs of True in a boolean array (stop exclusive)."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(int), [0]))))
    return list(zip(edges[::2], edges[1::2], strict=True))


def _nearest_box(p_body, boxes):
    """Signed distance (N,) [m] from body points (N, 3) to the nearest target box, and that box's name (N,)."""
    dist = np.array([signed_distance_to_box(p_body, center, size)
                     for center, size in zip(boxes.center_body_m, boxes.size_m, strict=True)])
    nearest = np.argmin(dist, axis=0)
    return dist[nearest, np.arange(dist.shape[1])], np.asarray(boxes.names)[nearest]


def _predicted_distance(prediction, r_hill, t, config):
    """Gap [m] of the chaser envelope from the target's predicted geometry at each (r_hill (M, 3), t (M,)), with no
    uncertainty, and the nearest box's name per sample."""
    c_hb = prediction.c_hill_from_body(t)
    dist, names = _nearest_box(np.einsum('mji,mj->mi', c_hb, r_hill), config.boxes)  # C_hill_from_body' r
    return dist - config.envelope_radius_m, names


def _predicted_gaps(prediction, r_hill, t, t_grasp, config):
    """Gap [m] of the chaser envelope from the target's predicted geometry at each (r_hill (M, 3), t (M,)),
    less the prediction's uncertainty, and the nearest box's name per sample.

    The uncertainty is |r| times an attitude error: for a prediction that carries the estimate's
    covariance (guidance's gate), UNCERTAINTY_SIGMAS times its own propagated 1-sigma attitude error;
    otherwise (a PlannerConfig without EstimateAccuracy) the fixed model geometry_attitude_margin +
    geometry_rate_margin |t - t_g|. The planner with EstimateAccuracy uses _TargetUncertainty instead (_passages)."""
    gap, names = _predicted_distance(prediction, r_hill, t, config)
    if getattr(prediction, 'has_covariance', False):
        angle = UNCERTAINTY_SIGMAS * prediction.attitude_sigma_rad(t)
    else:
        angle = config.geometry_attitude_margin_rad + config.geometry_rate_margin_rad_s * np.abs(t - t_grasp)
    return gap - np.linalg.norm(r_hill, axis=1) * angle, names


def _passages(keys, states_at_grasp, prediction, region, config, back_s=None, uncertainty=None):
    """_Passage of each (t_grasp, offset) key from its hill state (6,) at the grasp (module doc, step 4),
    from back_s before the grasp (default: the longest fly-by) over the escape. With uncertainty
    (_TargetUncertainty) the passages carry the parts of the planner's uncertainty model (_Passage)."""
    n = config.mean_motion_rad_s
    back = max(config.flyby_durations_s) if back_s is None else back_s
    escape = config.escape_duration_s
    x0 = np.array(states_at_grasp)
    dense_back = _propagate_passive(x0, -back, config)
    dense_on = _propagate_passive(x0, escape, config)
    tau = np.concatenate((np.linspace(-back, 0.0, int(math.ceil(back / _PATH_STEP_S)) + 1)[:-1],
                          np.linspace(0.0, escape, int(math.ceil(escape / _PATH_STEP_S)) + 1)))
    r_all = np.concatenate((dense_back(tau[tau < 0.0]), dense_on(tau[tau >= 0.0])), axis=2)[:3]
    rate = max(float(np.linalg.norm(prediction.state(min(k[0], prediction.t_end)).omega_body)) for k in keys)
    burn_limit = config.restriction_sphere_radius_m + config.sphere_margin_m + LAST_BURN_SLACK_M
    out = {}
    for j, key in enumerate(keys):
        t_g = key[0]
        r = r_all[:, j, :].T
        radius = np.linalg.norm(r, axis=1)
        burnable = np.flatnonzero((tau <= 0.0) & (radius > burn_limit))
        coast = float(-tau[burnable[-1]]) if burnable.size else back
        swept = region.clearance(r, t_g + tau, n, config.envelope_radius_m)
        gap = swept.copy()
        closest = np.full(len(tau), 'swept region', dtype=object)
        # Near the grasp, where the swept region is too close, the predicted geometry at each instant.
        near = ((np.abs(tau) <= config.geometry_window_s) & (t_g + tau >= prediction.t0)
                & (t_g + tau <= prediction.t_end))
        danger = near & (gap < config.clearance_margin_m)
        danger = near & (danger | np.roll(danger, 1) | np.roll(danger, -1))
        keep = ~danger
        fine_tau = []
        speed = rate * region.bounding_radius_m + float(np.linalg.norm(x0[j, 3:]))
        step = min(max(_FINE_STEP_M / speed, 0.002), 0.25) if speed > 0.0 else 0.25
        for a, b in _runs(danger):
            lo, hi = tau[max(a - 1, 0)], tau[min(b, len(tau) - 1)]
            fine_tau.append(np.linspace(lo, hi, int(math.ceil((hi - lo) / step)) + 1))
        tau_k, gap_k, closest_k = tau[keep], gap[keep], closest[keep]
        swept_k, predicted_k = swept[keep], np.full(int(keep.sum()), -np.inf)
        names_k, radius_k = closest[keep], radius[keep]
        if fine_tau:
            tf = np.unique(np.concatenate(fine_tau))
            tf = tf[(t_g + tf >= prediction.t0) & (t_g + tf <= prediction.t_end)]
            # CW near the target: over a few hundred seconds within ~20 m it differs from the
            # nonlinear coast by far less than a micrometre.
            rf = np.einsum('mij,j->mi', cw_transition_matrix(n, tf), x0[j])[:, :3]
            swept_f = region.clearance(rf, t_g + tf, n, config.envelope_radius_m)
            if uncertainty is None:
                predicted, boxes = _predicted_gaps(prediction, rf, t_g + tf, t_g, config)
            else:
                predicted, boxes = _predicted_distance(prediction, rf, t_g + tf, config)
            use_predicted = predicted > swept_f
            order = np.argsort(np.concatenate((tau_k, tf)), kind='stable')
            tau_k = np.concatenate((tau_k, tf))[order]
            gap_k = np.concatenate((gap_k, np.where(use_predicted, predicted, swept_f)))[order]
            closest_k = np.concatenate((closest_k, np.where(use_predicted, boxes, 'swept region')))[order]
            swept_k = np.concatenate((swept_k, swept_f))[order]
            predicted_k = np.concatenate((predicted_k, predicted))[order]
            names_k = np.concatenate((names_k, boxes.astype(object)))[order]
            radius_k = np.concatenate((radius_k, np.linalg.norm(rf, axis=1)))[order]

        def path(tau_q, j=j):
            tau_q = np.atleast_1d(tau_q)
            xyz = np.empty((3, len(tau_q)))
            xyz[:, tau_q < 0.0] = dense_back(tau_q[tau_q < 0.0])[:3, j, :]
            xyz[:, tau_q >= 0.0] = dense_on(tau_q[tau_q >= 0.0])[:3, j, :]
            return xyz
        ps = _Passage(t_grasp=t_g, tau=tau_k, gap=gap_k, closest=closest_k, r_tau=tau, radius=radius, path=path,
                      coast_s=coast)
        if uncertainty is not None:
            _add_uncertainty(ps, x0[j], swept_k, predicted_k, names_k, radius_k, prediction, uncertainty, config)
        out[key] = ps
    return out


def _add_uncertainty(ps, state_at_grasp, swept, predicted, names, radius, prediction, uncertainty, config):
    """Fill the uncertainty parts of a passage (_Passage): the target estimate guidance computes the last burn
    from is that of command_lead_s before it; seen from there, |r| sigma_att at each sample within the window
    (the surface moves by |r| times the attitude error) and the covariance of X_Ft, V_Ft at the grasp, J P J' with
    J the Jacobian of the body point X_Ft^B (seed 000 eq 8-9, 20-21: X_Ft is a body point) and P the
    estimate's covariance carried to the grasp."""
    t_g = ps.t_grasp
    ps.t_estimate = t_g - ps.coast_s - config.command_lead_s
    window = np.abs(ps.tau) <= config.geometry_window_s
    window &= (t_g + ps.tau >= prediction.t0) & (t_g + ps.tau <= prediction.t_end)
    # On a grid of _PATH_STEP_S over the window (the sigma grows smoothly), interpolated to the samples.
    tau = ps.tau[window]
    grid = np.arange(tau.min(), tau.max() + _PATH_STEP_S, _PATH_STEP_S) if tau.size else tau
    cov = uncertainty.predicted(ps.t_estimate, np.concatenate(((t_g,), t_g + grid)))
    lever = np.zeros(len(ps.tau))
    if tau.size:
        lever[window] = radius[window] * np.interp(tau, grid, np.sqrt(_largest_eigenvalue(cov[1:, :3, :3])))
    ps.swept, ps.predicted, ps.lever, ps.window, ps.names = swept, predicted, lever, window, names
    at_grasp = prediction.state(t_g)
    c_hill_from_body = prediction.c_hill_from_body(np.array((t_g,)))[0]
    x_ft_body = c_hill_from_body.T @ state_at_grasp[:3]
    _, _, jac = body_point_in_hill(c_hill_from_body, at_grasp.omega_body, x_ft_body, config.mean_motion_rad_s)
    ps.target_miss_cov = jac @ cov[0] @ jac.T  # J P J'


def _sigma3(cov):
    """3 sigma [m or m/s] along the worst direction of a 3x3 covariance."""
    return UNCERTAINTY_SIGMAS * math.sqrt(float(_largest_eigenvalue(cov)))


def _chaser_error_at_estimate(c, coast_s, config):
    """6x6 covariance of the chaser's state error at the estimate guidance's last burn is computed from: the
    navigation estimate's (EstimateAccuracy.navigation_covariance) and the velocity error of the last burn.

    The last burn is the injection (eq 29, |dV_Tf|) when no adjusting burn fits between t_i and the last burnable
    instant (adjust_interval_s apart); each adjusting burn before the last corrects the one before to the
    thrusters' execution error, so the last burn's error is impulse_error_sigma^(k + 1) |dV_Tf| after k adjusting
    burns (isotropic: magnitude and pointing together)."""
    k = math.floor(max(c.flyby_duration_s - coast_s, 0.0) / config.adjust_interval_s)
    sigma_v = config.impulse_error_sigma ** (k + 1) * float(np.linalg.norm(c.dv_tf))
    cov = config.accuracy.navigation_covariance.copy()
    cov[3:, 3:] += sigma_v ** 2 * np.eye(3)
    return cov


def _miss(c, ps, chaser_cov, coast_s, config):
    """The predicted 3-sigma miss at the grasp ([m], [m/s], worst direction) and its parts [m]: the chaser's state
    error at the estimate carried along CW over the command lead and the coast (seed 000 eq 22), plus the target
    estimate's error at X_Ft (_add_uncertainty). Parts: navigation, last burn, target."""
    n = config.mean_motion_rad_s
    stm = cw_transition_matrix(n, coast_s + config.command_lead_s)
    nav = config.accuracy.navigation_covariance
    chaser = stm @ chaser_cov @ stm.T
    total = chaser + ps.target_miss_cov
    parts = (_sigma3((stm @ nav @ stm.T)[:3, :3]), _sigma3((stm @ (chaser_cov - nav) @ stm.T)[:3, :3]),
             _sigma3(ps.target_miss_cov[:3, :3]))
    return _sigma3(total[:3, :3]), _sigma3(total[3:, 3:]), parts


class _ReaimModel:
    """The true target motions the plan estimate allows, for the passage guidance will fly once it re-aims (module
    doc, step 4).

    Guidance re-aims every adjusting burn at the grasp re-solved from the latest estimate (grasp.refine_grasp, the
    same offset, eq 20-21), and by the last burn that estimate is close to the truth: the passage flown is the one
    through the *true* motion's grasp, not the plan's. The plan estimate's error, carried 500-700 s to the grasp,
    moves that passage against the target's parts by decimetres (envelope runs 499, 569, 810, 819, 869: their
    re-aimed arcs came -0.44 to -0.005 m from a panel where the plan's had 0.10-0.29 m; guidance refused to fly them
    and kept a stale aim or aborted). So the re-aim is checked against the motions of the plan estimate moved
    UNCERTAINTY_SIGMAS sigma along each principal direction of its covariance: the target filter's own at the plan
    time (covariance_body, 6x6 [dtheta_body, domega_body], target_motion.covariance_from_published) inflated by
    REAIM_COVARIANCE_SCALE; integrated in full (target_motion.perturbed_predictions): motions[0] is the estimate's,
    then the +- pairs."""

    def __init__(self, prediction, t_now, config, covariance_body):
        cov = REAIM_COVARIANCE_SCALE * np.asarray(covariance_body, dtype=float)
        if cov.shape != (6, 6) or not np.all(np.isfinite(cov)):
            raise ValueError(f'the plan estimate covariance must be a finite 6x6 matrix, got {covariance_body!r}')
        values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
        steps = UNCERTAINTY_SIGMAS * vectors * np.sqrt(np.maximum(values, 0.0))  # columns: 3 sigma along each
        errors = np.vstack([np.zeros(6)] + [sign * steps[:, k] for k in range(6) for sign in (1.0, -1.0)])
        s = prediction.state(t_now)
        self.t_plan, self.t_end = t_now, prediction.t_end
        self.errors = errors
        self.motions = perturbed_predictions(ErrorStateDynamics(config.inertia_kg_m2), config.mean_motion_rad_s,
                                             t_now, s.q_eci_from_body, s.omega_body, errors, prediction.t_end)


def _reaim_check(c, ps, chaser_cov, model, config):
    """The re-aimed passage of candidate c at 3 sigma of the plan estimate (_ReaimModel): (least gap [m], what it is
    to, when [s], the re-aim's 3-sigma spread there [m]), or None when the passage has no sample near the target
    (the swept region holds there at any timing).

    For each motion the grasp is re-solved as guidance does (refine_grasp near c's grasp time), X_Ft, V_Ft placed
    with c's offset (eq 20-21) and the arc coasted along CW (eq 22) over the samples where the planner checks the
    predicted geometry (those within the window, from X_Fi on), each at the same time from its own grasp; the gap
    of each motion's arc from that motion's geometry, e_k. Per principal direction the larger shortfall of its two
    motions below e_0 is its 3-sigma effect, and their root sum square the re-aim's 3-sigma spread S; with the
    last burn's uncertainty L = 3 sqrt((|r| sigma_att)^2 + sigma_c^2) (the planner's passage model) the gap is
    e_0 - sqrt(S^2 + L^2). A motion with no grasp near c's (the turn drifts out of reach), or motions parting by more
    than REAIM_MAX_PARTING_RAD at c's grasp, give -inf."""
    n = config.mean_motion_rad_s
    c_grasp = np.array([m.c_hill_from_body(np.array([c.t_grasp]))[0] for m in model.motions])
    cos_parting = (np.einsum('ij,kij->k', c_grasp[0], c_grasp[1:]) - 1.0) / 2.0  # (trace(C0' Ck) - 1) / 2
    parting = math.acos(float(np.clip(cos_parting.min(), -1.0, 1.0)))
    if parting > REAIM_MAX_PARTING_RAD:
        why = (f'its 3-sigma motions part by {math.degrees(parting):.0f} deg at the grasp (beyond '
               f'{math.degrees(REAIM_MAX_PARTING_RAD):.0f} deg the re-aim model vouches for nothing)')
        return -math.inf, why, c.t_grasp, math.inf
    near = np.flatnonzero(ps.window & np.isfinite(ps.predicted) & (ps.tau >= -c.flyby_duration_s))
    if not near.size:
        return None
    tau = ps.tau[near]
    stm = cw_transition_matrix(n, tau)
    gaps, names = [], None
    for motion in model.motions:
        g = refine_grasp(motion, config.x_grasp_body_m, c.t_grasp, n,
                         t_latest=min(c.t_grasp + REFINE_HORIZON_S, motion.t_end))
        if g is None:
            return -math.inf, 'no convex grasp re-solved near the planned one', c.t_grasp, math.inf
        x_ft, v_ft = flyby_target_point(g.x_g, g.v_g, c.offset_m)  # eq 20-21
        t = g.t_grasp + tau
        inside = (t >= motion.t0) & (t <= motion.t_end)
        gap = np.full(len(tau), math.inf)
        r = np.einsum('mij,j->mi', stm[inside], np.concatenate((x_ft, v_ft)))[:, :3]  # eq 22
        gap[inside], boxes = _predicted_distance(motion, r, t[inside], config)
        if names is None:
            names = np.full(len(tau), 'target', dtype=object)
            names[inside] = boxes
        gaps.append(gap)
    e0, pairs = gaps[0], np.array(gaps[1:]).reshape(-1, 2, len(tau))
    shortfall = np.maximum(e0 - pairs.min(axis=1), 0.0)
    spread = np.sqrt(np.sum(np.where(np.isfinite(shortfall), shortfall, 0.0) ** 2, axis=0))
    last_burn = UNCERTAINTY_SIGMAS * np.hypot(ps.lever[near], ps.chaser_sigma(chaser_cov, n)[near])
    total = e0 - np.hypot(spread, last_burn)
    i = int(np.argmin(total))
    return float(total[i]), str(names[i]), float(c.t_grasp + tau[i]), float(spread[i])


def _passes(c):
    """Checked, no reason against it, and its re-aim checked where the plan has the model."""
    return c.clearance_approach_m is not None and not c.reasons and c.reaim_checked is not False


def _check_passive_safety(batch, passages, prediction, region, config, uncertainty=None, reaim=None,
                          reaim_all=False):
    """Step 4 for a batch of candidates: fill their clearances, sphere entry, coast and predicted miss, reject the
    unsafe ones and those whose predicted miss exceeds the manipulator's tolerances; with reaim (_ReaimModel), those
    whose re-aimed passage (_reaim_check) keeps less than the margin, in order of delta-v up to the cheapest that
    passes and its ties (reaim_all: every one)."""
    new = {}
    for c in batch:
        key = (c.t_grasp, c.offset_m)
        if key not in passages and key not in new:
            new[key] = np.concatenate((c.x_ft, c.v_ft))
    if new:
        passages.update(_passages(list(new), list(new.values()), prediction, region, config,
                                  uncertainty=uncertainty))
    for c in batch:
        ps = passages[(c.t_grasp, c.offset_m)]
        c.unguided_coast_s = min(ps.coast_s, c.flyby_duration_s)
        chaser_cov = None
        if uncertainty is not None:
            chaser_cov = _chaser_error_at_estimate(c, ps.coast_s, config)
            c.miss_3sigma_m, c.miss_3sigma_mps, parts = _miss(c, ps, chaser_cov, c.unguided_coast_s, config)
        gap_all, closest_all = ps.profile(chaser_cov, config.mean_motion_rad_s)
        inside = ps.tau >= -c.flyby_duration_s
        tau, gap, closest = ps.tau[inside], gap_all[inside], closest_all[inside]
        approach = tau <= 0.0
        c.clearance_approach_m = float(gap[approach].min())
        c.clearance_escape_m = float(gap[~approach].min())
        i = int(np.argmin(gap))
        c.closest = str(closest[i])
        c.t_min_clearance = float(c.t_grasp + tau[i])
        entered = np.flatnonzero((ps.r_tau >= -c.flyby_duration_s) & (ps.radius <= config.restriction_sphere_radius_m))
        c.t_sphere_entry = float(c.t_grasp + ps.r_tau[entered[0]]) if entered.size else None
        if uncertainty is not None and (c.miss_3sigma_m > config.position_tolerance_m
                                        or c.miss_3sigma_mps > config.velocity_tolerance_mps):
            c.reasons.append(f'predicted 3-sigma miss at the grasp {c.miss_3sigma_m:.3f} m, '
                             f'{c.miss_3sigma_mps * 1e3:.2f} mm/s exceeds the manipulator tolerance '
                             f'{config.position_tolerance_m:g} m, {config.velocity_tolerance_mps * 1e3:g} mm/s '
                             f'(navigation {parts[0]:.3f} m, last burn {parts[1]:.3f} m, target {parts[2]:.3f} m '
                             f'over an unguided coast of {c.unguided_coast_s:.0f} s)')
        if gap[i] < config.clearance_margin_m:
            part = 'approach' if tau[i] <= 0.0 else 'escape'
            c.reasons.append(f'passive {part} clearance {gap[i]:.3f} m from the {c.closest} at t = '
                             f'{c.t_grasp + tau[i]:.1f} s is below the margin {config.clearance_margin_m:g} m')
    if reaim is None:
        return
    cheapest = math.inf
    for c in sorted((c for c in batch if not c.reasons), key=lambda c: c.dv_total_mps):
        c.reaim_checked = False
        if not reaim_all and c.dv_total_mps > cheapest + config.delta_v_tie_mps:
            continue
        c.reaim_checked = True
        ps = passages[(c.t_grasp, c.offset_m)]
        found = _reaim_check(c, ps, _chaser_error_at_estimate(c, ps.coast_s, config), reaim, config)
        if found is None:
            cheapest = min(cheapest, c.dv_total_mps)
            continue
        c.reaim_gap_m, closest, t_gap, spread = found
        if not math.isfinite(c.reaim_gap_m):
            c.reasons.append(f'the re-aimed passage: with the plan estimate 3 sigma off over '
                             f'{c.t_grasp - reaim.t_plan:.0f} s, {closest}')
        elif c.reaim_gap_m < config.clearance_margin_m:
            c.reasons.append(f'the re-aimed passage: with the plan estimate 3 sigma off over '
                             f'{c.t_grasp - reaim.t_plan:.0f} s, the arc through the re-solved grasp comes '
                             f'{c.reaim_gap_m:.3f} m from the {closest} at t = {t_gap:.1f} s (re-aim spread '
                             f'{spread:.3f} m), below the margin {config.clearance_margin_m:g} m')
        else:
            cheapest = min(cheapest, c.dv_total_mps)


def _predicted_region(prediction, t_from, config):
    """The swept region (keepout.SweptRegion) of the predicted motion from t_from to the prediction's end."""
    samples = [prediction.state(t) for t in np.linspace(t_from, prediction.t_end, _REGION_SAMPLES)]
    return swept_region(config.boxes, config.inertia_kg_m2, [s.q_eci_from_body for s in samples],
                        [s.omega_body for s in samples])


@dataclasses.dataclass(frozen=True)
class PassageCheck:
    """Step 4 for one passive arc: its least gap [m] from the target, what that gap is to (a box of the
    predicted geometry or 'swept region') and when [s]; safe when the gap keeps clearance_margin_m."""

    gap_m: float
    closest: str
    t_min_gap: float
    margin_m: float

    @property
    def safe(self):
        return self.gap_m >= self.margin_m


def check_passage(prediction, x_ft, v_ft, t_grasp, t_from, config, margin_m=None):
    """The passive-safety check of step 4 for the arc through X_Ft, V_Ft at t_grasp (hill, velocity
    relative to hill), coasted from t_from over the grasp and the escape: the predicted geometry less
    its uncertainty near the grasp (3 sigma of the prediction's own covariance if it carries one), the
    swept region elsewhere; safe when the least gap keeps margin_m (default: the planning margin,
    clearance_margin_m). Guidance runs it on every re-aimed arc before
    it flies onto it (flyby_guidance.guidance_core); ``prediction`` covers [t_from,
    t_grasp + geometry_window_s] for the predicted geometry to count over the whole passage."""
    region = _predicted_region(prediction, max(t_from, prediction.t0), config)
    key = (float(t_grasp), 0.0)
    ps = _passages([key], [np.concatenate((x_ft, v_ft))], prediction, region, config,
                   back_s=max(float(t_grasp) - t_from, 0.0))[key]
    later = ps.tau >= t_from - t_grasp
    i = int(np.argmin(np.where(later, ps.gap, np.inf)))
    return PassageCheck(gap_m=float(ps.gap[i]), closest=str(ps.closest[i]), t_min_gap=float(t_grasp + ps.tau[i]),
                        margin_m=config.clearance_margin_m if margin_m is None else margin_m)


def _select(candidates, config):
    """Step 5 among the checked candidates (one stage's): least total delta-v; within delta_v_tie_mps of
    it the larger least clearance wins."""
    safe = [c for c in candidates if _passes(c)]
    for c in safe:
        c.status = 'safe'
    if not safe:
        return None
    cheapest = min(c.dv_total_mps for c in safe)
    tied = [c for c in safe if c.dv_total_mps <= cheapest + config.delta_v_tie_mps]
    chosen = max(tied, key=lambda c: c.clearance_min_m)
    chosen.status = 'selected'
    return chosen


def _path(chosen, r_now, v_now, t_now, passage, config):
    """Predicted chaser path of the chosen plan (times (M,), hill positions (M, 3))."""
    n = config.mean_motion_rad_s
    t_coast = np.linspace(t_now, chosen.t_ti, 20)
    coast = np.array([cw_coast(r_now, v_now, t - t_now, n) for t in t_coast])
    r_ti, v_ti = coast[-1, :3], coast[-1, 3:] + chosen.dv_ti
    t_transfer = np.linspace(chosen.t_ti, chosen.t_i, 200)
    transfer = np.array([cw_coast(r_ti, v_ti, t - chosen.t_ti, n) for t in t_transfer])
    # Coarse over the orbit, every 0.5 s for a minute either side of the passage.
    lo, hi = -chosen.flyby_duration_s, config.escape_duration_s
    tau = np.union1d(np.linspace(lo, hi, _PUBLISHED_PATH_POINTS), np.arange(max(-60.0, lo), min(60.0, hi), 0.5))
    passive = passage.path(tau).T
    t = np.concatenate((t_coast, t_transfer[1:], chosen.t_grasp + tau[1:]))
    r = np.concatenate((coast[:, :3], transfer[1:, :3], passive[1:]))
    return t, r


# Classes of rejection, by the start of the reason, and the step of the checks that makes it (module doc: the
# grasp instant's conditions, X_Fi, the transfer's impulses, the transfer's path, then the passage and the miss).
_REASON_CLASSES = (
    ('condition (a)', 'condition (a), rate', 0), ('condition (b)', 'condition (b), spin axis near hill y', 0),
    ('not convex', 'not convex (eq 15)', 0), ('condition (c)', 'condition (c), lighting', 0),
    ('X_Fi', 'X_Fi inside the restriction sphere', 1), ('transfer impulse', 'transfer impulse above the limit', 2),
    ('transfer passes', 'transfer through the restriction sphere', 3),
    ('predicted 3-sigma miss', 'predicted miss above the tolerance', 4),
    ('passive', 'passive clearance below the margin', 4),
    ('the re-aimed passage', 'the re-aimed passage below the margin', 5),
)


def _reason_class(reason):
    return next((label for prefix, label, _ in _REASON_CLASSES if reason.startswith(prefix)), reason)


def _reason_step(label):
    return next((step for _, name, step in _REASON_CLASSES if name == label), -1)


def _refusal_reason(candidates, region, config):
    """One line: how many candidates fell to each class of reason, the classes of the latest check first (what
    bound the candidates that came furthest, e.g. the passage or the miss, before the many a short fly-by's X_Fi
    rejects at once), then by count; the best clearance found and, when a part of the target sweeps through the
    grasp point, which."""
    counts = collections.Counter(_reason_class(c.reasons[0]) for c in candidates if c.reasons)
    parts = [f'{k} {label}' for label, k in sorted(counts.items(), key=lambda item: (-_reason_step(item[0]),
                                                                                      -item[1], item[0]))]
    checked = [c for c in candidates if c.clearance_approach_m is not None]
    if checked:
        best = max(checked, key=lambda c: c.clearance_min_m)
        parts.append(f'best passive clearance {best.clearance_min_m:.3f} m (from the {best.closest}, offset '
                     f'{best.offset_m:g} m, fly-by {best.flyby_duration_s:g} s)')
        g = checked[0]
        own = _nearest_box(np.atleast_2d(config.x_grasp_body_m), config.boxes)[1][0]
        axial, radial = region.axial_radial(g.x_g[None, :], np.array([g.t_grasp]), config.mean_motion_rad_s)
        sweeping = [name for name, lo, hi, rad in zip(region.names, region.axial_min_m, region.axial_max_m,
                                                      region.radius_m, strict=True)
                    if lo <= axial[0] <= hi and radial[0] <= rad and name != own]
        if sweeping:
            parts.append('the grasp point lies in the region ' + ' and '.join(sweeping) + ' sweep'
                         + ('s' if len(sweeping) == 1 else ''))
    return f'all {len(candidates)} candidates rejected: ' + '; '.join(parts)


def _offset_gaps(config):
    """Gap [m] of the chaser envelope at the fly-by target point (eq 20) of each searched offset from the
    target's other parts, and the nearest box's name: with EstimateAccuracy the exact geometry (the uncertainty
    counts on the passage, per candidate), else less the fixed attitude uncertainty at the grasp.

    In body axes X_Ft = (1 + delta r / |x_g|) x_g for every grasp instant alike, so an offset that
    fails here fails at any grasp time."""
    x_g = np.asarray(config.x_grasp_body_m, dtype=float)
    radius = float(np.linalg.norm(x_g))
    points = np.array([(1.0 + dr / radius) * x_g for dr in config.offsets_m])
    dist, names = _nearest_box(points, config.boxes)
    angle = 0.0 if config.accuracy is not None else config.geometry_attitude_margin_rad
    gaps = dist - config.envelope_radius_m - np.linalg.norm(points, axis=1) * angle
    return {dr: (float(gap), str(name)) for dr, gap, name in zip(config.offsets_m, gaps, names, strict=True)}


def _grasp_reasons(g, config):
    """Step 2: conditions (a), (b), eq 15 and (c) of one grasp instant (reasons, empty if it passes)."""
    n = config.mean_motion_rad_s
    reasons = []
    rate_g = float(np.linalg.norm(g.omega_hill))
    if rate_g >= config.max_rate_rad_s:
        reasons.append(f'condition (a): rate {math.degrees(rate_g):.3g} deg/s >= {_deg(config.max_rate_rad_s)}/s')
    angle = _angle_from_orbit_normal(g.omega_hill)
    if angle < config.min_spin_axis_angle_from_orbit_normal_rad:
        reasons.append(f'condition (b): spin axis {_deg(angle)} from hill y < '
                       f'{_deg(config.min_spin_axis_angle_from_orbit_normal_rad)} (out-of-plane motion)')
    if not g.convex:
        reasons.append(f'not convex: eq 15 value {g.convex_value:.3g} m^2/s^2 <= 0')
    if config.sun_direction_eci is not None:
        sun = eci_vector_in_hill(config.sun_direction_eci, g.t_grasp, n)
        cos_sun = float(g.v_g @ sun) / (float(np.linalg.norm(g.v_g)) * float(np.linalg.norm(sun)))
        if cos_sun < math.cos(config.max_sun_angle_from_grasp_velocity_rad):
            reasons.append(f'condition (c): sun {_deg(math.acos(max(-1.0, cos_sun)))} from the grasp velocity > '
                           f'{_deg(config.max_sun_angle_from_grasp_velocity_rad)}')
    return reasons


def _candidate(g, offset_m, duration_s, t_ti, chaser_at_ti, reasons, config):
    """Step 3: the fly-by of one grasp instant, offset and duration (eq 20-23, 28-29) and its checks."""
    n = config.mean_motion_rad_s
    x_ft, v_ft = flyby_target_point(g.x_g, g.v_g, offset_m)  # eq 20-21
    x_fi, v_fi = flyby_initial_point(x_ft, v_ft, duration_s, n)  # eq 23
    reasons = list(reasons)
    if not reasons and np.linalg.norm(x_fi) <= config.restriction_sphere_radius_m:
        reasons.append(f'X_Fi at {np.linalg.norm(x_fi):.2f} m is inside the restriction sphere '
                       f'({config.restriction_sphere_radius_m:g} m)')
    t_i = g.t_grasp - duration_s
    dv_ti, dv_tf = terminal_impulses(chaser_at_ti[:3], chaser_at_ti[3:], x_fi, v_fi, t_i - t_ti, n)  # eq 28-29
    largest = max(np.linalg.norm(dv_ti), np.linalg.norm(dv_tf))
    if not reasons and largest > config.max_delta_v_per_maneuver_mps:
        reasons.append(f'transfer impulse {largest:.3f} m/s exceeds the per-maneuver limit '
                       f'{config.max_delta_v_per_maneuver_mps:g} m/s')
    if not reasons:
        # The transfer and its corrections thrust along the way: it must keep out of the sphere and the
        # guidance's burn margin (a midcourse burn there would end the mission), the first impulse's
        # execution error included.
        span = t_i - t_ti
        taus = np.linspace(0.0, span, _TRANSFER_SAMPLES)
        stm = cw_transition_matrix(n, taus)
        start = np.concatenate((chaser_at_ti[:3], chaser_at_ti[3:] + dv_ti))
        distance = np.linalg.norm(np.einsum('mij,j->mi', stm, start)[:, :3], axis=1)
        spread = _transfer_spread_m(taus, stm, span, float(np.linalg.norm(dv_ti)), config)
        k = int(np.argmin(distance - spread))
        limit = config.restriction_sphere_radius_m + config.sphere_margin_m
        if distance[k] - spread[k] < limit:
            reasons.append(f'transfer passes {distance[k]:.2f} m from the target at t = {t_ti + taus[k]:.1f} s, less '
                           f'{spread[k]:.2f} m of 3-sigma execution error: inside the restriction sphere and burn '
                           f'margin ({limit:g} m)')
    return Candidate(t_grasp=g.t_grasp, x_g=g.x_g, v_g=g.v_g, omega_hill=g.omega_hill, convex_value=g.convex_value,
                     offset_m=offset_m, flyby_duration_s=duration_s, x_ft=x_ft, v_ft=v_ft, t_i=t_i, x_fi=x_fi,
                     v_fi=v_fi, t_ti=t_ti, dv_ti=dv_ti, dv_tf=dv_tf, reasons=reasons)


def _transfer_spread_m(taus, stm, span_s, dv_mps, config):
    """3-sigma position spread [m] of the flown transfer about the planned one at the times taus (M,) after
    its first impulse dv_mps [m/s], with the CW transition matrices stm (M, 6, 6) (seed 000 eq 22).

    The impulse's execution error (config.impulse_error_sigma, relative, magnitude and pointing
    together) grows as |Phi_rv(tau)| up to the first midcourse correction, which re-solves eq 28 from
    where the chaser is: from there the spread shrinks to nothing at X_Fi (linearly, the re-solved
    transfer's own error being second order)."""
    growth = 3.0 * config.impulse_error_sigma * dv_mps * np.linalg.norm(stm[:, :3, 3:], ord=2, axis=(1, 2))
    t_mid = span_s / (config.midcourse_corrections + 1)
    if config.midcourse_corrections == 0:
        return growth
    at_mid = np.interp(t_mid, taus, growth)
    return np.where(taus <= t_mid, growth, at_mid * (span_s - taus) / (span_s - t_mid))


def plan_capture(prediction, r_chaser_hill, v_chaser_hill, t_now, config, covariance_body=None):
    """Plan a fly-by capture from the target prediction and the chaser state at t_now (module doc).

    Args:
        prediction: flyby_estimation.target_motion.MotionPrediction (or an object with the same
            ``state(t)``, ``track(x_body, times)``, ``c_hill_from_body(times)``, ``t0`` and ``t_end``)
            covering [t_now, t_now + config.search_window(rate)[1]]; where it reaches
            geometry_window_s further, the passage after the last grasp instants is checked against
            the predicted geometry too (config.prediction_span_s gives the full span).
        r_chaser_hill, v_chaser_hill: chaser position [m] and velocity relative to hill [m/s] at t_now.
        t_now: plan time [s] (sim time).
        config: PlannerConfig.
        covariance_body: the target estimate's 6x6 error covariance of [dtheta_body, domega_body] at t_now
            (target_motion.covariance_from_published), for the re-aim check (_ReaimModel); None: no re-aim check.

    Returns:
        CapturePlan; ok False with a one-line reason when the target cannot be captured by fly-by or
        no candidate is safe (each candidate's reasons are in ``candidates``).
    """
    n = config.mean_motion_rad_s
    r_now = np.asarray(r_chaser_hill, dtype=float)
    v_now = np.asarray(v_chaser_hill, dtype=float)
    if r_now.shape != (3,) or v_now.shape != (3,) or not (np.all(np.isfinite(r_now)) and np.all(np.isfinite(v_now))):
        raise ValueError(f'chaser state must be two finite 3-vectors, got r {r_chaser_hill!r}, v {v_chaser_hill!r}')
    if not prediction.t0 <= t_now <= prediction.t_end:
        raise ValueError(f'the prediction covers [{prediction.t0}, {prediction.t_end}] s, not the plan time {t_now} s')
    omega_now = prediction.state(t_now).omega_hill
    rate_rel = _rate_relative_to_hill(omega_now, n)
    w_lo, w_hi = (t_now + dt for dt in config.search_window(rate_rel))
    if prediction.t_end < w_hi:
        raise ValueError(f'the prediction covers [{prediction.t0}, {prediction.t_end}] s; planning at {t_now} s '
                         f'needs it up to {w_hi} s')
    # The extended window as far as the mission lasts (the prediction is carried on for it when it is searched);
    # the grasp window plans as it always did, a short test run ending on its time limit.
    w_ext = min(t_now + config.search_window(rate_rel, extended=True)[1], config.latest_grasp_s)

    # Condition (a) on the current motion: a fly-by needs category II/III (seed 000 section 2.1).
    rate = float(np.linalg.norm(omega_now))
    if rate >= config.max_rate_rad_s:
        return _refused(f'condition (a): target rate {math.degrees(rate):.3g} deg/s >= {_deg(config.max_rate_rad_s)}/s '
                        '(category IV, spinning: beyond the fly-by method, seed 000 section 2.1)', t_now)

    if rate < _MIN_SPIN_RAD_S:
        return _refused(f'target rate {math.degrees(rate):.3g} deg/s: no rotation to time a grasp with '
                        '(category I; approach it conventionally, seed 000 section 2.1)', t_now)

    offset_gaps = _offset_gaps(config)
    offsets = [dr for dr in config.offsets_m if offset_gaps[dr][0] >= config.clearance_margin_m]
    if not offsets:
        dr, (gap, box) = max(offset_gaps.items(), key=lambda item: item[1][0])
        lo, hi = config.offsets_range_m
        return _refused(f'no offset reaches the grasp point: at every offset {lo:g}-{hi:g} m the fly-by target '
                        f'point (eq 20) leaves the chaser envelope at most {gap:.3f} m from the {box} (margin '
                        f'{config.clearance_margin_m:g} m, '
                        + ('with the attitude known exactly' if config.accuracy is not None else
                           'attitude uncertainty included')
                        + f'), at any grasp time: the {box} blocks the grasp point', t_now)

    region = _predicted_region(prediction, t_now, config)

    t_ti = t_now + config.maneuver_lead_s
    chaser_at_ti = cw_coast(r_now, v_now, config.maneuver_lead_s, n)
    transfer_max = config.transfer_max_for(rate_rel)
    transfer_cap = max(config.transfer_cap_s, transfer_max)

    def build(found, extended):
        """The candidates of these grasp instants whose transfer is within the window (or, extended, beyond it)."""
        out = []
        for g in found:
            durations = [d for d in config.flyby_durations_s
                         if config.transfer_min_s <= g.t_grasp - d - t_ti <= transfer_cap
                         and (g.t_grasp - d - t_ti > transfer_max or g.t_grasp > w_hi) == extended
                         and (not extended or g.t_grasp <= config.latest_grasp_s)]
            if not durations:
                continue
            reasons = _grasp_reasons(g, config)
            if reasons:  # one entry per rejected grasp instant, at the first offset and duration searched
                out.append(_candidate(g, offsets[0], durations[0], t_ti, chaser_at_ti, reasons, config))
            else:
                out += [_candidate(g, dr, d, t_ti, chaser_at_ti, (), config) for d in durations for dr in offsets]
        for c in out:
            c.extended = extended
        return out

    # The grasp window first, stage by stage; if it holds no safe plan, the extended window (transfers up to the cap),
    # searched in full the same way: a budget there refused envelope run 340, whose safe plans lay in its second stage
    # past the first stage's failures (docs/campaigns.md).
    found = grasp_candidates(prediction, config.x_grasp_body_m, w_lo, w_hi, n) if w_hi > w_lo else []
    candidates = build(found, False)
    passages = {}
    uncertainty = reaim = None
    for extended in (False, True):
        if extended:
            if prediction.t_end < w_ext + config.geometry_window_s:
                prediction = _carried_on(prediction, t_now, w_ext + config.geometry_window_s, config)
                region = _predicted_region(prediction, t_now, config)
            if w_ext > w_hi:
                more = [g for g in grasp_candidates(prediction, config.x_grasp_body_m, max(w_lo, w_hi), w_ext, n)
                        if g.t_grasp > w_hi]
                found += more
            candidates += build(found, True)
        if config.accuracy is not None:
            horizon = min(prediction.t_end, (w_ext if extended else w_hi) + config.geometry_window_s)
            if uncertainty is None or uncertainty.nodes[-1] < horizon:
                uncertainty = _TargetUncertainty(prediction, t_now, config, t_end=horizon)
            if config.reaims(covariance_body) and (reaim is None or reaim.t_end < prediction.t_end):
                reaim = _ReaimModel(prediction, t_now, config, covariance_body)
        for stage in config.search_stages:
            pending = sorted((c for c in candidates if not c.reasons and c.extended == extended
                              and (c.offset_m, c.flyby_duration_s) in stage), key=lambda c: c.dv_total_mps)
            cheapest_safe = math.inf
            for start in range(0, len(pending), _BATCH):
                batch = pending[start:start + _BATCH]
                if batch[0].dv_total_mps > cheapest_safe + config.delta_v_tie_mps:
                    break
                _check_passive_safety(batch, passages, prediction, region, config, uncertainty, reaim)
                cheapest_safe = min([cheapest_safe] + [c.dv_total_mps for c in batch if _passes(c)])
            if cheapest_safe < math.inf:
                break
        if cheapest_safe < math.inf:
            break
    if not found:
        angle = _angle_from_orbit_normal(omega_now)
        why = (f'condition (b): spin axis {_deg(angle)} from hill y, the singular case of seed 000 section 3.3 '
               '(the grasp point never has zero y velocity)'
               if angle < config.min_spin_axis_angle_from_orbit_normal_rad else
               'the grasp point\'s hill y velocity does not change sign')
        return _refused(f'no grasp instant in [{w_lo:.1f}, {max(w_hi, w_ext):.1f}] s: {why}', t_now, region=region)
    for c in candidates:
        if not c.reasons and (c.clearance_approach_m is None or c.reaim_checked is False):
            c.status = 'unchecked'
    chosen = _select(candidates, config)
    if chosen is None:
        return _refused(_refusal_reason(candidates, region, config) if candidates else
                        f'no grasp instant in [{w_lo:.1f}, {max(w_hi, w_ext):.1f}] s is reachable with a transfer of '
                        f'{config.transfer_min_s:g}-{transfer_cap:g} s', t_now, candidates, region)
    path_t, path_r = _path(chosen, r_now, v_now, t_now, passages[(chosen.t_grasp, chosen.offset_m)], config)
    return CapturePlan(ok=True, reason='', t_plan=t_now, selected=chosen, candidates=candidates, region=region,
                       path_t=path_t, path_r_hill=path_r, prediction=prediction)


def _carried_on(prediction, t_now, t_end, config):
    """The prediction's motion from t_now carried on to t_end (a MotionPrediction without covariance from its
    state at t_now: the same torque-free motion, seed 000 eq 4), for the extended window."""
    s = prediction.state(t_now)
    return MotionPrediction(ErrorStateDynamics(config.inertia_kg_m2), config.mean_motion_rad_s, t_now,
                            s.q_eci_from_body, s.omega_body, None, t_end, with_covariance=False)


def avoidance_burn(r_hill, v_hill, t, region, config, dv_mps):
    """The collision-avoidance burn of an abort outside the restriction sphere, or None if none is needed.

    The chaser's coast from (r, v) at t is propagated (nonlinear) for escape_check_orbits orbits; if
    its envelope keeps clearance_margin_m from the swept region no burn is needed (the fly-by's
    passive safety, seed 000 section 4.1). Otherwise impulses of dv_mps along +-x, +-y, +-z and
    radially away from the target, and a retreat (cancel the closing speed, then dv_mps away), are
    tried and the one whose coast keeps the largest least clearance is returned.

    Returns:
        (dv_hill or None, least clearance of the coast without the burn [m], with it [m]).
    """
    r = np.asarray(r_hill, dtype=float)
    v = np.asarray(v_hill, dtype=float)
    away = r / np.linalg.norm(r) if np.linalg.norm(r) > 0.0 else np.array((1.0, 0.0, 0.0))
    closing = min(float(v @ away), 0.0)
    options = [np.zeros(3)] + [dv_mps * d for d in (*np.eye(3), *-np.eye(3), away)] + [(dv_mps - closing) * away]
    *_, gaps = _passive_gaps(np.array([np.concatenate((r, v + dv)) for dv in options]), [t] * len(options),
                             config.escape_duration_s, region, config)
    least = [float(g.min()) for g in gaps]
    if least[0] >= config.clearance_margin_m:
        return None, least[0], least[0]
    best = int(np.argmax(least[1:])) + 1
    return options[best], least[0], least[best]


@dataclasses.dataclass
class RefusalCheck:
    """Every fly-by of seed 000's form open at a plan time, checked (exhaustive_check).

    offsets_clear: offsets whose X_Ft (eq 20) clears the target with the attitude exact; grasp_instants and
    grasp_rejected: the roots of eq 13 in the grasp and extended windows and those failing (a)-(c) or eq 15;
    candidates: every offset x fly-by duration of the others, the transfer's conditions set aside; n_miss_ok,
    n_clear_ok, n_both: those whose predicted 3-sigma miss is within the manipulator's position and velocity
    tolerances, whose passive path keeps clearance_margin_m (the planner's checks), and both; n_flyable: both
    and a transfer that passes; the least miss, the largest clearance, each among the candidates that meet the
    other bound (None: none does).
    """

    offsets_clear: int
    grasp_instants: int = 0
    grasp_rejected: int = 0
    candidates: int = 0
    n_miss_ok: int = 0
    n_clear_ok: int = 0
    n_both: int = 0
    n_flyable: int = 0
    min_miss_m: float | None = None
    max_clearance_m: float | None = None
    min_miss_if_clear_m: float | None = None
    max_clearance_if_miss_ok_m: float | None = None
    coast_at_min_miss_s: float | None = None


def exhaustive_check(prediction, r_chaser_hill, v_chaser_hill, t_now, config, covariance_body=None):
    """Check every candidate plan_capture could fly, and more, for passive clearance and the predicted miss.

    The evidence that a refusal holds no safe and capturable fly-by (docs/campaigns.md, issue 12): every grasp
    instant of the grasp and extended windows (up to config.latest_grasp_s), every offset whose X_Ft clears
    the target, every fly-by duration, with the transfer's conditions (window, impulse, X_Fi outside the
    sphere) set aside; plan_capture searches a subset of these in stages and stops at the first safe stage.
    ``prediction`` must reach the extended window plus geometry_window_s; covariance_body as plan_capture's.
    Returns a RefusalCheck.
    """
    n = config.mean_motion_rad_s
    r_now = np.asarray(r_chaser_hill, dtype=float)
    v_now = np.asarray(v_chaser_hill, dtype=float)
    rate_rel = _rate_relative_to_hill(prediction.state(t_now).omega_hill, n)
    w_lo, w_hi = (t_now + dt for dt in config.search_window(rate_rel, extended=True))
    w_hi = min(w_hi, config.latest_grasp_s)
    offsets = [dr for dr, (gap, _name) in _offset_gaps(config).items() if gap >= config.clearance_margin_m]
    check = RefusalCheck(offsets_clear=len(offsets))
    if not offsets or w_hi <= w_lo:
        return check
    region = _predicted_region(prediction, t_now, config)
    uncertainty = _TargetUncertainty(prediction, t_now, config) if config.accuracy is not None else None
    reaim = _ReaimModel(prediction, t_now, config, covariance_body) if config.reaims(covariance_body) else None
    found = grasp_candidates(prediction, config.x_grasp_body_m, w_lo, w_hi, n)
    t_ti = t_now + config.maneuver_lead_s
    chaser_at_ti = cw_coast(r_now, v_now, config.maneuver_lead_s, n)
    transfer_cap = max(config.transfer_cap_s, config.transfer_max_for(rate_rel))
    candidates, transfer_ok = [], []
    for g in found:
        if _grasp_reasons(g, config):
            check.grasp_rejected += 1
            continue
        for duration in config.flyby_durations_s:
            if not config.transfer_min_s <= g.t_grasp - duration - t_ti <= transfer_cap:
                continue
            for dr in offsets:
                c = _candidate(g, dr, duration, t_ti, chaser_at_ti, (), config)
                transfer_ok.append(not c.reasons)
                c.reasons = []  # set aside: only the passage's checks reject below
                candidates.append(c)
    passages = {}
    for k in range(0, len(candidates), _BATCH):
        _check_passive_safety(candidates[k:k + _BATCH], passages, prediction, region, config, uncertainty, reaim,
                              reaim_all=True)
    check.grasp_instants, check.candidates = len(found), len(candidates)
    if not candidates:
        return check
    miss = np.array([math.inf if c.miss_3sigma_m is None else c.miss_3sigma_m for c in candidates])
    clearance = np.array([c.clearance_min_m for c in candidates])
    # The planner's own verdicts (_check_passive_safety's reasons), not the bounds stated again here.
    miss_ok = np.array([not any(r.startswith('predicted 3-sigma miss') for r in c.reasons) for c in candidates])
    clear_ok = np.array([not any(r.startswith(('passive', 'the re-aimed passage')) for r in c.reasons)
                         for c in candidates])
    transfer_ok = np.array(transfer_ok)
    check.n_miss_ok, check.n_clear_ok = int(miss_ok.sum()), int(clear_ok.sum())
    check.n_both, check.n_flyable = int((miss_ok & clear_ok).sum()), int((miss_ok & clear_ok & transfer_ok).sum())
    check.min_miss_m, check.max_clearance_m = float(miss.min()), float(clearance.max())
    check.min_miss_if_clear_m = float(miss[clear_ok].min()) if clear_ok.any() else None
    check.max_clearance_if_miss_ok_m = float(clearance[miss_ok].max()) if miss_ok.any() else None
    check.coast_at_min_miss_s = float(candidates[int(np.argmin(miss))].unguided_coast_s)
    return check
