#!/usr/bin/env python3
"""Fly each undetected fault's run again without its faults and say whether the fault changed the outcome.

    .venv/bin/python scripts/fault_effect.py --out runs/faults_single [--workers K]

--out is a fault campaign's directory (scripts/run_campaign.py). Each run with an injected fault that no detection
names is flown again from its scenario.yaml without its faults (flyby_mission.campaign.fault_effect), on a Dask
LocalCluster of K single-threaded workers (default: one per core); its summary goes to runs/<i>/twin_summary.json,
one row per undetected fault to fault_effect.csv, and per fault type the undetected faults and those whose run's
outcome differs from its twin's are printed and written to report.md (its section replaced on a rerun). Rerun to
resume. Exit code 0 when no undetected fault changed an outcome, 1 when one did or a twin raised, 2 for a misused
option (one line naming it).
"""

import json
import os
import sys
from pathlib import Path

import dask
import distributed

from flyby_mission import cli
from flyby_mission.campaign.fault_effect import (
    TWIN_SUMMARY,
    changed_text,
    effect_by_kind,
    effect_rows,
    runs_to_twin,
    twin_scenario,
    with_effect_section,
    write_effect,
)
from flyby_mission.campaign.runner import QUIET_CLUSTER, error_summary, fly
from flyby_msgs_py import contract as c


def parse_args(argv):
    """The options, each refused in one line naming it (exit code 2)."""
    ap = cli.OneLineParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--out', required=True, help="a fault campaign's output directory")
    ap.add_argument('--workers', type=cli.processes,
                    help='LocalCluster worker processes, in [1, 256] (default: os.cpu_count())')
    ap.add_argument('--debug', action='store_true', help='show the traceback of an error')
    args = ap.parse_args(argv)
    if not (Path(args.out) / 'runs').is_dir():
        ap.error(f'--out {args.out}: no campaign there (no runs/ directory)')
    return args


def fly_twins(out, todo, workers):
    """Fly the twins of ``todo`` (runs) on a LocalCluster, each summary written as it finishes."""
    with dask.config.set(QUIET_CLUSTER):
        cluster = distributed.LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=1,
                                           processes=True, dashboard_address=None)
        try:
            with distributed.Client(cluster) as client:
                futures = {client.submit(fly, run, twin_scenario(out, run), pure=False): run for run in todo}
                for n, future in enumerate(distributed.as_completed(futures), 1):
                    run = futures[future]
                    try:
                        summary = future.result()
                    except Exception as e:  # e.g. KilledWorker: the twin's ERROR, as a campaign's row
                        summary = error_summary(None, e, None)
                    (out / 'runs' / str(run) / TWIN_SUMMARY).write_text(json.dumps(summary, indent=2) + '\n')
                    print(f'{n}/{len(todo)} twins, run {run}: {summary["outcome"]}', file=sys.stderr)
        finally:
            cluster.close()


def main(argv=None):
    args = parse_args(argv)
    out = Path(args.out)
    try:
        summaries = runs_to_twin(out)
        todo = [run for run in summaries if not (out / 'runs' / str(run) / TWIN_SUMMARY).is_file()]
        if todo:
            fly_twins(out, todo, args.workers)
        rows = effect_rows(out, summaries)
        write_effect(out, rows)
        report = out / 'report.md'
        if report.is_file():
            report.write_text(with_effect_section(report.read_text(), rows))
    except (OSError, ValueError, KeyError) as err:
        return cli.fail(err, args.debug)
    changed = 0
    for kind, k in effect_by_kind(rows).items():
        runs = ', '.join(changed_text(*c) for c in k['changed']) or 'none'
        print(f'{kind}: {k["undetected"]} undetected, outcome changed in {len(k["changed"])}: {runs}')
        changed += len(k['changed'])
    errors = sum(1 for r in rows if r['twin_outcome'] == c.OUTCOME_ERROR)
    print(f'{len(rows)} undetected faults in {len(summaries)} runs; {changed} changed the outcome; '
          f'{errors} twins raised; {out / "fault_effect.csv"}')
    return 1 if changed or errors else 0


if __name__ == '__main__':
    sys.exit(main())
