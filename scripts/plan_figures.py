"""The figures of scripts/plan_capture.py --plot, from a CapturePlan's fields and its SweptRegion only.

<prefix>xz.png: the path in the hill x-z plane (seed 000 Fig. 6 and 11); <prefix>3d.png: near the target, with
the swept keep-out region (Fig. 7); <prefix>clearance.png: clearance from the swept region and range along the path.
"""

import numpy as np

from flyby_mission.report import plotting as plots
from flyby_mission.report.plotting import plt

ZOOM_HALF_WIDTH_M = 10.0
NEAR_HALF_WIDTH_M = 15.0
TERMINAL_HALF_WIDTH_M = 60.0
VIEW_ELEVATION_DEG = 25.0
VIEW_AZIMUTH_OFFSET_DEG = -60.0
DPI = 80


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
