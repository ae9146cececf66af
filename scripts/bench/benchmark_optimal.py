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
and 0.138 m/s^2 (delta_v_lower_bound) and SCP with the safety weight off (the least-fuel plan that still meets
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
from optimal_cases import ACCEL_TABLE1_MPS2, HEADER, T_TABLE1_S, free_time, least_delta_v, row, two_robots
from optimal_figures import write_figures

from flyby_msgs_py.schema import ScenarioError
from flyby_planner.flyby.config import truth_prediction
from flyby_planner.optimal.approach import LEAST_FUEL_SCP, ApproachSettings
from flyby_planner.optimal.baseline import NelderMeadSettings, plan_nelder_mead
from flyby_planner.optimal.problem import approach_problem
from flyby_planner.optimal.scp import plan_scp
from flyby_sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]


def parse_args():
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
    return ap.parse_args()


def timed(plan):
    """(plan()'s result, (its wall time, its CPU time) [s])."""
    start, cpu = time.perf_counter(), time.process_time()
    result = plan()
    return result, (time.perf_counter() - start, time.process_time() - cpu)


def side_by_side(args, sc, problem):
    """The table: Nelder-Mead, SCP (cold, then warm), SCP with k_s = 0, and the mission's least-fuel plan; the plans
    (Nelder-Mead, SCP, SCP with k_s = 0) and the least-fuel problem."""
    # SCP first: its cold plan is the process's first (cvxpy compiles its parametrized program), wall and CPU time
    scp, (cold_s, cold_cpu_s) = timed(lambda: plan_scp([problem], duration_s=T_TABLE1_S))
    start = time.perf_counter()
    nm = plan_nelder_mead([problem], NelderMeadSettings(waypoints_max=args.waypoints_max), duration_s=T_TABLE1_S)
    print(row(f'Nelder-Mead, n = {nm.waypoints}', sc, problem, nm.plans[0], time.perf_counter() - start))
    warm = [timed(lambda: plan_scp([problem], duration_s=T_TABLE1_S))[1][0] for _ in range(args.repeat)]
    print(row('SCP (warm median)', sc, problem, scp.plans[0], float(np.median(warm))))
    least_fuel = dataclasses.replace(problem, weights=dataclasses.replace(problem.weights, safety=0.0))
    start = time.perf_counter()
    lean = plan_scp([least_fuel], duration_s=T_TABLE1_S)
    print(row('SCP, k_s = 0', sc, problem, lean.plans[0], time.perf_counter() - start))
    # the least-fuel plan as the mission plans it (approach.plan_approach with k_s = 0): its first plan compiles
    # the program of that shape (cold), then warm plans
    lean_mission, lean_cold = timed(lambda: plan_scp([least_fuel], LEAST_FUEL_SCP, duration_s=T_TABLE1_S))
    lean_warm = [timed(lambda: plan_scp([least_fuel], LEAST_FUEL_SCP, duration_s=T_TABLE1_S))[1]
                 for _ in range(args.repeat)]
    print(row(f'SCP, k_s = 0, {LEAST_FUEL_SCP.steps} st', sc, problem, lean_mission.plans[0], lean_cold[0]))
    print(f'Nelder-Mead stages (n, P): {[(n, round(c, 3)) for n, c in nm.stages]}, {nm.evaluations} evaluations')
    print(f'SCP: {scp.solves} convex programs, converged {scp.converged}; cold {cold_s:.3f} s wall, {cold_cpu_s:.3f} s '
          f'CPU (first plan of the process, cvxpy compiles), warm median {np.median(warm):.3f} s, '
          f'min {min(warm):.3f} s, max {max(warm):.3f} s')
    print(f'SCP k_s = 0 on {LEAST_FUEL_SCP.steps} steps (the mission\'s least-fuel plan): {lean_mission.solves} convex '
          f'programs; cold {lean_cold[0]:.3f} s wall, {lean_cold[1]:.3f} s CPU; warm median '
          f'{np.median([w for w, _ in lean_warm]):.3f} s wall, {np.median([c for _, c in lean_warm]):.3f} s CPU')
    return nm, scp, lean, least_fuel


def main():
    args = parse_args()
    if args.repeat < 1:
        print(f'error: --repeat: must be >= 1, got {args.repeat}', file=sys.stderr)
        return 2
    try:
        sc = load_scenario(args.scenario)
    except ScenarioError as err:
        print(f'error: {err}', file=sys.stderr)
        return 2
    prediction = truth_prediction(sc, args.t0 + 400.0)
    settings = ApproachSettings.from_scenario(sc)
    chaser = dataclasses.replace(settings.chaser, accel_max_mps2=ACCEL_TABLE1_MPS2)
    problem = approach_problem(settings, prediction, sc.chaser.initial_position_hill_m,
                               sc.chaser.initial_velocity_hill_mps, args.t0, args.plume_radius, chaser=chaser)
    w = problem.weights
    print(f'{sc.name}: chaser {chaser.mass_kg:g} kg, Isp {chaser.isp_s:g} s, a_max {chaser.accel_max_mps2:g} m/s^2, '
          f'envelope {chaser.envelope_radius_m:g} m; plume radius {args.plume_radius:g} m; grasp point '
          f'{[float(v) for v in sc.target.grasp_point_body_m]} body, offset {sc.planner.offset_m:g} m')
    print(f'eq 5 weights: k_a {w.actuator:g} 1/s, k_f {w.fuel_per_kg:g} 1/kg, k_s {w.safety:g} s/m, '
          f'k_pi {w.plume:g} s/m, k_t {w.time:g} 1/s^2')
    print(HEADER)
    nm, scp, lean, least_fuel = side_by_side(args, sc, problem)
    least_delta_v(sc, problem, least_fuel, lean, args.bound_steps, args.plume_radius)
    if args.figures:
        write_figures(args.figures, sc, problem, {'Nelder-Mead': nm.plans[0], 'SCP': scp.plans[0]})
    if args.free_time:
        free_time(sc, problem, args.waypoints_max)
    if args.two_robots:
        two_robots(sc, prediction, problem, chaser, args.plume_radius)
    return 0


if __name__ == '__main__':
    sys.exit(main())
