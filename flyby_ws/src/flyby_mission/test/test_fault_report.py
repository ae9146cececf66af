"""A fault campaign's statistics (fault_report) and the undetected faults' twins (fault_effect), read from a
campaign directory built here: the summaries' keys as the headless driver writes them."""

import csv
import json
import subprocess
import sys
from pathlib import Path

import yaml

from flyby_mission.campaign.fault_effect import (
    EFFECT_CSV,
    TWIN_SUMMARY,
    effect_by_kind,
    effect_rows,
    runs_to_twin,
    twin_scenario,
    with_effect_section,
    write_effect,
)
from flyby_mission.campaign.fault_report import fault_lines, fault_statistics
from flyby_sim.scenario import load_scenario, scenario_from_dict

REPO = Path(__file__).resolve().parents[4]


def _fault(n, kind, target='relative_position'):
    return {'fault': n, 'kind': kind, 'target': target, 't_start_s': 100.0, 't_end_s': 130.0, 'value': None}


def _detection(n, delay_s, isolated=True):
    return {'t_s': 100.0 + delay_s, 'monitor': 'm', 'kind': 'sensor_stale', 'component': 'c', 'fault': n,
            'isolated': isolated, 'delay_s': delay_s}


def _campaign(tmp_path):
    """Four runs: 0 detected, 1 undetected (its twin captures where it aborted), 2 undetected (no change), 3 a
    detection with no fault (a false alarm)."""
    runs = {
        0: dict(outcome='ABORTED', faults_injected={'plant': [_fault(0, 'sensor_dropout')]},
                faults_detected=[_detection(0, 0.6)]),
        1: dict(outcome='ABORTED', faults_injected={'plant': [_fault(0, 'topic_loss', 'topic /x')]},
                faults_detected=[_detection(0, 2.0, isolated=False)], min_clearance_m=9.0),
        2: dict(outcome='CAPTURE', faults_injected={'plant': [_fault(0, 'thruster_misaligned', 'thruster 3')]},
                faults_detected=[], min_clearance_m=0.3),
        3: dict(outcome='CAPTURE', faults_injected={'plant': []},
                faults_detected=[dict(_detection(0, 1.0), fault=None)]),
    }
    for run, summary in runs.items():
        d = tmp_path / 'runs' / str(run)
        d.mkdir(parents=True)
        (d / 'summary.json').write_text(json.dumps(summary))
        faults = [{'type': 'sensor_dropout', 'sensor': 'relative_position'}] if run != 3 else []
        (d / 'scenario.yaml').write_text(yaml.safe_dump({'seed': run, 'faults': faults}))
    return runs


def test_fault_statistics_counts_detections_delays_and_false_alarms(tmp_path):
    _campaign(tmp_path)
    stats = fault_statistics(tmp_path, {0: {}, 1: {}, 2: {}, 3: {}})
    by_kind = stats['by_kind']
    assert by_kind['sensor_dropout']['detected'] == 1
    assert by_kind['sensor_dropout']['delay_s']['p50'] == 0.6
    assert by_kind['topic_loss']['detected'] == 0  # a detection not isolated to the fault is no detection of it
    assert by_kind['thruster_misaligned']['outcomes'] == {'CAPTURE': 1}
    assert stats['false_alarms']['runs'] == [3] and stats['false_alarms']['detections'] == 1
    assert any('sensor_dropout' in line for line in fault_lines(stats))


def test_fault_effect_twins_only_undetected_runs_and_compares_outcomes(tmp_path):
    summaries = _campaign(tmp_path)
    todo = runs_to_twin(tmp_path)
    assert sorted(todo) == [1, 2]
    assert 'faults' not in twin_scenario(tmp_path, 1)
    assert effect_rows(tmp_path, todo) == []  # no twin flown yet
    for run, outcome in ((1, 'CAPTURE'), (2, 'CAPTURE')):
        (tmp_path / 'runs' / str(run) / TWIN_SUMMARY).write_text(json.dumps({'outcome': outcome,
                                                                             'min_clearance_m': 0.4}))
    rows = effect_rows(tmp_path, todo)
    assert [(r['run'], r['changed']) for r in rows] == [(1, True), (2, False)]
    by_kind = effect_by_kind(rows)
    assert by_kind['topic_loss'] == {'undetected': 1, 'changed': [(1, 'ABORTED', 'CAPTURE', 'sensor_stale on c')]}
    assert by_kind['thruster_misaligned'] == {'undetected': 1, 'changed': []}
    write_effect(tmp_path, rows)
    with (tmp_path / EFFECT_CSV).open() as f:
        assert [r['run'] for r in csv.DictReader(f)] == ['1', '2']
    assert summaries[0]['outcome'] == 'ABORTED'
    report = with_effect_section('# report\n\nbody\n', rows)
    assert '| topic_loss | 1 | 1 | 1 (ABORTED against CAPTURE; seen as sensor_stale on c) |' in report
    assert with_effect_section(report, rows) == report  # the section replaced, not repeated


def test_fault_effect_script_refuses_a_directory_without_a_campaign(tmp_path):
    out = subprocess.run([sys.executable, str(REPO / 'scripts' / 'fault_effect.py'), '--out', str(tmp_path)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert out.stderr.strip().splitlines()[-1].endswith(f'--out {tmp_path}: no campaign there (no runs/ directory)')
    assert 'Traceback' not in out.stderr


def test_fault_effect_script_reports_a_changed_outcome_from_flown_twins(tmp_path):
    _campaign(tmp_path)
    for run in (1, 2):
        (tmp_path / 'runs' / str(run) / TWIN_SUMMARY).write_text(json.dumps({'outcome': 'CAPTURE'}))
    out = subprocess.run([sys.executable, str(REPO / 'scripts' / 'fault_effect.py'), '--out', str(tmp_path)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 1, out.stderr
    assert 'topic_loss: 1 undetected, outcome changed in 1: 1 (ABORTED against CAPTURE; seen as sensor_stale on c)' \
        in out.stdout
    assert 'thruster_misaligned: 1 undetected, outcome changed in 0: none' in out.stdout


def test_a_twin_of_a_drawn_fault_scenario_loads_without_its_faults(tmp_path):
    """The twin of a real scenario with a fault is a valid scenario (a faults list, when given, must not be empty)."""
    scenario = load_scenario(REPO / 'scenarios' / 'paper_flyby_6dof.yaml').to_dict()
    scenario['faults'] = [{'type': 'thruster_off', 'index': 3, 'start_phase': 'TERMINAL_APPROACH', 'delay_s': 5.0}]
    run_dir = tmp_path / 'runs' / '0'
    run_dir.mkdir(parents=True)
    (run_dir / 'scenario.yaml').write_text(yaml.safe_dump(scenario))
    assert scenario_from_dict(scenario, name='faulted').faults
    twin = scenario_from_dict(twin_scenario(tmp_path, 0), name='twin')
    assert not twin.faults and twin.seed == scenario['seed']
