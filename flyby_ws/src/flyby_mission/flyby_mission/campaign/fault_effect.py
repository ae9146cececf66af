"""Whether an undetected fault changed its run's outcome: each run of a fault campaign whose injected fault went
undetected is flown again without its faults (its twin: the same scenario, seed and draws), and the two outcomes are
compared (issue 40's acceptance: every fault that changes the outcome must be detected; docs/faults.md).

The campaign directory (flyby_mission.campaign.runner) gains ``runs/<i>/twin_summary.json`` per twin flown and
``fault_effect.csv``, one row per undetected fault: its run, kind and target, the outcome with and without it, and the
least clearance of both. A run whose twin was flown is not flown again (resume).
"""

import csv
import json
from pathlib import Path

import yaml

TWIN_SUMMARY = 'twin_summary.json'
EFFECT_CSV = 'fault_effect.csv'
EFFECT_COLUMNS = ('run', 'fault', 'kind', 'target', 'seen_as', 'outcome', 'twin_outcome', 'changed',
                  'min_clearance_m', 'twin_min_clearance_m')


def _read_json(path):
    return json.loads(path.read_text()) if path.is_file() else None


def undetected_faults(summary):
    """The injected plant faults of a run's summary that no isolated detection names (fault_report's rule)."""
    injected = (summary.get('faults_injected') or {}).get('plant') or []
    detections = summary.get('faults_detected') or []
    named = {d.get('fault') for d in detections if d.get('isolated', True)}
    return [f for f in injected if f['fault'] not in named]


def seen_as(summary, fault):
    """The first detection the summary counts toward ``fault`` but not isolated to it (its kind on its component:
    the fault's effect seen, its cause not named), or ''."""
    seen = [d for d in summary.get('faults_detected') or [] if d.get('fault') == fault['fault']]
    return f'{seen[0]["kind"]} on {seen[0]["component"]}' if seen else ''


def runs_to_twin(out_dir):
    """{run: its summary} of the campaign's runs with an undetected injected fault, in run order."""
    todo = {}
    for run_dir in sorted((Path(out_dir) / 'runs').iterdir(), key=lambda p: int(p.name)):
        summary = _read_json(run_dir / 'summary.json')
        if summary is not None and undetected_faults(summary):
            todo[int(run_dir.name)] = summary
    return todo


def twin_scenario(out_dir, run):
    """The run's scenario dict (runs/<i>/scenario.yaml) without its faults (the key left out: a scenario's faults
    list, when given, is not empty)."""
    scenario = yaml.safe_load((Path(out_dir) / 'runs' / str(run) / 'scenario.yaml').read_text())
    scenario.pop('faults', None)
    return scenario


def effect_rows(out_dir, summaries):
    """fault_effect.csv's rows of the runs in ``summaries`` whose twin was flown."""
    rows = []
    for run, summary in summaries.items():
        twin = _read_json(Path(out_dir) / 'runs' / str(run) / TWIN_SUMMARY)
        if twin is None:
            continue
        for f in undetected_faults(summary):
            rows.append(dict(run=run, fault=f['fault'], kind=f['kind'], target=f.get('target'),
                             seen_as=seen_as(summary, f), outcome=summary['outcome'], twin_outcome=twin['outcome'],
                             changed=summary['outcome'] != twin['outcome'],
                             min_clearance_m=summary.get('min_clearance_m'),
                             twin_min_clearance_m=twin.get('min_clearance_m')))
    return rows


def write_effect(out_dir, rows):
    """fault_effect.csv in the campaign directory."""
    with (Path(out_dir) / EFFECT_CSV).open('w', newline='') as f:
        writer = csv.DictWriter(f, fieldnames=EFFECT_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)


def effect_by_kind(rows):
    """{kind: {'undetected': n, 'changed': [(run, outcome, twin outcome, seen_as), ...]}} of fault_effect's rows."""
    out = {}
    for r in rows:
        k = out.setdefault(r['kind'], {'undetected': 0, 'changed': []})
        k['undetected'] += 1
        if r['changed']:
            k['changed'].append((r['run'], r['outcome'], r['twin_outcome'], r['seen_as']))
    return dict(sorted(out.items()))


EFFECT_HEADING = '## Undetected faults against their twins'


def effect_lines(rows):
    """report.md's section of fault_effect's rows: per fault type the undetected faults and the runs whose outcome
    their fault changed."""
    lines = ['', EFFECT_HEADING, '', 'Each run whose fault no isolated detection names, flown again without its '
             'faults (scripts/fault_effect.py): where the outcomes differ, the fault changed the outcome without being '
             'named.', '',
             '| fault injected | undetected | outcome changed | runs (with the fault against without; a detection of '
             'its effect not isolated to it) |',
             '|---|---|---|---|']
    for kind, k in effect_by_kind(rows).items():
        runs = ', '.join(changed_text(*c) for c in k['changed']) or '-'
        lines.append(f'| {kind} | {k["undetected"]} | {len(k["changed"])} | {runs} |')
    return lines


def changed_text(run, outcome, twin_outcome, seen):
    """One changed run as the report says it: its outcome against its twin's, and how its fault was seen."""
    return f'{run} ({outcome} against {twin_outcome}' + (f'; seen as {seen})' if seen else ')')


def with_effect_section(report_text, rows):
    """report.md's text with its undetected faults' section (``effect_lines``) in place of any earlier one."""
    head = report_text.split('\n' + EFFECT_HEADING)[0].rstrip('\n')
    return head + '\n' + '\n'.join(effect_lines(rows)) + '\n'
