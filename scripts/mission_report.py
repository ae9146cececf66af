#!/usr/bin/env python3
"""Figures of a mission run, from its bag and scenario (PNG, matplotlib Agg).

    .venv/bin/python scripts/mission_report.py RUN_DIR [--out DIR]

RUN_DIR is what scripts/run_mission.py leaves (bag/, scenario.yaml, summary.json); the figures go to
DIR (default RUN_DIR). Which figures a run gets, by its mission kind, is listed in flyby_mission.report.

An interrupted run works too: a bag without metadata.yaml is repaired first (as analyze_bag.py
does), and whatever is missing (topics, plan, grasp, burns, scenario) is left out; what was left out
is said on stderr. A figure whose essential data is missing is not written. Exit code 0, or 1 when a
figure failed (a bug: its traceback is on stderr) or the bag cannot be read.
"""

import sys
from pathlib import Path

from flyby_mission import cli
from flyby_mission.report.loading import say
from flyby_mission.report.writer import write_figures, write_report
from flyby_msgs_py.bag import BagError

__all__ = ('main', 'write_report')  # run_mission.py --report imports write_report from here


def main(argv=None):
    parser = cli.OneLineParser(description=__doc__.split('\n')[0])
    parser.add_argument('run_dir', type=Path, help='run directory (bag/, scenario.yaml, summary.json)')
    parser.add_argument('--out', type=Path, default=None, help='where the PNGs go (default RUN_DIR)')
    args = parser.parse_args(argv)
    if not args.run_dir.is_dir():
        parser.error(f'run_dir {args.run_dir}: not a directory')
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        parser.error(f'--out {args.out}: exists and is not a directory')
    try:
        written, failed = write_figures(args.run_dir, args.out)
    except BagError as err:
        say(str(err))
        return 1
    for path in written:
        print(path)
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
