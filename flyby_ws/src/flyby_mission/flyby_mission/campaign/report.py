"""The statistics and report of a Monte Carlo campaign (docs/campaigns.md): campaign.json, report.md, plots.

Rates are binomial proportions with exact (Clopper-Pearson) two-sided 95 % bounds from the beta
distribution: for k successes in n runs, lower = Beta(alpha/2; k, n - k + 1), upper = Beta(1 - alpha/2;
k + 1, n - k) (Clopper and Pearson 1934; the same as scipy.stats.binomtest(k, n).proportion_ci('exact')).
The zero-failure statement is the order-statistics one: N runs without failure give a success
probability >= 0.1**(1/N) at 90 % confidence (the p at which N successes in a row have probability
0.1), i.e. a failure probability <= 1 - 0.1**(1/N); 22 clean runs give >= 90 %.

Flown runs are those that reached an outcome of the mission (all but ERROR and INTERRUPTED: those are
failures of the software or of the operator, counted and listed but not flight statistics). Runs that
flew a plan are those whose phases reached a method's approach (TERMINAL_APPROACH, OPTIMAL_APPROACH or
SYNC_APPROACH): the capture rate of a method is taken over them (a NO_SAFE_PLAN run is safe and counted with
its reason, not a failed capture), in all and by the method flown (``method``, DESIGN §10). Refusals are
counted by class: the planner's one-line reason names the binding class first.
"""

import collections
import json
import math
from pathlib import Path

import numpy as np
import scipy.stats

from flyby_mission.campaign.fault_report import fault_lines, fault_statistics
from flyby_msgs_py import contract as c
from flyby_sim.scenario import load_scenario

NOT_FLOWN = (c.OUTCOME_ERROR, c.OUTCOME_INTERRUPTED)
# Figures whose large tail is the worst (percentiles 50/95/99/max).
UPPER_TAIL = ('capture_position_error_m', 'capture_velocity_error_mps', 'delta_v_total_mps', 'fuel_used_kg')
MAX_LISTED = 20
WORST_LISTED = 5
# Transport's figures (docs/transport.md; results.csv has them when the base scenario transports): upper tails.
TRANSPORT_FIGURES = ('transport_final_position_error_m', 'transport_orbital_momentum_error_n_m_s',
                     'transport_final_angular_momentum_kg_m2_s', 'transport_wheel_momentum_share', 'transport_fuel_kg',
                     'transport_impulses', 'transport_time_s')
# The time from the planned arrival to transport_complete, against the bound the planner stated before flying.
SETTLE_TIME, SETTLE_BOUND = 'transport_settle_time_s', 'transport_settle_bound_s'
SETTLE_PERCENTILES = (50, 90, 99)
# Keys whose dispersion moves the spin axis or rate: then the outcome map is drawn.
SPIN_KEYS = ('target.initial_rate.', 'target.initial_attitude.')


def clopper_pearson(k, n, confidence=0.95):
    """Exact two-sided bounds (lower, upper) of a binomial proportion with k successes in n trials."""
    alpha = 1.0 - confidence
    lower = 0.0 if k == 0 else float(scipy.stats.beta.ppf(alpha / 2.0, k, n - k + 1))
    upper = 1.0 if k == n else float(scipy.stats.beta.ppf(1.0 - alpha / 2.0, k + 1, n - k))
    return lower, upper


def zero_failure_lower_bound(n, confidence=0.9):
    """Least success probability that n runs without failure support at ``confidence``: (1 - confidence)**(1/n)."""
    return (1.0 - confidence) ** (1.0 / n)


def _number(cell):
    return float(cell) if cell not in ('', None) else None


def _rate(name, k, n):
    if n == 0:
        return {'rate': None, 'successes': 0, 'runs': 0}
    lower, upper = clopper_pearson(k, n)
    out = {'rate': k / n, 'successes': k, 'runs': n, 'ci95_clopper_pearson': [lower, upper]}
    if k == n:
        bound = zero_failure_lower_bound(n)
        out['zero_failure_90'] = (f'{n} flown runs without a {name} failure: success probability >= '
                                  f'{bound:.4f} (1 - 0.1**(1/{n}) = {1.0 - bound:.4f} at most failing) '
                                  f'at 90 % confidence')
    return out


def _percentiles(values, tail):
    a = np.array([v for v in values if v is not None], dtype=float)
    if a.size == 0:
        return {'n': 0}
    if tail == 'upper':
        return {'n': int(a.size), 'p50': float(np.percentile(a, 50)), 'p95': float(np.percentile(a, 95)),
                'p99': float(np.percentile(a, 99)), 'max': float(a.max())}
    return {'n': int(a.size), 'p50': float(np.percentile(a, 50)), 'p5': float(np.percentile(a, 5)),
            'p1': float(np.percentile(a, 1)), 'min': float(a.min())}


# The optimization-based approach's refusals (flyby_planner.optimal.approach), by how their text starts.
OPTIMAL_REFUSALS = (('no feasible program', 'no feasible program'),
                    ('refused: peak acceleration', 'peak acceleration above its share'),
                    ('refused: thrust', 'thrust away from the target inside the plume radius'),
                    ('refused: the envelope comes', 'clearance below the margin'))


def refusal_class(end_reason):
    """The class of a NO_SAFE_PLAN reason: what bound the refusal (the first class the planner names; with
    ``auto``, where the fly-by's refusal is followed by the optimization-based approach's, the latter's)."""
    reason = end_reason.removeprefix('no safe plan: ')
    if reason.startswith('optimal approach') or '; optimal approach' in reason:
        optimal = reason.rsplit('optimal approach', 1)[1].lstrip(': ')
        return 'optimal approach: ' + next((cls for start, cls in OPTIMAL_REFUSALS if optimal.startswith(start)),
                                           optimal.split(':')[0])
    if reason.startswith('all ') and ': ' in reason:  # 'all N candidates rejected: K <class>; ...'
        return reason.split(': ', 1)[1].split(';')[0].split(' ', 1)[1]
    return reason.split(':')[0]


APPROACH_PHASES = (c.PHASE_TERMINAL_APPROACH, c.PHASE_OPTIMAL_APPROACH, c.PHASE_SYNC_APPROACH)


def _flew_plan(row):
    return any(p in APPROACH_PHASES for p in json.loads(row.get('phase_sequence') or '[]'))


def statistics(rows):
    """campaign.json's statistics of the rows of results.csv ({run: row of text cells})."""
    outcomes = [r['outcome'] for r in rows.values()]
    counts = {o: outcomes.count(o) for o in c.OUTCOMES if o in outcomes}
    counts.update({o: outcomes.count(o) for o in sorted(set(outcomes) - set(c.OUTCOMES))})
    flown = [r for r in rows.values() if r['outcome'] not in NOT_FLOWN]
    n = len(flown)
    captured = sum(r['outcome'] == c.OUTCOME_CAPTURE for r in flown)
    safe = sum(r['outcome'] != c.OUTCOME_COLLISION for r in flown)
    figures = {key: _percentiles([_number(r[key]) for r in flown], 'upper') for key in UPPER_TAIL}
    figures['min_clearance_m'] = _percentiles([_number(r['min_clearance_m']) for r in flown], 'lower')
    planned = [r for r in flown if _flew_plan(r)]
    refused = collections.Counter(refusal_class(r['end_reason']) for r in rows.values()
                                  if r['outcome'] == c.OUTCOME_NO_SAFE_PLAN)
    by_method = collections.defaultdict(collections.Counter)  # results.csv from before the column: ''
    for r in planned:
        by_method[r.get('method') or ''][r['outcome']] += 1
    out = {
        'runs': len(rows), 'flown': n, 'flew_a_plan': len(planned), 'outcome_counts': counts,
        'plans_flown_by_method': {m: dict(by_method[m].most_common()) for m in sorted(by_method)},
        'capture_rate': _rate('capture', captured, n),
        'capture_rate_of_plans_flown': _rate('capture', sum(r['outcome'] == c.OUTCOME_CAPTURE for r in planned),
                                             len(planned)),
        'refusals_by_class': dict(refused.most_common()),
        'safe_rate': _rate('collision', safe, n),
        'percentiles': figures,
    }
    if any(r.get('transport_conditions_met') for r in flown):
        out['transport_rate'] = _rate('transport', sum(_met(r) for r in flown), n)
        out['transport_percentiles'] = {key: _percentiles([_number(r.get(key)) for r in flown], 'upper')
                                        for key in TRANSPORT_FIGURES}
        out['transport_settle_time'] = settle_time_statistics(flown)
    return out


def settle_time_statistics(rows):
    """The settle time's percentiles (SETTLE_PERCENTILES and max) over the runs whose transport completed, and how
    many of them ended within the bound their plan stated (both cells present)."""
    times = np.array([t for t in (_number(r.get(SETTLE_TIME)) for r in rows) if t is not None], dtype=float)
    out = {'n': int(times.size)}
    if times.size:
        out.update({f'p{q}': float(np.percentile(times, q)) for q in SETTLE_PERCENTILES}, max=float(times.max()))
    pairs = [(_number(r.get(SETTLE_TIME)), _number(r.get(SETTLE_BOUND))) for r in rows]
    pairs = [(t, b) for t, b in pairs if t is not None and b is not None]
    out['within_bound'] = sum(t <= b for t, b in pairs)
    out['with_bound'] = len(pairs)
    return out


def _met(row):
    """The row's transport_conditions_met (results.csv writes it True or False)."""
    return row.get('transport_conditions_met') == 'True'


def _replay(out_dir, run):
    return (f'.venv/bin/python scripts/run_mission.py --scenario {out_dir}/runs/{run}/scenario.yaml '
            f'--out runs/replay_{run}')


def worst_runs(rows):
    """(title, [(run, figure text)]) of the runs worth replaying: largest capture error, least clearance,
    every run that did not capture (up to MAX_LISTED)."""
    def by(key, reverse):
        have = [(r, _number(row[key])) for r, row in rows.items() if _number(row[key]) is not None]
        return sorted(have, key=lambda x: x[1], reverse=reverse)[:WORST_LISTED]
    transport = [('every transport that missed a condition',
                  [(r, f'{_fmt(_number(row["transport_final_position_error_m"]))} m, '
                       f'{_fmt(_number(row["transport_orbital_momentum_error_n_m_s"]))} N s, '
                       f'{_fmt(_number(row["transport_final_angular_momentum_kg_m2_s"]))} kg m2/s, '
                       f'wheels at {_fmt(_number(row.get("transport_wheel_momentum_share")))} of their capacity')
                   for r, row in sorted(rows.items()) if row.get('transport_conditions_met') and not _met(row)
                   ][:MAX_LISTED])] if any(row.get('transport_conditions_met') for row in rows.values()) else []
    return [
        ('largest capture position error', [(r, f'{v:.4g} m') for r, v in by('capture_position_error_m', True)]),
        ('least clearance', [(r, f'{v:.4g} m') for r, v in by('min_clearance_m', False)]),
        ('every run that did not capture',
         [(r, f'{row["outcome"]}: {row["end_reason"][:160]}') for r, row in sorted(rows.items())
          if row['outcome'] != c.OUTCOME_CAPTURE][:MAX_LISTED]),
        *transport,
    ]


def _spin_axes(out_dir, rows):
    """{run: (angle of the spin axis from hill y [deg], longitude about hill y [deg], rate [deg/s])} at t = 0."""
    out = {}
    for r in rows:
        sc = load_scenario(Path(out_dir) / 'runs' / str(r) / 'scenario.yaml')
        omega_hill = sc.rotation_hill_from_body0.apply(sc.omega_body0_rad_s)
        rate = float(np.linalg.norm(omega_hill))
        u = omega_hill / rate if rate > 0 else np.array([0.0, 1.0, 0.0])
        out[r] = (math.degrees(math.acos(np.clip(u[1], -1.0, 1.0))), math.degrees(math.atan2(u[2], u[0])),
                  math.degrees(rate))
    return out


def plots(out_dir, rows, keys):
    """Write outcome_counts.png and, when the spin was dispersed, outcome_map.png; the file names written."""
    import matplotlib
    matplotlib.use('Agg')  # files only, no display
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    written = []
    counts = statistics(rows)['outcome_counts']
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.bar(list(counts), list(counts.values()), color='tab:blue')
    ax.set_ylabel('runs')
    ax.set_title(f'Outcomes of {len(rows)} runs')
    fig.tight_layout()
    fig.savefig(out / 'outcome_counts.png', dpi=100)
    plt.close(fig)
    written.append('outcome_counts.png')
    if any(k.startswith(SPIN_KEYS) for k in keys):
        axes = _spin_axes(out, rows)
        fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
        for outcome in sorted({row['outcome'] for row in rows.values()}):
            runs = [r for r, row in rows.items() if row['outcome'] == outcome]
            a = np.array([axes[r] for r in runs])
            left.scatter(a[:, 1], 90.0 - a[:, 0], label=outcome, s=18)
            right.scatter(a[:, 0], a[:, 2], label=outcome, s=18)
        left.set_xlabel('spin axis longitude about hill y, from hill x toward z [deg]')
        left.set_ylabel('spin axis latitude toward hill y [deg]')
        right.set_xlabel('spin axis angle from hill y [deg]')
        right.set_ylabel('inertial spin rate [deg/s]')
        right.legend(fontsize=8)
        fig.suptitle('Outcome over the spin axis (hill, t = 0) and rate')
        fig.tight_layout()
        fig.savefig(out / 'outcome_map.png', dpi=100)
        plt.close(fig)
        written.append('outcome_map.png')
    return written


def _fmt(x):
    return '-' if x is None else f'{x:.4g}'


def report_markdown(out_dir, header, stats, rows, images):
    """The text of report.md."""
    lines = [f'# Campaign {header["name"]}', '',
             f'Campaign file `{header["campaign_file"]}` (sha256 {header["sha256"][:12]}), campaign seed '
             f'{header["campaign_seed"]}, base scenario `{header["base_scenario"]}`; dispersed: '
             + ', '.join(f'`{k}`' for k in header['dispersed_keys']) + '.', '',
             f'{stats["runs"]} runs, {stats["flown"]} flown (all but ERROR and INTERRUPTED), '
             f'{stats["flew_a_plan"]} of them flew a plan.', '',
             '| outcome | runs |', '|---|---|']
    lines += [f'| {o} | {n} |' for o, n in stats['outcome_counts'].items()]
    if any(stats['plans_flown_by_method']):
        lines += ['', '| plans flown, by method | runs | outcomes |', '|---|---|---|']
        lines += [f'| {m or "-"} | {sum(o.values())} | ' + ', '.join(f'{k} {v}' for k, v in o.items()) + ' |'
                  for m, o in stats['plans_flown_by_method'].items()]
    if stats['refusals_by_class']:
        lines += ['', '| NO_SAFE_PLAN, by what bound it | runs |', '|---|---|']
        lines += [f'| {k} | {n} |' for k, n in stats['refusals_by_class'].items()]
    lines += ['', '| rate | value | 95 % Clopper-Pearson |', '|---|---|---|']
    for name in ('capture_rate', 'capture_rate_of_plans_flown', 'safe_rate', 'transport_rate'):
        r = stats.get(name, {'runs': 0})
        if r['runs']:
            lo, hi = r['ci95_clopper_pearson']
            lines.append(f'| {name} | {r["successes"]}/{r["runs"]} = {r["rate"]:.3f} | [{lo:.3f}, {hi:.3f}] |')
    lines += [''] + [stats[n]['zero_failure_90'] + '.' for n in ('capture_rate_of_plans_flown', 'safe_rate',
                                                                 'transport_rate')
                     if 'zero_failure_90' in stats.get(n, {})]
    truth = stats.get('captures_within_tolerance_in_truth')
    if truth and truth['runs']:
        lines += ['', f'Captures within the manipulator\'s tolerances in truth (the supervisor decides on the '
                      f'estimates): {truth["successes"]}/{truth["runs"]}'
                  + ''.join(f'; run {r} outside at {p:.4g} m, {v:.4g} m/s' for r, p, v in truth['outside']) + '.']
    lines += ['', '| figure (flown runs) | n | p50 | p95 | p99 | max |', '|---|---|---|---|---|---|']
    for key in UPPER_TAIL:
        p = stats['percentiles'][key]
        lines.append(f'| {key} | {p["n"]} | ' + ' | '.join(_fmt(p.get(q)) for q in ('p50', 'p95', 'p99', 'max'))
                     + ' |')
    if 'transport_percentiles' in stats:
        lines += ['', 'transport_rate: the runs that meet all three rendezvous conditions in truth (seed 004 §3.2).',
                  '', '| transport figure (flown runs) | n | p50 | p95 | p99 | max |', '|---|---|---|---|---|---|']
        lines += [f'| {key} | {p["n"]} | ' + ' | '.join(_fmt(p.get(q)) for q in ('p50', 'p95', 'p99', 'max')) + ' |'
                  for key, p in stats['transport_percentiles'].items()]
        lines += _settle_lines(stats['transport_settle_time'])
    p = stats['percentiles']['min_clearance_m']
    lines += ['', '| least clearance (flown runs) | n | p50 | p5 | p1 | min |', '|---|---|---|---|---|---|',
              f'| min_clearance_m | {p["n"]} | ' + ' | '.join(_fmt(p.get(q)) for q in ('p50', 'p5', 'p1', 'min'))
              + ' |', '']
    lines += [f'![{name}]({name})' for name in images] + ['']
    for title, runs in worst_runs(rows):
        lines += [f'## Worst runs: {title}', '']
        lines += [f'- run {r}: {text}\n  `{_replay(out_dir, r)}`' for r, text in runs] or ['(none)']
        lines.append('')
    return '\n'.join(lines)


def _settle_lines(settle):
    """report.md's table of the settle time (settle_time_statistics) and the count within the stated bound."""
    names = [f'p{q}' for q in SETTLE_PERCENTILES] + ['max']
    return ['', f'{SETTLE_TIME}: from the planned arrival to transport_complete; within the bound the plan stated '
                f'({SETTLE_BOUND}) in {settle["within_bound"]} of {settle["with_bound"]} runs.', '',
            '| settle time (completed transports) | n | ' + ' | '.join(names) + ' |', '|---|---|---|---|---|---|',
            f'| {SETTLE_TIME} | {settle["n"]} | ' + ' | '.join(_fmt(settle.get(q)) for q in names) + ' |']


def truth_within_tolerance(out_dir, rows):
    """The captures whose truth errors (capture_position_error_m, capture_velocity_error_mps) are within their
    run's manipulator tolerances: the supervisor decides a capture on the estimates, so a CAPTURE can lie outside
    them in truth. A run that starts attached (post_capture.start) has no capture errors and is not counted.
    (rate of the captures, [(run, position, velocity) of those outside])."""
    captured = {r: row for r, row in rows.items() if row['outcome'] == c.OUTCOME_CAPTURE
                and _number(row.get('capture_position_error_m')) is not None}  # not a run that starts attached
    outside = []
    for r, row in sorted(captured.items()):
        arm = load_scenario(Path(out_dir) / 'runs' / str(r) / 'scenario.yaml').chaser.manipulator
        position, velocity = _number(row['capture_position_error_m']), _number(row['capture_velocity_error_mps'])
        if not (position <= arm.position_tolerance_m and velocity <= arm.velocity_tolerance_mps):
            outside.append((r, position, velocity))
    return _rate('tolerance', len(captured) - len(outside), len(captured)), outside


def write_report(out_dir, header, rows):
    """Write campaign.json (header and statistics), the plots and report.md; return the statistics."""
    out = Path(out_dir)
    stats = statistics(rows)
    rate, outside = truth_within_tolerance(out, rows)
    stats['captures_within_tolerance_in_truth'] = dict(rate, outside=[list(x) for x in outside])
    faults = fault_statistics(out, rows)
    if faults is not None:
        stats['faults'] = faults
    (out / 'campaign.json').write_text(json.dumps({'header': header, 'statistics': stats}, indent=1) + '\n')
    images = plots(out, rows, header['dispersed_keys'])
    text = report_markdown(out_dir, header, stats, rows, images)
    (out / 'report.md').write_text(text + ('\n'.join(fault_lines(faults)) + '\n' if faults is not None else ''))
    return stats
