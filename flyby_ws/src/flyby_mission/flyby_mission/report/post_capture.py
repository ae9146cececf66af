"""Seed 004's figures (Matsunaga et al.) of a run with a post_capture section (docs/post_capture.md): Fig 5 during
MASS_ESTIMATION, the arm's contact during GRASP and the angular momentum during DAMPING; with a transport section,
Fig 7 during TRANSPORT (docs/transport.md). Drawn from post_capture_analysis (the catalogue: flyby_mission.report)."""

import math

import numpy as np

from flyby_mission.report import plotting
from flyby_mission.report.drawing import (
    DPI,
    ESTIMATE,
    TRUTH,
    error_row,
    estimate_band,
    mark_peak,
    window_axis,
    xyz_and_norm,
)
from flyby_mission.report.plotting import plt
from flyby_mission.report.post_capture_analysis import (
    combined_motion,
    damping_momentum,
    grasp_contact,
    mass_property_estimates,
    transport_series,
)
from flyby_msgs_py import contract as c
from flyby_msgs_py import events

FIG5_MOMENT_NAMES = ('I$_1$ (smallest)', 'I$_2$', 'I$_3$ (largest)')


def fig_seed004_motion(run, path):
    """Seed 004 Fig 5 (a)-(d) (combined_motion)."""
    d = combined_motion(run)
    window = run.phase_window(c.PHASE_MASS_ESTIMATION)
    deg = math.degrees(1.0)
    fig = plt.figure(figsize=(17, 15))
    grid = fig.add_gridspec(4, 4, width_ratios=(2.0, 1.0, 1.0, 1.0))
    ax_r, ax_v = fig.add_subplot(grid[0, :]), fig.add_subplot(grid[1, :])
    mm = 1e3
    r0 = d.r_com_hill[0]
    xyz_and_norm(ax_r, d.t, (d.r_com_hill - r0) * mm, '[mm]')
    ax_r.set_title(f'(a) position of the combined CoM in hill (truth), from its {np.array2string(r0, precision=3)} m '
                   'at the phase\'s start', fontsize=10)
    xyz_and_norm(ax_v, d.t, d.v_com_inertial * mm, '[mm/s]')
    ax_v.set_title('(b) inertial velocity of the combined CoM, hill axes of each instant (truth)', fontsize=10)
    for ax in (ax_r, ax_v):
        ax.legend(fontsize=8, ncol=4, loc='upper left', framealpha=0.9)
        window_axis(ax, window, xlabel=False)
    ax_q = fig.add_subplot(grid[2, 0])
    for k, name in enumerate('xyzw'):
        ax_q.plot(d.t, d.q_hill_from_body[:, k], color=f'C{k}', lw=1.4, label=f'$q_{name}$ truth')
        ax_q.plot(d.t_est, d.q_est[:, k], color='k', lw=0.7, ls=(0, (4, 4)), label='estimate' if k == 0 else None)
    ax_q.set(ylabel='$q_{hill \\leftarrow body}$', title='(c) attitude of chaser_body (the combined body) in hill')
    ax_w = fig.add_subplot(grid[3, 0], sharex=ax_q)
    for k, name in enumerate('xyz'):
        ax_w.plot(d.t, d.omega_body[:, k] * deg, color=f'C{k}', lw=1.4, label=f'$\\omega_{name}$ truth')
        ax_w.plot(d.t_est, d.omega_est[:, k] * deg, color='k', lw=0.7, ls=(0, (4, 4)),
                  label='estimate' if k == 0 else None)
    ax_w.set(ylabel='[deg/s]', title='(d) inertial angular velocity, chaser_body axes')
    for ax in (ax_q, ax_w):
        ax.legend(fontsize=7, ncol=3, loc='best', framealpha=0.85)
        window_axis(ax, window, xlabel=ax is ax_w)
    for row, name, unit, err, sig3 in ((2, '(c) attitude error (hill axes)', 'deg', d.attitude_error_hill * deg,
                                        d.attitude_sigma3_hill * deg),
                                       (3, '(d) rate error (body axes)', 'deg/s', d.rate_error_body * deg,
                                        d.rate_sigma3_body * deg)):
        ax_row = [fig.add_subplot(grid[row, k + 1], sharex=ax_q) for k in range(3)]
        error_row(ax_row, run, name, unit, d.t_est, err, sig3, symlog=False)
        for ax in ax_row:
            window_axis(ax, window, xlabel=row == 3)
    fig.suptitle(f'{run.title}: seed 004 Fig 5 (a)-(d), the combined body during MASS_ESTIMATION\n'
                 '(a)-(b) truth only: the mission publishes no estimate of the combined CoM; (c)-(d) the estimate of '
                 'the chaser\'s attitude filter (/estimation/chaser/odom):\nthe mass-property filter\'s own attitude '
                 'and rate are not published')
    fig.tight_layout(rect=(0, 0, 1, 0.98))
    plotting.save(fig, path, DPI)


def fig_seed004_mass_properties(run, path):
    """Seed 004 Fig 5 (e)-(h) (mass_property_estimates): each estimate with its +-3 sigma and the truth."""
    d = mass_property_estimates(run)
    window = run.phase_window(c.PHASE_MASS_ESTIMATION)
    deg = math.degrees(1.0)
    fig = plt.figure(figsize=(16, 15))
    grid = fig.add_gridspec(4, 3)
    prior = d.prior
    for k, name in enumerate(FIG5_MOMENT_NAMES):
        ax = fig.add_subplot(grid[0, k])
        estimate_band(ax, d.t, d.moments_kg_m2[:, k], d.moments_sigma_kg_m2[:, k])
        ax.axhline(d.true_moments_kg_m2[k], color='k', ls='--', lw=1.0, label=f'truth {d.true_moments_kg_m2[k]:g}')
        if prior is not None:
            ax.plot(prior['t'], prior['principal_moments_kg_m2'][k], 'o', mfc='none', mec='k', label='prior')
        error = (d.moments_kg_m2[-1, k] / d.true_moments_kg_m2[k] - 1.0) * 100.0
        ax.set_title(f'(e) {name}: {d.moments_kg_m2[-1, k]:.1f} $\\pm$ {d.moments_sigma_kg_m2[-1, k]:.1f} kg m$^2$ '
                     f'({error:+.2f} %)', fontsize=9)
        ax.set_ylabel('principal moment [kg m$^2$]' if k == 0 else None)
    ax_m = fig.add_subplot(grid[1, :])
    estimate_band(ax_m, d.t, d.mass_kg, d.mass_sigma_kg)
    ax_m.axhline(d.true_mass_kg, color='k', ls='--', lw=1.0, label=f'truth {d.true_mass_kg:g} kg')
    if prior is not None:
        ax_m.plot(prior['t'], prior['mass_kg'], 'o', mfc='none', mec='k', label='prior (at the lock)')
    ax_m.set(ylabel='target mass [kg]',
             title=f'(f) mass: {d.mass_kg[-1]:.1f} $\\pm$ {d.mass_sigma_kg[-1]:.1f} kg '
                   f'({(d.mass_kg[-1] / d.true_mass_kg - 1.0) * 100.0:+.2f} %)')
    for k in range(3):
        ax = fig.add_subplot(grid[2, k])
        estimate_band(ax, d.t, d.axes_error_rad[:, k] * deg, d.axes_sigma_rad[:, k] * deg, label='estimate - truth')
        ax.axhline(0.0, color='k', ls='--', lw=1.0, label='truth')
        ax.set_title(f'(g) principal axes, d$\\phi_{k + 1}$ (about axis {k + 1}); axis {k + 1} off by '
                     f'{d.axes_angle_rad[-1, k] * deg:.3f} deg at the end', fontsize=9)
        ax.set_ylabel('rotation of the axes [deg]' if k == 0 else None)
    for k, axis in enumerate('xyz'):
        ax = fig.add_subplot(grid[3, k])
        estimate_band(ax, d.t, d.com_body_m[:, k], d.com_sigma_m[:, k])
        ax.plot(d.t_truth, d.true_com_body_m[:, k], color='k', ls='--', lw=1.0, label='truth')
        if prior is not None:
            ax.plot(prior['t'], prior['com_body_m'][k], 'o', mfc='none', mec='k', label='prior')
        error_mm = (d.com_body_m[-1, k] - d.true_com_at_estimate_m[-1, k]) * 1e3
        ax.set_title(f'(h) centre of mass, chaser_body {axis}: {d.com_body_m[-1, k]:.4f} m '
                     f'$\\pm$ {d.com_sigma_m[-1, k] * 1e3:.1f} mm ({error_mm:+.1f} mm)', fontsize=9)
        ax.set_ylabel('target CoM from the chaser CoM [m]' if k == 0 else None)
    for ax in fig.axes:
        ax.legend(fontsize=7, loc='best', framealpha=0.85, ncol=2)
        window_axis(ax, window, xlabel=ax in fig.axes[-3:])
    fig.suptitle(f'{run.title}: seed 004 Fig 5 (e)-(h), the target\'s mass properties during MASS_ESTIMATION\n'
                 '/estimation/target/inertia with the 1-sigma of the estimator\'s mass_properties_estimate events; '
                 'truth: the scenario\'s mass and moments, CoM and axes from both bodies\' truth')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def fig_grasp_contact(run, path):
    """The arm's contact force, torque and stroke during GRASP (grasp_contact) with the arm's limits, at which the
    grasp lets go (docs/post_capture.md)."""
    t, force, torque, stroke = grasp_contact(run)
    g = run.need_scenario().post_capture.grasp
    fig, axes = plt.subplots(3, 1, figsize=(12, 10), sharex=True)
    for ax, values, unit, limit, name, what in (
            (axes[0], force, 'N', g.max_force_n, '|force|', 'on the target'),
            (axes[1], torque, 'N m', g.max_torque_n_m, '|torque|', 'on the target'),
            (axes[2], stroke * 1e3, 'mm', g.max_stroke_m * 1e3, '|stroke|', 'the handle from the end effector')):
        ax.plot(t, values, color=TRUTH, lw=1.4, label=f'{name}, {what} (truth)')
        ax.axhline(limit, color='r', ls='--', lw=1.1, label=f"the arm's limit {limit:g} {unit}")
        mark_peak(ax, t, values, unit)
        ax.set(yscale='log', ylabel=f'{name} [{unit}]')
        ax.legend(fontsize=8, loc='center right', framealpha=0.9)
        window_axis(ax, (t[0], t[-1]), xlabel=ax is axes[-1])
    peaks = [run.summary.get(k) for k in ('peak_grasp_force_n', 'peak_grasp_torque_n_m')]
    stated = f' (summary.json: {peaks[0]:.3g} N, {peaks[1]:.3g} N m)' if None not in peaks else ''
    fig.suptitle(f'{run.title}: the arm\'s impedance during GRASP, recomputed from both bodies\' truth at every '
                 f'sample\npeak {force.max():.3g} N and {torque.max():.3g} N m{stated}; '
                 f'GRASP lasted {t[-1] - t[0]:.2f} s')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def fig_damping_momentum(run, path):
    """The combined body's angular momentum during DAMPING (damping_momentum) against seed 004 §3.2's threshold."""
    t, momentum = damping_momentum(run)
    threshold = run.need_scenario().post_capture.damping.momentum_threshold_kg_m2_s
    fig, ax = plt.subplots(figsize=(12, 6.5))
    ax.plot(t, momentum, color=TRUTH, lw=1.4, label='|H| about the combined CoM, wheels included (truth)')
    ax.axhline(threshold, color='r', ls='--', lw=1.1, label=f'threshold {threshold:g} kg m$^2$/s (seed 004 §3.2)')
    ax.plot(t[-1], momentum[-1], 'kv', ms=8, label=f'at the end: {momentum[-1]:.3g} kg m$^2$/s')
    done = next((e for e in run.events if e['name'] == events.DAMPING_COMPLETE), None)
    if done is not None and 'momentum_bound_kg_m2_s' in done['values']:
        ax.plot(done['t'], float(done['values']['momentum_bound_kg_m2_s']), 'D', color=ESTIMATE, mec='k',
                label='guidance\'s bound from its estimates (damping_complete)')
    below = np.flatnonzero(momentum < threshold)
    first_below = f'first below the threshold at t = {t[below[0]]:.1f} s' if len(below) else 'never below the threshold'
    ax.set(yscale='log', ylabel='angular momentum [kg m$^2$/s]',
           title=f'from {momentum[0]:.4g} to {momentum[-1]:.3g} kg m$^2$/s in {t[-1] - t[0]:.1f} s; {first_below}')
    ax.legend(fontsize=8, loc='upper right', framealpha=0.9)
    window_axis(ax, (t[0], t[-1]))
    fig.suptitle(f'{run.title}: the combined body\'s angular momentum during DAMPING')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def fig_seed004_fig7(run, path):
    """Seed 004 Fig 7's analogue during TRANSPORT (transport_series): (a) angular momentum, (b) distance to the goal,
    (c) linear momentum relative to the goal's circular motion (the relative velocity times the combined mass, the
    quantity of condition 3) with the speed in its title, each against its rendezvous condition, the
    planned arrival and guidance's transport_complete marked, the thrusters' firing steps shaded."""
    t, miss, speed, momentum, h = transport_series(run)
    tr = run.need_scenario().post_capture.transport
    fig, axes = plt.subplots(3, 1, figsize=(12, 10), sharex=True)
    rows = ((axes[0], h, 'angular momentum [kg m$^2$/s]', tr.max_angular_momentum_kg_m2_s, 'kg m$^2$/s'),
            (axes[1], miss, 'distance to the goal [m]', tr.max_position_error_m, 'm'),
            (axes[2], momentum, 'linear momentum relative\nto the goal [N s]', tr.max_momentum_error_n_s, 'N s'))
    for ax, values, label, bound, unit in rows:
        ax.plot(t, values, color=TRUTH, lw=1.3, label='truth')
        ax.axhline(bound, color='r', ls='--', lw=1.1, label=f'condition: below {bound:.3g} {unit}')
        ax.plot(t[-1], values[-1], 'kv', ms=7, label=f'at the end: {values[-1]:.3g} {unit}')
        ax.set(yscale='log', ylabel=label)
    axes[2].set_title(f'the relative velocity: {speed[0] * 1e3:.3g} mm/s at the start, peak {speed.max() * 1e3:.3g} '
                      f'mm/s, {speed[-1] * 1e3:.3g} mm/s at the end', fontsize=9)
    planned = next((e for e in run.events if e['name'] == events.TRANSPORT_PLANNED), None)
    done = next((e for e in run.events if e['name'] == events.TRANSPORT_COMPLETE), None)
    thrust = run.get(c.SIM_CHASER_THRUST)
    for ax in axes:
        if planned is not None:
            ax.axvline(float(planned['values']['t_arrival_s']), color='0.4', ls=':', lw=1.0, label='planned arrival')
        if done is not None:
            ax.axvline(done['t'], color='g', ls='-.', lw=1.0, label=events.TRANSPORT_COMPLETE)
        if thrust is not None and len(thrust.t):
            firing = (np.linalg.norm(thrust.force, axis=1) > 0) & (thrust.t >= t[0])
            ax.fill_between(thrust.t, 0, 1, where=firing, color='orange', alpha=0.25, step='post',
                            transform=ax.get_xaxis_transform(), label='thrusters firing')
        ax.legend(fontsize=7, loc='upper right', framealpha=0.9)
        ax.grid(True, which='both', alpha=0.3)
    window_axis(axes[-1], (t[0], t[-1]))
    axes[-1].set_xlabel('t [s]')
    fig.suptitle(f'{run.title}: TRANSPORT, seed 004 Fig 7 (truth)')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


FIGURES = (  # written for a scenario with a post_capture section only
    ('seed004_fig5_motion.png', fig_seed004_motion),
    ('seed004_fig5_mass_properties.png', fig_seed004_mass_properties),
    ('post_capture_grasp_contact.png', fig_grasp_contact),
    ('post_capture_damping_momentum.png', fig_damping_momentum),
)
TRANSPORT_FIGURES = (  # written for a scenario with a post_capture.transport section only
    ('seed004_fig7_transport.png', fig_seed004_fig7),
)
