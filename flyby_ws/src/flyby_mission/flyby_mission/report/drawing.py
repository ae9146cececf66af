"""Drawing shared by the report's figures of a run (loading.Run): the style (resolution, colours), the target, the
restriction sphere and the chaser's paths in hill, the mission's phases, burns and grasp against time, and rows of
estimate minus truth with their +-3 sigma."""

import math

import numpy as np

from flyby_mission.report import plotting
from flyby_mission.report.loading import STEP_TOLERANCE_S
from flyby_msgs_py import contract as c
from flyby_sim.dynamics.rotation import quat_normalize, quat_rotate_many

DPI = 100
TRUTH, ESTIMATE, PLAN, ATTACHED = 'C0', 'C1', 'k', 'C2'
PATH_MARGIN = 0.08  # of the flown path's extent, about it in the trajectory views
REGION_FILL, BODY_FILL = '0.82', '0.45'
PHASE_COLORS = {
    c.PHASE_ESTIMATION: '#dddddd', c.PHASE_PLANNING: '#ffe9a8', c.PHASE_TERMINAL_APPROACH: '#cfe3ff',
    c.PHASE_TRAJECTORY_ADJUST: '#d9f2d0', c.PHASE_FLYBY: '#f9d5e5', c.PHASE_CAPTURE: '#b9f0e4',
    c.PHASE_ESCAPE: '#ffd9b3', c.PHASE_COMPLETE: '#e5e5ff', c.PHASE_ABORTED: '#ffb3b3',
    c.PHASE_SYNC_APPROACH: '#cfe3ff', c.PHASE_ATTITUDE_SYNC: '#fde2c4', c.PHASE_ORBITING: '#d9f2d0',
    c.PHASE_DOCKING: '#f9d5e5', c.PHASE_HOLD: '#fff3b0', c.PHASE_RETREAT: '#ffc9a3',
}


def box_corners_hill(scenario, q_hill_from_body):
    """Per target box: its 8 corners in hill (8, 3) [m] at the attitude q_hill_from_body."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    q = quat_normalize(q_hill_from_body)
    return [quat_rotate_many(q, np.asarray(center) + 0.5 * signs * np.asarray(size))
            for center, size in zip(scenario.boxes.center_body_m, scenario.boxes.size_m, strict=True)]


def target_xz(ax, run):
    """The swept region and the target's boxes at the region time, and the restriction sphere."""
    t_r, label = run.region_time
    if run.region is not None:
        axis = run.region.axis_hill(t_r, run.scenario.mean_motion_rad_s)
        plotting.fill_outline_xz(ax, plotting.cylinder_surfaces(run.region, axis), color=REGION_FILL, lw=0, zorder=1,
                                 label=f'swept keep-out region ({label}, t = {t_r:.0f} s)')
    q_true = run.target_attitude_at(t_r)
    if run.scenario is not None and q_true is not None:
        plotting.fill_outline_xz(ax, _boxes_at(run, t_r, q_true), color=BODY_FILL, lw=0, zorder=2,
                                 label=f'target boxes at t = {t_r:.0f} s')
    q_held = run.target_attitude_at(run.attached[1]) if run.attached is not None else None
    if run.scenario is not None and q_held is not None and run.attached[1] != t_r:
        plotting.fill_outline_xz(ax, _boxes_at(run, run.attached[1], q_held), fill=False, edgecolor=ATTACHED,
                                 lw=1.0, ls='--', zorder=3, label=f'target boxes at t = {run.attached[1]:.0f} s, held')
    if run.scenario is not None:
        radius = run.scenario.planner.restriction_sphere_radius_m
        plotting.sphere_xz(ax, radius, color='0.4', lw=0.8, ls=':', label=f'restriction sphere {radius:g} m')


def _boxes_at(run, t, q_hill_from_body):
    """The target's boxes' corners in hill (box_corners_hill) at time t: about its truth CoM then (the hill origin
    until a capture; the combined body moves it after)."""
    target = run.get(c.SIM_TARGET_ODOM)
    r_com = np.zeros(3) if target is None or target.position is None else \
        target.position[int(np.argmin(np.abs(target.t - t)))]
    return [r_com + corners for corners in box_corners_hill(run.scenario, q_hill_from_body)]


def attached_split(run, t):
    """(free, attached): boolean masks of the stamps t (N,) before the chaser holds the target and while it does
    (Run.attached; the first held stamp in both, so that the two lines join)."""
    if run.attached is None:
        return np.ones(len(t), bool), np.zeros(len(t), bool)
    t0, t1 = run.attached
    attached = (t >= t0 - STEP_TOLERANCE_S) & (t <= t1 + STEP_TOLERANCE_S)
    first = int(np.argmax(attached)) if attached.any() else len(t)
    free = ~attached
    free[first:first + 1] = attached[first:first + 1]
    return free, attached


def _only(points, keep):
    """The points (N, 3) with NaN where not keep (N,): a line drawn through them breaks there."""
    return np.where(keep[:, None], points, np.nan)


def paths_and_points(ax, run, project):
    """Truth path, planned path, burns and the planner's points, drawn through project((N, 3)) ->
    plot coordinates (NaN for a point the axes leave out: it gets no legend entry either). While the chaser holds the
    target (Run.attached) its path is drawn apart, with the target's centre of mass: the two move as one body, the
    arm's reach between them, so the path crosses where the target's boxes were before without touching them."""
    chaser = run.need(c.SIM_CHASER_ODOM)
    free, attached = attached_split(run, chaser.t)
    if not attached.all():
        ax.plot(*project(_only(chaser.position, free)), color=TRUTH, lw=2.2, label='chaser truth')
    if attached.any():
        t0, t1 = run.attached
        ax.plot(*project(_only(chaser.position, attached)), color=ATTACHED, lw=2.2,
                label=f'chaser truth, holding the target ({t0:.0f}-{t1:.0f} s)')
        target = run.get(c.SIM_TARGET_ODOM)
        if target is not None and target.position is not None:
            held = attached_split(run, target.t)[1]
            ax.plot(*project(_only(target.position, held)), color=ATTACHED, lw=1.2, ls=':', label='target CoM, held')
    planned = run.planned_path()
    if planned is not None:
        ax.plot(*project(planned[1]), color=PLAN, lw=1.0, ls='--', label='planned path')
    marks = [(f'{b.kind} burn', run.truth_at(b.t_start), dict(marker='^', ms=6, color=run.kind_colors[b.kind]))
             for b in run.burns]
    plotting.mark_points(ax, run.points() + marks, project, mec='k', mew=0.5, zorder=5)


def flown_limits_xz(run, margin=PATH_MARGIN):
    """(xlim, zlim) [m] of the hill x-z view of the flown path: a square about the chaser's truth path and the
    target's boxes at the region time, half its larger side plus margin of it (zlim descending: up is away from
    Earth). The planned path beyond (an escape orbit of hundreds of metres) and the restriction sphere are clipped."""
    points = [run.need(c.SIM_CHASER_ODOM).position]
    t_r = run.region_time[0]
    q_true = run.target_attitude_at(t_r)
    if run.scenario is not None and q_true is not None:
        points += _boxes_at(run, t_r, q_true)
    x, z = plotting.xz(np.concatenate(points))
    half = 0.5 * max(np.ptp(x), np.ptp(z)) * (1.0 + 2.0 * margin)
    x_c, z_c = 0.5 * (x.min() + x.max()), 0.5 * (z.min() + z.max())
    return (x_c - half, x_c + half), (z_c + half, z_c - half)


def phase_bands(ax, run, legend=True):
    """The mission's phases (Run.phases) as coloured bands against time."""
    seen = set()
    for phase, t0, t1 in run.phases:
        ax.axvspan(t0, t1, color=PHASE_COLORS.get(phase, '#eeeeee'), lw=0, zorder=0,
                   label=phase if legend and phase not in seen else None)
        seen.add(phase)


def grasp_line(ax, run, legend=True):
    """The grasp time (decided, else planned) as a vertical line, if it falls within the run."""
    t_g, label = run.grasp
    if t_g is not None and t_g <= run.t_end + STEP_TOLERANCE_S:
        ax.axvline(t_g, color='darkred', ls='-.', lw=0.9, label=label if legend else None)


def burn_lines(ax, run, labels=True):
    """Each executed burn start as a vertical line in its kind's colour, labelled at the top."""
    for b in run.burns:
        ax.axvline(b.t_start, color=run.kind_colors[b.kind], lw=0.9, zorder=1)
        if labels:
            ax.text(b.t_start, 1.0, f' {b.kind}', transform=ax.get_xaxis_transform(), rotation=90,
                    va='bottom', ha='center', fontsize=7, color=run.kind_colors[b.kind])


def error_row(ax_row, run, name, unit, t, err, sig3, symlog=True):
    """Estimate - truth err (N, 3) with its +-3 sigma sig3 (N, 3) at times t, one axis per component; symlog False:
    a linear scale (a window in which the filter has settled)."""
    # Linear up to the decade above the typical 3 sigma of the second half of the run,
    # logarithmic beyond (the first estimates are far larger).
    typical = float(np.median(sig3[len(sig3) // 2:]))
    linthresh = 10.0 ** math.ceil(math.log10(typical)) if typical > 0.0 else 1e-9
    for k, (ax, axis) in enumerate(zip(ax_row, 'xyz', strict=True)):
        ax.fill_between(t, -sig3[:, k], sig3[:, k], color='C0', alpha=0.2, lw=0, label='$\\pm 3\\sigma$')
        ax.plot(t, err[:, k], color='C3', lw=0.7, label='estimate - truth')
        if symlog:
            ax.set_yscale('symlog', linthresh=linthresh)
        ax.axhline(0.0, color='k', lw=0.5)
        grasp_line(ax, run)
        ax.grid(alpha=0.3)
        ax.set_title(f'{name}, {axis}', fontsize=9)
        outside = np.mean(np.abs(err[:, k]) > sig3[:, k]) * 100.0
        ax.text(0.99, 0.03, f'{outside:.1f} % outside 3$\\sigma$', transform=ax.transAxes, ha='right',
                fontsize=7)
    ax_row[0].set_ylabel(f'[{unit}] (symlog,\nlinear below {linthresh:.2g})' if symlog else f'[{unit}]')


def sphere_spans(ax, run, label=True):
    """The restriction sphere's inside (truth range below its radius) shaded, entry and exit as lines."""
    for k, (t_in, t_out) in enumerate(run.sphere):
        ax.axvspan(t_in, t_out, facecolor='none', edgecolor='0.35', hatch='///', lw=0, zorder=0.5,
                   label='inside the restriction sphere' if label and k == 0 else None)
        for t in (t_in, t_out):
            ax.axvline(t, color='0.35', ls=':', lw=1.0, zorder=1)


def time_axis(ax, run, xlabel=True):
    """x over the whole run [s], with a grid."""
    ax.set_xlim(0.0, run.t_end)
    ax.grid(alpha=0.3)
    if xlabel:
        ax.set_xlabel('simulation time [s]')


def xyz_and_norm(ax, t, vectors, ylabel, frame='hill'):
    """The components of vectors (N, 3) in frame's axes and their norm (black) against t."""
    for k, axis in enumerate('xyz'):
        ax.plot(t, vectors[:, k], color=f'C{k}', lw=1.1, label=f'{frame} {axis}')
    ax.plot(t, np.linalg.norm(vectors, axis=1), color='k', lw=1.3, label='norm')
    ax.set_ylabel(ylabel)


def mark_peak(ax, t, values, unit):
    """The largest of values (N,) at times t marked and labelled, if any is finite."""
    finite = np.flatnonzero(np.isfinite(values))
    if len(finite):
        k = finite[int(np.argmax(values[finite]))]
        ax.plot(t[k], values[k], 'kv', ms=7, label=f'peak {values[k]:.3g} {unit} at t = {t[k]:.1f} s')


def window_axis(ax, window, xlabel=True, margin=0.015):
    """x from window[0] to window[1] [s] with a margin of its span each side (marks at its ends stay visible)."""
    pad = margin * (window[1] - window[0])
    ax.set_xlim(window[0] - pad, window[1] + pad)
    ax.grid(alpha=0.3)
    if xlabel:
        ax.set_xlabel('simulation time [s]')


def estimate_band(ax, t, estimate, sigma, label='estimate'):
    """An estimate (K,) at times t with its +-3 sigma (K,) as a band."""
    ax.fill_between(t, estimate - 3.0 * sigma, estimate + 3.0 * sigma, color=ESTIMATE, alpha=0.25, lw=0,
                    label='$\\pm 3\\sigma$')
    ax.plot(t, estimate, '.-', color=ESTIMATE, lw=1.1, ms=4, label=label)
