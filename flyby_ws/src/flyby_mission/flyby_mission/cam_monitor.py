"""The independent collision-avoidance monitor (docs/faults.md): ATV's monitoring and safing unit for flyby.

It shares nothing with the planning chain but the sensors' raw samples and the scenario's geometry: its own estimate
of the chaser's motion (the IMU's raw thrust acceleration, turned into hill by its raw star-tracker attitude and
integrated twice, taken off the last ``POSITION_FIT_S`` of relative positions, whose least-squares line is then the
coast's: position and velocity now; coasted by Clohessy-Wiltshire, Matsumoto et al. eq 22, with the thrust
acceleration of the last IMU sample held) and of the target's attitude (``cam_attitude``: the torque-free motion on
the scenario's inertia fitted to the last 30 s of vision attitudes: a tumbler's rate is not constant over a window,
docs/faults.md), so a fault of the navigation filter, the planner, guidance or the supervisor does not reach it. At
every relative-position sample it predicts the clearance between the chaser's envelope and the target's real
geometry (its boxes at the predicted attitude, ``geometry.clearance``) every ``STEP_S`` over ``HORIZON_S``; where
the coast meets the geometry (a planned passage may clear it by centimetres: a margin there would fire on nominal
fly-bys) within the time the chaser still needs to stop, ``REACTION_S`` plus the time its closing speed takes to
cover its braking distance (the thrusters' braking: the least of their largest pure forces along 26 body directions
over its mass; an approach that brakes on its own later, as a thrusting approach does, is left to the planning chain
until then), it commands a collision-avoidance manoeuvre (CAM) straight to the plant's thrusters on ``safety/cam``:
the chaser's closing speed along the line from the target's CoM cancelled and ``avoidance_delta_v_mps`` away, once.
The plant executes it ahead of everything queued and takes no more commands of the planning chain
(``Plant.command_cam``); the supervisor aborts at its ``cam_fired``.

Its estimates need ``MIN_SAMPLES`` of each sensor within their windows; it stands down at the capture (the chaser
then holds the target) and never fires twice.
"""

import dataclasses
import itertools
from typing import NamedTuple

import numpy as np

from flyby_mission.cam_attitude import TargetAttitudeFit
from flyby_msgs_py import contract as c
from flyby_msgs_py import events, params
from flyby_msgs_py.wire import Event
from flyby_sim.dynamics.actuators import allocate_max_force
from flyby_sim.dynamics.geometry import clearance
from flyby_sim.dynamics.orbital import cw_transition_matrix
from flyby_sim.dynamics.rotation import quat_rotate

POSITION_FIT_S = 5.0
MIN_SAMPLES = 5
HORIZON_S = 30.0
STEP_S = 0.25
REACTION_S = 2.5  # from a sample to the CAM's burn under way: the graph's pace lets it come up to 1 s late
STAND_DOWN_PHASES = (c.PHASE_CAPTURE,) + c.POST_CAPTURE_PHASES + (c.PHASE_COMPLETE,)


def _braking(scenario):
    """The least of the thrusters' largest pure forces over 26 body directions (the axes, the edges' and the corners'
    diagonals) over the chaser's mass [m/s^2]; the point mass's thrust along any."""
    mass = scenario.chaser.mass_kg
    if scenario.chaser.model != 'rigid_body':
        return scenario.chaser.thrusters.max_thrust_n / mass
    layout = scenario.thruster_layout
    directions = [np.array(d, dtype=float) for d in itertools.product((-1, 0, 1), repeat=3) if any(d)]
    return min(allocate_max_force(layout, d / np.linalg.norm(d)).force_n for d in directions) / mass


def _boxes(scenario):
    g = scenario.target.geometry
    return tuple((tuple(b.center_m), tuple(b.size_m)) for b in g)


@params.record
class CamParams:
    """What the monitor reads of the scenario."""

    boxes: tuple = params.derived(_boxes)  # the target's geometry: (center_m, size_m) in target_body
    envelope_radius_m: float = params.key('chaser.envelope_radius_m')
    mean_motion_rad_s: float = params.key('mean_motion_rad_s')
    avoidance_delta_v_mps: float = params.key('supervisor.avoidance_delta_v_mps')
    braking_mps2: float = params.derived(_braking)  # the CAM's least acceleration, whatever the attitude
    target_inertia_kg_m2: tuple = params.key('target_inertia', lambda m: tuple(map(tuple, np.asarray(m).tolist())))


class CamBurn(NamedTuple):
    """The CAM: delta-v [m/s, hill] to start at t [s] (safety/cam), with the clearance that fired it."""

    t: float
    dv_hill: np.ndarray
    predicted_clearance_m: float
    t_contact_s: float


@dataclasses.dataclass
class _Fit:
    """The samples of one sensor within its window: (t, value)."""

    window_s: float
    samples: list = dataclasses.field(default_factory=list)

    def add(self, t, value):
        self.samples.append((float(t), np.asarray(value, dtype=float)))
        while self.samples and self.samples[0][0] < t - self.window_s - 1e-9:
            self.samples.pop(0)


class CamMonitor:
    """The monitor's state and rule (module doc)."""

    def __init__(self, p: CamParams, name='flyby_cam_monitor'):
        self.p = p
        self.name = name
        self.positions = _Fit(POSITION_FIT_S)
        self.attitudes = TargetAttitudeFit(p.target_inertia_kg_m2, p.mean_motion_rad_s)
        self.standing_down = False
        self.fired = None
        self.q_chaser = None  # the star tracker's last attitude of chaser_body in hill
        self.thrust = None  # (t, u [m/s], s [m], a [m/s^2]) hill: the thrust's integrals since the first IMU sample
        self.taus = np.arange(0.0, HORIZON_S + 1e-9, STEP_S)
        # CW's position rows at each step of the horizon, (K, 3, 6): the same at every sample
        self.phi_r = np.array([cw_transition_matrix(p.mean_motion_rad_s, tau)[:3] for tau in self.taus])
        # the geometry lies within this of the target's CoM: a path farther off meets none of it, whatever the attitude
        self.reach_m = max(float(np.linalg.norm(c)) + 0.5 * float(np.linalg.norm(s)) for c, s in p.boxes)

    def on_phase(self, phase):
        if phase in STAND_DOWN_PHASES:
            self.standing_down = True

    def on_attitude(self, t, q_hill_from_body):
        self.attitudes.add(t, q_hill_from_body)
        return []

    def on_imu(self, t, q_hill_from_body, specific_force_body):
        """An IMU sample: the star tracker's attitude (or None) and the mean specific force since the last
        [m/s^2, chaser_body], integrated in hill."""
        if q_hill_from_body is not None:
            self.q_chaser = np.asarray(q_hill_from_body, dtype=float)
        if self.q_chaser is None or specific_force_body is None:
            return []
        a = quat_rotate(self.q_chaser, np.asarray(specific_force_body, dtype=float))
        if self.thrust is None:
            self.thrust = (float(t), np.zeros(3), np.zeros(3), a)
            return []
        t0, u, s, _ = self.thrust
        dt = float(t) - t0
        self.thrust = (float(t), u + a * dt, s + u * dt + 0.5 * a * dt**2, a)
        return []

    def _thrust_at(self, t):
        """(u, s, a) of the thrust at t, carried from the last IMU sample with its acceleration (zeros without)."""
        if self.thrust is None:
            return np.zeros(3), np.zeros(3), np.zeros(3)
        t0, u, s, a = self.thrust
        dt = t - t0
        return u + a * dt, s + u * dt + 0.5 * a * dt**2, a

    def on_position(self, t, r_hill):
        """A relative-position sample: the prediction, and the CAM where it is contact (module doc)."""
        self.positions.add(t, np.asarray(r_hill, dtype=float) - self._thrust_at(t)[1])
        if self.standing_down or self.fired is not None:
            return []
        state = self.chaser_state(t)
        if state is None or not self.attitudes.ready:
            return []
        taus = self.taus
        u, s, accel = self._thrust_at(t)
        state = state + np.concatenate((s, u))
        r = self.phi_r @ state + 0.5 * np.outer(taus**2, accel)
        if float(np.linalg.norm(r, axis=1).min()) >= self.reach_m + self.p.envelope_radius_m:
            return []  # every predicted clearance is positive: the attitude need not be predicted
        q = self.attitudes.q_hill_at(t, t + taus)
        gaps = clearance(r, q, self.p.boxes, self.p.envelope_radius_m)
        if not np.any(gaps < 0.0):
            return []
        k = int(np.argmax(gaps < 0.0))
        if taus[k] > self.stopping_time_s(state):
            return []
        self.fired = CamBurn(t, self._escape(state), float(gaps.min()), float(t + taus[k]))
        burn = self.fired
        return [burn, Event(t, 'ERROR', events.CAM_FIRED,
                            f'CAM: contact predicted at t = {burn.t_contact_s:.2f} s (least clearance '
                            f'{burn.predicted_clearance_m:.3f} m within {HORIZON_S:g} s): '
                            f'{float(np.linalg.norm(burn.dv_hill)):.4g} m/s away',
                            dict(dv_hill=burn.dv_hill, t_contact_s=burn.t_contact_s,
                                 predicted_clearance_m=burn.predicted_clearance_m), self.name)]

    def stopping_time_s(self, state):
        """REACTION_S plus the time the closing speed on the target's CoM takes to cover the CAM's braking distance,
        v^2 / (2 a) at v: v / (2 a)."""
        r, v = state[:3], state[3:]
        closing = max(0.0, -float(v @ r) / max(float(np.linalg.norm(r)), 1e-9))
        return REACTION_S + closing / (2.0 * self.p.braking_mps2)

    def chaser_state(self, t):
        """[r; v] (hill) at t of the coast through the window's positions less the thrust's displacement (the
        thrust's own part not added back), or None with too few."""
        if len(self.positions.samples) < MIN_SAMPLES:
            return None
        ts = np.array([s for s, _ in self.positions.samples]) - t
        ys = np.array([v for _, v in self.positions.samples])
        design = np.column_stack((np.ones_like(ts), ts))
        coef, *_ = np.linalg.lstsq(design, ys, rcond=None)
        return np.concatenate((coef[0], coef[1]))

    def _escape(self, state):
        """The CAM's delta-v: the closing speed along the line from the target's CoM cancelled, and
        avoidance_delta_v_mps away."""
        r, v = state[:3], state[3:]
        norm = float(np.linalg.norm(r))
        away = r / norm if norm > 0.0 else np.array([1.0, 0.0, 0.0])
        closing = min(float(v @ away), 0.0)
        return (self.p.avoidance_delta_v_mps - closing) * away
