#!/usr/bin/env python3
"""Recompute a run's figures from the truth topics of its bag and check them against summary.json.

    .venv/bin/python scripts/analyze_bag.py RUN_DIR [--scenario FILE]

RUN_DIR is what scripts/run_mission.py leaves (bag/, scenario.yaml, summary.json); a bag directory
alone also works with --scenario. A bag cut short by an interruption is repaired first (a copy is
not needed: the repair only writes the missing metadata). Every figure is recomputed by a different
route than flyby_mission.summary takes, from truth alone (flyby_mission.bag_check says which).

Prints a table and exits 0 when everything agrees (1 mm, 0.1 mm/s, 1e-6 kg, 1 ms), 4 when something
disagrees, 2 on bad input.
"""

import argparse
import json
import sys
from pathlib import Path

from flyby_mission import bag_check
from flyby_msgs_py.bag import repair_bag
from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_scenario


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('run_dir', help='run directory (bag/, scenario.yaml, summary.json) or a bag directory')
    ap.add_argument('--scenario', help='scenario file (default RUN_DIR/scenario.yaml)')
    args = ap.parse_args(argv)
    run_dir = Path(args.run_dir)
    bag_dir = run_dir / 'bag' if (run_dir / 'bag').is_dir() else run_dir
    scenario_path = Path(args.scenario) if args.scenario else run_dir / 'scenario.yaml'
    try:
        scenario = load_scenario(scenario_path)
    except (ScenarioError, OSError) as err:
        print(f'analyze_bag: {err}', file=sys.stderr)
        return 2
    if not bag_dir.is_dir():
        print(f'analyze_bag: {bag_dir}: no bag directory', file=sys.stderr)
        return 2
    if not (bag_dir / 'metadata.yaml').exists():
        print(f'analyze_bag: {bag_dir} was cut short; repairing: {repair_bag(bag_dir)}', file=sys.stderr)
    recomputed = bag_check.recompute_run(bag_dir, scenario)
    summary_path = run_dir / 'summary.json'
    if not summary_path.exists():
        print(json.dumps(recomputed, indent=2))
        print('analyze_bag: no summary.json to compare with; figures above recomputed from the bag', file=sys.stderr)
        return 0
    summary = json.loads(summary_path.read_text())
    rows = bag_check.compare_run(summary, recomputed, scenario)
    width = max(len(r[0]) for r in rows)
    for key, a, b, agrees in rows:
        print(f'{key:<{width}}  {a!s:>24}  {b!s:>24}  {"ok" if agrees else "DISAGREES"}')
    bad = [r[0] for r in rows if not r[3]]
    print('every figure agrees' if not bad else f'{len(bad)} figure(s) disagree: {", ".join(bad)}')
    return 4 if bad else 0


if __name__ == '__main__':
    sys.exit(main())
