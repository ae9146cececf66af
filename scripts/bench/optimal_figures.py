"""Seed 003 Fig 10 (x-z path, waypoints, the panels' swept area) and Fig 11 (safety metric vs time) regenerated for
the plans of scripts/bench/benchmark_optimal.py --figures: seed003_fig10_xz.png and seed003_fig11_safety.png."""

from pathlib import Path

import numpy as np
from optimal_cases import T_TABLE1_S

from flyby_mission.report import plotting as plots
from flyby_mission.report.plotting import plt
from flyby_planner.flyby.keepout import swept_region
from flyby_planner.optimal.cost import midpoint_times, safety_metric
from flyby_sim.dynamics.orbital import q_eci_from_body


def write_figures(out, scenario, problem, plans):
    """Seed 003 Fig 10 and Fig 11 for the plans {label: plan} (module doc)."""
    n = scenario.mean_motion_rad_s
    region = swept_region(scenario.boxes, scenario.target_inertia, q_eci_from_body(0.0, n, scenario.q_hill_from_body0),
                          scenario.omega_body0_rad_s[None])
    axis = region.axis_hill(0.0, n)
    e1 = np.cross(axis, (0.0, 1.0, 0.0))
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    theta = np.linspace(0.0, 2.0 * np.pi, 181)
    fig, ax = plt.subplots(figsize=(9, 5.5))
    for name, lo, hi, radius in zip(region.names, region.axial_min_m, region.axial_max_m, region.radius_m,
                                    strict=True):
        if name.startswith('panel'):
            disc = 0.5 * (lo + hi) * axis + radius * (np.outer(np.cos(theta), e1) + np.outer(np.sin(theta), e2))
            ax.fill(*plots.xz(disc), color='0.8', label='area swept by the panels' if name.endswith('y') and
                    'plus' in name else None)
    spin = np.outer((-12.0, 12.0), axis)
    ax.plot(*plots.xz(spin), 'k-.', lw=1, label='spin axis')
    colors = {'Nelder-Mead': 'tab:blue', 'SCP': 'tab:red'}
    for label, plan in plans.items():
        traj = plan.sample(np.linspace(0.0, plan.duration_s, 600))
        ax.plot(*plots.xz(traj.r_hill), color=colors[label], label=label)
        if hasattr(plan, 'knots_s'):
            ax.plot(*plots.xz(plan.p_hill[1:-2]), 'o', color=colors[label], ms=5, label='waypoints on path')
    r_f, _ = problem.end_state(T_TABLE1_S)
    ax.plot(*plots.xz(problem.r0_hill[None]), 'ks', label='robot initial position')
    ax.plot(*plots.xz(r_f[None]), 'k*', ms=12, label='final position')
    ax.set(xlim=(-15, 55), ylim=(15, -15), aspect='equal', xlabel='hill x, along-track [m]',
           ylabel='hill z, toward Earth [m]', title='Seed 003 Fig 10: optimal approach, single robot (x-z)')
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc='upper right')
    fig.tight_layout()
    plots.save(fig, Path(out) / 'seed003_fig10_xz.png', 100)
    fig, ax = plt.subplots(figsize=(8, 4))
    for label, plan in plans.items():
        tau, _ = midpoint_times(plan.duration_s, 600)
        traj = plan.sample(tau)
        c, omega_rel = problem.target.attitude(traj.t_s)
        s, _ = safety_metric(traj.r_hill, traj.v_hill, c, omega_rel, scenario.boxes, problem.chaser.envelope_radius_m)
        ax.plot(tau, s, color=colors[label], label=label)
    ax.set(xlabel='time [s]', ylabel='safety metric $s_p$ [m/s$^2$]',
           title='Seed 003 Fig 11: value of the safety metric vs time')
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    plots.save(fig, Path(out) / 'seed003_fig11_safety.png', 100)
