"""Fly-by capture task planning, seed 000 sections 4.3-4.5 and 4.7 (eq 13-23, 28-29), seed 003 section 3.

Pure numpy/scipy, no ROS. ``plan_capture`` takes the estimator's prediction of the target motion
(flyby_estimation.target_motion.MotionPrediction) and the chaser's estimated state, and returns a
``CapturePlan``: the grasp time and point, the fly-by target point X_Ft (eq 20-21), the fly-by
initial point X_Fi (eq 23), the terminal-transfer impulses (eq 28-29), the predicted passive path
and, for every candidate considered, why it was kept or rejected.

Steps (seed 000 section 4.4: "multiple candidates ... over a period of rotations"):

1. Grasp-time search over the window of grasp times reachable with a terminal transfer of
   transfer_min_s ... transfer_max_s starting maneuver_lead_s from now (grasp.grasp_candidates,
   eq 13-15).
2. Per candidate: condition (a) rate below the category III/IV limit, (b) spin axis away from hill
   y (no pure out-of-plane motion), the safe convex condition eq 15, (c) lighting against the sun
   direction; X_Ft, X_Fi; X_Fi outside the thruster-restriction sphere; the eq 28-29 impulses within
   the per-maneuver limit.
3. Passive safety of each candidate that passed step 2: the coast from X_Fi through X_Ft and the
   escape after it are propagated with the nonlinear relative dynamics (flyby_sim.dynamics.orbital) for
   flyby_duration_s + escape_check_orbits orbits, and the chaser envelope must stay
   clearance_margin_m outside the target's swept keep-out region (keepout.SweptRegion) throughout.
4. Selection: the least total delta-v of the terminal transfer; plans within delta_v_tie_mps of it
   tie and the larger least clearance wins.
"""

import dataclasses
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from flyby_estimation.target_motion import ErrorStateDynamics, MotionPrediction
from flyby_planner.grasp import flyby_initial_point, flyby_target_point, grasp_candidates
from flyby_planner.keepout import swept_region
from flyby_planner.transfer import terminal_impulses
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.orbital import (
    cw_coast,
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


@dataclasses.dataclass(frozen=True)
class PlannerConfig:
    """Everything ``plan_capture`` needs besides the prediction and the chaser state.

    Attributes (SI; angles in rad): see the ``planner`` section of docs/scenario.md for the meaning
    and the seed 000 example defaults; ``boxes`` is flyby_sim.scenario.Boxes.
    """

    mean_motion_rad_s: float
    orbit_radius_m: float
    x_grasp_body_m: np.ndarray
    boxes: object
    inertia_kg_m2: np.ndarray
    envelope_radius_m: float
    offset_m: float = 1.0
    flyby_duration_s: float = 300.0
    restriction_sphere_radius_m: float = 15.0
    clearance_margin_m: float = 0.1
    escape_check_orbits: float = 1.0
    max_rate_rad_s: float = math.radians(18.0)
    min_spin_axis_angle_from_orbit_normal_rad: float = math.radians(10.0)
    sun_direction_eci: np.ndarray | None = None
    max_sun_angle_from_grasp_velocity_rad: float = math.radians(100.0)
    maneuver_lead_s: float = 10.0
    transfer_min_s: float = 150.0
    transfer_max_s: float = 450.0
    delta_v_tie_mps: float = 0.001
    max_delta_v_per_maneuver_mps: float = math.inf

    def __post_init__(self):
        for name in ('mean_motion_rad_s', 'orbit_radius_m', 'envelope_radius_m', 'offset_m', 'flyby_duration_s',
                     'restriction_sphere_radius_m', 'escape_check_orbits', 'max_rate_rad_s', 'maneuver_lead_s',
                     'transfer_min_s', 'transfer_max_s'):
            require_positive(name, getattr(self, name))
        require_positive('max_delta_v_per_maneuver_mps', self.max_delta_v_per_maneuver_mps, allow_inf=True)
        if self.transfer_max_s < self.transfer_min_s:
            raise ValueError(f'transfer_max_s {self.transfer_max_s} s < transfer_min_s {self.transfer_min_s} s')

    @property
    def search_window(self):
        """(earliest, latest) grasp time relative to the plan time [s]."""
        t_ti = self.maneuver_lead_s + self.flyby_duration_s
        return t_ti + self.transfer_min_s, t_ti + self.transfer_max_s

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
        offset_m=p.offset_m, flyby_duration_s=p.flyby_duration_s,
        restriction_sphere_radius_m=p.restriction_sphere_radius_m, clearance_margin_m=p.clearance_margin_m,
        escape_check_orbits=p.escape_check_orbits,
        max_rate_rad_s=math.radians(scenario.estimation.spin_rate_deg_s),
        min_spin_axis_angle_from_orbit_normal_rad=math.radians(p.min_spin_axis_angle_from_orbit_normal_deg),
        sun_direction_eci=sun,
        max_sun_angle_from_grasp_velocity_rad=math.radians(p.max_sun_angle_from_grasp_velocity_deg),
        maneuver_lead_s=p.maneuver_lead_s, transfer_min_s=p.transfer_min_s, transfer_max_s=p.transfer_max_s,
        delta_v_tie_mps=p.delta_v_tie_mps,
        max_delta_v_per_maneuver_mps=scenario.chaser.thrusters.max_delta_v_per_maneuver_mps)


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
    """One grasp instant and the fly-by built on it (hill, SI; velocities relative to hill).

    status: 'selected', 'safe' (passed every check, not chosen) or 'rejected' (see reasons).
    clearance_approach_m / clearance_escape_m: least gap between the chaser envelope and the swept
    region from X_Fi to the grasp and over the escape; None when the candidate was rejected before
    the propagation. t_sphere_entry: when the passive path enters the restriction sphere.
    """

    t_grasp: float
    x_g: np.ndarray
    v_g: np.ndarray
    omega_hill: np.ndarray
    convex_value: float
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
    t_min_clearance: float | None = None
    t_sphere_entry: float | None = None

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
            'x_g_hill_m': vec(self.x_g), 'v_g_hill_mps': vec(self.v_g),
            'convex_value_m2_s2': float(f'{self.convex_value:.6g}'),
            'x_ft_hill_m': vec(self.x_ft), 'v_ft_hill_mps': vec(self.v_ft),
            't_i_s': round(self.t_i, 4), 'x_fi_hill_m': vec(self.x_fi), 'v_fi_hill_mps': vec(self.v_fi),
            't_ti_s': round(self.t_ti, 4), 'dv_ti_hill_mps': vec(self.dv_ti), 'dv_tf_hill_mps': vec(self.dv_tf),
            'dv_total_mps': round(self.dv_total_mps, 6),
            'clearance_approach_m': _rounded(self.clearance_approach_m),
            'clearance_escape_m': _rounded(self.clearance_escape_m),
            't_min_clearance_s': _rounded(self.t_min_clearance),
            't_sphere_entry_s': _rounded(self.t_sphere_entry),
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


def _propagate_passive(states0, duration_s, config):
    """Nonlinear coast of several initial hill states (K, 6) at once over [0, duration_s]; dense solution."""
    k = states0.shape[0]
    n, radius = config.mean_motion_rad_s, config.orbit_radius_m

    def rate(_, y):
        s = y.reshape(6, k)
        return np.concatenate((s[3:], nonlinear_relative_accel(s[:3], s[3:], n, radius))).ravel()

    sol = solve_ivp(rate, (0.0, duration_s), states0.T.ravel(), method='DOP853', rtol=1e-10, atol=1e-9,
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


def _check_passive_safety(candidates, region, config):
    """Fill clearances and sphere entry of the candidates (step 3) and reject the unsafe ones.

    Returns the dense passive solution tau -> (6, K, len(tau)), tau from each candidate's t_i.
    """
    if not candidates:
        return None
    n = config.mean_motion_rad_s
    t_fb = config.flyby_duration_s
    span = t_fb + config.escape_duration_s
    dense, tau, states, gaps = _passive_gaps(np.array([np.concatenate((c.x_fi, c.v_fi)) for c in candidates]),
                                             [c.t_i for c in candidates], span, region, config)
    for j, c in enumerate(candidates):
        r = states[:3, j, :].T

        def gap(tau_s, c=c, j=j):
            return float(region.clearance(dense(np.atleast_1d(tau_s))[:3, j, :].T, c.t_i + tau_s, n,
                                          config.envelope_radius_m)[0])
        g = gaps[j]
        i = int(np.argmin(g))
        # The grid minimum, refined between its neighbours (the passage is a smooth minimum).
        lo, hi = tau[max(i - 1, 0)], tau[min(i + 1, len(tau) - 1)]
        best = minimize_scalar(gap, bounds=(lo, hi), method='bounded', options={'xatol': 1e-3})
        g_min, tau_min = (best.fun, best.x) if best.fun < g[i] else (g[i], tau[i])
        approach = tau <= t_fb
        c.clearance_approach_m = float(min(g[approach].min(), g_min if tau_min <= t_fb else math.inf))
        c.clearance_escape_m = float(min(g[~approach].min(), g_min if tau_min > t_fb else math.inf))
        c.t_min_clearance = float(c.t_i + tau_min)
        inside = np.flatnonzero(np.linalg.norm(r, axis=1) <= config.restriction_sphere_radius_m)
        c.t_sphere_entry = float(c.t_i + tau[inside[0]]) if inside.size else None
        if g_min < config.clearance_margin_m:
            part = 'approach' if tau_min <= t_fb else 'escape'
            c.reasons.append(f'passive {part} clearance {g_min:.3f} m at t = {c.t_i + tau_min:.1f} s is below '
                             f'the margin {config.clearance_margin_m:g} m')
    return dense


def _select(candidates, config):
    """Step 4: least total delta-v; within delta_v_tie_mps of it the larger least clearance wins."""
    safe = [c for c in candidates if not c.reasons]
    for c in safe:
        c.status = 'safe'
    if not safe:
        return None
    cheapest = min(c.dv_total_mps for c in safe)
    tied = [c for c in safe if c.dv_total_mps <= cheapest + config.delta_v_tie_mps]
    chosen = max(tied, key=lambda c: c.clearance_min_m)
    chosen.status = 'selected'
    return chosen


def _path(chosen, r_now, v_now, t_now, passive_xyz, config):
    """Predicted chaser path of the chosen plan (times (M,), hill positions (M, 3)).

    passive_xyz: tau -> (3, len(tau)) hill positions of the passive arc, tau from chosen.t_i.
    """
    n = config.mean_motion_rad_s
    t_fb = config.flyby_duration_s
    span = t_fb + config.escape_duration_s
    t_coast = np.linspace(t_now, chosen.t_ti, 20)
    coast = np.array([cw_coast(r_now, v_now, t - t_now, n) for t in t_coast])
    r_ti, v_ti = coast[-1, :3], coast[-1, 3:] + chosen.dv_ti
    t_transfer = np.linspace(chosen.t_ti, chosen.t_i, 200)
    transfer = np.array([cw_coast(r_ti, v_ti, t - chosen.t_ti, n) for t in t_transfer])
    # Coarse over the orbit, every 0.5 s for a minute either side of the passage.
    tau = np.union1d(np.linspace(0.0, span, _PUBLISHED_PATH_POINTS),
                     np.arange(max(t_fb - 60.0, 0.0), min(t_fb + 60.0, span), 0.5))
    passive = passive_xyz(tau).T
    t = np.concatenate((t_coast, t_transfer[1:], chosen.t_i + tau[1:]))
    r = np.concatenate((coast[:, :3], transfer[1:, :3], passive[1:]))
    return t, r


def plan_capture(prediction, r_chaser_hill, v_chaser_hill, t_now, config):
    """Plan a fly-by capture from the target prediction and the chaser state at t_now (module doc).

    Args:
        prediction: flyby_estimation.target_motion.MotionPrediction (or an object with the same
            ``state(t)``, ``body_point_in_hill(x_body, t)``, ``t0`` and ``t_end``) covering
            [t_now, t_now + config.search_window[1]].
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
    w_lo, w_hi = (t_now + dt for dt in config.search_window)
    if not (prediction.t0 <= t_now and prediction.t_end >= w_hi):
        raise ValueError(f'the prediction covers [{prediction.t0}, {prediction.t_end}] s; planning at {t_now} s '
                         f'needs it up to {w_hi} s')

    # Condition (a) on the current motion: a fly-by needs category II/III (seed 000 section 2.1).
    omega_now = prediction.state(t_now).omega_hill
    rate = float(np.linalg.norm(omega_now))
    if rate >= config.max_rate_rad_s:
        return _refused(f'condition (a): target rate {math.degrees(rate):.3g} deg/s >= {_deg(config.max_rate_rad_s)}/s '
                        '(category IV, spinning: beyond the fly-by method, seed 000 section 2.1)', t_now)

    if rate < _MIN_SPIN_RAD_S:
        return _refused(f'target rate {math.degrees(rate):.3g} deg/s: no rotation to time a grasp with '
                        '(category I; approach it conventionally, seed 000 section 2.1)', t_now)

    samples = [prediction.state(t) for t in np.linspace(t_now, prediction.t_end, _REGION_SAMPLES)]
    region = swept_region(config.boxes, config.inertia_kg_m2, [s.q_eci_from_body for s in samples],
                          [s.omega_body for s in samples])

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
    cos_sun_min = math.cos(config.max_sun_angle_from_grasp_velocity_rad)
    candidates = []
    for g in found:
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
            if cos_sun < cos_sun_min:
                reasons.append(f'condition (c): sun {_deg(math.acos(max(-1.0, cos_sun)))} from the grasp velocity > '
                               f'{_deg(config.max_sun_angle_from_grasp_velocity_rad)}')
        x_ft, v_ft = flyby_target_point(g.x_g, g.v_g, config.offset_m)  # eq 20-21
        x_fi, v_fi = flyby_initial_point(x_ft, v_ft, config.flyby_duration_s, n)  # eq 23
        if np.linalg.norm(x_fi) <= config.restriction_sphere_radius_m:
            reasons.append(f'X_Fi at {np.linalg.norm(x_fi):.2f} m is inside the restriction sphere '
                           f'({config.restriction_sphere_radius_m:g} m)')
        t_i = g.t_grasp - config.flyby_duration_s
        dv_ti, dv_tf = terminal_impulses(chaser_at_ti[:3], chaser_at_ti[3:], x_fi, v_fi, t_i - t_ti, n)  # eq 28-29
        largest = max(np.linalg.norm(dv_ti), np.linalg.norm(dv_tf))
        if largest > config.max_delta_v_per_maneuver_mps:
            reasons.append(f'transfer impulse {largest:.3f} m/s exceeds the per-maneuver limit '
                           f'{config.max_delta_v_per_maneuver_mps:g} m/s')
        candidates.append(Candidate(t_grasp=g.t_grasp, x_g=g.x_g, v_g=g.v_g, omega_hill=g.omega_hill,
                                    convex_value=g.convex_value, x_ft=x_ft, v_ft=v_ft, t_i=t_i, x_fi=x_fi, v_fi=v_fi,
                                    t_ti=t_ti, dv_ti=dv_ti, dv_tf=dv_tf, reasons=reasons))

    checked = [c for c in candidates if not c.reasons]
    dense = _check_passive_safety(checked, region, config)
    chosen = _select(candidates, config)
    if chosen is None:
        rejected = '; '.join(f't_g {c.t_grasp:.1f} s: {c.reasons[0]}' for c in candidates)
        return _refused(f'all {len(candidates)} candidates rejected ({rejected})', t_now, candidates, region)
    j = next(k for k, c in enumerate(checked) if c is chosen)  # by identity: dataclass == compares arrays
    path_t, path_r = _path(chosen, r_now, v_now, t_now, lambda tau: dense(tau)[:3, j, :], config)
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
