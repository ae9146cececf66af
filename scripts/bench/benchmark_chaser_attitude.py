#!/usr/bin/env python3
"""Benchmark of the chaser's attitude filter: accuracy, consistency and cost.

    benchmark_chaser_attitude.py [--runs 50] [--duration 300] [--hold-runs 10]

Runs the filter (flyby_estimation.chaser_attitude_filter, the default IMU: gyro 10 Hz with
1e-5 rad/s noise, 1e-4 rad/s initial bias and 1e-7 rad/s/sqrt(s) bias walk, star tracker 2 Hz with
0.01 deg) over seeded torque-free tumbles of seed 001's servicer (2.9 deg/s about a random axis), the
truth and measurements drawn by the test module's generator (test_chaser_attitude_filter.simulate_imu,
the sensor model written out independently of flyby_sim.sensors). Prints:

- the steady-state 1-sigma attitude error per body axis (rms over the runs and every IMU sample of the
  last third of the runs) against the star tracker's sigma, the filter's own sigma and the Riccati
  steady state of its model (chaser_attitude_filter.steady_state);
- the bias error at the end and its steady state;
- the 6-state NEES averaged over the runs, against the 95 % chi-square band;
- the same NEES with the gyro samples held instead of interpolated ('hold', --hold-runs of the runs);
- the cost of a gyro step (on_gyro) and of a star-tracker update (on_star_tracker), in microseconds.
"""

import argparse
import dataclasses
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.stats import chi2

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / 'flyby_ws' / 'src' / 'flyby_estimation' / 'test'))  # the generator lives there

import test_chaser_attitude_filter as model  # noqa: E402

from flyby_estimation.chaser_attitude_filter import ChaserAttitudeFilter, steady_state  # noqa: E402


def nees_figures(t, runs, start_s=5.0):
    """(mean NEES over the runs and every sample from start_s, fraction of whole seconds inside the band, band)."""
    n = len(runs)
    mean = np.mean([r.nees for r in runs], axis=0)
    band = (chi2.ppf(0.025, 6 * n) / n, chi2.ppf(0.975, 6 * n) / n)
    seconds = (t >= start_s) & (np.round(t * model.CONFIG.rate_hz) % model.CONFIG.rate_hz == 0)
    inside = float(np.mean((mean[seconds] >= band[0]) & (mean[seconds] <= band[1])))
    return float(mean[t >= start_s].mean()), inside, band


def update_costs(run, config):
    """Microseconds per on_gyro and per on_star_tracker call over one run (perf_counter around each call)."""
    f = ChaserAttitudeFilter(config)
    gyro, star = [], []
    for k in range(run.t.size):
        t0 = time.perf_counter()
        f.on_gyro(run.t[k], run.omega_meas[k])
        t1 = time.perf_counter()
        gyro.append(t1 - t0)
        if k in run.star:
            t0 = time.perf_counter()
            f.on_star_tracker(run.t[k], run.star[k])
            star.append(time.perf_counter() - t0)
    return np.array(gyro[1:]) * 1e6, np.array(star[1:]) * 1e6


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--runs', type=int, default=model.NEES_RUNS)
    ap.add_argument('--duration', type=float, default=model.NEES_DURATION_S, help='seconds per run')
    ap.add_argument('--hold-runs', type=int, default=10, help="runs flown again with gyro_interpolation='hold'")
    args = ap.parse_args()
    config = model.CONFIG
    sigma_st = config.star_tracker_sigma_rad
    t_wall = time.perf_counter()
    t, runs = model.campaign(args.runs, args.duration, config)
    wall = time.perf_counter() - t_wall
    print(f"{args.runs} runs x {args.duration:g} s, 2.9 deg/s tumble of seed 001's servicer, sigma_st = "
          f'{math.degrees(sigma_st):g} deg, gyro {config.rate_hz:g} Hz, star tracker '
          f'{config.star_tracker_rate_hz:g} Hz ({wall:.1f} s wall)')

    window = t >= 2.0 * args.duration / 3.0
    error = np.concatenate([r.error[window, :3] for r in runs])
    rms = np.sqrt(np.mean(error ** 2, axis=0))
    sigma_filter = np.sqrt(np.mean(np.concatenate([np.diagonal(r.covariance[window], axis1=1, axis2=2)[:, :3]
                                                   for r in runs]), axis=0))
    fixed, turning = steady_state(config), steady_state(config, (0.0, 0.0, model.TUMBLE_RATE_RAD_S))
    ratio = ' '.join(f'{x:.3f}' for x in rms / sigma_st)
    print(f'steady-state attitude error, 1 sigma per body axis (t >= {t[window][0]:.0f} s, every IMU sample): '
          f'{ratio} sigma_st = {" ".join(f"{math.degrees(x) * 3600:.2f}" for x in rms)} arcsec')
    print(f'  filter sigma {" ".join(f"{x:.3f}" for x in sigma_filter / sigma_st)} sigma_st; Riccati steady state '
          f'{fixed.attitude_sigma_rad[0] / sigma_st:.3f} sigma_st (inertially fixed), '
          f'{turning.attitude_sigma_rad[0] / sigma_st:.3f} across and {turning.attitude_sigma_rad[2] / sigma_st:.3f} '
          f'along the axis of a 2.9 deg/s spin')
    bias_error = np.array([r.error[-1, 3:] for r in runs])
    bias_sigma = np.sqrt(np.mean([np.diag(r.covariance[-1])[3:] for r in runs], axis=0))
    bias_rms = np.sqrt(np.mean(bias_error ** 2, axis=0))
    print(f'bias error at {t[-1]:.0f} s, rms per axis: {" ".join(f"{x:.2e}" for x in bias_rms)} '
          f'rad/s (filter sigma {" ".join(f"{x:.2e}" for x in bias_sigma)}, steady state '
          f'{fixed.bias_sigma_rad_s[0]:.2e}; initial sigma {config.gyro_bias_sigma_rad_s:.0e})')
    mean, inside, band = nees_figures(t, runs)
    outliers = sum(res.kind == 'outlier' for r in runs for res in r.results)
    print(f'NEES (6 dof), mean over {args.runs} runs and t >= 5 s: {mean:.2f}; band [{band[0]:.2f}, {band[1]:.2f}], '
          f'{100 * inside:.0f} % of the whole seconds inside; {outliers} of '
          f'{sum(len(r.results) for r in runs)} star-tracker samples gated')
    if args.hold_runs:
        hold = dataclasses.replace(config, gyro_interpolation='hold')
        t_h, held = model.campaign(args.hold_runs, args.duration, hold)
        linear = runs[:args.hold_runs]
        m_h, in_h, band_h = nees_figures(t_h, held)
        m_l, in_l, _ = nees_figures(t_h, linear)
        print(f"gyro held instead of interpolated ('hold'), {args.hold_runs} runs: NEES {m_h:.2f} "
              f'({100 * in_h:.0f} % inside [{band_h[0]:.2f}, {band_h[1]:.2f}]) against {m_l:.2f} ({100 * in_l:.0f} %) '
              f'interpolated; gated samples {sum(res.kind == "outlier" for r in held for res in r.results)}')
    gyro, star = update_costs(model.tumble_run(0, config, min(args.duration, 300.0)), config)
    print(f'cost: gyro step median {np.median(gyro):.0f} us (p99 {np.percentile(gyro, 99):.0f}), star-tracker update '
          f'median {np.median(star):.0f} us (p99 {np.percentile(star, 99):.0f}); per second of IMU data at '
          f'{config.rate_hz:g} + {config.star_tracker_rate_hz:g} Hz: '
          f'{(config.rate_hz * np.median(gyro) + config.star_tracker_rate_hz * np.median(star)) / 1e3:.2f} ms')


if __name__ == '__main__':
    main()
