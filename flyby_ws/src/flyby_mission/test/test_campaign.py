"""Campaigns on Dask (flyby_mission.campaign.runner) and their statistics (campaign_report).

The campaign is campaign_short.yaml beside this file: paper_flyby cut to 40 s of simulated time
(every run ends TIME_LIMIT in well under a second), so 20 runs on a LocalCluster of 2 workers take
seconds; what is tested is the machinery, not the outcomes.
"""

import csv
import json
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import distributed
import numpy as np
import pytest
import scipy.stats
import yaml

from flyby_mission.campaign.dispersions import load_campaign
from flyby_mission.campaign.report import clopper_pearson, zero_failure_lower_bound
from flyby_mission.campaign.runner import TIMING_COLUMNS, CampaignMismatch, columns, fly, read_results, run_campaign
from flyby_sim.scenario import load_scenario

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[3]
RUNS = 20


@pytest.fixture(scope='module')
def campaign_file(tmp_path_factory):
    data = yaml.safe_load((HERE / 'campaign_short.yaml').read_text())
    data['base_scenario'] = str(ROOT / 'scenarios' / 'paper_flyby.yaml')
    data['dispersions']['simulation.duration_s']['values'] = [40.0]
    path = tmp_path_factory.mktemp('campaign') / 'short.yaml'
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


@pytest.fixture(scope='module')
def flown(campaign_file, tmp_path_factory):
    out = tmp_path_factory.mktemp('out') / 'c'
    rows, stats, _ = run_campaign(campaign_file, out, runs=RUNS, workers=2, progress=False)
    return out, rows, stats


def _rows_by_run(out, campaign):
    with (out / 'results.csv').open(newline='') as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == columns(campaign)
    return {int(r['run']): r for r in rows}, len(rows)


@pytest.mark.slow
def test_every_run_is_written_once_with_its_drawn_parameters(campaign_file, flown):
    out, _, stats = flown
    campaign = load_campaign(campaign_file)
    rows, n = _rows_by_run(out, campaign)
    assert n == RUNS and sorted(rows) == list(range(RUNS))
    for i, row in rows.items():
        scenario, values = campaign.draw(i)  # each run redrawn alone
        for key, value in values.items():
            assert json.loads(row[key]) == value, (i, key)
        assert int(row['seed']) == scenario.seed
        assert load_scenario(out / 'runs' / str(i) / 'scenario.yaml') == scenario
        summary = json.loads((out / 'runs' / str(i) / 'summary.json').read_text())
        assert summary['outcome'] == row['outcome'] and summary['seed'] == scenario.seed
    assert sum(stats['outcome_counts'].values()) == RUNS
    header = json.loads((out / 'campaign.json').read_text())
    assert header['header']['sha256'] == campaign.sha256 and header['statistics']['runs'] == RUNS
    truth = header['statistics']['captures_within_tolerance_in_truth']
    arm = load_scenario(out / 'runs' / '0' / 'scenario.yaml').chaser.manipulator
    outside = [i for i, row in rows.items() if row['outcome'] == 'CAPTURE' and not (
        float(row['capture_position_error_m']) <= arm.position_tolerance_m
        and float(row['capture_velocity_error_mps']) <= arm.velocity_tolerance_mps)]
    assert truth['runs'] == stats['outcome_counts'].get('CAPTURE', 0)
    assert [r for r, _p, _v in truth['outside']] == sorted(outside)
    assert (out / 'report.md').read_text().count('scripts/run_mission.py --scenario') >= 1
    assert (out / 'outcome_counts.png').exists() and (out / 'outcome_map.png').exists()


@pytest.mark.slow
def test_resume_flies_only_the_missing_runs_and_gives_the_same_rows(campaign_file, flown, tmp_path):
    out, _, _ = flown
    campaign = load_campaign(campaign_file)
    before, _ = _rows_by_run(out, campaign)
    resumed = tmp_path / 'c'
    shutil.copytree(out, resumed)
    # Keep the even runs, and the odd run 1 cut off mid-row (a killed campaign): 11 runs left to fly.
    text = (resumed / 'results.csv').read_text().splitlines(keepends=True)
    kept = [text[0]] + [line for line in text[1:] if int(line.split(',')[0]) % 2 == 0]
    cut = next(line for line in text[1:] if line.startswith('1,'))
    (resumed / 'results.csv').write_text(''.join(kept) + cut[:40])
    assert len(read_results(resumed, columns(campaign))) == RUNS // 2
    rows, stats, _ = run_campaign(campaign_file, resumed, runs=RUNS, workers=2, progress=False)
    after, n = _rows_by_run(resumed, campaign)
    assert n == RUNS and sorted(after) == list(range(RUNS)) and stats['runs'] == RUNS
    for i in range(RUNS):
        assert {k: v for k, v in after[i].items() if k not in TIMING_COLUMNS} == \
               {k: v for k, v in before[i].items() if k not in TIMING_COLUMNS}, i
    with pytest.raises(CampaignMismatch, match=r'campaign\.json: header\.runs: the number of runs changed'):
        run_campaign(campaign_file, resumed, runs=RUNS + 1, workers=2, progress=False)


def test_a_run_that_raises_is_an_error_row():
    summary = fly(3, {'name': 'broken', 'seed': 5})
    assert summary['outcome'] == 'ERROR' and summary['seed'] == 5
    assert summary['end_reason'].startswith('ScenarioError: run 3: ') and '\n' not in summary['end_reason']


@pytest.mark.parametrize('k, n', [(0, 1), (0, 20), (3, 20), (17, 20), (20, 20), (1, 1), (512, 1000)])
def test_clopper_pearson_against_scipy_binomtest(k, n):
    expected = scipy.stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method='exact')
    np.testing.assert_allclose(clopper_pearson(k, n), (expected.low, expected.high), rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize('n', [1, 10, 22, 59, 299])
def test_zero_failure_bound_is_the_one_sided_clopper_pearson_bound(n):
    # n successes in n runs: the 90 % one-sided lower bound Beta(0.1; n, 1) solves p**n = 0.1.
    assert zero_failure_lower_bound(n) == pytest.approx(scipy.stats.beta.ppf(0.1, n, 1), rel=1e-12)
    assert zero_failure_lower_bound(n) ** n == pytest.approx(0.1, rel=1e-12)


def _free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_a_scheduler_and_workers_as_processes_give_the_same_rows_even_when_a_worker_dies(campaign_file, flown,
                                                                                        tmp_path):
    """`dask scheduler` and two `dask worker` processes on this machine (as on a cluster): the same rows as
    the LocalCluster's, apart from wall times, although one worker is killed (SIGKILL) mid-campaign: its
    runs in flight are re-run on the other, and each run is written once."""
    out_local, _, _ = flown
    campaign = load_campaign(campaign_file)
    local, _ = _rows_by_run(out_local, campaign)
    address = f'tcp://127.0.0.1:{_free_port()}'
    dask = str(Path(sys.executable).parent / 'dask')
    procs = [subprocess.Popen([dask, 'scheduler', '--host', '127.0.0.1', '--port', address.rsplit(':', 1)[1],
                               '--dashboard-address', ':0'], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    procs += [subprocess.Popen([dask, 'worker', address, '--nworkers', '1', '--nthreads', '1', '--no-nanny',
                                '--dashboard-address', ':0'], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
              for _ in range(2)]
    out = tmp_path / 'c'
    killed = []

    def kill_one_worker_after_three_rows():
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and not killed:
            results = out / 'results.csv'
            if results.exists() and len(results.read_text().splitlines()) > 3:
                procs[1].send_signal(signal.SIGKILL)
                killed.append(time.monotonic())
            time.sleep(0.01)

    try:
        with distributed.Client(address, timeout=30) as client:
            client.wait_for_workers(2, timeout=30)
        killer = threading.Thread(target=kill_one_worker_after_three_rows)
        killer.start()
        run_campaign(campaign_file, out, runs=RUNS, scheduler=address, progress=False)
        killer.join()
    finally:
        for p in procs:
            p.kill()
            p.wait()
    assert killed, 'the worker was not killed mid-campaign'
    remote, n = _rows_by_run(out, campaign)
    assert n == RUNS and sorted(remote) == list(range(RUNS))
    for i in range(RUNS):
        assert {k: v for k, v in remote[i].items() if k not in TIMING_COLUMNS} == \
               {k: v for k, v in local[i].items() if k not in TIMING_COLUMNS}, i


def test_refusals_are_counted_by_what_bound_them_and_captures_over_the_plans_flown():
    from flyby_mission.campaign.report import refusal_class, statistics

    def row(outcome, reason, phases, method='flyby'):
        return {'outcome': outcome, 'end_reason': reason, 'phase_sequence': json.dumps(phases), 'method': method,
                'min_clearance_m': '', 'capture_position_error_m': '', 'capture_velocity_error_mps': '',
                'delta_v_total_mps': '', 'fuel_used_kg': ''}
    flown = ['ESTIMATION', 'PLANNING', 'TERMINAL_APPROACH', 'TRAJECTORY_ADJUST', 'FLYBY']
    rows = {0: row('CAPTURE', 'phase COMPLETE', flown + ['CAPTURE', 'COMPLETE']),
            1: row('ESCAPE', 'time_limit', flown + ['ESCAPE']),
            2: row('NO_SAFE_PLAN', 'no safe plan: all 40 candidates rejected: 30 unguided coast too long; 10 not '
                                   'convex (eq 15)', ['ESTIMATION', 'PLANNING', 'COMPLETE']),
            3: row('NO_SAFE_PLAN', 'no safe plan: no offset reaches the grasp point: at every offset ...',
                   ['ESTIMATION', 'PLANNING', 'COMPLETE']),
            4: row('TIME_LIMIT', 'time_limit', ['ESTIMATION']),
            5: row('CAPTURE', 'phase COMPLETE', ['ESTIMATION', 'PLANNING', 'OPTIMAL_APPROACH', 'CAPTURE', 'COMPLETE'],
                   'optimal')}
    stats = statistics(rows)
    assert stats['flew_a_plan'] == 3 and stats['capture_rate_of_plans_flown']['successes'] == 2
    assert stats['plans_flown_by_method'] == {'flyby': {'CAPTURE': 1, 'ESCAPE': 1}, 'optimal': {'CAPTURE': 1}}
    assert stats['capture_rate']['runs'] == 6
    assert stats['refusals_by_class'] == {'unguided coast too long': 1, 'no offset reaches the grasp point': 1}
    assert refusal_class('no safe plan: condition (a): target rate 21 deg/s >= 18 deg/s') == 'condition (a)'
    both = ('no safe plan: fly-by: all 169 candidates rejected: 90 predicted miss above the tolerance; 20 passive '
            'clearance below the margin; best passive clearance 0.074 m; optimal approach')
    assert refusal_class(both + ' refused: the envelope comes 0.038 m from the bus at t = 158.5 s (uncertainty '
                                'included, margin 0.1 m)') == 'optimal approach: clearance below the margin'
    assert refusal_class(both + ': no feasible program for an approach of 20-200 s at 0.09 m/s^2 (SCP, 24 '
                                'programs)') == 'optimal approach: no feasible program'


def test_a_transport_campaign_has_the_post_capture_and_transport_columns():
    """results.csv of a campaign whose base scenario goes on after the capture carries the summary's post-capture
    keys, and with a transport its transport keys (a transport campaign is judged on them); a fly-by campaign's
    columns are the summary figures alone."""
    from flyby_mission.post_capture_figures import POST_CAPTURE_KEYS, TRANSPORT_KEYS
    transport = columns(load_campaign(ROOT / 'campaigns' / 'transport_orbit_advance.yaml', checked_draws=0))
    assert set(POST_CAPTURE_KEYS) <= set(transport) and set(TRANSPORT_KEYS) <= set(transport)
    assert transport[-len(TIMING_COLUMNS):] == TIMING_COLUMNS and len(set(transport)) == len(transport)
    flyby = columns(load_campaign(ROOT / 'campaigns' / 'smoke.yaml', checked_draws=0))
    assert not set(POST_CAPTURE_KEYS + TRANSPORT_KEYS) & set(flyby)


def test_a_numpy_float_cell_is_written_as_a_number():
    """A summary figure computed in numpy (np.float64, a float) is a plain number in results.csv, read back exactly."""
    from flyby_mission.campaign.runner import _cell
    value = np.float64(0.1) * 3.0
    assert _cell(value) == repr(float(value)) and float(_cell(value)) == value


def test_a_transport_campaign_report_counts_the_three_conditions_and_skips_the_missing_capture_errors(tmp_path):
    """Runs that start attached have no capture errors (empty cells): the truth-within-tolerance count leaves them out
    instead of failing on them, and the report rates the transports that met all three conditions, with the settle
    time's percentiles and the runs within the bound their plan stated."""
    from flyby_mission.campaign.report import report_markdown, statistics, truth_within_tolerance

    def row(met, position_error_m, settle_s='600.0'):
        return {'outcome': 'CAPTURE', 'end_reason': 'phase COMPLETE', 'method': '',
                'phase_sequence': json.dumps(['MASS_ESTIMATION', 'TRANSPORT', 'COMPLETE']), 'min_clearance_m': '0.0',
                'capture_position_error_m': '', 'capture_velocity_error_mps': '', 'delta_v_total_mps': '0.0',
                'fuel_used_kg': '0.1', 'transport_conditions_met': str(met),
                'transport_final_position_error_m': repr(position_error_m),
                'transport_orbital_momentum_error_n_m_s': '0.4' if not met else '0.003',
                'transport_final_angular_momentum_kg_m2_s': '0.02', 'transport_fuel_kg': '0.07',
                'transport_impulses': '56', 'transport_time_s': '1200.0', 'transport_wheel_momentum_share': '0.3',
                'transport_settle_time_s': settle_s, 'transport_settle_bound_s': '900.0'}
    rows = {0: row(True, 0.7), 1: row(False, 0.5, '1200.0'), 2: row(True, 1.9), 3: row(True, 1.0, '')}
    assert truth_within_tolerance(tmp_path, rows) == ({'rate': None, 'successes': 0, 'runs': 0}, [])
    stats = statistics(rows)
    assert stats['transport_rate']['successes'] == 3 and stats['transport_rate']['runs'] == 4
    assert stats['transport_percentiles']['transport_final_position_error_m']['max'] == 1.9
    assert stats['transport_percentiles']['transport_wheel_momentum_share']['max'] == 0.3
    settle = stats['transport_settle_time']
    assert settle['n'] == 3 and settle['p50'] == 600.0 and settle['max'] == 1200.0
    assert 600.0 < settle['p90'] < settle['p99'] < 1200.0
    assert (settle['within_bound'], settle['with_bound']) == (2, 3)
    header = {'name': 'n', 'campaign_file': 'f', 'sha256': '0' * 64, 'campaign_seed': 1, 'base_scenario': 'b',
              'dispersed_keys': []}
    text = report_markdown(tmp_path, header, stats, rows, [])
    assert '| transport_rate | 3/4 = 0.750 |' in text
    assert '- run 1: 0.5 m, 0.4 N s, 0.02 kg m2/s, wheels at 0.3 of their capacity' in text
    assert '| transport_settle_time_s | 3 | 600 | 1080 | 1188 | 1200 |' in text
    assert 'in 2 of 3 runs' in text
    assert 'transport_rate' not in statistics({0: {**row(True, 0.7), 'transport_conditions_met': ''}})
