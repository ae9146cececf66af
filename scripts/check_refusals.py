#!/usr/bin/env python3
"""Is a campaign's NO_SAFE_PLAN right? Re-fly each refused run to its plan time and check every fly-by.

    check_refusals.py CAMPAIGN_DIR [--runs 12,19,40-45] [--out FILE.jsonl]

For each run (default: every NO_SAFE_PLAN row of CAMPAIGN_DIR/results.csv) the run's scenario.yaml is flown
headless up to the planner's first plan, and at that plan time, from the same estimates and covariance,
flyby_planner.flyby.diagnostics.exhaustive_check tries every grasp instant of the grasp and extended windows, every
offset and every fly-by duration for passive clearance and the predicted 3-sigma miss. One JSON line per run
(the RefusalCheck's fields, the run, the plan time and the class of refusal the row gives), and a table of
the classes. A refusal is shown to hold no safe and capturable fly-by of seed 000's form when n_both is 0:
no offset clears the target (offsets_clear 0), no grasp instant passes (a)-(c) and eq 15, or no candidate is
both clear and within the manipulator's tolerance (docs/campaigns.md).
"""

import collections
import csv
import dataclasses
import json
import sys
from pathlib import Path

from flyby_mission import cli
from flyby_mission.campaign.report import refusal_class
from flyby_mission.campaign.runner import run_indices
from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_planner.flyby.diagnostics import exhaustive_check
from flyby_planner.methods import FlybyMethod
from flyby_planner.params import PlannerParams
from flyby_planner.planner_core import PlannerCore
from flyby_sim.scenario import load_scenario


class _PlanTime(BaseException):  # not an Exception: the headless core guard does not take it for a fault
    """Stops the flight at the planner's first plan, with what it would plan from."""

    def __init__(self, t, chaser_now, prediction, covariance_body):
        super().__init__(t)
        self.t, self.chaser_now, self.prediction = t, chaser_now, prediction
        self.covariance_body = covariance_body


class _StopAtPlan(FlybyMethod):
    def plan(self, core, t, q_hill_from_body, omega_body, why, covariance_body, reason):
        raise _PlanTime(t, *core.plan_inputs(t, q_hill_from_body, omega_body, extended=True), covariance_body)


def check_run(scenario):
    """The RefusalCheck at the run's first plan time, and that time (None, None: it never planned)."""
    graph = HeadlessGraph(scenario)
    graph.planner = PlannerCore(PlannerParams.from_scenario(scenario))
    graph.planner.methods['flyby'] = _StopAtPlan()
    try:
        run_headless(scenario, graph=graph)
    except _PlanTime as at:
        return exhaustive_check(at.prediction, at.chaser_now[:3], at.chaser_now[3:], at.t, graph.planner.params.flyby,
                                at.covariance_body), at.t
    return None, None


def main():
    ap = cli.OneLineParser(description=__doc__.split('\n')[0])
    ap.add_argument('campaign_dir', type=Path)
    ap.add_argument('--runs', help='run indices (default: every NO_SAFE_PLAN row)')
    ap.add_argument('--out', type=Path, help='JSON lines, one per run')
    args = ap.parse_args()
    if not (args.campaign_dir / 'results.csv').is_file():
        ap.error(f'campaign_dir {args.campaign_dir}: holds no results.csv (not a campaign directory)')
    try:
        picked = run_indices(args.runs) if args.runs else None
    except ValueError:
        ap.error(f"--runs {args.runs}: expected run indices like '0-19', '0,3,10' or '0-4,8'")
    with open(args.campaign_dir / 'results.csv', newline='') as f:
        rows = {int(r['run']): r for r in csv.DictReader(f)}
    runs = picked if picked is not None else sorted(i for i, r in rows.items() if r['outcome'] == 'NO_SAFE_PLAN')
    out = open(args.out, 'w') if args.out else None
    by_class = collections.defaultdict(lambda: [0, 0])
    for i in runs:
        check, t_plan = check_run(load_scenario(args.campaign_dir / 'runs' / str(i) / 'scenario.yaml'))
        row = rows.get(i, {})
        cls = refusal_class(row.get('end_reason', '')) if row.get('outcome') == 'NO_SAFE_PLAN' else row.get('outcome')
        rec = {'run': i, 'class': cls, 't_plan_s': t_plan, **(dataclasses.asdict(check) if check else {})}
        if out:
            out.write(json.dumps(rec) + '\n')
            out.flush()
        by_class[cls][0] += 1
        by_class[cls][1] += bool(check and check.n_both)
        print(json.dumps(rec), flush=True)
    print(f'{"class":60s} runs  with a clear and capturable candidate', file=sys.stderr)
    for cls, (n, found) in sorted(by_class.items(), key=lambda kv: -kv[1][0]):
        print(f'{cls:60s} {n:4d}  {found}', file=sys.stderr)


if __name__ == '__main__':
    main()
