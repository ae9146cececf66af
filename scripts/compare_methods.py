#!/usr/bin/env python3
"""Seed 003 Table 2 and Fig 14 measured: the fly-by and the optimization-based approach flown on the same case.

    compare_methods.py [--scenario scenarios/paper_flyby_6dof.yaml] [--figure PNG]

Flies the scenario headless (the graph's cores and rules, flyby_mission.headless) once with each
``planner.method`` (flyby, optimal), same seed and everything else equal, and prints a Markdown table of what
Table 2 compares in words, from truth: outcome and capture errors, approach time (the approach phase's start to
the grasp), delta-v (net force) and fuel (every thruster's impulse), peak thrust acceleration (the mean over a
simulation step: a fly-by burn is shorter than a step, so its own peak is higher), least clearance
to the real geometry, thrust inside the restriction sphere and the plume rule's figure (thrust away from the
target within the plume radius, N s), pointing, and the planning wall time. It draws Fig 14's analogue, both
paths in the hill x-z and x-y planes about the target from the approach's start to the grasp, and their range
and thrust acceleration against the time to the grasp, into --figure: by default
runs/compare_methods/seed003_fig14_methods.png under the working directory (a run's output, never a tracked file
unless named: docs/figures/seed003_fig14_methods.png is regenerated with --figure).
"""

import sys
from pathlib import Path

import numpy as np

from flyby_mission import cli
from flyby_mission.campaign.dispersions import set_values
from flyby_mission.headless import HeadlessGraph, require_one_chaser, run_headless
from flyby_mission.report import plotting as plots
from flyby_msgs_py import contract as c
from flyby_msgs_py import events
from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_yaml_mapping, scenario_from_dict

ROOT = Path(__file__).resolve().parents[1]
METHODS = ('flyby', 'optimal')
DEFAULT_FIGURE = Path('runs') / 'compare_methods' / 'seed003_fig14_methods.png'
APPROACH = {'flyby': c.PHASE_TERMINAL_APPROACH, 'optimal': c.PHASE_OPTIMAL_APPROACH}


def fly(scenario_path, method):
    """(summary, chaser truth, thrust truth, approach start [s]) of the scenario flown with ``method``."""
    data = load_yaml_mapping(scenario_path)
    set_values(data, {'planner.method': method})
    scenario = scenario_from_dict(data, name=f'{scenario_path} (planner.method {method})', path=scenario_path)
    require_one_chaser(scenario)
    graph = HeadlessGraph(scenario)
    run = run_headless(scenario, graph)
    chaser, _target, thrust, _wheels = graph.truth.series()
    starts = [e['t'] for e in run.events
              if e['name'] == events.PHASE_CHANGED and e['values'].get('to') == APPROACH[method]]
    return run.summary, chaser, thrust, (starts[0] if starts else None), scenario


def table(results):
    """The Markdown table of the runs {method: (summary, chaser, thrust, t_start, scenario)}."""
    def approach_time(r):
        summary, _chaser, _thrust, t_start, _sc = r
        return None if t_start is None or summary['t_grasp_s'] is None else summary['t_grasp_s'] - t_start

    rows = [('outcome', lambda r: r[0]['outcome'], '{}'),
            ('capture position error [cm]', lambda r: _scaled(r[0]['capture_position_error_m'], 100), '{:.2f}'),
            ('capture velocity error [mm/s]', lambda r: _scaled(r[0]['capture_velocity_error_mps'], 1000), '{:.2f}'),
            ('approach time, approach phase to grasp [s]', approach_time, '{:.1f}'),
            ('delta-v, net force [m/s]', lambda r: r[0]['delta_v_total_mps'], '{:.3f}'),
            ('fuel, every thruster [kg]', lambda r: r[0]['fuel_used_kg'], '{:.4f}'),
            ('peak thrust acceleration, mean over a step [m/s²]', lambda r: r[0]['peak_acceleration_mps2'], '{:.3f}'),
            ('least clearance to the real geometry [m]', lambda r: r[0]['min_clearance_m'], '{:.3f}'),
            ('thrust inside the restriction sphere', lambda r: r[0]['thrust_inside_restriction_sphere'], '{}'),
            ('plume: thrust away from the target within the plume radius [N s]',
             lambda r: r[0].get('plume_impulse_away_n_s'), '{:.4f}'),
            ('pointing error p95 [deg]', lambda r: r[0].get('pointing_error_p95_deg'), '{:.2f}'),
            ('planning, wall [s]', lambda r: r[0].get('planning_time_s'), '{:.2f}')]
    lines = ['| | ' + ' | '.join(results) + ' |', '|---|' + '---|' * len(results)]
    for label, value, fmt in rows:
        cells = []
        for r in results.values():
            v = value(r)
            cells.append('-' if v is None else fmt.format(v))
        lines.append(f'| {label} | ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines)


def _scaled(x, k):
    return None if x is None else x * k


def figure(results, path):
    """Fig 14's analogue: both paths (hill x-z, x-y) and range and thrust acceleration against time to grasp."""
    fig, axes = plots.plt.subplots(2, 2, figsize=(11, 9))
    styles = {'flyby': dict(color='tab:blue'), 'optimal': dict(color='tab:red')}
    for method, (summary, chaser, thrust, t_start, scenario) in results.items():
        if t_start is None or summary['t_grasp_s'] is None:
            continue
        t_g = summary['t_grasp_s']
        keep = (chaser.t >= t_start) & (chaser.t <= t_g)
        r = chaser.position[keep]
        label = f'{method}: {summary["outcome"]}, {summary["delta_v_total_mps"]:.2f} m/s'
        for ax, (i, j) in zip(axes[0], ((0, 2), (0, 1)), strict=True):
            ax.plot(r[:, i], r[:, j], label=label, **styles[method])
            ax.plot(r[-1, i], r[-1, j], 'o', **styles[method])
        axes[1, 0].plot(chaser.t[keep] - t_g, np.linalg.norm(r, axis=1), label=method, **styles[method])
        on = (thrust.t >= t_start) & (thrust.t <= t_g)
        axes[1, 1].plot(thrust.t[on] - t_g, np.linalg.norm(thrust.force[on], axis=1) / scenario.chaser.mass_kg,
                        label=method, **styles[method])
    sphere = next(iter(results.values()))[4].planner.restriction_sphere_radius_m
    for ax, (xl, yl) in zip(axes[0], (('hill x [m]', 'hill z, toward Earth [m]'), ('hill x [m]', 'hill y [m]')),
                            strict=True):
        plots.sphere_xz(ax, sphere, color='0.6', ls='--')
        ax.plot(0.0, 0.0, 'k+')
        ax.set(xlabel=xl, ylabel=yl, aspect='equal')
        ax.legend(fontsize=8)
    axes[0, 0].invert_yaxis()
    axes[0, 0].set_title('paths from the approach phase to the grasp (dashed: restriction sphere)')
    axes[1, 0].set(xlabel='time to the grasp [s]', ylabel='range to the target CoM [m]', yscale='log')
    axes[1, 1].set(xlabel='time to the grasp [s]', ylabel='thrust acceleration, mean over a step [m/s²]')
    for ax in axes[1]:
        ax.legend(fontsize=8)
    fig.tight_layout()
    plots.save(fig, path, 110)


def main():
    ap = cli.OneLineParser(description=__doc__.split('\n')[0])
    ap.add_argument('--scenario', default=str(ROOT / 'scenarios' / 'paper_flyby_6dof.yaml'))
    ap.add_argument('--figure', type=Path, default=DEFAULT_FIGURE,
                    help='write Fig 14 analogue here (PNG; default %(default)s, under the working directory)')
    args = ap.parse_args()
    if args.figure.is_dir():
        ap.error(f'--figure {args.figure}: is a directory (give a .png file)')
    if args.figure != DEFAULT_FIGURE and not args.figure.parent.is_dir():
        ap.error(f'--figure {args.figure}: its directory does not exist')
    try:
        results = {m: fly(args.scenario, m) for m in METHODS}
    except ScenarioError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    print(table(results))
    args.figure.parent.mkdir(parents=True, exist_ok=True)
    figure(results, args.figure)
    print(f'figure: {args.figure}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
