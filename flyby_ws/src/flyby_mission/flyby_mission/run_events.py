"""What a run's events on /mission/events say about it (DESIGN §10): the supervisor's phases and their times, the
grasp time it decided at, the plan flown and its method; read by the run's figures (``flyby_mission.summary``).
Events are dicts with t, level, name, message, values (text), hardware_id."""

from flyby_msgs_py import contract as c
from flyby_msgs_py import events as ev
from flyby_msgs_py.core_guard import failed_node
from flyby_msgs_py.event_payloads import decode_values
from flyby_msgs_py.link_faults import COMPONENT_OF_TOPIC
from flyby_msgs_py.wiring import SUPERVISOR


def no_safe_plan_reason(events):
    """The supervisor's reason for ending in NO_SAFE_PLAN ('no safe plan: ...', from its PLANNING -> COMPLETE
    event), or None."""
    for e in events:
        if e['name'] == ev.PHASE_CHANGED and e['values'].get('no_safe_plan') == 'true':
            return e['message'].split(': ', 1)[-1]
    return None


def supervisor_error(events):
    """The supervisor's core's node_error (flyby_msgs_py.core_guard: the mission lost its judge), or None."""
    return next((e for e in events if failed_node(e['name'], e['values']) == SUPERVISOR), None)


def chosen_method(events):
    """The method of the plan flown (the planner's last method_chosen event, DESIGN §10), or None."""
    chosen = [e['values']['method'] for e in events if e['name'] == ev.METHOD_CHOSEN]
    return chosen[-1] if chosen else None


def phase_windows(events, t_end):
    """[(phase, t_from, t_to)] of the supervisor's phase_changed events, the last one to t_end [s]."""
    changes = [(float(e['t']), e['values']['to']) for e in events
               if e['name'] == ev.PHASE_CHANGED and e['values'].get('to')]
    return [(phase, t0, changes[k + 1][0] if k + 1 < len(changes) else t_end)
            for k, (t0, phase) in enumerate(changes)]


def grasp_time(events):
    """The grasp time t_g the supervisor decided at (its FLYBY -> CAPTURE / ESCAPE event), or None."""
    for e in events:
        if e['name'] == ev.PHASE_CHANGED and e['values'].get('to') in (c.PHASE_CAPTURE, c.PHASE_ESCAPE) \
                and 't_grasp_s' in e['values']:
            return float(e['values']['t_grasp_s'])
    return None


def planned_flyby(events):
    """(offset delta r [m], fly-by duration [s]) of the last plan selected, or (None, None)."""
    selected = [e['values'] for e in events if e['name'] == ev.PLAN_SELECTED and 'offset_m' in e['values']]
    if not selected:
        return None, None
    duration = selected[-1].get('flyby_duration_s')  # none for an optimal approach
    return float(selected[-1]['offset_m']), None if duration is None else float(duration)


def phase_start(events, phase):
    """The time [s] the supervisor entered phase (its first phase_changed to it), or None."""
    return next((float(e['t']) for e in events if e['name'] == ev.PHASE_CHANGED and e['values'].get('to') == phase),
                None)


def lock_time(events, scenario):
    """The stamp [s] the arm locked chaser and target into one rigid body: the simulator's ``grasp_damped``, t = 0 in
    a run that starts attached; None before."""
    if scenario.post_capture is not None and scenario.post_capture.start == 'attached':
        return 0.0
    return next((float(e['t']) for e in events if e['name'] == ev.GRASP_DAMPED), None)


def plant_faults(events):
    """The faults the simulator injected (its ``fault_injected`` and ``fault_ended``), in start order: dicts of
    fault (its number in the scenario's list), kind, target, t_start_s, t_end_s (None while it lasts) and value."""
    faults = {}
    for e in events:
        if e['name'] == ev.FAULT_INJECTED:
            p = decode_values(e['name'], e['values'])
            faults[p.fault] = dict(fault=p.fault, kind=p.kind, target=p.target, t_start_s=p.t_start, t_end_s=None,
                                   value=p.value)
        elif e['name'] == ev.FAULT_ENDED:
            p = decode_values(e['name'], e['values'])
            if p.fault in faults:
                faults[p.fault]['t_end_s'] = p.t_end
    return list(faults.values())


def _explains(fault, detection):
    """Whether an injected fault (``plant_faults``' dict) is one the detection (a FaultDetected) may be of."""
    target, component = fault['target'], detection.component
    actuator, _, index = target.partition(' ')
    if actuator in ('thruster', 'wheel'):  # the monitor's component: 'thrusters [i, ...]' or 'wheels [i, ...]'
        return component.startswith(f'{actuator}s') and (not detection.candidates or int(index) in detection.candidates)
    if actuator == 'node':  # the watchdog names the node
        return component == index
    if actuator == 'topic':  # a link fault: the monitors name the sensor the topic carries
        return component == COMPONENT_OF_TOPIC.get(index)
    if fault['kind'] == 'gyro_bias_jump':
        return component in ('imu', 'star_tracker')
    return component == target or (target == 'imu' and component == 'star_tracker')


def fault_detections(events, grace_s=60.0):
    """The health monitors' detections (``fault_detected``), each a dict of t_s, monitor, kind, component, the
    injected fault it answers and whether it names that fault's component (``isolated``): the latest fault started at
    or before it, still acting or ended within grace_s [s], whose target it may be of (isolated, with the delay from
    the fault's start [s]), else the latest acting at all (a consequence: the navigation's innovations after a
    thruster's fault); None: no fault acting, a false alarm."""
    injected = plant_faults(events)
    out = []
    for e in events:
        if e['name'] != ev.FAULT_DETECTED:
            continue
        d = decode_values(e['name'], e['values'])
        t = float(e['t'])
        acting = [f for f in injected if f['t_start_s'] <= t + 1e-9
                  and (f['t_end_s'] is None or t <= f['t_end_s'] + grace_s)]
        named = [f for f in acting if _explains(f, d)]
        fault = named[-1] if named else acting[-1] if acting else None
        out.append(dict(t_s=t, monitor=d.monitor, kind=d.kind, component=d.component,
                        fault=None if fault is None else fault['fault'], isolated=bool(named),
                        delay_s=t - named[-1]['t_start_s'] if named else None))
    return out


def fault_responses(events):
    """The supervisor's answers (``fault_response``): dicts of t_s, kind, component, response, phase, severity."""
    out = []
    for e in events:
        if e['name'] == ev.FAULT_RESPONSE:
            r = decode_values(e['name'], e['values'])
            out.append(dict(t_s=float(e['t']), kind=r.kind, component=r.component, response=r.response,
                            phase=r.phase, severity=r.severity))
    return out


def cam_time(events):
    """The stamp [s] the independent monitor fired its CAM (``cam_fired``), or None."""
    return next((float(e['t']) for e in events if e['name'] == ev.CAM_FIRED), None)
