#!/usr/bin/env python3
"""Recompute a run's figures from the truth topics of its bag and check them against summary.json.

    .venv/bin/python scripts/analyze_bag.py RUN_DIR [--scenario FILE]

RUN_DIR is what scripts/run_mission.py leaves (bag/, scenario.yaml, summary.json); a bag directory
alone also works with --scenario. --scenario of a run directory must be the run's own scenario (the
same content as RUN_DIR/scenario.yaml once loaded). A bag cut short by an interruption is repaired
first (a copy is not needed: the repair keeps the original as *.mcap.damaged). The bag's CRCs are
checked first (flyby_msgs_py.bag.verify_bag). Every figure is recomputed by a different route than
flyby_mission.summary takes, from truth alone (flyby_mission.bag_check says which).

Prints a table and exits 0 when everything agrees (1 mm, 0.1 mm/s, 1e-6 kg, 1 ms), 4 when something
disagrees, 1 on a damaged input (bag, non-finite truth, summary.json), 2 on bad input (arguments,
scenario); an error is one line `analyze_bag: error: ...` on stderr.
"""

import argparse
import json
import sys
from pathlib import Path

from flyby_mission import bag_check
from flyby_msgs_py.bag import BagError, repair_bag, verify_bag
from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_scenario

REPAIR_HINT = 'run `python -m flyby_msgs_py.bag repair {}` to salvage what is intact'


class InputError(Exception):
    """An error of the input with the exit code it ends the command with."""

    def __init__(self, message, code):
        super().__init__(message)
        self.code = code


def _scenario(run_dir, given):
    """The scenario to recompute with: the run's own, or ``given`` if it is the same (exit 2 if not)."""
    own = run_dir / 'scenario.yaml'
    try:
        scenario = load_scenario(Path(given) if given else own)
        if given and own.is_file():
            theirs = load_scenario(own)
            if theirs.to_yaml() != scenario.to_yaml():
                raise InputError(f'--scenario {given} (name {scenario.raw.get("name")!r}, seed '
                                 f'{scenario.raw.get("seed")!r}) is not the scenario of this run, {own} (name '
                                 f'{theirs.raw.get("name")!r}, seed {theirs.raw.get("seed")!r}); '
                                 'leave --scenario out to use the run\'s own', 2)
    except (ScenarioError, OSError) as err:
        raise InputError(str(err), 2) from None
    return scenario


def _summary(run_dir):
    """summary.json of the run as a dict, None if there is none (exit 1 if it is not a JSON object)."""
    path = run_dir / 'summary.json'
    if not path.exists():
        return None
    try:
        summary = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise InputError(f'{path}: not a summary (unreadable JSON: {err})', 1) from None
    if not isinstance(summary, dict):
        raise InputError(f'{path}: not a summary (a JSON {type(summary).__name__}, not an object)', 1)
    return summary


def _recompute(bag_dir, scenario):
    """The figures of the bag, after repairing a cut-short bag and checking its CRCs (exit 1 if damaged)."""
    if not bag_dir.is_dir():
        raise InputError(f'{bag_dir}: no bag directory', 2)
    if not (bag_dir / 'metadata.yaml').exists():
        try:
            report = repair_bag(bag_dir)
        except BagError as err:
            raise InputError(f'{bag_dir} was cut short and cannot be repaired: {err}', 1) from None
        print(f'analyze_bag: {bag_dir} was cut short; repaired: {report["message_count"]} messages salvaged',
              file=sys.stderr)
    try:
        verify_bag(bag_dir)
        return bag_check.recompute_run(bag_dir, scenario)
    except BagError as err:
        message = str(err).replace('bag repair DIR`', f'bag repair {bag_dir}`')
        hint = '' if 'flyby_msgs_py.bag repair' in message else '; ' + REPAIR_HINT.format(bag_dir)
        raise InputError(message + hint, 1) from None
    except bag_check.TruthError as err:
        raise InputError(f'{bag_dir}: {err}', 1) from None


def _run(args):
    run_dir = Path(args.run_dir)
    bag_dir = run_dir / 'bag' if (run_dir / 'bag').is_dir() else run_dir
    scenario = _scenario(run_dir, args.scenario)
    summary = _summary(run_dir)
    recomputed = _recompute(bag_dir, scenario)
    if summary is None:
        print(json.dumps(recomputed, indent=2))
        print('analyze_bag: no summary.json to compare with; figures above recomputed from the bag', file=sys.stderr)
        return 0
    rows = bag_check.compare_run(summary, recomputed, scenario)
    width = max(len(r[0]) for r in rows)
    for key, a, b, agrees in rows:
        print(f'{key:<{width}}  {a!s:>24}  {b!s:>24}  {"ok" if agrees else "DISAGREES"}')
    bad = [r[0] for r in rows if not r[3]]
    print('every figure agrees' if not bad else f'{len(bad)} figure(s) disagree: {", ".join(bad)}')
    return 4 if bad else 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('run_dir', help='run directory (bag/, scenario.yaml, summary.json) or a bag directory')
    ap.add_argument('--scenario', help='scenario file (default RUN_DIR/scenario.yaml; must be the run\'s own)')
    args = ap.parse_args(argv)
    try:
        return _run(args)
    except InputError as err:
        print(f'analyze_bag: error: {err}', file=sys.stderr)
        return err.code


if __name__ == '__main__':
    sys.exit(main())
