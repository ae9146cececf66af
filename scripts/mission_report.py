#!/usr/bin/env python3
"""Figures of a mission run, from its bag and scenario (PNG, matplotlib Agg).

    .venv/bin/python scripts/mission_report.py RUN_DIR [--out DIR]

RUN_DIR is what scripts/run_mission.py leaves (bag/, scenario.yaml, summary.json); the figures go to
DIR (default RUN_DIR):

* trajectory_xz.png  chaser path in the hill x-z plane (seed 000 Fig. 11): truth, planned path, the
                     restriction sphere, the target's swept keep-out region and its boxes at the grasp
                     time, burns, start, X_Fi, X_Ft, grasp point; a second panel +-10 m about the target
* trajectory_3d.png  the same in 3-D within +-20 m of the target
* range.png          range and range rate, truth and estimate, over the mission phases and burns
* maneuvers.png      each executed burn's delta-v, commanded against executed
* estimation.png     chaser position / velocity and target attitude / body-rate errors with +-3 sigma
* clearance.png      gap of the chaser envelope to the target's boxes and to the swept region

and for a six-degree-of-freedom chaser (scenario chaser.model rigid_body; docs/chaser_6dof.md):

* attitude.png       chaser_body in hill (quaternion), truth and estimate; the estimate's attitude error
                     about hill axes with +-3 sigma; the inertial body rate (chaser_body axes)
* pointing.png       truth pointing error of body +x at the target's centre of mass, the window from the
                     first burn to the grasp, the 1 deg requirement and the summary's p95 / max
* wheels.png         reaction wheel speeds and motor torques with their limits
* thrusters.png      each thruster's thrust over time and the thrusters' total torque, with the
                     restriction sphere's entry and exit (no firing inside)

and for a run of the synchronized approach (summary.json's method sync; docs/synchronized.md), seed 001's figures
(Seweryn and Banaszkiewicz, section 3) from the truth, Euler angles R = Rz(psi) Ry(theta) Rx(phi) as the scenario
reads rpy_rad:

* seed001_fig4_position_velocity.png  Fig 4: the chaser's position and velocity relative to the target in hill, its
                     position in target_body and its thrust acceleration; stages 1-2 and stages 3-4 side by side
* seed001_fig5_euler_sigma.png        Fig 5: standard deviation of the estimated target Euler angles (the estimator's
                     covariance), and their error with +-3 sigma
* seed001_fig6_attitude.png           Fig 6: both bodies' Euler angles and body rates (from stage 3 the target's carried
                     by the relative attitude, which the chaser's follow), the relative attitude and rate
* seed001_fig7_kinetic_energy.png     Fig 7: translational (relative to hill) and rotational kinetic energy of both
                     bodies, and the chaser's wheels' spin energy

and for a scenario with a post_capture section (docs/post_capture.md: CAPTURE -> GRASP -> DAMPING -> MASS_ESTIMATION),
seed 004's Fig 5 (Matsunaga et al., the estimation results) and the phases before it, the truth from both bodies'
truth by flyby_mission.summary's functions (the figures of summary.json):

* seed004_fig5_motion.png             Fig 5 (a)-(d) during MASS_ESTIMATION: the combined CoM's position and velocity
                     (truth only: the mission publishes no estimate of them), the combined body's attitude and rate,
                     truth and the chaser attitude filter's estimate with +-3 sigma
* seed004_fig5_mass_properties.png    Fig 5 (e)-(h): the target's principal moments, mass, principal axes and CoM
                     from /estimation/target/inertia with +-3 sigma (the estimator's mass_properties_estimate events),
                     the truth and the prior
* post_capture_grasp_contact.png      the arm's contact force, torque and stroke during GRASP with its limits
* post_capture_damping_momentum.png   the combined body's angular momentum during DAMPING, seed 004's 0.1 kg m^2/s
* seed004_fig7_transport.png          Fig 7 during TRANSPORT (docs/transport.md): the combined body's angular momentum,
                     its CoM's distance to the goal and its speed relative to the goal's circular motion, each
                     against seed 004 §3.2's rendezvous condition, with the thrusters' firings

and for a run of several chasers (a ``chasers:`` scenario, docs/two_robots.md) instead of the above:

* chasers.png        every chaser's truth path in the hill x-z plane with the target's boxes at the least
                     separation; the least distance between two chasers' envelopes over time; each chaser's
                     clearance to the target's boxes (truth attitude)

Velocities follow nav_msgs' rule (DESIGN section 10): an Odometry's twist is in child_frame_id axes, so
twist.linear and its covariance are turned into hill by pose.orientation before use (the rigid-body
chaser's twist is in chaser_body axes; the point mass publishes the identity, which changes nothing).

An interrupted run works too: a bag without metadata.yaml is repaired first (as analyze_bag.py
does), and whatever is missing (topics, plan, grasp, burns, scenario) is left out; what was left out
is said on stderr. A figure whose essential data is missing is not written. Exit code 0, or 1 when a
figure failed (a bug: its traceback is on stderr) or the bag cannot be read.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import math
import sys
import traceback
import typing
from pathlib import Path

import matplotlib.colors
import numpy as np
from scipy.spatial.transform import Rotation

from flyby_estimation.mass_properties import principal_axis_errors_rad
from flyby_mission.summary import (
    angular_momentum_about_com,
    chaser_truth_from_odometry,
    damping_window,
    grasp_contact_series,
    grasp_time,
    lock_time,
    phase_windows,
    pointing_figures,
    post_capture_truth,
    target_mass_properties_truth,
    thrust_truth,
    transport_state,
)
from flyby_msgs_py import contract as c
from flyby_msgs_py.bag import BagError, MessageList, PathLatest, StringSeries, bag_topics, read_bag, repair_bag
from flyby_msgs_py.convert import inertia_to_numpy
from flyby_msgs_py.schema import ScenarioError
from flyby_msgs_py.wire import STAMP_TOLERANCE_S  # truth (every step) and estimate stamps: one instant
from flyby_planner.keepout import swept_region
from flyby_sim.dynamics.attitude import kinetic_energy
from flyby_sim.dynamics.attitude_control import pointing_error_rad
from flyby_sim.dynamics.geometry import clearance
from flyby_sim.dynamics.orbital import q_eci_from_body
from flyby_sim.dynamics.rigid_body import ReactionWheels
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_multiply,
    quat_normalize,
    quat_rotate_many,
    quat_to_matrix_many,
    rotation_angle_many,
    rotation_vector_from_quat,
)
from flyby_sim.scenario import load_scenario

sys.path.insert(0, str(Path(__file__).resolve().parent))  # scripts/ is not a package
import plots  # noqa: E402
from plots import plt  # noqa: E402

DPI = 100
BURN_MATCH_TOLERANCE_S = 0.01  # a commanded burn time against the simulator's start of it
STEP_TOLERANCE_S = 0.05        # a time this close to the truth's span is within it (one step)
REGION_SAMPLES = 200           # truth attitude samples the swept region is built from
TRUTH, ESTIMATE, PLAN = 'C0', 'C1', 'k'
REGION_FILL, BODY_FILL = '0.82', '0.45'
PHASE_COLORS = {
    c.PHASE_ESTIMATION: '#dddddd', c.PHASE_PLANNING: '#ffe9a8', c.PHASE_TERMINAL_APPROACH: '#cfe3ff',
    c.PHASE_TRAJECTORY_ADJUST: '#d9f2d0', c.PHASE_FLYBY: '#f9d5e5', c.PHASE_CAPTURE: '#b9f0e4',
    c.PHASE_ESCAPE: '#ffd9b3', c.PHASE_COMPLETE: '#e5e5ff', c.PHASE_ABORTED: '#ffb3b3',
    c.PHASE_SYNC_APPROACH: '#cfe3ff', c.PHASE_ATTITUDE_SYNC: '#fde2c4', c.PHASE_ORBITING: '#d9f2d0',
    c.PHASE_DOCKING: '#f9d5e5',
}
TOPICS = (c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM, c.EST_CHASER_ODOM, c.EST_TARGET_ODOM, c.PLANNER_PATH,
          c.PLANNER_GRASP, c.PLANNER_FLYBY_TARGET, c.PLANNER_FLYBY_INITIAL, c.MISSION_PHASE,
          c.MISSION_EVENTS)
RIGID_BODY_TOPICS = (c.SIM_CHASER_THRUST, c.SIM_CHASER_WHEELS, c.SIM_CHASER_THRUSTERS)  # read for rigid_body only
POST_CAPTURE_TOPICS = (c.EST_TARGET_INERTIA,)  # read with a post_capture section only
POINTING_REQUIREMENT_DEG = 1.0  # issue 13: p95 of the truth from the first terminal burn to the grasp


class Skipped(Exception):
    """A figure (or a part of one) cannot be drawn: its data is not in the run."""


def _say(message):
    print(f'mission_report: {message}', file=sys.stderr)


# ---------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Burn:
    t_start: float
    kind: str
    dv_cmd_hill: np.ndarray | None   # [m/s]
    dv_hill: np.ndarray | None       # executed [m/s]


def _vector(values, key):
    """A '[x, y, z]' event value as an array, None if absent."""
    return np.array(json.loads(values[key]), dtype=float) if key in values else None


def _burns(events):
    """Executed burns (the simulator's burn_started), labelled with the kind guidance commanded."""
    commanded = [(float(e['values']['t_burn_s']), e['values'].get('kind', 'burn'))
                 for e in events if e['name'] == 'maneuver_commanded' and 't_burn_s' in e['values']]
    burns = []
    for e in events:
        if e['name'] != 'burn_started' or e['hardware_id'] != 'flyby_sim':
            continue
        v = e['values']
        t_start = float(v.get('t_start', e['t']))
        t_cmd = float(v.get('t_cmd', t_start))
        kind = next((k for t, k in commanded if abs(t - t_cmd) <= BURN_MATCH_TOLERANCE_S), 'burn')
        burns.append(Burn(t_start, kind, _vector(v, 'dv_cmd_hill'), _vector(v, 'dv_hill')))
    return burns


def _is_empty(series):
    if isinstance(series, list):          # events
        return not series
    if isinstance(series, PathLatest):
        return not len(series.positions)
    if isinstance(series, StringSeries):
        return not series.data
    if isinstance(series, MessageList):
        return not series.messages
    return not len(series.t)


def _open_bag(bag_dir):
    """The bag's topics; a bag whose recorder was killed (no metadata.yaml) is repaired first."""
    try:
        return bag_topics(bag_dir)
    except BagError as err:
        if not bag_dir.is_dir():
            raise
        _say(f'{err}; repairing it')
        report = repair_bag(bag_dir)
        _say(f'bag repaired: {report["message_count"]} messages kept ({report.get("stop_reason")})')
        return bag_topics(bag_dir)


def match_stamps(t_a, t_b, tolerance_s=STAMP_TOLERANCE_S):
    """Index pairs (i_a, i_b) of the stamps of t_a with a stamp of t_b (sorted) within tolerance_s."""
    if not len(t_a) or not len(t_b):
        return np.zeros(0, int), np.zeros(0, int)
    right = np.searchsorted(t_b, t_a).clip(1, len(t_b) - 1) if len(t_b) > 1 else np.zeros(len(t_a), int)
    left = (right - 1).clip(0)
    nearest = np.where(np.abs(t_b[left] - t_a) <= np.abs(t_b[right] - t_a), left, right)
    ok = np.abs(t_b[nearest] - t_a) <= tolerance_s
    return np.flatnonzero(ok), nearest[ok]


def velocity_hill(odom):
    """twist.linear of an Odometry series (N, 3) in hill axes: turned by pose.orientation (child frame in
    hill), as nav_msgs' rule says (DESIGN section 10); the identity of a point mass changes nothing."""
    return quat_rotate_many(odom.orientation_xyzw, odom.linear)


def velocity_covariance_hill(odom):
    """The twist's linear covariance block (N, 3, 3) in hill axes: C_hill_from_child P C_hill_from_child'."""
    c_hill_from_child = quat_to_matrix_many(odom.orientation_xyzw)
    return np.einsum('nij,njk,nlk->nil', c_hill_from_child, odom.twist_covariance[:, :3, :3], c_hill_from_child)


def sphere_intervals(t, r_hill, radius_m):
    """[(t_entry, t_exit)] [s] of the positions r_hill (N, 3) at times t inside the sphere of radius_m
    about the hill origin, the crossings interpolated linearly in range; an interval still open at the
    end closes at t[-1] (one that is open at the start begins at t[0])."""
    r = np.linalg.norm(r_hill, axis=1)
    inside = r < radius_m
    if not len(r):
        return []
    crossings = []
    for i in np.flatnonzero(inside[1:] != inside[:-1]):
        crossings.append(t[i] + (radius_m - r[i]) / (r[i + 1] - r[i]) * (t[i + 1] - t[i]))
    edges = ([float(t[0])] if inside[0] else []) + [float(x) for x in crossings] + \
        ([float(t[-1])] if inside[-1] else [])
    return list(zip(edges[::2], edges[1::2], strict=True))


class Run:
    """What the figures draw from: the bag's series (absent or empty topics left out), the scenario,
    the summary, and quantities derived from them once."""

    def __init__(self, run_dir):
        self.run_dir = Path(run_dir)
        present = _open_bag(self.run_dir / 'bag')
        self.scenario = self._load_scenario()
        self.rigid_body = self.scenario is not None and self.scenario.chaser.model == 'rigid_body'
        self.post_capture = self.scenario is not None and self.scenario.post_capture is not None
        self.transport = self.post_capture and self.scenario.post_capture.transport is not None
        wanted = [c.absolute(t) for t in TOPICS + (RIGID_BODY_TOPICS if self.rigid_body else ())
                  + (POST_CAPTURE_TOPICS if self.post_capture else ())]
        data = read_bag(self.run_dir / 'bag', topics=[t for t in wanted if t in present])
        self.series = {t: s for t, s in data.items() if not _is_empty(s)}
        absent = [t for t in wanted if t not in self.series]
        if absent:
            _say(f'not in the bag or empty, left out: {", ".join(absent)}')
        self.events = self.series.get(c.absolute(c.MISSION_EVENTS), [])
        self.burns = _burns(self.events)
        summary = self.run_dir / 'summary.json'
        self.summary = json.loads(summary.read_text()) if summary.is_file() else {}
        self.sync = is_sync(self.summary, self.events)

    def _load_scenario(self):
        try:
            return load_scenario(self.run_dir / 'scenario.yaml')
        except (OSError, ScenarioError) as err:
            _say(f'no scenario ({err}): the sphere, keep-out region and clearances are left out')
            return None

    def get(self, topic):
        """The series of a contract topic, None if the run has none."""
        return self.series.get(c.absolute(topic))

    def need(self, *topics):
        """The series of the topics; Skipped naming the first one the run lacks."""
        for topic in topics:
            if self.get(topic) is None:
                raise Skipped(f'no {c.absolute(topic)}')
        return tuple(self.get(t) for t in topics) if len(topics) > 1 else self.get(topics[0])

    def need_scenario(self):
        if self.scenario is None:
            raise Skipped('no scenario.yaml')
        return self.scenario

    @property
    def title(self):
        s = self.scenario
        name = f'{s.name}, seed {s.seed}' if s is not None else self.run_dir.name
        outcome = self.summary.get('outcome')
        return f'{name}: {outcome}' if outcome else name

    @functools.cached_property
    def t_end(self):
        chaser = self.get(c.SIM_CHASER_ODOM)
        return float(chaser.t[-1]) if chaser is not None else max((e['t'] for e in self.events), default=0.0)

    @functools.cached_property
    def grasp(self):
        """(t_g, label): the supervisor's decided grasp time, else the planned one, else None."""
        t_g = grasp_time(self.events)
        if t_g is not None:
            return t_g, 'grasp'
        planned = self.get(c.PLANNER_GRASP)
        if planned is not None:
            return float(planned.t[-1]), 'planned grasp'
        return None, None

    @functools.cached_property
    def phases(self):
        """[(phase, t_start, t_end)] of the supervisor's stamped phase_changed events (summary.phase_windows), else
        of the receive times of /mission/phase, which lag the decisions; a window never ends before it starts."""
        windows = phase_windows(self.events, self.t_end)
        msgs = self.get(c.MISSION_PHASE)
        if not windows and msgs is not None:
            received = [{'name': 'phase_changed', 't': t, 'values': {'to': phase}}
                        for t, phase in zip(msgs.t_received, msgs.data, strict=True)]
            windows = phase_windows(received, self.t_end)
        return [(phase, t0, max(t0, t1)) for phase, t0, t1 in windows]

    @functools.cached_property
    def kind_colors(self):
        kinds = list(dict.fromkeys(b.kind for b in self.burns))
        palette = ('C3', 'C4', 'C6', 'C5', 'C8', 'C9', 'C7')  # not truth, estimate or start colours
        return {k: palette[i % len(palette)] for i, k in enumerate(kinds)}

    @functools.cached_property
    def sphere(self):
        """[(t_entry, t_exit)] of the truth chaser inside the restriction sphere; [] without truth or scenario."""
        chaser = self.get(c.SIM_CHASER_ODOM)
        if chaser is None or self.scenario is None:
            return []
        return sphere_intervals(chaser.t, chaser.position, self.scenario.planner.restriction_sphere_radius_m)

    def truth_pair(self):
        """(chaser, target, i_chaser, i_target): both bodies' truth series and the indices of their common stamps;
        Skipped if either is missing or they share no stamp."""
        chaser, target = self.need(c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM)
        i_c, i_t = match_stamps(chaser.t, target.t)
        if not len(i_c):
            raise Skipped('no truth chaser and target samples at the same stamps')
        return chaser, target, i_c, i_t

    def phase_window(self, phase):
        """(t_start, t_end) [s] of the run's first window of phase (Run.phases); Skipped if it never ran."""
        window = next(((t0, t1) for p, t0, t1 in self.phases if p == phase), None)
        if window is None:
            raise Skipped(f'no {phase} phase')
        return window

    @functools.cached_property
    def bodies(self):
        """flyby_mission.summary.post_capture_truth of the truth topics, read as compute_summary reads them: (common
        stamps, i_chaser, i_target, bodies(k) -> (chaser, target) grasp.Body at common[k]); Skipped without them."""
        odom, target, wheels = self.need(c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM, c.SIM_CHASER_WHEELS)
        wrench = self.get(c.SIM_CHASER_THRUST)
        thrust = None if wrench is None else thrust_truth(wrench, self.get(c.SIM_CHASER_THRUSTERS))
        scenario = self.need_scenario()
        return post_capture_truth(chaser_truth_from_odometry(odom), target, wheels, thrust, scenario,
                                  lock_time(self.events, scenario))

    def truth_at(self, t):
        """Truth chaser position (3,) at time t, interpolated."""
        chaser = self.need(c.SIM_CHASER_ODOM)
        return np.array([np.interp(t, chaser.t, chaser.position[:, k]) for k in range(3)])

    def target_attitude_at(self, t):
        """Truth q_hill_from_body at the truth sample nearest t, None if t is outside the truth."""
        target = self.get(c.SIM_TARGET_ODOM)
        if target is None or not target.t[0] - STEP_TOLERANCE_S <= t <= target.t[-1] + STEP_TOLERANCE_S:
            return None
        return target.orientation_xyzw[int(np.argmin(np.abs(target.t - t)))]

    @functools.cached_property
    def region(self):
        """The target's swept keep-out region from truth attitude samples up to the grasp, or None."""
        target = self.get(c.SIM_TARGET_ODOM)
        if self.scenario is None or target is None:
            return None
        t_g, _ = self.grasp
        before = np.flatnonzero(target.t <= (t_g if t_g is not None else np.inf))
        idx = before[np.linspace(0, len(before) - 1, min(REGION_SAMPLES, len(before))).astype(int)]
        n = self.scenario.mean_motion_rad_s
        try:
            return swept_region(self.scenario.boxes, self.scenario.target_inertia,
                                [q_eci_from_body(target.t[i], n, target.orientation_xyzw[i]) for i in idx],
                                target.angular[idx])
        except ValueError as err:
            _say(f'no swept keep-out region: {err}')
            return None

    @functools.cached_property
    def region_time(self):
        """(t, label) the region and the target's boxes are drawn at: the grasp time, else the end."""
        t_g, label = self.grasp
        return (t_g, label) if t_g is not None else (self.t_end, 'end of run')

    def planned_path(self):
        """(times, positions) of the last published path, up to the later of the run's end and the
        planned escape (flyby_duration_s past the grasp); None if no path."""
        path = self.get(c.PLANNER_PATH)
        if path is None:
            return None
        t_g, _ = self.grasp
        t_stop = self.t_end
        if t_g is not None and self.scenario is not None:
            t_stop = max(t_stop, t_g + self.scenario.planner.flyby_duration_s)
        keep = path.times <= t_stop
        return path.times[keep], path.positions[keep]

    def points(self):
        """[(label, position, marker style)] of the start and the planner's points the run has."""
        out = []
        chaser = self.get(c.SIM_CHASER_ODOM)
        if chaser is not None:
            out.append(('start', chaser.position[0], dict(marker='o', color='g', ms=11)))
        for topic, label, style in ((c.PLANNER_FLYBY_INITIAL, '$X_{Fi}$', dict(marker='s', color='m', ms=11)),
                                    (c.PLANNER_FLYBY_TARGET, '$X_{Ft}$', dict(marker='*', color='r', ms=13)),
                                    (c.PLANNER_GRASP, 'grasp point', dict(marker='X', color='darkred', ms=9))):
            series = self.get(topic)
            if series is not None:
                out.append((label, series.position[-1], style))
        return out


# ---------------------------------------------------------------------------------------------
# Shared drawing
# ---------------------------------------------------------------------------------------------

def box_corners_hill(scenario, q_hill_from_body):
    """Per target box: its 8 corners in hill (8, 3) [m] at the attitude q_hill_from_body."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    q = quat_normalize(q_hill_from_body)
    return [quat_rotate_many(q, np.asarray(center) + 0.5 * signs * np.asarray(size))
            for center, size in zip(scenario.boxes.center_body_m, scenario.boxes.size_m, strict=True)]


def _target_xz(ax, run):
    """The swept region and the target's boxes at the region time, and the restriction sphere."""
    t_r, label = run.region_time
    if run.region is not None:
        axis = run.region.axis_hill(t_r, run.scenario.mean_motion_rad_s)
        plots.fill_outline_xz(ax, plots.cylinder_surfaces(run.region, axis), color=REGION_FILL, lw=0, zorder=1,
                              label=f'swept keep-out region ({label}, t = {t_r:.0f} s)')
    q_true = run.target_attitude_at(t_r)
    if run.scenario is not None and q_true is not None:
        plots.fill_outline_xz(ax, box_corners_hill(run.scenario, q_true), color=BODY_FILL, lw=0, zorder=2,
                              label=f'target boxes at t = {t_r:.0f} s')
    if run.scenario is not None:
        radius = run.scenario.planner.restriction_sphere_radius_m
        plots.sphere_xz(ax, radius, color='0.4', lw=0.8, ls=':', label=f'restriction sphere {radius:g} m')


def _paths_and_points(ax, run, project):
    """Truth path, planned path, burns and the planner's points, drawn through project((N, 3)) ->
    plot coordinates (NaN for a point the axes leave out: it gets no legend entry either)."""
    chaser = run.need(c.SIM_CHASER_ODOM)
    ax.plot(*project(chaser.position), color=TRUTH, lw=2.2, label='chaser truth')
    planned = run.planned_path()
    if planned is not None:
        ax.plot(*project(planned[1]), color=PLAN, lw=1.0, ls='--', label='planned path')
    marks = [(f'{b.kind} burn', run.truth_at(b.t_start), dict(marker='^', ms=6, color=run.kind_colors[b.kind]))
             for b in run.burns]
    plots.mark_points(ax, run.points() + marks, project, mec='k', mew=0.5, zorder=5)


def _phase_bands(ax, run, legend=True):
    seen = set()
    for phase, t0, t1 in run.phases:
        ax.axvspan(t0, t1, color=PHASE_COLORS.get(phase, '#eeeeee'), lw=0, zorder=0,
                   label=phase if legend and phase not in seen else None)
        seen.add(phase)


def _grasp_line(ax, run, legend=True):
    """The grasp time (decided, else planned) as a vertical line, if it falls within the run."""
    t_g, label = run.grasp
    if t_g is not None and t_g <= run.t_end + STEP_TOLERANCE_S:
        ax.axvline(t_g, color='darkred', ls='-.', lw=0.9, label=label if legend else None)


def _burn_lines(ax, run, labels=True):
    for b in run.burns:
        ax.axvline(b.t_start, color=run.kind_colors[b.kind], lw=0.9, zorder=1)
        if labels:
            ax.text(b.t_start, 1.0, f' {b.kind}', transform=ax.get_xaxis_transform(), rotation=90,
                    va='bottom', ha='center', fontsize=7, color=run.kind_colors[b.kind])


# ---------------------------------------------------------------------------------------------
# Figures
# ---------------------------------------------------------------------------------------------

def fig_trajectory_xz(run, path):
    run.need(c.SIM_CHASER_ODOM)
    fig, axes = plt.subplots(1, 2, figsize=(16, 7.5))
    for ax, zoom in zip(axes, (None, 10.0), strict=True):
        _target_xz(ax, run)
        _paths_and_points(ax, run, plots.xz)
        ax.set(aspect='equal', xlabel='hill x, along-track [m]', ylabel='hill z, toward Earth [m] (up: away)')
        ax.grid(alpha=0.3)
        if zoom is not None:
            ax.set(xlim=(-zoom, zoom), ylim=(zoom, -zoom), title=f'within {zoom:g} m of the target')
        else:
            ax.set(adjustable='datalim', title='chaser in the hill x-z plane')
            ax.invert_yaxis()
    fig.legend(*axes[0].get_legend_handles_labels(), loc='center right', fontsize=9)
    fig.suptitle(run.title)
    fig.tight_layout(rect=(0, 0, 0.76, 1))
    plots.save(fig, path, DPI)


def _oblique_view(axis, elev=25.0, off_axis_deg=55.0):
    """(elev, azim) [deg]: the camera azimuth, nearest matplotlib's default -60 deg, that sees the
    region's axis about off_axis_deg from the line of sight, so its discs show as ellipses rather
    than edge-on or face-on (the z axis is drawn inverted: display up is -z)."""
    a = np.array((axis[0], axis[1], -axis[2]))
    azims = np.arange(-180.0, 180.0, 5.0)
    e, z = math.radians(elev), np.radians(azims)
    sight = np.stack((np.cos(e) * np.cos(z), np.cos(e) * np.sin(z), np.full_like(z, math.sin(e))), axis=1)
    off_axis = np.degrees(np.arccos(np.clip(np.abs(sight @ a), 0.0, 1.0)))
    from_default = np.abs((azims + 60.0 + 180.0) % 360.0 - 180.0)
    return elev, float(azims[np.argmin(np.abs(off_axis - off_axis_deg) + 0.1 * from_default)])


def fig_trajectory_3d(run, path, half_width_m=20.0):
    run.need(c.SIM_CHASER_ODOM)
    fig = plt.figure(figsize=(10, 9.5))
    ax = fig.add_axes((0.0, 0.1, 1.0, 0.85), projection='3d')
    t_r, label = run.region_time
    elev, azim = 22.0, -55.0
    if run.region is not None:
        axis = run.region.axis_hill(t_r, run.scenario.mean_motion_rad_s)
        elev, azim = _oblique_view(axis)
        for surface in plots.cylinder_surfaces(run.region, axis):
            ax.plot_surface(*np.moveaxis(surface, -1, 0), color='0.5', alpha=0.3, lw=0)
        ax.plot([], [], color='0.55', lw=6, alpha=0.5, label=f'swept keep-out region ({label}, t = {t_r:.0f} s)')
    if run.scenario is not None:
        radius = run.scenario.planner.restriction_sphere_radius_m
        plots.sphere_wireframe(ax, radius, 19, 10, color='0.6', lw=0.3, alpha=0.5,
                               label=f'restriction sphere {radius:g} m')
    _paths_and_points(ax, run, plots.cube_clip(half_width_m))
    plots.cube_axes(ax, half_width_m, 5,
                    labels=('hill x, along-track [m]', 'hill y, anti-normal [m]', 'hill z, toward Earth [m]'))
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=elev, azim=azim)
    fig.legend(*ax.get_legend_handles_labels(), loc='lower center', ncol=3, fontsize=9)
    fig.suptitle(f'{run.title}: within {half_width_m:g} m of the target (what lies beyond is left out)')
    plots.save(fig, path, DPI)


def _range_and_rate(series):
    r = np.linalg.norm(series.position, axis=1)
    return r, np.sum(series.position * velocity_hill(series), axis=1) / np.maximum(r, 1e-9)


def fig_range(run, path):
    truth = run.need(c.SIM_CHASER_ODOM)
    estimate = run.get(c.EST_CHASER_ODOM)
    curves = [(truth.t, _range_and_rate(truth), dict(color=TRUTH, lw=1.3, label='truth'))]
    if estimate is not None:
        curves.append((estimate.t, _range_and_rate(estimate), dict(color=ESTIMATE, lw=1.1, ls='--',
                                                                     label='estimate')))
    fig, (ax_r, ax_v) = plt.subplots(2, 1, figsize=(13, 8), sharex=True)
    for ax, k, unit in ((ax_r, 0, 'range |r| [m]'), (ax_v, 1, 'range rate [m/s]')):
        _phase_bands(ax, run, legend=ax is ax_r)
        _burn_lines(ax, run, labels=ax is ax_r)
        for t, values, style in curves:
            ax.plot(t, values[k], **style)
        ax.set_ylabel(unit)
        ax.grid(alpha=0.3, which='both')
    ax_r.set_yscale('log')
    if run.scenario is not None:
        ax_r.axhline(run.scenario.planner.restriction_sphere_radius_m, color='0.4', ls=':', lw=0.9,
                     label='restriction sphere')
    for ax in (ax_r, ax_v):
        _grasp_line(ax, run, legend=ax is ax_r)
    ax_v.axhline(0.0, color='k', lw=0.6)
    ax_v.set(xlabel='simulation time [s]', xlim=(0.0, run.t_end))
    ax_r.legend(fontsize=8, ncol=3, loc='lower left', framealpha=0.9)
    ax_v.legend(fontsize=8, loc='lower left')
    fig.suptitle(f'{run.title}: range to the target (vertical lines: burn starts)')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def fig_maneuvers(run, path):
    burns = run.burns
    if not burns:
        raise Skipped('no executed burn (burn_started event)')
    idx = np.arange(len(burns))
    mm = 1e3  # m/s -> mm/s
    nan3 = np.full(3, np.nan)
    cmd = np.array([b.dv_cmd_hill if b.dv_cmd_hill is not None else nan3 for b in burns]) * mm
    exe = np.array([b.dv_hill if b.dv_hill is not None else nan3 for b in burns]) * mm
    fig, (ax_c, ax_m, ax_e) = plt.subplots(3, 1, figsize=(13, 10), sharex=True,
                                           gridspec_kw=dict(height_ratios=(1.4, 1, 0.8)))
    width = 0.13
    for k, axis in enumerate('xyz'):
        color = f'C{k}'
        ax_c.bar(idx + (2 * k - 2.5) * width, cmd[:, k], width, color=color, alpha=0.35, edgecolor=color,
                 hatch='//', label=f'{axis} commanded')
        ax_c.bar(idx + (2 * k - 1.5) * width, exe[:, k], width, color=color, label=f'{axis} executed')
    linthresh = 0.01  # mm/s: well below any burn a thruster can make (0.1 mm/s for the paper's chaser)
    ax_c.set_yscale('symlog', linthresh=linthresh)
    ax_c.axhline(0.0, color='k', lw=0.6)
    ax_c.set_ylabel(f'delta-v hill component [mm/s]\n(symlog, linear below {linthresh:.2g})')
    ax_c.legend(fontsize=8, ncol=3)

    mag_cmd, mag_exe = np.linalg.norm(cmd, axis=1), np.linalg.norm(exe, axis=1)
    ax_m.bar(idx - 0.15, mag_cmd, 0.3, color='0.7', hatch='//', edgecolor='0.4', label='commanded |dv|')
    ax_m.bar(idx + 0.15, mag_exe, 0.3, color='C3', label='executed |dv|')
    for i, m in enumerate(mag_exe):
        if np.isfinite(m):
            ax_m.text(i + 0.15, m, f'{m:.3g}', ha='center', va='bottom', fontsize=7)
    ax_m.set(yscale='log', ylabel='|delta-v| [mm/s]')
    ax_m.legend(fontsize=8)

    magnitude_error = np.abs(mag_exe - mag_cmd) / mag_cmd * 100.0
    vector_error = np.linalg.norm(exe - cmd, axis=1) / mag_cmd * 100.0
    pointing_error = np.degrees(np.arccos(np.clip(np.sum(exe * cmd, axis=1) / (mag_exe * mag_cmd), -1.0, 1.0)))
    ax_e.bar(idx - 0.15, magnitude_error, 0.3, color='C4', label='magnitude error [%]')
    ax_e.bar(idx + 0.15, vector_error, 0.3, color='C5', label='|dv_exec - dv_cmd| / |dv_cmd| [%]')
    ax_e2 = ax_e.twinx()
    ax_e2.plot(idx, pointing_error, 'kd', ms=5, label='pointing error [deg]')
    ax_e2.set_ylabel('pointing error [deg]')
    for ax in (ax_e, ax_e2):  # headroom for the legend
        ax.set_ylim(0.0, 1.4 * ax.get_ylim()[1])
    ax_e.set_ylabel('execution error [%]')
    handles = ax_e.get_legend_handles_labels()[0] + ax_e2.get_legend_handles_labels()[0]
    ax_e.legend(handles=handles, fontsize=8, ncol=3, loc='upper left')
    ax_e.set_xticks(idx, [f'{b.kind}\nt = {b.t_start:.1f} s' for b in burns], fontsize=8)
    ax_e.set_xlabel('executed burns in order (kind, start time)')
    for ax in (ax_c, ax_m, ax_e):
        ax.grid(alpha=0.3, axis='y', which='both')
    fig.suptitle(f'{run.title}: {len(burns)} executed burns, commanded (hatched) against executed')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def _sigma3(covariance, block):
    return 3.0 * np.sqrt(np.maximum(np.diagonal(covariance[:, block, block], axis1=1, axis2=2), 0.0))


def _matched(run, est_topic, truth_topic):
    """(estimate, truth, i_est, i_truth) at the same stamps, or the reason there is none."""
    est, truth = run.get(est_topic), run.get(truth_topic)
    if est is None or truth is None:
        return f'no {c.absolute(est_topic if est is None else truth_topic)}'
    i_est, i_truth = match_stamps(est.t, truth.t)
    if not len(i_est):
        return f'no {c.absolute(est_topic)} stamp matches {c.absolute(truth_topic)}'
    return est, truth, i_est, i_truth


def estimation_errors(run):
    """The four rows of estimation.png: (quantity, unit, t, error (N, 3), 3 sigma (N, 3)), or
    (quantity, reason) for a row the run has no data for.

    Errors are estimate minus truth at the same stamps; the chaser velocity and its covariance in hill
    axes (velocity_hill: the rigid-body chaser's twist is in chaser_body axes). The target attitude
    error is the rotation vector of q_est q_true^-1, i.e. about hill axes like the pose covariance the
    estimator publishes (flyby_estimation.target_motion.PredictedState.covariance_hill); the body-rate
    error and its covariance are in body axes.
    """
    pos, rot = slice(0, 3), slice(3, 6)
    deg = math.degrees(1.0)
    rows = []
    chaser = _matched(run, c.EST_CHASER_ODOM, c.SIM_CHASER_ODOM)
    if isinstance(chaser, str):
        rows += [('chaser position', chaser), ('chaser velocity (hill axes)', chaser)]
    else:
        e, tr, i, j = chaser
        rows.append(('chaser position', 'm', e.t[i], e.position[i] - tr.position[j],
                     _sigma3(e.pose_covariance[i], pos)))
        rows.append(('chaser velocity (hill axes)', 'm/s', e.t[i], velocity_hill(e)[i] - velocity_hill(tr)[j],
                     _sigma3(velocity_covariance_hill(e)[i], pos)))
    target = _matched(run, c.EST_TARGET_ODOM, c.SIM_TARGET_ODOM)
    if isinstance(target, str):
        rows += [('target attitude', target), ('target body rate', target)]
    else:
        e, tr, i, j = target
        dtheta = np.array([rotation_vector_from_quat(quat_multiply(q_est, quat_conjugate(q_true)))
                           for q_est, q_true in zip(e.orientation_xyzw[i], tr.orientation_xyzw[j], strict=True)])
        rows.append(('target attitude (hill axes)', 'deg', e.t[i], dtheta * deg,
                     _sigma3(e.pose_covariance[i], rot) * deg))
        rows.append(('target body rate (body axes)', 'deg/s', e.t[i], (e.angular[i] - tr.angular[j]) * deg,
                     _sigma3(e.twist_covariance[i], rot) * deg))
    return rows


def _error_row(ax_row, run, name, unit, t, err, sig3, symlog=True):
    """Estimate - truth err (N, 3) with its +-3 sigma sig3 (N, 3) at times t, one axis per component; symlog False:
    a linear scale (a window in which the filter has settled)."""
    # Linear up to the decade above the typical 3 sigma of the second half of the run,
    # logarithmic beyond (the first estimates are far larger).
    typical = float(np.median(sig3[len(sig3) // 2:]))
    linthresh = 10.0 ** math.ceil(math.log10(typical)) if typical > 0.0 else 1e-9
    for k, (ax, axis) in enumerate(zip(ax_row, 'xyz', strict=True)):
        ax.fill_between(t, -sig3[:, k], sig3[:, k], color='C0', alpha=0.2, lw=0, label='$\\pm 3\\sigma$')
        ax.plot(t, err[:, k], color='C3', lw=0.7, label='estimate - truth')
        if symlog:
            ax.set_yscale('symlog', linthresh=linthresh)
        ax.axhline(0.0, color='k', lw=0.5)
        _grasp_line(ax, run)
        ax.grid(alpha=0.3)
        ax.set_title(f'{name}, {axis}', fontsize=9)
        outside = np.mean(np.abs(err[:, k]) > sig3[:, k]) * 100.0
        ax.text(0.99, 0.03, f'{outside:.1f} % outside 3$\\sigma$', transform=ax.transAxes, ha='right',
                fontsize=7)
    ax_row[0].set_ylabel(f'[{unit}] (symlog,\nlinear below {linthresh:.2g})' if symlog else f'[{unit}]')


def fig_estimation(run, path):
    rows = estimation_errors(run)
    if all(len(r) == 2 for r in rows):
        raise Skipped('; '.join(dict.fromkeys(r[1] for r in rows)))
    fig, axes = plt.subplots(len(rows), 3, figsize=(15, 12), sharex=True)
    for row, ax_row in zip(rows, axes, strict=True):
        if len(row) == 2:
            _say(f'estimation.png: {row[0]} left out: {row[1]}')
            for ax in ax_row:
                ax.text(0.5, 0.5, row[1], transform=ax.transAxes, ha='center', fontsize=8)
            ax_row[0].set_ylabel(row[0])
            continue
        _error_row(ax_row, run, *row)
    for ax in axes[-1]:
        ax.set_xlabel('simulation time [s]')
    handles = next((ax.get_legend_handles_labels() for ax in axes[:, 0] if ax.get_legend_handles_labels()[0]),
                   None)
    if handles:
        fig.legend(*handles, loc='upper right', fontsize=8, ncol=3)
    fig.suptitle(f'{run.title}: estimation errors')
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    plots.save(fig, path, DPI)


def clearances(run):
    """(t, gap to the target's boxes [m], gap to the swept region [m] or None) over the truth."""
    scenario = run.need_scenario()
    chaser, target, i_c, i_t = run.truth_pair()
    t, r = chaser.t[i_c], chaser.position[i_c]
    envelope = scenario.chaser.envelope_radius_m
    boxes = list(zip(scenario.boxes.center_body_m, scenario.boxes.size_m, strict=True))
    actual = clearance(r, target.orientation_xyzw[i_t], boxes, envelope)
    swept = None if run.region is None else run.region.clearance(r, t, scenario.mean_motion_rad_s, envelope)
    return t, actual, swept


def fig_clearance(run, path, window_s=30.0):
    t, actual, swept = clearances(run)
    k = int(np.argmin(actual))
    fig, (ax_all, ax_zoom) = plt.subplots(2, 1, figsize=(13, 9))
    zoom = np.abs(t - t[k]) <= window_s
    for ax, keep in ((ax_all, slice(None)), (ax_zoom, zoom)):
        ax.plot(t[keep], actual[keep], color=TRUTH, lw=1.3, label="to the target's boxes (truth attitude)")
        if swept is not None:
            ax.plot(t[keep], swept[keep], color='C2', lw=1.1, ls='--', label='to the swept keep-out region')
        ax.axhline(0.0, color='r', lw=1.0, label='contact')
        ax.plot(t[k], actual[k], 'rv', ms=8, label=f'closest: {actual[k]:.3f} m at t = {t[k]:.2f} s')
        t_g, label = run.grasp
        if t_g is not None and t[keep][0] <= t_g <= t[keep][-1]:
            ax.axvline(t_g, color='darkred', ls='-.', lw=0.9, label=label)
        ax.grid(alpha=0.3, which='both')
        ax.set_ylabel('envelope clearance [m]')
    _phase_bands(ax_all, run)
    _phase_bands(ax_zoom, run, legend=False)
    ax_all.set_yscale('symlog', linthresh=1.0)
    ax_all.set(xlim=(t[0], t[-1]), title='whole run (symlog: linear below 1 m)')
    ax_all.legend(fontsize=8, ncol=3, loc='lower left', framealpha=0.9)
    ax_zoom.set(xlabel='simulation time [s]', xlim=(t[zoom][0], t[zoom][-1]),
                title=f'within {window_s:g} s of the closest approach')
    ax_zoom.legend(fontsize=8, loc='best')
    fig.suptitle(f'{run.title}: clearance of the chaser envelope '
                 f'({run.scenario.chaser.envelope_radius_m:g} m sphere)')
    fig.tight_layout()
    plots.save(fig, path, DPI)


# ---------------------------------------------------------------------------------------------
# The six-degree-of-freedom chaser (chaser.model rigid_body)
# ---------------------------------------------------------------------------------------------

def continuous_quaternions(q):
    """Quaternions (N, 4) (x, y, z, w) each multiplied by +-1 so that neighbours agree in sign and the first
    has w >= 0 (q and -q are one attitude): their components then plot as continuous curves."""
    q = np.array(q, dtype=float)
    if not len(q):
        return q
    flips = np.concatenate(([q[0, 3] < 0.0], np.einsum('ij,ij->i', q[1:], q[:-1]) < 0.0))
    return q * np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)[:, None]


def chaser_attitude_estimate(run):
    """(estimate, truth, i_est, i_truth): the chaser estimates that carry an attitude (a nonzero orientation
    covariance) at the truth's stamps, or the reason there are none."""
    matched = _matched(run, c.EST_CHASER_ODOM, c.SIM_CHASER_ODOM)
    if isinstance(matched, str):
        return matched
    e, tr, i, j = matched
    keep = np.any(e.pose_covariance[i, 3:, 3:] != 0.0, axis=(1, 2))
    if not np.any(keep):
        return f'no {c.absolute(c.EST_CHASER_ODOM)} sample carries an attitude (zero orientation covariance)'
    return e, tr, i[keep], j[keep]


def _sphere_spans(ax, run, label=True):
    """The restriction sphere's inside (truth range below its radius) shaded, entry and exit as lines."""
    for k, (t_in, t_out) in enumerate(run.sphere):
        ax.axvspan(t_in, t_out, facecolor='none', edgecolor='0.35', hatch='///', lw=0, zorder=0.5,
                   label='inside the restriction sphere' if label and k == 0 else None)
        for t in (t_in, t_out):
            ax.axvline(t, color='0.35', ls=':', lw=1.0, zorder=1)


def _time_axis(ax, run, xlabel=True):
    ax.set_xlim(0.0, run.t_end)
    ax.grid(alpha=0.3)
    if xlabel:
        ax.set_xlabel('simulation time [s]')


def fig_attitude(run, path):
    truth = run.need(c.SIM_CHASER_ODOM)
    deg = math.degrees(1.0)
    estimate = chaser_attitude_estimate(run)
    fig = plt.figure(figsize=(15, 12))
    grid = fig.add_gridspec(3, 3, height_ratios=(1.2, 1.0, 1.0))
    ax_q = fig.add_subplot(grid[0, :])
    ax_err = [fig.add_subplot(grid[1, k], sharex=ax_q) for k in range(3)]
    ax_w = fig.add_subplot(grid[2, :], sharex=ax_q)
    for ax in (ax_q, ax_w):
        _phase_bands(ax, run, legend=ax is ax_q)
        _burn_lines(ax, run, labels=ax is ax_q)
        _grasp_line(ax, run, legend=ax is ax_q)

    q_true = continuous_quaternions(truth.orientation_xyzw)
    for k, name in enumerate('xyzw'):
        ax_q.plot(truth.t, q_true[:, k], color=f'C{k}', lw=1.4, label=f'$q_{name}$')
    for k, name in enumerate('xyz'):
        ax_w.plot(truth.t, truth.angular[:, k] * deg, color=f'C{k}', lw=1.2, label=f'$\\omega_{name}$')
    if isinstance(estimate, str):
        _say(f'attitude.png: the estimate left out: {estimate}')
        for ax in ax_err:
            ax.text(0.5, 0.5, estimate, transform=ax.transAxes, ha='center', fontsize=8, wrap=True)
    else:
        e, tr, i, j = estimate
        q_est = e.orientation_xyzw[i]
        q_est = q_est * np.where(np.einsum('ij,ij->i', q_est, q_true[j]) < 0.0, -1.0, 1.0)[:, None]
        for k in range(4):
            ax_q.plot(e.t[i], q_est[:, k], color='k', lw=0.6, ls=(0, (4, 4)),
                      label='estimate (dashed)' if k == 0 else None)
        for k in range(3):
            ax_w.plot(e.t[i], e.angular[i, k] * deg, color='k', lw=0.6, ls=(0, (4, 4)),
                      label='estimate (dashed)' if k == 0 else None)
        # The attitude error as the rotation vector of q_est q_true^-1: about hill axes, like the
        # orientation block of the pose covariance (the estimator's attitude_covariance_hill).
        dtheta = np.array([rotation_vector_from_quat(quat_multiply(a, quat_conjugate(b)))
                           for a, b in zip(e.orientation_xyzw[i], tr.orientation_xyzw[j], strict=True)])
        _error_row(ax_err, run, 'chaser attitude error (hill axes)', 'deg', e.t[i], dtheta * deg,
                   _sigma3(e.pose_covariance[i], slice(3, 6)) * deg)
        ax_err[1].legend(*ax_err[1].get_legend_handles_labels(), fontsize=8, loc='upper right', ncol=3)
    ax_q.set(ylabel='$q_{hill \\leftarrow body}$ component\n(sign kept continuous)', ylim=(-1.05, 1.05))
    ax_q.legend(fontsize=8, ncol=5, loc='lower left', framealpha=0.9)
    ax_w.set(ylabel='[deg/s]', title='inertial angular velocity in chaser_body axes, truth and estimate')
    ax_w.legend(fontsize=8, ncol=4, loc='lower left', framealpha=0.9)
    _time_axis(ax_q, run, xlabel=False)
    _time_axis(ax_w, run)
    for ax in ax_err:
        ax.set_xlabel('simulation time [s]')
    fig.suptitle(f'{run.title}: chaser attitude, chaser_body in hill (quaternion x, y, z, w), truth and estimate')
    fig.tight_layout(rect=(0, 0, 1, 0.98))
    plots.save(fig, path, DPI)


def pointing_window(run):
    """(t_start, t_end) [s] of the pointing requirement: the first burn's start to the grasp (else the end of
    the truth), as flyby_mission.summary.pointing_figures; None before any burn."""
    if not run.burns:
        return None
    t_g = grasp_time(run.events)
    return min(b.t_start for b in run.burns), (t_g if t_g is not None else run.t_end)


def fig_pointing(run, path):
    truth = run.need(c.SIM_CHASER_ODOM)
    error_deg = np.degrees(pointing_error_rad(truth.orientation_xyzw, truth.position))
    floor = 1e-4  # [deg] a log axis shows no zero
    window = pointing_window(run)
    figures = {k: run.summary.get(k) for k in ('pointing_error_p95_deg', 'pointing_error_max_deg')}
    source = 'summary.json'
    if figures['pointing_error_p95_deg'] is None and window is not None:
        figures, source = pointing_figures(truth, run.events, grasp_time(run.events)), 'bag'
    fig, (ax, ax_cdf) = plt.subplots(1, 2, figsize=(15, 7.5), gridspec_kw=dict(width_ratios=(3.2, 1)))
    _phase_bands(ax, run)
    _burn_lines(ax, run)
    _sphere_spans(ax, run)
    est = chaser_attitude_estimate(run)
    if not isinstance(est, str):
        e, _, i, _ = est
        ax.plot(e.t[i], np.maximum(np.degrees(pointing_error_rad(e.orientation_xyzw[i], e.position[i])), floor),
                color=ESTIMATE, lw=0.6, alpha=0.8, label="estimate's (what guidance controls)")
    ax.plot(truth.t, np.maximum(error_deg, floor), color=TRUTH, lw=1.2, label='truth')
    ax.axhline(POINTING_REQUIREMENT_DEG, color='r', ls='--', lw=1.1,
               label=f'requirement: p95 <= {POINTING_REQUIREMENT_DEG:g} deg')
    _grasp_line(ax, run)
    title = 'no burn: no requirement window'
    if window is not None:
        t0, t1 = window
        ax.axvspan(t0, t1, ymin=0.0, ymax=0.015, color='0.15', lw=0, label='window: first burn to grasp')
        inside = (truth.t >= t0) & (truth.t <= t1)
        p95, peak = figures['pointing_error_p95_deg'], figures['pointing_error_max_deg']
        if p95 is not None:
            ax.hlines(p95, t0, t1, color='k', ls='--', lw=1.0, label=f'p95 {p95:.3g} deg ({source})')
        if np.any(inside):
            k = np.flatnonzero(inside)[int(np.argmax(error_deg[inside]))]
            ax.plot(truth.t[k], error_deg[k], 'kv', ms=7, label=f'max {error_deg[k]:.3g} deg at t = {truth.t[k]:.1f} s')
            ordered = np.sort(error_deg[inside])
            ax_cdf.plot(np.maximum(ordered, floor), np.arange(1, len(ordered) + 1) / len(ordered) * 100.0,
                        color=TRUTH, lw=1.4)
        if p95 is not None:
            ax_cdf.axvline(p95, color='k', ls='--', lw=1.0, label=f'p95 {p95:.3g} deg')
            ax_cdf.axhline(95.0, color='k', ls=':', lw=0.8)
        title = (f'window {t0:.1f} to {t1:.1f} s: p95 {p95:.3g} deg, max {peak:.3g} deg ({source})'
                 if p95 is not None else f'window {t0:.1f} to {t1:.1f} s')
    ax.set(yscale='log', ylabel='body +x from the line of sight\nto the target CoM [deg]')
    _time_axis(ax, run)
    ax.legend(fontsize=8, ncol=5, loc='upper center', bbox_to_anchor=(0.5, -0.12), framealpha=0.9)
    ax_cdf.axvline(POINTING_REQUIREMENT_DEG, color='r', ls='--', lw=1.1, label='requirement')
    ax_cdf.set(xscale='log', ylim=(0.0, 100.0), xlabel='pointing error [deg]',
               ylabel='share of the window [%]', title='in the window (truth)')
    ax_cdf.grid(alpha=0.3, which='both')
    if ax_cdf.get_legend_handles_labels()[0]:
        ax_cdf.legend(fontsize=8, loc='lower right')
    fig.suptitle(f'{run.title}: pointing of body +x at the target centre of mass\n{title}')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def fig_wheels(run, path):
    wheels = run.need(c.SIM_CHASER_WHEELS)
    limits = run.need_scenario().chaser.wheels
    speed_limit = limits.max_momentum_n_m_s / limits.spin_inertia_kg_m2
    axes = np.asarray(limits.axes, dtype=float)
    fig, (ax_s, ax_u) = plt.subplots(2, 1, figsize=(13, 8.5), sharex=True)
    for ax in (ax_s, ax_u):
        _phase_bands(ax, run, legend=ax is ax_s)
        _burn_lines(ax, run, labels=ax is ax_s)
        _sphere_spans(ax, run, label=ax is ax_s)
    for k, name in enumerate(wheels.names):
        axis = f', axis ({", ".join(f"{a:.3g}" for a in axes[k])})' if len(axes) == len(wheels.names) else ''
        ax_s.plot(wheels.t, wheels.velocity[:, k], color=f'C{k}', lw=1.1, label=f'{name}{axis}')
        ax_u.plot(wheels.t, wheels.effort[:, k], color=f'C{k}', lw=0.6, label=name)
    for sign in (1.0, -1.0):
        ax_s.axhline(sign * speed_limit, color='r', ls='--', lw=1.0,
                     label=f'momentum limit {limits.max_momentum_n_m_s:g} N m s / {limits.spin_inertia_kg_m2:g} '
                           f'kg m$^2$ = {speed_limit:.4g} rad/s' if sign > 0 else None)
        ax_u.axhline(sign * limits.max_torque_n_m, color='r', ls='--', lw=1.0,
                     label=f'torque limit {limits.max_torque_n_m:g} N m' if sign > 0 else None)
    ax_s.secondary_yaxis('right', functions=(lambda w: w * limits.spin_inertia_kg_m2,
                                             lambda h: h / limits.spin_inertia_kg_m2)).set_ylabel(
        'J$_s$ x speed [N m s]')
    peak = np.nanmax(np.abs(wheels.velocity))
    ax_s.set(ylabel='wheel speed relative to the body [rad/s]')
    ax_u.set(ylabel='motor torque applied [N m]\n(limits included)')
    ax_s.legend(fontsize=8, ncol=3, loc='lower left', framealpha=0.9)
    ax_u.legend(fontsize=8, ncol=4, loc='lower left', framealpha=0.9)
    _time_axis(ax_s, run, xlabel=False)
    _time_axis(ax_u, run)
    fig.suptitle(f'{run.title}: reaction wheels (/sim/chaser/wheels)\n'
                 f'largest |speed| {peak:.3g} rad/s = {peak / speed_limit * 100.0:.1f} % of the momentum limit')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def firing_inside_sphere(run, t, firing):
    """How many of the samples at times t with firing (N,) true fired inside the restriction sphere: the
    truth range below the radius at the sample or at the one before (a sample's thrust acted between
    them), as flyby_mission.summary.thrust_figures counts; None without truth or scenario."""
    chaser = run.get(c.SIM_CHASER_ODOM)
    if chaser is None or run.scenario is None or not len(t):
        return None
    inside = np.interp(t, chaser.t, np.linalg.norm(chaser.position, axis=1)) < \
        run.scenario.planner.restriction_sphere_radius_m
    inside[1:] |= inside[:-1]
    return int(np.sum(firing & inside))


def fig_thrusters(run, path, max_bins=1200):
    thrusters = run.need(c.SIM_CHASER_THRUSTERS)
    f_max = run.need_scenario().chaser.thrusters.max_thrust_n
    wrench = run.get(c.SIM_CHASER_THRUST)
    t, thrust = thrusters.t, np.nan_to_num(thrusters.effort)
    n_thrusters = thrust.shape[1]
    # Each thruster's largest thrust in each time bin, bins no shorter than a sample's step: a single
    # firing step stays visible and no bin is left empty between two samples.
    span = max(run.t_end, t[-1])
    bins = int(min(max_bins, span / np.median(np.diff(t)))) if len(t) > 1 else 1
    edges = np.linspace(0.0, span, bins + 1)
    peak = np.zeros((bins, n_thrusters))
    np.maximum.at(peak, np.clip(np.searchsorted(edges, t, side='right') - 1, 0, bins - 1), thrust)
    fig = plt.figure(figsize=(14, 9))
    grid = fig.add_gridspec(2, 2, height_ratios=(1.6, 1), width_ratios=(1, 0.015), wspace=0.02)
    ax_r = fig.add_subplot(grid[0, 0])
    ax_m = fig.add_subplot(grid[1, 0], sharex=ax_r)
    _phase_bands(ax_r, run)
    positive = thrust[thrust > 0.0]
    vmin = max(float(positive.min()) if len(positive) else f_max * 1e-3, f_max * 1e-4)
    image = ax_r.imshow(np.ma.masked_less_equal(peak.T, 0.0), aspect='auto', interpolation='nearest',
                        cmap='viridis', norm=matplotlib.colors.LogNorm(vmin=vmin, vmax=f_max), zorder=2,
                        extent=(edges[0], edges[-1], n_thrusters - 0.5, -0.5))
    fig.colorbar(image, cax=fig.add_subplot(grid[0, 1]), label=f'thrust [N], largest in each {edges[1]:.2g} s bin')
    ax_r.set_yticks(range(n_thrusters), thrusters.names)
    ax_r.set(ylabel='thruster (/sim/chaser/thrusters effort)')
    firing = np.any(thrust > 0.0, axis=1)
    if wrench is not None:
        torque = np.linalg.norm(wrench.torque, axis=1)
        force = np.linalg.norm(wrench.force, axis=1)
        firing_w = (torque > 0.0) | (force > 0.0)
        _phase_bands(ax_m, run, legend=False)
        floor = 1e-5  # [N], [N m]: arithmetic residues of pure forces and couples go on the bottom edge
        for values, color, name in ((force, 'C1', '|force| [N]'), (torque, 'C3', '|torque| about the CoM [N m]')):
            ax_m.plot(wrench.t[firing_w], np.where(values > 0.0, np.maximum(values, floor), np.nan)[firing_w], '.',
                      color=color, ms=3, label=name)
        ax_m.set(yscale='log', ylim=(0.5 * floor, None),
                 ylabel=f'/sim/chaser/thrust\n[N] and [N m] (below {floor:g}:\non the bottom edge)')
    else:
        ax_m.text(0.5, 0.5, f'no {c.absolute(c.SIM_CHASER_THRUST)}', transform=ax_m.transAxes, ha='center')
    for ax in (ax_r, ax_m):
        _burn_lines(ax, run, labels=ax is ax_r)
        _sphere_spans(ax, run)
        _time_axis(ax, run, xlabel=ax is ax_m)
    handles, labels = ax_m.get_legend_handles_labels()
    if handles:
        ax_m.legend(handles, labels, fontsize=8, ncol=3, loc='lower left', framealpha=0.9)
    n_inside = firing_inside_sphere(run, t, firing)
    radius = run.scenario.planner.restriction_sphere_radius_m
    entries = ', '.join(f'{a:.1f} to {"the end" if b >= run.t_end - STEP_TOLERANCE_S else f"{b:.1f} s"}'
                        for a, b in run.sphere) or 'never'
    verdict = ('no firing inside' if n_inside == 0 else
               f'{n_inside} firing samples INSIDE' if n_inside is not None else 'no truth')
    fig.suptitle(f'{run.title}: thrust of each thruster and of all (nothing drawn: off)\n'
                 f'inside the {radius:g} m restriction sphere (hatched): {entries}; {verdict}')
    fig.subplots_adjust(left=0.08, right=0.93, top=0.9, bottom=0.07, hspace=0.12)
    plots.save(fig, path, DPI)


# ---------------------------------------------------------------------------------------------
# The synchronized approach (seed 001 section 2, its Fig 4-7)
# ---------------------------------------------------------------------------------------------

SYNC_STAGES = (('stages 1-2', (c.PHASE_SYNC_APPROACH, c.PHASE_ATTITUDE_SYNC)),
               ('stages 3-4', (c.PHASE_ORBITING, c.PHASE_DOCKING)))
RPY_NAMES = ('$\\phi$ (roll, x)', '$\\theta$ (pitch, y)', '$\\psi$ (yaw, z)')
RPY_SEQUENCE = 'R = Rz($\\psi$) Ry($\\theta$) Rx($\\phi$) of body in hill'


def is_sync(summary, events):
    """Whether the run flew the synchronized approach: summary.json's method, or a plan_selected event's."""
    return summary.get('method') == 'sync' or any(
        e['name'] == 'plan_selected' and e['values'].get('method') == 'sync' for e in events)


def stage_windows(phases):
    """{'stages 1-2': (t0, t1), 'stages 3-4': (t0, t1)} [s] of the phase windows [(phase, t0, t1)]: seed 001's
    stages 1-2 (phase-space transfer, attitude synchronization) and 3-4 (orbiting, docking), each from the start of
    its first phase to the end of its last; a pair the run did not reach is left out."""
    out = {}
    for name, members in SYNC_STAGES:
        spans = [(t0, t1) for phase, t0, t1 in phases if phase in members]
        if spans:
            out[name] = (min(t0 for t0, _ in spans), max(t1 for _, t1 in spans))
    return out


def euler_rpy(q_hill_from_body):
    """Euler angles (phi, theta, psi) [rad] (N, 3) of q_hill_from_body (N, 4): R = Rz(psi) Ry(theta) Rx(phi), the
    scenario's reading of rpy_rad (scipy's extrinsic 'xyz'); theta in [-pi/2, pi/2], phi and psi in [-pi, pi]."""
    return Rotation.from_quat(q_hill_from_body).as_euler('xyz')


def euler_from_hill_rotation(rpy):
    """(N, 3, 3) J = d(phi, theta, psi) / d(dtheta_hill) at the Euler angles rpy (N, 3) [rad] (euler_rpy): a small
    rotation dtheta_hill about hill axes (q' = exp(dtheta_hill) q, how the estimator's attitude error is defined)
    moves the angles by J dtheta_hill. J inverts [Rz(psi) Ry(theta) e_x, Rz(psi) e_y, e_z], the hill-axes angular
    velocities of unit Euler rates, and grows without bound at theta = +-90 deg (gimbal lock)."""
    _, theta, psi = np.moveaxis(np.asarray(rpy, dtype=float), -1, 0)
    cos_psi, sin_psi, zero = np.cos(psi), np.sin(psi), np.zeros_like(psi)
    return np.stack((np.stack((cos_psi, sin_psi, zero), -1) / np.cos(theta)[:, None],
                     np.stack((-sin_psi, cos_psi, zero), -1),
                     np.stack((cos_psi * np.tan(theta), sin_psi * np.tan(theta), zero + 1.0), -1)), axis=1)


def euler_estimation_errors(run):
    """Seed 001 Fig 5: (t [s], error (N, 3), sigma (N, 3)) [rad] of the target's Euler angles (euler_rpy) estimated
    on /estimation/target/odom against the truth at the same stamps. sigma is the standard deviation the estimator
    publishes: its attitude covariance P (about hill axes, as estimation_errors reads it) carried into the angles to
    first order, J P J' with J = euler_from_hill_rotation at the truth."""
    matched = _matched(run, c.EST_TARGET_ODOM, c.SIM_TARGET_ODOM)
    if isinstance(matched, str):
        raise Skipped(matched)
    e, tr, i, j = matched
    rpy_true = euler_rpy(tr.orientation_xyzw[j])
    error = (euler_rpy(e.orientation_xyzw[i]) - rpy_true + np.pi) % (2.0 * np.pi) - np.pi  # the short way round
    jac = euler_from_hill_rotation(rpy_true)
    covariance = jac @ e.pose_covariance[i, 3:, 3:] @ np.swapaxes(jac, 1, 2)
    return e.t[i], error, _sigma3(covariance, slice(0, 3)) / 3.0


class SyncTranslation(typing.NamedTuple):
    """Seed 001 Fig 4 (sync_translation)."""

    t: np.ndarray              # (N,) [s] truth stamps of chaser and target
    r_hill: np.ndarray         # (N, 3) [m] chaser CoM from the target's (the hill origin)
    v_hill: np.ndarray         # (N, 3) [m/s] relative to the rotating hill frame, hill axes
    r_target_body: np.ndarray  # (N, 3) [m] r_hill in target_body axes
    a_thrust_mps2: np.ndarray  # (N,) |thrust force| / initial mass, NaN where /sim/chaser/thrust has no sample


def sync_translation(run):
    """Seed 001 Fig 4 from the truth: the chaser's position and velocity relative to the target in hill (the twist is
    in chaser_body axes: velocity_hill), its position in target_body axes (constant while orbiting, seed 001 Fig 2;
    radial while docking, Fig 3), and the thrusters' acceleration |F| / m0 with the scenario's initial mass (the fuel
    burned, under 3 % of it in seweryn_tumbling, left out)."""
    truth, target, i_c, i_t = run.truth_pair()
    t, r_hill = truth.t[i_c], truth.position[i_c]
    r_target_body = quat_rotate_many(quat_conjugate(target.orientation_xyzw[i_t].T).T, r_hill)
    a_thrust = np.full(len(t), np.nan)
    thrust = run.get(c.SIM_CHASER_THRUST)
    if thrust is not None:
        i_a, i_f = match_stamps(t, thrust.t)
        a_thrust[i_a] = np.linalg.norm(thrust.force[i_f], axis=1) / run.need_scenario().chaser.mass_kg
    return SyncTranslation(t, r_hill, velocity_hill(truth)[i_c], r_target_body, a_thrust)


def relative_attitude(q_hill_from_chaser, omega_chaser_body, q_hill_from_target, omega_target_body):
    """(q_target_from_chaser (N, 4), omega_relative_body (N, 3) [rad/s]) of the two bodies' truth (N, 4) and (N, 3):
    the chaser's attitude in target_body and its angular velocity relative to the target's, omega_chaser -
    C_chaser_from_target omega_target in chaser_body axes; synchronized (seed 001 stages 3-4) the one is constant
    and the other zero."""
    q_target_from_chaser = quat_multiply(quat_conjugate(np.asarray(q_hill_from_target).T),
                                         np.asarray(q_hill_from_chaser).T).T
    omega_target_chaser_axes = quat_rotate_many(quat_conjugate(q_target_from_chaser.T).T, omega_target_body)
    return q_target_from_chaser, np.asarray(omega_chaser_body) - omega_target_chaser_axes


class SyncAttitude(typing.NamedTuple):
    """Seed 001 Fig 6 (sync_attitude); the last four are None when stage 3 did not start."""

    t: np.ndarray                          # (N,) [s] truth stamps of both bodies
    rpy_chaser: np.ndarray                 # (N, 3) [rad] chaser_body in hill (euler_rpy)
    rpy_target: np.ndarray                 # (N, 3) [rad] target_body in hill
    omega_chaser_body: np.ndarray          # (N, 3) [rad/s] inertial, chaser_body axes
    omega_target_body: np.ndarray          # (N, 3) [rad/s] inertial, target_body axes
    relative_angle_rad: np.ndarray         # (N,) rotation angle of q_target_from_chaser
    omega_relative_body: np.ndarray        # (N, 3) [rad/s] relative_attitude's
    t_stage3: float | None                 # [s] the first stamp of stage 3 (ORBITING)
    rpy_carried: np.ndarray | None         # (N, 3) [rad] the target's attitude times its stage-3 relative one
    omega_carried_body: np.ndarray | None  # (N, 3) [rad/s] omega_target in the chaser axes of that attitude
    drift_rad: np.ndarray | None           # (N,) angle of the relative attitude from its value at t_stage3


def sync_attitude(run):
    """Seed 001 Fig 6 from the truth: both bodies' Euler angles (euler_rpy) and body rates, their relative attitude,
    and from the start of stage 3 the target's motion carried into the chaser by the relative attitude of that
    instant (where the chaser is if it turns with the target: in stages 3-4 the chaser's own, up to the drift,
    as summary.json's relative_attitude_drift_max_deg measures it to the grasp)."""
    chaser, target, i_c, i_t = run.truth_pair()
    t = chaser.t[i_c]
    q_c, w_c = chaser.orientation_xyzw[i_c], chaser.angular[i_c]
    q_t, w_t = target.orientation_xyzw[i_t], target.angular[i_t]
    q_rel, w_rel = relative_attitude(q_c, w_c, q_t, w_t)
    starts = [t0 for phase, t0, _ in run.phases if phase == c.PHASE_ORBITING]
    carried = (None, None, None, None)
    k = int(np.searchsorted(t, starts[0] - STAMP_TOLERANCE_S)) if starts else len(t)
    if k < len(t):
        q_rel0 = np.tile(q_rel[k], (len(t), 1))
        carried = (float(t[k]), euler_rpy(quat_multiply(q_t.T, q_rel0.T).T),
                   quat_rotate_many(quat_conjugate(q_rel[k]), w_t),
                   rotation_angle_many(quat_multiply(quat_conjugate(q_rel0.T), q_rel.T).T))
    return SyncAttitude(t, euler_rpy(q_c), euler_rpy(q_t), w_c, w_t, rotation_angle_many(q_rel), w_rel, *carried)


def wheel_energy_j(wheels, speed_rad_s, omega_body):
    """Spin kinetic energy [J] (N,) of the reaction wheels (flyby_sim.dynamics.rigid_body.ReactionWheels) at their
    speeds relative to the body (N, K) [rad/s] (/sim/chaser/wheels) and the body rate omega_body (N, 3): the sum of
    h^2 / (2 J_s) with h = J_s (speed + a . omega) each wheel's absolute momentum. The chaser's inertia leaves the
    wheels' spin-axis inertia out, so this adds to its body's 1/2 omega . I omega."""
    spin_rad_s = np.asarray(speed_rad_s) + np.asarray(omega_body) @ wheels.axes_body.T
    return 0.5 * np.sum(wheels.spin_inertia_kg_m2 * spin_rad_s ** 2, axis=1)


class SyncEnergy(typing.NamedTuple):
    """Seed 001 Fig 7 (kinetic_energies) [J]."""

    t: np.ndarray                      # (N,) [s] truth stamps of both bodies
    chaser_translational: np.ndarray   # (N,) 1/2 m |v_hill|^2, relative to the target (the hill frame)
    chaser_rotational: np.ndarray      # (N,) 1/2 omega . I omega of the chaser's body
    chaser_wheels: np.ndarray          # (N,) wheel_energy_j, NaN where /sim/chaser/wheels has no sample
    target_translational: np.ndarray   # (N,) 1/2 M |v_hill|^2 (zero: the hill origin is the target's CoM)
    target_rotational: np.ndarray      # (N,) 1/2 omega . I omega (constant: torque-free)


def kinetic_energies(run):
    """Seed 001 Fig 7 from the truth and the scenario's masses and inertias: each body's translational and rotational
    kinetic energy. Translation is relative to the target's centre of mass in the rotating hill frame, as the
    paper's relative motion (its eq 2) and Fig 4 have it: the velocity of velocity_hill, not the orbital one
    (1/2 m (7.8 km/s)^2 would hide every change); the chaser's mass is the initial one (its fuel burned left out),
    its inertia that of its body, the reaction wheels' spin energy apart (wheel_energy_j)."""
    scenario = run.need_scenario()
    chaser, target, i_c, i_t = run.truth_pair()
    t, w_c, w_t = chaser.t[i_c], chaser.angular[i_c], target.angular[i_t]
    wheels_j = np.full(len(t), np.nan)
    wheels = run.get(c.SIM_CHASER_WHEELS)
    if wheels is not None:
        config = scenario.chaser.wheels
        i_w, i_s = match_stamps(t, wheels.t)
        assembly = ReactionWheels(config.axes, config.max_torque_n_m, config.max_momentum_n_m_s,
                                  config.spin_inertia_kg_m2)
        wheels_j[i_w] = wheel_energy_j(assembly, wheels.velocity[i_s], w_c[i_w])
    return SyncEnergy(
        t,
        0.5 * scenario.chaser.mass_kg * np.sum(velocity_hill(chaser)[i_c] ** 2, axis=1),
        np.array([kinetic_energy(w, scenario.chaser_inertia) for w in w_c]),
        wheels_j,
        0.5 * scenario.target.mass_kg * np.sum(velocity_hill(target)[i_t] ** 2, axis=1),
        np.array([kinetic_energy(w, scenario.target_inertia) for w in w_t]))


def _stage_grid(run, rows, row_height=2.6):
    """(fig, axes (rows, columns), windows [(t0, t1)]): a column for each pair of seed 001's stages the run reached
    (stage_windows), its x-axis over the pair's window with the phases named at the top; Skipped if it reached
    neither. The figures draw in a column only the samples of its window, so that each axis scales to them."""
    windows = stage_windows(run.phases)
    if not windows:
        raise Skipped('no phase of the synchronized approach')
    fig, axes = plt.subplots(rows, len(windows), figsize=(7.0 * len(windows), row_height * rows + 1.2),
                             sharex='col', squeeze=False)
    for col, (name, (t0, t1)) in enumerate(windows.items()):
        for ax in axes[:, col]:
            _phase_bands(ax, run, legend=False)
            _grasp_line(ax, run, legend=ax is axes[0, col])
            ax.set_xlim(t0, t1)
            ax.grid(alpha=0.3)
        top = axes[0, col]
        for phase, p0, p1 in run.phases:
            if p1 > t0 and p0 < t1:
                top.text(0.5 * (max(p0, t0) + min(p1, t1)), 1.0, phase, transform=top.get_xaxis_transform(),
                         ha='center', va='bottom', fontsize=7)
        top.set_title(f'seed 001 {name}: {t0:.1f} to {t1:.1f} s\n', fontsize=10)
        axes[-1, col].set_xlabel('simulation time [s]')
    return fig, axes, list(windows.values())


def _xyz_and_norm(ax, t, vectors, ylabel, frame='hill'):
    """The components of vectors (N, 3) in frame's axes and their norm (black) against t."""
    for k, axis in enumerate('xyz'):
        ax.plot(t, vectors[:, k], color=f'C{k}', lw=1.1, label=f'{frame} {axis}')
    ax.plot(t, np.linalg.norm(vectors, axis=1), color='k', lw=1.3, label='norm')
    ax.set_ylabel(ylabel)


def _peak(ax, t, values, unit):
    """The largest of values (N,) at times t marked and labelled, if any is finite."""
    finite = np.flatnonzero(np.isfinite(values))
    if len(finite):
        k = finite[int(np.argmax(values[finite]))]
        ax.plot(t[k], values[k], 'kv', ms=7, label=f'peak {values[k]:.3g} {unit} at t = {t[k]:.1f} s')


def fig_sync_translation(run, path):
    """Seed 001 Fig 4 (sync_translation): a column for stages 1-2 and one for stages 3-4."""
    d = sync_translation(run)
    station_m = run.need_scenario().planner.sync.station_range_m
    fig, axes, windows = _stage_grid(run, 4)
    for (t0, t1), (ax_r, ax_v, ax_b, ax_a) in zip(windows, axes.T, strict=True):
        keep = (d.t >= t0) & (d.t <= t1)
        t = d.t[keep]
        _xyz_and_norm(ax_r, t, d.r_hill[keep], 'chaser position\nin hill [m]')
        _xyz_and_norm(ax_v, t, d.v_hill[keep], 'velocity relative to\nhill, hill axes [m/s]')
        _xyz_and_norm(ax_b, t, d.r_target_body[keep], 'position in\ntarget_body axes [m]', frame='target_body')
        ax_b.axhline(station_m, color='0.3', ls=':', lw=1.0, label=f'station range {station_m:g} m')
        ax_a.plot(t, d.a_thrust_mps2[keep], color='C3', lw=0.8, label='|F| / m$_0$')
        _peak(ax_a, t, d.a_thrust_mps2[keep], 'm/s$^2$')
        ax_a.set_ylabel('thrust acceleration\n[m/s$^2$]')
        for ax in (ax_r, ax_v, ax_b, ax_a):
            ax.legend(fontsize=7, ncol=3, loc='best', framealpha=0.85)
    fig.suptitle(f'{run.title}: seed 001 Fig 4, the chaser relative to the target (truth; '
                 f'|F| / m$_0$ with the initial mass)')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def fig_sync_estimation(run, path):
    """Seed 001 Fig 5 (euler_estimation_errors): the standard deviation of each Euler angle's estimate, and its
    error against the truth with +-3 sigma."""
    t, error, sigma = euler_estimation_errors(run)
    deg = math.degrees(1.0)
    fig, axes = plt.subplots(2, 3, figsize=(16, 8.5), sharex=True)
    for k, (ax, name) in enumerate(zip(axes[0], RPY_NAMES, strict=True)):
        _phase_bands(ax, run, legend=k == 0)
        ax.plot(t, sigma[:, k] * deg, color='C0', lw=1.1, label='$\\sigma$ (estimator covariance)')
        late = np.median(sigma[t >= 0.5 * (t[0] + t[-1]), k]) * deg
        ax.set(yscale='log', title=f'{name}: median $\\sigma$ of the second half {late:.3g} deg',
               ylabel='standard deviation [deg]' if k == 0 else None)
        _grasp_line(ax, run)
        _time_axis(ax, run, xlabel=False)
    axes[0, 0].legend(fontsize=7, ncol=2, loc='upper right', framealpha=0.9)
    _error_row(axes[1], run, 'estimate - truth', 'deg', t, error * deg, 3.0 * sigma * deg)
    for ax, name in zip(axes[1], RPY_NAMES, strict=True):
        ax.set_title(f'{name}: estimate - truth, $\\pm 3\\sigma$', fontsize=9)
        _time_axis(ax, run)
    fig.suptitle(f'{run.title}: seed 001 Fig 5, the target\'s Euler angles as estimated (/estimation/target/odom)\n'
                 f'{RPY_SEQUENCE}; sigma of $\\phi$ and $\\psi$ grows without bound as $\\theta$ nears $\\pm$90 deg')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def _angles_deg(angles_rad):
    """Angles (N, ...) [rad] in degrees, NaN at each wrap (a jump over 180 deg) so that no line crosses the axis."""
    deg = np.degrees(angles_rad)
    deg[1:][np.abs(np.diff(deg, axis=0)) > 180.0] = np.nan
    return deg


def fig_sync_attitude(run, path):
    """Seed 001 Fig 6 (sync_attitude): both bodies' Euler angles and body rates (chaser solid, target dotted, as the
    paper draws them), from stage 3 the target's carried into the chaser (dashed), and the relative attitude."""
    d = sync_attitude(run)
    deg = math.degrees(1.0)
    fig, axes, windows = _stage_grid(run, 4, row_height=2.7)
    for (t0, t1), (ax_e, ax_w, ax_rel, ax_dw) in zip(windows, axes.T, strict=True):
        keep = (d.t >= t0) & (d.t <= t1)
        t = d.t[keep]
        carried = d.t_stage3 is not None and t0 >= d.t_stage3 - STEP_TOLERANCE_S
        for k, name in enumerate(RPY_NAMES):
            ax_e.plot(t, _angles_deg(d.rpy_chaser[keep, k]), color=f'C{k}', lw=1.2, label=f'chaser {name}')
            ax_e.plot(t, _angles_deg(d.rpy_target[keep, k]), color=f'C{k}', lw=1.0, ls=':', label=f'target {name}')
            ax_w.plot(t, d.omega_chaser_body[keep, k] * deg, color=f'C{k}', lw=1.2, label=f'chaser {"pqr"[k]}')
            ax_w.plot(t, d.omega_target_body[keep, k] * deg, color=f'C{k}', lw=1.0, ls=':', label=f'target {"pqr"[k]}')
            if carried:
                ax_e.plot(t, _angles_deg(d.rpy_carried[keep, k]), color='k', lw=0.9, ls='--',
                          label='target x stage-3 relative attitude' if k == 0 else None)
                ax_w.plot(t, d.omega_carried_body[keep, k] * deg, color='k', lw=0.9, ls='--',
                          label='target rate in those chaser axes' if k == 0 else None)
        ax_e.set(ylabel=f'Euler angles [deg]\n{RPY_SEQUENCE}' if ax_e is axes[0, 0] else None, ylim=(-185.0, 185.0))
        ax_w.set_ylabel('body rates p, q, r [deg/s]\n(own body axes)' if ax_w is axes[1, 0] else None)
        ax_rel.plot(t, np.degrees(d.relative_angle_rad[keep]), color='C4', lw=1.2,
                    label='angle of chaser_body in target_body')
        ax_rel.set_ylabel('relative attitude [deg]' if ax_rel is axes[2, 0] else None)
        if carried:
            ax_drift = ax_rel.twinx()
            drift_deg = np.degrees(d.drift_rad[keep])
            ax_drift.plot(t, drift_deg, color='C3', lw=1.0, ls='--')
            ax_drift.set_ylabel('its drift from the start\nof stage 3 [deg] (dashed)', color='C3')
            k = int(np.argmax(drift_deg))
            ax_rel.set_title(f'drift from t = {d.t_stage3:.1f} s: largest {drift_deg[k]:.3g} deg at t = {t[k]:.1f} s',
                             fontsize=9)
        relative_rate = np.linalg.norm(d.omega_relative_body[keep], axis=1) * deg
        ax_dw.plot(t, relative_rate, color='C5', lw=1.0, label='|$\\omega_c$ - C$_{c \\leftarrow t}$ $\\omega_t$|')
        ax_dw.set(yscale='log', ylabel='relative rate [deg/s]' if ax_dw is axes[3, 0] else None)
        for ax in (ax_e, ax_w, ax_rel, ax_dw):
            ax.legend(fontsize=7, ncol=3, loc='lower left', framealpha=0.85)
    fig.suptitle(f'{run.title}: seed 001 Fig 6, orientation and angular velocity of both bodies (truth)')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def fig_sync_energy(run, path):
    """Seed 001 Fig 7 (kinetic_energies): translational (left axes, dashed) and rotational (right axes, dotted)
    kinetic energy of the chaser and of the target, and the chaser's wheels' spin energy."""
    d = kinetic_energies(run)
    fig, (ax_c, ax_t, ax_w) = plt.subplots(3, 1, figsize=(13, 11), sharex=True)
    for ax, name, translational, rotational in ((ax_c, 'chaser', d.chaser_translational, d.chaser_rotational),
                                                 (ax_t, 'target', d.target_translational, d.target_rotational)):
        _phase_bands(ax, run, legend=ax is ax_c)
        _grasp_line(ax, run, legend=ax is ax_c)
        ax.plot(d.t, translational, color='C0', ls='--', lw=1.3, label=f'{name} translational (left)')
        ax_rot = ax.twinx()
        ax_rot.plot(d.t, rotational, color='C3', ls=':', lw=1.6)
        ax.plot([], [], color='C3', ls=':', lw=1.6, label=f'{name} rotational (right)')
        for axis, values in ((ax, translational), (ax_rot, rotational)):  # from zero: a constant shows as one
            axis.set_ylim(0.0, 1.1 * max(float(np.max(values)), 1.0))
        ax.set_ylabel(f'{name} translational [J]\n(relative to hill)', color='C0')
        ax_rot.set_ylabel(f'{name} rotational [J]', color='C3')
        ax.set_title(f'{name}: translational peak {np.max(translational):.4g} J, '
                     f'rotational {np.min(rotational):.6g} to {np.max(rotational):.6g} J', fontsize=9)
        ax.legend(fontsize=8, ncol=4, loc='upper left', framealpha=0.9)
        _time_axis(ax, run, xlabel=False)
    _phase_bands(ax_w, run, legend=False)
    ax_w.plot(d.t, d.chaser_wheels, color='C2', lw=1.2, label='reaction wheels, $\\Sigma$ h$^2$ / 2 J$_s$')
    _peak(ax_w, d.t, d.chaser_wheels, 'J')
    ax_w.set_ylabel('chaser wheels\' spin [J]')
    ax_w.legend(fontsize=8, loc='upper left', framealpha=0.9)
    _time_axis(ax_w, run)
    fig.suptitle(f'{run.title}: seed 001 Fig 7, kinetic energy (truth; masses and inertias of the scenario, '
                 f'the chaser\'s initial mass)')
    fig.tight_layout()
    plots.save(fig, path, DPI)


# ---------------------------------------------------------------------------------------------
# After the capture (scenario post_capture, docs/post_capture.md): seed 004 Fig 5, the grasp, the damping
# ---------------------------------------------------------------------------------------------

FIG5_MOMENT_NAMES = ('I$_1$ (smallest)', 'I$_2$', 'I$_3$ (largest)')


class CombinedMotion(typing.NamedTuple):
    """Seed 004 Fig 5 (a)-(d) (combined_motion): the combined body's motion during MASS_ESTIMATION."""

    t: np.ndarray                  # (N,) [s] truth stamps of both bodies in the window
    r_com_hill: np.ndarray         # (N, 3) [m] the combined CoM in hill (truth)
    v_com_inertial: np.ndarray     # (N, 3) [m/s] its inertial velocity, hill axes of each instant (truth)
    q_hill_from_body: np.ndarray   # (N, 4) chaser_body (the combined body's axes) in hill (truth)
    omega_body: np.ndarray         # (N, 3) [rad/s] inertial, chaser_body axes (truth)
    t_est: np.ndarray              # (K,) [s] /estimation/chaser/odom stamps with a truth sample, in the window
    q_est: np.ndarray              # (K, 4) the attitude filter's q_hill_from_body, signs as the truth's
    omega_est: np.ndarray          # (K, 3) [rad/s] its rate
    attitude_error_hill: np.ndarray  # (K, 3) [rad] rotation vector of q_est q_true^-1 (hill axes)
    attitude_sigma3_hill: np.ndarray  # (K, 3) [rad] its 3 sigma (the pose covariance's orientation block)
    rate_error_body: np.ndarray    # (K, 3) [rad/s] estimate - truth
    rate_sigma3_body: np.ndarray   # (K, 3) [rad/s] its 3 sigma


def combined_motion(run):
    """Seed 004 Fig 5 (a)-(d) over MASS_ESTIMATION: the combined body's CoM position and velocity from both bodies'
    truth (their grasp.Body, flyby_mission.summary.post_capture_truth, the masses of the lock), and its
    attitude and rate, which are the chaser's (one rigid body), truth and the estimate the mission publishes: the
    chaser's attitude filter on /estimation/chaser/odom. The mass-property filter's own r, v, q, omega are not
    published: the combined CoM has no estimate (its chaser position stays the capture's, docs/post_capture.md)."""
    t0, t1 = run.phase_window(c.PHASE_MASS_ESTIMATION)
    common, i_c, _, bodies = run.bodies
    ks = np.flatnonzero((common >= t0 - STAMP_TOLERANCE_S) & (common <= t1 + STAMP_TOLERANCE_S))
    if not len(ks):
        raise Skipped('no truth sample in MASS_ESTIMATION')
    r_com, v_com = [], []
    for k in ks:
        pair = bodies(k)
        mass_kg = sum(b.mass_kg for b in pair)
        r_com.append(sum(b.mass_kg * b.r_m for b in pair) / mass_kg)
        v_com.append(sum(b.mass_kg * b.v_mps for b in pair) / mass_kg)
    chaser = run.need(c.SIM_CHASER_ODOM)
    q_true = continuous_quaternions(chaser.orientation_xyzw[i_c[ks]])
    estimate = chaser_attitude_estimate(run)
    if isinstance(estimate, str):
        raise Skipped(estimate)
    e, tr, i, j = estimate
    keep = (e.t[i] >= t0 - STAMP_TOLERANCE_S) & (e.t[i] <= t1 + STAMP_TOLERANCE_S)
    i, j = i[keep], j[keep]
    q_est = e.orientation_xyzw[i]
    q_est = q_est * np.where(np.einsum('ij,ij->i', q_est, tr.orientation_xyzw[j]) < 0.0, -1.0, 1.0)[:, None]
    q_est = q_est * np.where(q_est @ q_true[0] < 0.0, -1.0, 1.0)[:, None]  # the truth's continuous sign
    dtheta = np.array([rotation_vector_from_quat(quat_multiply(a, quat_conjugate(b)))
                       for a, b in zip(e.orientation_xyzw[i], tr.orientation_xyzw[j], strict=True)]).reshape(-1, 3)
    return CombinedMotion(common[ks], np.array(r_com), np.array(v_com), q_true, chaser.angular[i_c[ks]],
                          e.t[i], q_est, e.angular[i], dtheta, _sigma3(e.pose_covariance[i], slice(3, 6)),
                          e.angular[i] - tr.angular[j], _sigma3(e.twist_covariance[i], slice(3, 6)))


class MassPropertyEstimates(typing.NamedTuple):
    """Seed 004 Fig 5 (e)-(h) (mass_property_estimates): the estimates with their 1-sigma and the truth."""

    t: np.ndarray                       # (K,) [s] stamps of /estimation/target/inertia
    mass_kg: np.ndarray                 # (K,) the message's target mass
    mass_sigma_kg: np.ndarray           # (K,) the event's
    com_body_m: np.ndarray              # (K, 3) the message's X_s: target CoM from the chaser CoM, chaser_body
    com_sigma_m: np.ndarray             # (K, 3)
    true_com_at_estimate_m: np.ndarray  # (K, 3) X_s from both bodies' truth at each estimate's stamp
    moments_kg_m2: np.ndarray           # (K, 3) the event's principal moments, the filter's order (the truth's)
    moments_sigma_kg_m2: np.ndarray     # (K, 3)
    axes_error_rad: np.ndarray          # (K, 3) dphi: q_true^-1 q_est as a rotation vector in principal axes
    axes_sigma_rad: np.ndarray          # (K, 3) the filter's sigma of dphi
    axes_angle_rad: np.ndarray          # (K, 3) angle of each estimated principal axis from the true one
    inertia_body_kg_m2: np.ndarray      # (K, 3, 3) the message's inertia about the target CoM, chaser_body
    true_mass_kg: float                 # the scenario's (the plant's truth)
    true_moments_kg_m2: np.ndarray      # (3,) the scenario's, ascending
    t_truth: np.ndarray                 # (N,) [s] truth stamps in MASS_ESTIMATION
    true_com_body_m: np.ndarray         # (N, 3) X_s from both bodies' truth
    prior: dict | None                  # the estimator's mass_properties_prior values (no sigmas) and its t


def _json_values(event, keys):
    return {k: np.array(json.loads(event['values'][k]), dtype=float) for k in keys}


def nearest_principal_axes_error(q_body_from_principal_est, q_body_from_principal_true):
    """dphi (3,) [rad], the rotation vector of q_true^-1 q_est (principal axes: the mass-property filter's
    Q = Q_ref exp(dphi), flyby_estimation.mass_properties), of the four sign choices of the true axes that keep them
    right-handed the one nearest the estimate (an axis is a line: its sign is a convention)."""
    c_est = quat_to_matrix_many(np.asarray(q_body_from_principal_est, dtype=float)[None, :])[0]
    c_true = quat_to_matrix_many(np.asarray(q_body_from_principal_true, dtype=float)[None, :])[0]
    candidates = [Rotation.from_matrix((c_true * np.array(signs)).T @ c_est).as_rotvec()
                  for signs in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))]
    return min(candidates, key=np.linalg.norm)


def mass_property_estimates(run):
    """Seed 004 Fig 5 (e)-(h): the target's mass, CoM and inertia as /estimation/target/inertia gives them, their
    1-sigma and principal form from the mass_properties_estimate(d) event of the same stamp (the estimator's
    _mass_outputs), and the truth: mass and principal moments the scenario's, X_s and the principal axes in
    chaser_body from both bodies' truth (flyby_mission.summary.target_mass_properties_truth, as summary.json's errors).
    The principal axes' error is dphi (nearest_principal_axes_error) against the truth at the estimate's stamp (the
    first truth stamp at or after it, as the summary takes it)."""
    scenario = run.need_scenario()
    messages = run.need(c.EST_TARGET_INERTIA).messages
    t0, t1 = run.phase_window(c.PHASE_MASS_ESTIMATION)
    chaser, target = run.need(c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM)
    common, i_c, i_t, _ = run.bodies
    events = {round(e['t'], 6): e for e in run.events
              if e['name'] in ('mass_properties_estimate', 'mass_properties_estimated')}
    rows = []
    for msg in messages:
        t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        event = events.get(round(t, 6))
        k = int(np.searchsorted(common, t - 1e-9))
        if event is None or k >= len(common):
            continue
        mass_kg, com, inertia = inertia_to_numpy(msg.inertia)
        v = _json_values(event, ('com_sigma_m', 'principal_moments_kg_m2', 'principal_moments_sigma_kg_m2',
                                 'principal_axes_q', 'principal_axes_sigma_rad'))
        x_s, true_moments, q_true = target_mass_properties_truth(chaser, target, i_c[k], i_t[k], scenario)
        rows.append((t, mass_kg, float(event['values']['mass_sigma_kg']), com, v['com_sigma_m'], x_s,
                     v['principal_moments_kg_m2'], v['principal_moments_sigma_kg_m2'],
                     nearest_principal_axes_error(v['principal_axes_q'], q_true), v['principal_axes_sigma_rad'],
                     principal_axis_errors_rad(v['principal_axes_q'], q_true), inertia))
    if not rows:
        raise Skipped(f'no {c.absolute(c.EST_TARGET_INERTIA)} message with its 1-sigma event and a truth sample')
    window = np.flatnonzero((common >= t0 - STAMP_TOLERANCE_S) & (common <= t1 + STAMP_TOLERANCE_S))
    true_com = np.array([target_mass_properties_truth(chaser, target, i_c[k], i_t[k], scenario)[0] for k in window])
    prior = next((e for e in run.events if e['name'] == 'mass_properties_prior'), None)
    if prior is not None:
        prior = {'t': float(prior['t']), 'mass_kg': float(prior['values']['mass_kg']),
                 **_json_values(prior, ('com_body_m', 'principal_moments_kg_m2'))}
    columns = [np.array(col) for col in zip(*rows, strict=True)]
    return MassPropertyEstimates(*columns, scenario.target.mass_kg, true_moments, common[window],
                                 true_com.reshape(-1, 3), prior)


def grasp_contact(run):
    """(t (N,) [s], |force| (N,) [N], |torque| (N,) [N m], |stroke| (N,) [m]) of the arm on the target at every truth
    stamp of GRASP: flyby_mission.summary.grasp_contact_series, the arm's impedance recomputed from both bodies'
    truth (its peak is summary.json's peak_grasp_force_n and peak_grasp_torque_n_m); Skipped without GRASP."""
    common, _, _, bodies = run.bodies
    t, force, torque, stroke = grasp_contact_series(run.events, common, bodies, run.need_scenario())
    if not len(t):
        raise Skipped('no truth sample in GRASP')
    return t, *(np.array([np.linalg.norm(v) for v in series]) for series in (force, torque, stroke))


def damping_momentum(run):
    """(t (N,) [s], |H| (N,) [kg m^2/s]) of the combined body about its CoM (inertial, wheels included:
    flyby_mission.summary.angular_momentum_about_com of both bodies' truth) at every truth stamp of DAMPING, to the
    sample summary.json's final_angular_momentum_kg_m2_s is taken at (seed 004 §3.2's condition 1)."""
    common, _, _, bodies = run.bodies
    t_damping, t_damped = damping_window(run.events, run.t_end)
    if t_damping is None:
        raise Skipped('no DAMPING phase')
    ks = np.flatnonzero((common >= t_damping - 1e-9) & (common <= t_damped + 1e-9))
    return common[ks], np.array([angular_momentum_about_com(bodies(k)) for k in ks])


TRANSPORT_SAMPLE_S = 0.5  # Fig 7's sample period: a transport is thousands of seconds of 20 Hz truth


def transport_series(run):
    """(t (N,) [s], distance to the goal (N,) [m], speed relative to the goal's circular motion (N,) [m/s], linear
    momentum (N,) [N s], angular momentum about the combined CoM (N,) [kg m^2/s]): flyby_mission.summary's
    transport_state of both bodies' truth every TRANSPORT_SAMPLE_S from TRANSPORT's start to the run's end."""
    common, _, _, bodies = run.bodies
    t_start, _ = run.phase_window(c.PHASE_TRANSPORT)
    ks = np.flatnonzero(common >= t_start - 1e-9)
    if not len(ks):
        raise Skipped('no truth sample in TRANSPORT')
    step = max(1, int(round(TRANSPORT_SAMPLE_S / max(float(np.median(np.diff(common))), 1e-9))))
    ks = np.unique(np.append(ks[::step], ks[-1]))
    tr = run.need_scenario().post_capture.transport
    rows = np.array([transport_state(bodies(k), tr.goal_hill_m, run.need_scenario().mean_motion_rad_s) for k in ks])
    return common[ks], rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]


def _window_axis(ax, window, xlabel=True, margin=0.015):
    """x from window[0] to window[1] [s] with a margin of its span each side (marks at its ends stay visible)."""
    pad = margin * (window[1] - window[0])
    ax.set_xlim(window[0] - pad, window[1] + pad)
    ax.grid(alpha=0.3)
    if xlabel:
        ax.set_xlabel('simulation time [s]')


def _estimate_band(ax, t, estimate, sigma, label='estimate'):
    """An estimate (K,) at times t with its +-3 sigma (K,) as a band."""
    ax.fill_between(t, estimate - 3.0 * sigma, estimate + 3.0 * sigma, color=ESTIMATE, alpha=0.25, lw=0,
                    label='$\\pm 3\\sigma$')
    ax.plot(t, estimate, '.-', color=ESTIMATE, lw=1.1, ms=4, label=label)


def fig_seed004_motion(run, path):
    """Seed 004 Fig 5 (a)-(d) (combined_motion)."""
    d = combined_motion(run)
    window = run.phase_window(c.PHASE_MASS_ESTIMATION)
    deg = math.degrees(1.0)
    fig = plt.figure(figsize=(17, 15))
    grid = fig.add_gridspec(4, 4, width_ratios=(2.0, 1.0, 1.0, 1.0))
    ax_r, ax_v = fig.add_subplot(grid[0, :]), fig.add_subplot(grid[1, :])
    mm = 1e3
    r0 = d.r_com_hill[0]
    _xyz_and_norm(ax_r, d.t, (d.r_com_hill - r0) * mm, '[mm]')
    ax_r.set_title(f'(a) position of the combined CoM in hill (truth), from its {np.array2string(r0, precision=3)} m '
                   'at the phase\'s start', fontsize=10)
    _xyz_and_norm(ax_v, d.t, d.v_com_inertial * mm, '[mm/s]')
    ax_v.set_title('(b) inertial velocity of the combined CoM, hill axes of each instant (truth)', fontsize=10)
    for ax in (ax_r, ax_v):
        ax.legend(fontsize=8, ncol=4, loc='upper left', framealpha=0.9)
        _window_axis(ax, window, xlabel=False)
    ax_q = fig.add_subplot(grid[2, 0])
    for k, name in enumerate('xyzw'):
        ax_q.plot(d.t, d.q_hill_from_body[:, k], color=f'C{k}', lw=1.4, label=f'$q_{name}$ truth')
        ax_q.plot(d.t_est, d.q_est[:, k], color='k', lw=0.7, ls=(0, (4, 4)), label='estimate' if k == 0 else None)
    ax_q.set(ylabel='$q_{hill \\leftarrow body}$', title='(c) attitude of chaser_body (the combined body) in hill')
    ax_w = fig.add_subplot(grid[3, 0], sharex=ax_q)
    for k, name in enumerate('xyz'):
        ax_w.plot(d.t, d.omega_body[:, k] * deg, color=f'C{k}', lw=1.4, label=f'$\\omega_{name}$ truth')
        ax_w.plot(d.t_est, d.omega_est[:, k] * deg, color='k', lw=0.7, ls=(0, (4, 4)),
                  label='estimate' if k == 0 else None)
    ax_w.set(ylabel='[deg/s]', title='(d) inertial angular velocity, chaser_body axes')
    for ax in (ax_q, ax_w):
        ax.legend(fontsize=7, ncol=3, loc='best', framealpha=0.85)
        _window_axis(ax, window, xlabel=ax is ax_w)
    for row, name, unit, err, sig3 in ((2, '(c) attitude error (hill axes)', 'deg', d.attitude_error_hill * deg,
                                        d.attitude_sigma3_hill * deg),
                                       (3, '(d) rate error (body axes)', 'deg/s', d.rate_error_body * deg,
                                        d.rate_sigma3_body * deg)):
        ax_row = [fig.add_subplot(grid[row, k + 1], sharex=ax_q) for k in range(3)]
        _error_row(ax_row, run, name, unit, d.t_est, err, sig3, symlog=False)
        for ax in ax_row:
            _window_axis(ax, window, xlabel=row == 3)
    fig.suptitle(f'{run.title}: seed 004 Fig 5 (a)-(d), the combined body during MASS_ESTIMATION\n'
                 '(a)-(b) truth only: the mission publishes no estimate of the combined CoM; (c)-(d) the estimate of '
                 'the chaser\'s attitude filter (/estimation/chaser/odom):\nthe mass-property filter\'s own attitude '
                 'and rate are not published')
    fig.tight_layout(rect=(0, 0, 1, 0.98))
    plots.save(fig, path, DPI)


def fig_seed004_mass_properties(run, path):
    """Seed 004 Fig 5 (e)-(h) (mass_property_estimates): each estimate with its +-3 sigma and the truth."""
    d = mass_property_estimates(run)
    window = run.phase_window(c.PHASE_MASS_ESTIMATION)
    deg = math.degrees(1.0)
    fig = plt.figure(figsize=(16, 15))
    grid = fig.add_gridspec(4, 3)
    prior = d.prior
    for k, name in enumerate(FIG5_MOMENT_NAMES):
        ax = fig.add_subplot(grid[0, k])
        _estimate_band(ax, d.t, d.moments_kg_m2[:, k], d.moments_sigma_kg_m2[:, k])
        ax.axhline(d.true_moments_kg_m2[k], color='k', ls='--', lw=1.0, label=f'truth {d.true_moments_kg_m2[k]:g}')
        if prior is not None:
            ax.plot(prior['t'], prior['principal_moments_kg_m2'][k], 'o', mfc='none', mec='k', label='prior')
        error = (d.moments_kg_m2[-1, k] / d.true_moments_kg_m2[k] - 1.0) * 100.0
        ax.set_title(f'(e) {name}: {d.moments_kg_m2[-1, k]:.1f} $\\pm$ {d.moments_sigma_kg_m2[-1, k]:.1f} kg m$^2$ '
                     f'({error:+.2f} %)', fontsize=9)
        ax.set_ylabel('principal moment [kg m$^2$]' if k == 0 else None)
    ax_m = fig.add_subplot(grid[1, :])
    _estimate_band(ax_m, d.t, d.mass_kg, d.mass_sigma_kg)
    ax_m.axhline(d.true_mass_kg, color='k', ls='--', lw=1.0, label=f'truth {d.true_mass_kg:g} kg')
    if prior is not None:
        ax_m.plot(prior['t'], prior['mass_kg'], 'o', mfc='none', mec='k', label='prior (at the lock)')
    ax_m.set(ylabel='target mass [kg]',
             title=f'(f) mass: {d.mass_kg[-1]:.1f} $\\pm$ {d.mass_sigma_kg[-1]:.1f} kg '
                   f'({(d.mass_kg[-1] / d.true_mass_kg - 1.0) * 100.0:+.2f} %)')
    for k in range(3):
        ax = fig.add_subplot(grid[2, k])
        _estimate_band(ax, d.t, d.axes_error_rad[:, k] * deg, d.axes_sigma_rad[:, k] * deg, label='estimate - truth')
        ax.axhline(0.0, color='k', ls='--', lw=1.0, label='truth')
        ax.set_title(f'(g) principal axes, d$\\phi_{k + 1}$ (about axis {k + 1}); axis {k + 1} off by '
                     f'{d.axes_angle_rad[-1, k] * deg:.3f} deg at the end', fontsize=9)
        ax.set_ylabel('rotation of the axes [deg]' if k == 0 else None)
    for k, axis in enumerate('xyz'):
        ax = fig.add_subplot(grid[3, k])
        _estimate_band(ax, d.t, d.com_body_m[:, k], d.com_sigma_m[:, k])
        ax.plot(d.t_truth, d.true_com_body_m[:, k], color='k', ls='--', lw=1.0, label='truth')
        if prior is not None:
            ax.plot(prior['t'], prior['com_body_m'][k], 'o', mfc='none', mec='k', label='prior')
        error_mm = (d.com_body_m[-1, k] - d.true_com_at_estimate_m[-1, k]) * 1e3
        ax.set_title(f'(h) centre of mass, chaser_body {axis}: {d.com_body_m[-1, k]:.4f} m '
                     f'$\\pm$ {d.com_sigma_m[-1, k] * 1e3:.1f} mm ({error_mm:+.1f} mm)', fontsize=9)
        ax.set_ylabel('target CoM from the chaser CoM [m]' if k == 0 else None)
    for ax in fig.axes:
        ax.legend(fontsize=7, loc='best', framealpha=0.85, ncol=2)
        _window_axis(ax, window, xlabel=ax in fig.axes[-3:])
    fig.suptitle(f'{run.title}: seed 004 Fig 5 (e)-(h), the target\'s mass properties during MASS_ESTIMATION\n'
                 '/estimation/target/inertia with the 1-sigma of the estimator\'s mass_properties_estimate events; '
                 'truth: the scenario\'s mass and moments, CoM and axes from both bodies\' truth')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def fig_grasp_contact(run, path):
    """The arm's contact force, torque and stroke during GRASP (grasp_contact) with the arm's limits, at which the
    grasp lets go (docs/post_capture.md)."""
    t, force, torque, stroke = grasp_contact(run)
    g = run.need_scenario().post_capture.grasp
    fig, axes = plt.subplots(3, 1, figsize=(12, 10), sharex=True)
    for ax, values, unit, limit, name, what in (
            (axes[0], force, 'N', g.max_force_n, '|force|', 'on the target'),
            (axes[1], torque, 'N m', g.max_torque_n_m, '|torque|', 'on the target'),
            (axes[2], stroke * 1e3, 'mm', g.max_stroke_m * 1e3, '|stroke|', 'the handle from the end effector')):
        ax.plot(t, values, color=TRUTH, lw=1.4, label=f'{name}, {what} (truth)')
        ax.axhline(limit, color='r', ls='--', lw=1.1, label=f"the arm's limit {limit:g} {unit}")
        _peak(ax, t, values, unit)
        ax.set(yscale='log', ylabel=f'{name} [{unit}]')
        ax.legend(fontsize=8, loc='center right', framealpha=0.9)
        _window_axis(ax, (t[0], t[-1]), xlabel=ax is axes[-1])
    peaks = [run.summary.get(k) for k in ('peak_grasp_force_n', 'peak_grasp_torque_n_m')]
    stated = f' (summary.json: {peaks[0]:.3g} N, {peaks[1]:.3g} N m)' if None not in peaks else ''
    fig.suptitle(f'{run.title}: the arm\'s impedance during GRASP, recomputed from both bodies\' truth at every '
                 f'sample\npeak {force.max():.3g} N and {torque.max():.3g} N m{stated}; '
                 f'GRASP lasted {t[-1] - t[0]:.2f} s')
    fig.tight_layout()
    plots.save(fig, path, DPI)


def fig_damping_momentum(run, path):
    """The combined body's angular momentum during DAMPING (damping_momentum) against seed 004 §3.2's threshold."""
    t, momentum = damping_momentum(run)
    threshold = run.need_scenario().post_capture.damping.momentum_threshold_kg_m2_s
    fig, ax = plt.subplots(figsize=(12, 6.5))
    ax.plot(t, momentum, color=TRUTH, lw=1.4, label='|H| about the combined CoM, wheels included (truth)')
    ax.axhline(threshold, color='r', ls='--', lw=1.1, label=f'threshold {threshold:g} kg m$^2$/s (seed 004 §3.2)')
    ax.plot(t[-1], momentum[-1], 'kv', ms=8, label=f'at the end: {momentum[-1]:.3g} kg m$^2$/s')
    done = next((e for e in run.events if e['name'] == 'damping_complete'), None)
    if done is not None and 'momentum_bound_kg_m2_s' in done['values']:
        ax.plot(done['t'], float(done['values']['momentum_bound_kg_m2_s']), 'D', color=ESTIMATE, mec='k',
                label='guidance\'s bound from its estimates (damping_complete)')
    below = np.flatnonzero(momentum < threshold)
    first_below = f'first below the threshold at t = {t[below[0]]:.1f} s' if len(below) else 'never below the threshold'
    ax.set(yscale='log', ylabel='angular momentum [kg m$^2$/s]',
           title=f'from {momentum[0]:.4g} to {momentum[-1]:.3g} kg m$^2$/s in {t[-1] - t[0]:.1f} s; {first_below}')
    ax.legend(fontsize=8, loc='upper right', framealpha=0.9)
    _window_axis(ax, (t[0], t[-1]))
    fig.suptitle(f'{run.title}: the combined body\'s angular momentum during DAMPING')
    fig.tight_layout()
    plots.save(fig, path, DPI)



def fig_seed004_fig7(run, path):
    """Seed 004 Fig 7's analogue during TRANSPORT (transport_series): (a) angular momentum, (b) distance to the goal,
    (c) linear momentum relative to the goal's circular motion (the relative velocity times the combined mass, the
    quantity of condition 3) with the speed in its title, each against its rendezvous condition, the
    planned arrival and guidance's transport_complete marked, the thrusters' firing steps shaded."""
    t, miss, speed, momentum, h = transport_series(run)
    tr = run.need_scenario().post_capture.transport
    fig, axes = plt.subplots(3, 1, figsize=(12, 10), sharex=True)
    rows = ((axes[0], h, 'angular momentum [kg m$^2$/s]', tr.max_angular_momentum_kg_m2_s, 'kg m$^2$/s'),
            (axes[1], miss, 'distance to the goal [m]', tr.max_position_error_m, 'm'),
            (axes[2], momentum, 'linear momentum relative\nto the goal [N s]', tr.max_momentum_error_n_s, 'N s'))
    for ax, values, label, bound, unit in rows:
        ax.plot(t, values, color=TRUTH, lw=1.3, label='truth')
        ax.axhline(bound, color='r', ls='--', lw=1.1, label=f'condition: below {bound:.3g} {unit}')
        ax.plot(t[-1], values[-1], 'kv', ms=7, label=f'at the end: {values[-1]:.3g} {unit}')
        ax.set(yscale='log', ylabel=label)
    axes[2].set_title(f'the relative velocity: {speed[0] * 1e3:.3g} mm/s at the start, peak {speed.max() * 1e3:.3g} '
                      f'mm/s, {speed[-1] * 1e3:.3g} mm/s at the end', fontsize=9)
    planned = next((e for e in run.events if e['name'] == 'transport_planned'), None)
    done = next((e for e in run.events if e['name'] == 'transport_complete'), None)
    thrust = run.get(c.SIM_CHASER_THRUST)
    for ax in axes:
        if planned is not None:
            ax.axvline(float(planned['values']['t_arrival_s']), color='0.4', ls=':', lw=1.0, label='planned arrival')
        if done is not None:
            ax.axvline(done['t'], color='g', ls='-.', lw=1.0, label='transport_complete')
        if thrust is not None and len(thrust.t):
            firing = (np.linalg.norm(thrust.force, axis=1) > 0) & (thrust.t >= t[0])
            ax.fill_between(thrust.t, 0, 1, where=firing, color='orange', alpha=0.25, step='post',
                            transform=ax.get_xaxis_transform(), label='thrusters firing')
        ax.legend(fontsize=7, loc='upper right', framealpha=0.9)
        ax.grid(True, which='both', alpha=0.3)
    _window_axis(axes[-1], (t[0], t[-1]))
    axes[-1].set_xlabel('t [s]')
    fig.suptitle(f'{run.title}: TRANSPORT, seed 004 Fig 7 (truth)')
    fig.tight_layout()
    plots.save(fig, path, DPI)

FIGURES = (
    ('trajectory_xz.png', fig_trajectory_xz),
    ('trajectory_3d.png', fig_trajectory_3d),
    ('range.png', fig_range),
    ('maneuvers.png', fig_maneuvers),
    ('estimation.png', fig_estimation),
    ('clearance.png', fig_clearance),
)
RIGID_BODY_FIGURES = (  # written for chaser.model rigid_body only
    ('attitude.png', fig_attitude),
    ('pointing.png', fig_pointing),
    ('wheels.png', fig_wheels),
    ('thrusters.png', fig_thrusters),
)
SYNC_FIGURES = (  # written for a run of the synchronized approach only (is_sync)
    ('seed001_fig4_position_velocity.png', fig_sync_translation),
    ('seed001_fig5_euler_sigma.png', fig_sync_estimation),
    ('seed001_fig6_attitude.png', fig_sync_attitude),
    ('seed001_fig7_kinetic_energy.png', fig_sync_energy),
)
POST_CAPTURE_FIGURES = (  # written for a scenario with a post_capture section only
    ('seed004_fig5_motion.png', fig_seed004_motion),
    ('seed004_fig5_mass_properties.png', fig_seed004_mass_properties),
    ('post_capture_grasp_contact.png', fig_grasp_contact),
    ('post_capture_damping_momentum.png', fig_damping_momentum),
)
TRANSPORT_FIGURES = (  # written for a scenario with a post_capture.transport section only
    ('seed004_fig7_transport.png', fig_seed004_fig7),
)


class FleetRun:
    """What the figure of several chasers draws from: each chaser's truth positions (its namespace's
    sim/chaser/odom), the target's truth attitude, the scenario and the summary."""

    def __init__(self, run_dir, scenario):
        self.run_dir, self.scenario = Path(run_dir), scenario
        _open_bag(self.run_dir / 'bag')
        topics = {name: c.absolute(c.SIM_CHASER_ODOM, f'/{name}') for name in scenario.chaser_names}
        data = read_bag(self.run_dir / 'bag', topics=[*topics.values(), c.absolute(c.SIM_TARGET_ODOM)])
        self.chasers = {name: data[t] for name, t in topics.items() if not _is_empty(data.get(t))}
        self.target = data.get(c.absolute(c.SIM_TARGET_ODOM))
        summary = self.run_dir / 'summary.json'
        self.summary = json.loads(summary.read_text()) if summary.is_file() else {}
        self.title = f'{scenario.name}, seed {scenario.seed}: {self.summary.get("outcome", "")}'.rstrip(': ')


def fig_chasers(run, path):
    """chasers.png (module doc)."""
    if len(run.chasers) < 2 or _is_empty(run.target):
        raise Skipped('fewer than two chasers or no target truth in the bag')
    names = list(run.chasers)
    fig, ((ax_xz, ax_sep), (ax_zoom, ax_clear)) = plt.subplots(2, 2, figsize=(16, 10))
    boxes = list(zip(run.scenario.boxes.center_body_m, run.scenario.boxes.size_m, strict=True))
    worst = (math.inf, None)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            sa, sb = run.chasers[a], run.chasers[b]
            i_a, i_b = match_stamps(sa.t, sb.t)
            gap = (np.linalg.norm(sa.position[i_a] - sb.position[i_b], axis=1)
                   - run.scenario.for_chaser(a).chaser.envelope_radius_m
                   - run.scenario.for_chaser(b).chaser.envelope_radius_m)
            k = int(np.argmin(gap))
            ax_sep.plot(sa.t[i_a], gap, lw=1.3, label=f'{a} - {b}: least {gap[k]:.2f} m at t = {sa.t[i_a][k]:.1f} s')
            if gap[k] < worst[0]:
                worst = (float(gap[k]), float(sa.t[i_a][k]))
    for j, name in enumerate(names):
        s = run.chasers[name]
        color = f'C{j}'
        for ax in (ax_xz, ax_zoom):
            ax.plot(*plots.xz(s.position), color=color, lw=1.8, label=f'{name} truth')
        ax_xz.plot(*plots.xz(s.position[:1]), 'o', color=color, mec='k', ms=7)
        i_c, i_t = match_stamps(s.t, run.target.t)
        gap = clearance(s.position[i_c], run.target.orientation_xyzw[i_t], boxes,
                        run.scenario.for_chaser(name).chaser.envelope_radius_m)
        k = int(np.argmin(gap))
        ax_clear.plot(s.t[i_c], gap, color=color, lw=1.3,
                      label=f'{name}: least {gap[k]:.3f} m at t = {s.t[i_c][k]:.1f} s')
    k_t = int(np.argmin(np.abs(run.target.t - worst[1])))
    for ax in (ax_xz, ax_zoom):
        plots.fill_outline_xz(ax, box_corners_hill(run.scenario, run.target.orientation_xyzw[k_t]), color=BODY_FILL,
                              lw=0, zorder=2, label=f'target boxes at t = {run.target.t[k_t]:.1f} s (least separation)')
        ax.set(aspect='equal', xlabel='hill x, along-track [m]', ylabel='hill z, toward Earth [m] (up: away)')
    ax_xz.set(adjustable='datalim', title='chasers in the hill x-z plane (o: start)')
    ax_xz.invert_yaxis()
    ax_zoom.set(xlim=(-8.0, 8.0), ylim=(8.0, -8.0), title='within 8 m of the target')
    ax_sep.set(ylabel='distance between envelopes [m]', title='separation of the chasers (truth)')
    ax_clear.set_yscale('symlog', linthresh=1.0)
    ax_clear.set(xlabel='simulation time [s]', ylabel='envelope clearance [m]',
                 title="clearance to the target's boxes (truth; symlog: linear below 1 m)")
    for ax in (ax_xz, ax_zoom, ax_sep, ax_clear):
        ax.grid(alpha=0.3, which='both')
        ax.legend(fontsize=8, loc='best')
    for ax in (ax_sep, ax_clear):
        ax.axhline(0.0, color='r', lw=1.0)
    fig.suptitle(run.title)
    fig.tight_layout()
    plots.save(fig, path, DPI)


def _write_fleet(run_dir, out, scenario):
    """The figure of several chasers: ([path] or [], [] or its name if it failed)."""
    path = out / 'chasers.png'
    try:
        fig_chasers(FleetRun(run_dir, scenario), path)
        return [path], []
    except Skipped as why:
        _say(f'chasers.png skipped: {why}')
        return [], []
    except Exception:  # noqa: BLE001 - reported like any figure's failure
        _say(f'chasers.png failed:\n{traceback.format_exc()}')
        return [], ['chasers.png']
    finally:
        plt.close('all')


def _write(run_dir, out_dir):
    """(paths written, names of the figures that failed)."""
    out = Path(out_dir) if out_dir is not None else Path(run_dir)
    out.mkdir(parents=True, exist_ok=True)
    try:
        scenario = load_scenario(Path(run_dir) / 'scenario.yaml')
    except (OSError, ScenarioError):
        scenario = None  # Run says so
    if scenario is not None and scenario.chaser_names:
        return _write_fleet(run_dir, out, scenario)
    run = Run(run_dir)
    written, failed = [], []
    for name, draw in (FIGURES + (RIGID_BODY_FIGURES if run.rigid_body else ()) + (SYNC_FIGURES if run.sync else ())
                       + (POST_CAPTURE_FIGURES if run.post_capture else ())
                       + (TRANSPORT_FIGURES if run.transport else ())):
        path = out / name
        try:
            draw(run, path)
            written.append(path)
        except Skipped as why:
            _say(f'{name} skipped: {why}')
        except Exception:  # noqa: BLE001 - one broken figure must not cost the others
            _say(f'{name} failed:\n{traceback.format_exc()}')
            failed.append(name)
        finally:
            plt.close('all')
    return written, failed


def write_report(run_dir, out_dir=None):
    """Write the figures of the run in run_dir into out_dir (default run_dir); the paths written.

    A figure whose data is missing is skipped, one that fails is reported; both on stderr.
    """
    return _write(run_dir, out_dir)[0]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('run_dir', type=Path, help='run directory (bag/, scenario.yaml, summary.json)')
    parser.add_argument('--out', type=Path, default=None, help='where the PNGs go (default RUN_DIR)')
    args = parser.parse_args(argv)
    try:
        written, failed = _write(args.run_dir, args.out)
    except BagError as err:
        _say(str(err))
        return 1
    for path in written:
        print(path)
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
