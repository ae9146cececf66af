#!/usr/bin/env python3
"""Monte Carlo consistency and accuracy of the target attitude filter on the pure Plant.

    estimation_consistency.py [--runs 50] [--scenario scenarios/paper_flyby.yaml] [--duration 120]
                              [--settle 30] [--horizon 600] [--accuracy-time 60] [--jobs 2]

Run k uses the scenario with seed = first_seed + k (the Plant's sensor noise; DESIGN: seeded streams).
Each run feeds the Plant's vision attitude measurements (10 Hz) to a fresh TargetAttitudeFilter for
`duration` seconds after the first measurement and records, once per second, the 6-dof error
e = [dtheta_body, domega_body] (true relative to estimated) and its NEES e' P^-1 e.

Consistency (Bar-Shalom, Li, Kirubarajan 2001, section 5.4): at each time after `settle` seconds the
average NEES over the N runs must lie in the two-sided 95 % band chi2.ppf([0.025, 0.975], 6 N) / N.
The script prints the time average of the ensemble-average NEES (the figure the band is applied to)
and the fraction of time points inside the band.

Accuracy: attitude and rate errors at `accuracy-time` (default 60 s) after the first measurement, and
the error of the grasp point (scenario target.grasp_point_body_m) predicted `horizon` seconds past
that time (seed 000 eq 8),
against the true attitude integrated by flyby_sim.dynamics.attitude.AttitudePropagator from the Plant's
initial state (the Plant's own integrator and tolerances). With each figure, the number of runs that
meet the limit of --limits.

Efficiency: at `accuracy-time` each run's fused measurements are also fitted at once by the batch
maximum-likelihood estimator (flyby_estimation.batch). The script prints the largest gap between the
filter's state and that fit in units of the fit's sigma, the range of the eigenvalues of
CRB^-1/2 P CRB^-1/2 (1 = the filter's covariance is the Cramer-Rao bound), the bound's 1-sigma of the
rate, and the probability that a rate error distributed as the bound is below the limit (Anderson:
no unbiased Gaussian estimator does better; a seeded Monte Carlo draw).
"""

import concurrent.futures
import math
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from flyby_mission import cli
from flyby_mission.estimation_consistency import run_one
from flyby_sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def summarize(values, unit, fmt='.4g', limit=None):
    v = np.asarray(values)
    text = (f'median {np.median(v):{fmt}} {unit}, 95th pct {np.percentile(v, 95):{fmt}} {unit}, '
            f'max {v.max():{fmt}} {unit}')
    return text if limit is None else f'{text}; < {limit:g} {unit} in {int(np.sum(v < limit))}/{v.size} runs'


def probability_below(covariances, limit, draws=20000, seed=0):
    """P(|x| < limit) for x ~ N(0, C), averaged over the runs' covariances (seeded Monte Carlo)."""
    rng = np.random.default_rng(seed)
    return float(np.mean([np.mean(np.linalg.norm(rng.multivariate_normal(np.zeros(3), c, draws), axis=1) < limit)
                          for c in covariances]))


def main():
    ap = cli.OneLineParser(description=__doc__.split('\n')[0])
    ap.add_argument('--scenario', default=str(ROOT / 'scenarios' / 'paper_flyby.yaml'))
    ap.add_argument('--runs', type=cli.int_at_least(1), default=50)
    ap.add_argument('--first-seed', type=cli.seed, default=0)
    ap.add_argument('--duration', type=cli.float_above(0), default=120.0,
                    help='seconds of data per run after the first')
    ap.add_argument('--settle', type=cli.float_at_least(0), default=30.0, help='NEES is averaged from this time on [s]')
    ap.add_argument('--horizon', type=cli.float_at_least(0), default=600.0,
                    help='grasp-point prediction horizon past 60 s')
    ap.add_argument('--accuracy-time', type=cli.float_at_least(0), default=60.0,
                    help='accuracy figures this long after the first measurement [s]')
    ap.add_argument('--limits', type=cli.float_above(0), nargs=3, default=(0.3, 0.01, 0.05),
                    metavar=('DEG', 'DEG_S', 'M'),
                    help='limits of the attitude error, the rate error and the grasp-point prediction error')
    ap.add_argument('--jobs', type=cli.processes, default=2)
    args = ap.parse_args()
    cli.check_seed_span(ap, args.first_seed, args.runs)
    if args.duration < args.accuracy_time:
        ap.error('--duration must be >= --accuracy-time')

    seeds = range(args.first_seed, args.first_seed + args.runs)
    with concurrent.futures.ProcessPoolExecutor(max_workers=args.jobs) as pool:
        results = list(pool.map(run_one, [args.scenario] * args.runs, seeds, [args.duration] * args.runs,
                                [args.horizon] * args.runs, [args.accuracy_time] * args.runs))
    length = min(len(r[0]) for r in results)
    times = results[0][0][:length]
    nees = np.array([r[1][:length] for r in results])  # runs x times
    mean_nees = nees.mean(axis=0)
    mask = times >= args.settle
    n_runs = args.runs
    lo, hi = chi2.ppf([0.025, 0.975], 6 * n_runs) / n_runs
    avg = float(mean_nees[mask].mean())
    inside = float(np.mean((mean_nees[mask] >= lo) & (mean_nees[mask] <= hi)))
    name = load_scenario(args.scenario).name
    attitude_limit, rate_limit, grasp_limit = args.limits
    at = f'at {args.accuracy_time:g} s'
    print(f'{name}: {n_runs} runs (seeds {seeds.start}-{seeds.stop - 1}), {args.duration:g} s of 10 Hz vision each')
    print(f'  NEES (6 dof) averaged over runs and over t = {args.settle:g}-{times[-1]:g} s: {avg:.3f}; '
          f'95 % band for {n_runs} runs [{lo:.3f}, {hi:.3f}] -> {"INSIDE" if lo <= avg <= hi else "OUTSIDE"}; '
          f'{inside:.0%} of the {int(mask.sum())} time points inside')
    acc = [r[2] for r in results]
    print(f'  {at}: attitude error {summarize([a["attitude_deg"] for a in acc], "deg", limit=attitude_limit)}')
    print(f'  {at}: rate error {summarize([a["rate_deg_s"] for a in acc], "deg/s", limit=rate_limit)}')
    print(f'  {at}: rate error along the spin axis '
          f'{summarize([a["rate_along_spin_deg_s"] for a in acc], "deg/s", limit=rate_limit)}')
    print(f'  grasp point predicted {args.horizon:g} s past {args.accuracy_time:g} s: error '
          f'{summarize([a["grasp_err_m"] for a in acc], "m", limit=grasp_limit)}; filter 1-sigma (rss) '
          f'{np.median([a["grasp_sigma_m"] for a in acc]):.4g} m')
    print(f'  converged (3-sigma < 1 deg, 0.05 deg/s) {at} in {sum(a["converged"] for a in acc)}/{n_runs} runs')
    print(f'  {at}, filter vs batch maximum-likelihood fit of the same measurements: largest state gap '
          f'{max(a["gap_sigma"] for a in acc):.3g} sigma; eigenvalues of CRB^-1/2 P CRB^-1/2 in '
          f'[{min(a["ratio_min"] for a in acc):.3f}, {max(a["ratio_max"] for a in acc):.3f}]')
    fit_rates = [a['fit_rate_deg_s'] for a in acc]
    print(f'  {at}: rate error of the batch fit {summarize(fit_rates, "deg/s", limit=rate_limit)}')
    rate_covariances = [a['crb_rate_cov'] for a in acc]
    print(f'  {at}: Cramer-Rao bound of the rate, 1-sigma rss, median '
          f'{np.median([a["crb_rate_deg_s"] for a in acc]):.4g} deg/s; P(rate error < {rate_limit:g} deg/s) '
          f'at the bound {probability_below(rate_covariances, math.radians(rate_limit)):.2f}')
    rejected = {k: sum(r[3][k] for r in results) for k in results[0][3]}
    print(f'  rejected measurements: {rejected}')


if __name__ == '__main__':
    main()
