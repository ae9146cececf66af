#!/usr/bin/env python3
"""Plan a fly-by capture offline from a scenario's true initial state (seed 000 sections 4.3-4.5, 4.7).

    plan_capture.py --scenario scenarios/paper_flyby.yaml [--seed N] [--t-plan T]
                    [--plot DIR] [--plot-prefix plan_]

The chaser state is the scenario's initial one, coasted (CW, seed 000 eq 22) to the plan time T; the
target motion is the scenario's truth (flyby_planner.flyby.config.truth_prediction). Prints the plan as JSON
on stdout: CapturePlan.to_dict() with the scenario name, the planning time and, at the top level, a
summary of the selected candidate (grasp time and point, X_Ft/V_Ft, X_Fi/V_Fi, transfer delta-v,
clearances and their margin) and the rejected candidates with their reasons.

--plot DIR writes, when a plan is found, <prefix>xz.png (the path in the hill x-z plane, like seed 000
Fig. 6 and 11), <prefix>3d.png (near the target, with the swept keep-out region, Fig. 7) and
<prefix>clearance.png (clearance from the swept region and range along the path).

Exit code: 0 plan found, 3 refused (the reason on stderr, one line), 2 bad input: an invalid or missing
scenario, or one the planner cannot take (one line on stderr).
"""

import json
import sys
import time
from pathlib import Path

from plan_figures import write_plots

from flyby_mission import cli
from flyby_msgs_py.schema import ScenarioError
from flyby_planner.flyby.config import PlannerConfig, truth_prediction
from flyby_planner.flyby.search import plan_capture
from flyby_sim.dynamics.orbital import cw_coast
from flyby_sim.scenario import load_scenario

EXIT_PLANNED, EXIT_BAD_INPUT, EXIT_REFUSED = 0, 2, 3
# Fields of the selected candidate's to_dict() repeated at the top level of the output.
SUMMARY_KEYS = ('t_grasp_s', 'x_g_hill_m', 'v_g_hill_mps', 'x_ft_hill_m', 'v_ft_hill_mps', 't_i_s', 'x_fi_hill_m',
                'v_fi_hill_mps', 't_ti_s', 'dv_ti_hill_mps', 'dv_tf_hill_mps', 'dv_total_mps',
                'clearance_approach_m', 'clearance_escape_m', 't_sphere_entry_s')


def chaser_state_at(scenario, t_plan_s):
    """Chaser (r_hill [m], v_hill [m/s]) at t_plan_s: the scenario's initial state coasted under CW (eq 22)."""
    state = cw_coast(scenario.chaser.initial_position_hill_m, scenario.chaser.initial_velocity_hill_mps, t_plan_s,
                     scenario.mean_motion_rad_s)
    return state[:3], state[3:]


def timed_plan(scenario, t_plan_s):
    """(CapturePlan, PlannerConfig, prediction time [s], plan_capture time [s]) from the true initial state."""
    config = PlannerConfig.from_scenario(scenario)
    r_hill, v_hill = chaser_state_at(scenario, t_plan_s)
    t0 = time.perf_counter()
    prediction = truth_prediction(scenario, t_plan_s + config.prediction_span_s(scenario.omega_body0_rad_s))
    t1 = time.perf_counter()
    plan = plan_capture(prediction, r_hill, v_hill, t_plan_s, config)
    return plan, config, t1 - t0, time.perf_counter() - t1


def plan_report(scenario, plan, config, prediction_s, plan_s):
    """The JSON document: scenario, timing, the summary fields, then CapturePlan.to_dict()."""
    full = plan.to_dict()
    selected = full['selected'] or {}
    return {
        'scenario': scenario.name, 'seed': scenario.seed,
        'planning_time_ms': round(1e3 * (prediction_s + plan_s), 3),
        'prediction_time_ms': round(1e3 * prediction_s, 3),
        'ok': full['ok'], 'reason': full['reason'],
        **{key: selected.get(key) for key in SUMMARY_KEYS},
        'clearance_margin_m': config.clearance_margin_m,
        'restriction_sphere_radius_m': config.restriction_sphere_radius_m,
        'rejected': [{'t_grasp_s': c['t_grasp_s'], 'reasons': c['reasons']}
                     for c in full['candidates'] if c['status'] == 'rejected'],
        **full,
    }


def main(argv=None):
    ap = cli.OneLineParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--scenario', required=True, help='scenario YAML file')
    ap.add_argument('--seed', type=cli.seed,
                    help="override the scenario's seed (recorded; the plan uses the truth)")
    ap.add_argument('--t-plan', type=cli.float_at_least(0), default=0.0, metavar='T',
                    help='plan time [s], >= 0 (default 0)')
    ap.add_argument('--plot', type=Path, metavar='DIR', help='write the figures into DIR')
    ap.add_argument('--plot-prefix', default='plan_', help='figure file name prefix (default plan_)')
    args = ap.parse_args(argv)
    if args.plot is not None and args.plot.exists() and not args.plot.is_dir():
        ap.error(f'--plot {args.plot}: exists and is not a directory')
    try:
        scenario = load_scenario(args.scenario, seed=args.seed)
    except ScenarioError as err:  # a missing file included
        print(f'error: {err}', file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        plan, config, prediction_s, plan_s = timed_plan(scenario, args.t_plan)
    except ValueError as err:  # inputs the planner cannot take, e.g. a target without angular momentum
        print(f'error: {args.scenario}: cannot plan: {err}', file=sys.stderr)
        return EXIT_BAD_INPUT
    print(json.dumps(plan_report(scenario, plan, config, prediction_s, plan_s), indent=1))
    if not plan.ok:
        print(f'refused: {plan.reason}', file=sys.stderr)
        return EXIT_REFUSED
    if args.plot is not None:
        write_plots(plan, config, args.plot, args.plot_prefix)
    return EXIT_PLANNED


if __name__ == '__main__':
    sys.exit(main())
