"""The figures of a run (DESIGN §7, §10 ``summary.json``), computed from its truth.

Both drivers write the same summary by the same function, ``summarize``: the graph from the truth
topics of its bag (``compute_summary``), the headless driver (flyby_mission.headless) from the
plant's truth samples, stamped as the messages would be. Nothing here trusts what a node claimed
about itself: delta-v and fuel come from the applied thrust (``/sim/chaser/thrust`` is the mean force
over each step, so force x step is the exact impulse), clearance and collision from the truth poses
and the scenario's geometry, the capture errors from the truth at the grasp time. The claims used
are *which* grasp time (the one the supervisor decided at) and the phases the mission went through.
"""

import math

import numpy as np

from flyby_mission.approach_figures import (
    approach_figures,
    capture_errors,
    least_clearance_index,
    pointing_figures,
    sync_figures,
    thrust_figures,
)
from flyby_mission.post_capture_figures import post_capture_figures, transport_figures
from flyby_mission.run_events import (
    cam_time,
    chosen_method,
    fault_detections,
    fault_responses,
    grasp_time,
    no_safe_plan_reason,
    phase_start,
    planned_flyby,
    plant_faults,
    supervisor_error,
)
from flyby_mission.run_truth import (
    RIGID_TRUTH_TOPICS,
    TRUTH_TOPICS,
    ThrustTruth,
    chaser_truth_from_odometry,
    fuel_steps,
    thrust_truth,
)
from flyby_msgs_py import contract as c
from flyby_msgs_py import events as ev
from flyby_msgs_py.bag import read_bag
from flyby_planner.flyby.grasp_search import capture_target_body
from flyby_sim.dynamics.geometry import clearance

# Process exit code of each outcome: 0 capture, 3 safe without capture, 5 collision, 130 interrupted, 1 error.
EXIT_CODES = {c.OUTCOME_CAPTURE: 0, c.OUTCOME_ESCAPE: 3, c.OUTCOME_NO_SAFE_PLAN: 3, c.OUTCOME_ABORTED: 3,
              c.OUTCOME_TIME_LIMIT: 3, c.OUTCOME_COLLISION: 5, c.OUTCOME_INTERRUPTED: 130, c.OUTCOME_ERROR: 1}


def outcome_of(end_reason, phases, collided=False, refused=False, held=False):
    """Outcome (DESIGN §10) from how the run ended, the phases it went through, whether the truth shows
    a collision before any capture and whether the plan was refused before anything was flown; held: the run
    started with the chaser holding the target (post_capture.start attached), a capture from t = 0."""
    if collided:
        return c.OUTCOME_COLLISION
    if end_reason == 'interrupted':
        return c.OUTCOME_INTERRUPTED
    if end_reason is None or end_reason.startswith('error'):
        return c.OUTCOME_ERROR
    if c.PHASE_ABORTED in phases:
        return c.OUTCOME_ABORTED
    if refused and c.PHASE_TERMINAL_APPROACH not in phases:
        return c.OUTCOME_NO_SAFE_PLAN
    if c.PHASE_ESCAPE in phases:  # a decision to escape, or a grasp that let go (GRASP -> ESCAPE)
        return c.OUTCOME_ESCAPE
    if c.PHASE_CAPTURE in phases or held:
        return c.OUTCOME_CAPTURE
    return c.OUTCOME_TIME_LIMIT


def compute_summary(bag_dir, scenario, end_reason, final_phase=None, wall_time_s=float('nan'), namespace='',
                    **launcher):
    """The summary dict of a run from its bag; robust to a bag cut short by an interruption. ``launcher``:
    what only the launcher knows (summarize's node_exit_codes, nodes_killed, bag_repair, faults_injected).
    ``namespace``: the chaser's (``/chaser1``) of a ``chasers:`` scenario, whose view ``scenario`` is."""
    rigid = scenario.chaser.model == 'rigid_body'
    wheels_topics = [c.SIM_CHASER_WHEELS] if scenario.post_capture is not None else []
    data = read_bag(bag_dir, topics=[c.absolute(t, namespace) for t in TRUTH_TOPICS + (RIGID_TRUTH_TOPICS if rigid
                                                                                      else []) + wheels_topics])
    if namespace:  # the chaser's topics by their single-chaser names
        data = {(name[len(namespace):] if name.startswith(namespace + '/') else name): v for name, v in data.items()}
    chaser = data.get(c.absolute(c.SIM_CHASER_ODOM))
    if rigid:
        chaser = chaser_truth_from_odometry(chaser)
    target = data.get(c.absolute(c.SIM_TARGET_ODOM))
    try:
        thrust = thrust_truth(data.get(c.absolute(c.SIM_CHASER_THRUST)),
                              data[c.absolute(c.SIM_CHASER_THRUSTERS)] if rigid else None)
    except ValueError as err:
        raise ValueError(f'{bag_dir}: {err}') from None
    phase_msgs = data.get(c.absolute(c.MISSION_PHASE))
    events = data.get(c.absolute(c.MISSION_EVENTS)) or []
    phases = list(phase_msgs.data) if phase_msgs is not None else []
    return summarize(chaser, target, thrust, phases, events, scenario, end_reason, final_phase, wall_time_s,
                     wheels=data.get(c.absolute(c.SIM_CHASER_WHEELS)), **launcher)


def summarize(chaser, target, thrust, phases, events, scenario, end_reason, final_phase=None,
              wall_time_s=float('nan'), node_exit_codes=None, nodes_killed=(), bag_repair=None, faults_injected=None,
              wheels=None):
    """The summary dict of a run from its truth (ChaserTruth, TargetTruth, ThrustTruth or the bag's series
    with the same fields, any of them None), the phases in order and the events (dicts with t, level,
    name, message, values (text), hardware_id). The next four are the launcher's: the nodes' exit codes,
    the nodes it killed, its repair of the bag and the faults it injected (none for the headless driver).
    wheels: the wheels' truth (t (N,), velocity (N, M) [rad/s] relative to the body, /sim/chaser/wheels), read
    with a post_capture section.

    After the capture (post_capture, DESIGN §10) the combined body fires inside the restriction sphere by design:
    delta_v_total_mps and thrust_inside_restriction_sphere are the approach's (up to the capture), fuel_used_kg the
    whole run's."""
    if final_phase is None and phases:
        final_phase = phases[-1]
    has_chaser = chaser is not None and len(chaser.t)
    has_target = target is not None and len(target.t)
    sim_time_s = float(chaser.t[-1]) if has_chaser else 0.0
    sphere_m = scenario.planner.restriction_sphere_radius_m
    held = scenario.post_capture is not None and scenario.post_capture.start == 'attached'
    approach = _approach_thrust(thrust, events, scenario, held)
    delta_v, fuel, thrust_inside = _thrust_totals(chaser, thrust, approach, scenario, has_chaser)

    t_g = grasp_time(events)
    offset_m, flyby_duration_s = planned_flyby(events)
    min_clearance = t_min_clearance = None
    collided = False
    e_pos = e_vel = None
    if has_chaser and has_target:
        min_clearance, t_min_clearance, collided, e_pos, e_vel = _clearance_and_capture(
            chaser, target, phases, events, scenario, held, t_g, offset_m)
    figures = _phase_figures(chaser if has_chaser else None, target if has_target else None, approach, thrust, wheels,
                             events, scenario, t_g)

    refused = no_safe_plan_reason(events)
    end_reason = _judged_end_reason(end_reason, events)
    outcome = outcome_of(end_reason, phases, collided, refused is not None, held)
    if outcome == c.OUTCOME_NO_SAFE_PLAN:
        end_reason = refused

    def count(name):
        return sum(1 for e in events if e['name'] == name)

    return {
        'outcome': outcome,
        'final_phase': final_phase,
        'end_reason': end_reason,
        'method': chosen_method(events),
        'phase_sequence': list(phases),
        'scenario': scenario.name,
        'seed': scenario.seed,
        't_grasp_s': t_g,
        'flyby_offset_m': offset_m,
        'flyby_duration_s': flyby_duration_s,
        'capture_position_error_m': e_pos,
        'capture_velocity_error_mps': e_vel,
        'delta_v_total_mps': delta_v,
        'fuel_used_kg': fuel,
        'min_clearance_m': min_clearance,
        't_min_clearance_s': t_min_clearance,
        'restriction_sphere_radius_m': sphere_m,
        'thrust_inside_restriction_sphere': thrust_inside,
        'maneuvers_executed': count(ev.BURN_STARTED),
        'late_maneuvers': count(ev.LATE_MANEUVER),
        'rejected_maneuvers': count(ev.MANEUVER_REJECTED),
        **figures,
        'sim_time_s': sim_time_s,
        'planning_time_s': sum(float(e['values'].get('planning_time_s', 0.0)) for e in events
                               if e['name'] in (ev.PLAN_SELECTED, ev.PLAN_REFUSED)),
        'wall_time_s': wall_time_s,
        'real_time_factor': sim_time_s / wall_time_s if wall_time_s > 0 else None,
        'node_exit_codes': node_exit_codes or {},
        'nodes_killed': list(nodes_killed),
        'bag_repair': bag_repair,
        **_fault_keys(events, faults_injected),
    }


def _judged_end_reason(end_reason, events):
    """How the run ended, or, once the supervisor's core raised (its node_error), an error naming the exception, its
    stamp and how the run then ended: the mission had no judge from there (no phase change, no abort, propulsion idle),
    so whatever phase it stopped in, its outcome is ERROR, unless the truth shows a collision (docs/runtime.md). An
    interruption, or an error of the launcher's, stays as it was."""
    error = supervisor_error(events)
    if error is None or end_reason is None or end_reason == 'interrupted' or end_reason.startswith('error'):
        return end_reason
    return f'error: the supervisor\'s core raised at t = {float(error["t"]):.3f} s ({error["message"]}); {end_reason}'


def _fault_keys(events, faults_injected):
    """The faults of the run (docs/faults.md): the launcher's (``faults_injected``, None headless) and the plant's
    injected, the monitors' detections, the supervisor's responses and the independent monitor's CAM."""
    t_cam = cam_time(events)
    return {
        'faults_injected': {**(faults_injected or {'abort_at_s': None, 'kill': None}), 'plant': plant_faults(events)},
        'faults_detected': fault_detections(events),
        'fault_responses': fault_responses(events),
        'cam_fired': t_cam is not None,
        't_cam_s': t_cam,
    }


def _approach_thrust(thrust, events, scenario, held):
    """The thrust up to the capture (summarize's docstring): GRASP's start, t = 0 in a run that starts attached; all
    of it without a post_capture section."""
    t_capture = 0.0 if held else phase_start(events, c.PHASE_GRASP) if scenario.post_capture is not None else None
    if thrust is not None and t_capture is not None:
        return ThrustTruth(*(None if a is None else a[:int(np.searchsorted(thrust.t, t_capture + 1e-9))]
                             for a in thrust))
    return thrust


def _thrust_totals(chaser, thrust, approach, scenario, has_chaser):
    """(delta-v [m/s], fuel [kg], thrust inside the restriction sphere): the approach's delta-v and thrust inside,
    the whole run's fuel (summarize's docstring)."""
    if not (thrust is not None and has_chaser and len(thrust.t)):
        return 0.0, 0.0, False
    r_at_thrust = chaser.position[np.searchsorted(chaser.t, approach.t).clip(0, len(chaser.t) - 1)]
    delta_v, fuel, thrust_inside = thrust_figures(
        approach.t, approach.force, r_at_thrust, scenario.chaser.mass_kg,
        scenario.chaser.thrusters.isp_s, scenario.planner.restriction_sphere_radius_m, approach.torque,
        approach.thrusters)
    if approach is not thrust:
        fuel = float(np.sum(fuel_steps(thrust, scenario))) if len(thrust.t) > 1 else 0.0
    return delta_v, fuel, thrust_inside


def _clearance_and_capture(chaser, target, phases, events, scenario, held, t_g, offset_m):
    """(least clearance [m], its time [s], whether the truth collided, capture position error [m], velocity error
    [m/s]) from both bodies' truth; the errors None without a grasp time."""
    t_common, i_c, i_t = np.intersect1d(chaser.t, target.t, return_indices=True)
    boxes = [(b.center_m, b.size_m) for b in scenario.target.geometry]
    # The chaser from the target's CoM, off the hill origin after a grasp (zero before).
    r_from_target = chaser.position[i_c] - (0.0 if target.position is None else target.position[i_t])
    gaps = clearance(r_from_target, target.orientation_xyzw[i_t], boxes, scenario.chaser.envelope_radius_m)
    k = least_clearance_index(gaps)
    # A collision is contact before a capture (afterwards the chaser holds the target, DESIGN §10; held from
    # t = 0 in a run that starts attached).
    free = t_common <= t_g if c.PHASE_CAPTURE in phases and t_g is not None else np.full(len(gaps), not held)
    collided = bool(np.any(gaps[free] < 0.0))
    e_pos = e_vel = None
    if t_g is not None:
        x_target_body = capture_target_body(chosen_method(events), scenario.target.grasp_point_body_m,
                                            offset_m or scenario.planner.offset_m, boxes)
        e_pos, e_vel = capture_errors(t_g, chaser, target, x_target_body, scenario.mean_motion_rad_s)
    return float(gaps[k]), float(t_common[k]), collided, e_pos, e_vel


def _phase_figures(chaser, target, approach, thrust, wheels, events, scenario, t_g):
    """The keys of the rigid chaser's pointing, a thrusting and a synchronized approach, and after the capture the
    post-capture and transport figures, in summary.json's order; chaser, target None where not read."""
    has_chaser = chaser is not None
    pointing = pointing_figures(chaser, events, t_g) if has_chaser and scenario.chaser.model == 'rigid_body' else {}
    approach_keys = approach_figures(chaser, approach, events, scenario) if has_chaser else {}
    sync = sync_figures(chaser, target, approach, events, t_g) if has_chaser else {}
    post = {} if scenario.post_capture is None else post_capture_figures(chaser, target, wheels, thrust, events,
                                                                         scenario)
    if scenario.post_capture is not None and scenario.post_capture.transport is not None:
        post.update(transport_figures(chaser, target, wheels, thrust, events, scenario))
    return {**pointing, **approach_keys, **sync, **post}


# The phases a run that starts attached (post_capture.start attached) begins in: after the capture, no approach.
ATTACHED_START_PHASES = (c.PHASE_DAMPING, c.PHASE_MASS_ESTIMATION, c.PHASE_TRANSPORT)


def _text(value, unit='', digits=4):
    """A figure with its unit; None for one the run has not (None, NaN)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return None
    if isinstance(value, float):
        return f'{value:.{digits}g} {unit}'.strip()
    return f'{value} {unit}'.strip()


def _named(name, text):
    """``name text``, None without the text."""
    return None if text is None else f'{name} {text}'


def _row(label, *parts, sep=' / '):
    """[(label, the parts the run has, joined by sep)], [] when it has none: no row of the terminal table is empty."""
    present = [p for p in parts if p is not None]
    return [(label, sep.join(present))] if present else []


def started_attached(summary):
    """Whether the run started with the chaser holding the target (post_capture.start attached): its first phase
    comes after the capture."""
    phases = summary.get('phase_sequence') or []
    return bool(phases) and phases[0] in ATTACHED_START_PHASES


def run_rows(s):
    """The rows of how the run went: scenario, outcome, phase, end reason, seed, and any fault, killed node or
    repaired bag."""
    faults = s.get('faults_injected') or {}
    repair = s.get('bag_repair')
    return [*_row('scenario', _text(s.get('scenario'))), ('outcome', _text(s['outcome'])),
            *_row('final phase', _text(s['final_phase'])), *_row('end reason', _text(s['end_reason'])),
            ('seed', _text(s['seed'])),
            *_row('faults injected', _named('abort at', _text(faults.get('abort_at_s'), 's')),
                  _named('kill', faults.get('kill')),
                  *(f"{f['kind']} on {f['target']} at {f['t_start_s']:.1f} s" for f in faults.get('plant') or ()),
                  sep=', '),
            *_row('nodes killed', ', '.join(s.get('nodes_killed') or []) or None),
            *_row('bag repaired', _named('kept', _text((repair or {}).get('message_count'), 'messages')))]


def _approach_rows(s):
    """The approach and the capture: method, grasp, capture errors, delta-v, fuel, clearance, pointing, the
    synchronized approach's drift and a thrusting approach's figures."""
    return [
        *_row('method', _text(s.get('method'))),
        *_row('grasp time', _text(s['t_grasp_s'], 's', 7)),
        *_row('capture position error', _text(s['capture_position_error_m'], 'm')),
        *_row('capture velocity error', _text(s['capture_velocity_error_mps'], 'm/s')),
        *_row('delta-v total', _text(s['delta_v_total_mps'], 'm/s')),
        *_row('fuel used', _text(s['fuel_used_kg'], 'kg')),
        *_row('min clearance', _text(s['min_clearance_m'], 'm')),
        *_row('thrust inside sphere', _text(s['thrust_inside_restriction_sphere'])),
        *_row('pointing error p95 / max', _text(s.get('pointing_error_p95_deg'), 'deg'),
              _text(s.get('pointing_error_max_deg'), 'deg')),
        *_row('relative attitude drift', _text(s.get('relative_attitude_drift_max_deg'), 'deg')),
        *(_optimal_rows(s) if s.get('approach_time_s') is not None else []),
        *_row('late maneuvers', _text(s['late_maneuvers'])),
    ]


def _optimal_rows(s):
    """A thrusting approach's figures (seed 003 Table 2): its time, peak acceleration and the plume's impulse."""
    return [*_row('approach time', _text(s['approach_time_s'], 's')),
            *_row('peak acceleration', _text(s.get('peak_acceleration_mps2'), 'm/s^2')),
            *_row('thrust away in plume', _named('net', _text(s.get('plume_impulse_away_n_s'), 'N s')),
                  _text(s.get('plume_thruster_impulse_n_s'), 'N s of exhaust at the target'), sep=', ')]


def _post_capture_rows(s):
    """After the capture: the grasp's peak contact, the damping, the target's mass-property errors."""
    released = ' (released)' if s.get('grasp_released') else ''
    grasp = _row('peak grasp force / torque', _text(s.get('peak_grasp_force_n'), 'N'),
                 _text(s.get('peak_grasp_torque_n_m'), 'N m'))
    return [
        *[(label, text + released) for label, text in grasp],
        *_row('damping', _text(s.get('damping_time_s'), 's'), _text(s.get('damping_fuel_kg'), 'kg'),
              _named('momentum', _text(s.get('final_angular_momentum_kg_m2_s'), 'kg m^2/s')), sep=', '),
        *_row('target mass error', _text(s.get('target_mass_error_pct'), '%')),
        *_row('target CoM error', _text(s.get('target_com_error_m'), 'm')),
        *_row('target moments / axes error', _text(s.get('target_principal_moments_error_pct'), '%'),
              _text(s.get('target_principal_axes_error_deg'), 'deg')),
    ]


def _transport_rows(s):
    """With a transport (seed 004 §3.2): the goal, whether the rendezvous conditions hold and the combined body's
    figures at transport_complete: its CoM's distance from the goal, its momentum relative to the goal's circular
    motion (mass times the velocity error), its own angular momentum (wheels excluded), the wheels' momentum and the
    largest share of a wheel's capacity, the time from the planned arrival and its bound; the time, fuel, impulses,
    re-plans and terminal firings."""
    if s.get('transport_goal_hill_m') is None:
        return []
    goal = ', '.join(f'{x:g}' for x in s['transport_goal_hill_m'])
    rows = [('transport goal', f'[{goal}] m in hill')]
    if s.get('transport_final_position_error_m') is None:
        return [*rows, ('transport', 'not flown (no TRANSPORT phase)')]
    met = s.get('transport_conditions_met')
    share = s.get('transport_wheel_momentum_share')
    bound = _text(s.get('transport_settle_bound_s'), 's')
    return [
        *rows,
        *_row('transport conditions', None if met is None else 'met' if met else 'missed'),
        *_row('final position error', _text(s['transport_final_position_error_m'], 'm')),
        *_row('final momentum error', _text(s.get('transport_orbital_momentum_error_n_m_s'), 'N s')),
        *_row('body angular momentum', _text(s.get('transport_final_angular_momentum_kg_m2_s'), 'kg m^2/s')),
        *_row('wheel momentum', _text(s.get('transport_wheel_momentum_n_m_s'), 'N m s'),
              None if share is None else f'(fullest wheel at {100.0 * share:.3g} % of capacity)', sep=' '),
        *_row('settle time', _text(s.get('transport_settle_time_s'), 's'),
              None if bound is None else f'(bound {bound})', sep=' '),
        *_row('transport time / fuel', _text(s.get('transport_time_s'), 's'), _text(s.get('transport_fuel_kg'), 'kg')),
        *_row('impulses / re-plans / terminal firings', _text(s.get('transport_impulses')),
              _text(s.get('transport_replans')), _text(s.get('transport_terminal_firings'))),
    ]


def figure_rows(s):
    """The figures that apply to the run's kind: the approach and capture's, or for a run that starts attached what
    it is instead; after the capture the post-capture figures, with a transport its conditions."""
    if started_attached(s):
        head = [('start', 'attached: the chaser holds the target from t = 0 (no approach, no capture figures)'),
                *_row('fuel used', _text(s['fuel_used_kg'], 'kg'))]
    else:
        head = _approach_rows(s)
    return [*head, *_post_capture_rows(s), *_transport_rows(s)]


def timing_rows(s):
    """Simulated time, wall time and the real-time factor."""
    return [*_row('sim time', _text(s['sim_time_s'], 's', 6)), *_row('wall time', _text(s['wall_time_s'], 's')),
            *_row('real-time factor', _text(s['real_time_factor'], 'x', 3))]


def format_rows(rows):
    """(label, text) rows as a two-column table."""
    width = max(len(k) for k, _ in rows)
    return '\n'.join(f'{k:<{width}}  {v}'.rstrip() for k, v in rows)


def format_summary(summary):
    """The terminal table of a run's summary: the figures that apply to its kind (figure_rows), none shown empty.
    What is printed only; summary.json's keys are the same for every run (DESIGN §10)."""
    return format_rows(run_rows(summary) + figure_rows(summary) + timing_rows(summary))
