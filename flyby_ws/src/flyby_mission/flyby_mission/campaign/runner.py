"""Monte Carlo campaigns of headless missions on Dask distributed (docs/campaigns.md).

A campaign (``flyby_mission.campaign.dispersions``: base scenario, campaign seed, dispersions) is flown run by run,
each run a headless mission (``flyby_mission.headless.run_headless``) on a Dask worker: a
``distributed.LocalCluster`` of one single-threaded worker process per core, or the scheduler at an
address (``dask scheduler`` / ``dask worker ADDRESS``). The output directory holds::

    campaign.json          header (campaign file, its hash, runs, keys) and, at the end, the statistics
    results.csv            one row per finished run, in the order they finish, flushed row by row
    runs/<i>/scenario.yaml the full drawn scenario (replay it alone with scripts/run_mission.py)
    runs/<i>/summary.json  the run's summary.json
    report.md, *.png       the report (flyby_mission.campaign.report)

As in Basilisk's MonteCarlo controller, each run's parameters and seed are written beside its results,
any run is redrawn alone (``Campaign.draw(i)``), and a run that raises is returned as a row with outcome
``ERROR`` and the exception in ``end_reason``. A rerun into the same directory skips the runs already in
results.csv (resume) and refuses a changed campaign file, base scenario or number of runs.
"""

import csv
import json
import os
import sys
import time
import traceback
from pathlib import Path

import dask
import distributed

from flyby_mission.campaign.dispersions import CampaignError, load_campaign
from flyby_mission.campaign.report import write_report
from flyby_mission.headless import run_headless
from flyby_mission.post_capture_figures import POST_CAPTURE_KEYS, TRANSPORT_KEYS
from flyby_msgs_py import contract as c
from flyby_sim.scenario import scenario_from_dict

# The summary.json figures of a row, under their summary.json names (the wall times last, after them).
SUMMARY_COLUMNS = (
    'outcome', 'final_phase', 'end_reason', 'phase_sequence', 'method', 'seed', 't_grasp_s', 'flyby_offset_m',
    'flyby_duration_s', 'capture_position_error_m',
    'capture_velocity_error_mps', 'delta_v_total_mps', 'fuel_used_kg', 'min_clearance_m', 't_min_clearance_s',
    'thrust_inside_restriction_sphere', 'maneuvers_executed', 'late_maneuvers', 'rejected_maneuvers', 'sim_time_s',
)
# Wall-clock figures: the only cells that differ between two runs of the same campaign.
TIMING_COLUMNS = ('planning_time_s', 'wall_time_s')
RESULTS = 'results.csv'
HEADER = 'campaign.json'


class CampaignMismatch(ValueError):
    """The output directory holds another campaign (its file, base scenario or number of runs differ)."""


def run_indices(spec):
    """Run indices of '0-19', '0,3,10' or '0-4,8' (the scripts' --runs)."""
    out = []
    for part in spec.split(','):
        lo, _, hi = part.partition('-')
        out += list(range(int(lo), int(hi) + 1)) if hi else [int(lo)]
    return out


def columns(campaign):
    """The columns of results.csv: run, the dispersed keys in file order, the summary figures (with the
    post-capture and transport keys where the base scenario has those phases), the wall times."""
    post = campaign.base.post_capture
    extra = (() if post is None else POST_CAPTURE_KEYS) + (() if post is None or post.transport is None
                                                           else TRANSPORT_KEYS)
    return ('run', *campaign.keys, *SUMMARY_COLUMNS, *extra, *TIMING_COLUMNS)


def fly(run, scenario_dict):
    """Fly one run on a worker: its summary.json dict; an exception becomes outcome ERROR (never hidden)."""
    wall_start = time.monotonic()
    try:
        return run_headless(scenario_from_dict(scenario_dict, name=f'run {run}')).summary
    except Exception as e:  # a failed run is a result (Basilisk MonteCarlo)
        return error_summary(scenario_dict.get('seed'), e, time.monotonic() - wall_start,
                             traceback.format_exc())


def error_summary(seed, error, wall_time_s, trace=None):
    """The summary of a run that raised: outcome ERROR, the exception in end_reason (one line)."""
    summary = dict.fromkeys(SUMMARY_COLUMNS)
    summary.update(outcome=c.OUTCOME_ERROR, end_reason=' '.join(f'{type(error).__name__}: {error}'.split()), seed=seed,
                   phase_sequence=[], wall_time_s=wall_time_s)
    if trace:
        summary['traceback'] = trace
    return summary


def _cell(value):
    """A CSV cell: vectors and lists as JSON lists, None as empty, numbers with full precision."""
    if value is None:
        return ''
    if isinstance(value, (list, tuple, dict)):
        return json.dumps(value)
    return repr(float(value)) if isinstance(value, float) else str(value)  # numpy's float64 too


def row_of(run, values, summary, cols):
    """The results.csv row of a finished run, as text cells keyed by column (cols: ``columns(campaign)``)."""
    row = {'run': str(run)}
    row.update({key: _cell(v) for key, v in values.items()})
    row.update({key: _cell(summary.get(key)) for key in cols if key not in row})
    return row


def read_results(out_dir, cols):
    """The complete rows of DIR/results.csv ({run: row}); a row cut off mid-write is left out."""
    path = Path(out_dir) / RESULTS
    if not path.exists():
        return {}
    with path.open(newline='') as f:
        reader = csv.DictReader(f)
        if tuple(reader.fieldnames or ()) != tuple(cols):
            raise CampaignMismatch(f'{path}: columns {reader.fieldnames} differ from this campaign\'s {list(cols)}')
        return {int(r['run']): r for r in reader if None not in r.values() and None not in r and r['run'].isdigit()}


def _header(campaign, runs):
    return {'campaign_file': str(campaign.path), 'name': campaign.name, 'sha256': campaign.sha256,
            'campaign_seed': campaign.seed, 'runs': runs, 'base_scenario': str(campaign.base.path),
            'dispersed_keys': list(campaign.keys)}


def _check_header(out_dir, header):
    path = Path(out_dir) / HEADER
    if not path.exists():
        return
    old = json.loads(path.read_text())['header']
    for key in ('sha256', 'runs'):
        if old[key] != header[key]:
            what = 'the campaign file or its base scenario changed' if key == 'sha256' else 'the number of runs changed'
            raise CampaignMismatch(f'{path}: header.{key}: {what} ({old[key]!r} -> {header[key]!r}); '
                                   f'use a new --out directory')


# The LocalCluster's monitoring, which a campaign never reads (no dashboard): the workers' statistical profiler
# samples the running task 100 times a second, the event-loop tick runs 50 times a second in every server, the
# system and memory monitors 2-10 times: a fifth of a core on an idle 2-worker cluster, a tenth of that with these
# (docs/campaigns.md).
QUIET_CLUSTER = {
    'distributed.worker.profile.enabled': False,
    'distributed.admin.tick.interval': '1s',
    'distributed.admin.system-monitor.interval': '5s',
    'distributed.worker.memory.monitor-interval': '1s',
}


class _Progress:
    """One line on stderr, rewritten in place: runs done / total, runs per hour, time left."""

    def __init__(self, total, done, stream=sys.stderr):
        self.total, self.done, self.start_done, self.stream = total, done, done, stream
        self.t0 = time.monotonic()

    def runs_per_hour(self):
        elapsed_s = time.monotonic() - self.t0
        return 3600.0 * (self.done - self.start_done) / elapsed_s if elapsed_s > 0 else 0.0

    def update(self, outcome=''):
        self.done += 1
        rate = self.runs_per_hour()
        left_s = 3600.0 * (self.total - self.done) / rate if rate > 0 else float('nan')
        left = time.strftime('%H:%M:%S', time.gmtime(left_s)) if left_s == left_s else '?'
        self.stream.write(f'\r{self.done}/{self.total} runs, {rate:.0f} runs/h, {left} left, last {outcome:<12}')
        self.stream.flush()

    def close(self):
        self.stream.write('\n')
        self.stream.flush()


def run_campaign(campaign_file, out_dir, runs=None, scheduler=None, workers=None, progress=True):
    """Fly a campaign into ``out_dir`` and write its report; return (rows by run, statistics, runs per hour of
    this invocation, None if it flew none).

    ``runs``: how many (default: the campaign's ``runs``); ``scheduler``: the address of a running Dask
    scheduler, else a LocalCluster of ``workers`` (default os.cpu_count()) single-threaded processes.
    Raises CampaignError (invalid campaign, before any run) or CampaignMismatch (another campaign in out_dir).
    """
    campaign = load_campaign(campaign_file, checked_draws=runs)  # every run to fly validated first
    runs = campaign.runs if runs is None else runs
    if runs < 1:
        raise CampaignError(campaign_file, 'runs', f'must be >= 1, got {runs!r} (from the runs argument)')
    if workers is not None and workers < 1:  # 0 would be every core, a negative count a cluster that never starts
        raise CampaignError(campaign_file, 'workers', f'must be >= 1, got {workers!r} (from the workers argument)')
    out = Path(out_dir)
    header = _header(campaign, runs)
    _check_header(out, header)
    cols = columns(campaign)
    done = read_results(out, cols)
    out.mkdir(parents=True, exist_ok=True)
    (out / HEADER).write_text(json.dumps({'header': header}, indent=1) + '\n')
    todo = [i for i in range(runs) if i not in done]

    # Rewrite the complete rows (drops a row cut off by a killed run) and append from there.
    results = out / RESULTS
    with results.open('w', newline='') as f:
        writer = csv.DictWriter(f, fieldnames=cols)
        writer.writeheader()
        writer.writerows(done[i] for i in sorted(done))
    bar = _Progress(runs, len(done)) if progress else None
    if todo:
        drawn = {}
        for i in todo:
            scenario, values = campaign.draw(i)
            run_dir = out / 'runs' / str(i)
            run_dir.mkdir(parents=True, exist_ok=True)
            (run_dir / 'scenario.yaml').write_text(scenario.to_yaml())
            drawn[i] = (scenario.to_dict(), values)
        with dask.config.set(QUIET_CLUSTER):  # the workers a LocalCluster spawns take the config set here
            cluster = None if scheduler else distributed.LocalCluster(
                n_workers=workers or os.cpu_count(), threads_per_worker=1, processes=True, dashboard_address=None)
            try:
                with distributed.Client(scheduler or cluster) as client, results.open('a', newline='') as f:
                    writer = csv.DictWriter(f, fieldnames=cols)
                    key_prefix = f'flyby-{campaign.sha256[:12]}-run'
                    futures = {client.submit(fly, i, drawn[i][0], key=f'{key_prefix}-{i}', pure=False): i for i in todo}
                    for future in distributed.as_completed(futures):
                        i = futures[future]
                        if i in done:  # a lost worker's task re-run by Dask: one result per run
                            continue
                        try:
                            summary = future.result()
                        except Exception as e:  # e.g. KilledWorker: an ERROR row
                            summary = error_summary(drawn[i][0]['seed'], e, None)
                        (out / 'runs' / str(i) / 'summary.json').write_text(json.dumps(summary, indent=2) + '\n')
                        done[i] = row_of(i, drawn[i][1], summary, cols)
                        writer.writerow(done[i])
                        f.flush()
                        if bar:
                            bar.update(summary['outcome'])
            finally:
                if cluster is not None:
                    cluster.close()
    rate = bar.runs_per_hour() if bar and todo else None
    if bar:
        bar.close()
    return done, write_report(out, header, done), rate
