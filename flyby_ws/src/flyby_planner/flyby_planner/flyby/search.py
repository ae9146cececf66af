"""The fly-by's search (package doc, steps 1-5): ``plan_capture`` searches the grasp window and, if it holds no
safe plan, the extended one, stage by stage (PlannerConfig.search_stages), and returns a ``CapturePlan``.

Pure numpy/scipy, no ROS. Frames and units as in flyby_planner.flyby.grasp_search (hill, velocities relative to the
rotating hill frame, SI).
"""

import math

import numpy as np

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import MotionPrediction
from flyby_planner.flyby.candidates import (
    CapturePlan,
    angle_from_orbit_normal,
    build_candidate,
    degrees_text,
    grasp_reasons,
    offset_gaps,
    rate_relative_to_hill,
    refused,
)
from flyby_planner.flyby.checks import BATCH, check_passive_safety, passes_checks
from flyby_planner.flyby.grasp_search import grasp_candidates
from flyby_planner.flyby.passive_safety import predicted_region
from flyby_planner.flyby.reaim import ReaimModel
from flyby_planner.flyby.selection import refusal_reason, select_plan
from flyby_planner.flyby.uncertainty import TargetUncertainty
from flyby_sim.dynamics.orbital import cw_coast

# Points of the published passive path (coarse over the orbit).
_PUBLISHED_PATH_POINTS = 1500
# Below this inertial rate (0.01 deg/s, category I's hold rate) there is no turn to time a grasp with.
_MIN_SPIN_RAD_S = math.radians(0.01)


def plan_capture(prediction, r_chaser_hill, v_chaser_hill, t_now, config, covariance_body=None):
    """Plan a fly-by capture from the target prediction and the chaser state at t_now (package doc).

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
            (target_motion.covariance_from_published), for the re-aim check (ReaimModel); None: no re-aim check.

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
    rate_rel = rate_relative_to_hill(omega_now, n)
    w_lo, w_hi = (t_now + dt for dt in config.search_window(rate_rel))
    if prediction.t_end < w_hi:
        raise ValueError(f'the prediction covers [{prediction.t0}, {prediction.t_end}] s; planning at {t_now} s '
                         f'needs it up to {w_hi} s')
    # The extended window as far as the mission lasts (the prediction is carried on for it when it is searched);
    # the grasp window plans as it always did, a short test run ending on its time limit.
    w_ext = min(t_now + config.search_window(rate_rel, extended=True)[1], config.latest_grasp_s)
    why = _motion_refusal(omega_now, config)
    if why is not None:
        return refused(why, t_now)
    gaps = offset_gaps(config)
    offsets = [dr for dr in config.offsets_m if gaps[dr][0] >= config.clearance_margin_m]
    if not offsets:
        return refused(_blocked_reason(gaps, config), t_now)
    search = _Search(prediction, r_now, v_now, t_now, config, covariance_body, rate_rel, (w_lo, w_hi, w_ext), offsets)
    search.run()
    if not search.found:
        return refused(search.no_grasp_reason(omega_now), t_now, region=search.region)
    for c in search.candidates:
        if not c.reasons and (c.clearance_approach_m is None or c.reaim_checked is False):
            c.status = 'unchecked'
    chosen = select_plan(search.candidates, config)
    if chosen is None:
        return refused(refusal_reason(search.candidates, search.region, config) if search.candidates else
                       f'no grasp instant in [{w_lo:.1f}, {max(w_hi, w_ext):.1f}] s is reachable with a transfer of '
                       f'{config.transfer_min_s:g}-{search.transfer_cap:g} s', t_now, search.candidates, search.region)
    path_t, path_r = _path(chosen, r_now, v_now, t_now, search.passages[(chosen.t_grasp, chosen.offset_m)], config)
    return CapturePlan(ok=True, reason='', t_plan=t_now, selected=chosen, candidates=search.candidates,
                       region=search.region, path_t=path_t, path_r_hill=path_r, prediction=search.prediction)


def _motion_refusal(omega_now, config):
    """Why the target's current motion (inertial rate omega_now, hill axes) rules a fly-by out, or None: condition (a)
    (category IV) or no rotation to time a grasp with (category I), seed 000 section 2.1."""
    rate = float(np.linalg.norm(omega_now))
    if rate >= config.max_rate_rad_s:
        return (f'condition (a): target rate {math.degrees(rate):.3g} deg/s >= {degrees_text(config.max_rate_rad_s)}/s '
                '(category IV, spinning: beyond the fly-by method, seed 000 section 2.1)')
    if rate < _MIN_SPIN_RAD_S:
        return (f'target rate {math.degrees(rate):.3g} deg/s: no rotation to time a grasp with '
                '(category I; approach it conventionally, seed 000 section 2.1)')
    return None


def _blocked_reason(gaps, config):
    """The refusal when no offset's X_Ft (eq 20) clears the target (gaps: offset_gaps)."""
    dr, (gap, box) = max(gaps.items(), key=lambda item: item[1][0])
    lo, hi = config.offsets_range_m
    return (f'no offset reaches the grasp point: at every offset {lo:g}-{hi:g} m the fly-by target '
            f'point (eq 20) leaves the chaser envelope at most {gap:.3f} m from the {box} (margin '
            f'{config.clearance_margin_m:g} m, '
            + ('with the attitude known exactly' if config.accuracy is not None else
               'attitude uncertainty included')
            + f'), at any grasp time: the {box} blocks the grasp point')


class _Search:
    """One search of plan_capture (package doc, steps 1-5): the grasp window first, stage by stage; if it holds no
    safe plan, the extended window (transfers up to the cap), searched in full the same way. Holds what it found
    (grasp instants, candidates, passages) and the models it made on the way; prediction and region are those of
    the extended window once it is searched."""

    def __init__(self, prediction, r_now, v_now, t_now, config, covariance_body, rate_rel, window, offsets):
        self.prediction, self.t_now, self.config, self.covariance_body = prediction, t_now, config, covariance_body
        self.w_lo, self.w_hi, self.w_ext = window
        self.offsets = offsets
        self.region = predicted_region(prediction, t_now, config)
        self.t_ti = t_now + config.maneuver_lead_s
        self.chaser_at_ti = cw_coast(r_now, v_now, config.maneuver_lead_s, config.mean_motion_rad_s)
        self.transfer_max = config.transfer_max_for(rate_rel)
        self.transfer_cap = max(config.transfer_cap_s, self.transfer_max)
        self.found, self.candidates, self.passages = [], [], {}
        self.uncertainty = self.reaim = None

    def run(self):
        """Steps 1-5 over the grasp window, then the extended one unless a stage of the first holds a safe plan."""
        cfg = self.config
        if self.w_hi > self.w_lo:
            self.found = grasp_candidates(self.prediction, cfg.x_grasp_body_m, self.w_lo, self.w_hi,
                                          cfg.mean_motion_rad_s)
        self.candidates = self._build(self.found, False)
        for extended in (False, True):
            if extended:
                self._extend()
            if cfg.accuracy is not None:
                self._update_models(extended)
            if self._search_stages(extended) < math.inf:
                break

    def _build(self, found, extended):
        """The candidates of these grasp instants whose transfer is within the window (or, extended, beyond it)."""
        cfg = self.config
        out = []
        for g in found:
            durations = [d for d in cfg.flyby_durations_s
                         if cfg.transfer_min_s <= g.t_grasp - d - self.t_ti <= self.transfer_cap
                         and (g.t_grasp - d - self.t_ti > self.transfer_max or g.t_grasp > self.w_hi) == extended
                         and (not extended or g.t_grasp <= cfg.latest_grasp_s)]
            if not durations:
                continue
            reasons = grasp_reasons(g, cfg)
            if reasons:  # one entry per rejected grasp instant, at the first offset and duration searched
                out.append(build_candidate(g, self.offsets[0], durations[0], self.t_ti, self.chaser_at_ti, reasons,
                                           cfg))
            else:
                out += [build_candidate(g, dr, d, self.t_ti, self.chaser_at_ti, (), cfg)
                        for d in durations for dr in self.offsets]
        for c in out:
            c.extended = extended
        return out

    def _extend(self):
        """The extended window's grasp instants and candidates, the prediction carried on over it if it is short."""
        cfg = self.config
        if self.prediction.t_end < self.w_ext + cfg.geometry_window_s:
            self.prediction = _carried_on(self.prediction, self.t_now, self.w_ext + cfg.geometry_window_s, cfg)
            self.region = predicted_region(self.prediction, self.t_now, cfg)
        if self.w_ext > self.w_hi:
            more = [g for g in grasp_candidates(self.prediction, cfg.x_grasp_body_m, max(self.w_lo, self.w_hi),
                                                self.w_ext, cfg.mean_motion_rad_s)
                    if g.t_grasp > self.w_hi]
            self.found += more
        self.candidates += self._build(self.found, True)

    def _update_models(self, extended):
        """The target's uncertainty over the window searched and the re-aim model over the prediction."""
        cfg = self.config
        horizon = min(self.prediction.t_end, (self.w_ext if extended else self.w_hi) + cfg.geometry_window_s)
        if self.uncertainty is None or self.uncertainty.nodes[-1] < horizon:
            self.uncertainty = TargetUncertainty(self.prediction, self.t_now, cfg, t_end=horizon)
        if cfg.reaims(self.covariance_body) and (self.reaim is None or self.reaim.t_end < self.prediction.t_end):
            self.reaim = ReaimModel(self.prediction, self.t_now, cfg, self.covariance_body)

    def _search_stages(self, extended):
        """Step 4 stage by stage, in order of delta-v in batches, until a stage holds a safe plan; the least
        delta-v of a safe plan in the last stage searched (inf: none)."""
        cfg = self.config
        for stage in cfg.search_stages:
            pending = sorted((c for c in self.candidates if not c.reasons and c.extended == extended
                              and (c.offset_m, c.flyby_duration_s) in stage), key=lambda c: c.dv_total_mps)
            cheapest_safe = math.inf
            for start in range(0, len(pending), BATCH):
                batch = pending[start:start + BATCH]
                if batch[0].dv_total_mps > cheapest_safe + cfg.delta_v_tie_mps:
                    break
                check_passive_safety(batch, self.passages, self.prediction, self.region, cfg, self.uncertainty,
                                     self.reaim)
                cheapest_safe = min([cheapest_safe] + [c.dv_total_mps for c in batch if passes_checks(c)])
            if cheapest_safe < math.inf:
                break
        return cheapest_safe

    def no_grasp_reason(self, omega_now):
        """The refusal when neither window holds a grasp instant: condition (b) or no sign change of eq 13."""
        angle = angle_from_orbit_normal(omega_now)
        why = (f'condition (b): spin axis {degrees_text(angle)} from hill y, the singular case of seed 000 section '
               '3.3 (the grasp point never has zero y velocity)'
               if angle < self.config.min_spin_axis_angle_from_orbit_normal_rad else
               'the grasp point\'s hill y velocity does not change sign')
        return f'no grasp instant in [{self.w_lo:.1f}, {max(self.w_hi, self.w_ext):.1f}] s: {why}'


def _carried_on(prediction, t_now, t_end, config):
    """The prediction's motion from t_now carried on to t_end (a MotionPrediction without covariance from its
    state at t_now: the same torque-free motion, seed 000 eq 4), for the extended window."""
    s = prediction.state(t_now)
    return MotionPrediction(ErrorStateDynamics(config.inertia_kg_m2), config.mean_motion_rad_s, t_now,
                            s.q_eci_from_body, s.omega_body, None, t_end, with_covariance=False)


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
