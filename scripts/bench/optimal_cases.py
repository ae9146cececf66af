"""The cases of scripts/bench/benchmark_optimal.py besides its side-by-side table: the table's row, the least
delta-v bracket, T free, the two robots (seed 003 Table 1 and Fig 12)."""

import dataclasses
import time

import numpy as np

from flyby_planner.optimal.approach import LEAST_FUEL_SCP, ApproachSettings
from flyby_planner.optimal.baseline import NelderMeadSettings, plan_nelder_mead
from flyby_planner.optimal.cost import plan_terms, total_cost
from flyby_planner.optimal.delta_v_bound import delta_v_lower_bound
from flyby_planner.optimal.problem import approach_problem
from flyby_planner.optimal.scp import plan_scp
from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.geometry import clearance
from flyby_sim.dynamics.orbital import q_eci_from_body, q_hill_from_body_many
from flyby_sim.dynamics.propulsion import fuel_for_delta_v_kg

T_TABLE1_S = 58.9
ACCEL_TABLE1_MPS2 = 0.138
FUEL_TABLE1_KG = 1.05

def truth_clearance_m(scenario, plan):
    """Least gap [m] of the chaser envelope to the boxes turned by the true attitude, every 10 ms of the plan."""
    n = scenario.mean_motion_rad_s
    tau = np.linspace(0.0, plan.duration_s, int(round(plan.duration_s / 0.01)) + 1)
    truth = AttitudePropagator(q_eci_from_body(0.0, n, scenario.q_hill_from_body0), scenario.omega_body0_rad_s,
                               scenario.target_inertia)
    q_eci, _ = truth.states_at(plan.t0_s + tau)
    boxes = list(zip(scenario.boxes.center_body_m, scenario.boxes.size_m, strict=True))
    return float(clearance(plan.sample(tau).r_hill, q_hill_from_body_many(plan.t0_s + tau, n, q_eci), boxes,
                           scenario.chaser.envelope_radius_m).min())


def row(label, scenario, problem, plan, compute_s):
    """One line of the table (HEADER): eq 5's terms of the plan, its delta-v, fuel, duration, peak acceleration,
    least true clearance and compute time."""
    t = plan_terms(problem, plan)
    fuel_kg = fuel_for_delta_v_kg(problem.chaser.mass_kg, t.delta_v_mps, problem.chaser.exhaust_velocity_mps)
    return (f'{label:<22} {t.actuator:8.4f} {t.fuel:7.3f} {t.safety:7.3f} {t.plume:7.4f} {t.time:6.3f} '
            f'{t.total:8.3f} | {t.delta_v_mps:6.3f} {fuel_kg:6.3f} {t.duration_s:6.1f} {t.peak_accel_mps2:6.4f} '
            f'{truth_clearance_m(scenario, plan):6.3f} {compute_s:8.3f}')


HEADER = (f'{"plan":<22} {"k_a a":>8} {"k_f f":>7} {"k_s s":>7} {"k_pi pi":>7} {"k_t T2":>6} {"P eq 5":>8} | '
          f'{"dv m/s":>6} {"fuel kg":>6} {"T s":>6} {"a_max":>6} {"clear m":>6} {"compute s":>8}')


def least_delta_v(sc, problem, least_fuel, lean, bound_steps, plume_radius_m):
    """The least delta-v bracket for T_TABLE1_S and ACCEL_TABLE1_MPS2 (delta_v_lower_bound), the least found with
    keep-out and the plume rule on the grids bound_steps, and what Table 1's fuel asks of the chaser."""
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
    for steps in bound_steps:
        settings = dataclasses.replace(LEAST_FUEL_SCP, steps=steps)
        small = dataclasses.replace(least_fuel, plume_radius_m=0.7 * plume_radius_m)
        for label, initial in (('route', None),
                               (f'{small.plume_radius_m:g} m sphere', plan_scp([small], settings,
                                                                               duration_s=T_TABLE1_S).plans)):
            start = time.perf_counter()
            plans = plan_scp([least_fuel], settings, duration_s=T_TABLE1_S, initial=initial).plans
            if plans is None:
                continue
            terms, clear = plan_terms(problem, plans[0]), truth_clearance_m(sc, plans[0])
            valid = terms.plume == 0.0 and clear > 0.0
            if valid:
                found[(steps, label)] = terms.delta_v_mps
            print(f'least delta-v with keep-out and the {plume_radius_m:g} m plume rule, SCP k_s = 0 on {steps} '
                  f'steps from the {label}: {terms.delta_v_mps:.4f} m/s ({time.perf_counter() - start:.1f} s; '
                  f'plume {terms.plume:.1e}, true clearance {clear:.3f} m{"" if valid else ", not counted"})')
    if found:
        least = min(found, key=found.get)
        print(f'least delta-v found with keep-out and plume: {found[least]:.4f} m/s ({least[0]} steps, from the '
              f'{least[1]}); 5 % above it: {1.05 * found[least]:.4f} m/s')
    m_over_isp = FUEL_TABLE1_KG * 9.80665 / bound.lower_mps
    print(f'Table 1: {T_TABLE1_S} s, ~{FUEL_TABLE1_KG} kg, {ACCEL_TABLE1_MPS2} m/s^2; {FUEL_TABLE1_KG} kg at the least '
          f'delta-v needs m / Isp >= {m_over_isp:.2f} kg/s (e.g. {m_over_isp * 220.0:.0f} kg at 220 s)')


def free_time(sc, problem, waypoints_max):
    """Both solvers choosing T as well (eq 5's k_t T^2)."""
    print('\nT free (eq 5 k_t T^2):')
    print(HEADER)
    start = time.perf_counter()
    nm_free = plan_nelder_mead([problem], NelderMeadSettings(waypoints_max=waypoints_max),
                               duration0_s=T_TABLE1_S)
    print(row(f'Nelder-Mead, n = {nm_free.waypoints}', sc, problem, nm_free.plans[0],
              time.perf_counter() - start))
    start = time.perf_counter()
    scp_free = plan_scp([problem])
    print(row('SCP', sc, problem, scp_free.plans[0], time.perf_counter() - start))
    print(f'SCP tried T = {[round(t, 1) for t in scp_free.durations_s]}')


def two_robots(sc, prediction, problem, chaser, plume_radius_m):
    """The +-50 m V-bar pair of seed 003 Fig 12 by both solvers: eq 5's cost and the least gaps."""
    print('\ntwo robots (+-50 m V-bar, grasp points [1.5, 0, 1.5] and [-1.5, 0, -1.5] body), T 58.9 s:')
    minus = approach_problem(ApproachSettings.from_scenario(sc), prediction, [-50.0, 0.0, 0.0], np.zeros(3), 0.0,
                             plume_radius_m, x_grasp_body=[-1.5, 0.0, -1.5], chaser=chaser)
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
              f'{apart:6.2f} m, to the target {min(truth_clearance_m(sc, p) for p in plans):6.3f} m, '
              f'compute {took:6.2f} s')
