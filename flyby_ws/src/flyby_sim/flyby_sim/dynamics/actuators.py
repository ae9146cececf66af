"""Body-fixed thrusters of the six-degree-of-freedom chaser: layout, wrench allocation, execution, fuel.

A thruster i sits at r_i (chaser_body, from the centre of mass [m]) and pushes the chaser along the unit
direction d_i (chaser_body; its exhaust leaves along -d_i) with a thrust 0 <= f_i <= f_max_i [N]. The
thrusts make the body wrench

.. math::

    \\begin{bmatrix} F \\\\ M \\end{bmatrix} = B f, \\qquad
    B = \\begin{bmatrix} d_1 & \\cdots & d_N \\\\ r_1 \\times d_1 & \\cdots & r_N \\times d_N \\end{bmatrix}

(force [N] over torque about the CoM [N m], chaser_body axes; the torque is seed 001 eq 3's M_c, the force
eq 2's F_c). A layout gives full six-axis authority when B has rank 6 and its columns span R^6 positively
(every wrench is B f for some f >= 0), i.e. when some strictly positive f has B f = 0.

Fuel: a thruster of thrust f burns f / (Isp g0) kg/s, so its propellant is its impulse over Isp g0,
whatever the mass; the rocket equation (``propulsion``) follows from the same flow and gives the delta-v
that fuel buys.
"""

import math
from typing import NamedTuple

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, linprog, milp

from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2
from flyby_sim.dynamics.rotation import quat_rotate, random_small_rotation

# HiGHS's own feasibility tolerances (default 1e-7) are tighter here so that an achievable wrench is
# reproduced to about 1e-12 N; 1e-10 is the smallest value HiGHS accepts.
_HIGHS_OPTIONS = {'primal_feasibility_tolerance': 1e-10, 'dual_feasibility_tolerance': 1e-10}


class ThrusterLayout:
    """Positions, force directions and limits of N body-fixed thrusters (validated here)."""

    def __init__(self, positions_body_m, force_directions_body, max_thrust_n, isp_s, min_impulse_bit_n_s):
        """positions_body_m (N, 3) from the CoM [m]; force_directions_body (N, 3), the direction each pushes
        the chaser (any nonzero length, normalized here); max_thrust_n one value or N values [N]; isp_s [s];
        min_impulse_bit_n_s, the smallest impulse one firing delivers [N s] (0: none)."""
        positions = np.atleast_2d(np.asarray(positions_body_m, dtype=float))
        directions = np.atleast_2d(np.asarray(force_directions_body, dtype=float))
        if positions.ndim != 2 or positions.shape[1] != 3 or not np.all(np.isfinite(positions)):
            raise ValueError(f'positions_body_m must be N finite 3-vectors, got {positions_body_m!r}')
        if directions.shape != positions.shape or not np.all(np.isfinite(directions)):
            raise ValueError(f'force_directions_body must be {positions.shape[0]} finite 3-vectors, '
                             f'got {force_directions_body!r}')
        norms = np.linalg.norm(directions, axis=1)
        if np.any(norms == 0.0):
            raise ValueError(f'force_directions_body has a zero direction: {directions.tolist()}')
        n = positions.shape[0]
        thrust = np.asarray(max_thrust_n, dtype=float)
        thrust = np.full(n, float(thrust)) if thrust.ndim == 0 else thrust
        if thrust.shape != (n,) or not np.all(np.isfinite(thrust)) or np.any(thrust <= 0.0):
            raise ValueError(f'max_thrust_n must be one finite value > 0 or {n} of them, got {max_thrust_n!r}')
        require_positive('isp_s', isp_s)
        require_positive('min_impulse_bit_n_s', min_impulse_bit_n_s, allow_zero=True)
        self.positions_body_m = positions
        self.force_directions_body = directions / norms[:, None]
        self.max_thrust_n = thrust
        self.isp_s = float(isp_s)
        self.min_impulse_bit_n_s = float(min_impulse_bit_n_s)
        self.positions_body_m.flags.writeable = False
        self.force_directions_body.flags.writeable = False
        # B (6, N): force directions over their torques r_i x d_i about the CoM (module doc); read-only, built once
        # (the plant allocates with it at every wrench command).
        self.wrench_matrix = wrench_matrix(self.positions_body_m, self.force_directions_body)
        self.wrench_matrix.flags.writeable = False

    @property
    def count(self):
        """Number of thrusters N."""
        return self.positions_body_m.shape[0]

    @property
    def exhaust_velocity_mps(self):
        """Isp g0 [m/s]."""
        return self.isp_s * STANDARD_GRAVITY_M_S2

    def subset(self, allowed):
        """The ThrusterLayout of the thrusters where allowed ((N,) bool) is True, in the same order."""
        return ThrusterLayout(self.positions_body_m[allowed], self.force_directions_body[allowed],
                              self.max_thrust_n[allowed], self.isp_s, self.min_impulse_bit_n_s)


def wrench_matrix(positions_body_m, force_directions_body):
    """B (6, N) of thrusters at positions_body_m (N, 3) pushing along unit force_directions_body (N, 3)."""
    d = np.asarray(force_directions_body, dtype=float)
    return np.vstack((d.T, np.cross(np.asarray(positions_body_m, dtype=float), d).T))


def default_thruster_layout(max_thrust_n=10.0, isp_s=220.0, min_impulse_bit_n_s=0.01, face_m=0.3,
                            lever_arm_m=0.25):
    """Twelve thrusters on a cube-like 100 kg chaser: two pairs per body axis giving full six-axis authority.

    For each axis k, two thrusters push along +k from the -k face and two along -k from the +k face; the
    two of a pair sit at +-lever_arm_m along the next axis (x pairs along y, y along z, z along x), so
    firing a pair together gives a pure force and firing one of each direction crosswise a pure couple
    (x thrusters give torque about z, y about x, z about y). The defaults (10 N, 220 s, 0.01 N s) are
    scenarios/paper_flyby.yaml's thruster figures; every thruster lies within the 0.5 m envelope.
    """
    positions, directions = [], []
    for k in range(3):
        e_k, e_next = np.eye(3)[k], np.eye(3)[(k + 1) % 3]
        for sign in (1.0, -1.0):  # push along +k from the -k face, then along -k from the +k face
            for side in (1.0, -1.0):
                positions.append(-sign * face_m * e_k + side * lever_arm_m * e_next)
                directions.append(sign * e_k)
    return ThrusterLayout(positions, directions, max_thrust_n, isp_s, min_impulse_bit_n_s)


def plume_free_thrusters(layout, toward_body, cone_half_angle_deg):
    """(N,) bool: the thrusters whose exhaust (opposite their force direction) stays outside a cone of the given
    half-angle about toward_body (chaser_body: the direction to what the plume must not hit, e.g. a captured target's
    CoM), the ones a tug may fire without impinging on what it holds (seed 004 §2.3: direction-limited thrusters)."""
    toward = np.asarray(toward_body, dtype=float)
    norm = float(np.linalg.norm(toward))
    if toward.shape != (3,) or not math.isfinite(norm) or norm == 0.0:
        raise ValueError(f'toward_body must be a finite nonzero 3-vector, got {toward_body!r}')
    exhaust = -layout.force_directions_body
    return exhaust @ (toward / norm) < math.cos(math.radians(cone_half_angle_deg))


def is_positively_spanning(wrench_matrix_):
    """True if the columns of a (6, N) wrench matrix have rank 6 and span R^6 with non-negative weights.

    Positive spanning holds iff the columns span R^6 and some f >= 1 (strictly positive, scaled) has
    B f = 0; the second is a feasibility linear program (HiGHS).
    """
    b = np.asarray(wrench_matrix_, dtype=float)
    if b.ndim != 2 or b.shape[0] != 6:
        raise ValueError(f'wrench matrix must be 6 x N, got shape {b.shape}')
    if np.linalg.matrix_rank(b) < 6:
        return False
    n = b.shape[1]
    result = linprog(np.zeros(n), A_eq=b, b_eq=np.zeros(6), bounds=[(1.0, None)] * n, method='highs')
    return result.status == 0


class Allocation(NamedTuple):
    """Thrusts for a commanded body wrench, what they deliver and what they cannot (saturation)."""

    thrusts_n: np.ndarray  # (N,), 0 <= f <= max_thrust_n
    wrench_commanded_body: np.ndarray  # (6,): force [N], torque [N m]
    wrench_delivered_body: np.ndarray  # (6,): B f
    wrench_undelivered_body: np.ndarray  # (6,): commanded - delivered; zero unless saturated
    saturated: bool  # the command lies outside what the layout can deliver

    @property
    def total_thrust_n(self):
        """Sum of the thrusts [N] (what the allocation minimizes)."""
        return float(self.thrusts_n.sum())


def allocate_wrench(layout, force_body_n, torque_body_n_m):
    """Non-negative bounded thrusts delivering a commanded body force and torque with the least total thrust.

    Solved as linear programs by scipy.optimize.linprog (HiGHS); why an LP: thrusts are non-negative and
    bounded and the fuel is linear in them (each thruster's flow is f_i / (Isp g0)), so minimum fuel with
    the wrench met exactly is an LP whose optimum is exact at a vertex; a least-squares solver (lsq_linear,
    nnls) would meet the wrench but not minimize fuel, and it spreads thrust over opposing thrusters.

    1. Achievable command:  min sum f  s.t.  B f = w,  0 <= f <= f_max.
    2. If (1) is infeasible, the closest wrench the thrusters can make, residual in the 1-norm with the
       torque rows divided by the layout's mean lever arm L (so both are in newtons):
       rho = min sum |W (B f - w)| over 0 <= f <= f_max (slacks s+, s- >= 0 with B f - w = s+ - s-), then the
       least total thrust among those with sum |W (B f - w)| <= rho (the 1-norm has ties, e.g. force traded
       for torque, and the first program may fire opposing thrusters where it costs nothing). The second
       program meets rho to HiGHS's 1e-10 tolerance; should round-off make it infeasible, the first
       program's thrusts are kept.
    The returned wrench_undelivered_body is w - B f, nonzero only in the saturated case (at the 1e-12 level
    otherwise).

    Args:
        layout: ThrusterLayout.
        force_body_n: commanded force [N], chaser_body axes.
        torque_body_n_m: commanded torque about the CoM [N m], chaser_body axes.
    """
    force = np.asarray(force_body_n, dtype=float)
    torque = np.asarray(torque_body_n_m, dtype=float)
    if force.shape != (3,) or not np.all(np.isfinite(force)):
        raise ValueError(f'force_body_n must be 3 finite values [N], got {force_body_n!r}')
    if torque.shape != (3,) or not np.all(np.isfinite(torque)):
        raise ValueError(f'torque_body_n_m must be 3 finite values [N m], got {torque_body_n_m!r}')
    w = np.concatenate((force, torque))
    b = layout.wrench_matrix
    n = layout.count
    bounds = [(0.0, f_max) for f_max in layout.max_thrust_n.tolist()]
    exact = linprog(np.ones(n), A_eq=b, b_eq=w, bounds=bounds, method='highs', options=_HIGHS_OPTIONS)
    saturated = exact.status != 0
    if not saturated:
        thrusts = exact.x
    else:
        thrusts = _closest_wrench_thrusts(b, w, bounds)
    thrusts = np.clip(thrusts, 0.0, layout.max_thrust_n)  # the solver's 1e-10 bound tolerance
    delivered = b @ thrusts
    return Allocation(thrusts, w, delivered, w - delivered, saturated)


def _closest_wrench_thrusts(b, w, bounds):
    """Thrusts of step 2 of allocate_wrench: least weighted 1-norm wrench residual, then least thrust."""
    n = b.shape[1]
    lever_m = float(np.mean(np.linalg.norm(b[3:], axis=0)))
    weight = np.concatenate((np.ones(3), np.full(3, 1.0 / lever_m if lever_m > 0.0 else 1.0)))
    a_eq = np.hstack((b, -np.eye(6), np.eye(6)))  # B f - s+ + s- = w
    slack_bounds = [(0.0, None)] * 12
    residual_cost = np.concatenate((np.zeros(n), weight, weight))
    closest = linprog(residual_cost, A_eq=a_eq, b_eq=w, bounds=bounds + slack_bounds, method='highs',
                      options=_HIGHS_OPTIONS)
    if closest.status != 0:
        raise RuntimeError(f'thrust allocation of wrench {w.tolist()} failed: {closest.message}')
    least_thrust = linprog(np.concatenate((np.ones(n), np.zeros(12))), A_ub=residual_cost[None, :],
                           b_ub=[closest.fun], A_eq=a_eq, b_eq=w, bounds=bounds + slack_bounds,
                           method='highs', options=_HIGHS_OPTIONS)
    return (least_thrust.x if least_thrust.status == 0 else closest.x)[:n]


class ThrusterErrors(NamedTuple):
    """Execution errors of each thruster: thrust scale factor and its actual force direction."""

    magnitude_factors: np.ndarray  # (N,): actual thrust = factor x commanded
    force_directions_body: np.ndarray  # (N, 3): actual unit directions (misaligned)


def draw_thruster_errors(layout, rng, magnitude_sigma, misalignment_sigma_rad):
    """Per-thruster execution errors drawn from rng (a numpy Generator; no global random state).

    Thruster by thruster: one standard normal for the magnitude (factor 1 + magnitude_sigma z), then three
    for a small rotation of its force direction (rotation vector N(0, misalignment_sigma_rad^2) per axis,
    ``rotation.random_small_rotation``; the component along the direction leaves it unchanged, so the
    misalignment is N(0, sigma^2) about each perpendicular axis). Exactly 4 N draws, whatever the sigmas.
    """
    require_positive('magnitude_sigma', magnitude_sigma, allow_zero=True)
    require_positive('misalignment_sigma_rad', misalignment_sigma_rad, allow_zero=True)
    factors, directions = [], []
    for d in layout.force_directions_body:
        factors.append(1.0 + magnitude_sigma * rng.standard_normal())
        directions.append(quat_rotate(random_small_rotation(rng, misalignment_sigma_rad), d))
    return ThrusterErrors(np.array(factors), np.array(directions))


class Firing(NamedTuple):
    """What the thrusters actually did over one hold period."""

    thrusts_n: np.ndarray  # (N,) actual thrust of each thruster (errors included)
    force_body_n: np.ndarray  # (3,) actual force, chaser_body axes
    torque_body_n_m: np.ndarray  # (3,) actual torque about the CoM, chaser_body axes
    impulses_n_s: np.ndarray  # (N,) thrust x period
    fuel_kg: float  # sum of impulses / (Isp g0)
    below_minimum_impulse: np.ndarray  # (N,) bool: commanded but not fired (impulse under the minimum bit)


def fire(layout, thrusts_n, period_s, errors=None):
    """The Firing of commanded thrusts held for period_s [s]: thrusts whose impulse over the period is below
    the minimum impulse bit are not fired (reported), the rest act with the execution errors (if given).

    Fuel per thruster impulse: m_fuel = f dt / (Isp g0), the mass flow that also underlies the rocket
    equation (module doc).
    """
    if not (math.isfinite(period_s) and period_s > 0.0):
        raise ValueError(f'period_s must be finite and > 0, got {period_s!r}')
    f = np.asarray(thrusts_n, dtype=float)
    if f.shape != (layout.count,) or not np.all(np.isfinite(f)):
        raise ValueError(f'thrusts_n must be {layout.count} finite values [N], got {thrusts_n!r}')
    if np.any(f < 0.0) or np.any(f > layout.max_thrust_n):
        raise ValueError(f'thrusts_n {f.tolist()} outside [0, max_thrust_n {layout.max_thrust_n.tolist()}]')
    too_short = (f > 0.0) & (f * period_s < layout.min_impulse_bit_n_s)
    f = np.where(too_short, 0.0, f)
    directions = layout.force_directions_body
    if errors is not None:
        f = f * errors.magnitude_factors
        directions = errors.force_directions_body
    wrench = wrench_matrix(layout.positions_body_m, directions) @ f
    impulses = f * period_s
    return Firing(f, wrench[:3], wrench[3:], impulses, float(impulses.sum()) / layout.exhaust_velocity_mps,
                  too_short)


class DirectionAllocation(NamedTuple):
    """Thrusts giving the largest force along a body direction with no torque and nothing across it."""

    thrusts_n: np.ndarray  # (N,), 0 <= f <= max_thrust_n
    force_n: float  # the force delivered along the direction [N]
    force_body_n: np.ndarray  # (3,) B f's force (force_n times the unit direction, to the LP's tolerance)
    torque_body_n_m: np.ndarray  # (3,) B f's torque (zero to the LP's tolerance)

    @property
    def total_thrust_n(self):
        """Sum of the thrusts [N]: the propellant flow is total_thrust_n / (Isp g0)."""
        return float(self.thrusts_n.sum())


def allocate_max_force(layout, direction_body):
    """The largest pure force the thrusters give along a body direction, with the least total thrust.

    How an impulsive delta-v is executed at whatever attitude the chaser holds: its direction in chaser_body
    is pushed along as hard as the layout allows while the torque and the force across it stay zero. Two
    linear programs (scipy.optimize.linprog, HiGHS), u the unit direction:

    1. max s  s.t.  B f = s [u; 0],  0 <= f <= f_max,  s >= 0   (the force along u; bounded since f is)
    2. min sum f  s.t.  B f = s* (1 - 1e-9) [u; 0],  0 <= f <= f_max   (the least propellant flow for it; the
       first program's vertex may fire opposing thrusters where it costs nothing, e.g. with a redundant
       layout; the 1e-9 keeps it feasible after round-off, else the first program's thrusts are kept)

    A positively spanning layout gives s* > 0 along every direction.

    Args:
        layout: ThrusterLayout.
        direction_body: the force direction in chaser_body (any nonzero length).
    """
    u = np.asarray(direction_body, dtype=float)
    norm = float(np.linalg.norm(u)) if u.shape == (3,) else math.nan
    if not (math.isfinite(norm) and norm > 0.0):
        raise ValueError(f'direction_body must be a finite nonzero 3-vector, got {direction_body!r}')
    u = u / norm
    b = layout.wrench_matrix
    n = layout.count
    wrench_u = np.concatenate((u, np.zeros(3)))
    bounds = [(0.0, f_max) for f_max in layout.max_thrust_n.tolist()]
    largest = linprog(np.concatenate((np.zeros(n), [-1.0])), A_eq=np.hstack((b, -wrench_u[:, None])),
                      b_eq=np.zeros(6), bounds=bounds + [(0.0, None)], method='highs', options=_HIGHS_OPTIONS)
    if largest.status != 0 or -largest.fun <= 0.0:
        raise ValueError(f'the thrusters give no pure force along {u.tolist()} (layout not positively spanning): '
                         f'{largest.message}')
    thrusts = largest.x[:n]
    least = linprog(np.ones(n), A_eq=b, b_eq=(-largest.fun * (1.0 - 1e-9)) * wrench_u, bounds=bounds,
                    method='highs', options=_HIGHS_OPTIONS)
    if least.status == 0:
        thrusts = least.x
    thrusts = np.clip(thrusts, 0.0, layout.max_thrust_n)
    wrench = b @ thrusts
    return DirectionAllocation(thrusts, float(wrench[:3] @ u), wrench[:3], wrench[3:])


class BurnPlan(NamedTuple):
    """A delta-v executed by the thrusters of a DirectionAllocation held over the burn (nominal, no errors)."""

    allocation: DirectionAllocation
    duration_s: float
    fuel_kg: float
    mass_flow_kg_s: float  # total_thrust_n / (Isp g0)
    minimum_impulse_allocated: bool = False  # re-allocated so every firing thruster gives the minimum impulse bit


# Relative margin on the minimum-impulse thrust floor, so that f T >= bit survives the solvers' round-off.
_MINIMUM_IMPULSE_MARGIN = 1e-7
# allocate_force_with_minimum_impulse drops force components below this fraction of the force.
_NEGLIGIBLE_COMPONENT = 1e-6
# The force of a burn too short for any allocation above the floor is halved at most this many times.
_MAX_FORCE_HALVINGS = 20


def plan_burn(layout, direction_body, dv_mps, mass_kg, max_force_n=None):
    """The finite burn delivering a delta-v of dv_mps [m/s] along direction_body from mass mass_kg [kg].

    max_force_n: the force to push with, if the layout gives that much along the direction (its largest
    pure force scaled down, the same thrusters firing); None: the largest. The mission passes the
    point-mass chaser's thrust, which the navigation filter's burn model assumes (flyby_estimation.relative_nav).

    The force F along the direction comes with a propellant flow mdot = sum f / (Isp g0) (sum f >= F when
    thrusters not along the direction fire), so integral F / m dt = (F / mdot) ln(m0 / m1): the rocket equation
    with the effective exhaust velocity ve F / sum f. Fuel m0 (1 - exp(-dv sum f / (F ve))), duration
    fuel / mdot (``propulsion.fuel_for_delta_v_kg``).

    Minimum impulse bit: a thruster cannot give less than ``layout.min_impulse_bit_n_s`` per firing, and
    ``fire`` leaves one off whose thrust over the burn, f T, is below it. A small burn whose scaled allocation
    has such thrusters (a 0.3 mm/s trim of a 100 kg chaser is 0.03 N s in all, a component across the main
    axis a few mN s) would lose those components: the delta-v would miss by up to its whole size. Such a
    burn is re-allocated (``allocate_force_with_minimum_impulse``) with every firing thruster at least
    bit / T, the same force F along the direction for the same duration (an opposing pair takes up what is
    below the bit, at a little more propellant); if no allocation meets the floor (a burn shorter than the
    bit at the force allows), F is halved and the burn lengthened until one does.
    """
    require_positive('dv_mps', dv_mps)
    require_positive('mass_kg', mass_kg)
    allocation = allocate_max_force(layout, direction_body)
    if max_force_n is not None:
        require_positive('max_force_n', max_force_n)
        if max_force_n < allocation.force_n:
            scale = max_force_n / allocation.force_n
            allocation = DirectionAllocation(allocation.thrusts_n * scale, max_force_n,
                                             allocation.force_body_n * scale, allocation.torque_body_n_m * scale)
    plan = _burn_of(layout, allocation, dv_mps, mass_kg)
    bit = layout.min_impulse_bit_n_s
    f = plan.allocation.thrusts_n
    if not np.any((f > 0.0) & (f * plan.duration_s < bit)):
        return plan
    u = np.asarray(direction_body, dtype=float) / float(np.linalg.norm(direction_body))
    force_n = allocation.force_n
    s_max = float(layout.max_thrust_n.sum())
    for _ in range(_MAX_FORCE_HALVINGS):
        # The shortest duration any allocation of force_n can have (the largest flow): a floor bit / T for it
        # holds for whatever allocation is found.
        t_min = _burn_duration(force_n, s_max, dv_mps, mass_kg, layout.exhaust_velocity_mps)
        floor_n = bit / t_min * (1.0 + _MINIMUM_IMPULSE_MARGIN)
        floored = allocate_force_with_minimum_impulse(layout, force_n * u, floor_n)
        if floored is not None:
            return _burn_of(layout, floored, dv_mps, mass_kg)._replace(minimum_impulse_allocated=True)
        force_n *= 0.5
    return plan  # not reached for a positively spanning layout; fire() then reports what is below the bit


def _burn_duration(force_n, total_thrust_n, dv_mps, mass_kg, exhaust_velocity_mps):
    """Duration [s] of a burn of force_n along the delta-v from a flow total_thrust_n / ve (plan_burn)."""
    effective_exhaust_velocity = force_n * exhaust_velocity_mps / total_thrust_n
    fuel = -mass_kg * math.expm1(-dv_mps / effective_exhaust_velocity)
    return fuel / (total_thrust_n / exhaust_velocity_mps)


def _burn_of(layout, allocation, dv_mps, mass_kg):
    mass_flow = allocation.total_thrust_n / layout.exhaust_velocity_mps
    effective_exhaust_velocity = allocation.force_n / mass_flow
    fuel = -mass_kg * math.expm1(-dv_mps / effective_exhaust_velocity)
    return BurnPlan(allocation, fuel / mass_flow, fuel, mass_flow)


def allocate_force_with_minimum_impulse(layout, force_body_n, floor_n):
    """The least total thrust giving exactly the pure body force force_body_n [N] (no torque) with every
    firing thruster at floor_n [N] or more (0 < floor_n): a DirectionAllocation, or None if there is none.

    Each thrust is semi-continuous, f_i = 0 or floor_n <= f_i <= f_max_i (a thruster fires for the whole burn
    with at least its minimum impulse bit, or not at all), which a linear program cannot state: a mixed-integer
    linear program with one on/off variable z_i per thruster (the usual big-M form of a semi-continuous
    variable; H. P. Williams, "Model Building in Mathematical Programming", 5th ed., Wiley, 2013, ch. 9),

        min sum f  s.t.  B f = [F; 0],  floor_n z_i <= f_i <= f_max_i z_i,  z_i in {0, 1},

    solved by scipy.optimize.milp (HiGHS branch and bound; 10-30 ms for the 12 default thrusters on the loaded
    2-core machine, once per small burn). The thrusts are then polished by the linear program of the same problem
    with the on/off pattern fixed (f_i in [floor_n, f_max_i] or 0), so the force is met to HiGHS's 1e-10 rather
    than its 1e-6 MIP feasibility tolerance; for that, force components below 1e-6 of |F| are dropped first (a
    direction change below 1e-6 rad), which the MIP tolerance would take as met without an opposing pair.
    """
    force = np.asarray(force_body_n, dtype=float)
    if force.shape != (3,) or not np.all(np.isfinite(force)) or not np.any(force):
        raise ValueError(f'force_body_n must be 3 finite values, not all zero [N], got {force_body_n!r}')
    if not (math.isfinite(floor_n) and floor_n > 0.0):
        raise ValueError(f'floor_n must be finite and > 0, got {floor_n!r}')
    f_max = layout.max_thrust_n
    if np.all(floor_n > f_max):
        return None
    b = layout.wrench_matrix
    n = layout.count
    norm = float(np.linalg.norm(force))
    force = np.where(np.abs(force) < _NEGLIGIBLE_COMPONENT * norm, 0.0, force)
    wrench = np.concatenate((force, np.zeros(3)))
    eye = np.eye(n)
    constraints = [LinearConstraint(np.hstack((b, np.zeros((6, n)))), wrench, wrench),  # B f = [F; 0]
                   LinearConstraint(np.hstack((eye, -np.diag(f_max))), -np.inf, 0.0),  # f_i <= f_max z_i
                   LinearConstraint(np.hstack((eye, -floor_n * eye)), 0.0, np.inf)]  # f_i >= floor z_i
    result = milp(np.concatenate((np.ones(n), np.zeros(n))), constraints=constraints,
                  integrality=np.concatenate((np.zeros(n), np.ones(n))),
                  bounds=Bounds(np.zeros(2 * n), np.concatenate((f_max, np.ones(n)))),
                  options={'presolve': False})  # HiGHS prints on stdout where it repairs a presolved point
    if result.status != 0:
        return None
    on = result.x[n:] > 0.5
    bounds = [(floor_n, float(f_hi)) if fires else (0.0, 0.0) for fires, f_hi in zip(on, f_max, strict=True)]
    polished = linprog(np.ones(n), A_eq=b, b_eq=wrench, bounds=bounds, method='highs', options=_HIGHS_OPTIONS)
    thrusts = polished.x if polished.status == 0 else np.where(on, result.x[:n], 0.0)
    thrusts = np.where(on, np.clip(thrusts, floor_n, f_max), 0.0)
    delivered = b @ thrusts
    return DirectionAllocation(thrusts, float(delivered[:3] @ force) / norm, delivered[:3], delivered[3:])
