"""The figure of a run of several chasers (a ``chasers:`` scenario, docs/two_robots.md), drawn from loading.FleetRun
instead of the single chaser's figures (the catalogue: flyby_mission.report)."""

import math

import numpy as np

from flyby_mission.report import plotting
from flyby_mission.report.drawing import BODY_FILL, DPI, box_corners_hill
from flyby_mission.report.loading import Skipped, is_empty, match_stamps
from flyby_mission.report.plotting import plt
from flyby_sim.dynamics.geometry import clearance


def fig_chasers(run, path):
    """chasers.png (module doc)."""
    if len(run.chasers) < 2 or is_empty(run.target):
        raise Skipped('fewer than two chasers or no target truth in the bag')
    names = list(run.chasers)
    fig, ((ax_xz, ax_sep), (ax_zoom, ax_clear)) = plt.subplots(2, 2, figsize=(16, 10))
    boxes = list(zip(run.scenario.boxes.center_body_m, run.scenario.boxes.size_m, strict=True))
    worst = (math.inf, None)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            sa, sb = run.chasers[a], run.chasers[b]
            i_a, i_b = match_stamps(sa.t, sb.t)
            gap = (np.linalg.norm(sa.position[i_a] - sb.position[i_b], axis=1)
                   - run.scenario.for_chaser(a).chaser.envelope_radius_m
                   - run.scenario.for_chaser(b).chaser.envelope_radius_m)
            k = int(np.argmin(gap))
            ax_sep.plot(sa.t[i_a], gap, lw=1.3, label=f'{a} - {b}: least {gap[k]:.2f} m at t = {sa.t[i_a][k]:.1f} s')
            if gap[k] < worst[0]:
                worst = (float(gap[k]), float(sa.t[i_a][k]))
    for j, name in enumerate(names):
        s = run.chasers[name]
        color = f'C{j}'
        for ax in (ax_xz, ax_zoom):
            ax.plot(*plotting.xz(s.position), color=color, lw=1.8, label=f'{name} truth')
        ax_xz.plot(*plotting.xz(s.position[:1]), 'o', color=color, mec='k', ms=7)
        i_c, i_t = match_stamps(s.t, run.target.t)
        gap = clearance(s.position[i_c], run.target.orientation_xyzw[i_t], boxes,
                        run.scenario.for_chaser(name).chaser.envelope_radius_m)
        k = int(np.argmin(gap))
        ax_clear.plot(s.t[i_c], gap, color=color, lw=1.3,
                      label=f'{name}: least {gap[k]:.3f} m at t = {s.t[i_c][k]:.1f} s')
    k_t = int(np.argmin(np.abs(run.target.t - worst[1])))
    for ax in (ax_xz, ax_zoom):
        plotting.fill_outline_xz(ax, box_corners_hill(run.scenario, run.target.orientation_xyzw[k_t]),
                                 color=BODY_FILL, lw=0, zorder=2,
                                 label=f'target boxes at t = {run.target.t[k_t]:.1f} s (least separation)')
        ax.set(aspect='equal', xlabel='hill x, along-track [m]', ylabel='hill z, toward Earth [m] (up: away)')
    ax_xz.set(adjustable='datalim', title='chasers in the hill x-z plane (o: start)')
    ax_xz.invert_yaxis()
    ax_zoom.set(xlim=(-8.0, 8.0), ylim=(8.0, -8.0), title='within 8 m of the target')
    ax_sep.set(ylabel='distance between envelopes [m]', title='separation of the chasers (truth)')
    ax_clear.set_yscale('symlog', linthresh=1.0)
    ax_clear.set(xlabel='simulation time [s]', ylabel='envelope clearance [m]',
                 title="clearance to the target's boxes (truth; symlog: linear below 1 m)")
    for ax in (ax_xz, ax_zoom, ax_sep, ax_clear):
        ax.grid(alpha=0.3, which='both')
        ax.legend(fontsize=8, loc='best')
    for ax in (ax_sep, ax_clear):
        ax.axhline(0.0, color='r', lw=1.0)
    fig.suptitle(run.title)
    fig.tight_layout()
    plotting.save(fig, path, DPI)
