#!/usr/bin/env python3
"""Run one flyby mission: launch the node graph, record it, wait for the end, write the summary.

    run_mission.py --scenario scenarios/paper_flyby.yaml --out runs/paper_flyby [--seed N]
                   [--rtf X] [--in-process] [--force] [--wall-timeout S] [--foxglove [PORT]]

Leaves in OUT: scenario.yaml (the input, seed as flown), bag/ (rosbag2, MCAP), summary.json, logs/ and
params/ (one file per node), run.json (ROS domain and process ids, written at start). Every node runs
as its own process on a ROS domain no other run on this machine holds; ``--in-process`` runs them
all in this process on one executor instead (flyby_mission.launcher).
Exit code: 0 capture, 3 no capture but safe (escape, no safe plan, abort, time limit), 5 collision,
130 interrupted, 1 error, 2 misuse of an option (one line naming it).
--force replaces only a directory that holds a previous run (its run.json, written first), never the working
directory, one of its parents, / or the home directory.
"""

import sys
from pathlib import Path

from flyby_mission import cli, launcher, live_view
from flyby_mission.summary import EXIT_CODES


def parse_args(argv):
    """The options, each refused in one line naming it (exit code 2) when out of its range; --out checked too."""
    ap = cli.OneLineParser(description=__doc__.split('\n')[0])
    ap.add_argument('--scenario', required=True, help='scenario YAML file')
    ap.add_argument('--out', required=True, help='run directory to create')
    ap.add_argument('--seed', type=cli.seed, default=None, help="override the scenario's seed")
    ap.add_argument('--rtf', type=cli.float_at_least(0), default=0.0,
                    help='bound on the real-time factor (0 = as fast as the graph keeps up)')
    ap.add_argument('--in-process', action='store_true', help='every node in this process')
    ap.add_argument('--force', action='store_true',
                    help='replace OUT if it holds a previous run (its run.json); never ., a parent of it, / or ~')
    ap.add_argument('--wall-timeout', type=cli.float_above(0), default=1800.0, help='give up after S seconds')
    ap.add_argument('--without', action='append', default=[], choices=launcher.OPTIONAL_NODES,
                    help='leave out an optional node (repeatable)')
    ap.add_argument('--quiet', action='store_true', help='no progress line')
    ap.add_argument('--report', action='store_true', help='write the plots of the run (*.png) into OUT')
    ap.add_argument('--abort-at', type=cli.float_at_least(0), metavar='T',
                    help='call mission/abort at sim time T (a fault)')
    ap.add_argument('--kill', metavar='NODE@T', help='kill a node at sim time T, e.g. flyby_guidance@200 (a fault)')
    ap.add_argument('--foxglove', type=int, nargs='?', const=live_view.DEFAULT_PORT, metavar='PORT',
                    help=f'serve the run live to a Foxglove app on ws://{live_view.HOST}:PORT '
                         f'(default {live_view.DEFAULT_PORT}; foxglove/flyby_layout.json)')
    ap.add_argument('--debug', action='store_true', help='show the traceback of an error')
    args = ap.parse_args(argv)
    try:
        launcher.faults_from_args(args)
        cli.check_out(args.out, args.force)
        if args.foxglove is not None:
            live_view.check_port(args.foxglove, args.in_process)
    except ValueError as err:
        ap.error(str(err))
    return args


def main(argv=None):
    args = parse_args(argv)
    options = {k: v for k, v in vars(args).items() if k not in ('report', 'debug')}
    try:
        summary = launcher.run(launcher.LaunchOptions(**options))
    except launcher.LaunchError as err:
        return cli.fail(err, args.debug)
    if args.report:
        from mission_report import write_report  # scripts/, beside this file
        for png in write_report(Path(args.out)):
            print(f'report: {png}', file=sys.stderr)
    return EXIT_CODES[summary['outcome']]


if __name__ == '__main__':
    sys.exit(main())
