"""The fly-by's adjusting burns (seed 000 §4): which plan guidance flies, when it steps, when it re-aims.

A new plan (the fly-by initial point X_Fi at t_i, the fly-by target point X_Ft at t_f, and the path whose stamp is
the plan time) starts ``FlybyGuidance`` (flyby_guidance.guidance) with its first burn ``planner.maneuver_lead_s``
after the plan time, as the planner assumed (t_Ti). Each chaser estimate steps it, in order; the maneuvers it returns
are commanded ahead of their start. Before each adjusting burn the grasp is re-solved from the target estimate of the
deciding chaser estimate's stamp and the burn aims at it (seed 000 §4.6): a chaser estimate that re-aims waits for
that target estimate, so the aim is the same at any pace of the run. Only an estimate the estimator would call
converged re-aims (its published covariance within the ``estimation.convergence_*`` bounds, and a spin axis): one
that is not (the target filter restarted after a run of outliers, its rate zero and its covariance the initial one)
keeps the aim, which the last converged estimate checked, and says so (fd_s8 run 59: it raised, guidance and the
supervisor died, the mission idled to its time limit). In the phases CAPTURE, ESCAPE, COMPLETE and
ABORTED nothing is commanded, nor in HOLD and RETREAT, which drop the plan (``drop_plan``).
"""

import collections

import numpy as np

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import covariance_from_published, prediction_from_estimate
from flyby_guidance.guidance import FlybyGuidance, FlybyTarget
from flyby_guidance.modes.interface import GuidanceMode
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events
from flyby_planner.flyby.grasp_search import REFINE_HORIZON_S, flyby_target_point, offset_of_flyby_target, refine_grasp
from flyby_planner.flyby.keepout import has_spin_axis
from flyby_planner.flyby.passive_safety import check_passage

QUIET_PHASES = c.WAITING_PHASES + (c.PHASE_CAPTURE, c.PHASE_ESCAPE, c.PHASE_COMPLETE, c.PHASE_ABORTED)
# A re-aimed arc is flown if the chaser envelope keeps off the target's predicted geometry less its
# uncertainty [m]: the planner's clearance_margin_m is a planning margin, this is the floor (a re-aimed arc a few
# centimetres less clear than the plan is no reason to give up a capture).
_GATE_MARGIN_M = 0.0


def flyby_target_of_plan(t_plan, t_i, x_fi, v_fi, t_f, x_ft, v_ft, maneuver_lead_s):
    """The FlybyTarget of a published plan: the first burn t_Ti is maneuver_lead_s after the plan time,
    as the planner assumed when it chose the transfer (plan.plan_capture)."""
    return FlybyTarget(t_ti=t_plan + maneuver_lead_s, t_i=t_i, x_fi=np.asarray(x_fi, dtype=float),
                       v_fi=np.asarray(v_fi, dtype=float), t_f=t_f, x_ft=np.asarray(x_ft, dtype=float),
                       v_ft=np.asarray(v_ft, dtype=float))


class FlybyAdjusting(GuidanceMode):
    """The fly-by's rules (module doc): the plan's inputs, and ``command`` steps every chaser estimate (the
    maneuvers and their events; a list, never None: the fly-by translates whatever else commands the attitude)."""

    def __init__(self, params, source, targets):
        """params: the FlybyParams (flyby_guidance.params); targets: the StampedBuffer of the target estimates
        (q_hill_from_body, omega_body, published covariance blocks or None), which the re-aim reads."""
        super().__init__(source)
        self.params = params
        self.guidance = FlybyGuidance(params.guidance)
        # The estimator's torque noise: the gate propagates the estimate's covariance as the filter would.
        self.dynamics = ErrorStateDynamics(params.target_inertia_kg_m2, params.torque_psd_n2m2s)
        self.planner_config = params.planner
        self.n = params.mean_motion_rad_s
        self.x_grasp_body = params.x_grasp_body_m
        self.flyby_initial = self.flyby_target = None  # (t, x, v) as last published
        self.plan_stamp = None  # the plan time of the plan being flown
        self.targets = targets
        self.waiting = collections.deque()  # (t, r_hill, v_hill) chaser estimates not yet stepped, in order

    def on_flyby_initial(self, t_i, x_fi, v_fi):
        self.flyby_initial = (t_i, x_fi, v_fi)
        return []

    def on_flyby_target(self, t_f, x_ft, v_ft):
        self.flyby_target = (t_f, x_ft, v_ft)
        return []

    def on_path(self, t_plan):
        """The planner publishes the path last: a new plan is complete."""
        if self.flyby_initial is None or self.flyby_target is None or t_plan == self.plan_stamp:
            return []
        self.plan_stamp = t_plan
        target = flyby_target_of_plan(t_plan, *self.flyby_initial, *self.flyby_target,
                                      self.planner_config.maneuver_lead_s)
        self.guidance.set_target(target)
        return [self._event(t_plan, 'OK', events.GUIDANCE_STARTED,
                            f'flying the plan of t = {t_plan:.2f} s: transfer at {target.t_ti:.2f} s, injection '
                            f'at {target.t_i:.2f} s, fly-by target at {target.t_f:.2f} s', {'t_plan_s': t_plan})]

    def drop_plan(self):
        """No burn of the plan given up (its mass account kept: a burn may have been flown)."""
        self.guidance.stop('the supervisor holds')
        self.flyby_initial = self.flyby_target = self.plan_stamp = None
        self.waiting.clear()

    def command(self, estimate, phase):
        self.waiting.append((estimate.t, estimate.r_hill, estimate.v_hill))
        return self.step_waiting(phase)

    def step_waiting(self, phase):
        """Step with the chaser estimates in order; one that re-aims waits for the target estimate of
        its own stamp."""
        g = self.guidance
        out = []
        while self.waiting:
            t, r_hill, v_hill = self.waiting[0]
            if g.next_burn_time is None or phase in QUIET_PHASES:
                self.waiting.clear()
                break
            if self.params.refine_target and g.wants_refined_target(t):
                target = self.targets.first_at_or_after(t)
                if target is None:
                    break
                out += self._refine(t, target)
            self.waiting.popleft()
            out += self._step(t, r_hill, v_hill)
        return out

    def _step(self, t, r_hill, v_hill):
        maneuvers, emitted = self.guidance.step(t, r_hill, v_hill)
        out = []
        for mv in maneuvers:
            out.append(mv)
            out.append(self._event(t, 'OK', events.MANEUVER_COMMANDED,
                                   f'{mv.kind} burn of {np.linalg.norm(mv.dv_hill) * 1e3:.2f} mm/s at t = {mv.t:.2f} s',
                                   event_payloads.encode(event_payloads.ManeuverCommanded(mv.kind, mv.t, mv.dv_hill),
                                                         mv.values)))
        return out + [e._replace(source=self.source) for e in emitted]

    def _unusable(self, omega_body, covariance):
        """Why the target estimate (omega_body, its error covariance or None) may not re-aim, or '' (module doc)."""
        if not has_spin_axis(self.params.target_inertia_kg_m2, omega_body):
            return 'has no spin axis (the target filter restarted)'
        if covariance is None:
            return ''
        largest = np.linalg.eigvalsh(np.array((covariance[:3, :3], covariance[3:, 3:])))[:, -1]
        att, rate = 3.0 * np.sqrt(np.maximum(largest, 0.0))
        if not self.params.convergence.met_by(att, rate):
            return (f'not converged (3-sigma {np.degrees(att):.3g} deg, {np.degrees(rate):.3g} deg/s; bounds '
                    f'{np.degrees(self.params.convergence.attitude_3sigma_rad):g} deg, '
                    f'{np.degrees(self.params.convergence.rate_3sigma_rad_s):g} deg/s)')
        return ''

    def _refine(self, t, target):
        """Re-aim at the grasp re-solved from the target estimate (stamp, (q, omega)), seed 000 §4.6, if the
        passive arc through it keeps off the target by that estimate (plan.check_passage, the planner's
        step 4, with the floor _GATE_MARGIN_M);
        otherwise keep the aim if its arc still is, or stop thrusting and report the fault (the
        supervisor aborts and escapes): a re-aim never flies the chaser onto an unsafe arc."""
        t_est, (q_hb, omega_body, blocks) = target
        aim = self.guidance.target
        if aim.t_f <= t_est:
            return []
        covariance = None if blocks is None else covariance_from_published(q_hb, *blocks)
        unusable = self._unusable(omega_body, covariance)
        if unusable:
            return [self._event(t, 'WARN', events.TARGET_REFINED, f'target estimate of t = {t_est:.2f} s {unusable}: '
                                                                  f'keeping the aim',
                                event_payloads.encode(event_payloads.TargetRefined()))]
        cfg = self.planner_config
        prediction = prediction_from_estimate(self.dynamics, self.n, t_est, q_hb, omega_body,
                                              aim.t_f + max(REFINE_HORIZON_S, cfg.geometry_window_s), covariance)
        g = refine_grasp(prediction, self.x_grasp_body, aim.t_f, self.n, t_latest=aim.t_f + REFINE_HORIZON_S)
        if g is not None:
            offset_m = offset_of_flyby_target(aim.x_ft, self.x_grasp_body)
            x_ft, v_ft = flyby_target_point(g.x_g, g.v_g, offset_m)  # eq 20-21
            check = check_passage(prediction, x_ft, v_ft, g.t_grasp, t, cfg, _GATE_MARGIN_M)
            if check.safe:
                shift = float(np.linalg.norm(x_ft - aim.x_ft))
                self.guidance.retarget(g.t_grasp, x_ft, v_ft)
                at_grasp = prediction.state(g.t_grasp)
                return [self._event(t, 'OK', events.TARGET_REFINED,
                                    f'grasp re-solved at t = {g.t_grasp:.3f} s, aim moved {shift * 1e3:.1f} mm',
                                    event_payloads.encode(event_payloads.TargetRefined(
                                        g.t_grasp, shift, g.x_g, g.v_g, x_ft, v_ft, at_grasp.q_hill_from_body,
                                        at_grasp.omega_body, check.gap_m)))]
            why = (f'the arc through the grasp re-solved at t = {g.t_grasp:.3f} s would come {check.gap_m:.3f} m '
                   f'from the {check.closest} at t = {check.t_min_gap:.1f} s (margin {check.margin_m:g} m)')
        else:
            why = 'no convex grasp near the planned one'
        kept = check_passage(prediction, aim.x_ft, aim.v_ft, aim.t_f, t, cfg, _GATE_MARGIN_M)
        if kept.safe:
            return [self._event(t, 'WARN', events.TARGET_REFINED, f'{why}; keeping the aim, whose arc keeps '
                                                             f'{kept.gap_m:.3f} m',
                                event_payloads.encode(event_payloads.TargetRefined(passage_gap_m=kept.gap_m)))]
        self.guidance.stop(f'no safe arc at t = {t:.1f} s')
        return [self._event(t, 'ERROR', events.PASSAGE_UNSAFE,
                            f'{why}, and the arc flown now would come {kept.gap_m:.3f} m from the {kept.closest} at '
                            f't = {kept.t_min_gap:.1f} s: no thrust onto either, escape',
                            {'passage_gap_m': kept.gap_m, 'closest': kept.closest, 't_min_gap_s': kept.t_min_gap})]
