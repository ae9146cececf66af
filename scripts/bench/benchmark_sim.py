#!/usr/bin/env python3
"""Benchmark: the simulator and the recorder coasting, then the whole mission graph, as separate processes.

    benchmark_sim.py [--scenario scenarios/paper_flyby.yaml] [--duration 1500] [--compare-rtf 10]

Prints the cost of one plant step alone and of one Odometry message (built, as bytes, read), and the
real-time factor of full-speed runs (sim time / wall time from launch to summary, start-up included) of
the simulator and recorder alone and of the whole graph (which ends at COMPLETE after a capture). With
``--compare-rtf X`` the whole graph runs again paced at X: its truth, the attachment at the capture included
(the simulator holds time for the capture decision), and its capture errors must be identical to the
full-speed run's.
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
import timeit
from pathlib import Path

import numpy as np
import yaml

from flyby_msgs_py import contract as c
from flyby_msgs_py import events
from flyby_msgs_py.bag import read_bag
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
TRUTH = ['/sim/chaser/odom', '/sim/target/odom']
EVENTS = c.absolute(c.MISSION_EVENTS)


def run(scenario, out, rtf, *extra):
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, str(ROOT / 'scripts' / 'run_mission.py'), '--quiet',
                           '--scenario', str(scenario), '--out', str(out), '--rtf', str(rtf),
                           *extra], capture_output=True, text=True)
    wall = time.monotonic() - t0
    if done.returncode not in (0, 3):
        raise SystemExit(f'run failed ({done.returncode}): {done.stderr}')
    return json.loads((out / 'summary.json').read_text()), wall


def truth_identical(run_a, run_b):
    """Whether two runs' truth (chaser and target odometry) is bit-identical up to the stamp of the supervisor's
    change to the final phase (the mission's end, the same in both when they agree); past it the simulator steps on
    until the launcher stops it, a wall-clock matter. Returns (identical, that stamp, each run's tail in s)."""
    a, b = (read_bag(d / 'bag', topics=TRUTH + [EVENTS]) for d in (run_a, run_b))
    ends = [max(e['t'] for e in bag[EVENTS] if e['name'] == events.PHASE_CHANGED) for bag in (a, b)]
    if ends[0] != ends[1]:
        return False, ends, None
    t_end, same = ends[0], True
    for topic in TRUTH:
        ka, kb = (int(np.searchsorted(bag[topic].t, t_end, side='right')) for bag in (a, b))
        same = same and ka == kb and all(np.array_equal(getattr(a[topic], f)[:ka], getattr(b[topic], f)[:kb])
                                         for f in ('t', 'position', 'linear', 'orientation_xyzw', 'angular'))
    tails = [round(float(bag[TRUTH[0]].t[-1]) - t_end, 3) for bag in (a, b)]
    return same, t_end, tails


def plant_step_cost_us(scenario_path, steps=20000):
    plant = Plant(PlantConfig.from_scenario(load_scenario(scenario_path)))
    t0 = time.perf_counter()
    for _ in range(steps):
        plant.step()
    return (time.perf_counter() - t0) / steps * 1e6


def codec_costs_us(n=2000):
    """Per-message cost [us] of the hot path's Odometry: built as a Python message, built as CDR bytes, read
    from CDR bytes (flyby_msgs_py.convert); best of five repeats."""
    from flyby_msgs_py import convert
    p, q, v, w = (1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    raw = convert.odometry_cdr(12.35, c.FRAME_HILL, c.FRAME_CHASER_BODY, p, q, v, w)
    calls = {'odometry (message)': lambda: convert.odometry(12.35, c.FRAME_HILL, c.FRAME_CHASER_BODY, p, q, v, w),
             'odometry_cdr (bytes)': lambda: convert.odometry_cdr(12.35, c.FRAME_HILL, c.FRAME_CHASER_BODY,
                                                                  p, q, v, w),
             'odometry_cdr_to_numpy': lambda: convert.odometry_cdr_to_numpy(raw)}
    return {name: min(timeit.repeat(call, number=n, repeat=5)) / n * 1e6 for name, call in calls.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--scenario', default=str(ROOT / 'scenarios' / 'paper_flyby.yaml'))
    ap.add_argument('--duration', type=float, default=1500.0, help='simulated seconds')
    ap.add_argument('--compare-rtf', type=float, default=None)
    args = ap.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        data = yaml.safe_load(Path(args.scenario).read_text())
        data['simulation']['duration_s'] = args.duration
        scenario = tmp / 'bench.yaml'
        scenario.write_text(yaml.safe_dump(data, sort_keys=False))

        print(f'plant step alone: {plant_step_cost_us(scenario):.1f} us per '
              f'{data["simulation"]["step_s"]} s step')
        print('one Odometry: ' + ', '.join(f'{name} {us:.1f} us' for name, us in codec_costs_us().items()))
        alone = [a for node in ('flyby_estimator', 'flyby_planner', 'flyby_guidance', 'flyby_supervisor')
                 for a in ('--without', node)]
        for label, extra in (('simulator + recorder', alone), ('whole graph', ())):
            summary, wall = run(scenario, tmp / 'max', 0.0, '--force', *extra)
            print(f'{label}, full speed: {summary["sim_time_s"]:.0f} s simulated in {wall:.1f} s '
                  f'wall (launcher to summary) -> {summary["sim_time_s"] / wall:.1f}x real time; '
                  f'summary real_time_factor {summary["real_time_factor"]:.1f}x')
        if args.compare_rtf:
            slow, slow_wall = run(scenario, tmp / 'paced', args.compare_rtf)
            same, t_end, tails = truth_identical(tmp / 'max', tmp / 'paced')
            errors = [(s['capture_position_error_m'], s['capture_velocity_error_mps']) for s in (summary, slow)]
            print(f'paced at {args.compare_rtf}x: {slow_wall:.1f} s wall; the whole truth to the mission\'s end '
                  f'({t_end} s, the final phase\'s stamp) identical to the full-speed run: {same} (after it, '
                  f'until the launcher stopped the simulator: {tails[0]} and {tails[1]} s); capture errors (m, m/s) '
                  f'full speed {errors[0]}, paced {errors[1]}')

if __name__ == '__main__':
    main()
