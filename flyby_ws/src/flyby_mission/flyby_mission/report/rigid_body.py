"""The figures of a six-degree-of-freedom chaser (scenario chaser.model rigid_body; docs/chaser_6dof.md): its attitude,
the pointing of body +x at the target, the reaction wheels and the thrusters (the catalogue: flyby_mission.report)."""

import math

import matplotlib.colors
import numpy as np

from flyby_mission.approach_figures import pointing_figures
from flyby_mission.report import plotting
from flyby_mission.report.analysis import (
    chaser_attitude_estimate,
    continuous_quaternions,
    firing_inside_sphere,
    pointing_window,
    sigma3,
)
from flyby_mission.report.drawing import (
    DPI,
    ESTIMATE,
    TRUTH,
    burn_lines,
    error_row,
    grasp_line,
    phase_bands,
    sphere_spans,
    time_axis,
)
from flyby_mission.report.loading import STEP_TOLERANCE_S, say
from flyby_mission.report.plotting import plt
from flyby_mission.run_events import grasp_time
from flyby_msgs_py import contract as c
from flyby_sim.dynamics.attitude_control import pointing_error_rad
from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, rotation_vector_from_quat

POINTING_REQUIREMENT_DEG = 1.0  # p95 of the truth from the first terminal burn to the grasp (docs/chaser_6dof.md)


def fig_attitude(run, path):
    """attitude.png (the catalogue: flyby_mission.report)."""
    truth = run.need(c.SIM_CHASER_ODOM)
    deg = math.degrees(1.0)
    estimate = chaser_attitude_estimate(run)
    fig = plt.figure(figsize=(15, 12))
    grid = fig.add_gridspec(3, 3, height_ratios=(1.2, 1.0, 1.0))
    ax_q = fig.add_subplot(grid[0, :])
    ax_err = [fig.add_subplot(grid[1, k], sharex=ax_q) for k in range(3)]
    ax_w = fig.add_subplot(grid[2, :], sharex=ax_q)
    for ax in (ax_q, ax_w):
        phase_bands(ax, run, legend=ax is ax_q)
        burn_lines(ax, run, labels=ax is ax_q)
        grasp_line(ax, run, legend=ax is ax_q)

    q_true = continuous_quaternions(truth.orientation_xyzw)
    for k, name in enumerate('xyzw'):
        ax_q.plot(truth.t, q_true[:, k], color=f'C{k}', lw=1.4, label=f'$q_{name}$')
    for k, name in enumerate('xyz'):
        ax_w.plot(truth.t, truth.angular[:, k] * deg, color=f'C{k}', lw=1.2, label=f'$\\omega_{name}$')
    if isinstance(estimate, str):
        say(f'attitude.png: the estimate left out: {estimate}')
        for ax in ax_err:
            ax.text(0.5, 0.5, estimate, transform=ax.transAxes, ha='center', fontsize=8, wrap=True)
    else:
        e, tr, i, j = estimate
        q_est = e.orientation_xyzw[i]
        q_est = q_est * np.where(np.einsum('ij,ij->i', q_est, q_true[j]) < 0.0, -1.0, 1.0)[:, None]
        for k in range(4):
            ax_q.plot(e.t[i], q_est[:, k], color='k', lw=0.6, ls=(0, (4, 4)),
                      label='estimate (dashed)' if k == 0 else None)
        for k in range(3):
            ax_w.plot(e.t[i], e.angular[i, k] * deg, color='k', lw=0.6, ls=(0, (4, 4)),
                      label='estimate (dashed)' if k == 0 else None)
        # The attitude error as the rotation vector of q_est q_true^-1: about hill axes, like the
        # orientation block of the pose covariance (the estimator's attitude_covariance_hill).
        dtheta = np.array([rotation_vector_from_quat(quat_multiply(a, quat_conjugate(b)))
                           for a, b in zip(e.orientation_xyzw[i], tr.orientation_xyzw[j], strict=True)])
        error_row(ax_err, run, 'chaser attitude error (hill axes)', 'deg', e.t[i], dtheta * deg,
                   sigma3(e.pose_covariance[i], slice(3, 6)) * deg)
        ax_err[1].legend(*ax_err[1].get_legend_handles_labels(), fontsize=8, loc='upper right', ncol=3)
    ax_q.set(ylabel='$q_{hill \\leftarrow body}$ component\n(sign kept continuous)', ylim=(-1.05, 1.05))
    ax_q.legend(fontsize=8, ncol=5, loc='lower left', framealpha=0.9)
    ax_w.set(ylabel='[deg/s]', title='inertial angular velocity in chaser_body axes, truth and estimate')
    ax_w.legend(fontsize=8, ncol=4, loc='lower left', framealpha=0.9)
    time_axis(ax_q, run, xlabel=False)
    time_axis(ax_w, run)
    for ax in ax_err:
        ax.set_xlabel('simulation time [s]')
    fig.suptitle(f'{run.title}: chaser attitude, chaser_body in hill (quaternion x, y, z, w), truth and estimate')
    fig.tight_layout(rect=(0, 0, 1, 0.98))
    plotting.save(fig, path, DPI)


def fig_pointing(run, path):
    """pointing.png: the pointing error against the requirement in its window, and its distribution."""
    truth = run.need(c.SIM_CHASER_ODOM)
    error_deg = np.degrees(pointing_error_rad(truth.orientation_xyzw, truth.position))
    floor = 1e-4  # [deg] a log axis shows no zero
    window = pointing_window(run)
    figures = {k: run.summary.get(k) for k in ('pointing_error_p95_deg', 'pointing_error_max_deg')}
    source = 'summary.json'
    if figures['pointing_error_p95_deg'] is None and window is not None:
        figures, source = pointing_figures(truth, run.events, grasp_time(run.events)), 'bag'
    fig, (ax, ax_cdf) = plt.subplots(1, 2, figsize=(15, 7.5), gridspec_kw=dict(width_ratios=(3.2, 1)))
    phase_bands(ax, run)
    burn_lines(ax, run)
    sphere_spans(ax, run)
    est = chaser_attitude_estimate(run)
    if not isinstance(est, str):
        e, _, i, _ = est
        ax.plot(e.t[i], np.maximum(np.degrees(pointing_error_rad(e.orientation_xyzw[i], e.position[i])), floor),
                color=ESTIMATE, lw=0.6, alpha=0.8, label="estimate's (what guidance controls)")
    ax.plot(truth.t, np.maximum(error_deg, floor), color=TRUTH, lw=1.2, label='truth')
    ax.axhline(POINTING_REQUIREMENT_DEG, color='r', ls='--', lw=1.1,
               label=f'requirement: p95 <= {POINTING_REQUIREMENT_DEG:g} deg')
    grasp_line(ax, run)
    title = 'no burn: no requirement window'
    if window is not None:
        t0, t1 = window
        ax.axvspan(t0, t1, ymin=0.0, ymax=0.015, color='0.15', lw=0, label='window: first burn to grasp')
        inside = (truth.t >= t0) & (truth.t <= t1)
        p95, peak = figures['pointing_error_p95_deg'], figures['pointing_error_max_deg']
        if p95 is not None:
            ax.hlines(p95, t0, t1, color='k', ls='--', lw=1.0, label=f'p95 {p95:.3g} deg ({source})')
        if np.any(inside):
            k = np.flatnonzero(inside)[int(np.argmax(error_deg[inside]))]
            ax.plot(truth.t[k], error_deg[k], 'kv', ms=7, label=f'max {error_deg[k]:.3g} deg at t = {truth.t[k]:.1f} s')
            ordered = np.sort(error_deg[inside])
            ax_cdf.plot(np.maximum(ordered, floor), np.arange(1, len(ordered) + 1) / len(ordered) * 100.0,
                        color=TRUTH, lw=1.4)
        if p95 is not None:
            ax_cdf.axvline(p95, color='k', ls='--', lw=1.0, label=f'p95 {p95:.3g} deg')
            ax_cdf.axhline(95.0, color='k', ls=':', lw=0.8)
        title = (f'window {t0:.1f} to {t1:.1f} s: p95 {p95:.3g} deg, max {peak:.3g} deg ({source})'
                 if p95 is not None else f'window {t0:.1f} to {t1:.1f} s')
    ax.set(yscale='log', ylabel='body +x from the line of sight\nto the target CoM [deg]')
    time_axis(ax, run)
    ax.legend(fontsize=8, ncol=5, loc='upper center', bbox_to_anchor=(0.5, -0.12), framealpha=0.9)
    ax_cdf.axvline(POINTING_REQUIREMENT_DEG, color='r', ls='--', lw=1.1, label='requirement')
    ax_cdf.set(xscale='log', ylim=(0.0, 100.0), xlabel='pointing error [deg]',
               ylabel='share of the window [%]', title='in the window (truth)')
    ax_cdf.grid(alpha=0.3, which='both')
    if ax_cdf.get_legend_handles_labels()[0]:
        ax_cdf.legend(fontsize=8, loc='lower right')
    fig.suptitle(f'{run.title}: pointing of body +x at the target centre of mass\n{title}')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def fig_wheels(run, path):
    """wheels.png: wheel speeds and motor torques against their limits."""
    wheels = run.need(c.SIM_CHASER_WHEELS)
    limits = run.need_scenario().chaser.wheels
    speed_limit = limits.max_momentum_n_m_s / limits.spin_inertia_kg_m2
    axes = np.asarray(limits.axes, dtype=float)
    fig, (ax_s, ax_u) = plt.subplots(2, 1, figsize=(13, 8.5), sharex=True)
    for ax in (ax_s, ax_u):
        phase_bands(ax, run, legend=ax is ax_s)
        burn_lines(ax, run, labels=ax is ax_s)
        sphere_spans(ax, run, label=ax is ax_s)
    for k, name in enumerate(wheels.names):
        axis = f', axis ({", ".join(f"{a:.3g}" for a in axes[k])})' if len(axes) == len(wheels.names) else ''
        ax_s.plot(wheels.t, wheels.velocity[:, k], color=f'C{k}', lw=1.1, label=f'{name}{axis}')
        ax_u.plot(wheels.t, wheels.effort[:, k], color=f'C{k}', lw=0.6, label=name)
    for sign in (1.0, -1.0):
        ax_s.axhline(sign * speed_limit, color='r', ls='--', lw=1.0,
                     label=f'momentum limit {limits.max_momentum_n_m_s:g} N m s / {limits.spin_inertia_kg_m2:g} '
                           f'kg m$^2$ = {speed_limit:.4g} rad/s' if sign > 0 else None)
        ax_u.axhline(sign * limits.max_torque_n_m, color='r', ls='--', lw=1.0,
                     label=f'torque limit {limits.max_torque_n_m:g} N m' if sign > 0 else None)
    ax_s.secondary_yaxis('right', functions=(lambda w: w * limits.spin_inertia_kg_m2,
                                             lambda h: h / limits.spin_inertia_kg_m2)).set_ylabel(
        'J$_s$ x speed [N m s]')
    peak = np.nanmax(np.abs(wheels.velocity))
    ax_s.set(ylabel='wheel speed relative to the body [rad/s]')
    ax_u.set(ylabel='motor torque applied [N m]\n(limits included)')
    ax_s.legend(fontsize=8, ncol=3, loc='lower left', framealpha=0.9)
    ax_u.legend(fontsize=8, ncol=4, loc='lower left', framealpha=0.9)
    time_axis(ax_s, run, xlabel=False)
    time_axis(ax_u, run)
    fig.suptitle(f'{run.title}: reaction wheels (/sim/chaser/wheels)\n'
                 f'largest |speed| {peak:.3g} rad/s = {peak / speed_limit * 100.0:.1f} % of the momentum limit')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


def fig_thrusters(run, path, max_bins=1200):
    """thrusters.png: each thruster's largest thrust per time bin (at most max_bins) and the total wrench."""
    thrusters = run.need(c.SIM_CHASER_THRUSTERS)
    f_max = run.need_scenario().chaser.thrusters.max_thrust_n
    wrench = run.get(c.SIM_CHASER_THRUST)
    t, thrust = thrusters.t, np.nan_to_num(thrusters.effort)
    n_thrusters = thrust.shape[1]
    # Each thruster's largest thrust in each time bin, bins no shorter than a sample's step: a single
    # firing step stays visible and no bin is left empty between two samples.
    span = max(run.t_end, t[-1])
    bins = int(min(max_bins, span / np.median(np.diff(t)))) if len(t) > 1 else 1
    edges = np.linspace(0.0, span, bins + 1)
    peak = np.zeros((bins, n_thrusters))
    np.maximum.at(peak, np.clip(np.searchsorted(edges, t, side='right') - 1, 0, bins - 1), thrust)
    fig = plt.figure(figsize=(14, 9))
    grid = fig.add_gridspec(2, 2, height_ratios=(1.6, 1), width_ratios=(1, 0.015), wspace=0.02)
    ax_r = fig.add_subplot(grid[0, 0])
    ax_m = fig.add_subplot(grid[1, 0], sharex=ax_r)
    phase_bands(ax_r, run)
    positive = thrust[thrust > 0.0]
    vmin = max(float(positive.min()) if len(positive) else f_max * 1e-3, f_max * 1e-4)
    image = ax_r.imshow(np.ma.masked_less_equal(peak.T, 0.0), aspect='auto', interpolation='nearest',
                        cmap='viridis', norm=matplotlib.colors.LogNorm(vmin=vmin, vmax=f_max), zorder=2,
                        extent=(edges[0], edges[-1], n_thrusters - 0.5, -0.5))
    fig.colorbar(image, cax=fig.add_subplot(grid[0, 1]), label=f'thrust [N], largest in each {edges[1]:.2g} s bin')
    ax_r.set_yticks(range(n_thrusters), thrusters.names)
    ax_r.set(ylabel='thruster (/sim/chaser/thrusters effort)')
    firing = np.any(thrust > 0.0, axis=1)
    if wrench is not None:
        torque = np.linalg.norm(wrench.torque, axis=1)
        force = np.linalg.norm(wrench.force, axis=1)
        firing_w = (torque > 0.0) | (force > 0.0)
        phase_bands(ax_m, run, legend=False)
        floor = 1e-5  # [N], [N m]: arithmetic residues of pure forces and couples go on the bottom edge
        for values, color, name in ((force, 'C1', '|force| [N]'), (torque, 'C3', '|torque| about the CoM [N m]')):
            ax_m.plot(wrench.t[firing_w], np.where(values > 0.0, np.maximum(values, floor), np.nan)[firing_w], '.',
                      color=color, ms=3, label=name)
        ax_m.set(yscale='log', ylim=(0.5 * floor, None),
                 ylabel=f'/sim/chaser/thrust\n[N] and [N m] (below {floor:g}:\non the bottom edge)')
    else:
        ax_m.text(0.5, 0.5, f'no {c.absolute(c.SIM_CHASER_THRUST)}', transform=ax_m.transAxes, ha='center')
    for ax in (ax_r, ax_m):
        burn_lines(ax, run, labels=ax is ax_r)
        sphere_spans(ax, run)
        time_axis(ax, run, xlabel=ax is ax_m)
    handles, labels = ax_m.get_legend_handles_labels()
    if handles:
        ax_m.legend(handles, labels, fontsize=8, ncol=3, loc='lower left', framealpha=0.9)
    n_inside = firing_inside_sphere(run, t, firing)
    radius = run.scenario.planner.restriction_sphere_radius_m
    entries = ', '.join(f'{a:.1f} to {"the end" if b >= run.t_end - STEP_TOLERANCE_S else f"{b:.1f} s"}'
                        for a, b in run.sphere) or 'never'
    verdict = ('no firing inside' if n_inside == 0 else
               f'{n_inside} firing samples INSIDE' if n_inside is not None else 'no truth')
    fig.suptitle(f'{run.title}: thrust of each thruster and of all (nothing drawn: off)\n'
                 f'inside the {radius:g} m restriction sphere (hatched): {entries}; {verdict}')
    fig.subplots_adjust(left=0.08, right=0.93, top=0.9, bottom=0.07, hspace=0.12)
    plotting.save(fig, path, DPI)


FIGURES = (  # written for chaser.model rigid_body only
    ('attitude.png', fig_attitude),
    ('pointing.png', fig_pointing),
    ('wheels.png', fig_wheels),
    ('thrusters.png', fig_thrusters),
)
