"""Reading a mission run directory (what scripts/run_mission.py leaves: bag/, scenario.yaml, summary.json) for the
report's figures: the bag's series, the scenario, the summary and the quantities derived from them once (Run); the
truth paths of several chasers (FleetRun).

An interrupted run works too: a bag without metadata.yaml is repaired first (as analyze_bag.py does), and whatever
is missing (topics, plan, grasp, burns, scenario) is left out and said on stderr (say); a figure whose essential
data is missing raises Skipped.

Velocities follow nav_msgs' rule (DESIGN section 10): an Odometry's twist is in child_frame_id axes, so
twist.linear and its covariance are turned into hill by pose.orientation before use (the rigid-body
chaser's twist is in chaser_body axes; the point mass publishes the identity, which changes nothing).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import sys
from pathlib import Path

import numpy as np

from flyby_mission.post_capture_figures import post_capture_truth
from flyby_mission.run_events import grasp_time, lock_time, phase_start, phase_windows
from flyby_mission.run_truth import chaser_truth_from_odometry, thrust_truth
from flyby_msgs_py import contract as c
from flyby_msgs_py import events
from flyby_msgs_py.bag import BagError, MessageList, PathLatest, StringSeries, bag_topics, read_bag, repair_bag
from flyby_msgs_py.schema import ScenarioError
from flyby_msgs_py.wire import STAMP_TOLERANCE_S  # truth (every step) and estimate stamps: one instant
from flyby_planner.flyby.keepout import swept_region
from flyby_sim.dynamics.orbital import q_eci_from_body
from flyby_sim.dynamics.rotation import quat_rotate_many, quat_to_matrix_many
from flyby_sim.scenario import load_scenario

BURN_MATCH_TOLERANCE_S = 0.01  # a commanded burn time against the simulator's start of it
STEP_TOLERANCE_S = 0.05        # a time this close to the truth's span is within it (one step)
REGION_SAMPLES = 200           # truth attitude samples the swept region is built from
TOPICS = (c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM, c.EST_CHASER_ODOM, c.EST_TARGET_ODOM, c.PLANNER_PATH,
          c.PLANNER_GRASP, c.PLANNER_FLYBY_TARGET, c.PLANNER_FLYBY_INITIAL, c.MISSION_PHASE,
          c.MISSION_EVENTS)
RIGID_BODY_TOPICS = (c.SIM_CHASER_THRUST, c.SIM_CHASER_WHEELS, c.SIM_CHASER_THRUSTERS)  # read for rigid_body only
POST_CAPTURE_TOPICS = (c.EST_TARGET_INERTIA,)  # read with a post_capture section only


class Skipped(Exception):
    """A figure (or a part of one) cannot be drawn: its data is not in the run."""


def say(message):
    """Tell the reader of stderr what the report left out or repaired."""
    print(f'mission_report: {message}', file=sys.stderr)


@dataclasses.dataclass(frozen=True)
class Burn:
    """An executed burn: its start [s], the kind guidance commanded, delta-v commanded and executed."""
    t_start: float
    kind: str
    dv_cmd_hill: np.ndarray | None   # [m/s]
    dv_hill: np.ndarray | None       # executed [m/s]


def _vector(values, key):
    """A '[x, y, z]' event value as an array, None if absent."""
    return np.array(json.loads(values[key]), dtype=float) if key in values else None


def _burns(mission_events):
    """Executed burns (the simulator's burn_started), labelled with the kind guidance commanded."""
    commanded = [(float(e['values']['t_burn_s']), e['values'].get('kind', 'burn'))
                 for e in mission_events if e['name'] == events.MANEUVER_COMMANDED]
    burns = []
    for e in mission_events:
        if e['name'] != events.BURN_STARTED or e['hardware_id'] != 'flyby_sim':
            continue
        v = e['values']
        t_start = float(v.get('t_start', e['t']))
        t_cmd = float(v.get('t_cmd', t_start))
        kind = next((k for t, k in commanded if abs(t - t_cmd) <= BURN_MATCH_TOLERANCE_S), 'burn')
        burns.append(Burn(t_start, kind, _vector(v, 'dv_cmd_hill'), _vector(v, 'dv_hill')))
    return burns


def is_empty(series):
    """Whether a series read from the bag has no sample."""
    if isinstance(series, list):          # events
        return not series
    if isinstance(series, PathLatest):
        return not len(series.positions)
    if isinstance(series, StringSeries):
        return not series.data
    if isinstance(series, MessageList):
        return not series.messages
    return not len(series.t)


def open_bag(bag_dir):
    """The bag's topics; a bag whose recorder was killed (no metadata.yaml) is repaired first."""
    try:
        return bag_topics(bag_dir)
    except BagError as err:
        if not bag_dir.is_dir():
            raise
        say(f'{err}; repairing it')
        report = repair_bag(bag_dir)
        say(f'bag repaired: {report["message_count"]} messages kept ({report.get("stop_reason")})')
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


def is_sync(summary, mission_events):
    """Whether the run flew the synchronized approach: summary.json's method, or a plan_selected event's."""
    return summary.get('method') == 'sync' or any(
        e['name'] == events.PLAN_SELECTED and e['values'].get('method') == 'sync' for e in mission_events)


def run_title(run_dir, scenario, summary):
    """A run's figure title: its scenario's name, the run's seed (summary.json's, the one flown; else its
    scenario.yaml's) and its outcome."""
    seed = summary.get('seed', scenario.seed if scenario is not None else None)
    name = scenario.name if scenario is not None else summary.get('scenario', Path(run_dir).name)
    name = f'{name}, seed {seed}' if seed is not None else name
    outcome = summary.get('outcome')
    return f'{name}: {outcome}' if outcome else name


class Run:
    """What the figures draw from: the bag's series (absent or empty topics left out), the scenario,
    the summary, and quantities derived from them once."""

    def __init__(self, run_dir):
        self.run_dir = Path(run_dir)
        present = open_bag(self.run_dir / 'bag')
        self.scenario = self._load_scenario()
        self.rigid_body = self.scenario is not None and self.scenario.chaser.model == 'rigid_body'
        self.post_capture = self.scenario is not None and self.scenario.post_capture is not None
        self.transport = self.post_capture and self.scenario.post_capture.transport is not None
        wanted = [c.absolute(t) for t in TOPICS + (RIGID_BODY_TOPICS if self.rigid_body else ())
                  + (POST_CAPTURE_TOPICS if self.post_capture else ())]
        data = read_bag(self.run_dir / 'bag', topics=[t for t in wanted if t in present])
        self.series = {t: s for t, s in data.items() if not is_empty(s)}
        absent = [t for t in wanted if t not in self.series]
        if absent:
            say(f'not in the bag or empty, left out: {", ".join(absent)}')
        self.events = self.series.get(c.absolute(c.MISSION_EVENTS), [])
        self.burns = _burns(self.events)
        summary = self.run_dir / 'summary.json'
        self.summary = json.loads(summary.read_text()) if summary.is_file() else {}
        self.sync = is_sync(self.summary, self.events)

    def _load_scenario(self):
        """The run's scenario.yaml, None (said on stderr) if it cannot be read."""
        try:
            return load_scenario(self.run_dir / 'scenario.yaml')
        except (OSError, ScenarioError) as err:
            say(f'no scenario ({err}): the sphere, keep-out region and clearances are left out')
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
        """The scenario; Skipped without one."""
        if self.scenario is None:
            raise Skipped('no scenario.yaml')
        return self.scenario

    @property
    def title(self):
        """The figures' title: scenario, the run's seed (its summary's, else its scenario.yaml's) and outcome."""
        return run_title(self.run_dir, self.scenario, self.summary)

    @functools.cached_property
    def t_end(self):
        """The run's last truth stamp [s], else its last event's."""
        chaser = self.get(c.SIM_CHASER_ODOM)
        return float(chaser.t[-1]) if chaser is not None else max((e['t'] for e in self.events), default=0.0)

    @functools.cached_property
    def attached(self):
        """(t_start, t_end) [s] in which the chaser holds the target and the plant moves them as one: the whole run
        when it starts attached, else from the CAPTURE phase's start to a release (ESCAPE after it) or the run's
        end; None if it never holds it."""
        post = self.scenario.post_capture if self.scenario is not None else None
        if post is not None and post.start == 'attached':
            return 0.0, self.t_end
        t_capture = phase_start(self.events, c.PHASE_CAPTURE)
        if t_capture is None:
            return None
        t_release = phase_start(self.events, c.PHASE_ESCAPE)
        return t_capture, t_release if t_release is not None and t_release > t_capture else self.t_end

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
        """[(phase, t_start, t_end)] of the supervisor's stamped phase_changed events (run_events.phase_windows), else
        of the receive times of /mission/phase, which lag the decisions; a window never ends before it starts."""
        windows = phase_windows(self.events, self.t_end)
        msgs = self.get(c.MISSION_PHASE)
        if not windows and msgs is not None:
            received = [{'name': events.PHASE_CHANGED, 't': t, 'values': {'to': phase}}
                        for t, phase in zip(msgs.t_received, msgs.data, strict=True)]
            windows = phase_windows(received, self.t_end)
        return [(phase, t0, max(t0, t1)) for phase, t0, t1 in windows]

    @functools.cached_property
    def kind_colors(self):
        """A colour per burn kind, in order of appearance."""
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
        """post_capture_figures.post_capture_truth of the truth topics, read as compute_summary reads them: (common
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
            say(f'no swept keep-out region: {err}')
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


class FleetRun:
    """What the figure of several chasers draws from: each chaser's truth positions (its namespace's
    sim/chaser/odom), the target's truth attitude, the scenario and the summary."""

    def __init__(self, run_dir, scenario):
        self.run_dir, self.scenario = Path(run_dir), scenario
        open_bag(self.run_dir / 'bag')
        topics = {name: c.absolute(c.SIM_CHASER_ODOM, f'/{name}') for name in scenario.chaser_names}
        data = read_bag(self.run_dir / 'bag', topics=[*topics.values(), c.absolute(c.SIM_TARGET_ODOM)])
        self.chasers = {name: data[t] for name, t in topics.items() if not is_empty(data.get(t))}
        self.target = data.get(c.absolute(c.SIM_TARGET_ODOM))
        summary = self.run_dir / 'summary.json'
        self.summary = json.loads(summary.read_text()) if summary.is_file() else {}
        self.title = run_title(self.run_dir, scenario, self.summary)
