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
Exit code 0 when every run flew (whatever its outcome), 1 when a run raised (ERROR) or the campaign is invalid.
"""

import argparse
import sys

from flyby_mission.campaign.runner import CampaignMismatch, run_campaign
from flyby_msgs_py.schema import ScenarioError


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--campaign', required=True, help='campaign YAML file')
    ap.add_argument('--out', required=True, help='output directory (resumed if it holds this campaign)')
    ap.add_argument('--runs', type=int, help="number of runs (default: the campaign file's runs)")
    ap.add_argument('--scheduler', help='address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786')
    ap.add_argument('--workers', type=int, help='LocalCluster worker processes (default: os.cpu_count())')
    args = ap.parse_args(argv)
    if args.scheduler and args.workers:
        ap.error('--workers sizes the local cluster; a --scheduler has its own workers')
    try:
        rows, stats, runs_per_hour = run_campaign(args.campaign, args.out, runs=args.runs, scheduler=args.scheduler,
                                                  workers=args.workers)
    except (ScenarioError, CampaignMismatch) as e:
        print(f'error: {e}', file=sys.stderr)
        return 1
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
