"""Grasp time, grasp point and fly-by target/initial points, seed 000 sections 4.3 and 4.5 (eq 10-23).

Pure numpy/scipy, no ROS.

Frames. ``hill`` is that of ``flyby_sim.dynamics.orbital`` (seed 000 Fig. 3): origin at the target's centre
of mass, x along-track, y orbit anti-normal, z toward Earth's centre; it rotates relative to inertial
space with Omega^H = [0, -n, 0] (eq 11). Every velocity here is relative to the rotating hill frame
(d/dt of the hill position, the velocity the chaser must match). ``omega_hill`` is the target's
*inertial* angular velocity in hill axes (eq 6), as in ``flyby_estimation.target_motion``.
Quaternions, where used, are (x, y, z, w), scalar last. SI units: m, s, rad.

Two routes to the grasp instant:

* ``grasp_candidates`` -- general: samples the grasp point's hill y-velocity from a prediction,
  brackets its sign changes and refines them with Brent's method (eq 13 without the constant-spin
  assumption), then applies the safe convex condition eq 15 to each root.
* ``grasp_point_closed_form`` / ``convex_grasp_closed_form`` -- eq 12, 18-19 for a spin vector that
  is constant in hill axes (the section 4.3 assumption); the tests check the search against them.

Paper notes (one line each, settled by tests in test/test_grasp.py):

* Eq 13 writes v_g^H = omega_T^H x x_g^H, i.e. it neglects the hill frame's own rotation. The
  velocity relative to hill is (omega^H - Omega^H) x x_g^H (eq 9 note of
  flyby_sim.dynamics.attitude.body_point_state); with the section 5 orbit (7000 km, n = 1.08e-3 rad/s)
  and 5 deg/s spin this moves the grasp point by 7 mm and its velocity by 2.6 mm/s (2 %)
  (test_hill_rotation_effect_on_seed000_grasp). The closed forms hold exactly with the rate relative
  to hill, omega_rel = omega^H - Omega^H, at the grasp instant.
* Eq 15 is the sign test of the projection of x_g on the spin axis against the CW acceleration at
  the grasp state; it vanishes identically for n = 0, so it needs the true orbit rate even when the
  kinematics neglect it (test_seed000_section5_grasp_values).
* Eq 16's second term prints cos(psi) for sin(psi) (convex_condition_closed_form).
* Eq 17 drops the n^2 terms of eq 16; they are not always negligible: when |omega| sin(xi) is below
  about 2 n both roots of a turn can satisfy eq 15 (the 3 n^2 z term wins). grasp_candidates applies
  eq 15 in full, so it may then report two convex candidates per turn; eq 17's pick is one of them.
* Eq 19b prints |omega_T^B| |x_g^B| where 19a has |omega_T^H| |x_g^H|: equal (rotation invariant).
"""

import dataclasses
import math

import numpy as np
from scipy.optimize import brentq

from flyby_estimation.target_motion import body_point_in_hill
from flyby_sim.dynamics.geometry import outward_normal
from flyby_sim.dynamics.orbital import cw_accel, cw_coast
from flyby_sim.dynamics.rotation import quat_to_matrix

_E_Y = np.array((0.0, 1.0, 0.0))
# A re-solved root this close to the planned grasp time [turns relative to hill] is the planned root.
_FOLLOW_TURNS = 0.1
# Guidance's re-aim searches the re-solved grasp at most this far past the aimed grasp time [s] (refine_grasp's
# t_latest; the planner's re-aim check does the same).
REFINE_HORIZON_S = 60.0


@dataclasses.dataclass(frozen=True)
class GraspCandidate:
    """One instant where the grasp point's hill y-velocity vanishes (seed 000 eq 13-14).

    Attributes:
        t_grasp: sim time [s].
        x_g: grasp point position in hill [m] (from the target's centre of mass).
        v_g: grasp point velocity relative to the rotating hill frame, hill axes [m/s].
        omega_hill: target inertial angular velocity in hill axes at t_grasp [rad/s] (eq 6).
        convex_value: left side of eq 15 [m^2/s^2]; > 0 means convex.
        convex: convex_value > 0, the safe convex approach condition (eq 15).
    """

    t_grasp: float
    x_g: np.ndarray
    v_g: np.ndarray
    omega_hill: np.ndarray
    convex_value: float
    convex: bool


def convex_condition_value(omega_hill, x_g, v_g, n):
    """Left side of seed 000 eq 15; the approach is safely convex when it is > 0.

    .. math:: \\left(\\frac{\\omega^\\top x_g}{|\\omega|}\\frac{\\omega}{|\\omega|}\\right)^\\top \\ddot X_g

    The projection of x_g on the spin axis dotted with the CW acceleration at (x_g, v_g) (the X''_g^H
    under eq 15: eq 2a-2c without external acceleration, flyby_sim.dynamics.orbital.cw_accel): positive
    when the Coriolis curvature (right-handed screw about +y, section 3.2) bends the approach and
    escape paths away from the target body. The full acceleration is used (eq 16), not the
    small-n approximation eq 17. Zero for n = 0.

    Args:
        omega_hill: target angular velocity in hill axes [rad/s] (eq 6; nonzero).
        x_g: grasp point in hill [m].
        v_g: grasp point velocity relative to hill [m/s].
        n: orbital mean motion [rad/s], >= 0.
    """
    w = np.asarray(omega_hill, dtype=float)
    w2 = float(w @ w)
    if not (math.isfinite(w2) and w2 > 0.0):
        raise ValueError(f'omega_hill must be finite and nonzero, got {list(w)}')
    projection = (w @ np.asarray(x_g, dtype=float)) / w2 * w  # (w'x / |w|) w / |w|
    return float(projection @ cw_accel(x_g, v_g, n))  # eq 15


# --------------------------------------------------------------------------------------------------
# Closed forms for a constant spin vector, eq 10-19

def spin_angles(omega_hill):
    """(|omega|, psi_omega, theta_omega) of seed 000 eq 10 / Fig. 10.

    omega = |omega| [cos psi sin theta, sin psi, cos psi cos theta]: psi in [-pi/2, pi/2] is the
    elevation out of the hill x-z plane, theta the azimuth from +z toward +x. For psi = +-pi/2
    theta is arbitrary and returned as 0.
    """
    w = np.asarray(omega_hill, dtype=float)
    rate = float(np.linalg.norm(w))
    if not (math.isfinite(rate) and rate > 0.0):
        raise ValueError(f'omega_hill must be finite and nonzero, got {list(w)}')
    in_plane = math.hypot(w[0], w[2])
    psi = math.atan2(w[1], in_plane)  # atan2, not asin: exact near psi = +-pi/2
    theta = math.atan2(w[0], w[2]) if in_plane > 0.0 else 0.0
    return rate, psi, theta


def grasp_point_closed_form(omega_hill, x_norm_m, xi_rad, phi_sign):
    """Grasp point and velocity at phi_omega = phi_sign * pi/2 for a constant spin, seed 000 eq 12, 18-19.

    With phi = +pi/2 this is eq 18a / 19a, with phi = -pi/2 eq 18b / 19b:

    .. math:: x_{gt} = |x_g| [\\sin\\theta\\cos(\\psi \\pm \\xi), \\sin(\\psi \\pm \\xi),
              \\cos\\theta\\cos(\\psi \\pm \\xi)]

    .. math:: v_{gt} = \\omega \\times x_{gt} = \\pm|\\omega||x_g|\\sin\\xi [-\\cos\\theta, 0, \\sin\\theta]

    These are the two points of the circle of half-angle xi about omega where the y-velocity
    vanishes (eq 14, case b).

    Args:
        omega_hill: spin vector in hill [rad/s]. For velocities relative to the rotating hill frame
            pass the rate relative to hill, omega^H - Omega^H (module doc).
        x_norm_m: distance of the grasp point from the centre of mass |x_g| [m], > 0.
        xi_rad: angle between omega and x_g, xi_omega [rad] in [0, pi].
        phi_sign: +1 or -1.

    Returns:
        (x_gt [m], v_gt [m/s]) in hill.
    """
    if phi_sign not in (1, -1):
        raise ValueError(f'phi_sign must be +1 or -1, got {phi_sign}')
    if not (math.isfinite(x_norm_m) and x_norm_m > 0.0):
        raise ValueError(f'x_norm_m must be finite and positive, got {x_norm_m}')
    if not (0.0 <= xi_rad <= math.pi):
        raise ValueError(f'xi_rad must be in [0, pi], got {xi_rad}')
    rate, psi, theta = spin_angles(omega_hill)
    a = psi + phi_sign * xi_rad
    x_gt = x_norm_m * np.array((math.sin(theta) * math.cos(a), math.sin(a),
                                math.cos(theta) * math.cos(a)))  # eq 18a / 18b
    v_gt = phi_sign * rate * x_norm_m * math.sin(xi_rad) * np.array(
        (-math.cos(theta), 0.0, math.sin(theta)))  # eq 19a / 19b
    return x_gt, v_gt


def convex_grasp_closed_form(omega_hill, x_norm_m, xi_rad):
    """The grasp state selected by the safe convex condition for a constant spin, seed 000 eq 17-19.

    By eq 17 the sign of eq 15 is that of phi_sign cos(xi) (n << |omega|): angle xi < 90 deg takes
    phi = +pi/2 (eq 18a, 19a), xi > 90 deg phi = -pi/2 (eq 18b, 19b). At xi = 90 deg (and for a
    spin along +-y, psi = +-pi/2) eq 17 is zero and neither choice is convex: ValueError.

    Returns:
        (x_gt [m], v_gt [m/s]) in hill.
    """
    _, psi, _ = spin_angles(omega_hill)
    c = math.cos(xi_rad) * math.cos(psi)
    if abs(c) < 1e-12:
        raise ValueError(f'no convex grasp: eq 17 vanishes (xi_rad {xi_rad}, psi {psi} rad)')
    return grasp_point_closed_form(omega_hill, x_norm_m, xi_rad, 1 if c > 0.0 else -1)


def convex_condition_closed_form(omega_hill, x_norm_m, xi_rad, phi_sign, n):
    """Seed 000 eq 16: eq 15 evaluated at the closed-form grasp state of phi = phi_sign * pi/2.

    The velocity is taken as omega x x_gt (eq 19) with omega the argument. Misprint: eq 16's second
    term prints cos(psi) where the y-projection of the spin axis gives sin(psi):
    -n^2 |x|^2 cos(xi) sin(psi +- xi) sin(psi) (test_seed000_eq16_equals_eq15_at_closed_form).
    """
    rate, psi, theta = spin_angles(omega_hill)
    s = phi_sign
    x2 = x_norm_m * x_norm_m
    cx, sx, cp = math.cos(xi_rad), math.sin(xi_rad), math.cos(psi)
    return (s * 2.0 * n * rate * x2 * sx * cx * cp
            - n * n * x2 * cx * math.sin(psi + s * xi_rad) * math.sin(psi)  # eq 16 corrected
            + 3.0 * n * n * x2 * cx * math.cos(psi + s * xi_rad) * cp * math.cos(theta) ** 2)


# --------------------------------------------------------------------------------------------------
# General search, eq 13-15

def _point_source(prediction_or_callable, x_grasp_body):
    """A function times (N,) -> (x_hill, v_hill, omega_hill), each (N, 3), of the grasp point."""
    if hasattr(prediction_or_callable, 'track'):
        pred = prediction_or_callable
        if x_grasp_body is None:
            raise ValueError('x_grasp_body is required with a prediction object')
        x_b = np.asarray(x_grasp_body, dtype=float)

        def source(times):
            track = pred.track(x_b, times)
            return track.r_hill, track.v_hill, track.omega_hill
        return source
    if callable(prediction_or_callable):
        f = prediction_or_callable

        def source(times):
            rows = [f(t) for t in np.atleast_1d(times)]
            return tuple(np.array([row[k] for row in rows], dtype=float) for k in range(3))
        return source
    raise TypeError('prediction_or_callable must have track(x_body, times) (a MotionPrediction) or be a '
                    f'callable t -> (x_hill, v_hill, omega_hill); got {type(prediction_or_callable)}')


def grasp_candidates(prediction_or_callable, x_grasp_body, t_start, t_end, n, sample_step_s=None,
                     xtol_s=1e-12):
    """Grasp instants in [t_start, t_end] with zero hill y-velocity, and their eq 15 convexity.

    Seed 000 eq 13: e_y' v_g^H = 0. Instead of the constant-spin solution eq 14 (phi = +-pi/2) the
    y-velocity is sampled from the prediction (eq 8-9, so a changing spin axis and the hill
    rotation are included), its sign changes are bracketed and each root is refined with
    scipy.optimize.brentq. Each root is tested with the safe convex condition eq 15
    (convex_condition_value, omega = omega_hill of eq 6). A rigid rotation gives two roots per
    turn relative to hill, one convex and one not (eq 17). Roots where v_y only touches zero
    without changing sign are not found; a spin along +-y (eq 14 case a, v_y = 0 throughout) gives
    no sign change and so no candidates -- seed 000 section 4.4 (b) excludes that case anyway.

    Args:
        prediction_or_callable: either a flyby_estimation.target_motion.MotionPrediction (e.g.
            TargetAttitudeFilter.prediction(t_end); anything with its ``track(x_body, times)``) or a
            callable t -> (x_hill [m], v_hill [m/s] relative to hill, omega_hill [rad/s]) of the
            grasp point itself.
        x_grasp_body: grasp point in body axes [m]; ignored (may be None) with a callable.
        t_start, t_end: search interval [s], t_start < t_end, inside the prediction's interval.
        n: orbital mean motion Omega_t [rad/s] for eq 15 (> 0 for any candidate to be convex).
        sample_step_s: grid step [s]; default 1/72 of a turn at the rate relative to hill at
            t_start (5 deg), capped to the interval length.
        xtol_s: brentq absolute time tolerance [s].

    Returns:
        list of GraspCandidate in time order.
    """
    if not (math.isfinite(t_start) and math.isfinite(t_end) and t_end > t_start):
        raise ValueError(f'need finite t_start < t_end, got t_start {t_start} s, t_end {t_end} s')
    if not (math.isfinite(n) and n >= 0.0):
        raise ValueError(f'n must be finite and >= 0 [rad/s], got {n}')
    source = _point_source(prediction_or_callable, x_grasp_body)
    span = t_end - t_start
    if sample_step_s is None:
        w0 = source(t_start)[2][0]
        rate_rel = float(np.linalg.norm(w0 - np.array((0.0, -n, 0.0))))
        sample_step_s = 2.0 * math.pi / rate_rel / 72.0 if rate_rel > 0.0 else span
    if not (math.isfinite(sample_step_s) and sample_step_s > 0.0):
        raise ValueError(f'sample_step_s must be finite and positive, got {sample_step_s}')
    steps = max(1, math.ceil(span / sample_step_s))
    grid = np.linspace(t_start, t_end, steps + 1)

    def v_y(t):
        return float(source(t)[1][0] @ _E_Y)  # eq 13

    v_grid = source(grid)[1]
    vy = v_grid @ _E_Y
    speed_scale = float(np.linalg.norm(v_grid, axis=1).max())
    sign = np.where(np.abs(vy) <= 1e-12 * speed_scale, 0, np.sign(vy)).astype(int)
    roots = []
    for i in range(steps + 1):
        if sign[i] == 0:
            # A sample on a root counts once; a run of zero samples (v_y = 0 identically, eq 14
            # case a) has no isolated root and is skipped.
            if (i == 0 or sign[i - 1] != 0) and (i == steps or sign[i + 1] != 0):
                roots.append(float(grid[i]))
        elif i < steps and sign[i] * sign[i + 1] < 0:
            roots.append(float(brentq(v_y, grid[i], grid[i + 1], xtol=xtol_s)))

    out = []
    for t in roots:
        x_g, v_g, w = (a[0] for a in source(t))
        value = convex_condition_value(w, x_g, v_g, n)  # eq 15
        out.append(GraspCandidate(t_grasp=t, x_g=x_g, v_g=v_g, omega_hill=w,
                                  convex_value=value, convex=value > 0.0))
    return out


# --------------------------------------------------------------------------------------------------
# Fly-by target and initial points, eq 20-23

def flyby_target_point(x_g, v_g, offset_m):
    """Fly-by approach target point X_Ft, V_Ft, seed 000 eq 20-21.

    .. math:: X_{Ft} = (1 + \\delta r / |x_g|)\\, x_{gt}, \\quad V_{Ft} = (1 + \\delta r / |x_g|)\\, v_{gt}

    The offset is radial: the point moves delta r outward from the target's centre of mass along
    x_g, and its velocity is that of the body-fixed point there (the rigid rotation scales with
    the radius). The paper's |x_g^B| equals |x_g^H|.

    Args:
        x_g: grasp point in hill [m], nonzero.
        v_g: grasp point velocity relative to hill [m/s].
        offset_m: delta r [m]; 1 + delta r / |x_g| must stay positive.

    Returns:
        (X_Ft [m], V_Ft [m/s]) in hill.
    """
    x = np.asarray(x_g, dtype=float)
    v = np.asarray(v_g, dtype=float)
    r = float(np.linalg.norm(x))
    if not (math.isfinite(r) and r > 0.0):
        raise ValueError(f'x_g must be finite and nonzero, got {list(x)}')
    if not math.isfinite(offset_m):
        raise ValueError(f'offset_m must be finite, got {offset_m}')
    k = 1.0 + offset_m / r
    if k <= 0.0:
        raise ValueError(f'offset_m {offset_m} m would put the target point through the centre of mass '
                         f'(|x_g| = {r} m)')
    return k * x, k * v  # eq 20, eq 21


def docking_axis(x_port_body, boxes):
    """The docking port's outward direction (3,), body axes: the outward normal of the target's surface at the port
    (boxes: (center_m, size_m) pairs, body axes). A ValueError names the port when it is not on the surface."""
    axis = outward_normal(x_port_body, boxes)
    if axis is None:
        raise ValueError(f'the docking port (target.grasp_point_body_m) {np.round(x_port_body, 4).tolist()} m is not '
                         'on the outer surface of target.geometry: its outward direction is undefined')
    return axis


def capture_target_body(method, x_grasp_body, offset_m, boxes):
    """The body point [m, body axes] the chaser's centre of mass must be at, moving with the body, at the grasp
    time (DESIGN §10): the synchronized approach's final point, the port plus offset_m along its outward direction
    (``docking_axis``: the line it docks along, normal to the face); for the fly-by and the optimal approach
    seed 000 eq 20, the grasp point moved offset_m outward from the centre of mass (their velocities, eq 21, are
    the body point's)."""
    x = np.asarray(x_grasp_body, dtype=float)
    if method == 'sync':
        return x + offset_m * docking_axis(x, boxes)
    return (1.0 + offset_m / float(np.linalg.norm(x))) * x  # eq 20


def offset_of_flyby_target(x_ft, x_grasp_body):
    """The offset delta r [m] of a fly-by target point X_Ft of the grasp point x_grasp_body (body axes).

    Eq 20 inverted: X_Ft = (1 + delta r / |x_g|) x_g gives |X_Ft| = |x_g| + delta r, and |x_g| is the
    body-frame |x_grasp_body| at any attitude.
    """
    return float(np.linalg.norm(x_ft)) - float(np.linalg.norm(x_grasp_body))


def flyby_initial_point(x_ft, v_ft, duration_s, n):
    """Fly-by approach initial point X_Fi, V_Fi, seed 000 eq 23.

    [X_Fi; V_Fi] = Phi(t_f - t_i)^-1 [X_Ft; V_Ft] = Phi(t_i - t_f) [X_Ft; V_Ft], the CW coast of eq 22
    (flyby_sim.dynamics.orbital.cw_coast) run backward by the fly-by duration t_f - t_i.

    Args:
        x_ft, v_ft: fly-by target point [m], [m/s] (hill, relative velocity).
        duration_s: t_f - t_i [s], >= 0.
        n: orbital mean motion [rad/s], > 0.

    Returns:
        (X_Fi [m], V_Fi [m/s]) in hill.
    """
    if not (math.isfinite(duration_s) and duration_s >= 0.0):
        raise ValueError(f'duration_s must be finite and >= 0, got {duration_s}')
    if not (math.isfinite(n) and n > 0.0):
        raise ValueError(f'n must be finite and positive [rad/s], got {n}')
    state_i = cw_coast(x_ft, v_ft, -duration_s, n)  # eq 23
    return state_i[:3], state_i[3:]


def refine_grasp(prediction, x_grasp_body, t_grasp_prev, n, t_latest=None):
    """The convex grasp instant nearest t_grasp_prev according to a newer prediction, or None; not
    later than t_latest (default: the prediction's end).

    Re-aiming during the trajectory-adjusting phase (seed 000 section 4.6: the adjusting maneuvers
    absorb "timing errors due to ... motion estimation"): the same turn's convex root (eq 13-15),
    searched within 0.4 of a turn (relative to hill) either side of the previous grasp time and
    inside the prediction's interval. Convex roots are a turn apart, so the window holds one.

    Without a convex root there, the planned root itself is followed (the root within
    _FOLLOW_TURNS of a turn of t_grasp_prev): the planner found it convex, and a newer estimate can
    flip the sign of eq 15 where its value is near zero (docs/planner.md, "How these rules were found"). The arc
    through it is checked for passive safety before it is flown (passive_safety.check_passage in
    flyby_guidance.guidance_core), as every re-aimed arc is.
    """
    omega = prediction.state(min(max(t_grasp_prev, prediction.t0), prediction.t_end)).omega_hill
    rate_rel = float(np.linalg.norm(np.asarray(omega) - np.array((0.0, -n, 0.0))))
    if not rate_rel > 0.0:
        return None
    half = 0.4 * 2.0 * math.pi / rate_rel
    t_end = prediction.t_end if t_latest is None else min(t_latest, prediction.t_end)
    lo, hi = max(t_grasp_prev - half, prediction.t0), min(t_grasp_prev + half, t_end)
    if not hi > lo:
        return None
    roots = grasp_candidates(prediction, x_grasp_body, lo, hi, n)
    nearest = [c for c in roots if c.convex] or [
        c for c in roots if abs(c.t_grasp - t_grasp_prev) <= _FOLLOW_TURNS * 2.0 * math.pi / rate_rel]
    return min(nearest, key=lambda c: abs(c.t_grasp - t_grasp_prev)) if nearest else None


def grasp_from_attitude(q_hill_from_body, omega_body, x_grasp_body, n):
    """Grasp point x_g [m] and its velocity relative to hill v_g [m/s] of a target in the given attitude (eq 8-9)."""
    x_g, v_g, _ = body_point_in_hill(quat_to_matrix(q_hill_from_body), omega_body, x_grasp_body, n)
    return x_g, v_g


def flyby_target_from_attitude(q_hill_from_body, omega_body, x_grasp_body, offset_m, n):
    """X_Ft, V_Ft (eq 20-21) of the grasp point of a target in the given attitude and body rate (eq 8-9).

    With the *true* attitude at the grasp time this is the point the chaser should truly be at: the
    reference of the capture position and velocity errors (DESIGN §7).
    """
    return flyby_target_point(*grasp_from_attitude(q_hill_from_body, omega_body, x_grasp_body, n), offset_m)
