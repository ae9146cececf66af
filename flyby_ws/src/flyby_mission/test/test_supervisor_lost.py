"""The supervisor's own core raising (docs/runtime.md, 'An exception in a core'): the mission has no judge, guidance
idles propulsion, the independent CAM monitor stays armed, and the run goes on to its duration and ends in ERROR,
its end_reason naming the exception and its stamp; a collision in the truth is still a COLLISION."""

import copy
from pathlib import Path

import numpy as np
import pytest

from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_mission.summary import _judged_end_reason, outcome_of
from flyby_msgs_py import contract as c
from flyby_msgs_py import events, wiring
from flyby_sim.scenario import load_scenario, scenario_from_dict

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'


def _paper_flyby_to(duration_s):
    """paper_flyby (grasp at 813 s) flown to duration_s."""
    d = copy.deepcopy(load_scenario(SCENARIOS / 'paper_flyby.yaml').to_dict())
    d['simulation']['duration_s'] = duration_s
    return scenario_from_dict(d, name='paper_flyby')


def _supervisor_raising_at(t_fault_s, duration_s=900.0):
    """A headless paper_flyby whose supervisor core raises at its first chaser estimate stamped at or after
    t_fault_s: (its HeadlessGraph, its HeadlessRun)."""
    scenario = _paper_flyby_to(duration_s)
    graph = HeadlessGraph(scenario)
    nominal = graph.supervisor.on_chaser_estimate

    def on_chaser_estimate(t, *args):
        if t >= t_fault_s:
            raise ZeroDivisionError(f'injected supervisor fault at t = {t:.2f} s')
        return nominal(t, *args)

    graph.supervisor.on_chaser_estimate = on_chaser_estimate
    return graph, run_headless(scenario, graph)


def _the_error(run):
    (error,) = [e for e in run.events if e['name'] == events.NODE_ERROR]
    assert error['values']['node'] == wiring.SUPERVISOR and error['values']['exception'] == 'ZeroDivisionError'
    return error


def test_the_supervisor_raising_mid_approach_idles_propulsion_and_the_run_ends_in_error():
    """At 600 s, in TRAJECTORY_ADJUST (adjust burns every 20 s to 713 s): guidance commands no burn after it, the
    coast passes the target clear, and the run goes on to its duration: ERROR, saying why."""
    graph, run = _supervisor_raising_at(600.0)
    error = _the_error(run)
    t_error = float(error['t'])
    assert t_error == 600.0
    (idled,) = [e for e in run.events if e['name'] == events.PROPULSION_IDLED]
    assert idled['hardware_id'] == wiring.GUIDANCE and idled['level'] == 'ERROR' and float(idled['t']) == t_error
    # No burn commanded from then on; the truth's thrust is nil after the error (the last burn, 593 s, long over).
    assert [b['t'] for b in run.burns if b['t'] >= t_error] == []
    assert not [e for e in run.events if e['name'] == events.MANEUVER_COMMANDED and float(e['t']) >= t_error]
    t = np.array(graph.truth.t)
    assert not np.any(np.array(graph.truth.f)[t >= t_error])
    # The independent monitor: armed to the end (never stood down, its core never fenced off).
    assert not graph.cam.standing_down and graph.guards[wiring.CAM].failed is None
    s = run.summary
    assert s['outcome'] == c.OUTCOME_ERROR and s['final_phase'] == c.PHASE_TRAJECTORY_ADJUST
    assert s['end_reason'] == ("error: the supervisor's core raised at t = 600.000 s (flyby_supervisor: "
                               "ZeroDivisionError: injected supervisor fault at t = 600.00 s); time_limit")
    assert s['sim_time_s'] == pytest.approx(900.0) and s['min_clearance_m'] > 0.0 and not s['cam_fired']


def test_the_cam_monitor_stays_armed_and_fires_on_the_coast_the_supervisors_loss_leaves():
    """At 509 s, after guidance commanded the injection burn of 513 s: the injection flies (it was with the
    thrusters), no adjust burn follows, and the coast comes at the target: the independent monitor fires its CAM;
    the chaser passes clear: ERROR, not COLLISION."""
    _, run = _supervisor_raising_at(509.0)
    t_error = float(_the_error(run)['t'])
    assert [(b['kind'], round(b['t'], 2)) for b in run.burns if b['t'] >= t_error] == [('injection', 513.01)]
    s = run.summary
    assert s['cam_fired'] and s['t_cam_s'] > 800.0
    assert s['outcome'] == c.OUTCOME_ERROR and s['min_clearance_m'] > 0.0
    assert "the supervisor's core raised at t = 509.000 s" in s['end_reason']


def test_a_collision_after_the_supervisors_loss_is_still_a_collision():
    supervisor_error = [{'t': 600.0, 'level': 'ERROR', 'name': events.NODE_ERROR,
                         'message': 'flyby_supervisor: ValueError: boom', 'hardware_id': wiring.SUPERVISOR,
                         'values': {'node': wiring.SUPERVISOR, 'exception': 'ValueError', 'callback': 'x'}}]
    phases = [c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH]
    reason = _judged_end_reason('time_limit', supervisor_error)
    assert reason == "error: the supervisor's core raised at t = 600.000 s (flyby_supervisor: ValueError: boom); " \
                     "time_limit"
    assert outcome_of(reason, phases) == c.OUTCOME_ERROR
    assert outcome_of(reason, phases, collided=True) == c.OUTCOME_COLLISION
    # Whatever phase the run stopped in (an abort the supervisor published before it raised, a capture).
    for phase in (c.PHASE_ABORTED, c.PHASE_CAPTURE):
        assert outcome_of(_judged_end_reason(f'phase {phase}', supervisor_error), phases + [phase]) == c.OUTCOME_ERROR
    # An interruption or the launcher's own error stays; another node's node_error is the supervisor's to answer.
    assert _judged_end_reason('interrupted', supervisor_error) == 'interrupted'
    assert _judged_end_reason('error: wall-clock timeout', supervisor_error) == 'error: wall-clock timeout'
    planner_error = [dict(supervisor_error[0], values=dict(supervisor_error[0]['values'], node=wiring.PLANNER))]
    assert _judged_end_reason('phase ABORTED', planner_error) == 'phase ABORTED'
