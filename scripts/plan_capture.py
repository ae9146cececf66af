#!/usr/bin/env python3
"""Plan a fly-by capture offline from a scenario's true initial state (seed 000 sections 4.3-4.5, 4.7).

    plan_capture.py --scenario scenarios/paper_flyby.yaml [--seed N] [--t-plan T]
                    [--plot DIR] [--plot-prefix plan_]

The chaser state is the scenario's initial one, coasted (CW, seed 000 eq 22) to the plan time T; the
target motion is the scenario's truth (flyby_planner.plan.truth_prediction). Prints the plan as JSON
on stdout: CapturePlan.to_dict() with the scenario name, the planning time and, at the top level, a
summary of the selected candidate (grasp time and point, X_Ft/V_Ft, X_Fi/V_Fi, transfer delta-v,
clearances and their margin) and the rejected candidates with their reasons.

--plot DIR writes, when a plan is found, <prefix>xz.png (the path in the hill x-z plane, like seed 000
Fig. 6 and 11), <prefix>3d.png (near the target, with the swept keep-out region, Fig. 7) and
<prefix>clearance.png (clearance from the swept region and range along the path).

Exit code: 0 plan found, 3 refused (the reason on stderr, one line), 2 bad input: an invalid or missing
scenario, or one the planner cannot take (one line on stderr).
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import plots
from flyby_msgs_py.schema import ScenarioError
from flyby_planner.plan import plan_capture, planner_config_from_scenario, truth_prediction
from flyby_sim.dynamics.orbital import cw_coast
from flyby_sim.scenario import load_scenario
from plots import plt

EXIT_PLANNED, EXIT_BAD_INPUT, EXIT_REFUSED = 0, 2, 3
# Fields of the selected candidate's to_dict() repeated at the top level of the output.
SUMMARY_KEYS = ('t_grasp_s', 'x_g_hill_m', 'v_g_hill_mps', 'x_ft_hill_m', 'v_ft_hill_mps', 't_i_s', 'x_fi_hill_m',
                'v_fi_hill_mps', 't_ti_s', 'dv_ti_hill_mps', 'dv_tf_hill_mps', 'dv_total_mps',
                'clearance_approach_m', 'clearance_escape_m', 't_sphere_entry_s')
ZOOM_HALF_WIDTH_M = 10.0
NEAR_HALF_WIDTH_M = 15.0
TERMINAL_HALF_WIDTH_M = 60.0
VIEW_ELEVATION_DEG = 25.0
VIEW_AZIMUTH_OFFSET_DEG = -60.0
DPI = 80


def chaser_state_at(scenario, t_plan_s):
    """Chaser (r_hill [m], v_hill [m/s]) at t_plan_s: the scenario's initial state coasted under CW (eq 22)."""
    state = cw_coast(scenario.chaser.initial_position_hill_m, scenario.chaser.initial_velocity_hill_mps, t_plan_s,
                     scenario.mean_motion_rad_s)
    return state[:3], state[3:]


def timed_plan(scenario, t_plan_s):
    """(CapturePlan, PlannerConfig, prediction time [s], plan_capture time [s]) from the true initial state."""
    config = planner_config_from_scenario(scenario)
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


# --------------------------------------------------------------------------------------------------
# Figures: plan fields and SweptRegion only

def _segments(plan):
    """Boolean masks of the path parts: coast, terminal transfer, fly-by approach (passive), escape."""
    t, c = plan.path_t, plan.selected
    return {'coast': t <= c.t_ti, 'terminal transfer': (t >= c.t_ti) & (t <= c.t_i),
            'fly-by approach': (t >= c.t_i) & (t <= c.t_grasp), 'fly-by escape': t >= c.t_grasp}


SEGMENT_STYLE = {'coast': dict(color='0.5', ls=':'), 'terminal transfer': dict(color='tab:purple', ls='--'),
                 'fly-by approach': dict(color='tab:blue'), 'fly-by escape': dict(color='tab:orange')}


def _points(plan):
    """Labelled hill positions to mark: chaser start, the two transfer burns, X_Ft and the grasp point."""
    c = plan.selected
    at_ti = np.array([np.interp(c.t_ti, plan.path_t, plan.path_r_hill[:, k]) for k in range(3)])
    return [('chaser start', plan.path_r_hill[0], dict(marker='s', color='k')),
            (f'burn 1 ($t_{{Ti}}$ = {c.t_ti:.0f} s)', at_ti, dict(marker='^', color='tab:purple')),
            (f'burn 2 at $X_{{Fi}}$ ($t_i$ = {c.t_i:.0f} s)', c.x_fi, dict(marker='v', color='tab:red')),
            (f'$X_{{Ft}}$ ($t_g$ = {c.t_grasp:.1f} s)', c.x_ft, dict(marker='*', color='tab:green', ms=12)),
            ('grasp point $x_g$', c.x_g, dict(marker='o', color='tab:brown'))]


def _xz_panel(ax, plan, config, half_width_m=None):
    c = plan.selected
    axis = plan.region.axis_hill(c.t_grasp, config.mean_motion_rad_s)
    plots.fill_outline_xz(ax, plots.cylinder_surfaces(plan.region, axis, samples=48), color='0.55', alpha=0.45,
                          lw=0)
    ax.plot([], [], color='0.55', alpha=0.45, lw=6, label='swept keep-out region at $t_g$')
    reach = plan.region.bounding_radius_m
    ax.plot(*(np.outer((-reach, reach), axis)[:, [0, 2]].T), color='0.3', lw=0.8, ls='-.', label='its axis at $t_g$')
    plots.sphere_xz(ax, config.restriction_sphere_radius_m, color='tab:red', ls='--',
                    label=f'restriction sphere ({config.restriction_sphere_radius_m:g} m)')
    for part, mask in _segments(plan).items():
        plots.plot_path(ax, plan.path_r_hill[mask], plots.xz, label=part, **SEGMENT_STYLE[part])
    plots.mark_points(ax, _points(plan), plots.xz, ms=8)
    if half_width_m is not None and half_width_m <= ZOOM_HALF_WIDTH_M:
        ax.annotate('', xy=(c.x_ft + 10.0 * c.v_ft)[[0, 2]], xytext=c.x_ft[[0, 2]],
                    arrowprops=dict(arrowstyle='-|>', color='tab:green'))
        ax.legend(handles=ax.plot([], [], color='tab:green', label='$V_{Ft}$ x 10 s'), fontsize=8, loc='lower left')
    ax.set_aspect('equal')
    if half_width_m is not None:
        ax.set(xlim=(-half_width_m, half_width_m), ylim=(-half_width_m, half_width_m))
    ax.invert_yaxis()  # up = -z, away from Earth
    ax.set(xlabel='hill x, along-track [m]', ylabel='hill z, toward Earth [m] (up = -z)')
    ax.grid(alpha=0.3)


def plot_xz(plan, config, path):
    fig = plt.figure(figsize=(13, 11))
    grid = fig.add_gridspec(2, 2, height_ratios=(1.0, 1.2))
    whole = fig.add_subplot(grid[0, :])
    _xz_panel(whole, plan, config)
    whole.set_title(f'Planned path in the hill x-z plane: coast, transfer, fly-by and {config.escape_check_orbits:g} '
                    'orbit of passive escape')
    whole.legend(fontsize=8, loc='center', ncol=2)
    for k, half in enumerate((TERMINAL_HALF_WIDTH_M, ZOOM_HALF_WIDTH_M)):
        ax = fig.add_subplot(grid[1, k])
        _xz_panel(ax, plan, config, half)
        ax.set_title(f'near the target, ±{half:g} m (region: silhouette in x-z)')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def plot_3d(plan, config, path):
    c, half = plan.selected, NEAR_HALF_WIDTH_M
    axis = plan.region.axis_hill(c.t_grasp, config.mean_motion_rad_s)
    fig = plt.figure(figsize=(9, 8))
    ax = fig.add_subplot(projection='3d')
    for surface in plots.cylinder_surfaces(plan.region, axis, samples=36):
        for part in (surface[1:3], surface[0:2], surface[3:1:-1]):  # side, lower cap, upper cap (centre first)
            ax.plot_surface(*np.moveaxis(part, -1, 0), color='0.55', alpha=0.35, linewidth=0)
    radius = config.restriction_sphere_radius_m
    plots.sphere_wireframe(ax, radius, 25, 13, color='tab:red', lw=0.3, alpha=0.4)
    clip = plots.cube_clip(half)
    for part, mask in _segments(plan).items():
        plots.plot_path(ax, plan.path_r_hill[mask], clip, label=part, **SEGMENT_STYLE[part])
    plots.mark_points(ax, _points(plan), clip, ms=8)
    ax.plot([], [], color='0.55', alpha=0.5, lw=6, label='swept keep-out region at $t_g$')
    ax.plot([], [], color='tab:red', lw=0.5, label=f'restriction sphere ({radius:g} m)')
    plots.cube_axes(ax, half, 7, title=f'Fly-by near the target (±{half:g} m), keep-out region about its axis at '
                                       f'$t_g$ = {c.t_grasp:.1f} s')
    ax.set_box_aspect((1, 1, 1))
    # Look obliquely along the region's axis, so the panel disks show their face and the bus its end.
    ax.view_init(elev=VIEW_ELEVATION_DEG, azim=np.degrees(np.arctan2(axis[1], axis[0])) + VIEW_AZIMUTH_OFFSET_DEG)
    ax.legend(fontsize=8, loc='upper left')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def plot_clearance(plan, config, path):
    c, n = plan.selected, config.mean_motion_rad_s
    passive = plan.path_t >= c.t_i
    t = plan.path_t[passive]
    gap = plan.region.clearance(plan.path_r_hill[passive], t, n, config.envelope_radius_m)
    fig, (ax_all, ax_near, ax_range) = plt.subplots(3, 1, figsize=(10, 10))
    near = np.abs(t - c.t_grasp) <= 60.0
    for ax, mask, title in ((ax_all, slice(None), 'passive fly-by and escape'),
                            (ax_near, near, '±60 s about the grasp')):
        ax.plot(t[mask], gap[mask], color='tab:blue', label='clearance of the chaser envelope from the swept region')
        ax.axhline(config.clearance_margin_m, color='tab:red', ls='--', label=f'margin {config.clearance_margin_m:g} m')
        ax.axvline(c.t_grasp, color='tab:green', lw=0.8, label=f'grasp $t_g$ = {c.t_grasp:.1f} s')
        ax.set(ylabel='clearance [m]', title=f'Clearance, {title} (least: approach {c.clearance_approach_m:.3f} m, '
                                             f'escape {c.clearance_escape_m:.3f} m)')
        ax.grid(alpha=0.3, which='both')
    ax_all.set_yscale('symlog', linthresh=0.1)  # linear through the margin, logarithmic far out
    for ax in (ax_all, ax_near):
        ax.set_ylim(bottom=min(0.0, float(gap.min())))
    ax_all.legend(fontsize=8, loc='lower right')
    ax_range.semilogy(plan.path_t, np.linalg.norm(plan.path_r_hill, axis=1), color='k', label='range |r|')
    ax_range.axhline(config.restriction_sphere_radius_m, color='tab:red', ls='--',
                     label=f'restriction sphere {config.restriction_sphere_radius_m:g} m')
    for t_mark, label, color in ((c.t_ti, 'burn 1 $t_{Ti}$', 'tab:purple'), (c.t_i, 'burn 2 $t_i$', 'tab:red'),
                                 (c.t_grasp, 'grasp $t_g$', 'tab:green')):
        ax_range.axvline(t_mark, color=color, lw=0.8, label=label)
    ax_range.set(xlabel='sim time t [s]', ylabel='range [m]', title='Range from the target centre of mass')
    ax_range.grid(alpha=0.3, which='both')
    ax_range.legend(fontsize=8, loc='lower right')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def write_plots(plan, config, out_dir, prefix):
    """The three PNGs of --plot: <prefix>xz.png, <prefix>3d.png, <prefix>clearance.png in out_dir."""
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, plot in (('xz', plot_xz), ('3d', plot_3d), ('clearance', plot_clearance)):
        plot(plan, config, out_dir / f'{prefix}{name}.png')


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--scenario', required=True, help='scenario YAML file')
    ap.add_argument('--seed', type=int, help="override the scenario's seed (recorded; the plan uses the truth)")
    ap.add_argument('--t-plan', type=float, default=0.0, metavar='T', help='plan time [s], >= 0 (default 0)')
    ap.add_argument('--plot', type=Path, metavar='DIR', help='write the figures into DIR')
    ap.add_argument('--plot-prefix', default='plan_', help='figure file name prefix (default plan_)')
    args = ap.parse_args(argv)
    if not (math.isfinite(args.t_plan) and args.t_plan >= 0.0):
        print(f'error: --t-plan: must be finite and >= 0 s, got {args.t_plan}', file=sys.stderr)
        return EXIT_BAD_INPUT
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
