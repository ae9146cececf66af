#!/usr/bin/env python3
"""Benchmark: wall time of headless runs (flyby_mission.headless.run_headless), per run and mean.

    benchmark_headless.py SCENARIO.yaml [SCENARIO.yaml ...] [--save FILE.json] [--compare FILE.json]
    benchmark_headless.py --runs-dir DIR/runs --runs 0-19 [...]

Each scenario is flown once, in this process, one after the other (one core); the per-run wall time,
outcome and capture errors are printed, then the mean. ``--save`` writes every run's summary (floats
as their exact repr) and mission events to a JSON file; ``--compare`` flies the runs again and reports,
field by field, whether the summaries and events equal those saved, to the bit, and otherwise the
largest relative difference. Wall-clock figures (wall_time_s, real_time_factor, planning_time_s and
the events' planning_time_s) are left out of the comparison.
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

from flyby_mission.campaign.runner import run_indices
from flyby_mission.headless import run_headless
from flyby_sim.scenario import load_scenario

# Figures that measure the wall clock, not the mission.
WALL_CLOCK_KEYS = ('wall_time_s', 'real_time_factor', 'planning_time_s')
# The figures a campaign's rows are judged by.
KEY_FIGURES = ('outcome', 'capture_position_error_m', 'capture_velocity_error_mps', 'delta_v_total_mps',
               'min_clearance_m', 't_grasp_s')


def comparable(summary, events):
    """The run's summary and events without the wall-clock figures (module doc)."""
    s = {k: v for k, v in summary.items() if k not in WALL_CLOCK_KEYS}
    ev = [{**e, 'values': {k: v for k, v in e['values'].items() if k not in WALL_CLOCK_KEYS}} for e in events]
    return s, ev


def differences(saved, now, path=''):
    """[(path, saved value, new value, relative difference or None)] where the two differ."""
    if isinstance(saved, dict) and isinstance(now, dict):
        out = []
        for k in sorted(set(saved) | set(now)):
            out += differences(saved.get(k), now.get(k), f'{path}.{k}' if path else k)
        return out
    if isinstance(saved, list) and isinstance(now, list) and len(saved) == len(now):
        out = []
        for i, (a, b) in enumerate(zip(saved, now, strict=True)):
            out += differences(a, b, f'{path}[{i}]')
        return out
    if saved == now or (isinstance(saved, float) and isinstance(now, float) and math.isnan(saved) and math.isnan(now)):
        return []
    rel = None
    if isinstance(saved, (int, float)) and isinstance(now, (int, float)) and not isinstance(saved, bool):
        rel = abs(now - saved) / max(abs(saved), abs(now), 1e-300)
    return [(path, saved, now, rel)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('scenarios', nargs='*', help='scenario files')
    ap.add_argument('--runs-dir', help='a campaign\'s runs directory (DIR/runs), with --runs')
    ap.add_argument('--runs', default='0-19', help='run indices under --runs-dir (default 0-19)')
    ap.add_argument('--save', help='write the summaries and events to this JSON file')
    ap.add_argument('--compare', help='compare the summaries and events with this JSON file (of --save)')
    args = ap.parse_args()
    paths = list(args.scenarios)
    if args.runs_dir:
        paths += [str(Path(args.runs_dir) / str(i) / 'scenario.yaml') for i in run_indices(args.runs)]
    if not paths:
        ap.error('no scenario: give files or --runs-dir')
    saved = json.loads(Path(args.compare).read_text()) if args.compare else None
    records, walls, mismatched = {}, [], 0
    for path in paths:
        scenario = load_scenario(path)
        t0 = time.perf_counter()
        run = run_headless(scenario)
        wall = time.perf_counter() - t0
        walls.append(wall)
        s = run.summary
        summary, events = comparable(s, run.events)
        records[path] = {'summary': summary, 'events': events}
        line = (f'{path}: {wall:7.2f} s  {s["outcome"]:<13} sim {s["sim_time_s"]:7.1f} s  '
                f'capture {s["capture_position_error_m"]!r} m {s["capture_velocity_error_mps"]!r} m/s')
        if saved is not None:
            if path not in saved:
                line += '  (not in the saved file)'
            else:
                diff = differences(saved[path], records[path])
                key = [d for d in diff if d[0].split('.')[-1] in KEY_FIGURES and d[0].startswith('summary')]
                mismatched += bool(diff)
                rels = [d[3] for d in diff if d[3] is not None]
                line += ('  identical' if not diff else
                         f'  DIFFERS in {len(diff)} fields ({len(key)} key figures), largest relative '
                         f'{max(rels) if rels else float("nan"):.3g}')
                for d in diff[:8]:
                    line += f'\n    {d[0]}: {d[1]!r} -> {d[2]!r}'
        print(line, flush=True)
    mean = sum(walls) / len(walls)
    print(f'{len(walls)} runs: mean {mean:.3f} s, total {sum(walls):.2f} s')
    if saved is not None:
        print(f'{len(paths) - mismatched} of {len(paths)} runs identical to {args.compare} (summaries and events, '
              f'wall-clock figures left out)')
    if args.save:
        Path(args.save).write_text(json.dumps(records, indent=1))
    return 1 if mismatched else 0


if __name__ == '__main__':
    sys.exit(main())
