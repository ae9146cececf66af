"""The faults on the mission's timeline (docs/faults.md), for a run with an injected fault, a detection, a response
or a CAM:

* faults_timeline.png  one row per injected fault (a bar from its start to its end), its detections on its row
                       (the ones no fault explains on a row of false alarms), the supervisor's responses and the
                       isolated thrusters as labelled lines, the independent monitor's CAM; below, the truth range
                       to the target with the restriction sphere, over the same phases.
"""

import collections

import numpy as np

from flyby_mission.report import plotting
from flyby_mission.report.drawing import phase_bands, time_axis
from flyby_mission.report.plotting import plt
from flyby_mission.run_events import cam_time, fault_detections, fault_responses, plant_faults
from flyby_msgs_py import contract as c
from flyby_msgs_py import events

DPI = 100
FAULT_EVENTS = frozenset((events.FAULT_INJECTED, events.FAULT_DETECTED, events.FAULT_RESPONSE, events.CAM_FIRED))
RESPONSE_COLORS = {'continue': 'tab:green', 'abort': 'tab:red', 'isolate': 'tab:orange',
                   'isolate_abort': 'tab:purple', 'reallocate': 'tab:blue', 'hold': 'tab:olive', 'retreat': 'tab:brown'}


def has_faults(mission_events):
    """Whether the run has a fault to draw: injected, detected, answered, or a CAM."""
    return any(e['name'] in FAULT_EVENTS for e in mission_events)


def _rows(injected, detections):
    """The y labels: one per injected fault, then the false alarms' row where there are any."""
    labels = [f'fault {f["fault"]}: {f["kind"]}\n{f["target"]}' for f in injected]
    if any(d['fault'] is None for d in detections):
        labels.append('no fault acting\n(false alarm)')
    return labels


def _draw_faults(ax, run, injected, detections):
    """The faults as bars, their detections as markers on their rows."""
    row_of = {f['fault']: k for k, f in enumerate(injected)}
    false_row = len(injected)
    for k, f in enumerate(injected):
        end = run.t_end if f['t_end_s'] is None else f['t_end_s']
        ax.barh(k, max(end - f['t_start_s'], run.t_end * 2e-3), left=f['t_start_s'], height=0.5, color='0.75',
                edgecolor='0.4', label='fault acting' if k == 0 else None)
    labelled, on_row = set(), collections.Counter()
    for d in detections:
        row = row_of.get(d['fault'], false_row)
        label = 'detected, naming the fault' if d['isolated'] else 'detected, another component (a consequence)'
        ax.plot(d['t_s'], row, marker='v', ms=9, ls='none', color='tab:red' if d['isolated'] else 'tab:orange',
                label=None if label in labelled else label)
        labelled.add(label)
        delay = '' if d['delay_s'] is None else f' +{d["delay_s"]:.2f} s'
        ax.annotate(f'{d["kind"]} {d["component"]}{delay}', (d['t_s'], row), xytext=(4, -14 - 10 * on_row[row]),
                    textcoords='offset points', fontsize=7)
        on_row[row] += 1
    labels = _rows(injected, detections)
    ax.set_yticks(range(len(labels)), labels, fontsize=8)
    ax.set_ylim(len(labels) - 0.4, -0.8)


def _draw_answers(ax, run, responses):
    """The supervisor's responses, the thrusters it isolated and the CAM, as labelled vertical lines."""
    for r in responses:
        color = RESPONSE_COLORS.get(r['response'], 'k')
        ax.axvline(r['t_s'], color=color, lw=1.0, ls='--')
        ax.annotate(f'{r["response"]} ({r["phase"]})', (r['t_s'], 1.0), xycoords=('data', 'axes fraction'),
                    xytext=(3, -12), textcoords='offset points', fontsize=7, color=color, rotation=90, va='top')
    for e in run.events:
        if e['name'] == events.THRUSTERS_CLOSED:
            ax.axvline(float(e['t']), color='tab:orange', lw=0.8, ls=':')
    t_cam = cam_time(run.events)
    if t_cam is not None:
        ax.axvline(t_cam, color='crimson', lw=2.0, label='CAM fired')


def fig_faults_timeline(run, path):
    """faults_timeline.png (module doc)."""
    injected, detections = plant_faults(run.events), fault_detections(run.events)
    truth = run.get(c.SIM_CHASER_ODOM)
    panels = 2 if truth is not None else 1
    fig, axes = plt.subplots(panels, 1, figsize=(13, 3.0 + 2.2 * panels + 0.3 * len(injected)), sharex=True,
                             squeeze=False, gridspec_kw=dict(height_ratios=(3, 2)[:panels]))
    ax_f = axes[0, 0]
    phase_bands(ax_f, run)
    _draw_faults(ax_f, run, injected, detections)
    _draw_answers(ax_f, run, fault_responses(run.events))
    ax_f.legend(fontsize=8, loc='lower right', ncol=3, framealpha=0.9)
    ax_f.grid(alpha=0.3, axis='x')
    if truth is not None:
        ax_r = axes[1, 0]
        phase_bands(ax_r, run, legend=False)
        ax_r.semilogy(truth.t, np.linalg.norm(truth.position, axis=1), color='k', lw=1.2, label='truth range')
        if run.scenario is not None:
            ax_r.axhline(run.scenario.planner.restriction_sphere_radius_m, color='0.4', ls=':', lw=0.9,
                         label='restriction sphere')
        _draw_answers(ax_r, run, [])
        ax_r.set_ylabel('range |r| [m]')
        ax_r.grid(alpha=0.3, which='both')
        ax_r.legend(fontsize=8, loc='lower left')
    time_axis(axes[-1, 0], run)
    fig.suptitle(f'{run.title}: faults, detections (delay from the start) and responses')
    fig.tight_layout()
    plotting.save(fig, path, DPI)


FIGURES = (('faults_timeline.png', fig_faults_timeline),)
