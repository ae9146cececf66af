#!/usr/bin/env python3
"""Benchmark of the chaser's pointing of body +x at the target's centre of mass on the reaction wheels.

    benchmark_pointing.py [--periods 0.1 0.5 1.0] [--mission scenarios/paper_flyby.yaml]

Seed 001's servicer (inertia diag(13, 38, 35) kg m^2, Table 1) on three orthogonal wheels (0.1 N m, 4 N m s,
spin inertia 0.01 kg m^2), ``AttitudeGuidance`` with its defaults (omega_n 0.2 rad/s, zeta 1, omega_max
0.05 rad/s), closed loop through ``GyrostatPropagator`` (``attitude_guidance.simulate_pointing``): each
command held for one control period and applied one period after the estimates it was computed from, the
attitude and rate estimates the truth plus 0.01 deg and 1e-5 rad/s per axis (seeded), gravity gradient on,
restriction sphere 15 m (no thruster inside). Prints the pointing error percentiles (true body +x against the
true line of sight), the peak wheel momentum and torque, and the cost of one guidance command, for:

* the fly-by of test_attitude_guidance.py: CW coast from 150 s before to 150 s after a closest approach of
  5 m at 0.2 m/s (passing 11 deg from R-bar, where the roll rule is singular; line of sight up to 2.3 deg/s);
* the same at 3 m (3.8 deg/s, the wheels' torque limit reached);
* momentum dumping: the chaser held pointing from 30 m on V-bar (outside the sphere) with wheel momenta
  (1.5, -1.2, 0.8) N m s: how long until every axis is within 0.2 N m s, the pointing error meanwhile, and the
  thrusters' impulse and fuel (the dump torques allocated to the default layout and fired, ``actuators``);
* with ``--mission``: the scenario flown headless (today's point-mass chaser, flyby_mission.headless), its
  true relative path and its estimator's relative estimates replayed from the first terminal burn to the grasp
  (the window of the pointing requirement), the chaser on its goal at the first burn.

docs/guidance.md ("The chaser's attitude") quotes these figures.
"""

import argparse
import time

import numpy as np
from pointing_cases import (
    ATTITUDE_SIGMA_RAD,
    RATE_SIGMA_RAD_S,
    SEED001_SERVICER,
    SPHERE_M,
    WHEELS,
    N,
    command_cost,
    dumping,
    flyby_path,
    report,
)

from flyby_guidance.attitude_guidance import (
    AttitudeGuidance,
    AttitudeGuidanceConfig,
    simulate_pointing,
)
from flyby_sim.dynamics.rigid_body import GyrostatPropagator


def synthetic(periods):
    for closest_m in (5.0, 3.0):
        path = flyby_path(closest_m, 0.2, 150.0)
        for period in periods:
            for noisy in (True, False):
                if not noisy and (closest_m != 5.0 or period != periods[0]):
                    continue
                guidance = AttitudeGuidance(AttitudeGuidanceConfig(control_period_s=period), SEED001_SERVICER,
                                            WHEELS)
                t0 = time.perf_counter()
                run = simulate_pointing(guidance, GyrostatPropagator(SEED001_SERVICER, WHEELS), path, 0.0, 300.0, N,
                                        rng=np.random.default_rng(13) if noisy else None,
                                        attitude_sigma_rad=ATTITUDE_SIGMA_RAD, rate_sigma_rad_s=RATE_SIGMA_RAD_S,
                                        restriction_sphere_radius_m=SPHERE_M)
                wall = time.perf_counter() - t0
                errors = 'estimation errors' if noisy else 'perfect estimates'
                report(f'fly-by {closest_m:g} m at 0.2 m/s, period {period:g} s, {errors} ({wall:.1f} s wall)', run)


def mission(scenario_path, periods):
    # imported here: the headless mission needs every package, the synthetic cases only the cores
    import flyby_mission.headless as closed_loop
    from flyby_estimation.estimator_core import ChaserEstimate
    from flyby_sim.scenario import load_scenario

    scenario = load_scenario(scenario_path)
    estimates = []
    graphs = []
    deliver = closed_loop.HeadlessGraph._deliver

    def recording_deliver(graph, out):
        if not graphs:
            graphs.append(graph)
        if isinstance(out, ChaserEstimate):
            estimates.append((out.t, *out.r_hill, *out.v_hill))
        return deliver(graph, out)

    closed_loop.HeadlessGraph._deliver = recording_deliver
    try:
        t0 = time.perf_counter()
        run = closed_loop.run_headless(scenario)
    finally:
        closed_loop.HeadlessGraph._deliver = deliver
    summary = run.summary
    truth = graphs[0].truth
    t_truth = np.array(truth.t, dtype=float)
    r_truth, v_truth = np.array(truth.r), np.array(truth.v)
    est = np.array(estimates)
    t_first = min(b['t'] for b in run.burns)
    t_grasp = summary['t_grasp_s']
    print(f'{scenario.name} headless: {summary["outcome"]} in {time.perf_counter() - t0:.1f} s wall; first terminal '
          f'burn {t_first:.1f} s, grasp {t_grasp:.2f} s, range at the grasp '
          f'{np.linalg.norm(np.array([np.interp(t_grasp, t_truth, r_truth[:, i]) for i in range(3)])):.2f} m')
    n = scenario.mean_motion_rad_s

    def path(t):
        return (np.array([np.interp(t, t_truth, r_truth[:, i]) for i in range(3)]),
                np.array([np.interp(t, t_truth, v_truth[:, i]) for i in range(3)]))

    def estimate(t):
        k = max(int(np.searchsorted(est[:, 0], t + 1e-9)) - 1, 0)  # the latest estimate stamped at or before t
        return est[k, 1:4], est[k, 4:7]

    for period in periods:
        guidance = AttitudeGuidance(AttitudeGuidanceConfig(control_period_s=period), SEED001_SERVICER, WHEELS)
        result = simulate_pointing(guidance, GyrostatPropagator(SEED001_SERVICER, WHEELS), path, t_first,
                                   t_grasp, n, rng=np.random.default_rng(13), attitude_sigma_rad=ATTITUDE_SIGMA_RAD,
                                   rate_sigma_rad_s=RATE_SIGMA_RAD_S,
                                   restriction_sphere_radius_m=scenario.planner.restriction_sphere_radius_m,
                                   estimate=estimate)
        report(f'{scenario.name}, first terminal burn to grasp, period {period:g} s', result)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--periods', type=float, nargs='+', default=[0.1, 0.5, 1.0],
                        help='control periods [s] to measure (default 0.1 0.5 1.0)')
    parser.add_argument('--mission', help='also replay the headless fly-by of this scenario (e.g. '
                        'scenarios/paper_flyby.yaml)')
    args = parser.parse_args()
    synthetic(args.periods)
    dumping()
    command_cost()
    if args.mission:
        mission(args.mission, args.periods)


if __name__ == '__main__':
    main()
