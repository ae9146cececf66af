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
   searched fly-by duration; for a slow target the window is stretched to hold two turns.
2. Per grasp instant: condition (a) rate below the category III/IV limit, (b) spin axis away from
   hill y (no pure out-of-plane motion), the safe convex condition eq 15, (c) lighting against the
   sun direction.
3. Per grasp instant that passed, per offset delta r (section 4.3 leaves it "to be set considering
   capturing manipulation capability": searched from offset_min_m to offset_max_m, the
   manipulator's reach less its position tolerance) and per fly-by duration (flyby_duration_s and
   longer, up to flyby_duration_max_s): X_Ft, X_Fi; X_Fi outside the thruster-restriction sphere; the
   eq 28-29 impulses within the per-maneuver limit.
4. Passive safety, in order of total delta-v: the coast through X_Ft at the grasp time, backward to
   X_Fi and forward over escape_check_orbits orbits (nonlinear relative dynamics,
   flyby_sim.dynamics.orbital), must keep the chaser envelope clearance_margin_m from the target.
   The target is the region it sweeps about its angular momentum (keepout.SweptRegion, good for
   any timing); within geometry_window_s of the grasp, where the swept region is too coarse (a grasp
   point inside the cylinder the panels sweep), the target's *predicted* geometry at each instant
   counts instead, shrunk by its uncertainty: |r| (geometry_attitude_margin + geometry_rate_margin
   |t - t_g|), the attitude error at the grasp (guidance re-aims the grasp at the latest estimate,
   section 4.6) and the rate error carried away from it.
5. Selection, in stages (PlannerConfig.search_stages): the preferred offset and duration (the
   paper's choice) first, then the other offsets, then longer fly-bys; within the first stage that
   holds a safe plan, the least total delta-v of the terminal transfer, and plans within
   delta_v_tie_mps of it tie and the larger least clearance wins. Candidates checked in no stage
   (dearer than a safe plan, or in a later stage) have status 'unchecked'.
"""

import collections
import dataclasses
import math

import numpy as np
from scipy.integrate import solve_ivp

from flyby_estimation.target_motion import ErrorStateDynamics, MotionPrediction
from flyby_planner.grasp import flyby_initial_point, flyby_target_point, grasp_candidates
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
_DURATION_FACTORS = (1.0, 1.5, 2.0, 3.0)
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
# Points of the terminal transfer checked against the restriction sphere.
_TRANSFER_SAMPLES = 60


@dataclasses.dataclass(frozen=True)
class PlannerConfig:
    """Everything ``plan_capture`` needs besides the prediction and the chaser state.

    Attributes (SI; angles in rad): see the ``planner`` section of docs/scenario.md for the meaning
    and the seed 000 example defaults; ``boxes`` is flyby_sim.scenario.Boxes. offset_min_m,
    offset_max_m and flyby_duration_max_s None: offset_m and flyby_duration_s only (no search).
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
    max_unguided_coast_s: float = math.inf
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

    def __post_init__(self):
        for name in ('mean_motion_rad_s', 'orbit_radius_m', 'envelope_radius_m', 'offset_m', 'flyby_duration_s',
                     'restriction_sphere_radius_m', 'escape_check_orbits', 'max_rate_rad_s', 'maneuver_lead_s',
                     'transfer_min_s', 'transfer_max_s'):
            require_positive(name, getattr(self, name))
        require_positive('max_delta_v_per_maneuver_mps', self.max_delta_v_per_maneuver_mps, allow_inf=True)
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

    def search_window(self, rate_rel_rad_s):
        """(earliest, latest) grasp time relative to the plan time [s] for a target turning at
        rate_rel_rad_s relative to hill."""
        durations = self.flyby_durations_s
        return (self.maneuver_lead_s + self.transfer_min_s + min(durations),
                self.maneuver_lead_s + self.transfer_max_for(rate_rel_rad_s) + max(durations))

    def prediction_span_s(self, omega_body_rad_s):
        """How far past the plan time the target prediction must reach [s] for a target of inertial body
        rate omega_body_rad_s (vector or magnitude): the grasp window and the passage after it.
        The rate relative to hill is at least |omega| - n."""
        rate = float(np.linalg.norm(omega_body_rad_s))
        return self.search_window(max(rate - self.mean_motion_rad_s, 0.0))[1] + self.geometry_window_s

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
        max_unguided_coast_s=p.max_unguided_coast_s, clearance_margin_m=p.clearance_margin_m,
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
        midcourse_corrections=scenario.guidance.midcourse_corrections)


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
        }


def _rounded(x):
    return None if x is None else round(float(x), 6)


@dataclasses.dataclass
class CapturePlan:
    """Result of plan_capture. ``ok`` False means refused; ``reason`` then says why in one line.

    path_t, path_r_hill: the predicted chaser path of the selected plan -- coast to the first burn,
    the terminal transfer (CW), the passive fly-by and the escape (nonlinear) -- for /planner/path.
    """

    ok: bool
    reason: str
    t_plan: float
    selected: Candidate | None
    candidates: list
    region: object = None
    path_t: np.ndarray = None
    path_r_hill: np.ndarray = None

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

    tau (M,), gap (M,) [m] (the larger of the swept-region gap and the predicted-geometry gap less
    its uncertainty), closest (M,) what each gap is to, radius (M,) |r| [m] on the coarse samples.
    """

    t_grasp: float
    tau: np.ndarray
    gap: np.ndarray
    closest: np.ndarray
    r_tau: np.ndarray
    radius: np.ndarray
    path: object  # tau (relative to t_grasp) -> (3, len(tau)) hill positions


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


def _predicted_gaps(prediction, r_hill, t, t_grasp, config):
    """Gap [m] of the chaser envelope from the target's predicted geometry at each (r_hill (M, 3), t (M,)),
    less the prediction's uncertainty, and the nearest box's name per sample.

    The uncertainty is |r| times an attitude error: for a prediction that carries the estimate's
    covariance (guidance's gate), UNCERTAINTY_SIGMAS times its own propagated 1-sigma attitude error;
    otherwise (the planner, which plans from the estimate alone, long before the re-aims) the model of
    module doc step 4, geometry_attitude_margin + geometry_rate_margin |t - t_g|."""
    c_hb = prediction.c_hill_from_body(t)
    dist, names = _nearest_box(np.einsum('mji,mj->mi', c_hb, r_hill), config.boxes)  # C_hill_from_body' r
    if getattr(prediction, 'has_covariance', False):
        angle = UNCERTAINTY_SIGMAS * prediction.attitude_sigma_rad(t)
    else:
        angle = config.geometry_attitude_margin_rad + config.geometry_rate_margin_rad_s * np.abs(t - t_grasp)
    return dist - config.envelope_radius_m - np.linalg.norm(r_hill, axis=1) * angle, names


def _passages(keys, states_at_grasp, prediction, region, config, back_s=None):
    """_Passage of each (t_grasp, offset) key from its hill state (6,) at the grasp (module doc, step 4),
    from back_s before the grasp (default: the longest fly-by) over the escape."""
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
    out = {}
    for j, key in enumerate(keys):
        t_g = key[0]
        r = r_all[:, j, :].T
        gap = region.clearance(r, t_g + tau, n, config.envelope_radius_m)
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
        if fine_tau:
            tf = np.unique(np.concatenate(fine_tau))
            tf = tf[(t_g + tf >= prediction.t0) & (t_g + tf <= prediction.t_end)]
            # CW near the target: over a few hundred seconds within ~20 m it differs from the
            # nonlinear coast by far less than a micrometre.
            rf = np.einsum('mij,j->mi', cw_transition_matrix(n, tf), x0[j])[:, :3]
            swept = region.clearance(rf, t_g + tf, n, config.envelope_radius_m)
            predicted, boxes = _predicted_gaps(prediction, rf, t_g + tf, t_g, config)
            use_predicted = predicted > swept
            order = np.argsort(np.concatenate((tau_k, tf)), kind='stable')
            tau_k = np.concatenate((tau_k, tf))[order]
            gap_k = np.concatenate((gap_k, np.where(use_predicted, predicted, swept)))[order]
            closest_k = np.concatenate((closest_k, np.where(use_predicted, boxes, 'swept region')))[order]

        def path(tau_q, j=j):
            tau_q = np.atleast_1d(tau_q)
            xyz = np.empty((3, len(tau_q)))
            xyz[:, tau_q < 0.0] = dense_back(tau_q[tau_q < 0.0])[:3, j, :]
            xyz[:, tau_q >= 0.0] = dense_on(tau_q[tau_q >= 0.0])[:3, j, :]
            return xyz
        out[key] = _Passage(t_grasp=t_g, tau=tau_k, gap=gap_k, closest=closest_k, r_tau=tau,
                            radius=np.linalg.norm(r, axis=1), path=path)
    return out


def _check_passive_safety(batch, passages, prediction, region, config):
    """Step 4 for a batch of candidates: fill their clearances and sphere entry, reject the unsafe ones."""
    new = {}
    for c in batch:
        key = (c.t_grasp, c.offset_m)
        if key not in passages and key not in new:
            new[key] = np.concatenate((c.x_ft, c.v_ft))
    if new:
        passages.update(_passages(list(new), list(new.values()), prediction, region, config))
    for c in batch:
        ps = passages[(c.t_grasp, c.offset_m)]
        inside = ps.tau >= -c.flyby_duration_s
        tau, gap, closest = ps.tau[inside], ps.gap[inside], ps.closest[inside]
        approach = tau <= 0.0
        c.clearance_approach_m = float(gap[approach].min())
        c.clearance_escape_m = float(gap[~approach].min())
        i = int(np.argmin(gap))
        c.closest = str(closest[i])
        c.t_min_clearance = float(c.t_grasp + tau[i])
        entered = np.flatnonzero((ps.r_tau >= -c.flyby_duration_s) & (ps.radius <= config.restriction_sphere_radius_m))
        c.t_sphere_entry = float(c.t_grasp + ps.r_tau[entered[0]]) if entered.size else None
        burnable = np.flatnonzero((ps.r_tau <= 0.0) & (ps.radius > config.restriction_sphere_radius_m
                                                          + config.sphere_margin_m + LAST_BURN_SLACK_M))
        c.unguided_coast_s = float(-ps.r_tau[burnable[-1]]) if burnable.size else c.flyby_duration_s
        if c.unguided_coast_s > config.max_unguided_coast_s:
            c.reasons.append(f'unguided coast {c.unguided_coast_s:.0f} s from the last burn to the grasp is longer '
                             f'than {config.max_unguided_coast_s:g} s (navigation error grows unchecked)')
        if gap[i] < config.clearance_margin_m:
            part = 'approach' if tau[i] <= 0.0 else 'escape'
            c.reasons.append(f'passive {part} clearance {gap[i]:.3f} m from the {c.closest} at t = '
                             f'{c.t_grasp + tau[i]:.1f} s is below the margin {config.clearance_margin_m:g} m')


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
    safe = [c for c in candidates if c.clearance_approach_m is not None and not c.reasons]
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


# Classes of rejection, by the start of the reason, and how a refusal counts them.
_REASON_CLASSES = (
    ('condition (a)', 'condition (a), rate'), ('condition (b)', 'condition (b), spin axis near hill y'),
    ('not convex', 'not convex (eq 15)'), ('condition (c)', 'condition (c), lighting'),
    ('X_Fi', 'X_Fi inside the restriction sphere'), ('transfer impulse', 'transfer impulse above the limit'),
    ('transfer passes', 'transfer through the restriction sphere'),
    ('unguided coast', 'unguided coast too long'),
    ('passive', 'passive clearance below the margin'),
)


def _reason_class(reason):
    return next((label for prefix, label in _REASON_CLASSES if reason.startswith(prefix)), reason)


def _refusal_reason(candidates, region, config):
    """One line: how many candidates fell to each class of reason, the best clearance found and, when a
    part of the target sweeps through the grasp point, which."""
    counts = collections.Counter(_reason_class(c.reasons[0]) for c in candidates)
    parts = [f'{k} {label}' for label, k in counts.most_common()]
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
    target's other parts, less the attitude uncertainty at the grasp, and the nearest box's name.

    In body axes X_Ft = (1 + delta r / |x_g|) x_g for every grasp instant alike, so an offset that
    fails here fails at any grasp time."""
    x_g = np.asarray(config.x_grasp_body_m, dtype=float)
    radius = float(np.linalg.norm(x_g))
    points = np.array([(1.0 + dr / radius) * x_g for dr in config.offsets_m])
    dist, names = _nearest_box(points, config.boxes)
    gaps = dist - config.envelope_radius_m - np.linalg.norm(points, axis=1) * config.geometry_attitude_margin_rad
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


def plan_capture(prediction, r_chaser_hill, v_chaser_hill, t_now, config):
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
                        f'{config.clearance_margin_m:g} m, attitude uncertainty included), at any grasp time: the '
                        f'{box} blocks the grasp point', t_now)

    region = _predicted_region(prediction, t_now, config)

    found = grasp_candidates(prediction, config.x_grasp_body_m, w_lo, w_hi, n)
    if not found:
        angle = _angle_from_orbit_normal(omega_now)
        why = (f'condition (b): spin axis {_deg(angle)} from hill y, the singular case of seed 000 section 3.3 '
               '(the grasp point never has zero y velocity)'
               if angle < config.min_spin_axis_angle_from_orbit_normal_rad else
               'the grasp point\'s hill y velocity does not change sign')
        return _refused(f'no grasp instant in [{w_lo:.1f}, {w_hi:.1f}] s: {why}', t_now, region=region)

    t_ti = t_now + config.maneuver_lead_s
    chaser_at_ti = cw_coast(r_now, v_now, config.maneuver_lead_s, n)
    transfer_max = config.transfer_max_for(rate_rel)
    candidates = []
    for g in found:
        durations = [d for d in config.flyby_durations_s
                     if config.transfer_min_s <= g.t_grasp - d - t_ti <= transfer_max]
        if not durations:
            continue
        reasons = _grasp_reasons(g, config)
        if reasons:  # one entry per rejected grasp instant, at the first offset and duration searched
            candidates.append(_candidate(g, offsets[0], durations[0], t_ti, chaser_at_ti, reasons, config))
            continue
        candidates += [_candidate(g, dr, d, t_ti, chaser_at_ti, (), config) for d in durations for dr in offsets]

    passages = {}
    for stage in config.search_stages:
        pending = sorted((c for c in candidates if not c.reasons and (c.offset_m, c.flyby_duration_s) in stage),
                         key=lambda c: c.dv_total_mps)
        cheapest_safe = math.inf
        for start in range(0, len(pending), _BATCH):
            batch = pending[start:start + _BATCH]
            if batch[0].dv_total_mps > cheapest_safe + config.delta_v_tie_mps:
                break
            _check_passive_safety(batch, passages, prediction, region, config)
            cheapest_safe = min([cheapest_safe] + [c.dv_total_mps for c in batch if not c.reasons])
        if cheapest_safe < math.inf:
            break
    for c in candidates:
        if not c.reasons and c.clearance_approach_m is None:
            c.status = 'unchecked'
    chosen = _select(candidates, config)
    if chosen is None:
        return _refused(_refusal_reason(candidates, region, config) if candidates else
                        f'no grasp instant in [{w_lo:.1f}, {w_hi:.1f}] s is reachable with a transfer of '
                        f'{config.transfer_min_s:g}-{transfer_max:g} s', t_now, candidates, region)
    path_t, path_r = _path(chosen, r_now, v_now, t_now, passages[(chosen.t_grasp, chosen.offset_m)], config)
    return CapturePlan(ok=True, reason='', t_plan=t_now, selected=chosen, candidates=candidates, region=region,
                       path_t=path_t, path_r_hill=path_r)


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
