"""The approach planning problem of seed 003 section 4, shared by both solvers.

A chaser (a point mass with a spherical envelope, seed 003 section 4.1: "the robot is treated as a point mass")
leaves its state now, (r0_hill, v0_hill) at t0_s, and must arrive after the approach time T synchronized with
the target's grasp point at an offset (seed 003 section 4.2: "the robot has synchronized its motion with the
satellite at an offset distance from the target grasp point"): the end state is X_Ft, V_Ft of seed 000 eq 20-21
at t0_s + T, from the target-motion prediction (flyby_estimation.target_motion.MotionPrediction). The target's
geometry is its body boxes (flyby_sim.scenario.Boxes) turned by the predicted attitude at each time.

The thrust acceleration of a path is what the thrusters add to the Clohessy-Wiltshire motion (seed 000 eq 2,
flyby_sim.dynamics.orbital.cw_accel): a = r'' - cw_accel(r, r'). Over a one-minute approach the orbital terms are
about 1 % of the thrust, but both solvers count them, so their figures compare.

Frames and units as in flyby_planner.flyby.grasp_search (hill, velocities relative to the rotating hill frame, SI).
"""

import dataclasses
import math

import numpy as np

from flyby_msgs_py import params
from flyby_planner.flyby.grasp_search import flyby_target_point
from flyby_planner.optimal.cost import box_contacts
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2

# The plume rule's margin (seed 003 metric 4 as a rule), one home for the planner and the tracking: guidance applies
# the rule where the estimate, carried over the command's delay and hold, comes within the plume radius plus this
# (the estimate's error, 1 cm here), and the planner keeps a least-fuel plan's thrust (which brakes at the sphere) off
# the away side from the radius plus twice this (``planning_plume_radius_m``): the tracking's margin and as much again
# for the tracking error, so that the braking the plan ends at its sphere is flown, not removed by the rule [m].
PLUME_MARGIN_M = 0.1


def planning_plume_radius_m(plume_radius_m):
    """The sphere [m] within which a plan has no thrust away from the target: the rule's radius plus twice
    PLUME_MARGIN_M (its doc), zero for no rule."""
    return plume_radius_m + 2.0 * PLUME_MARGIN_M if plume_radius_m > 0.0 else 0.0


@dataclasses.dataclass(frozen=True)
class CostWeights:
    """Weights k_a, k_f, k_s, k_pi, k_t of seed 003 eq 5 (the paper prints none; these are ours).

    Each term of eq 5 is dimensionless with these units: k_a [1/s] on the actuator metric (dimensionless, per
    second of trajectory), k_f [1/kg] on the fuel rate f_p [kg/s], k_s [s/m] on the safety metric v^2/d
    [m/s^2], k_pi [s/m] on the plume metric [m/s^2], k_t [1/s^2] on the approach time squared.
    """

    actuator: float = 1000.0
    fuel_per_kg: float = 10.0
    safety: float = 1.0
    plume: float = 100.0
    time: float = 1e-3

    def __post_init__(self):
        for name in ('actuator', 'fuel_per_kg', 'safety', 'plume', 'time'):
            require_positive(name, getattr(self, name), allow_zero=True)


@params.record
class Chaser:
    """The robot: mass [kg], specific impulse [s], largest thrust acceleration [m/s^2] (of a scenario: the full
    thrust over the mass, thrusters.max_thrust_n / mass_kg), envelope radius [m]."""

    mass_kg: float = params.key('chaser.mass_kg')
    isp_s: float = params.key('chaser.thrusters.isp_s')
    accel_max_mps2: float = params.derived(lambda sc: sc.chaser.thrusters.max_thrust_n / sc.chaser.mass_kg)
    envelope_radius_m: float = params.key('chaser.envelope_radius_m')

    def __post_init__(self):
        for name in ('mass_kg', 'isp_s', 'accel_max_mps2'):
            require_positive(name, getattr(self, name))
        require_positive('envelope_radius_m', self.envelope_radius_m, allow_zero=True)

    @property
    def exhaust_velocity_mps(self):
        """Isp g0 [m/s]."""
        return self.isp_s * STANDARD_GRAVITY_M_S2


class TargetMotion:
    """The target's predicted attitude and geometry at any time of a MotionPrediction.

    ``attitude(times)`` gives C_hill_from_body (N, 3, 3) and the body's rate relative to the rotating hill frame,
    omega_rel_hill = omega_hill - Omega^H (N, 3) [rad/s] (seed 000 eq 6, 11), so that a body point at q_hill moves
    at omega_rel_hill x q_hill relative to hill (flyby_sim.dynamics.attitude.body_point_state).
    """

    def __init__(self, prediction, boxes, n):
        self.prediction = prediction
        self.boxes = boxes
        self.n = n
        self._omega_orbit_hill = np.array((0.0, -n, 0.0))

    def attitude(self, times):
        """(C_hill_from_body (N, 3, 3), omega_rel_hill (N, 3) [rad/s]) at the times (N,) [s]."""
        t = np.atleast_1d(np.asarray(times, dtype=float))
        c = self.prediction.c_hill_from_body(t)
        omega_hill = self.prediction.track(np.zeros(3), t).omega_hill
        return c, omega_hill - self._omega_orbit_hill


class GraspTerminal:
    """End state of the approach at time t: X_Ft, V_Ft of the grasp point x_grasp_body [m] at offset_m [m],
    seed 000 eq 20-21 (flyby_planner.flyby.grasp_search.flyby_target_point) on the predicted motion."""

    def __init__(self, prediction, x_grasp_body, offset_m):
        self.prediction = prediction
        self.x_grasp_body = np.asarray(x_grasp_body, dtype=float)
        self.offset_m = float(offset_m)

    def __call__(self, t):
        """(r_hill [m], v_hill [m/s]) at time t [s]."""
        track = self.prediction.track(self.x_grasp_body, np.array((float(t),)))
        return flyby_target_point(track.r_hill[0], track.v_hill[0], self.offset_m)  # eq 20-21


class FixedTerminal:
    """A fixed end state (r_hill [m], v_hill [m/s]) whatever the time (tests, a parking point)."""

    def __init__(self, r_hill, v_hill):
        self.r_hill = np.asarray(r_hill, dtype=float)
        self.v_hill = np.asarray(v_hill, dtype=float)

    def __call__(self, t):
        return self.r_hill.copy(), self.v_hill.copy()


@dataclasses.dataclass(frozen=True)
class ApproachProblem:
    """One robot's approach (module doc).

    Attributes:
        r0_hill, v0_hill: chaser state at t0_s [m], [m/s].
        t0_s: start time [s] (sim time of the prediction).
        terminal: t -> (r_hill, v_hill) of the end state (GraspTerminal, FixedTerminal).
        target: TargetMotion (geometry and attitude), or None for free space.
        chaser: Chaser.
        n: orbital mean motion [rad/s].
        plume_radius_m: within this distance of the target's centre of mass an acceleration away from the target
            (its exhaust toward the target) impinges (seed 003 metric 4).
        weights: CostWeights of eq 5.
        duration_min_s, duration_max_s: the range of approach times T searched [s].
    """

    r0_hill: np.ndarray
    v0_hill: np.ndarray
    t0_s: float
    terminal: object
    target: object
    chaser: Chaser
    n: float
    plume_radius_m: float
    weights: CostWeights = CostWeights()
    duration_min_s: float = 20.0
    duration_max_s: float = 200.0

    def __post_init__(self):
        require_positive('plume_radius_m', self.plume_radius_m, allow_zero=True)
        require_positive('duration_min_s', self.duration_min_s)
        if not (math.isfinite(self.duration_max_s) and self.duration_max_s > self.duration_min_s):
            raise ValueError(f'duration_max_s {self.duration_max_s} must exceed duration_min_s {self.duration_min_s}')

    def end_state(self, duration_s):
        """(r_hill, v_hill) the chaser must reach after duration_s [s]."""
        return self.terminal(self.t0_s + duration_s)


def _smoothstep(s):
    """3 s^2 - 2 s^3: leaves and arrives with zero rate, so a route along it starts and ends at rest."""
    return s * s * (3.0 - 2.0 * s)


def heuristic_route(problem, duration_s, samples=200):
    """A collision-free route from the start to the end point, the heuristic start of seed 003 section 4.1 ("a
    heuristically determined collision free path should be chosen as a starting point").

    The straight segment if the chaser envelope clears the target's geometry along it (sampled at ``samples``
    times with the predicted attitude); else the segments through a point 1.5 bounding radii from the centre of
    mass, toward the mean of the start and end directions or either side of it, whichever clears most. Either is
    run along a smoothstep in time (3 s^2 - 2 s^3 of the length), leaving and arriving at rest, which the
    acceleration bound allows when 6 length / T^2 is below it.

    Returns:
        route(s) -> (M, 3) hill positions [m] for path fractions s (M,) in [0, 1] (s = tau / T).
    """
    r0 = np.asarray(problem.r0_hill, dtype=float)
    r_f, _ = problem.end_state(duration_s)

    def straight(s):
        return r0 + np.outer(_smoothstep(np.asarray(s, dtype=float)), r_f - r0)

    target = problem.target
    if target is None:
        return straight
    s_check = np.linspace(0.0, 1.0, samples)
    c, _ = target.attitude(problem.t0_s + s_check * duration_s)

    def least_gap(route):
        return float(box_contacts(route(s_check), c, target.boxes)[0].min()) - problem.chaser.envelope_radius_m

    if least_gap(straight) > 0.0:
        return straight
    corners = np.abs(target.boxes.center_body_m) + 0.5 * np.asarray(target.boxes.size_m)
    radius = 1.5 * float(np.linalg.norm(corners, axis=1).max()) + problem.chaser.envelope_radius_m
    u0, uf = r0 / np.linalg.norm(r0), r_f / np.linalg.norm(r_f)
    mean = u0 + uf
    side = np.cross(u0, uf)
    if np.linalg.norm(side) < 1e-9:  # start and end on one line through the centre of mass
        side = np.cross(u0, (0.0, 1.0, 0.0) if abs(u0[1]) < 0.9 else (1.0, 0.0, 0.0))
    side = side / np.linalg.norm(side)
    directions = [mean, mean + side * np.linalg.norm(mean), mean - side * np.linalg.norm(mean), side, -side]
    best, best_gap = straight, least_gap(straight)
    for d in directions:
        if np.linalg.norm(d) < 1e-9:
            continue
        via = radius * d / np.linalg.norm(d)

        def through(s, via=via):
            # the two segments by arc length along the smoothstep, so the route leaves and arrives at rest
            first, second = np.linalg.norm(via - r0), np.linalg.norm(r_f - via)
            length = _smoothstep(np.asarray(s, dtype=float)) * (first + second)
            return np.where((length <= first)[:, None], r0 + np.outer(length / first, via - r0),
                            via + np.outer((length - first) / second, r_f - via))
        gap = least_gap(through)
        if gap > best_gap:
            best, best_gap = through, gap
        if gap > 0.0:
            break
    return best


def approach_problem(settings, prediction, r0_hill, v0_hill, t0_s, plume_radius_m, x_grasp_body=None, offset_m=None,
                     chaser=None, weights=CostWeights(), duration_min_s=20.0, duration_max_s=200.0):
    """ApproachProblem of the target of ``settings`` (optimal.approach.ApproachSettings: its boxes, grasp point,
    offset and chaser by default) from a MotionPrediction (the estimator's, or
    flyby_planner.flyby.config.truth_prediction) and the chaser's state at t0_s."""
    n = settings.mean_motion_rad_s
    grasp = settings.x_grasp_body_m if x_grasp_body is None else x_grasp_body
    offset = settings.offset_m if offset_m is None else offset_m
    return ApproachProblem(
        r0_hill=np.asarray(r0_hill, dtype=float), v0_hill=np.asarray(v0_hill, dtype=float), t0_s=float(t0_s),
        terminal=GraspTerminal(prediction, grasp, offset), target=TargetMotion(prediction, settings.boxes, n),
        chaser=settings.chaser if chaser is None else chaser, n=n, plume_radius_m=plume_radius_m,
        weights=weights, duration_min_s=duration_min_s, duration_max_s=duration_max_s)
