"""Seed 000 Fig. 6-8 (sections 3.2-3.3) of the coasting fly-by families (flyby_planner.flyby.families) and the Markdown
table of docs/relative_motion.md; scripts/paper_figures.py writes them."""

import numpy as np
from matplotlib.patches import Rectangle

from flyby_mission.report import plotting
from flyby_mission.report.plotting import plt
from flyby_planner.flyby.families import (
    SEED000_CASES,
    SEED000_CYLINDER_HALF_LENGTH_M,
    SEED000_CYLINDER_RADIUS_M,
    SEED000_SPEEDS_M_S,
)

TABLE_TIMES_S = (10.0, 60.0, 300.0)
DPI = 100
COLORS = plt.cm.viridis(np.linspace(0.0, 0.9, len(SEED000_SPEEDS_M_S)))
R_CYL = SEED000_CYLINDER_RADIUS_M
H_CYL = SEED000_CYLINDER_HALF_LENGTH_M


def _label(v):
    """A family member's legend entry: its speed v_i [m/s]."""
    return f'{v:g} m/s'


def _arrow(ax, points, i, color):
    """Arrowhead on a 2-D path at sample i, pointing along increasing time."""
    ax.annotate('', xy=points[i + 1], xytext=points[i - 1],
                arrowprops=dict(arrowstyle='-|>', color=color, mutation_scale=14, lw=0))


def fig6_inplane_xz(family, path):
    """Seed 000 Fig. 6: the in-plane family (spin +z) in the hill x-z plane about the collision region."""
    fig, ax = plt.subplots(figsize=(10, 4.6))
    ax.add_patch(Rectangle((-R_CYL, -H_CYL), 2 * R_CYL, 2 * H_CYL, color='0.75',
                           label='collision region (y = 0 section)'))
    for k, v in enumerate(SEED000_SPEEDS_M_S):
        xz = family.r_hill[k][:, [0, 2]]
        ax.plot(xz[:, 0], xz[:, 1], color=COLORS[k], label=_label(v))
        for x_mark in (-9.0, 9.0):  # one arrow on the approach, one on the escape
            i = int(np.argmin(np.abs(xz[:, 0] - x_mark)))
            _arrow(ax, xz, i, COLORS[k])
    x_t, _, z_t = SEED000_CASES['in_plane'][1]
    ax.plot(x_t, z_t, 'r*', ms=12, label='targeted point $X_i$ (t = 0)')
    ax.set(xlim=(-16, 16), ylim=(3, -8), aspect='equal', xlabel='hill x, along-track [m]',
           ylabel='hill z, toward Earth [m]',
           title='Seed 000 Fig. 6: in-plane fly-by, spin +z, $V_i$ = [$v_i$, 0, 0], t in [-300, 300] s')
    ax.grid(alpha=0.3)
    ax.legend(loc='lower right', fontsize=8, ncol=2)
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def _cylinder_surface(ax, axis_index):
    """Cylinder about hill axis axis_index (its t = 0 pose)."""
    phi, h = np.meshgrid(np.linspace(0, 2 * np.pi, 40), np.linspace(-H_CYL, H_CYL, 2))
    xyz = [R_CYL * np.cos(phi), R_CYL * np.sin(phi)]
    xyz.insert(axis_index, h)
    ax.plot_surface(*xyz, color='0.6', alpha=0.35, linewidth=0)


def _panel_3d(ax, family, axis_index, half_width_m, title):
    """The family in 3-D within half_width_m [m] of the target, about the region's cylinder."""
    _cylinder_surface(ax, axis_index)
    clip = plotting.cube_clip(half_width_m)
    for k, v in enumerate(SEED000_SPEEDS_M_S):
        ax.plot(*clip(family.r_hill[k]), color=COLORS[k], label=_label(v))
    i0 = int(np.flatnonzero(family.t_s == 0.0)[0])
    ax.plot(*family.r_hill[0, i0][:, None], 'r*', ms=10)
    plotting.cube_axes(ax, half_width_m, 5, title=title)
    ax.view_init(elev=20, azim=-60)


def _panel_axial_radial(ax, family, radial_max_m, axial_lim_m, title):
    """The escape half of each path in the cylinder's coordinates (radial, axial) [m]."""
    ax.axhspan(-H_CYL, H_CYL, color='0.92', label="the region's axial extent")
    ax.add_patch(Rectangle((0.0, -H_CYL), R_CYL, 2 * H_CYL, color='0.7', label='collision region'))
    escape = family.t_s >= 0.0  # the approach retraces it here (mirror-symmetric paths)
    for k in range(len(SEED000_SPEEDS_M_S)):
        ax.plot(family.inertial.radial_m[k, escape], family.inertial.axial_m[k, escape], color=COLORS[k], lw=2.0)
        ax.plot(family.hill_fixed.radial_m[k, escape], family.hill_fixed.axial_m[k, escape], color=COLORS[k],
                lw=1.2, dashes=(5, 3))
    ax.plot(R_CYL, -H_CYL, 'r*', ms=10, label='$X_i$')
    ax.plot([], [], 'k-', lw=2.0, label='axis fixed in inertial space')
    ax.plot([], [], 'k', lw=1.2, dashes=(5, 3), label='axis fixed in hill (paper)')
    ax.set(xlim=(0, radial_max_m), ylim=axial_lim_m, xlabel='distance from spin axis [m]',
           ylabel='position along spin axis [m]', title=title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc='lower right')


def _panel_distance(ax, family, title):
    """The signed distance [m] of each path to the region against time from the targeted point."""
    away = family.t_s != 0.0
    for k, v in enumerate(SEED000_SPEEDS_M_S):
        ax.semilogy(family.t_s[away], family.inertial.distance_m[k, away], color=COLORS[k], label=_label(v))
        ax.semilogy(family.t_s[away], family.hill_fixed.distance_m[k, away], color=COLORS[k], lw=1.2, dashes=(5, 3))
    ax.axvline(0.0, color='r', lw=0.8)
    ax.set(ylim=(1e-3, 1e3), xlabel='time from the targeted point t [s] (< 0 approach, > 0 escape)',
           ylabel='signed distance to the region [m]', title=title)
    ax.grid(alpha=0.3, which='both')
    ax.legend(fontsize=8, ncol=2, loc='lower right')


def fig_region(family, axis_index, axial_lim_m, title, path):
    """Seed 000 Fig. 7 or 8: a family about the cylinder along hill axis axis_index, in 3-D, in the cylinder's
    coordinates and as the signed distance to the region, the axis fixed in inertial space and in hill."""
    fig = plt.figure(figsize=(17, 5.2))
    _panel_3d(fig.add_subplot(1, 3, 1, projection='3d'), family, axis_index, 10.0, f'{title}: paths |x|,|y|,|z| < 10 m')
    _panel_axial_radial(fig.add_subplot(1, 3, 2), family, 20.0, axial_lim_m,
                        'paths in the cylinder coordinates (approach = escape)')
    _panel_distance(fig.add_subplot(1, 3, 3), family, 'signed distance to the region (dashed: axis fixed in hill)')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def markdown_table(families):
    """Min and sampled signed distance and axial gap per speed, as 'inertial axis / axis fixed in hill'."""
    head = ['family', 'v_i [m/s]', 'min d [m] (at t [s])']
    head += [f'd at ±{t:g} s [m]' for t in TABLE_TIMES_S]
    head += [f'axial gap at ±{t:g} s [m]' for t in TABLE_TIMES_S[1:]]
    lines = ['| ' + ' | '.join(head) + ' |', '|' + '---|' * len(head)]
    for case, family in families.items():
        idx = [int(np.flatnonzero(family.t_s == t)[0]) for t in TABLE_TIMES_S]
        for k, v in enumerate(SEED000_SPEEDS_M_S):
            row = [case.replace('_', '-'), f'{v:g}']
            views = (family.inertial, family.hill_fixed)
            mins = [f'{view.distance_m[k].min():.3f} ({family.t_s[np.argmin(view.distance_m[k])]:g})' for view in views]
            row.append(' / '.join(mins))
            row += [' / '.join(f'{view.distance_m[k, i]:.3f}' for view in views) for i in idx]
            row += [' / '.join(f'{view.axial_gap_m[k, i]:.3g}' for view in views) for i in idx[1:]]
            lines.append('| ' + ' | '.join(row) + ' |')
    return '\n'.join(lines)
