#!/usr/bin/env python3
"""Headless missions in one process (no ROS), by the rules of the node graph, figures from truth.

    .venv/bin/python scripts/closed_loop.py --scenario S --seed N --out DIR
    .venv/bin/python scripts/closed_loop.py [--scenario S] --runs N [--first-seed K] [--nav-noise-scale F]
                                            [--jobs J] [--json FILE]

With --out: one mission (flyby_mission.headless: the plant and the cores every node runs, wired as
the topics wire them); DIR receives scenario.yaml (the exact input) and summary.json with the keys and
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
import shutil
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from flyby_mission import cli
from flyby_mission.headless import require_one_chaser, run_headless, scaled_navigation_noise
from flyby_mission.summary import EXIT_CODES, format_summary
from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def _one(job):
    path, seed, scale = job
    scenario = load_scenario(path, seed=seed)
    if scale != 1.0:
        scenario = scaled_navigation_noise(scenario, scale)
    run = run_headless(scenario)
    return {**run.summary, 'dv_commanded_mps': run.dv_commanded_mps, 'dv_ideal_mps': run.dv_ideal_mps}


class WorkerFailed(RuntimeError):
    """A run raised in its worker process, or the worker died: the command ends with its message (one line)."""


def _result(job, future, pool):
    """The run's result; a worker's exception (picklable) raised again here, any but a ScenarioError as
    WorkerFailed naming the seed, the pending runs cancelled. A worker that dies breaks the pool
    (BrokenProcessPool) rather than leaving it waiting."""
    try:
        return future.result()
    except ScenarioError:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    except Exception as err:
        pool.shutdown(wait=False, cancel_futures=True)
        raise WorkerFailed(f'seed {job[1]}: {type(err).__name__}: {err}') from err


def _stats(label, values, unit, scale=1.0):
    a = np.array([v for v in values if v is not None], dtype=float) * scale
    if a.size == 0:
        return f'{label}: no data'
    return (f'{label}: min {a.min():.4g} {unit}, median {np.median(a):.4g} {unit}, 95th percentile '
            f'{np.percentile(a, 95):.4g} {unit}, max {a.max():.4g} {unit} (n = {a.size})')


def _fmt(x, spec):
    return format(x, spec) if x is not None else format(float('nan'), spec)


def many(args):
    jobs = [(args.scenario, args.first_seed + k, args.nav_noise_scale) for k in range(args.runs)]
    with ProcessPoolExecutor(args.jobs) as pool:
        runs = [_result(job, future, pool) for job, future in zip(jobs, [pool.submit(_one, j) for j in jobs],
                                                                    strict=True)]
    print(f'{"seed":>5} {"outcome":>12} {"t_grasp":>9} {"miss_m":>8} {"miss_mm/s":>9} {"dv":>7} {"ideal":>7} '
          f'{"dv/ideal":>8} {"clear_m":>7} {"thrust_in":>9}')
    for r in runs:
        ratio = r['dv_commanded_mps'] / r['dv_ideal_mps'] if r['dv_ideal_mps'] else None
        vel = None if r['capture_velocity_error_mps'] is None else 1e3 * r['capture_velocity_error_mps']
        print(f'{r["seed"]:>5} {r["outcome"]:>12} {_fmt(r["t_grasp_s"], "9.2f")} '
              f'{_fmt(r["capture_position_error_m"], "8.4f")} {_fmt(vel, "9.3f")} {r["dv_commanded_mps"]:7.4f} '
              f'{_fmt(r["dv_ideal_mps"], "7.4f")} {_fmt(ratio, "8.3f")} {_fmt(r["min_clearance_m"], "7.3f")} '
              f'{str(r["thrust_inside_restriction_sphere"]):>9}')
    flown = [r for r in runs if r['dv_ideal_mps']]
    outcomes = {o: sum(r['outcome'] == o for r in runs) for o in sorted({r['outcome'] for r in runs})}
    print(f'navigation noise x{args.nav_noise_scale:g}; outcomes {outcomes}')
    print(_stats('position miss at the grasp', [r['capture_position_error_m'] for r in flown], 'cm', 100.0))
    print(_stats('velocity miss at the grasp', [r['capture_velocity_error_mps'] for r in flown], 'mm/s', 1e3))
    print(_stats('commanded / ideal delta-v', [r['dv_commanded_mps'] / r['dv_ideal_mps'] for r in flown], ''))
    print(_stats('least clearance (real geometry)', [r['min_clearance_m'] for r in flown], 'm'))
    print(f'runs with thrust inside the restriction sphere: {sum(r["thrust_inside_restriction_sphere"] for r in runs)}')
    if any('peak_grasp_force_n' in r for r in runs):  # after the capture (a post_capture section)
        for key, label, unit in (('peak_grasp_force_n', 'peak grasp force', 'N'),
                                 ('final_angular_momentum_kg_m2_s', 'angular momentum after the damping', 'kg m^2/s'),
                                 ('damping_time_s', 'damping time', 's'), ('damping_fuel_kg', 'damping fuel', 'kg'),
                                 ('target_mass_error_pct', 'target mass error', '%'),
                                 ('target_com_error_m', 'target CoM error', 'm'),
                                 ('target_principal_moments_error_pct', 'target principal moments error', '%'),
                                 ('target_principal_axes_error_deg', 'target principal axes error', 'deg')):
            print(_stats(label, [r.get(key) for r in runs], unit))
        print(f'grasps released: {sum(bool(r.get("grasp_released")) for r in runs)}')
    if args.json:
        Path(args.json).write_text(json.dumps(runs, indent=1))
    return 0


def one(args):
    scenario = load_scenario(args.scenario, seed=args.seed)
    out = cli.make_run_dir(args.out, args.force, {'mode': 'headless', 'scenario': str(args.scenario),
                                                  'seed': scenario.seed, 'launcher_pid': os.getpid()})
    shutil.copyfile(args.scenario, out / 'scenario.yaml')
    summary = run_headless(scenario).summary
    (out / 'summary.json').write_text(json.dumps(summary, indent=2) + '\n')
    print(format_summary(summary))
    return EXIT_CODES[summary['outcome']]


def parse_args(argv):
    """The options, each refused in one line naming it (exit code 2) when out of its range."""
    ap = cli.OneLineParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--scenario', default=str(ROOT / 'scenarios' / 'paper_flyby.yaml'))
    ap.add_argument('--seed', type=cli.int_at_least(0), help="one run: override the scenario's seed")
    ap.add_argument('--out', help='one run: write run.json, scenario.yaml and summary.json here')
    ap.add_argument('--force', action='store_true', help='one run: replace OUT if it holds a previous run')
    ap.add_argument('--runs', type=cli.int_at_least(1),
                    help='many runs: how many (seeds first-seed, first-seed + 1, ...)')
    ap.add_argument('--first-seed', type=cli.int_at_least(0), default=1)
    ap.add_argument('--nav-noise-scale', type=cli.float_above(0), default=1.0,
                    help='many runs: multiply the relative-position noise')
    ap.add_argument('--jobs', type=cli.int_at_least(1), default=2)
    ap.add_argument('--json', help='many runs: write every run as JSON here')
    ap.add_argument('--debug', action='store_true', help='show the traceback of an error')
    args = ap.parse_args(argv)
    if (args.out is None) == (args.runs is None):
        ap.error('give either --out DIR (one run) or --runs N (many runs)')
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
