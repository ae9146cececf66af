#!/usr/bin/env python3
"""The mission's mass-property filter against the truth over seeded headless runs (its consistency):
the final estimate the estimator publishes (``mass_estimation_run.MassEstimationRun``), truth minus estimate in the
filter's coordinates (``mass_properties_errors.parameter_error``) with the filter's own covariance; prints the mean NEES
over the defined parameters with its 95 % band, the RMS z per parameter, and the accuracy figures of summary.json
(95th percentile). Asserts nothing (docs/post_capture.md).

    nice .venv/bin/python scripts/mass_estimation_consistency.py --scenario scenarios/matsunaga_tugrobot.yaml \\
        --set post_capture.mass_estimation.excitation=chosen --runs 50 --jobs 2

--set KEY=VALUE (repeatable) changes the scenario's YAML before it is validated (VALUE parsed as YAML), e.g.
sensors.chaser_imu.gyro_bias_sigma_rad_s=0 to take an effect out of the truth.
"""

import json
import multiprocessing
from pathlib import Path

import numpy as np
import yaml
from scipy.stats import chi2

from flyby_estimation.mass_estimation_run import principal_axes
from flyby_estimation.mass_properties_errors import defined_parameters, parameter_error, parameter_nees
from flyby_mission import cli
from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_mission.post_capture_figures import post_capture_truth, target_mass_properties_truth
from flyby_msgs_py.schema import load_yaml_mapping
from flyby_sim.scenario import scenario_from_dict

ACCURACY_KEYS = (('target_mass_error_pct', 'mass', '%', 1.0), ('target_com_error_m', 'CoM', 'mm', 1e3),
                 ('target_principal_moments_error_pct', 'moments (worst)', '%', 1.0),
                 ('target_principal_axes_error_deg', 'axes (defined)', 'deg', 1.0))
PARAMETERS = ('M', 'dphi1', 'dphi2', 'dphi3', 'Xs1', 'Xs2', 'Xs3', 'j1', 'j2', 'j3')


def scenario_with(path, seed, settings):
    """The scenario at path with seed and each (dotted key, value) of settings set in its YAML."""
    data = load_yaml_mapping(path)
    for key, value in settings:
        node = data
        *parents, leaf = key.split('.')
        for name in parents:
            node = node.setdefault(name, {})
        node[leaf] = value
    return scenario_from_dict(data, name=str(path), seed=seed, path=path)


def one_run(job):
    """One seeded mission: its accuracy figures, the final estimate's parameter error, NEES and z."""
    path, seed, settings = job
    scenario = scenario_with(path, seed, settings)
    graph = HeadlessGraph(scenario)
    summary = run_headless(scenario, graph).summary
    run = graph.estimator.mass_run
    estimate = run.filter.state()
    chaser, target, thrust, wheels = graph.truth.series()
    common, i_c, i_t, _ = post_capture_truth(chaser, target, wheels, thrust, scenario)
    k = int(np.searchsorted(common, estimate.t - 1e-9))
    x_s, moments, q_true = target_mass_properties_truth(chaser, target, i_c[k], i_t[k], scenario)
    error = parameter_error(estimate, scenario.target.mass_kg, x_s, q_true, moments)
    nees, z = parameter_nees(estimate, error, moments)
    return {'seed': seed, 'nees': nees, 'z': z.tolist(), 'error': error.tolist(),
            'imu_rejected': int(run.filter.imu_counts.get('outlier', 0)),
            **{key: summary.get(key) for key, *_ in ACCURACY_KEYS}}


def main(argv=None):
    ap = cli.OneLineParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--scenario', required=True)
    ap.add_argument('--set', action='append', default=[], metavar='KEY=VALUE', help='scenario override (YAML value)')
    ap.add_argument('--runs', type=cli.int_at_least(1), default=50)
    ap.add_argument('--first-seed', type=cli.seed, default=1)
    ap.add_argument('--jobs', type=cli.processes, default=2)
    ap.add_argument('--json', help='write every run as JSON here')
    args = ap.parse_args(argv)
    cli.check_seed_span(ap, args.first_seed, args.runs)
    settings = [(k, yaml.safe_load(v)) for k, v in (s.split('=', 1) for s in args.set)]
    moments, _ = principal_axes(scenario_with(args.scenario, None, settings).target_inertia)
    dof = len(defined_parameters(moments))
    jobs = [(args.scenario, args.first_seed + i, settings) for i in range(args.runs)]
    with multiprocessing.Pool(args.jobs) as pool:
        runs = pool.map(one_run, jobs)
    nees = np.array([r['nees'] for r in runs])
    z = np.array([r['z'] for r in runs])
    lo, hi = chi2.ppf([0.025, 0.975], dof * len(runs)) / len(runs)
    print(f'{args.scenario} {" ".join(args.set)}: {len(runs)} runs, seeds {args.first_seed}-'
          f'{args.first_seed + len(runs) - 1}')
    print(f'mean NEES ({dof} defined parameters) {nees.mean():.2f}, 95 % band [{lo:.2f}, {hi:.2f}], median '
          f'{np.median(nees):.2f}, runs above chi2({dof}) 99.9 %: {int(np.sum(nees > chi2.ppf(0.999, dof)))}')
    rms = np.sqrt(np.mean(z ** 2, axis=0))
    mean = np.mean(z, axis=0)
    print('RMS z  ' + ', '.join(f'{p} {v:.2f}' for p, v in zip(PARAMETERS, rms, strict=True)))
    print('mean z ' + ', '.join(f'{p} {v:+.2f}' for p, v in zip(PARAMETERS, mean, strict=True)))
    print(f'IMU samples rejected: median {np.median([r["imu_rejected"] for r in runs]):.0f}, max '
          f'{max(r["imu_rejected"] for r in runs)}')
    for key, label, unit, scale in ACCURACY_KEYS:
        a = np.array([r[key] for r in runs], dtype=float) * scale
        print(f'{label} error: median {np.median(a):.4g} {unit}, 95th percentile {np.percentile(a, 95):.4g} {unit}, '
              f'max {a.max():.4g} {unit}')
    if args.json:
        Path(args.json).write_text(json.dumps(runs, indent=1))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
