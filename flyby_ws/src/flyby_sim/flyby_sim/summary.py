"""The figures of a run (DESIGN §7 ``summary.json``), computed from the truth topics of its bag.

Nothing here trusts what a node claimed about itself: delta-v and fuel come from the applied thrust
(``/sim/chaser/thrust`` is the mean force over each step, so force x step is the exact impulse),
clearance from the truth poses and the scenario's geometry.
"""

import math

import numpy as np

from flyby_msgs_py import contract as c
from flyby_msgs_py.bag import read_bag
from flyby_sim.geometry import clearance
from flyby_sim.thrusters import STANDARD_GRAVITY_M_S2
EXIT_CODES = {'CAPTURE': 0, 'ESCAPE': 3, 'ABORTED': 3, 'TIME_LIMIT': 3, 'INTERRUPTED': 130,
              'ERROR': 1}
TRUTH_TOPICS = [c.absolute(t) for t in (c.CLOCK, c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM,
                                        c.SIM_CHASER_THRUST, c.MISSION_PHASE, c.MISSION_EVENTS)]


def outcome_of(end_reason, phases):
    """Outcome from how the run ended and the phases it went through."""
    if end_reason == 'interrupted':
        return 'INTERRUPTED'
    if end_reason is None or end_reason.startswith('error'):
        return 'ERROR'
    if c.PHASE_ABORTED in phases:
        return 'ABORTED'
    if c.PHASE_CAPTURE in phases:
        return 'CAPTURE'
    if c.PHASE_ESCAPE in phases:
        return 'ESCAPE'
    return 'TIME_LIMIT'


def thrust_figures(t, force_hill, r_hill, mass0_kg, isp_s, sphere_radius_m):
    """Delta-v [m/s], fuel [kg] and whether any thrust acted inside the restriction sphere."""
    if len(t) < 2:
        return 0.0, 0.0, False
    dt = np.diff(t)
    impulse = np.linalg.norm(force_hill[1:], axis=1) * dt
    v_exhaust = isp_s * STANDARD_GRAVITY_M_S2
    fuel_steps = impulse / v_exhaust
    mass_before = mass0_kg - np.concatenate(([0.0], np.cumsum(fuel_steps)[:-1]))
    # Rocket equation per step (thrust magnitude is constant within a step's burn).
    dv_steps = v_exhaust * np.log(mass_before / (mass_before - fuel_steps))
    firing = impulse > 0.0
    # A step's force acted between the previous sample and this one: check both ends.
    inside = (np.linalg.norm(r_hill[1:], axis=1) < sphere_radius_m) | \
             (np.linalg.norm(r_hill[:-1], axis=1) < sphere_radius_m)
    return (float(np.sum(dv_steps)), float(np.sum(fuel_steps)),
            bool(np.any(firing & inside)))


def compute_summary(bag_dir, scenario, end_reason, final_phase=None, wall_time_s=float('nan'),
                    node_exit_codes=None, nodes_killed=(), bag_repair=None):
    """The summary dict of a run from its bag; robust to a bag cut short by an interruption."""
    data = read_bag(bag_dir, topics=TRUTH_TOPICS)
    chaser = data.get(c.absolute(c.SIM_CHASER_ODOM))
    target = data.get(c.absolute(c.SIM_TARGET_ODOM))
    thrust = data.get(c.absolute(c.SIM_CHASER_THRUST))
    phase_msgs = data.get(c.absolute(c.MISSION_PHASE))
    events = data.get(c.absolute(c.MISSION_EVENTS)) or []
    phases = list(phase_msgs.data) if phase_msgs is not None else []
    if final_phase is None and phases:
        final_phase = phases[-1]

    sim_time_s = float(chaser.t[-1]) if chaser is not None and len(chaser.t) else 0.0
    sphere_m = scenario.planner.restriction_sphere_radius_m
    delta_v = fuel = 0.0
    thrust_inside = False
    if thrust is not None and chaser is not None and len(thrust.t):
        r_at_thrust = chaser.position[np.searchsorted(chaser.t, thrust.t).clip(0, len(chaser.t) - 1)]
        delta_v, fuel, thrust_inside = thrust_figures(
            thrust.t, thrust.force, r_at_thrust, scenario.chaser.mass_kg,
            scenario.chaser.thrusters.isp_s, sphere_m)

    min_clearance = t_min_clearance = None
    if chaser is not None and target is not None and len(chaser.t) and len(target.t):
        t_common, i_c, i_t = np.intersect1d(chaser.t, target.t, return_indices=True)
        boxes = [(b.center_m, b.size_m) for b in scenario.target.geometry]
        gaps = clearance(chaser.position[i_c], target.orientation_xyzw[i_t], boxes,
                         scenario.chaser.envelope_radius_m)
        k = int(np.argmin(gaps))
        min_clearance, t_min_clearance = float(gaps[k]), float(t_common[k])

    def count(name):
        return sum(1 for e in events if e['name'] == name)

    return {
        'outcome': outcome_of(end_reason, phases),
        'final_phase': final_phase,
        'end_reason': end_reason,
        'scenario': scenario.name,
        'seed': scenario.seed,
        't_grasp_s': None,
        'capture_position_error_m': None,
        'capture_velocity_error_mps': None,
        'delta_v_total_mps': delta_v,
        'fuel_used_kg': fuel,
        'min_clearance_m': min_clearance,
        't_min_clearance_s': t_min_clearance,
        'restriction_sphere_radius_m': sphere_m,
        'thrust_inside_restriction_sphere': thrust_inside,
        'maneuvers_executed': count('burn_started'),
        'late_maneuvers': count('late_maneuver'),
        'rejected_maneuvers': count('maneuver_rejected'),
        'sim_time_s': sim_time_s,
        'wall_time_s': wall_time_s,
        'real_time_factor': sim_time_s / wall_time_s if wall_time_s > 0 else None,
        'node_exit_codes': node_exit_codes or {},
        'nodes_killed': list(nodes_killed),
        'bag_repair': bag_repair,
    }


def format_summary(summary):
    """A short table of the figures a user reads first."""
    def fmt(value, unit='', digits=4):
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return '-'
        if isinstance(value, float):
            return f'{value:.{digits}g} {unit}'.strip()
        return f'{value} {unit}'.strip()

    rows = [
        ('outcome', fmt(summary['outcome'])),
        ('final phase', fmt(summary['final_phase'])),
        ('end reason', fmt(summary['end_reason'])),
        ('seed', fmt(summary['seed'])),
        ('grasp time', fmt(summary['t_grasp_s'], 's')),
        ('capture position error', fmt(summary['capture_position_error_m'], 'm')),
        ('capture velocity error', fmt(summary['capture_velocity_error_mps'], 'm/s')),
        ('delta-v total', fmt(summary['delta_v_total_mps'], 'm/s')),
        ('fuel used', fmt(summary['fuel_used_kg'], 'kg')),
        ('min clearance', fmt(summary['min_clearance_m'], 'm')),
        ('thrust inside sphere', fmt(summary['thrust_inside_restriction_sphere'])),
        ('late maneuvers', fmt(summary['late_maneuvers'])),
        ('sim time', fmt(summary['sim_time_s'], 's', 6)),
        ('wall time', fmt(summary['wall_time_s'], 's')),
        ('real-time factor', fmt(summary['real_time_factor'], 'x', 3)),
    ]
    width = max(len(k) for k, _ in rows)
    return '\n'.join(f'{k:<{width}}  {v}' for k, v in rows)
