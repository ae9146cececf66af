#!/usr/bin/env python3
"""Fly a Monte Carlo campaign of headless missions on Dask distributed.

    .venv/bin/python scripts/run_campaign.py --campaign campaigns/smoke.yaml --out runs/smoke [--runs N]
                                             [--workers K | --scheduler ADDRESS]

The campaign file (flyby_mission.campaign.dispersions) names the base scenario, the campaign seed and the dispersions;
run i is drawn from [campaign seed, i] alone. Each run's scenario.yaml and summary.json go to
DIR/runs/<i>/, one row per finished run to DIR/results.csv, and the statistics to DIR/campaign.json and
DIR/report.md (flyby_mission.campaign.runner, campaign_report). Rerun the same command to resume. Without
--scheduler, a LocalCluster of K (default: one per core) single-threaded worker processes; with it, the
workers of a running `dask scheduler` (`dask worker ADDRESS` on each machine).
Exit code 0 when every run flew (whatever its outcome), 1 when a run raised (ERROR) or the campaign is invalid, 2 for
a misused option (one line naming it; an unreachable --scheduler within a few seconds).
"""

import sys
from pathlib import Path

from flyby_mission import cli
from flyby_mission.campaign.runner import CampaignMismatch, run_campaign
from flyby_msgs_py.schema import ScenarioError


def parse_args(argv):
    """The options, each refused in one line naming it (exit code 2): ranges, --out, the scheduler's reachability."""
    ap = cli.OneLineParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--campaign', required=True, help='campaign YAML file')
    ap.add_argument('--out', required=True, help='output directory (resumed if it holds this campaign)')
    ap.add_argument('--runs', type=cli.int_at_least(1), help="number of runs (default: the campaign file's runs)")
    ap.add_argument('--scheduler', help='address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786')
    ap.add_argument('--workers', type=cli.processes,
                    help='LocalCluster worker processes, in [1, 256] (default: os.cpu_count())')
    ap.add_argument('--debug', action='store_true', help='show the traceback of an error')
    args = ap.parse_args(argv)
    if args.scheduler and args.workers:
        ap.error('--workers sizes the local cluster; a --scheduler has its own workers')
    try:
        if Path(args.out).exists() and not Path(args.out).is_dir():
            raise ValueError(f'--out {args.out}: exists and is not a directory')
        if args.scheduler:
            cli.check_scheduler(args.scheduler)
    except ValueError as err:
        ap.error(str(err))
    return args


def main(argv=None):
    args = parse_args(argv)
    try:
        rows, stats, runs_per_hour = run_campaign(args.campaign, args.out, runs=args.runs, scheduler=args.scheduler,
                                                  workers=args.workers)
    except (ScenarioError, CampaignMismatch, OSError) as err:
        return cli.fail(err, args.debug)
    if runs_per_hour is not None:
        print(f'throughput: {runs_per_hour:.0f} runs/h')
    print('outcomes: ' + ', '.join(f'{o} {n}' for o, n in stats['outcome_counts'].items())
          + f' ({stats["runs"]} runs)')
    for name, what in (('capture_rate', 'capture rate'),
                       ('capture_rate_of_plans_flown', 'capture rate of plans flown')):
        rate = stats[name]
        if rate['runs']:
            lo, hi = rate['ci95_clopper_pearson']
            print(f'{what} {rate["successes"]}/{rate["runs"]} = {rate["rate"]:.4f}, 95 % [{lo:.4f}, {hi:.4f}]')
    if stats['refusals_by_class']:
        print('NO_SAFE_PLAN by class: ' + ', '.join(f'{k} {n}' for k, n in stats['refusals_by_class'].items()))
    print(f'report: {args.out}/report.md')
    return 1 if stats['outcome_counts'].get('ERROR') else 0


if __name__ == '__main__':
    sys.exit(main())
