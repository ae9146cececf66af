"""Fly-by guidance: terminal approach (seed 000 eq 27-29), trajectory adjusting (eq 24-26) and the
thruster-restriction sphere interlock (seed 000 section 4.1, seed 003 section 3.1).

Pure numpy, no ROS: ``FlybyGuidance`` is stepped with the chaser's *estimated* state and returns the
time-tagged maneuvers to command; the guidance node and the one-process loop (closed_loop) both
drive it. Frames and units as in flyby_sim.dynamics.orbital (hill; velocities relative to the rotating frame).

Sequence for a plan (t_Ti < t_i < t_f):

1. Transfer (terminal approach, eq 28): at t_Ti the first impulse of the CW transfer to X_Fi at t_i;
   ``midcourse_corrections`` more re-solves of eq 28 from the then-current estimate, evenly spaced
   in (t_Ti, t_i).
2. Injection at t_i (eq 29): the arrival impulse V_Fi - v(t_i), with the estimated arrival velocity
   in place of eq 29's predicted one.
3. Trajectory adjusting every ``adjust_interval_s`` after t_i, skipped inside the deadband / below the
   minimum impulse bit / when the predicted miss at the fly-by target point (eq 24) is within
   tolerance. The aim point is whatever ``retarget`` last set (the grasp re-solved from the latest
   target estimate), which is how timing and attitude-estimation errors are absorbed. Two laws
   (``adjust_law``):

   * ``eq26``: seed 000's least-squares impulse against the predicted position and velocity miss
     (eq 24-26). One impulse changes a coast's position miss by ~T dV and its velocity miss by dV,
     so it cannot remove the combination dX - T dV; with m and m/s weighed alike the position
     wins and a velocity miss stays (10-20 mm/s after a re-aim on a tumbler, beyond the
     manipulator's 10 mm/s).
   * ``arc`` (default): the passive arc through the aim point (X_Ft, V_Ft at t_f, coasted back by
     eq 22-23) is the path to be on. Each adjusting burn is eq 28 to the arc's position at the
     rendezvous: the adjusting burn ``arc_rendezvous_lead_s`` before the last one still outside the
     sphere, where that burn matches the arc's velocity: a two-impulse transfer onto the arc
     (eq 28-29 applied to it), re-solved at every burn as the aim moves. The burns after the
     rendezvous only trim, aimed at the arc at the last burn, and that last burn is eq 28 to X_Ft
     at t_f itself. So the last burn before the unguided coast is small and so is its execution
     error (a rendezvous at the last burn itself, as before, left it the whole velocity mismatch of
     the injection, 41 mm/s on a fast tumbler, whose execution error missed by 9 cm). Position and
     velocity at the grasp are both met to the navigation and execution error.
4. The first adjusting burn whose predicted arc would come within ``sphere_margin_m`` of the
   restriction sphere ends all thrusting: from there the chaser coasts (fly-by, then escape).

Each burn is computed ``command_lead_s`` before it starts, from the estimate carried to its start
time along CW (eq 22), and is sent stamped with that start time.
"""

import dataclasses

import numpy as np

from flyby_msgs_py import events, params
from flyby_msgs_py.wire import Event
from flyby_planner.flyby.passive_safety import LAST_BURN_SLACK_M
from flyby_planner.transfer import terminal_impulses
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2
from flyby_sim.dynamics.orbital import cw_coast, cw_transition_matrix
from flyby_sim.dynamics.propulsion import fuel_for_delta_v_kg

# Points checked along a predicted burn arc.
_ARC_SAMPLES = 9
ADJUST_LAWS = ('arc', 'eq26')


@params.record
class GuidanceConfig:
    """Guidance settings (the ``guidance`` section of docs/scenario.md) and the thruster limits: the fly-by's record
    (``flyby_msgs_py.params``; defaults, ranges and descriptions are the scenario schema's)."""

    mean_motion_rad_s: float = params.key('mean_motion_rad_s')
    restriction_sphere_radius_m: float = params.key('planner.restriction_sphere_radius_m')
    max_thrust_n: float = params.key('chaser.thrusters.max_thrust_n')
    chaser_mass_kg: float = params.key('chaser.mass_kg')
    exhaust_velocity_mps: float = params.key('chaser.thrusters.isp_s', lambda isp_s: isp_s * STANDARD_GRAVITY_M_S2)
    min_impulse_bit_ns: float = params.key('chaser.thrusters.min_impulse_bit_ns')
    max_delta_v_per_maneuver_mps: float = params.key('chaser.thrusters.max_delta_v_per_maneuver_mps')
    adjust_interval_s: float = params.key('guidance.adjust_interval_s')
    midcourse_corrections: int = params.key('guidance.midcourse_corrections')
    command_lead_s: float = params.key('guidance.command_lead_s')
    deadband_mps: float = params.key('guidance.deadband_mps')
    adjust_position_tolerance_m: float = params.key('guidance.adjust_position_tolerance_m')
    adjust_velocity_tolerance_mps: float = params.key('guidance.adjust_velocity_tolerance_mps')
    sphere_margin_m: float = params.key('guidance.sphere_margin_m')
    adjust_law: str = params.key('guidance.adjust_law')
    arc_rendezvous_lead_s: float = params.key('guidance.arc_rendezvous_lead_s')

    def __post_init__(self):
        if self.adjust_law not in ADJUST_LAWS:
            raise ValueError(f'adjust_law must be one of {ADJUST_LAWS}, got {self.adjust_law!r}')
        for name in ('mean_motion_rad_s', 'restriction_sphere_radius_m', 'max_thrust_n', 'chaser_mass_kg',
                     'exhaust_velocity_mps',
                     'adjust_interval_s', 'command_lead_s', 'adjust_position_tolerance_m',
                     'adjust_velocity_tolerance_mps'):
            require_positive(name, getattr(self, name))
        require_positive('arc_rendezvous_lead_s', self.arc_rendezvous_lead_s, allow_zero=True)
        require_positive('max_delta_v_per_maneuver_mps', self.max_delta_v_per_maneuver_mps, allow_inf=True)
        if self.midcourse_corrections < 0:
            raise ValueError(f'midcourse_corrections must be >= 0, got {self.midcourse_corrections}')


@dataclasses.dataclass(frozen=True)
class FlybyTarget:
    """What the planner decided: first burn time t_ti, X_Fi/V_Fi at t_i (eq 23), X_Ft/V_Ft at t_f (eq 20-21)."""

    t_ti: float
    t_i: float
    x_fi: np.ndarray
    v_fi: np.ndarray
    t_f: float
    x_ft: np.ndarray
    v_ft: np.ndarray


@dataclasses.dataclass(frozen=True)
class Maneuver:
    """A commanded impulse: start time t [s], dv_hill [m/s], kind ('transfer', 'midcourse', 'injection',
    'adjust'), and the figures behind it (predicted miss before the burn, for an adjust)."""

    t: float
    dv_hill: np.ndarray
    kind: str
    values: dict


def predicted_miss(r_hill, v_hill, x_ft, v_ft, time_to_go_s, n):
    """Position and velocity error at the fly-by target point if the chaser coasts, seed 000 eq 24."""
    return cw_coast(r_hill, v_hill, time_to_go_s, n) - np.concatenate((x_ft, v_ft))


def adjusting_delta_v(r_hill, v_hill, x_ft, v_ft, time_to_go_s, n):
    """The trajectory-adjusting impulse, seed 000 eq 24-26, and the miss it corrects.

    Eq 26 gives the least-squares Delta V with [Phi12; Phi22] Delta V = [dX; dV] (eq 25): the impulse
    that would *cause* the predicted miss. The burn that cancels it is its negative, so the returned
    dv minimizes |[Phi12; Phi22] dv + miss| (test_eq26_is_the_least_squares_optimum).

    Returns:
        (dv_hill [m/s] (3,), miss (6,) [m, m/s] before the burn).
    """
    miss = predicted_miss(r_hill, v_hill, x_ft, v_ft, time_to_go_s, n)  # eq 24
    phi = cw_transition_matrix(n, time_to_go_s)
    a = phi[:, 3:]  # [Phi12; Phi22]
    dv_eq26 = np.linalg.solve(a.T @ a, a.T @ miss)  # eq 26
    return -dv_eq26, miss


def burn_arc(r_hill, v_hill, dv_hill, mass_kg, max_thrust_n, n):
    """Predicted positions (K, 3) over a finite burn at max thrust delivering dv_hill from (r, v).

    The burn lasts m |dv| / F (a few seconds); over it the coast is CW and the thrust adds a constant
    acceleration dv / T along the command (position offset a tau^2 / 2).
    """
    dv = np.asarray(dv_hill, dtype=float)
    duration = mass_kg * float(np.linalg.norm(dv)) / max_thrust_n
    taus = np.linspace(0.0, duration, _ARC_SAMPLES)
    accel = dv / duration if duration > 0.0 else np.zeros(3)
    return np.array([cw_coast(r_hill, v_hill, tau, n)[:3] + 0.5 * accel * tau * tau for tau in taus])


class FlybyGuidance:
    """Guidance of one fly-by (module doc). ``set_target`` starts it, ``step`` is called with each estimate.

    The chaser mass (burn durations, minimum impulse bit) is tracked from the commanded delta-v by the
    rocket equation, as the navigation filter does.
    """

    def __init__(self, config):
        self.config = config
        self.mass_kg = config.chaser_mass_kg
        self.target = None
        self.schedule = []  # (t, kind) of the burns still to compute, in time order
        self.thrust_ended = None  # why thrusting has ended, once it has
        self.commanded = []

    def set_target(self, target):
        """A new plan: schedule its transfer, midcourse corrections, injection and adjusting."""
        cfg = self.config
        self.target = target
        k = cfg.midcourse_corrections
        span = target.t_i - target.t_ti
        self.schedule = ([(target.t_ti, 'transfer')]
                         + [(target.t_ti + span * (j + 1) / (k + 1), 'midcourse') for j in range(k)]
                         + [(target.t_i, 'injection')])
        self.thrust_ended = None

    def retarget(self, t_f, x_ft, v_ft):
        """Aim the adjusting burns at a refined fly-by target point (the re-solved grasp)."""
        if self.target is not None:
            self.target = dataclasses.replace(self.target, t_f=float(t_f), x_ft=np.asarray(x_ft, dtype=float),
                                              v_ft=np.asarray(v_ft, dtype=float))

    def stop(self, why):
        """No more burns for this plan (a fault: the supervisor decides what follows)."""
        self.schedule = []
        self.thrust_ended = why

    def wants_refined_target(self, t):
        """True when the next burn is an adjusting one due within command_lead_s of t: re-aim first."""
        return bool(self.schedule) and self.schedule[0][1] == 'adjust' \
            and t >= self.schedule[0][0] - self.config.command_lead_s

    @property
    def next_burn_time(self):
        """Start time of the next scheduled burn, or None."""
        return self.schedule[0][0] if self.schedule else None

    def step(self, t, r_hill, v_hill):
        """Maneuvers to command now (each to start at its stamp >= t) and events, from the estimate at t."""
        cfg = self.config
        maneuvers, events = [], []
        while self.schedule and t >= self.schedule[0][0] - cfg.command_lead_s:
            t_burn, kind = self.schedule.pop(0)
            t_burn = max(t_burn, t + cfg.command_lead_s) if t_burn < t else t_burn
            state = cw_coast(r_hill, v_hill, t_burn - t, cfg.mean_motion_rad_s)
            m, e = self._burn(t_burn, kind, state[:3], state[3:], self.mass_kg)
            for mv in m:
                self.mass_kg -= fuel_for_delta_v_kg(self.mass_kg, float(np.linalg.norm(mv.dv_hill)),
                                                    cfg.exhaust_velocity_mps)
            maneuvers += m
            events += e
        self.commanded += maneuvers
        return maneuvers, events

    def _burn(self, t_burn, kind, r, v, mass_kg):
        cfg, tg = self.config, self.target
        n = cfg.mean_motion_rad_s
        values = {}
        if kind in ('transfer', 'midcourse'):
            dv, _ = terminal_impulses(r, v, tg.x_fi, tg.v_fi, tg.t_i - t_burn, n)  # eq 28
        elif kind == 'injection':
            dv = tg.v_fi - v  # eq 29 with the estimated arrival velocity
            self._schedule_adjust(t_burn + cfg.adjust_interval_s)
        elif cfg.adjust_law == 'eq26':
            dv, miss = adjusting_delta_v(r, v, tg.x_ft, tg.v_ft, tg.t_f - t_burn, n)  # eq 24-26
            values = {'miss_position_m': float(np.linalg.norm(miss[:3])),
                      'miss_velocity_mps': float(np.linalg.norm(miss[3:]))}
        else:
            miss = predicted_miss(r, v, tg.x_ft, tg.v_ft, tg.t_f - t_burn, n)  # eq 24
            t_aim, x_aim, v_aim = self._arc_aim(t_burn)
            dv, _ = terminal_impulses(r, v, x_aim, v_aim, t_aim - t_burn, n)  # eq 28 onto the arc
            values = {'miss_position_m': float(np.linalg.norm(miss[:3])),
                      'miss_velocity_mps': float(np.linalg.norm(miss[3:])), 'aim_time_s': t_aim}
        arc = burn_arc(r, v, dv, mass_kg, cfg.max_thrust_n, n)
        closest = float(np.linalg.norm(arc, axis=1).min())
        limit = cfg.restriction_sphere_radius_m + cfg.sphere_margin_m
        if closest < limit:
            # The interlock: no thrust near the sphere, ever again in this fly-by (seed 000 section 4.1).
            self.schedule = []
            self.thrust_ended = f'{kind} burn at t = {t_burn:.1f} s would thrust {closest:.2f} m from the target'
            return [], [Event(t_burn, 'OK' if kind == 'adjust' else 'ERROR', events.THRUSTING_ENDED,
                                      f'{self.thrust_ended} (< sphere {cfg.restriction_sphere_radius_m:g} m + margin '
                                      f'{cfg.sphere_margin_m:g} m); coasting from here',
                                      {'closest_m': closest, **values})]
        if kind == 'adjust':
            small = (values['miss_position_m'] < cfg.adjust_position_tolerance_m
                     and values['miss_velocity_mps'] < cfg.adjust_velocity_tolerance_mps)
            smallest = max(cfg.deadband_mps, cfg.min_impulse_bit_ns / mass_kg)
            self._schedule_adjust(t_burn + cfg.adjust_interval_s)
            if small or np.linalg.norm(dv) < smallest:
                why = 'predicted miss within tolerance' if small else f'|dv| below {smallest:.2g} m/s'
                return [], [Event(t_burn, 'OK', events.ADJUST_SKIPPED, why,
                                          {**values, 'dv_mps': float(np.linalg.norm(dv))})]
        size = float(np.linalg.norm(dv))
        if size > cfg.max_delta_v_per_maneuver_mps:
            dv = dv * (cfg.max_delta_v_per_maneuver_mps / size)
            values['clipped_from_mps'] = size
        return [Maneuver(t_burn, dv, kind, {**values, 'closest_m': closest})], []

    def _arc_aim(self, t_burn):
        """(time, position, velocity) the ``arc`` law aims an adjusting burn at: the passive arc's state at
        the latest later adjusting burn at least arc_rendezvous_lead_s before the last one that will still
        be outside the sphere, or, once that is past, at that last one; X_Ft, V_Ft at t_f when this burn
        is the last one (a two-impulse transfer onto the arc, re-solved at every burn)."""
        cfg, tg = self.config, self.target
        n = cfg.mean_motion_rad_s
        outside = cfg.restriction_sphere_radius_m + cfg.sphere_margin_m + LAST_BURN_SLACK_M
        ahead = []  # (t, arc state) at the later adjusting burns still outside the sphere
        t_k = t_burn + cfg.adjust_interval_s
        while t_k < tg.t_f:
            arc = cw_coast(tg.x_ft, tg.v_ft, t_k - tg.t_f, n)  # eq 23
            if np.linalg.norm(arc[:3]) <= outside:
                break
            ahead.append((t_k, arc))
            t_k += cfg.adjust_interval_s
        if not ahead:
            return tg.t_f, tg.x_ft, tg.v_ft
        t_last = ahead[-1][0]
        t_aim, arc = max((a for a in ahead if a[0] <= t_last - cfg.arc_rendezvous_lead_s + 1e-6),
                         key=lambda a: a[0], default=ahead[-1])
        return t_aim, arc[:3], arc[3:]

    def _schedule_adjust(self, t_next):
        if self.target is not None and t_next < self.target.t_f:
            self.schedule.append((t_next, 'adjust'))
