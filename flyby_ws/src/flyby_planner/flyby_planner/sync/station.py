"""Stage 1 of the synchronized approach, seed 001 section 2 and eq 1: the station point, the arrival time and the
phase-space link that reaches it.

The station is the point of the target's body frame on the docking port's outward line (the line through the port
along the outward normal of the face it sits on, flyby_planner.flyby.grasp_search.docking_axis) at
``station_range_m`` from the centre of mass: seed 001's circle of radius |r_alpha0,d| (5 m) that stage 3 orbits and
stage 4 leaves along the line for the final range of 1 m from the port. Seed 001 docks radially: its port faces away
from the centre of mass; for a port off the middle of a face the radial line is oblique to the face, and 1 m out
along it the chaser's envelope (0.75 m) reaches into the face (docs/synchronized.md, "How these rules were found"),
so the line is the face's normal, which is the radial line for a port in the middle of a face (Table 1's scenario).

**Eq 1** as printed is garbled ("min_v min_r [ |r_alpha0,dorb;x(t)| / dt - v_alpha0,dorb(t) ] -> t_s_opt < t <
t_f_opt"); we read it with the sentence before it ("a minimum difference between approaching and final velocity")
and the stated goal (least fuel): over the arrival times t in the window (t_s_opt, t_f_opt) the station point
fixed in the body is at r_s(t), moving at v_s(t) in the orbital frame; the chaser links its state now to
(r_s(t), v_s(t)) in phase space (Fig 1) and the time chosen is the one whose link costs least delta-v,
integral |a| dt of the thrust acceleration. With the 1 km start fixed, what varies with t is mostly the velocity
the chaser must match at arrival against the one its approach brings (test_seed001_eq1_optimum_by_brute_force).

**The link** (Fig 1, "linking the initial and final point in the phase space") is the cubic Hermite curve in hill
through (r0, v0) at t0 and (r_s, v_s) at t: position and velocity continuous at both ends; its thrust
acceleration is a = r'' - f(r, r') with f the relative motion without thrust of seed 001 eq 2
(``flyby_sim.dynamics.orbital.nonlinear_relative_accel``). A link whose chaser envelope would come within
``keepout_radius_m`` of the target's centre of mass (the geometry's bounding sphere plus the envelope and a
margin) is refused: the station is on the far side at that time.

**Re-solving** (section 2: "a new optimal solution is calculated from the condition of a minimum difference
between the new final state and the previous optimal solution"): with a newer target estimate the station's
motion r_s(t), v_s(t) moves; the new arrival time is the one in the window whose station state is closest to the
previous plan's, |r_s - r_prev|^2 + (tau |v_s - v_prev|)^2 with tau = ``velocity_weight_s``, among the links
that keep off the target.

Frames and units: ``hill`` of flyby_sim.dynamics.orbital (velocities relative to the rotating frame), SI.
"""

import dataclasses
import math

import numpy as np
from scipy.optimize import minimize_scalar

from flyby_planner.optimal.cost import Trajectory
from flyby_sim.dynamics.orbital import nonlinear_relative_accel

# Gauss-Legendre nodes of the delta-v integral of one link (the thrust acceleration is a smooth cubic-like
# curve; 48 nodes give its integral of |a| to about 1e-5 relative, kinks at the zero crossings included).
_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(48)
# Samples of a link checked against the keep-out sphere.
_CLEARANCE_SAMPLES = 200


@dataclasses.dataclass(frozen=True)
class StationGeometry:
    """The docking line in body axes: the port x_port_body [m], its outward unit vector u_body, the station (stages
    2-3) station_offset_m [m] out along u from the port and the final point (the end of stage 4, the capture's
    target point of DESIGN §10) final_range_m [m] out."""

    x_port_body: np.ndarray
    u_body: np.ndarray
    station_offset_m: float
    final_range_m: float

    def point(self, s_m):
        """The body point s_m [m] out along the line from the port."""
        return self.x_port_body + s_m * self.u_body

    @property
    def x_station_body(self):
        return self.point(self.station_offset_m)

    @property
    def x_final_body(self):
        return self.point(self.final_range_m)

    @property
    def station_range_m(self):
        """Distance of the station from the centre of mass [m]."""
        return float(np.linalg.norm(self.x_station_body))


def station_geometry(x_port_body, u_body, station_range_m, final_range_m):
    """StationGeometry of a docking port x_port_body [m] with outward unit vector u_body (body axes), the station on
    its line at station_range_m [m] from the centre of mass and the final point final_range_m [m] out from the
    port."""
    x_port = np.asarray(x_port_body, dtype=float)
    u = np.asarray(u_body, dtype=float)
    if not (np.all(np.isfinite(x_port)) and np.all(np.isfinite(u)) and abs(float(np.linalg.norm(u)) - 1.0) < 1e-9):
        raise ValueError(f'the docking port {x_port.tolist()} must be finite and its outward direction {u.tolist()} '
                         'a unit vector')
    if not (math.isfinite(final_range_m) and final_range_m > 0.0):
        raise ValueError(f'final_range_m must be finite and > 0, got {final_range_m}')
    along = float(x_port @ u)
    final_m = float(np.linalg.norm(x_port + final_range_m * u))
    if not station_range_m > final_m:
        raise ValueError(f'station_range_m {station_range_m} m must exceed the final point\'s distance {final_m:.3f} m '
                         f'from the centre of mass (the port plus the final range {final_range_m} m; docking moves '
                         'inward)')
    # |x_port + s u| = station_range_m, the root outward of the final point
    offset = -along + math.sqrt(along * along - float(x_port @ x_port) + station_range_m ** 2)
    return StationGeometry(x_port, u, offset, float(final_range_m))


class PhaseSpaceLink:
    """The cubic Hermite curve through (r0, v0) at t0 and (r1, v1) at t1 in hill (module doc)."""

    def __init__(self, t0, r0, v0, t1, r1, v1):
        if not t1 > t0:
            raise ValueError(f'a link needs t1 > t0, got t0 = {t0} s, t1 = {t1} s')
        self.t0, self.t1 = float(t0), float(t1)
        self.r0, self.v0 = np.asarray(r0, dtype=float), np.asarray(v0, dtype=float)
        self.r1, self.v1 = np.asarray(r1, dtype=float), np.asarray(v1, dtype=float)

    @property
    def duration_s(self):
        return self.t1 - self.t0

    def states(self, t):
        """(r (N, 3) [m], v (N, 3) [m/s], r'' (N, 3) [m/s^2]) at the times t (N,) in [t0, t1]."""
        h = self.duration_s
        s = ((np.atleast_1d(np.asarray(t, dtype=float)) - self.t0) / h)[:, None]
        r0, r1, m0, m1 = self.r0, self.r1, self.v0 * h, self.v1 * h
        s2, s3 = s * s, s * s * s
        r = (2 * s3 - 3 * s2 + 1) * r0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * r1 + (s3 - s2) * m1
        dr = (6 * s2 - 6 * s) * r0 + (3 * s2 - 4 * s + 1) * m0 + (-6 * s2 + 6 * s) * r1 + (3 * s2 - 2 * s) * m1
        ddr = (12 * s - 6) * r0 + (6 * s - 4) * m0 + (-12 * s + 6) * r1 + (6 * s - 2) * m1
        return r, dr / h, ddr / (h * h)

    def thrust_acceleration(self, t, n, radius_m):
        """(N, 3) thrust acceleration [m/s^2] a = r'' - f(r, r') (seed 001 eq 2) at the times t (N,)."""
        r, v, ddr = self.states(t)
        return ddr - nonlinear_relative_accel(r.T, v.T, n, radius_m).T

    def delta_v(self, n, radius_m):
        """integral of |a| dt [m/s] over the link (Gauss-Legendre)."""
        h = self.duration_s
        t = self.t0 + 0.5 * h * (_GAUSS_NODES + 1.0)
        return 0.5 * h * float(_GAUSS_WEIGHTS @ np.linalg.norm(self.thrust_acceleration(t, n, radius_m), axis=1))

    def closest_approach_m(self):
        """Least distance [m] of the link from the target's centre of mass (the hill origin), on samples."""
        r, _, _ = self.states(np.linspace(self.t0, self.t1, _CLEARANCE_SAMPLES))
        return float(np.min(np.linalg.norm(r, axis=1)))

    def peak_acceleration(self, n, radius_m, step_s=0.5):
        """Largest |a| [m/s^2] on samples step_s apart."""
        t = np.linspace(self.t0, self.t1, max(2, math.ceil(self.duration_s / step_s) + 1))
        return float(np.max(np.linalg.norm(self.thrust_acceleration(t, n, radius_m), axis=1)))

    def sample(self, step_s, n, radius_m):
        """flyby_planner.optimal.cost.Trajectory of the link every step_s [s] (the end included) for
        /planner/trajectory; a_hill is the thrust acceleration at each point (module doc)."""
        count = max(1, math.ceil(self.duration_s / step_s - 1e-9))
        t = np.append(self.t0 + step_s * np.arange(count), self.t1)
        r, v, _ = self.states(t)
        return Trajectory(t, r, v, self.thrust_acceleration(t, n, radius_m))


@dataclasses.dataclass(frozen=True)
class ArrivalChoice:
    """The chosen arrival: time t_arrival [s], the station's state there (r_hill [m], v_hill [m/s]), the link's
    delta-v [m/s], its closest approach to the centre of mass [m] and the link itself; how many candidate times
    were feasible out of those tried, in the arrival window window_s (t_s_opt, t_f_opt) [s]."""

    t_arrival: float
    r_hill: np.ndarray
    v_hill: np.ndarray
    delta_v_mps: float
    closest_m: float
    link: PhaseSpaceLink
    feasible: int
    tried: int
    window_s: tuple


def _grid(window_s, step_s):
    t_lo, t_hi = window_s
    if not (math.isfinite(t_lo) and math.isfinite(t_hi) and t_hi > t_lo):
        raise ValueError(f'the arrival window must be finite with its end after its start, got {window_s}')
    return np.linspace(t_lo, t_hi, max(2, math.ceil((t_hi - t_lo) / step_s) + 1))


def _best(cost, times, refine_bounds):
    """argmin of cost over the grid times (inf = infeasible), refined by a bounded scalar search between the grid
    neighbours; (t, cost) or None."""
    values = np.array([cost(t) for t in times])
    if not np.any(np.isfinite(values)):
        return None, 0
    k = int(np.argmin(values))
    lo, hi = times[max(k - 1, 0)], times[min(k + 1, len(times) - 1)]
    lo, hi = max(lo, refine_bounds[0]), min(hi, refine_bounds[1])
    best_t, best = float(times[k]), float(values[k])
    if hi > lo:
        res = minimize_scalar(cost, bounds=(lo, hi), method='bounded', options={'xatol': 1e-4})
        if res.fun < best:
            best_t, best = float(res.x), float(res.fun)
    return (best_t, best), int(np.sum(np.isfinite(values)))


def _station_state(station_track, t):
    r, v = station_track(np.array((t,)))
    return r[0], v[0]


def select_arrival(station_track, t0, r0_hill, v0_hill, window_s, n, radius_m, keepout_radius_m, grid_step_s=0.5):
    """Eq 1 (module doc): the arrival time in window_s = (t_s_opt, t_f_opt) whose link from the chaser's state
    (r0_hill, v0_hill) at t0 to the station's state costs least delta-v, among the links that keep
    keepout_radius_m off the centre of mass. station_track(times (N,)) -> (r (N, 3), v (N, 3)) of the station
    point in hill. An ArrivalChoice, or None when no time in the window is feasible."""
    lo = max(window_s[0], t0 + grid_step_s)
    if lo >= window_s[1]:
        return None
    times = _grid((lo, window_s[1]), grid_step_s)

    def link(t):
        r, v = _station_state(station_track, t)
        return PhaseSpaceLink(t0, r0_hill, v0_hill, t, r, v)

    def cost(t):
        k = link(t)
        return k.delta_v(n, radius_m) if k.closest_approach_m() >= keepout_radius_m else math.inf

    best, feasible = _best(cost, times, (lo, window_s[1]))
    if best is None:
        return None
    k = link(best[0])
    return ArrivalChoice(best[0], k.r1, k.v1, best[1], k.closest_approach_m(), k, feasible, len(times),
                         tuple(window_s))


def reselect_arrival(station_track, t0, r0_hill, v0_hill, window_s, previous_r_hill, previous_v_hill, n, radius_m,
                     keepout_radius_m, velocity_weight_s=1.0, grid_step_s=0.5):
    """The re-solve of section 2 (module doc): the arrival time in window_s whose station state is closest to the
    previous solution (previous_r_hill [m], previous_v_hill [m/s]), among the links from (r0_hill, v0_hill) at t0
    that keep keepout_radius_m off the centre of mass. An ArrivalChoice, or None."""
    lo = max(window_s[0], t0 + grid_step_s)
    if lo >= window_s[1]:
        return None
    times = _grid((lo, window_s[1]), grid_step_s)
    r_prev, v_prev = np.asarray(previous_r_hill, dtype=float), np.asarray(previous_v_hill, dtype=float)

    def cost(t):
        r, v = _station_state(station_track, t)
        if PhaseSpaceLink(t0, r0_hill, v0_hill, t, r, v).closest_approach_m() < keepout_radius_m:
            return math.inf
        return float(np.sum((r - r_prev) ** 2) + velocity_weight_s ** 2 * np.sum((v - v_prev) ** 2))

    best, feasible = _best(cost, times, (lo, window_s[1]))
    if best is None:
        return None
    r, v = _station_state(station_track, best[0])
    k = PhaseSpaceLink(t0, r0_hill, v0_hill, best[0], r, v)
    return ArrivalChoice(best[0], r, v, k.delta_v(n, radius_m), k.closest_approach_m(), k, feasible, len(times),
                         tuple(window_s))


def keepout_radius(boxes, envelope_radius_m, margin_m):
    """Radius [m] of the sphere about the centre of mass the chaser's centre keeps out of in stage 1: the target
    geometry's bounding sphere (boxes: (center_m, size_m) pairs, body axes) plus the envelope and a margin."""
    bound = max(float(np.linalg.norm(c)) + 0.5 * float(np.linalg.norm(s)) for c, s in boxes)
    return bound + envelope_radius_m + margin_m
