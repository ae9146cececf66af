"""Many headless missions of one scenario over consecutive seeds, in worker processes, and their statistics
(scripts/closed_loop.py --runs): each run's figures from truth and the statistics of the miss at the grasp, the
delta-v commanded against the ideal one (seed 000 eq 28-29 from the true state), the least clearance and, after a
capture, the post-capture figures. A worker's error ends the whole set in one line; no pool is left waiting."""

from concurrent.futures import ProcessPoolExecutor

import numpy as np

from flyby_mission.headless import run_headless, scaled_navigation_noise
from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_scenario

POST_CAPTURE_STATISTICS = (
    ('peak_grasp_force_n', 'peak grasp force', 'N'),
    ('final_angular_momentum_kg_m2_s', 'angular momentum after the damping', 'kg m^2/s'),
    ('damping_time_s', 'damping time', 's'), ('damping_fuel_kg', 'damping fuel', 'kg'),
    ('target_mass_error_pct', 'target mass error', '%'), ('target_com_error_m', 'target CoM error', 'm'),
    ('target_principal_moments_error_pct', 'target principal moments error', '%'),
    ('target_principal_axes_error_deg', 'target principal axes error', 'deg'))


def one_run(job):
    """The summary of one headless run (scenario path, seed, navigation noise scale), with the delta-v figures."""
    path, seed, scale = job
    scenario = load_scenario(path, seed=seed)
    if scale != 1.0:
        scenario = scaled_navigation_noise(scenario, scale)
    run = run_headless(scenario)
    return {**run.summary, 'dv_commanded_mps': run.dv_commanded_mps, 'dv_ideal_mps': run.dv_ideal_mps}


class WorkerFailed(RuntimeError):
    """A run raised in its worker process, or the worker died: the command ends with its message (one line)."""


def _failure(job, err):
    """The error a run raised in its worker: a ScenarioError as it is, any other as WorkerFailed naming the seed."""
    if isinstance(err, ScenarioError):
        return err
    return WorkerFailed(f'seed {job[1]}: {type(err).__name__}: {err}')


def run_seeds(scenario_path, first_seed, runs, nav_noise_scale, jobs):
    """The summaries of ``runs`` headless runs from seed ``first_seed`` on, in ``jobs`` processes. A worker's error
    (picklable) cancels the pending runs, lets the running ones end and is raised once the pool is gone: a pool
    still referenced at the interpreter's exit breaks its atexit hook (Python 3.11) into a traceback. A worker that
    dies breaks the pool (BrokenProcessPool) rather than leaving it waiting."""
    work = [(scenario_path, first_seed + k, nav_noise_scale) for k in range(runs)]
    results, failure = [], None
    with ProcessPoolExecutor(jobs) as pool:
        futures = [pool.submit(one_run, j) for j in work]
        for job, future in zip(work, futures, strict=True):
            try:
                results.append(future.result())
            except Exception as err:
                failure = _failure(job, err)
                pool.shutdown(wait=True, cancel_futures=True)
                break
    del pool, futures
    if failure is not None:
        raise failure.with_traceback(None)
    return results


def statistics_line(label, values, unit, scale=1.0):
    """min, median, 95th percentile and max of the values given (None left out)."""
    a = np.array([v for v in values if v is not None], dtype=float) * scale
    if a.size == 0:
        return f'{label}: no data'
    return (f'{label}: min {a.min():.4g} {unit}, median {np.median(a):.4g} {unit}, 95th percentile '
            f'{np.percentile(a, 95):.4g} {unit}, max {a.max():.4g} {unit} (n = {a.size})')


def _fmt(x, spec):
    return format(x, spec) if x is not None else format(float('nan'), spec)


def run_table(runs):
    """One line per run: seed, outcome, grasp time, miss, delta-v against the ideal, clearance, thrust inside."""
    lines = [f'{"seed":>5} {"outcome":>12} {"t_grasp":>9} {"miss_m":>8} {"miss_mm/s":>9} {"dv":>7} {"ideal":>7} '
             f'{"dv/ideal":>8} {"clear_m":>7} {"thrust_in":>9}']
    for r in runs:
        ratio = r['dv_commanded_mps'] / r['dv_ideal_mps'] if r['dv_ideal_mps'] else None
        vel = None if r['capture_velocity_error_mps'] is None else 1e3 * r['capture_velocity_error_mps']
        lines.append(f'{r["seed"]:>5} {r["outcome"]:>12} {_fmt(r["t_grasp_s"], "9.2f")} '
                     f'{_fmt(r["capture_position_error_m"], "8.4f")} {_fmt(vel, "9.3f")} '
                     f'{r["dv_commanded_mps"]:7.4f} {_fmt(r["dv_ideal_mps"], "7.4f")} {_fmt(ratio, "8.3f")} '
                     f'{_fmt(r["min_clearance_m"], "7.3f")} {str(r["thrust_inside_restriction_sphere"]):>9}')
    return lines


def statistics(runs, nav_noise_scale):
    """The statistics lines of a set of runs (module doc)."""
    flown = [r for r in runs if r['dv_ideal_mps']]
    outcomes = {o: sum(r['outcome'] == o for r in runs) for o in sorted({r['outcome'] for r in runs})}
    lines = [f'navigation noise x{nav_noise_scale:g}; outcomes {outcomes}',
             statistics_line('position miss at the grasp', [r['capture_position_error_m'] for r in flown], 'cm',
                             100.0),
             statistics_line('velocity miss at the grasp', [r['capture_velocity_error_mps'] for r in flown], 'mm/s',
                             1e3),
             statistics_line('commanded / ideal delta-v', [r['dv_commanded_mps'] / r['dv_ideal_mps'] for r in flown],
                             ''),
             statistics_line('least clearance (real geometry)', [r['min_clearance_m'] for r in flown], 'm'),
             f'runs with thrust inside the restriction sphere: '
             f'{sum(r["thrust_inside_restriction_sphere"] for r in runs)}']
    if any('peak_grasp_force_n' in r for r in runs):  # after the capture (a post_capture section)
        lines += [statistics_line(label, [r.get(key) for r in runs], unit)
                  for key, label, unit in POST_CAPTURE_STATISTICS]
        lines.append(f'grasps released: {sum(bool(r.get("grasp_released")) for r in runs)}')
    return lines
