#!/usr/bin/env python3
"""Accuracy and consistency of the mass-property filter (seed 004 §2.2) on seed 004 §3.1's TugRobot case, with
Table 1's thruster sequence and with a sequence chosen for observability at the same impulse; then the grasp
and the damping of the post-capture cores. Prints figures; asserts nothing (docs/post_capture.md).

    .venv/bin/python scripts/bench/benchmark_mass_estimation.py --runs 50 --candidates 16 --ramp-levels 10 10 10
"""

import argparse
import math
import time

import numpy as np
from grasp_damping_cases import grasp_and_damping
from scipy.stats import chi2

from flyby_estimation.mass_properties_errors import (
    defined_parameters,
    parameter_error,
    parameter_nees,
    principal_axis_errors_rad,
)
from flyby_estimation.mass_properties_excitation import (
    CHOSEN_ROWS,
    TugrobotCase,
    choose_sequence,
    default_prior,
    firings_from_rows,
    information_gain,
    run_filter,
    simulate_experiment,
    table1_firings,
    total_impulse_n_s,
    tugrobot_filter_config,
)

WINDOW_S = 25.0


def _figures(case, estimate):
    """(mass error %, CoM error cm, worst moment error %, distinct axis error deg, mass 1-sigma %, worst moment 1-sigma
    %), the NEES over the defined parameters and z per parameter of one final estimate."""
    truth_i = np.asarray(case.target_principal_moments_kg_m2)
    e = estimate
    row = (abs(e.target_mass_kg / case.target_mass_kg - 1.0) * 100.0,
           np.linalg.norm(e.target_com_body_m - case.target_com_body_m) * 100.0,
           np.max(np.abs(e.principal_moments_kg_m2 / truth_i - 1.0)) * 100.0,
           math.degrees(principal_axis_errors_rad(e.q_body_from_principal, case.q_body_from_principal)[0]),
           e.mass_sigma_kg / case.target_mass_kg * 100.0,
           np.max(e.principal_moments_sigma_kg_m2 / truth_i) * 100.0)
    err = parameter_error(e, case.target_mass_kg, case.target_com_body_m, case.q_body_from_principal, truth_i)
    return (row, *parameter_nees(e, err, truth_i))


def campaign(case, firings, runs, prior_scale=1.0, label=''):
    """The filter over ``runs`` seeded experiments; its figures printed twice: the forward filter's final estimate
    and the same after ``MassPropertyFilter.relinearize`` (the estimate the campaign returns)."""
    config = tugrobot_filter_config(case)
    out = {'forward': ([], [], []), 'relinearized': ([], [], [])}
    t0 = time.perf_counter()
    for seed in range(runs):
        rng = np.random.default_rng([16, seed])
        meas = simulate_experiment(case, firings, WINDOW_S, config, rng)
        prior = default_prior(case, rng, mass_sigma_kg=0.5 * prior_scale, com_sigma_m=0.01 * prior_scale,
                              axes_sigma_rad=math.radians(1.0) * prior_scale,
                              j_sigma=tuple(prior_scale * np.array([0.03, 0.03, 0.02])))
        f, _ = run_filter(case, firings, meas, config, prior)
        for key in out:
            if key == 'relinearized':
                f.relinearize()
            for acc, value in zip(out[key], _figures(case, f.state()), strict=True):
                acc.append(value)
    wall = time.perf_counter() - t0
    dof = len(defined_parameters(case.target_principal_moments_kg_m2))
    lo, hi = chi2.ppf([0.025, 0.975], dof * runs) / runs
    print(f'{label}: {runs} runs, {wall / runs:.2f} s per run (both), impulse {total_impulse_n_s(firings):.1f} N s, '
          f'window {WINDOW_S:.0f} s, prior x{prior_scale:g}')
    for key, (rows, nees, z) in out.items():
        rows = np.array(rows)
        p95 = np.percentile(rows, 95, axis=0)
        print(f' {key}:')
        print(f'  95th percentile  mass {p95[0]:.4f} %  CoM {p95[1]:.4f} cm  moments {p95[2]:.4f} %  '
              f'distinct axis {p95[3]:.4f} deg')
        print(f'  median 1-sigma   mass {np.median(rows[:, 4]):.4f} %  moments {np.median(rows[:, 5]):.4f} %')
        print(f'  mean NEES ({dof} parameters) {np.mean(nees):.2f}, 95 % band [{lo:.2f}, {hi:.2f}], '
              f'runs above chi2({dof}) 99.9 %: {int(np.sum(np.array(nees) > chi2.ppf(0.999, dof)))}')
        print(f'  RMS z (M, dphi, X_s, j) {np.round(np.sqrt(np.mean(np.square(z), axis=0)), 2).tolist()}')
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--runs', type=int, default=10, help='seeded runs per sequence')
    parser.add_argument('--candidates', type=int, default=16, help='random candidates of the design search')
    parser.add_argument('--wide-runs', type=int, default=3, help='runs from a ten times wider prior')
    parser.add_argument('--ramp-levels', type=float, nargs='*', default=[],
                        help='levels [%%] of the first firings of a graded design, also run (e.g. 10 10 10)')
    parser.add_argument('--skip-design', action='store_true', help='campaigns of Table 1 and CHOSEN_ROWS only')
    args = parser.parse_args()
    case = TugrobotCase()
    config = tugrobot_filter_config(case)
    campaign(case, table1_firings(), args.runs, label='Table 1')
    campaign(case, firings_from_rows(CHOSEN_ROWS), args.runs, label='chosen (CHOSEN_ROWS, on the 0.1 s grid)')
    designs = [] if args.skip_design else [('chosen', ())] + ([('graded', tuple(args.ramp_levels))]
                                                               if args.ramp_levels else [])
    for label, ramp in designs:
        t0 = time.perf_counter()
        design = choose_sequence(case, config, default_prior(case), np.random.default_rng(2026), args.candidates,
                                 ramp_levels=ramp)
        table1_gain = information_gain(case, table1_firings(), WINDOW_S, config, default_prior(case))
        print(f'design {label} (ramp {list(ramp)}): {args.candidates} candidates in {time.perf_counter() - t0:.0f} '
              f's; information gain (log det P0/P of the parameters) Table 1 {table1_gain:.2f}, chosen '
              f'{design.information_gain:.2f}, candidates {min(design.candidate_gains):.2f} to '
              f'{max(design.candidate_gains):.2f}')
        for f in design.firings:
            print(f'  firing at {f.t_start_s:5.1f} s for {f.duration_s:.3f} s, force {np.round(f.force_body_n, 3)} N')
        campaign(case, design.firings, args.runs, label=f'{label} design')
    if args.wide_runs:
        campaign(case, table1_firings(), args.wide_runs, prior_scale=10.0, label='Table 1, wide prior')
    grasp_and_damping()


if __name__ == '__main__':
    main()
