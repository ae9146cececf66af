"""The mission phase machine of DESIGN §4 and the capture decision (seed 000 §2.2, §4.1; seed 003 §3.1).

Pure Python, no ROS: the supervisor node feeds it what it observes (estimate stamps, events, the plan,
node progress, the clock) and publishes the transitions it returns. Every transition is caused by an
observable condition and carries its reason:

    ESTIMATION        -> PLANNING           target estimate converged and min_observation_s of data
    PLANNING          -> TERMINAL_APPROACH  the planner selected a plan
    PLANNING          -> ABORTED            the planner refused (no safe fly-by; the chaser stays put)
    TERMINAL_APPROACH -> TRAJECTORY_ADJUST  an estimate at or after the injection time t_i
    TRAJECTORY_ADJUST -> FLYBY              guidance ended thrusting, or the chaser is inside the sphere
    FLYBY             -> CAPTURE | ESCAPE   at the grasp time, from the estimated relative state
    CAPTURE           -> COMPLETE           after capture_hold_s attached
    ESCAPE            -> COMPLETE           after escape_observation_s of passive escape
    any active phase  -> ABORTED            abort request, a watched node silent for watchdog_s, or a
                                            fault (ERROR event) reported by a watched node
"""

import dataclasses
import math

import numpy as np

from flyby_msgs_py import contract as c

ACTIVE_PHASES = (c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH, c.PHASE_TRAJECTORY_ADJUST,
                 c.PHASE_FLYBY)
# Phases in which a silent or faulty node aborts the mission (after FLYBY nothing is left to command).
WATCHED_PHASES = ACTIVE_PHASES


@dataclasses.dataclass(frozen=True)
class SupervisorConfig:
    min_observation_s: float
    restriction_sphere_radius_m: float
    reach_m: float
    position_tolerance_m: float
    velocity_tolerance_mps: float
    capture_hold_s: float
    escape_observation_s: float
    watchdog_s: float
    watched_nodes: tuple = ('flyby_estimator', 'flyby_guidance')


def supervisor_config_from_scenario(scenario, watched_nodes=('flyby_estimator', 'flyby_guidance')):
    m, s = scenario.chaser.manipulator, scenario.supervisor
    return SupervisorConfig(
        min_observation_s=scenario.planner.min_observation_s,
        restriction_sphere_radius_m=scenario.planner.restriction_sphere_radius_m, reach_m=m.reach_m,
        position_tolerance_m=m.position_tolerance_m, velocity_tolerance_mps=m.velocity_tolerance_mps,
        capture_hold_s=s.capture_hold_s,
        escape_observation_s=scenario.planner.escape_check_orbits * scenario.orbit_period_s,
        watchdog_s=s.watchdog_s, watched_nodes=tuple(watched_nodes))


@dataclasses.dataclass(frozen=True)
class Transition:
    t: float
    phase_from: str
    phase_to: str
    reason: str
    values: dict


@dataclasses.dataclass(frozen=True)
class CaptureDecision:
    capture: bool
    reason: str
    values: dict


def capture_decision(r_hill, v_hill, x_g, x_ft, v_ft, config):
    """Capture if the manipulator can absorb the estimated error (seed 000 section 4.1).

    The chaser, estimated at (r, v) at the grasp time, must be within position_tolerance_m and
    velocity_tolerance_mps of the fly-by target point (X_Ft, V_Ft: where it should be, moving as the
    grasp point's offset does, eq 20-21) and the grasp point x_g within reach_m. Otherwise escape.
    """
    e_pos = float(np.linalg.norm(np.asarray(r_hill) - x_ft))
    e_vel = float(np.linalg.norm(np.asarray(v_hill) - v_ft))
    reach = float(np.linalg.norm(np.asarray(x_g) - r_hill))
    values = {'position_error_m': e_pos, 'velocity_error_mps': e_vel, 'grasp_distance_m': reach}
    problems = []
    if e_pos > config.position_tolerance_m:
        problems.append(f'position error {e_pos:.3f} m > {config.position_tolerance_m:g} m')
    if e_vel > config.velocity_tolerance_mps:
        problems.append(f'velocity error {e_vel * 1e3:.1f} mm/s > {config.velocity_tolerance_mps * 1e3:g} mm/s')
    if reach > config.reach_m:
        problems.append(f'grasp point {reach:.3f} m away > reach {config.reach_m:g} m')
    if problems:
        return CaptureDecision(False, 'escape: ' + '; '.join(problems), values)
    return CaptureDecision(True, f'capture: position error {e_pos * 100:.1f} cm, velocity error '
                                 f'{e_vel * 1e3:.2f} mm/s, grasp point {reach:.2f} m away', values)


class PhaseMachine:
    """The phase logic (module doc). Each input method returns the list of transitions it caused."""

    def __init__(self, config):
        self.config = config
        self.phase = c.PHASE_ESTIMATION
        self.t_first_estimate = None
        self.converged = False
        self.t_i = None
        self.t_grasp = None
        self.t_entered = 0.0
        self.progress = {}  # watched node -> sim time it last reported
        self.decision = None

    # -- helpers --------------------------------------------------------------------------------
    def _go(self, t, phase, reason, values=None):
        tr = Transition(t, self.phase, phase, reason, dict(values or {}))
        self.phase = phase
        self.t_entered = t
        return [tr]

    @property
    def active(self):
        return self.phase in ACTIVE_PHASES

    # -- inputs ---------------------------------------------------------------------------------
    def target_estimate(self, t):
        if self.t_first_estimate is None:
            self.t_first_estimate = t
        return self._maybe_plan(t)

    def _maybe_plan(self, t):
        if self.phase != c.PHASE_ESTIMATION or not self.converged or self.t_first_estimate is None:
            return []
        observed = t - self.t_first_estimate
        if observed < self.config.min_observation_s:
            return []
        return self._go(t, c.PHASE_PLANNING, f'target estimate converged; {observed:.1f} s of attitude data',
                        {'observation_s': observed})

    def event(self, t, level, name, source, values):
        """An event from /mission/events (not our own)."""
        if name == 'target_converged':
            self.converged = True
            return self._maybe_plan(t)
        if name == 'target_diverged':
            self.converged = False
            return []
        if name == 'plan_selected' and self.phase == c.PHASE_PLANNING:
            self.t_i = float(values['t_i_s'])
            self.t_grasp = float(values['t_grasp_s'])
            return self._go(t, c.PHASE_TERMINAL_APPROACH, f'plan selected: grasp at t = {self.t_grasp:.2f} s, '
                                                          f'injection at {self.t_i:.2f} s',
                            {'t_grasp_s': self.t_grasp, 't_i_s': self.t_i})
        if name == 'plan_refused' and self.phase == c.PHASE_PLANNING:
            return self._go(t, c.PHASE_ABORTED, f'no fly-by: {values.get("reason", "the planner refused")}')
        if name == 'target_refined' and 't_grasp_s' in values:
            self.t_grasp = float(values['t_grasp_s'])
            return []
        if name == 'thrusting_ended' and self.phase == c.PHASE_TRAJECTORY_ADJUST:
            return self._go(t, c.PHASE_FLYBY, 'guidance ended thrusting: passive fly-by')
        if level == 'ERROR' and source in self.config.watched_nodes and self.phase in WATCHED_PHASES:
            return self._go(t, c.PHASE_ABORTED, f'fault reported by {source}: {name}',
                            {'source': source, 'event': name})
        return []

    def chaser_estimate(self, t, r_hill):
        """Transitions due at a chaser estimate; the capture decision is ``decide`` (it needs the target)."""
        if self.phase == c.PHASE_TERMINAL_APPROACH and t >= self.t_i:
            return self._go(t, c.PHASE_TRAJECTORY_ADJUST, f'injection time t_i = {self.t_i:.2f} s reached')
        if self.phase == c.PHASE_TRAJECTORY_ADJUST and np.linalg.norm(r_hill) < self.config.restriction_sphere_radius_m:
            return self._go(t, c.PHASE_FLYBY, 'inside the restriction sphere: passive fly-by')
        return []

    def wants_decision(self, t):
        """True at the first chaser estimate at or after the grasp time in FLYBY."""
        return self.phase == c.PHASE_FLYBY and self.t_grasp is not None and t >= self.t_grasp

    def decide(self, t, decision):
        """Apply a CaptureDecision made at the grasp time."""
        self.decision = decision
        return self._go(t, c.PHASE_CAPTURE if decision.capture else c.PHASE_ESCAPE, decision.reason,
                        {'t_grasp_s': self.t_grasp, **decision.values})

    def node_progress(self, node, t):
        if node in self.config.watched_nodes:
            self.progress[node] = max(t, self.progress.get(node, -math.inf))
        return []

    def clock(self, t):
        """Timers: the watchdog in the active phases, the holds before COMPLETE."""
        if self.phase in WATCHED_PHASES:
            for node in self.config.watched_nodes:
                last = self.progress.get(node, 0.0)
                if t - last > self.config.watchdog_s:
                    return self._go(t, c.PHASE_ABORTED, f'watchdog: {node} silent for {t - last:.1f} s',
                                    {'node': node, 'last_progress_s': last})
        if self.phase == c.PHASE_CAPTURE and t - self.t_entered >= self.config.capture_hold_s:
            return self._go(t, c.PHASE_COMPLETE, f'attached for {t - self.t_entered:.1f} s')
        if self.phase == c.PHASE_ESCAPE and t - self.t_entered >= self.config.escape_observation_s:
            return self._go(t, c.PHASE_COMPLETE, f'passive escape observed for {t - self.t_entered:.1f} s')
        return []

    def abort(self, t, why):
        if not self.active:
            return []
        return self._go(t, c.PHASE_ABORTED, why)
