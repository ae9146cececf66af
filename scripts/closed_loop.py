#!/usr/bin/env python3
"""Headless missions in one process (no ROS), by the rules of the node graph, figures from truth.

    .venv/bin/python scripts/closed_loop.py --scenario S --seed N --out DIR
    .venv/bin/python scripts/closed_loop.py [--scenario S] --runs N [--first-seed K] [--nav-noise-scale F]
                                            [--jobs J] [--json FILE]

With --out: one mission (flyby_mission.headless: the plant and the cores every node runs, wired as
the topics wire them); DIR receives scenario.yaml (the input, seed as flown) and summary.json with the keys and
outcome classes of scripts/run_mission.py's, and the outcome table is printed. Exit code as
run_mission.py's (0 capture, 3 safe without capture, 5 collision, 1 error, 2 misuse of an option).
With --out, an existing DIR is replaced only with --force and only if it holds a previous run (its run.json).

With --runs: seeds K, K+1, ... in J processes; one line per run and the statistics: the miss of the
true chaser at the grasp time against the fly-by target point recomputed from the true target
attitude (position, velocity), the delta-v commanded against the ideal one (eq 28-29 of the same
transfer from the true state), the least clearance from the real target geometry, and any thrust
inside the restriction sphere; with a post_capture section also the grasp's peak force, the damping and the
target's mass-property errors (docs/post_capture.md).
"""

import json
import os
import sys
from pathlib import Path

from flyby_mission import cli, replay
from flyby_mission.headless import require_one_chaser, run_headless
from flyby_mission.headless_runs import WorkerFailed, run_seeds, run_table, statistics
from flyby_mission.summary import EXIT_CODES, format_summary
from flyby_sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def many(args):
    runs = run_seeds(args.scenario, args.first_seed, args.runs, args.nav_noise_scale, args.jobs)
    print('\n'.join(run_table(runs) + statistics(runs, args.nav_noise_scale)))
    if args.json:
        Path(args.json).write_text(json.dumps(runs, indent=1))
    return 0


def one(args):
    scenario = load_scenario(args.scenario, seed=args.seed)
    out = cli.make_run_dir(args.out, args.force, {'mode': 'headless', 'scenario': str(args.scenario),
                                                  'seed': scenario.seed, 'launcher_pid': os.getpid(),
                                                  replay.REPLAY_KEY: replay.replay_command('closed_loop.py', args.out)})
    replay.write_scenario(out, args.scenario, scenario.seed)  # the effective seed
    summary = run_headless(scenario).summary
    (out / 'summary.json').write_text(json.dumps(summary, indent=2) + '\n')
    print(format_summary(summary))
    return EXIT_CODES[summary['outcome']]


def parse_args(argv):
    """The options, each refused in one line naming it (exit code 2) when out of its range."""
    ap = cli.OneLineParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--scenario', default=str(ROOT / 'scenarios' / 'paper_flyby.yaml'))
    ap.add_argument('--seed', type=cli.seed, help="one run: override the scenario's seed")
    ap.add_argument('--out', help='one run: write run.json, scenario.yaml and summary.json here')
    ap.add_argument('--force', action='store_true', help='one run: replace OUT if it holds a previous run')
    ap.add_argument('--runs', type=cli.int_at_least(1),
                    help='many runs: how many (seeds first-seed, first-seed + 1, ...)')
    ap.add_argument('--first-seed', type=cli.seed, default=1)
    ap.add_argument('--nav-noise-scale', type=cli.float_above(0), default=1.0,
                    help='many runs: multiply the relative-position noise')
    ap.add_argument('--jobs', type=cli.processes, default=2, help='many runs: processes, in [1, 256]')
    ap.add_argument('--json', help='many runs: write every run as JSON here')
    ap.add_argument('--debug', action='store_true', help='show the traceback of an error')
    args = ap.parse_args(argv)
    if (args.out is None) == (args.runs is None):
        ap.error('give either --out DIR (one run) or --runs N (many runs)')
    if args.runs is not None:
        cli.check_seed_span(ap, args.first_seed, args.runs)
    try:
        if args.out is not None:
            cli.check_out(args.out, args.force)
        if args.json is not None and (Path(args.json).is_dir() or not Path(args.json).parent.is_dir()):
            raise ValueError(f'--json {args.json}: is a directory or its directory does not exist')
    except ValueError as err:
        ap.error(str(err))
    return args


def main(argv=None):
    args = parse_args(argv)
    try:
        require_one_chaser(load_scenario(args.scenario))
        return one(args) if args.out else many(args)
    except (ValueError, OSError, WorkerFailed) as err:  # ScenarioError is a ValueError
        return cli.fail(err, args.debug)


if __name__ == '__main__':
    sys.exit(main())
