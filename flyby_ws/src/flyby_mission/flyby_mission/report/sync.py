"""Seed 001's result figures (Seweryn and Banaszkiewicz, section 3, Fig 4-7) of a run of the synchronized approach
(summary.json's method sync; docs/synchronized.md), drawn from sync_analysis (the catalogue: flyby_mission.report)."""

import math

import numpy as np

from flyby_mission.report import plotting
from flyby_mission.report.drawing import DPI, error_row, grasp_line, mark_peak, phase_bands, time_axis, xyz_and_norm
from flyby_mission.report.loading import STEP_TOLERANCE_S, Skipped
from flyby_mission.report.plotting import plt
from flyby_mission.report.sync_analysis import (
    euler_estimation_errors,
    kinetic_energies,
    stage_windows,
    sync_attitude,
    sync_translation,
)

RPY_NAMES = ('$\\phi$ (roll, x)', '$\\theta$ (pitch, y)', '$\\psi$ (yaw, z)')
RPY_SEQUENCE = 'R = Rz($\\psi$) Ry($\\theta$) Rx($\\phi$) of body in hill'


def _stage_grid(run, rows, row_height=2.6):
    """(fig, axes (rows, columns), windows [(t0, t1)]): a column for each pair of seed 001's stages the run reached
    (stage_windows), its x-axis over the pair's window with the phases named at the top; Skipped if it reached
    neither. The figures draw in a column only the samples of its window, so that each axis scales to them."""
    windows = stage_windows(run.phases)
    if not windows:
        raise Skipped('no phase of the synchronized approach')
    fig, axes = plt.subplots(rows, len(windows), figsize=(7.0 * len(windows), row_height * rows + 1.2),
                             sharex='col', squeeze=False)
    for col, (name, (t0, t1)) in enumerate(windows.items()):
        for ax in axes[:, col]:
            phase_bands(ax, run, legend=False)
            grasp_line(ax, run, legend=ax is axes[0, col])
            ax.set_xlim(t0, t1)
            ax.grid(alpha=0.3)
        top = axes[0, col]
        for phase, p0, p1 in run.phases:
            if p1 > t0 and p0 < t1:
                top.text(0.5 * (max(p0, t0) + min(p1, t1)), 1.0, phase, transform=top.get_xaxis_transform(),
                         ha='center', va='bottom', fontsize=7)
        top.set_title(f'seed 001 {name}: {t0:.1f} to {t1:.1f} s\n', fontsize=10)
        axes[-1, col].set_xlabel('simulation time [s]')
    return fig, axes, list(windows.values())


def fig_sync_translation(run, path):
    """Seed 001 Fig 4 (sync_translation): a column for stages 1-2 and one for stages 3-4."""
    d = sync_translation(run)
    station_m = run.need_scenario().planner.sync.station_range_m
    fig, axes, windows = _stage_grid(run, 4)
    for (t0, t1), (ax_r, ax_v, ax_b, ax_a) in zip(windows, axes.T, strict=True):
        keep = (d.t >= t0) & (d.t <= t1)
        t = d.t[keep]
        xyz_and_norm(ax_r, t, d.r_hill[keep], 'chaser position\nin hill [m]')
        xyz_and_norm(ax_v, t, d.v_hill[keep], 'velocity relative to\nhill, hill axes [m/s]')
        xyz_and_norm(ax_b, t, d.r_target_body[keep], 'position in\ntarget_body axes [m]', frame='target_body')
        ax_b.axhline(station_m, color='0.3', ls=':', lw=1.0, label=f'station range {station_m:g} m')
        ax_a.plot(t, d.a_thrust_mps2[keep], color='C3', lw=0.8, label='|F| / m$_0$')
        mark_peak(ax_a, t, d.a_thrust_mps2[keep], 'm/s$^2$')
        ax_a.set_ylabel('thrust acceleration\n[m/s$^2$]')
        for ax in (ax_r, ax_v, ax_b, ax_a):
            ax.legend(fontsize=7, ncol=3, loc='best', framealpha=0.85)
    fig.suptitle(f'{run.title}: seed 001 Fig 4, the chaser relative to the target (truth; '
                 f'|F| / m$_0$ with the initial mass)')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def fig_sync_estimation(run, path):
    """Seed 001 Fig 5 (euler_estimation_errors): the standard deviation of each Euler angle's estimate, and its
    error against the truth with +-3 sigma."""
    t, error, sigma = euler_estimation_errors(run)
    deg = math.degrees(1.0)
    fig, axes = plt.subplots(2, 3, figsize=(16, 8.5), sharex=True)
    for k, (ax, name) in enumerate(zip(axes[0], RPY_NAMES, strict=True)):
        phase_bands(ax, run, legend=k == 0)
        ax.plot(t, sigma[:, k] * deg, color='C0', lw=1.1, label='$\\sigma$ (estimator covariance)')
        late = np.median(sigma[t >= 0.5 * (t[0] + t[-1]), k]) * deg
        ax.set(yscale='log', title=f'{name}: median $\\sigma$ of the second half {late:.3g} deg',
               ylabel='standard deviation [deg]' if k == 0 else None)
        grasp_line(ax, run)
        time_axis(ax, run, xlabel=False)
    axes[0, 0].legend(fontsize=7, ncol=2, loc='upper right', framealpha=0.9)
    error_row(axes[1], run, 'estimate - truth', 'deg', t, error * deg, 3.0 * sigma * deg)
    for ax, name in zip(axes[1], RPY_NAMES, strict=True):
        ax.set_title(f'{name}: estimate - truth, $\\pm 3\\sigma$', fontsize=9)
        time_axis(ax, run)
    fig.suptitle(f'{run.title}: seed 001 Fig 5, the target\'s Euler angles as estimated (/estimation/target/odom)\n'
                 f'{RPY_SEQUENCE}; sigma of $\\phi$ and $\\psi$ grows without bound as $\\theta$ nears $\\pm$90 deg')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def _angles_deg(angles_rad):
    """Angles (N, ...) [rad] in degrees, NaN at each wrap (a jump over 180 deg) so that no line crosses the axis."""
    deg = np.degrees(angles_rad)
    deg[1:][np.abs(np.diff(deg, axis=0)) > 180.0] = np.nan
    return deg


def fig_sync_attitude(run, path):
    """Seed 001 Fig 6 (sync_attitude): both bodies' Euler angles and body rates (chaser solid, target dotted, as the
    paper draws them), from stage 3 the target's carried into the chaser (dashed), and the relative attitude."""
    d = sync_attitude(run)
    deg = math.degrees(1.0)
    fig, axes, windows = _stage_grid(run, 4, row_height=2.7)
    for (t0, t1), (ax_e, ax_w, ax_rel, ax_dw) in zip(windows, axes.T, strict=True):
        keep = (d.t >= t0) & (d.t <= t1)
        t = d.t[keep]
        carried = d.t_stage3 is not None and t0 >= d.t_stage3 - STEP_TOLERANCE_S
        for k, name in enumerate(RPY_NAMES):
            ax_e.plot(t, _angles_deg(d.rpy_chaser[keep, k]), color=f'C{k}', lw=1.2, label=f'chaser {name}')
            ax_e.plot(t, _angles_deg(d.rpy_target[keep, k]), color=f'C{k}', lw=1.0, ls=':', label=f'target {name}')
            ax_w.plot(t, d.omega_chaser_body[keep, k] * deg, color=f'C{k}', lw=1.2, label=f'chaser {"pqr"[k]}')
            ax_w.plot(t, d.omega_target_body[keep, k] * deg, color=f'C{k}', lw=1.0, ls=':', label=f'target {"pqr"[k]}')
            if carried:
                ax_e.plot(t, _angles_deg(d.rpy_carried[keep, k]), color='k', lw=0.9, ls='--',
                          label='target x stage-3 relative attitude' if k == 0 else None)
                ax_w.plot(t, d.omega_carried_body[keep, k] * deg, color='k', lw=0.9, ls='--',
                          label='target rate in those chaser axes' if k == 0 else None)
        ax_e.set(ylabel=f'Euler angles [deg]\n{RPY_SEQUENCE}' if ax_e is axes[0, 0] else None, ylim=(-185.0, 185.0))
        ax_w.set_ylabel('body rates p, q, r [deg/s]\n(own body axes)' if ax_w is axes[1, 0] else None)
        ax_rel.plot(t, np.degrees(d.relative_angle_rad[keep]), color='C4', lw=1.2,
                    label='angle of chaser_body in target_body')
        ax_rel.set_ylabel('relative attitude [deg]' if ax_rel is axes[2, 0] else None)
        if carried:
            ax_drift = ax_rel.twinx()
            drift_deg = np.degrees(d.drift_rad[keep])
            ax_drift.plot(t, drift_deg, color='C3', lw=1.0, ls='--')
            ax_drift.set_ylabel('its drift from the start\nof stage 3 [deg] (dashed)', color='C3')
            k = int(np.argmax(drift_deg))
            ax_rel.set_title(f'drift from t = {d.t_stage3:.1f} s: largest {drift_deg[k]:.3g} deg at t = {t[k]:.1f} s',
                             fontsize=9)
        relative_rate = np.linalg.norm(d.omega_relative_body[keep], axis=1) * deg
        ax_dw.plot(t, relative_rate, color='C5', lw=1.0, label='|$\\omega_c$ - C$_{c \\leftarrow t}$ $\\omega_t$|')
        ax_dw.set(yscale='log', ylabel='relative rate [deg/s]' if ax_dw is axes[3, 0] else None)
        for ax in (ax_e, ax_w, ax_rel, ax_dw):
            ax.legend(fontsize=7, ncol=3, loc='lower left', framealpha=0.85)
    fig.suptitle(f'{run.title}: seed 001 Fig 6, orientation and angular velocity of both bodies (truth)')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def fig_sync_energy(run, path):
    """Seed 001 Fig 7 (kinetic_energies): translational (left axes, dashed) and rotational (right axes, dotted)
    kinetic energy of the chaser and of the target, and the chaser's wheels' spin energy."""
    d = kinetic_energies(run)
    fig, (ax_c, ax_t, ax_w) = plt.subplots(3, 1, figsize=(13, 11), sharex=True)
    for ax, name, translational, rotational in ((ax_c, 'chaser', d.chaser_translational, d.chaser_rotational),
                                                 (ax_t, 'target', d.target_translational, d.target_rotational)):
        phase_bands(ax, run, legend=ax is ax_c)
        grasp_line(ax, run, legend=ax is ax_c)
        ax.plot(d.t, translational, color='C0', ls='--', lw=1.3, label=f'{name} translational (left)')
        ax_rot = ax.twinx()
        ax_rot.plot(d.t, rotational, color='C3', ls=':', lw=1.6)
        ax.plot([], [], color='C3', ls=':', lw=1.6, label=f'{name} rotational (right)')
        for axis, values in ((ax, translational), (ax_rot, rotational)):  # from zero: a constant shows as one
            axis.set_ylim(0.0, 1.1 * max(float(np.max(values)), 1.0))
        ax.set_ylabel(f'{name} translational [J]\n(relative to hill)', color='C0')
        ax_rot.set_ylabel(f'{name} rotational [J]', color='C3')
        ax.set_title(f'{name}: translational peak {np.max(translational):.4g} J, '
                     f'rotational {np.min(rotational):.6g} to {np.max(rotational):.6g} J', fontsize=9)
        ax.legend(fontsize=8, ncol=4, loc='upper left', framealpha=0.9)
        time_axis(ax, run, xlabel=False)
    phase_bands(ax_w, run, legend=False)
    ax_w.plot(d.t, d.chaser_wheels, color='C2', lw=1.2, label='reaction wheels, $\\Sigma$ h$^2$ / 2 J$_s$')
    mark_peak(ax_w, d.t, d.chaser_wheels, 'J')
    ax_w.set_ylabel('chaser wheels\' spin [J]')
    ax_w.legend(fontsize=8, loc='upper left', framealpha=0.9)
    time_axis(ax_w, run)
    fig.suptitle(f'{run.title}: seed 001 Fig 7, kinetic energy (truth; masses and inertias of the scenario, '
                 f'the chaser\'s initial mass)')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


FIGURES = (  # written for a run of the synchronized approach only (is_sync)
    ('seed001_fig4_position_velocity.png', fig_sync_translation),
    ('seed001_fig5_euler_sigma.png', fig_sync_estimation),
    ('seed001_fig6_attitude.png', fig_sync_attitude),
    ('seed001_fig7_kinetic_energy.png', fig_sync_energy),
)
