#!/usr/bin/env python3
"""Benchmark: seed 003 Table 1's approach planned by the Nelder-Mead baseline and by SCP, side by side.

    benchmark_optimal.py [--scenario scenarios/paper_flyby.yaml] [--repeat 5] [--free-time] [--two-robots]
                         [--figures docs/figures]

Table 1's case: the chaser 50 m ahead on V-bar at rest, the target spinning 5 deg/s about [1, 1, 1]/sqrt(3)
(paper_flyby's target), the approach time 58.9 s and the peak acceleration 0.138 m/s^2 of Table 1; the end state is
X_Ft, V_Ft (seed 000 eq 20-21) of the grasp point at the scenario's offset; plume radius --plume-radius (5 m); the
chaser's mass and Isp from the scenario. Both plans are judged by the same eq 5 (flyby_planner.optimal.cost) on 600
steps, and their least clearance by the true attitude every 10 ms. SCP is timed cold (the first plan of the process,
cvxpy compiling its parametrized program) and warm (median of --repeat). Also the least delta-v bracket for 58.9 s
and 0.138 m/s^2 (scp.delta_v_lower_bound) and SCP with the safety weight off (the least-fuel plan that still meets
keep-out and the plume rule). --free-time: both solvers also choose T (eq 5's k_t T^2). --two-robots: the +-50 m
V-bar pair (seed 003 Fig 12). --figures DIR: seed 003 Fig 10 (x-z path, waypoints, the panels' swept area) and
Fig 11 (safety metric vs time) regenerated for both plans, seed003_fig10_xz.png and seed003_fig11_safety.png.
"""

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from flyby_msgs_py.schema import ScenarioError
from flyby_planner.keepout import swept_region
from flyby_planner.optimal.approach import LEAST_FUEL_SCP
from flyby_planner.optimal.baseline import NelderMeadSettings, plan_nelder_mead
from flyby_planner.optimal.cost import midpoint_times, plan_terms, safety_metric, total_cost
from flyby_planner.optimal.problem import approach_problem, chaser_from_scenario
from flyby_planner.optimal.scp import delta_v_lower_bound, plan_scp
from flyby_planner.plan import truth_prediction
from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.geometry import clearance
from flyby_sim.dynamics.orbital import q_eci_from_body, q_hill_from_body_many
from flyby_sim.dynamics.propulsion import fuel_for_delta_v_kg
from flyby_sim.scenario import load_scenario

sys.path.insert(0, str(Path(__file__).resolve().parent))  # scripts/ is not a package
import plots  # noqa: E402
from plots import plt  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
T_TABLE1_S = 58.9
ACCEL_TABLE1_MPS2 = 0.138
FUEL_TABLE1_KG = 1.05


def _truth_clearance_m(scenario, plan):
    """Least gap [m] of the chaser envelope to the boxes turned by the true attitude, every 10 ms of the plan."""
    n = scenario.mean_motion_rad_s
    tau = np.linspace(0.0, plan.duration_s, int(round(plan.duration_s / 0.01)) + 1)
    truth = AttitudePropagator(q_eci_from_body(0.0, n, scenario.q_hill_from_body0), scenario.omega_body0_rad_s,
                               scenario.target_inertia)
    q_eci, _ = truth.states_at(plan.t0_s + tau)
    boxes = list(zip(scenario.boxes.center_body_m, scenario.boxes.size_m, strict=True))
    return float(clearance(plan.sample(tau).r_hill, q_hill_from_body_many(plan.t0_s + tau, n, q_eci), boxes,
                           scenario.chaser.envelope_radius_m).min())


def _row(label, scenario, problem, plan, compute_s):
    t = plan_terms(problem, plan)
    fuel_kg = fuel_for_delta_v_kg(problem.chaser.mass_kg, t.delta_v_mps, problem.chaser.exhaust_velocity_mps)
    return (f'{label:<22} {t.actuator:8.4f} {t.fuel:7.3f} {t.safety:7.3f} {t.plume:7.4f} {t.time:6.3f} '
            f'{t.total:8.3f} | {t.delta_v_mps:6.3f} {fuel_kg:6.3f} {t.duration_s:6.1f} {t.peak_accel_mps2:6.4f} '
            f'{_truth_clearance_m(scenario, plan):6.3f} {compute_s:8.3f}')


HEADER = (f'{"plan":<22} {"k_a a":>8} {"k_f f":>7} {"k_s s":>7} {"k_pi pi":>7} {"k_t T2":>6} {"P eq 5":>8} | '
          f'{"dv m/s":>6} {"fuel kg":>6} {"T s":>6} {"a_max":>6} {"clear m":>6} {"compute s":>8}')


def _figures(out, scenario, problem, plans):
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--scenario', default=str(ROOT / 'scenarios' / 'paper_flyby.yaml'))
    ap.add_argument('--plume-radius', type=float, default=5.0, help='plume radius about the target CoM [m]')
    ap.add_argument('--repeat', type=int, default=5, help='warm SCP plans to time')
    ap.add_argument('--waypoints-max', type=int, default=6, help='the baseline\'s last stage')
    ap.add_argument('--t0', type=float, default=0.0,
                    help='start time [s] (jacobsen_optimal\'s mission starts at 65.1 s from the same state)')
    ap.add_argument('--bound-steps', type=lambda v: [int(x) for x in v.split(',') if x],
                    default=[40, 80, 120, 160, 200, 240],
                    help='grids of the least-fuel SCP with keep-out and plume (comma list; empty: none)')
    ap.add_argument('--free-time', action='store_true')
    ap.add_argument('--two-robots', action='store_true')
    ap.add_argument('--figures', metavar='DIR', help='write seed 003 Fig 10 and Fig 11 here')
    args = ap.parse_args()
    if args.repeat < 1:
        print(f'error: --repeat: must be >= 1, got {args.repeat}', file=sys.stderr)
        return 2
    try:
        sc = load_scenario(args.scenario)
    except ScenarioError as err:
        print(f'error: {err}', file=sys.stderr)
        return 2
    prediction = truth_prediction(sc, args.t0 + 400.0)
    chaser = chaser_from_scenario(sc, ACCEL_TABLE1_MPS2)
    problem = approach_problem(sc, prediction, sc.chaser.initial_position_hill_m, sc.chaser.initial_velocity_hill_mps,
                               args.t0, args.plume_radius, chaser=chaser)
    w = problem.weights
    print(f'{sc.name}: chaser {chaser.mass_kg:g} kg, Isp {chaser.isp_s:g} s, a_max {chaser.accel_max_mps2:g} m/s^2, '
          f'envelope {chaser.envelope_radius_m:g} m; plume radius {args.plume_radius:g} m; grasp point '
          f'{[float(v) for v in sc.target.grasp_point_body_m]} body, offset {sc.planner.offset_m:g} m')
    print(f'eq 5 weights: k_a {w.actuator:g} 1/s, k_f {w.fuel_per_kg:g} 1/kg, k_s {w.safety:g} s/m, '
          f'k_pi {w.plume:g} s/m, k_t {w.time:g} 1/s^2')
    print(HEADER)

    # SCP first: its cold plan is the process's first (cvxpy compiles its parametrized program), wall and CPU time
    start, cpu = time.perf_counter(), time.process_time()
    scp = plan_scp([problem], duration_s=T_TABLE1_S)
    cold_s, cold_cpu_s = time.perf_counter() - start, time.process_time() - cpu
    start = time.perf_counter()
    nm = plan_nelder_mead([problem], NelderMeadSettings(waypoints_max=args.waypoints_max), duration_s=T_TABLE1_S)
    nm_s = time.perf_counter() - start
    print(_row(f'Nelder-Mead, n = {nm.waypoints}', sc, problem, nm.plans[0], nm_s))
    warm = []
    for _ in range(args.repeat):
        start = time.perf_counter()
        plan_scp([problem], duration_s=T_TABLE1_S)
        warm.append(time.perf_counter() - start)
    print(_row('SCP (warm median)', sc, problem, scp.plans[0], float(np.median(warm))))
    least_fuel = dataclasses.replace(problem, weights=dataclasses.replace(w, safety=0.0))
    start = time.perf_counter()
    lean = plan_scp([least_fuel], duration_s=T_TABLE1_S)
    print(_row('SCP, k_s = 0', sc, problem, lean.plans[0], time.perf_counter() - start))
    # the least-fuel plan as the mission plans it (approach.plan_approach with k_s = 0): its first plan compiles
    # the program of that shape (cold), then warm plans
    mission = LEAST_FUEL_SCP
    start, cpu = time.perf_counter(), time.process_time()
    lean_mission = plan_scp([least_fuel], mission, duration_s=T_TABLE1_S)
    lean_cold = (time.perf_counter() - start, time.process_time() - cpu)
    lean_warm = []
    for _ in range(args.repeat):
        start, cpu = time.perf_counter(), time.process_time()
        plan_scp([least_fuel], mission, duration_s=T_TABLE1_S)
        lean_warm.append((time.perf_counter() - start, time.process_time() - cpu))
    print(_row(f'SCP, k_s = 0, {LEAST_FUEL_SCP.steps} st', sc, problem, lean_mission.plans[0], lean_cold[0]))
    print(f'Nelder-Mead stages (n, P): {[(n, round(c, 3)) for n, c in nm.stages]}, {nm.evaluations} evaluations')
    print(f'SCP: {scp.solves} convex programs, converged {scp.converged}; cold {cold_s:.3f} s wall, {cold_cpu_s:.3f} s '
          f'CPU (first plan of the process, cvxpy compiles), warm median {np.median(warm):.3f} s, '
          f'min {min(warm):.3f} s, max {max(warm):.3f} s')
    print(f'SCP k_s = 0 on {LEAST_FUEL_SCP.steps} steps (the mission\'s least-fuel plan): {lean_mission.solves} convex '
          f'programs; cold {lean_cold[0]:.3f} s wall, {lean_cold[1]:.3f} s CPU; warm median '
          f'{np.median([w for w, _ in lean_warm]):.3f} s wall, {np.median([c for _, c in lean_warm]):.3f} s CPU')

    r_f, v_f = problem.end_state(T_TABLE1_S)
    bound = delta_v_lower_bound(problem.r0_hill, problem.v0_hill, r_f, v_f, T_TABLE1_S, ACCEL_TABLE1_MPS2, problem.n)
    lean_dv = plan_terms(problem, lean.plans[0]).delta_v_mps
    print(f'least delta-v for {T_TABLE1_S} s, {ACCEL_TABLE1_MPS2} m/s^2: >= {bound.lower_mps:.4f} m/s (dual bound), '
          f'{bound.held_mps:.4f} m/s reached by held thrust on {bound.steps} steps (no keep-out, no plume); SCP '
          f'k_s = 0: {lean_dv:.4f} m/s, {100.0 * (lean_dv / bound.lower_mps - 1.0):.1f} % above')
    # The least delta-v of a path that meets what the flown path must (keep-out, the plume rule, the time and the
    # acceleration bound): SCP minimizing fuel alone (= delta-v) on finer grids, the least it finds from two starts
    # (the plume-constrained least-fuel problem has many local optima): the heuristic route, and the plan of a
    # smaller plume sphere (continuation); the mission's least-fuel settings but the grid, each plan
    # counted only if it keeps the plume rule and clears the true geometry on dense samples
    found = {}
    for steps in args.bound_steps:
        settings = dataclasses.replace(LEAST_FUEL_SCP, steps=steps)
        small = dataclasses.replace(least_fuel, plume_radius_m=0.7 * args.plume_radius)
        for label, initial in (('route', None),
                               (f'{small.plume_radius_m:g} m sphere', plan_scp([small], settings,
                                                                               duration_s=T_TABLE1_S).plans)):
            start = time.perf_counter()
            plans = plan_scp([least_fuel], settings, duration_s=T_TABLE1_S, initial=initial).plans
            if plans is None:
                continue
            terms, clear = plan_terms(problem, plans[0]), _truth_clearance_m(sc, plans[0])
            valid = terms.plume == 0.0 and clear > 0.0
            if valid:
                found[(steps, label)] = terms.delta_v_mps
            print(f'least delta-v with keep-out and the {args.plume_radius:g} m plume rule, SCP k_s = 0 on {steps} '
                  f'steps from the {label}: {terms.delta_v_mps:.4f} m/s ({time.perf_counter() - start:.1f} s; '
                  f'plume {terms.plume:.1e}, true clearance {clear:.3f} m{"" if valid else ", not counted"})')
    if found:
        least = min(found, key=found.get)
        print(f'least delta-v found with keep-out and plume: {found[least]:.4f} m/s ({least[0]} steps, from the '
              f'{least[1]}); 5 % above it: {1.05 * found[least]:.4f} m/s')
    m_over_isp = FUEL_TABLE1_KG * 9.80665 / bound.lower_mps
    print(f'Table 1: {T_TABLE1_S} s, ~{FUEL_TABLE1_KG} kg, {ACCEL_TABLE1_MPS2} m/s^2; {FUEL_TABLE1_KG} kg at the least '
          f'delta-v needs m / Isp >= {m_over_isp:.2f} kg/s (e.g. {m_over_isp * 220.0:.0f} kg at 220 s)')

    if args.figures:
        _figures(args.figures, sc, problem, {'Nelder-Mead': nm.plans[0], 'SCP': scp.plans[0]})

    if args.free_time:
        print('\nT free (eq 5 k_t T^2):')
        print(HEADER)
        start = time.perf_counter()
        nm_free = plan_nelder_mead([problem], NelderMeadSettings(waypoints_max=args.waypoints_max),
                                   duration0_s=T_TABLE1_S)
        print(_row(f'Nelder-Mead, n = {nm_free.waypoints}', sc, problem, nm_free.plans[0],
                   time.perf_counter() - start))
        start = time.perf_counter()
        scp_free = plan_scp([problem])
        print(_row('SCP', sc, problem, scp_free.plans[0], time.perf_counter() - start))
        print(f'SCP tried T = {[round(t, 1) for t in scp_free.durations_s]}')

    if args.two_robots:
        print('\ntwo robots (+-50 m V-bar, grasp points [1.5, 0, 1.5] and [-1.5, 0, -1.5] body), T 58.9 s:')
        minus = approach_problem(sc, prediction, [-50.0, 0.0, 0.0], np.zeros(3), 0.0, args.plume_radius,
                                 x_grasp_body=[-1.5, 0.0, -1.5], chaser=chaser)
        pair = [problem, minus]
        tau = np.linspace(0.0, T_TABLE1_S, 5891)
        for label, solve in (('Nelder-Mead', lambda: plan_nelder_mead(pair, NelderMeadSettings(waypoints_max=2),
                                                                       duration_s=T_TABLE1_S).plans),
                             ('SCP', lambda: plan_scp(pair, duration_s=T_TABLE1_S).plans)):
            start = time.perf_counter()
            plans = solve()
            took = time.perf_counter() - start
            a, b = (plan.sample(tau) for plan in plans)
            apart = np.linalg.norm(a.r_hill - b.r_hill, axis=1).min() - 2.0 * chaser.envelope_radius_m
            print(f'  {label:<12} P {total_cost(pair, plans, 600):8.3f}, least gap between the envelopes '
                  f'{apart:6.2f} m, to the target {min(_truth_clearance_m(sc, p) for p in plans):6.3f} m, '
                  f'compute {took:6.2f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
