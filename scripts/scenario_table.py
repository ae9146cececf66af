#!/usr/bin/env python3
"""The README's table of the shipped scenarios, generated from scenarios/*.yaml and their last measured runs.

A row: the file, its method (`planner.method` or the schema's default) and its last measured runs, kept per driver
in docs/measured/scenarios.json (outcome, wall time of the whole command, key figures, command, commit, load).
Prints the table; --write puts it into README.md between its markers (test/test_readme.py fails when they differ);
--measure [--headless-only] [--only NAME] flies the scenarios one at a time, niced (scripts/closed_loop.py --out
runs/table/NAME, scripts/run_mission.py --out runs/table/NAME_graph), and keeps what they give.
"""

import datetime
import json
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import yaml

from flyby_mission import cli
from flyby_sim.scenario.schema import SCHEMA

ROOT = Path(__file__).resolve().parents[1]
MEASURED = ROOT / 'docs' / 'measured' / 'scenarios.json'
README = ROOT / 'README.md'
BEGIN, END = '<!-- scenario-table:begin -->', '<!-- scenario-table:end -->'
DRIVERS = {'headless': ('scripts/closed_loop.py', 'runs/table/{name}'),
           'graph': ('scripts/run_mission.py', 'runs/table/{name}_graph')}
# The figures kept per run, those the summary has (not null) in this order; the two-chaser figures last.
KEY_FIGURES = ('capture_position_error_m', 'capture_velocity_error_mps', 'delta_v_total_mps', 'min_clearance_m',
               'final_angular_momentum_kg_m2_s', 'target_mass_error_pct', 'target_principal_moments_error_pct',
               'transport_final_position_error_m', 'transport_orbital_momentum_error_n_m_s',
               'transport_final_angular_momentum_kg_m2_s', 'transport_wheel_momentum_share', 'transport_settle_time_s',
               'transport_settle_bound_s', 'transport_conditions_met', 'min_separation_m')


def scenario_files():
    return sorted((ROOT / 'scenarios').glob('*.yaml'))


def method_of(path):
    planner = yaml.safe_load(path.read_text()).get('planner') or {}
    return planner.get('method', SCHEMA.fields['planner'].fields['method'].default)


def load_measured():
    return json.loads(MEASURED.read_text()) if MEASURED.exists() else {'scenarios': {}}


def caption(measured):
    """What the times are: when, on how many cores and under what load they were measured (from the records)."""
    runs = [r for e in measured['scenarios'].values() for r in (e.get('graph'), e.get('headless')) if r]
    days, loads = ' to '.join(sorted({r['date'][:10] for r in runs})), [r['load_average_1min'] for r in runs]
    return textwrap.fill(f'Wall time of the whole command, each run alone under `nice -n 10`, measured {days} on a'
                         f" {runs[0]['cpus']}-core machine (1-minute load average at a run's end, its own processes"
                         f' included: {min(loads):.1f} to {max(loads):.1f}). Headless `-`: the headless driver flies'
                         ' one chaser.', 120)


def row(path, entry):
    """One scenario's row: method as configured (and as flown where that differs), outcome, graph and headless time."""
    runs = [entry.get('graph'), entry.get('headless')]
    configured, flown = method_of(path), {r['method'] for r in runs if r and r.get('method')}
    method = configured if flown <= {configured} else f"{configured}: {', '.join(sorted(flown))}"
    outcome = ' / '.join(sorted({r['outcome'] for r in runs if r})) or 'not measured'
    graph, headless = ('-' if not r else f"{r['wall_s']:.0f} s" if r['wall_s'] < 120 else f"{r['wall_s'] / 60:.1f} min"
                       for r in runs)
    return f"| [`{path.name}`](scenarios/{path.name}) | {entry.get('shows', '')} | {method} | {outcome} | {graph} |" \
           f' {headless} |'


def table(measured=None):
    """The markdown table (with its caption line), one row per scenario file."""
    measured = load_measured() if measured is None else measured
    rows = ['| scenario | what it shows | method | outcome | graph | headless |', '|---|---|---|---|---|---|']
    rows += [row(path, measured['scenarios'].get(path.stem, {})) for path in scenario_files()]
    return '\n'.join(rows + ['', caption(measured)]).rstrip() + '\n'


def readme_table(text):
    """The text between the README's markers, or None without them."""
    return text.split(BEGIN, 1)[1].split(END, 1)[0].strip('\n') + '\n' if BEGIN in text and END in text else None


def write_readme():
    text = README.read_text()
    if readme_table(text) is None:
        raise SystemExit(f'error: {README.name}: no {BEGIN} ... {END} markers')
    head, rest = text.split(BEGIN, 1)
    README.write_text(f'{head}{BEGIN}\n{table()}{END}{rest.split(END, 1)[1]}')


def measure_one(path, driver):
    """Fly one scenario by one driver (niced) and return its record, or None when the run wrote no summary."""
    script, out = DRIVERS[driver]
    command = [script, '--scenario', f'scenarios/{path.name}', '--out', out.format(name=path.stem), '--force',
               *(['--quiet'] if driver == 'graph' else [])]
    summary_path = ROOT / out.format(name=path.stem) / 'summary.json'
    summary_path.unlink(missing_ok=True)
    start = time.monotonic()
    done = subprocess.run(['nice', '-n', '10', sys.executable, *command], cwd=ROOT, capture_output=True, text=True)
    wall_s = time.monotonic() - start
    if not summary_path.exists():
        print(f'{path.stem} {driver}: no summary (exit {done.returncode}): {done.stderr.strip()[-300:]}')
        return None
    summary = json.loads(summary_path.read_text())
    figures = {k: summary[k] for k in KEY_FIGURES if summary.get(k) is not None}
    if summary.get('chasers'):
        figures['chasers'] = {n: {k: c[k] for k in ('outcome', *KEY_FIGURES) if c.get(k) is not None}
                              for n, c in summary['chasers'].items()}
    return {'outcome': summary['outcome'], 'method': summary.get('method'), 'wall_s': round(wall_s, 1),
            'figures': figures, 'command': ' '.join(['.venv/bin/python', *command]),
            'commit': subprocess.run(['git', '-C', str(ROOT), 'describe', '--always', '--dirty'],
                                     capture_output=True, text=True).stdout.strip(),
            'date': datetime.datetime.now(datetime.UTC).strftime('%Y-%m-%d %H:%M UTC'),
            'load_average_1min': round(os.getloadavg()[0], 2), 'cpus': os.cpu_count()}


def measure(names, headless_only):
    """Fly the scenarios and keep each new record; a run without a summary keeps the scenario's last record."""
    measured = load_measured()
    for path in (p for p in scenario_files() if not names or p.stem in names):
        for driver in ('headless',) if headless_only else ('headless', 'graph'):
            record = measure_one(path, driver)
            if record is not None:
                measured['scenarios'].setdefault(path.stem, {})[driver] = record
                print(f"{path.stem} {driver}: {record['outcome']} in {record['wall_s']} s")
                MEASURED.write_text(json.dumps(measured, indent=1) + '\n')


def main(argv=None):
    ap = cli.OneLineParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--write', action='store_true', help='replace the table between the markers in README.md')
    ap.add_argument('--measure', action='store_true', help='run the scenarios and update ' + str(MEASURED.name))
    ap.add_argument('--headless-only', action='store_true', help='with --measure: the headless runs only')
    ap.add_argument('--only', action='append', default=[], choices=sorted(p.stem for p in scenario_files()),
                    metavar='NAME', help='with --measure: this scenario (repeatable)')
    args = ap.parse_args(argv)
    if (args.headless_only or args.only) and not args.measure:
        ap.error('--headless-only and --only go with --measure')
    if args.measure:
        measure(set(args.only), args.headless_only)
    write_readme() if args.write else print('' if args.measure else table(), end='')
    return 0


if __name__ == '__main__':
    sys.exit(main())
