#!/usr/bin/env python3
"""Closed-loop fly-by approaches in one process (no ROS): figures of the guidance, measured from truth.

    .venv/bin/python scripts/closed_loop.py [--scenario S] [--runs N] [--first-seed K] [--nav-noise-scale F]
                                            [--jobs J] [--json FILE]

Each run is the scenario with seed K, K+1, ...: estimation, planning (on the estimates), terminal
transfer, trajectory adjusting and the coast past the grasp (flyby_guidance.closed_loop). Prints one
line per run and the statistics: miss of the true chaser at the grasp time against the fly-by target
point recomputed from the true target attitude (position, velocity), commanded against ideal
delta-v (eq 28-29 of the same transfer from the true state), least clearance from the real target
geometry, and any thrust inside the restriction sphere.
"""

import argparse
import json
import multiprocessing
import sys
from pathlib import Path

import numpy as np

from flyby_guidance.closed_loop import run_closed_loop, scaled_navigation_noise
from flyby_msgs_py.scenario import ScenarioError, load_scenario

ROOT = Path(__file__).resolve().parents[1]


def _one(job):
    path, seed, scale = job
    scenario = load_scenario(path, seed=seed)
    if scale != 1.0:
        scenario = scaled_navigation_noise(scenario, scale)
    return run_closed_loop(scenario).to_dict()


def _stats(label, values, unit, scale=1.0):
    a = np.array([v for v in values if v is not None], dtype=float) * scale
    if a.size == 0:
        return f'{label}: no data'
    return (f'{label}: min {a.min():.4g} {unit}, median {np.median(a):.4g} {unit}, 95th percentile '
            f'{np.percentile(a, 95):.4g} {unit}, max {a.max():.4g} {unit} (n = {a.size})')


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--scenario', default=str(ROOT / 'scenarios' / 'paper_flyby.yaml'))
    ap.add_argument('--runs', type=int, default=10)
    ap.add_argument('--first-seed', type=int, default=1)
    ap.add_argument('--nav-noise-scale', type=float, default=1.0, help='multiply the relative-position noise')
    ap.add_argument('--jobs', type=int, default=2)
    ap.add_argument('--json', help='write every run as JSON here')
    args = ap.parse_args()
    try:
        load_scenario(args.scenario)
    except (ScenarioError, OSError) as err:
        print(err, file=sys.stderr)
        return 2
    jobs = [(args.scenario, args.first_seed + k, args.nav_noise_scale) for k in range(args.runs)]
    with multiprocessing.Pool(args.jobs) as pool:
        runs = pool.map(_one, jobs)
    print(f'{"seed":>5} {"t_grasp":>9} {"miss_m":>8} {"miss_mm/s":>9} {"dv":>7} {"ideal":>7} {"dv/ideal":>8} '
          f'{"clear_m":>7} {"thrust_in":>9}')
    for r in runs:
        if not r['plan_ok']:
            print(f'{r["seed"]:>5} no plan: {r["plan_reason"]}')
            continue
        miss = r['miss_position_m']
        print(f'{r["seed"]:>5} {r["t_grasp"] or float("nan"):9.2f} {miss if miss is not None else float("nan"):8.4f} '
              f'{1e3 * (r["miss_velocity_mps"] or float("nan")):9.3f} {r["dv_commanded_mps"]:7.4f} '
              f'{r["dv_ideal_mps"]:7.4f} {r["dv_commanded_mps"] / r["dv_ideal_mps"]:8.3f} '
              f'{r["min_clearance_m"] if r["min_clearance_m"] is not None else float("nan"):7.3f} '
              f'{str(r["thrust_inside_sphere"]):>9}')
    planned = [r for r in runs if r['plan_ok']]
    print(f'navigation noise x{args.nav_noise_scale:g}, {len(planned)}/{len(runs)} planned')
    print(_stats('position miss at the grasp', [r['miss_position_m'] for r in planned], 'cm', 100.0))
    print(_stats('velocity miss at the grasp', [r['miss_velocity_mps'] for r in planned], 'mm/s', 1e3))
    print(_stats('commanded / ideal delta-v', [r['dv_commanded_mps'] / r['dv_ideal_mps'] for r in planned], ''))
    print(_stats('least clearance (real geometry)', [r['min_clearance_m'] for r in planned], 'm'))
    print(f'runs with thrust inside the restriction sphere: {sum(r["thrust_inside_sphere"] for r in runs)}')
    if args.json:
        Path(args.json).write_text(json.dumps(runs, indent=1))
    return 0


if __name__ == '__main__':
    sys.exit(main())
