#!/usr/bin/env python3
"""Benchmark: the simulator and the recorder coasting, as separate processes over Fast DDS.

    benchmark_sim.py [--scenario scenarios/paper_flyby.yaml] [--duration 1500] [--compare-rtf 10]

Prints the real-time factor of a full-speed run (sim time / wall time from launch to summary,
start-up included) of the simulator and recorder alone and of the whole current graph, the cost of one plant step alone, and with ``--compare-rtf X`` whether the truth
of a run paced at X is identical to the full-speed one.
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from flyby_msgs_py.bag import read_bag
from flyby_msgs_py.scenario import load_scenario
from flyby_sim.plant import Plant, plant_config_from_scenario

ROOT = Path(__file__).resolve().parents[1]
TRUTH = ['/sim/chaser/odom', '/sim/target/odom']


def run(scenario, out, rtf, *extra):
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, str(ROOT / 'scripts' / 'run_mission.py'), '--quiet',
                           '--scenario', str(scenario), '--out', str(out), '--rtf', str(rtf),
                           *extra], capture_output=True, text=True)
    wall = time.monotonic() - t0
    if done.returncode not in (0, 3):
        raise SystemExit(f'run failed ({done.returncode}): {done.stderr}')
    return json.loads((out / 'summary.json').read_text()), wall


def plant_step_cost_us(scenario_path, steps=20000):
    plant = Plant(plant_config_from_scenario(load_scenario(scenario_path)))
    t0 = time.perf_counter()
    for _ in range(steps):
        plant.step()
    return (time.perf_counter() - t0) / steps * 1e6


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
        alone = [a for node in ('flyby_estimator', 'flyby_planner', 'flyby_guidance', 'flyby_supervisor')
                 for a in ('--without', node)]
        for label, extra in (('simulator + recorder', alone), ('whole graph', ())):
            summary, wall = run(scenario, tmp / 'max', 0.0, '--force', *extra)
            print(f'{label}, full speed: {summary["sim_time_s"]:.0f} s simulated in {wall:.1f} s '
                  f'wall (launcher to summary) -> {summary["sim_time_s"] / wall:.1f}x real time; '
                  f'summary real_time_factor {summary["real_time_factor"]:.1f}x')
        if args.compare_rtf:
            slow, slow_wall = run(scenario, tmp / 'paced', args.compare_rtf)
            a = read_bag(tmp / 'max' / 'bag', topics=TRUTH)
            b = read_bag(tmp / 'paced' / 'bag', topics=TRUTH)
            same = all(np.array_equal(getattr(a[t], f), getattr(b[t], f)) for t in TRUTH
                       for f in ('t', 'position', 'linear', 'orientation_xyzw', 'angular'))
            print(f'paced at {args.compare_rtf}x: {slow_wall:.1f} s wall; truth identical to the '
                  f'full-speed run: {same}')


if __name__ == '__main__':
    main()
