"""The fault table (docs/faults.md's FMECA, flyby_mission.fault_table) and the supervisor's answers to detections."""

import subprocess
import sys
from pathlib import Path

import pytest

from flyby_mission.fault_table import TABLE_PATH, FaultTable, fmeca_rows
from flyby_mission.supervisor import SupervisorCore, SupervisorParams
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.wire import Event, wire_event
from flyby_sim.scenario import load_scenario

REPO = Path(__file__).resolve().parents[4]


def test_the_yaml_table_is_the_fmecas():
    run = subprocess.run([sys.executable, str(REPO / 'scripts' / 'fault_table.py'), '--check'], capture_output=True,
                         text=True, check=False)
    assert run.returncode == 0, run.stdout + run.stderr
    rows = fmeca_rows((REPO / 'docs' / 'faults.md').read_text())
    assert FaultTable.load().rows == {(r['kind'], r['component']): r for r in rows}
    assert TABLE_PATH.exists()


def test_a_malformed_fmeca_row_is_refused_naming_it():
    text = (REPO / 'docs' / 'faults.md').read_text().replace('| isolate | isolate_abort |', '| isolate | explode |')
    with pytest.raises(ValueError, match=r"FMECA row 1 \(thrust_excess thrusters\): approach response 'explode'"):
        fmeca_rows(text)


@pytest.mark.parametrize('old, new, refusal', [
    ('| wheels | 2 | reallocate | reallocate |', '| wheels | 2 | continue | reallocate |', None),  # on wheels: kept
    ('| thrusters | 2 | abort | abort |', '| thrusters | 2 | reallocate | abort |',
     r"FMECA row 2 \(thrust_deficit thrusters\): standby response 'reallocate' acts on wheels only, not on thrusters"),
    ('| watchdog | 2 | hold | continue |', '| watchdog | 2 | hold | isolate |',
     r"FMECA row 7 \(node_lost flyby_planner\): approach response 'isolate' acts on thrusters only, not on "
     r"flyby_planner"),
    ('| wheels | 2 | reallocate | reallocate |', '| wheels | 2 | reallocate | isolate_abort |',
     r"FMECA row 3 \(wheel_torque_deficit wheels\): approach response 'isolate_abort' acts on thrusters only"),
    ('| watchdog | 2 | hold | continue |', '| watchdog | 2 | hold | hold |',
     r"FMECA row 7 \(node_lost flyby_planner\): approach response hold: answers in standby only"),
    ('| watchdog | 2 | hold | continue |', '| watchdog | 2 | retreat | continue |',
     r"FMECA row 7 \(node_lost flyby_planner\): standby response retreat: answers in approach only"),
])
def test_a_response_on_a_component_it_cannot_act_on_is_refused_naming_the_row(old, new, refusal):
    text = (REPO / 'docs' / 'faults.md').read_text()
    assert old in text
    text = text.replace(old, new, 1)
    if refusal is None:
        assert fmeca_rows(text)[2]['standby'] == 'continue'
    else:
        with pytest.raises(ValueError, match=refusal):
            fmeca_rows(text)


def test_the_script_refuses_a_misplaced_response_in_one_line(tmp_path):
    """scripts/fault_table.py --check (it writes nothing, whatever happens) on an FMECA with a reallocate on the
    thrusters: exit 2 and one line naming the row, no traceback."""
    script = (REPO / 'scripts' / 'fault_table.py').read_text()
    docs = tmp_path / 'docs'
    docs.mkdir()
    docs.joinpath('faults.md').write_text((REPO / 'docs' / 'faults.md').read_text().replace(
        '| thrusters | 2 | abort | abort |', '| thrusters | 2 | reallocate | abort |', 1))
    (tmp_path / 'scripts').mkdir()
    (tmp_path / 'scripts' / 'fault_table.py').write_text(script)  # REPO is the script's parent's parent: tmp_path
    run = subprocess.run([sys.executable, str(tmp_path / 'scripts' / 'fault_table.py'), '--check'],
                         capture_output=True, text=True, check=False)
    assert run.returncode == 2 and run.stdout == ''
    assert run.stderr.splitlines() == [
        "docs/faults.md: FMECA row 2 (thrust_deficit thrusters): standby response 'reallocate' acts on wheels only, "
        "not on thrusters"]


@pytest.mark.parametrize('kind, component, phase, response', [
    ('thrust_excess', 'thrusters [4, 5]', c.PHASE_TRAJECTORY_ADJUST, 'isolate_abort'),
    ('thrust_excess', 'thrusters [4, 5]', c.PHASE_FLYBY, 'isolate'),
    ('thrust_deficit', 'thrusters [0, 1]', c.PHASE_FLYBY, 'continue'),
    ('sensor_stale', 'relative_position', c.PHASE_TERMINAL_APPROACH, 'retreat'),
    ('sensor_stale', 'relative_position', c.PHASE_RETREAT, 'hold'),
    ('thrust_deficit', 'thrusters [0, 1]', c.PHASE_OPTIMAL_APPROACH, 'abort'),
    ('sensor_stale', 'relative_position', c.PHASE_ESTIMATION, 'hold'),
    ('node_lost', 'flyby_estimator', c.PHASE_HOLD, 'hold'),
    ('node_lost', 'flyby_estimator', c.PHASE_TERMINAL_APPROACH, 'retreat'),
    ('sensor_outliers', 'target_attitude', c.PHASE_DOCKING, 'continue'),
    ('sensor_inconsistent', 'star_tracker', c.PHASE_MASS_ESTIMATION, 'continue'),
    ('sensor_stale', 'lidar', c.PHASE_FLYBY, 'abort'),  # not in the table
    ('wheel_torque_deficit', 'wheels [2]', c.PHASE_PLANNING, 'reallocate'),
    ('wheel_torque_excess', 'wheels [0]', c.PHASE_TRAJECTORY_ADJUST, 'reallocate'),
    ('wheel_torque_deficit', 'wheels [2]', c.PHASE_FLYBY, 'continue'),
])
def test_the_table_answers_by_phase_group(kind, component, phase, response):
    assert FaultTable.load().response(kind, component, phase).response == response


def _detection(t, kind, component, candidates=None):
    monitor = ('thrusters' if kind.startswith('thrust') else 'wheels' if kind.startswith('wheel')
               else f'sensor/{component}')
    payload = event_payloads.FaultDetected(monitor, kind, component, t, candidates)
    return wire_event(Event(t, 'ERROR', events.FAULT_DETECTED, 'detected', event_payloads.encode(payload),
                            'flyby_estimator'))


def _supervisor_in(phase):
    core = SupervisorCore(SupervisorParams.from_scenario(load_scenario(REPO / 'scenarios' / 'paper_flyby_6dof.yaml')))
    core.machine.phase = phase
    return core


def test_a_leak_in_the_approach_closes_its_thrusters_and_aborts_and_in_the_flyby_only_closes_them():
    core = _supervisor_in(c.PHASE_TRAJECTORY_ADJUST)
    out = core.on_event(_detection(600.0, 'thrust_excess', 'thrusters [4, 5]', (4, 5)))
    names = [o.name for o in out if isinstance(o, Event)]
    assert names[:2] == [events.FAULT_RESPONSE, events.THRUSTERS_ISOLATED] and core.phase == c.PHASE_ABORTED
    isolated = next(o for o in out if isinstance(o, Event) and o.name == events.THRUSTERS_ISOLATED)
    assert event_payloads.decode_values(isolated.name, isolated.values).thrusters == (4, 5)
    flyby = _supervisor_in(c.PHASE_FLYBY)
    out = flyby.on_event(_detection(800.0, 'thrust_excess', 'thrusters [4, 5]', (4, 5)))
    assert flyby.phase == c.PHASE_FLYBY
    assert [o.name for o in out if isinstance(o, Event)] == [events.FAULT_RESPONSE, events.THRUSTERS_ISOLATED]


def test_a_continue_answer_leaves_the_phase_where_an_error_event_would_have_aborted():
    core = _supervisor_in(c.PHASE_TERMINAL_APPROACH)
    out = core.on_event(_detection(400.0, 'sensor_outliers', 'relative_position'))
    assert core.phase == c.PHASE_TERMINAL_APPROACH
    response = event_payloads.decode_values(out[0].name, out[0].values)
    assert (out[0].level, response.response, response.severity) == ('WARN', 'continue', 3)


def _event(t, name, payload, source='flyby_estimator'):
    e = wire_event(Event(t, 'ERROR', name, name, event_payloads.encode(payload), source))
    return {'t': e.t, 'level': e.level, 'name': e.name, 'message': e.message, 'values': e.values,
            'hardware_id': e.source}


def test_a_detection_answers_the_fault_acting_on_its_component_and_else_is_a_false_alarm():
    from flyby_mission.run_events import fault_detections
    log = [_event(10.0, events.FAULT_INJECTED, event_payloads.FaultInjected(0, 'thruster_stuck_on', 'thruster 3',
                                                                            10.0, None, 0.1), 'flyby_sim'),
           _event(10.3, events.FAULT_DETECTED, event_payloads.FaultDetected('thrusters', 'thrust_excess',
                                                                            'thrusters [2, 3]', 10.3, (2, 3))),
           _event(12.0, events.FAULT_DETECTED, event_payloads.FaultDetected('sensor/imu', 'sensor_stale', 'imu', 12.0)),
           _event(13.0, events.FAULT_DETECTED, event_payloads.FaultDetected('thrusters', 'thrust_deficit',
                                                                            'thrusters [0, 1]', 13.0, (0, 1)))]
    found = fault_detections(log)
    assert [(d['kind'], d['fault'], d['isolated']) for d in found] == [
        ('thrust_excess', 0, True), ('sensor_stale', 0, False), ('thrust_deficit', 0, False)]
    assert fault_detections(log[2:])[0]['fault'] is None  # nothing acting: a false alarm
    assert found[0]['delay_s'] == pytest.approx(0.3)


def test_the_single_fault_campaign_draws_one_valid_fault_of_each_type():
    from flyby_mission.campaign.dispersions import load_campaign
    campaign = load_campaign(REPO / 'campaigns' / 'faults_single.yaml', checked_draws=60)
    kinds = {campaign.draw(run)[0].faults[0].type for run in range(60)}
    assert len(kinds) == 12


def test_the_double_fault_campaign_draws_two_independent_valid_faults():
    from flyby_mission.campaign.dispersions import load_campaign
    campaign = load_campaign(REPO / 'campaigns' / 'faults_double.yaml', checked_draws=30)
    pairs = [tuple((f.type, f.start_phase) for f in campaign.draw(run)[0].faults) for run in range(30)]
    assert all(len(p) == 2 for p in pairs) and sum(a != b for a, b in pairs) >= 25


def test_an_isolation_without_candidates_aborts():
    core = _supervisor_in(c.PHASE_FLYBY)
    out = core.on_event(_detection(800.0, 'thrust_excess', 'thrusters', ()))
    response = event_payloads.decode_values(out[0].name, out[0].values)
    assert response.response == 'abort' and core.phase == c.PHASE_ABORTED
    assert not any(isinstance(o, Event) and o.name == events.THRUSTERS_ISOLATED for o in out)


def test_a_wheel_fault_in_the_approach_takes_the_wheel_out_and_the_approach_goes_on():
    core = _supervisor_in(c.PHASE_TERMINAL_APPROACH)
    out = core.on_event(_detection(400.0, 'wheel_torque_deficit', 'wheels [2]', (2,)))
    assert [o.name for o in out if isinstance(o, Event)] == [events.FAULT_RESPONSE, events.WHEELS_REALLOCATED]
    assert core.phase == c.PHASE_TERMINAL_APPROACH
    response = event_payloads.decode_values(out[0].name, out[0].values)
    assert (response.response, response.phase, response.severity) == ('reallocate', c.PHASE_TERMINAL_APPROACH, 2)
    assert event_payloads.decode_values(out[1].name, out[1].values).wheels == (2,)
    empty = _supervisor_in(c.PHASE_TERMINAL_APPROACH)  # a reallocation naming no wheel: nothing to take out
    out = empty.on_event(_detection(400.0, 'wheel_torque_excess', 'wheels []', ()))
    assert event_payloads.decode_values(out[0].name, out[0].values).response == 'abort'
    assert empty.phase == c.PHASE_ABORTED


def test_a_second_wheel_guidance_refuses_aborts_the_approach():
    """Wheel 2 reallocated, then wheel 0 detected: the table answers reallocate again, guidance refuses it (three
    orthogonal wheels, the wheels left no longer span three axes: modes.chaser) with an ERROR command_rejected, and
    the supervisor aborts on that watched node's ERROR."""
    core = _supervisor_in(c.PHASE_TERMINAL_APPROACH)
    core.on_event(_detection(400.0, 'wheel_torque_deficit', 'wheels [2]', (2,)))
    out = core.on_event(_detection(420.0, 'wheel_torque_deficit', 'wheels [0]', (0,)))
    assert event_payloads.decode_values(out[0].name, out[0].values).response == 'reallocate'
    assert core.phase == c.PHASE_TERMINAL_APPROACH
    refused = Event(420.0, 'ERROR', events.COMMAND_REJECTED, 'wheels_reallocated refused: wheels [0] cannot be taken '
                    'out: the wheels left [0, 1] already span fewer than three axes', {'wheels': [0]}, 'flyby_guidance')
    core.on_event(wire_event(refused))
    assert core.phase == c.PHASE_ABORTED
