"""The age of the estimates (flyby_mission.estimate_age, run by the supervisor's core): a lost or late estimate stream
is an estimate_stale answered by the fault table, cleared once fresh; a nominal stream, one the clock runs ahead of
(the graph's pace), a gap its sensor's detection explains, a lost estimator and the phases after the fly-by raise
nothing; the summary counts a detection as the topic fault's."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from flyby_mission.estimate_age import STALE_PERIODS, EstimateAgeMonitor, EstimateAgeParams
from flyby_mission.fault_table import FaultTable
from flyby_mission.run_events import fault_detections
from flyby_mission.supervisor import SupervisorCore, SupervisorParams, Transition
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.wire import Event, wire_event
from flyby_sim.scenario import load_scenario

REPO = Path(__file__).resolve().parents[4]
SIXDOF = SupervisorParams.from_scenario(load_scenario(REPO / 'scenarios' / 'paper_flyby_6dof.yaml'))
STEP_S = 0.05  # the plant's step: the supervisor's clock
PERIOD_S = 0.1  # the estimates' period (10 Hz sensors)
FAR = np.array((40.0, 0.0, -30.0))
Q = np.array((0.0, 0.0, 0.0, 1.0))
OMEGA = np.array((0.0, 0.0, 0.0873))


def _supervisor(phase):
    core = SupervisorCore(SIXDOF)
    core.machine.phase = phase
    core.machine.t_i = 1e9  # the approach's injection not reached
    return core


def _arrivals(stamps_s, delay_of=lambda t: 0.0):
    """{clock step index: [stamps arriving then]} of estimates stamped stamps_s, each delayed delay_of(stamp) [s] and
    kept in order behind the ones before it, as a topic fault's link holds them (flyby_msgs_py.link_faults)."""
    out, k_last = {}, 0
    for t in stamps_s:
        k_last = max(k_last, round((t + delay_of(t)) / STEP_S))
        out.setdefault(k_last, []).append(t)
    return out


def _fly(core, seconds, target, chaser, lead_s=0.0, t0_s=0.0):
    """The supervisor's inputs headless-like, over (t0_s, seconds]: at each step the nodes' heartbeats (the estimator's
    lead_s behind the clock, as the graph's pace may leave it), the clock, then the estimates arriving then
    (``_arrivals``: target, chaser). Returns the events it published."""
    out = []
    for k in range(round(t0_s / STEP_S) + 1, round(seconds / STEP_S) + 1):
        t = k * STEP_S
        for node in core.machine.watched_nodes:
            core.on_progress(node, max(0.0, t - lead_s))
        out += core.on_clock(t)
        for stamp in target.get(k, ()):
            out += core.on_target_estimate(stamp, Q, OMEGA)
        for stamp in chaser.get(k, ()):
            out += core.on_chaser_estimate(stamp, FAR, np.zeros(3))
    return [o for o in out if isinstance(o, Event)]


def _stamps(t0_s, t1_s):
    return [round(PERIOD_S * k, 9) for k in range(round(t0_s / PERIOD_S), round(t1_s / PERIOD_S))]


def _found(published):
    """(name, t, component, response) of the estimate-age detections, recoveries and the table's answers."""
    out = []
    for e in published:
        if e.name in (events.FAULT_DETECTED, events.FAULT_RECOVERED, events.FAULT_RESPONSE):
            p = event_payloads.decode(wire_event(e))
            if p.kind == 'estimate_stale':
                out.append((e.name, round(e.t, 3), p.component, getattr(p, 'response', None)))
    return out


def test_the_bound_is_eight_periods_and_each_stream_has_its_sensors_period():
    assert STALE_PERIODS == 8.0
    point_mass = EstimateAgeParams.from_scenario(load_scenario(REPO / 'scenarios' / 'paper_flyby.yaml'))
    monitor = EstimateAgeMonitor(dataclasses.replace(point_mass, relative_position_period_s=0.2))
    assert [(s.sensor, s.bound_s) for s in monitor.streams.values()] == [
        ('target_attitude', pytest.approx(0.8)), ('relative_position', pytest.approx(1.6))]
    assert EstimateAgeMonitor(SIXDOF.estimates).streams['chaser_estimate'].sensor == 'imu'


@pytest.mark.parametrize('lead_s', [0.0, 2.0])
def test_nominal_streams_raise_nothing_even_with_the_clock_two_seconds_ahead_of_the_estimator(lead_s):
    core = _supervisor(c.PHASE_TERMINAL_APPROACH)
    stamps = _stamps(0.1, 60.0)
    # Each estimate arrives at its stamp by the estimator's time, which trails the clock by lead_s.
    arrivals = _arrivals(stamps, lambda t: lead_s)
    assert _found(_fly(core, 60.0, arrivals, arrivals, lead_s=lead_s)) == []
    assert core.phase == c.PHASE_TERMINAL_APPROACH


def test_a_lost_chaser_estimate_in_the_approach_is_stale_and_retreats_and_a_target_one_goes_on():
    stamps = _stamps(0.1, 60.0)
    lost = [t for t in stamps if not 20.0 < t < 30.0]
    core = _supervisor(c.PHASE_TERMINAL_APPROACH)
    published = _fly(core, 60.0, _arrivals(stamps), _arrivals(lost))
    # Silent beyond 0.8 s after its last estimate (20.0), judged at the clock's next step.
    assert _found(published)[:2] == [(events.FAULT_DETECTED, 20.85, 'chaser_estimate', None),
                                     (events.FAULT_RESPONSE, 20.85, 'chaser_estimate', 'retreat')]
    moves = [event_payloads.decode(wire_event(e)) for e in published if e.name == events.PHASE_CHANGED]
    assert [(m.from_phase, m.to_phase) for m in moves] == [(c.PHASE_TERMINAL_APPROACH, c.PHASE_RETREAT),
                                                           (c.PHASE_RETREAT, c.PHASE_ESTIMATION)]  # back at 30 s
    core = _supervisor(c.PHASE_TERMINAL_APPROACH)
    published = _fly(core, 60.0, _arrivals(lost), _arrivals(stamps))
    assert _found(published) == [(events.FAULT_DETECTED, 20.85, 'target_estimate', None),
                                 (events.FAULT_RESPONSE, 20.85, 'target_estimate', 'continue'),
                                 (events.FAULT_RECOVERED, 30.0, 'target_estimate', None)]  # its first estimate back
    assert core.phase == c.PHASE_TERMINAL_APPROACH


def test_a_delayed_stream_is_stale_once_and_clears_twenty_estimates_after_they_come_fresh():
    stamps = _stamps(0.1, 60.0)
    late = _arrivals(stamps, lambda t: 1.0 if 20.0 <= t < 30.0 else 0.0)
    core = _supervisor(c.PHASE_ESTIMATION)
    published = _fly(core, 60.0, late, _arrivals(stamps))
    found = _found(published)
    assert [(name, comp, response) for name, _, comp, response in found] == [
        (events.FAULT_DETECTED, 'target_estimate', None), (events.FAULT_RESPONSE, 'target_estimate', 'hold'),
        (events.FAULT_RECOVERED, 'target_estimate', None)]
    assert found[0][1] == 20.75  # silent beyond 0.8 s after 19.9, before the first late one (20.0 at 21.0) came
    # The link keeps the order: 30.0 ... 30.8 wait behind 29.9 (released at 30.9), 30.0 the last late one (0.9 s):
    # cleared once the 20 after it came fresh, at 32.0's arrival.
    assert found[2][1] == pytest.approx(32.0)
    # A delay within the bound is fresh.
    core = _supervisor(c.PHASE_ESTIMATION)
    assert _found(_fly(core, 60.0, _arrivals(stamps, lambda t: 0.7 if 20.0 <= t < 30.0 else 0.0),
                       _arrivals(stamps))) == []


def _sensor(t, kind, sensor, detected=True):
    payload = (event_payloads.FaultDetected if detected else event_payloads.FaultRecovered)(
        f'sensor/{sensor}', kind, sensor, t)
    return wire_event(Event(t, 'ERROR' if detected else 'OK', events.FAULT_DETECTED if detected
                            else events.FAULT_RECOVERED, kind, event_payloads.encode(payload), 'flyby_estimator'))


def test_a_gap_its_sensors_detection_explains_is_left_to_the_estimator():
    """The target's attitude lost: the estimator finds it stale 0.6 s after its last sample, before the estimates'
    bound; the target estimate is then not judged, the chaser's still is."""
    stamps = _stamps(0.1, 40.0)
    lost = [t for t in stamps if not 20.0 < t < 30.0]
    core = _supervisor(c.PHASE_ESTIMATION)
    published = _fly(core, 20.6, _arrivals(lost), _arrivals(stamps))
    core.on_event(_sensor(20.6, 'sensor_stale', 'target_attitude'))
    published += _fly(core, 30.05, _arrivals(lost), _arrivals(stamps), t0_s=20.6)
    core.on_event(_sensor(30.1, 'sensor_stale', 'target_attitude', detected=False))
    published += _fly(core, 40.0, _arrivals(lost), _arrivals(stamps), t0_s=30.05)
    assert _found(published) == []
    outliers = _supervisor(c.PHASE_ESTIMATION)
    outliers.on_event(_sensor(19.0, 'sensor_outliers', 'target_attitude'))
    assert [f[2] for f in _found(_fly(outliers, 40.0, _arrivals(lost), _arrivals(lost)))] == [
        'chaser_estimate', 'chaser_estimate', 'chaser_estimate']  # detected, answered, recovered


def test_a_lost_estimator_is_the_watchdogs_alone_and_its_streams_wait_for_their_first_estimate_again():
    """The estimator silent from 20 s to 50 s (a crash and its respawn, whose filters publish again from 55 s): the
    watchdog's node_lost and its recovery, and no estimate_stale before, during or after it."""
    core = _supervisor(c.PHASE_ESTIMATION)
    stamps = {t for t in _stamps(0.1, 70.0) if not 20.0 < t < 55.0}
    out = []
    for k in range(1, round(70.0 / STEP_S) + 1):
        t = round(k * STEP_S, 9)
        core.on_progress('flyby_guidance', t)
        if not 20.0 < t < 50.0:
            core.on_progress('flyby_estimator', t)
        out += core.on_clock(t)
        if t in stamps:
            out += core.on_target_estimate(t, Q, OMEGA) + core.on_chaser_estimate(t, FAR, np.zeros(3))
    names = [(e.name, e.values.get('kind'), e.values.get('component')) for e in out if isinstance(e, Event)
             and e.name in (events.FAULT_DETECTED, events.FAULT_RECOVERED)]
    assert names == [(events.FAULT_DETECTED, 'node_lost', 'flyby_estimator'),
                     (events.FAULT_RECOVERED, 'node_lost', 'flyby_estimator')]


def test_a_respawned_estimator_is_judged_again_though_its_predecessor_never_cleared_its_detection():
    """The old estimator held sensor_outliers on the target attitude when it crashed; its respawn never sends the
    fault_recovered: once the watchdog had the estimator lost, the target stream is judged again."""
    monitor = EstimateAgeMonitor(SIXDOF.estimates)
    monitor.on_progress(10.0)
    monitor.on_detection('sensor_outliers', 'target_attitude', True)
    assert monitor.judge(10.0, judged=True, estimator_lost=True) == []
    monitor.on_progress(40.0)
    monitor.on_estimate('target_estimate', 40.0, 40.0, judged=True)
    monitor.on_progress(41.0)
    (found,) = monitor.judge(41.0, judged=True, estimator_lost=False)
    assert (found.component, found.detected, found.t) == ('target_estimate', True, 41.0)


def test_nothing_is_judged_before_the_first_estimate_nor_after_the_fly_by():
    core = _supervisor(c.PHASE_ESTIMATION)
    assert _found(_fly(core, 30.0, {}, _arrivals(_stamps(20.0, 30.0)))) == []  # the target's: none yet
    core = _supervisor(c.PHASE_ESCAPE)
    stamps = _stamps(0.1, 20.0)
    assert _found(_fly(core, 40.0, _arrivals(stamps), _arrivals(stamps))) == []


def test_the_table_answers_the_new_detections_by_phase_group():
    table = FaultTable.load()
    answers = {(kind, component): [table.response(kind, component, phase).response for phase in (
        c.PHASE_ESTIMATION, c.PHASE_TRAJECTORY_ADJUST, c.PHASE_FLYBY, c.PHASE_GRASP)] for kind, component in (
        ('estimate_stale', 'target_estimate'), ('estimate_stale', 'chaser_estimate'), ('sensor_stale', 'tachometers'))}
    assert answers == {('estimate_stale', 'target_estimate'): ['hold'] + ['continue'] * 3,
                       ('estimate_stale', 'chaser_estimate'): ['hold', 'retreat', 'continue', 'continue'],
                       ('sensor_stale', 'tachometers'): ['continue'] * 4}
    assert table.response('estimate_stale', 'chaser_estimate', c.PHASE_DOCKING).severity == 2


def _logged(t, name, payload, source):
    e = wire_event(Event(t, 'ERROR', name, name, event_payloads.encode(payload), source))
    return {'t': e.t, 'level': e.level, 'name': e.name, 'message': e.message, 'values': e.values,
            'hardware_id': e.source}


@pytest.mark.parametrize('topic, monitor, kind, component', [
    (c.EST_TARGET_ODOM, 'estimate_age', 'estimate_stale', 'target_estimate'),
    (c.EST_CHASER_ODOM, 'estimate_age', 'estimate_stale', 'chaser_estimate'),
    (c.SENSOR_CHASER_WHEELS, 'sensor/tachometers', 'sensor_stale', 'tachometers'),
])
def test_the_summary_counts_a_detection_as_the_topic_fault_that_caused_it(topic, monitor, kind, component):
    log = [_logged(70.0, events.FAULT_INJECTED, event_payloads.FaultInjected(0, 'topic_loss', f'topic {topic}', 70.0,
                                                                             30.0, None), 'flyby_sim'),
           _logged(70.85, events.FAULT_DETECTED, event_payloads.FaultDetected(monitor, kind, component, 70.85),
                   'flyby_supervisor')]
    [found] = fault_detections(log)
    assert (found['fault'], found['isolated'], found['delay_s']) == (0, True, pytest.approx(0.85))


def test_an_abort_on_a_stale_chaser_estimate_is_one_transition():
    """In TRAJECTORY_ADJUST the chaser's estimates stop after 19.9 s: one retreat, the table's; the target's
    estimates, never sent, wait for their first."""
    core = _supervisor(c.PHASE_TRAJECTORY_ADJUST)
    out = []
    for k in range(1, round(30.0 / STEP_S) + 1):
        t = k * STEP_S
        for node in core.machine.watched_nodes:
            core.on_progress(node, t)
        out += core.on_clock(t)
        if k % 2 == 0 and t < 20.0:
            out += core.on_chaser_estimate(round(t, 9), FAR, np.zeros(3))
    moves = [o for o in out if isinstance(o, Transition)]
    assert [(o.phase_to, o.reason) for o in moves] == [
        (c.PHASE_RETREAT, 'retreat: chaser_estimate: no estimate for 0.85 s (bound 0.80 s)')]
