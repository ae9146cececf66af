"""The summary of a run of several chasers (DESIGN §10 "Several chasers"; seed 003 Fig 12).

``summary.json`` keeps the single-chaser keys and adds ``chasers: {name: {...the same keys...}}``, each chaser's
summary from its own truth (``summary.compute_summary`` under its namespace, or ``summary.summarize``). The
top-level keys: ``outcome`` CAPTURE only when every chaser captured; COLLISION when any chaser's envelope was inside
the target's boxes before its capture, or inside another chaser's envelope at any time (the separation below); otherwise
the first chaser's outcome that is not CAPTURE (in the file's order). Sums over the chasers: ``delta_v_total_mps``,
``fuel_used_kg``, the maneuver counts; the least: ``min_clearance_m`` (with its time); the largest: the capture
errors; ``thrust_inside_restriction_sphere`` if any; the rest (phases, grasp time, method...) the first chaser's.

``min_separation_m``: the least distance between two chasers' envelopes (centre distance less both radii), truth,
at every common stamp; ``t_min_separation_s`` when, ``separation_pair`` which two. Frames: hill, SI.
"""

import itertools

import numpy as np

from flyby_mission.run_truth import chaser_truth_from_odometry
from flyby_mission.summary import compute_summary, figure_rows, format_rows, run_rows, timing_rows
from flyby_msgs_py import contract as c
from flyby_msgs_py.bag import read_bag

_SUMS = ('delta_v_total_mps', 'fuel_used_kg', 'maneuvers_executed', 'late_maneuvers', 'rejected_maneuvers',
         'planning_time_s')
_MAXIMA = ('capture_position_error_m', 'capture_velocity_error_mps')


def separation(positions, radii, t_free=None):
    """Least envelope separation of several chasers: positions {name: (t (K,), r_hill (K, 3))}, radii {name: m}.
    Returns (min_separation_m, t_s, (name_a, name_b), collided): collided if it is negative at a stamp <= t_free
    (the stamp until which no chaser is attached to the target; None: every stamp)."""
    best = (np.inf, None, None)
    collided = False
    for a, b in itertools.combinations(positions, 2):
        (t_a, r_a), (t_b, r_b) = positions[a], positions[b]
        t, i_a, i_b = np.intersect1d(t_a, t_b, return_indices=True)
        if not len(t):
            continue
        gap = np.linalg.norm(r_a[i_a] - r_b[i_b], axis=1) - radii[a] - radii[b]
        k = int(np.argmin(gap))
        if gap[k] < best[0]:
            best = (float(gap[k]), float(t[k]), (a, b))
        free = np.ones(len(t), bool) if t_free is None else t <= t_free
        collided = collided or bool(np.any(gap[free] < 0.0))
    return best[0] if best[1] is not None else None, best[1], best[2], collided


def combine(per_chaser, min_separation_m, t_min_separation_s, pair, collided):
    """The top-level summary of the chasers' summaries (module doc)."""
    names = list(per_chaser)
    first = per_chaser[names[0]]
    top = dict(first)
    outcomes = [per_chaser[n]['outcome'] for n in names]
    if collided or c.OUTCOME_COLLISION in outcomes:
        top['outcome'] = c.OUTCOME_COLLISION
    else:
        top['outcome'] = next((o for o in outcomes if o != c.OUTCOME_CAPTURE), c.OUTCOME_CAPTURE)
    for key in _SUMS:
        values = [per_chaser[n].get(key) for n in names]
        if all(v is not None for v in values):
            top[key] = sum(values)
    for key in _MAXIMA:
        values = [per_chaser[n].get(key) for n in names]
        top[key] = max(values) if all(v is not None for v in values) else None
    clear = [(per_chaser[n]['min_clearance_m'], per_chaser[n]['t_min_clearance_s']) for n in names
             if per_chaser[n].get('min_clearance_m') is not None]
    if clear:
        top['min_clearance_m'], top['t_min_clearance_s'] = min(clear)
    top['thrust_inside_restriction_sphere'] = any(per_chaser[n].get('thrust_inside_restriction_sphere')
                                                  for n in names)
    top['min_separation_m'] = min_separation_m
    top['t_min_separation_s'] = t_min_separation_s
    top['separation_pair'] = list(pair) if pair else None
    top['chasers'] = per_chaser
    return top


def compute_fleet_summary(bag_dir, scenario, end_reason, wall_time_s=float('nan'), **launcher):
    """The summary dict of a ``chasers:`` run from its bag (module doc)."""
    per_chaser, positions, radii = {}, {}, {}
    for name in scenario.chaser_names:
        view = scenario.for_chaser(name)
        per_chaser[name] = compute_summary(bag_dir, view, end_reason, None, wall_time_s, namespace=f'/{name}',
                                           **launcher)
        topic = c.absolute(c.SIM_CHASER_ODOM, f'/{name}')
        odom = read_bag(bag_dir, topics=[topic]).get(topic)
        if odom is not None and len(odom.t):
            truth = chaser_truth_from_odometry(odom) if view.chaser.model == 'rigid_body' else odom
            positions[name] = (np.asarray(truth.t), np.asarray(truth.position))
        radii[name] = view.chaser.envelope_radius_m
    # every stamp counts: two chasers attached to the target keep their distance, one attached is an obstacle
    return combine(per_chaser, *separation(positions, radii))


def format_fleet_summary(summary):
    """The terminal table of a run of several chasers: how the run went, the least separation of two chasers, the
    fleet's delta-v and fuel, then each chaser's own figures (summary.figure_rows, its outcome first) under its name,
    and the times. What is printed only; summary.json keeps its keys."""
    fleet = [*run_rows(summary)]
    if summary.get('min_separation_m') is not None:
        pair = ' - '.join(summary.get('separation_pair') or [])
        fleet.append(('min separation', f"{summary['min_separation_m']:.4g} m at t = "
                                        f"{summary['t_min_separation_s']:.6g} s ({pair})"))
    fleet += [(label, f'{summary[key]:.4g} {unit}') for label, key, unit in (
        ('delta-v, every chaser', 'delta_v_total_mps', 'm/s'), ('fuel, every chaser', 'fuel_used_kg', 'kg'))
        if summary.get(key) is not None]
    for name, own in summary['chasers'].items():
        fleet += [(name, ''), ('  outcome', own['outcome']),
                  *[(f'  {label}', text) for label, text in figure_rows(own)]]
    return format_rows(fleet + timing_rows(summary))
