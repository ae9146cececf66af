"""A campaign's faults (docs/faults.md): per injected fault type the outcomes, how many were detected and the
detection delay's percentiles, the CAMs fired; and the detections and CAMs of runs where no fault acted (false
alarms). Read from each run's summary.json (``faults_injected``, ``faults_detected``, ``cam_fired``)."""

import collections
import json
from pathlib import Path

import numpy as np
import yaml

from flyby_msgs_py import contract as c

DELAY_PERCENTILES = (50, 90, 99)


def _summary(out_dir, run):
    path = Path(out_dir) / 'runs' / str(run) / 'summary.json'
    return json.loads(path.read_text()) if path.is_file() else None


def fault_statistics(out_dir, rows):
    """{'by_kind': {kind: {runs, outcomes, detected, delay_s percentiles, cams, collisions}}, 'false_alarms':
    {runs_without_fault, detections, cams, runs}} over the runs of ``rows`` (run -> results.csv row), or None when no
    run injected a fault, detected one or fired a CAM."""
    by_kind = collections.defaultdict(lambda: dict(runs=0, outcomes=collections.Counter(), detected=0, delays=[],
                                                   cams=0, collisions=0))
    false = dict(runs_without_fault=0, never_started=0, detections=0, cams=0, runs=[])
    seen = False
    for run in sorted(rows):
        s = _summary(out_dir, run)
        if s is None:
            continue
        injected = (s.get('faults_injected') or {}).get('plant') or []
        detections = s.get('faults_detected') or []
        seen |= bool(injected or detections or s.get('cam_fired'))
        t_cam = s.get('t_cam_s')  # the CAM's own thrust is no fault: detections after it are not false alarms
        unexplained = [d for d in detections if d.get('fault') is None and (t_cam is None or d['t_s'] < t_cam)]
        if not injected:
            false['runs_without_fault'] += 1
            scenario = Path(out_dir) / 'runs' / str(run) / 'scenario.yaml'
            if scenario.is_file() and (yaml.safe_load(scenario.read_text()) or {}).get('faults'):
                false['never_started'] += 1  # its phase not reached, or due after the run's end
        if unexplained or (s.get('cam_fired') and not injected):
            false['detections'] += len(unexplained)
            false['cams'] += int(bool(s.get('cam_fired')) and not injected)
            false['runs'].append(run)
        for f in injected:
            k = by_kind[f['kind']]
            k['runs'] += 1
            k['outcomes'][s['outcome']] += 1
            k['cams'] += int(bool(s.get('cam_fired')))
            k['collisions'] += int(s['outcome'] == c.OUTCOME_COLLISION)
            delays = [d['delay_s'] for d in detections if d.get('fault') == f['fault'] and d.get('isolated', True)]
            if delays:
                k['detected'] += 1
                k['delays'].append(min(delays))
    if not seen:
        return None
    out = {}
    for kind, k in sorted(by_kind.items()):
        delays = np.array(k.pop('delays'))
        k['outcomes'] = dict(k['outcomes'])
        k['delay_s'] = {f'p{q}': float(np.percentile(delays, q)) for q in DELAY_PERCENTILES} if len(delays) else {}
        if len(delays):
            k['delay_s']['max'] = float(delays.max())
        out[kind] = k
    return {'by_kind': out, 'false_alarms': false}


def fault_lines(stats):
    """report.md's lines of ``fault_statistics``."""
    lines = ['', '## Faults', '', '| fault injected | runs | detected | delay p50 / p90 / p99 / max [s] | CAMs | '
             'collisions | outcomes |', '|---|---|---|---|---|---|---|']
    for kind, k in stats['by_kind'].items():
        d = k['delay_s']
        delay = ' / '.join(f'{d[q]:.2f}' for q in ('p50', 'p90', 'p99', 'max')) if d else '-'
        outcomes = ', '.join(f'{o} {n}' for o, n in sorted(k['outcomes'].items()))
        lines.append(f'| {kind} | {k["runs"]} | {k["detected"]} | {delay} | {k["cams"]} | {k["collisions"]} | '
                     f'{outcomes} |')
    f = stats['false_alarms']
    lines += ['', f'Detections with no fault acting (false alarms): {f["detections"]} in runs '
                  f'{f["runs"] or "none"}; CAMs in the {f["runs_without_fault"]} runs without a fault acting: '
                  f'{f["cams"]} ({f["never_started"]} of them scheduled one that never started: its phase not reached '
                  f'or due after the run\'s end).']
    return lines
