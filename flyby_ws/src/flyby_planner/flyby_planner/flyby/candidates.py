"""The fly-by's candidates (package doc, steps 2-3): per grasp instant conditions (a)-(c) and eq 15
(``grasp_reasons``), per offset and fly-by duration X_Ft, X_Fi and the terminal transfer (eq 20-23, 28-29,
``build_candidate``) with their checks, and the records a plan is made of (``Candidate``, ``CapturePlan``).

Pure numpy, no ROS. Frames and units as in flyby_planner.flyby.grasp_search (hill, velocities relative to the
rotating hill frame, SI).
"""

import dataclasses
import math

import numpy as np

from flyby_planner.flyby.grasp_search import flyby_initial_point, flyby_target_point
from flyby_planner.flyby.passive_safety import nearest_box
from flyby_planner.transfer import terminal_impulses
from flyby_sim.dynamics.orbital import cw_transition_matrix, eci_vector_in_hill

# Points of the terminal transfer checked against the restriction sphere.
_TRANSFER_SAMPLES = 60


@dataclasses.dataclass
class Candidate:
    """One grasp instant, offset and fly-by duration, and the fly-by built on them (hill, SI;
    velocities relative to hill).

    status: 'selected', 'safe' (passed every check, not chosen), 'rejected' (see reasons) or
    'unchecked' (passed steps 2-3, not checked for passive safety: a cheaper safe plan exists).
    clearance_approach_m / clearance_escape_m: least gap between the chaser envelope and the target
    from X_Fi to the grasp and over the escape (package doc, step 4); None when not propagated.
    closest: what the least gap is to (a box name from the predicted geometry, or 'swept region').
    t_sphere_entry: when the passive path enters the restriction sphere.
    unguided_coast_s: from the last burn guidance can fly (where the arc is still LAST_BURN_SLACK_M beyond the
    sphere and its burn margin, or the injection at t_i) to the grasp.
    miss_3sigma_m, miss_3sigma_mps: the predicted 3-sigma miss at the grasp (package doc, step 4), worst direction.
    reaim_gap_m: the least gap of the passage guidance will fly once it re-aims, at 3 sigma of the plan estimate
    (ReaimModel); reaim_checked: None without that model, False until checked (then 'unchecked' if never).
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


def refused(reason, t_plan, candidates=(), region=None):
    return CapturePlan(ok=False, reason=reason, t_plan=t_plan, selected=None, candidates=list(candidates),
                       region=region)


def degrees_text(rad):
    return f'{math.degrees(rad):.3g} deg'


def angle_from_orbit_normal(omega_hill):
    """Angle between the spin vector and the hill y axis, from condition (b)'s |Omega x w| / (|Omega| |w|)."""
    w = np.asarray(omega_hill, dtype=float)
    return math.asin(min(1.0, math.hypot(w[0], w[2]) / float(np.linalg.norm(w))))


def rate_relative_to_hill(omega_hill, n):
    """|omega^H - Omega^H| [rad/s]: the target's turn rate as the hill frame sees it (eq 11)."""
    return float(np.linalg.norm(np.asarray(omega_hill, dtype=float) - np.array((0.0, -n, 0.0))))


def offset_gaps(config):
    """Gap [m] of the chaser envelope at the fly-by target point (eq 20) of each searched offset from the
    target's other parts, and the nearest box's name: with EstimateAccuracy the exact geometry (the uncertainty
    counts on the passage, per candidate), else less the fixed attitude uncertainty at the grasp.

    In body axes X_Ft = (1 + delta r / |x_g|) x_g for every grasp instant alike, so an offset that
    fails here fails at any grasp time."""
    x_g = np.asarray(config.x_grasp_body_m, dtype=float)
    radius = float(np.linalg.norm(x_g))
    points = np.array([(1.0 + dr / radius) * x_g for dr in config.offsets_m])
    dist, names = nearest_box(points, config.boxes)
    angle = 0.0 if config.accuracy is not None else config.geometry_attitude_margin_rad
    gaps = dist - config.envelope_radius_m - np.linalg.norm(points, axis=1) * angle
    return {dr: (float(gap), str(name)) for dr, gap, name in zip(config.offsets_m, gaps, names, strict=True)}


def grasp_reasons(g, config):
    """Step 2: conditions (a), (b), eq 15 and (c) of one grasp instant (reasons, empty if it passes)."""
    n = config.mean_motion_rad_s
    reasons = []
    rate_g = float(np.linalg.norm(g.omega_hill))
    if rate_g >= config.max_rate_rad_s:
        reasons.append(f'condition (a): rate {math.degrees(rate_g):.3g} deg/s >= '
                       f'{degrees_text(config.max_rate_rad_s)}/s')
    angle = angle_from_orbit_normal(g.omega_hill)
    if angle < config.min_spin_axis_angle_from_orbit_normal_rad:
        reasons.append(f'condition (b): spin axis {degrees_text(angle)} from hill y < '
                       f'{degrees_text(config.min_spin_axis_angle_from_orbit_normal_rad)} (out-of-plane motion)')
    if not g.convex:
        reasons.append(f'not convex: eq 15 value {g.convex_value:.3g} m^2/s^2 <= 0')
    if config.sun_direction_eci is not None:
        sun = eci_vector_in_hill(config.sun_direction_eci, g.t_grasp, n)
        cos_sun = float(g.v_g @ sun) / (float(np.linalg.norm(g.v_g)) * float(np.linalg.norm(sun)))
        if cos_sun < math.cos(config.max_sun_angle_from_grasp_velocity_rad):
            reasons.append(f'condition (c): sun {degrees_text(math.acos(max(-1.0, cos_sun)))} from the grasp '
                           f'velocity > {degrees_text(config.max_sun_angle_from_grasp_velocity_rad)}')
    return reasons


def build_candidate(g, offset_m, duration_s, t_ti, chaser_at_ti, reasons, config):
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
