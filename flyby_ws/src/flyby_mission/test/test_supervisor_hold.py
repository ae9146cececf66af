"""The fault table's ``hold`` and ``retreat`` (docs/faults.md): standby held, or the approach given up, on a detection
until it recovers, the way to PLANNING again after it, their limits, and what the planner and guidance do meanwhile."""

import dataclasses
from pathlib import Path

import numpy as np

from flyby_guidance.guidance_core import GuidanceCore
from flyby_guidance.params import GuidanceParams
from flyby_mission.summary import outcome_of
from flyby_mission.supervisor import SupervisorCore, SupervisorParams, Transition
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.wire import Event, wire_event
from flyby_planner.params import PlannerParams
from flyby_planner.planner_core import PlannerCore
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
SCENARIO = load_scenario(SCENARIOS / 'paper_flyby_6dof.yaml')
PARAMS = dataclasses.replace(SupervisorParams.from_scenario(SCENARIO), min_observation_s=60.0, hold_limit_s=300.0)


def _found(t, kind, component, detected=True, source='flyby_estimator'):
    """A health monitor's fault_detected (or fault_recovered) as mission/events carries it."""
    payload = (event_payloads.FaultDetected if detected else event_payloads.FaultRecovered)(
        f'sensor/{component}', kind, component, t)
    name = events.FAULT_DETECTED if detected else events.FAULT_RECOVERED
    return wire_event(Event(t, 'ERROR' if detected else 'OK', name, kind, event_payloads.encode(payload), source))


def _converged(t):
    return wire_event(Event(t, 'OK', events.TARGET_CONVERGED, 'converged', {}, 'flyby_estimator'))


def _estimates(core, t0, t1):
    """Target estimates (and the estimator's progress) every 0.1 s from t0 to t1: the transitions they cause."""
    out = []
    for t in np.arange(t0, t1 + 1e-9, 0.1):
        core.on_progress('flyby_estimator', t)
        core.on_progress('flyby_guidance', t)
        out += core.on_target_estimate(t, (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.1))
        out += core.on_clock(t)
    return [o for o in out if isinstance(o, Transition)]


def test_a_hold_waits_in_standby_until_its_fault_recovers_then_plans():
    core = SupervisorCore(PARAMS)
    _estimates(core, 0.1, 10.0)
    core.on_event(_converged(10.0))
    out = core.on_event(_found(20.0, 'sensor_stale', 'relative_position'))
    response = [o for o in out if getattr(o, 'name', '') == events.FAULT_RESPONSE]
    assert response[0].values['response'] == 'hold' and core.phase == c.PHASE_HOLD
    assert [o for o in out if isinstance(o, Transition)][0].reason.startswith('hold: ')
    assert _estimates(core, 20.1, 80.0) == []  # converged and observed, but held: no PLANNING
    out = core.on_event(_found(80.0, 'sensor_stale', 'relative_position', detected=False))
    moves = [(o.phase_from, o.phase_to) for o in out if isinstance(o, Transition)]
    assert moves == [(c.PHASE_HOLD, c.PHASE_ESTIMATION), (c.PHASE_ESTIMATION, c.PHASE_PLANNING)]


def test_the_hold_ends_with_its_last_fault_and_a_fault_it_does_not_hold_changes_nothing():
    core = SupervisorCore(PARAMS)
    _estimates(core, 0.1, 1.0)
    core.on_event(_found(2.0, 'sensor_stale', 'relative_position'))
    core.on_event(_found(3.0, 'sensor_stale', 'target_attitude'))
    core.on_event(_found(4.0, 'sensor_stale', 'star_tracker'))  # continue in standby: not held
    out = core.on_event(_found(5.0, 'sensor_stale', 'relative_position', detected=False))
    assert not [o for o in out if isinstance(o, Transition)] and core.phase == c.PHASE_HOLD  # one still out
    out = core.on_event(_found(6.0, 'sensor_stale', 'target_attitude', detected=False))
    assert [o.phase_to for o in out if isinstance(o, Transition)] == [c.PHASE_ESTIMATION]


def test_a_hold_not_recovered_within_its_limit_aborts_naming_the_fault():
    core = SupervisorCore(PARAMS)
    _estimates(core, 0.1, 1.0)
    core.on_event(_found(2.0, 'sensor_inconsistent', 'star_tracker'))
    assert _estimates(core, 1.1, 301.9) == []
    [aborted] = _estimates(core, 302.0, 302.0)
    assert aborted.phase_to == c.PHASE_ABORTED
    assert aborted.reason == 'hold: sensor_inconsistent on star_tracker not recovered within 300 s'


def test_a_plan_made_before_the_hold_was_heard_is_not_taken():
    core = SupervisorCore(PARAMS)
    _estimates(core, 0.1, 60.0)
    core.on_event(_converged(10.0))
    assert _estimates(core, 60.1, 60.1)[0].phase_to == c.PHASE_PLANNING
    core.on_event(_found(60.15, 'sensor_stale', 'imu'))
    assert core.phase == c.PHASE_HOLD
    plan = event_payloads.PlanSelected(t_i_s=500.0, t_grasp_s=800.0, offset_m=1.0)
    out = core.on_event(wire_event(Event(60.2, 'OK', events.PLAN_SELECTED, 'plan', event_payloads.encode(plan),
                                         'flyby_planner')))
    assert out == [] and core.phase == c.PHASE_HOLD


def test_a_lost_estimators_successor_must_converge_and_observe_anew():
    core = SupervisorCore(PARAMS)
    _estimates(core, 0.1, 30.0)
    core.on_event(_converged(10.0))
    core.on_clock(36.0)  # the estimator silent since 30.0: node_lost, held
    assert core.phase == c.PHASE_HOLD
    moves = _estimates(core, 60.0, 70.0)  # it reports again: the hold ends, its new filter not yet converged
    assert [m.phase_to for m in moves] == [c.PHASE_ESTIMATION]
    assert _estimates(core, 70.1, 130.0) == []  # no convergence from the successor
    [planning] = [o for o in core.on_event(_converged(130.0)) if isinstance(o, Transition)]
    assert planning.phase_to == c.PHASE_PLANNING and '70.0 s of attitude data' in planning.reason  # its own


def _phase_event(t, phase_from, phase_to):
    return wire_event(Event(t, 'OK', events.PHASE_CHANGED, f'{phase_from} -> {phase_to}',
                            event_payloads.encode(event_payloads.PhaseChanged(phase_from, phase_to)),
                            'flyby_supervisor'))


def test_the_planner_forgets_its_request_in_hold_and_a_planning_long_past():
    """A respawned planner is fed the events' history: a PLANNING followed by the phase it moved on to is no request
    (before, a planner respawned in the approach planned again and guidance flew the new plan)."""
    planner = PlannerCore(PlannerParams.from_scenario(SCENARIO))
    planner.on_chaser_estimate(95.0, (40.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    planner.on_target_estimate(95.0, (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.1))
    # The history's PLANNING before the latched phase: no plan from it while the phase is not heard to be PLANNING.
    assert planner.on_event(_phase_event(60.1, c.PHASE_ESTIMATION, c.PHASE_PLANNING)) == []
    assert planner.on_phase(c.PHASE_TERMINAL_APPROACH) == []
    assert planner.request is not None
    planner.on_event(_phase_event(60.1, c.PHASE_PLANNING, c.PHASE_HOLD))
    assert planner.request is None
    planner.on_event(_phase_event(90.0, c.PHASE_ESTIMATION, c.PHASE_PLANNING))
    planner.on_event(_phase_event(90.0, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH))
    assert planner.request is None
    assert planner.on_chaser_estimate(95.1, (40.0, 0.0, 0.0), (0.0, 0.0, 0.0)) == []


def test_guidance_drops_the_plan_in_hold_and_takes_none_while_held():
    guidance = GuidanceCore(GuidanceParams.from_scenario(SCENARIO))
    guidance.on_phase(c.PHASE_PLANNING)
    guidance.on_flyby_initial(500.0, (5.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    guidance.on_flyby_target(800.0, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert guidance.on_path(60.1)  # guidance_started
    assert guidance.flyby.guidance.next_burn_time is not None
    guidance.on_phase(c.PHASE_HOLD)
    assert guidance.flyby.guidance.next_burn_time is None
    guidance.on_flyby_initial(500.0, (5.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    guidance.on_flyby_target(800.0, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert guidance.on_path(61.0) == [] and guidance.flyby.guidance.next_burn_time is None
    guidance.on_phase(c.PHASE_ESTIMATION)  # the hold over: nothing of the dropped plan is flown
    out = [o for t in np.arange(490.0, 510.0, 0.1) for o in guidance.on_chaser_estimate(
        t, (40.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0))]
    assert not [o for o in out if getattr(o, 'name', '') == events.MANEUVER_COMMANDED]


def _in_approach(max_retreats=1):
    core = SupervisorCore(dataclasses.replace(PARAMS, max_retreats=max_retreats))
    _estimates(core, 0.1, 60.0)
    core.on_event(_converged(10.0))
    _estimates(core, 60.1, 60.1)
    plan = event_payloads.PlanSelected(t_i_s=500.0, t_grasp_s=800.0, offset_m=1.0)
    core.on_event(wire_event(Event(60.1, 'OK', events.PLAN_SELECTED, 'plan', event_payloads.encode(plan),
                                   'flyby_planner')))
    core.on_chaser_estimate(60.1, (40.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert core.phase == c.PHASE_TERMINAL_APPROACH
    return core


def test_a_retreat_gives_the_approach_up_safely_and_plans_again_once_the_fault_has_recovered():
    core = _in_approach()
    out = core.on_event(_found(100.0, 'sensor_stale', 'relative_position'))
    assert core.phase == c.PHASE_RETREAT
    names = [o.name for o in out if isinstance(o, Event)]
    assert events.NO_AVOIDANCE_BURN in names or events.AVOIDANCE_BURN in names  # safed as by an abort
    assert core.machine.t_grasp is None  # the next plan's
    out = core.on_event(_found(130.0, 'sensor_stale', 'relative_position', detected=False))
    moves = [(o.phase_from, o.phase_to) for o in out if isinstance(o, Transition)]
    assert moves == [(c.PHASE_RETREAT, c.PHASE_ESTIMATION), (c.PHASE_ESTIMATION, c.PHASE_PLANNING)]


def test_retreats_beyond_the_limit_abort_and_a_retreat_waits_no_longer_than_the_hold_limit():
    core = _in_approach(max_retreats=0)
    core.on_event(_found(100.0, 'sensor_stale', 'imu'))
    assert core.phase == c.PHASE_ABORTED
    assert core.machine.decision is None
    core = _in_approach()
    core.on_event(_found(100.0, 'sensor_stale', 'imu'))
    core.on_event(_found(101.0, 'sensor_stale', 'target_attitude'))  # held as in standby while retreating
    core.on_event(_found(150.0, 'sensor_stale', 'imu', detected=False))
    assert core.phase == c.PHASE_RETREAT
    [aborted] = _estimates(core, 400.0, 400.0)
    assert aborted.phase_to == c.PHASE_ABORTED and aborted.reason.startswith('retreat: sensor_stale on target_attitude')


def test_guidance_drops_the_approach_in_retreat():
    guidance = GuidanceCore(GuidanceParams.from_scenario(SCENARIO))
    guidance.on_phase(c.PHASE_TERMINAL_APPROACH)
    guidance.on_flyby_initial(500.0, (5.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    guidance.on_flyby_target(800.0, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    guidance.on_path(60.1)
    guidance.on_phase(c.PHASE_RETREAT)
    assert guidance.flyby.guidance.next_burn_time is None
    assert guidance.on_path(61.0) == []


def test_a_refused_plan_after_a_retreat_aborts_with_its_safing_and_a_first_one_is_no_safe_plan():
    refusal = wire_event(Event(130.0, 'ERROR', events.PLAN_REFUSED, 'too close', event_payloads.encode(
        event_payloads.PlanRefused()), 'flyby_planner'))
    core = _in_approach()
    core.on_event(_found(100.0, 'sensor_stale', 'relative_position'))
    core.on_event(_found(120.0, 'sensor_stale', 'relative_position', detected=False))
    assert core.phase == c.PHASE_PLANNING
    out = core.on_event(refusal)
    assert core.phase == c.PHASE_ABORTED
    assert [o.reason for o in out if isinstance(o, Transition)] == ['no safe plan after the retreat: too close']
    assert any(getattr(o, 'name', '') in (events.NO_AVOIDANCE_BURN, events.AVOIDANCE_BURN) for o in out)
    first = SupervisorCore(PARAMS)
    first.machine.phase = c.PHASE_PLANNING
    first.on_event(refusal)
    assert first.phase == c.PHASE_COMPLETE
    after = [c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH, c.PHASE_RETREAT, c.PHASE_ESTIMATION,
             c.PHASE_PLANNING, c.PHASE_ABORTED]
    assert outcome_of('phase ABORTED', after, refused=True) == c.OUTCOME_ABORTED


def test_the_faults_still_active_when_a_retreat_ends_are_answered_again_as_in_standby():
    """The CAM monitor lost in the approach goes on there (continue); once the retreat ends it is held for."""
    core = _in_approach()
    core.on_event(_found(90.0, 'node_lost', 'flyby_cam_monitor', source='flyby_supervisor_watchdog'))
    assert core.phase == c.PHASE_TERMINAL_APPROACH
    core.on_event(_found(100.0, 'sensor_stale', 'relative_position'))
    out = core.on_event(_found(120.0, 'sensor_stale', 'relative_position', detected=False))
    assert [o.phase_to for o in out if isinstance(o, Transition)] == [c.PHASE_ESTIMATION, c.PHASE_HOLD]
    assert core.machine.held == {('node_lost', 'flyby_cam_monitor'): (120.0, 'flyby_supervisor_watchdog')}


def test_an_estimators_loss_forgets_the_detections_of_its_monitors():
    """Its successor's monitors never clear their predecessor's detections: a retreat on one would wait to its limit."""
    core = _in_approach()
    core.on_event(_found(100.0, 'sensor_stale', 'relative_position'))
    core.on_event(_found(105.0, 'node_lost', 'flyby_estimator', source='a_watchdog'))
    assert set(core.machine.held) == {('node_lost', 'flyby_estimator')}
    out = core.on_event(_found(125.0, 'node_lost', 'flyby_estimator', detected=False, source='a_watchdog'))
    assert [o.phase_to for o in out if isinstance(o, Transition)] == [c.PHASE_ESTIMATION]


def test_the_planner_forgets_an_optimal_plan_given_up():
    planner = PlannerCore(PlannerParams.from_scenario(SCENARIO))
    optimal = planner.methods['optimal']
    optimal.flown, optimal.aim_checked_t, planner.method_flown = object(), 60.0, 'optimal'
    planner.on_event(_phase_event(80.0, c.PHASE_OPTIMAL_APPROACH, c.PHASE_RETREAT))
    assert (optimal.flown, optimal.aim_checked_t, planner.method_flown, planner.request) == (None, None, None, None)


def test_guidance_takes_no_plan_stamped_before_the_wait_ended_from_the_latched_topics():
    """A guidance respawned after a retreat is fed the latched plan of the approach given up, then the events."""
    guidance = GuidanceCore(GuidanceParams.from_scenario(SCENARIO))
    guidance.on_phase(c.PHASE_ESTIMATION)
    guidance.on_event(_phase_event(80.0, c.PHASE_TERMINAL_APPROACH, c.PHASE_RETREAT))
    guidance.on_event(_phase_event(110.0, c.PHASE_RETREAT, c.PHASE_ESTIMATION))
    guidance.on_flyby_initial(500.0, (5.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    guidance.on_flyby_target(800.0, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert guidance.on_path(60.1) == [] and guidance.flyby.guidance.next_burn_time is None
    assert guidance.on_path(110.2)  # a plan made after the retreat: flown
