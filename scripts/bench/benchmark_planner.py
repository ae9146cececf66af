#!/usr/bin/env python3
"""Benchmark: cost of planning a fly-by capture (the target prediction and plan_capture).

    benchmark_planner.py [--scenario scenarios/paper_flyby.yaml] [--repeat 20]

Plans as scripts/plan_capture.py does at t = 0 (plan_capture.timed_plan): the prediction of the true
target motion over the grasp-time search window (flyby_planner.flyby.config.truth_prediction) and
plan_capture on it (grasp search eq 13-15, candidates, one-orbit nonlinear passive-safety check,
selection). One untimed plan first (imports, caches); then `--repeat` timed plans. The planner's
target is < 100 ms for the whole.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_scenario

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # scripts/ is not a package
from plan_capture import timed_plan  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
TARGET_MS = 100.0


def _line(label, seconds):
    ms = 1e3 * np.asarray(seconds)
    return f'  {label:<28} median {np.median(ms):7.1f} ms, min {ms.min():7.1f} ms, max {ms.max():7.1f} ms'


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--scenario', default=str(ROOT / 'scenarios' / 'paper_flyby.yaml'))
    ap.add_argument('--repeat', type=int, default=20)
    args = ap.parse_args()
    if args.repeat < 1:
        print(f'error: --repeat: must be >= 1, got {args.repeat}', file=sys.stderr)
        return 2
    try:
        scenario = load_scenario(args.scenario)
    except ScenarioError as err:
        print(f'error: {err}', file=sys.stderr)
        return 2
    plan, *_ = timed_plan(scenario, 0.0)
    runs = [timed_plan(scenario, 0.0)[2:] for _ in range(args.repeat)]
    prediction_s, plan_s = np.array(runs).T
    total_s = prediction_s + plan_s
    outcome = (f'plan ok, t_grasp {plan.selected.t_grasp:.1f} s, {len(plan.candidates)} candidates' if plan.ok
               else f'refused: {plan.reason}')
    print(f'{scenario.name}: {outcome}; {args.repeat} repeats')
    print(_line('truth_prediction', prediction_s))
    print(_line('plan_capture', plan_s))
    print(_line('total', total_s))
    verdict = 'meets' if np.median(total_s) * 1e3 < TARGET_MS else 'MISSES'
    print(f'  median total {verdict} the {TARGET_MS:g} ms target')
    return 0


if __name__ == '__main__':
    sys.exit(main())
