"""The figures of every single-chaser run: its path in the hill x-z plane (seed 000 Fig. 11) and in 3-D, range and
range rate, each burn commanded against executed, the estimation errors and the clearance to the target (the
catalogue: flyby_mission.report)."""

import math

import numpy as np

from flyby_mission.report import plotting
from flyby_mission.report.analysis import clearances, estimation_errors, range_and_rate
from flyby_mission.report.drawing import (
    DPI,
    ESTIMATE,
    TRUTH,
    burn_lines,
    error_row,
    flown_limits_xz,
    grasp_line,
    paths_and_points,
    phase_bands,
    target_xz,
)
from flyby_mission.report.loading import Skipped, say
from flyby_mission.report.plotting import plt
from flyby_msgs_py import contract as c


def trajectory_xz_figure(run):
    """The figure of trajectory_xz.png: the flown path (drawing.flown_limits_xz) and within 10 m of the target."""
    run.need(c.SIM_CHASER_ODOM)
    fig, axes = plt.subplots(1, 2, figsize=(16, 7.5))
    for ax, zoom in zip(axes, (None, 10.0), strict=True):
        target_xz(ax, run)
        paths_and_points(ax, run, plotting.xz)
        ax.set(aspect='equal', xlabel='hill x, along-track [m]', ylabel='hill z, toward Earth [m] (up: away)')
        ax.grid(alpha=0.3)
        if zoom is not None:
            ax.set(xlim=(-zoom, zoom), ylim=(zoom, -zoom), title=f'within {zoom:g} m of the target')
        else:
            x_lim, z_lim = flown_limits_xz(run)
            ax.set(xlim=x_lim, ylim=z_lim, title='the flown path in the hill x-z plane')
    fig.legend(*axes[0].get_legend_handles_labels(), loc='center right', fontsize=9)
    fig.suptitle(run.title)
    fig.tight_layout(rect=(0, 0, 0.76, 1))
    return fig


def fig_trajectory_xz(run, path):
    """trajectory_xz.png (the catalogue: flyby_mission.report)."""
    plotting.save(trajectory_xz_figure(run), path, DPI)


def _oblique_view(axis, elev=25.0, off_axis_deg=55.0):
    """(elev, azim) [deg]: the camera azimuth, nearest matplotlib's default -60 deg, that sees the
    region's axis about off_axis_deg from the line of sight, so its discs show as ellipses rather
    than edge-on or face-on (the z axis is drawn inverted: display up is -z)."""
    a = np.array((axis[0], axis[1], -axis[2]))
    azims = np.arange(-180.0, 180.0, 5.0)
    e, z = math.radians(elev), np.radians(azims)
    sight = np.stack((np.cos(e) * np.cos(z), np.cos(e) * np.sin(z), np.full_like(z, math.sin(e))), axis=1)
    off_axis = np.degrees(np.arccos(np.clip(np.abs(sight @ a), 0.0, 1.0)))
    from_default = np.abs((azims + 60.0 + 180.0) % 360.0 - 180.0)
    return elev, float(azims[np.argmin(np.abs(off_axis - off_axis_deg) + 0.1 * from_default)])


def fig_trajectory_3d(run, path, half_width_m=20.0):
    """trajectory_3d.png: the path within half_width_m [m] of the target in 3-D."""
    run.need(c.SIM_CHASER_ODOM)
    fig = plt.figure(figsize=(10, 9.5))
    ax = fig.add_axes((0.0, 0.1, 1.0, 0.85), projection='3d')
    t_r, label = run.region_time
    elev, azim = 22.0, -55.0
    if run.region is not None:
        axis = run.region.axis_hill(t_r, run.scenario.mean_motion_rad_s)
        elev, azim = _oblique_view(axis)
        for surface in plotting.cylinder_surfaces(run.region, axis):
            ax.plot_surface(*np.moveaxis(surface, -1, 0), color='0.5', alpha=0.3, lw=0)
        ax.plot([], [], color='0.55', lw=6, alpha=0.5, label=f'swept keep-out region ({label}, t = {t_r:.0f} s)')
    if run.scenario is not None:
        radius = run.scenario.planner.restriction_sphere_radius_m
        plotting.sphere_wireframe(ax, radius, 19, 10, color='0.6', lw=0.3, alpha=0.5,
                                  label=f'restriction sphere {radius:g} m')
    paths_and_points(ax, run, plotting.cube_clip(half_width_m))
    plotting.cube_axes(ax, half_width_m, 5,
                       labels=('hill x, along-track [m]', 'hill y, anti-normal [m]', 'hill z, toward Earth [m]'))
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=elev, azim=azim)
    fig.legend(*ax.get_legend_handles_labels(), loc='lower center', ncol=3, fontsize=9)
    fig.suptitle(f'{run.title}: within {half_width_m:g} m of the target (what lies beyond is left out)')
    plotting.save(fig, path, DPI)


def fig_range(run, path):
    """range.png: range and range rate, truth and estimate."""
    truth = run.need(c.SIM_CHASER_ODOM)
    estimate = run.get(c.EST_CHASER_ODOM)
    curves = [(truth.t, range_and_rate(truth), dict(color=TRUTH, lw=1.3, label='truth'))]
    if estimate is not None:
        curves.append((estimate.t, range_and_rate(estimate), dict(color=ESTIMATE, lw=1.1, ls='--',
                                                                     label='estimate')))
    fig, (ax_r, ax_v) = plt.subplots(2, 1, figsize=(13, 8), sharex=True)
    for ax, k, unit in ((ax_r, 0, 'range |r| [m]'), (ax_v, 1, 'range rate [m/s]')):
        phase_bands(ax, run, legend=ax is ax_r)
        burn_lines(ax, run, labels=ax is ax_r)
        for t, values, style in curves:
            ax.plot(t, values[k], **style)
        ax.set_ylabel(unit)
        ax.grid(alpha=0.3, which='both')
    ax_r.set_yscale('log')
    if run.scenario is not None:
        ax_r.axhline(run.scenario.planner.restriction_sphere_radius_m, color='0.4', ls=':', lw=0.9,
                     label='restriction sphere')
    for ax in (ax_r, ax_v):
        grasp_line(ax, run, legend=ax is ax_r)
    ax_v.axhline(0.0, color='k', lw=0.6)
    ax_v.set(xlabel='simulation time [s]', xlim=(0.0, run.t_end))
    ax_r.legend(fontsize=8, ncol=3, loc='lower left', framealpha=0.9)
    ax_v.legend(fontsize=8, loc='lower left')
    fig.suptitle(f'{run.title}: range to the target (vertical lines: burn starts)')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def fig_maneuvers(run, path):
    """maneuvers.png: each executed burn's delta-v, commanded against executed."""
    burns = run.burns
    if not burns:
        raise Skipped('no executed burn (burn_started event)')
    idx = np.arange(len(burns))
    mm = 1e3  # m/s -> mm/s
    nan3 = np.full(3, np.nan)
    cmd = np.array([b.dv_cmd_hill if b.dv_cmd_hill is not None else nan3 for b in burns]) * mm
    exe = np.array([b.dv_hill if b.dv_hill is not None else nan3 for b in burns]) * mm
    fig, (ax_c, ax_m, ax_e) = plt.subplots(3, 1, figsize=(13, 10), sharex=True,
                                           gridspec_kw=dict(height_ratios=(1.4, 1, 0.8)))
    width = 0.13
    for k, axis in enumerate('xyz'):
        color = f'C{k}'
        ax_c.bar(idx + (2 * k - 2.5) * width, cmd[:, k], width, color=color, alpha=0.35, edgecolor=color,
                 hatch='//', label=f'{axis} commanded')
        ax_c.bar(idx + (2 * k - 1.5) * width, exe[:, k], width, color=color, label=f'{axis} executed')
    linthresh = 0.01  # mm/s: well below any burn a thruster can make (0.1 mm/s for the paper's chaser)
    ax_c.set_yscale('symlog', linthresh=linthresh)
    ax_c.axhline(0.0, color='k', lw=0.6)
    ax_c.set_ylabel(f'delta-v hill component [mm/s]\n(symlog, linear below {linthresh:.2g})')
    ax_c.legend(fontsize=8, ncol=3)

    mag_cmd, mag_exe = np.linalg.norm(cmd, axis=1), np.linalg.norm(exe, axis=1)
    ax_m.bar(idx - 0.15, mag_cmd, 0.3, color='0.7', hatch='//', edgecolor='0.4', label='commanded |dv|')
    ax_m.bar(idx + 0.15, mag_exe, 0.3, color='C3', label='executed |dv|')
    for i, m in enumerate(mag_exe):
        if np.isfinite(m):
            ax_m.text(i + 0.15, m, f'{m:.3g}', ha='center', va='bottom', fontsize=7)
    ax_m.set(yscale='log', ylabel='|delta-v| [mm/s]')
    ax_m.legend(fontsize=8)

    magnitude_error = np.abs(mag_exe - mag_cmd) / mag_cmd * 100.0
    vector_error = np.linalg.norm(exe - cmd, axis=1) / mag_cmd * 100.0
    pointing_error = np.degrees(np.arccos(np.clip(np.sum(exe * cmd, axis=1) / (mag_exe * mag_cmd), -1.0, 1.0)))
    ax_e.bar(idx - 0.15, magnitude_error, 0.3, color='C4', label='magnitude error [%]')
    ax_e.bar(idx + 0.15, vector_error, 0.3, color='C5', label='|dv_exec - dv_cmd| / |dv_cmd| [%]')
    ax_e2 = ax_e.twinx()
    ax_e2.plot(idx, pointing_error, 'kd', ms=5, label='pointing error [deg]')
    ax_e2.set_ylabel('pointing error [deg]')
    for ax in (ax_e, ax_e2):  # headroom for the legend
        ax.set_ylim(0.0, 1.4 * ax.get_ylim()[1])
    ax_e.set_ylabel('execution error [%]')
    handles = ax_e.get_legend_handles_labels()[0] + ax_e2.get_legend_handles_labels()[0]
    ax_e.legend(handles=handles, fontsize=8, ncol=3, loc='upper left')
    ax_e.set_xticks(idx, [f'{b.kind}\nt = {b.t_start:.1f} s' for b in burns], fontsize=8)
    ax_e.set_xlabel('executed burns in order (kind, start time)')
    for ax in (ax_c, ax_m, ax_e):
        ax.grid(alpha=0.3, axis='y', which='both')
    fig.suptitle(f'{run.title}: {len(burns)} executed burns, commanded (hatched) against executed')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def fig_estimation(run, path):
    """estimation.png: the rows of estimation_errors, a row the run has no data for said so."""
    rows = estimation_errors(run)
    if all(len(r) == 2 for r in rows):
        raise Skipped('; '.join(dict.fromkeys(r[1] for r in rows)))
    fig, axes = plt.subplots(len(rows), 3, figsize=(15, 12), sharex=True)
    for row, ax_row in zip(rows, axes, strict=True):
        if len(row) == 2:
            say(f'estimation.png: {row[0]} left out: {row[1]}')
            for ax in ax_row:
                ax.text(0.5, 0.5, row[1], transform=ax.transAxes, ha='center', fontsize=8)
            ax_row[0].set_ylabel(row[0])
            continue
        error_row(ax_row, run, *row)
    for ax in axes[-1]:
        ax.set_xlabel('simulation time [s]')
    handles = next((ax.get_legend_handles_labels() for ax in axes[:, 0] if ax.get_legend_handles_labels()[0]),
                   None)
    if handles:
        fig.legend(*handles, loc='upper right', fontsize=8, ncol=3)
    fig.suptitle(f'{run.title}: estimation errors')
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    plotting.save(fig, path, DPI)


def fig_clearance(run, path, window_s=30.0):
    """clearance.png: the clearances over the run and within window_s [s] of the closest one."""
    t, actual, swept = clearances(run)
    k = int(np.argmin(actual))
    fig, (ax_all, ax_zoom) = plt.subplots(2, 1, figsize=(13, 9))
    zoom = np.abs(t - t[k]) <= window_s
    for ax, keep in ((ax_all, slice(None)), (ax_zoom, zoom)):
        ax.plot(t[keep], actual[keep], color=TRUTH, lw=1.3, label="to the target's boxes (truth attitude)")
        if swept is not None:
            ax.plot(t[keep], swept[keep], color='C2', lw=1.1, ls='--', label='to the swept keep-out region')
        ax.axhline(0.0, color='r', lw=1.0, label='contact')
        ax.plot(t[k], actual[k], 'rv', ms=8, label=f'closest: {actual[k]:.3f} m at t = {t[k]:.2f} s')
        t_g, label = run.grasp
        if t_g is not None and t[keep][0] <= t_g <= t[keep][-1]:
            ax.axvline(t_g, color='darkred', ls='-.', lw=0.9, label=label)
        ax.grid(alpha=0.3, which='both')
        ax.set_ylabel('envelope clearance [m]')
    phase_bands(ax_all, run)
    phase_bands(ax_zoom, run, legend=False)
    ax_all.set_yscale('symlog', linthresh=1.0)
    ax_all.set(xlim=(t[0], t[-1]), title='whole run (symlog: linear below 1 m)')
    ax_all.legend(fontsize=8, ncol=3, loc='lower left', framealpha=0.9)
    ax_zoom.set(xlabel='simulation time [s]', xlim=(t[zoom][0], t[zoom][-1]),
                title=f'within {window_s:g} s of the closest approach')
    ax_zoom.legend(fontsize=8, loc='best')
    fig.suptitle(f'{run.title}: clearance of the chaser envelope '
                 f'({run.scenario.chaser.envelope_radius_m:g} m sphere)')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


FIGURES = (
    ('trajectory_xz.png', fig_trajectory_xz),
    ('trajectory_3d.png', fig_trajectory_3d),
    ('range.png', fig_range),
    ('maneuvers.png', fig_maneuvers),
    ('estimation.png', fig_estimation),
    ('clearance.png', fig_clearance),
)
