"""Which thruster a thrust fault is, and how it failed: a hypothesis per thruster, tested on the window's residual
series (the isolation of ``health.ThrustMonitor``, docs/faults.md). Pure numpy/scipy.

Why not the residual's direction alone: a thruster off while its opposite partners fire (a couple, or a trim burn
re-allocated so every thruster gives its minimum impulse bit, where opposing pairs take up what is below it) leaves
their force unbalanced, along the partners' direction; read by direction, that is the partners' leak, and the fault
table closes healthy thrusters (campaign faults_single run 411: thruster 9 off in a 2.3 ms trim that fired all
twelve thrusters, ``thrust_excess`` named [10, 11]). What tells them apart is the timing: a leak pushes whether or
not its thruster is commanded; a thruster off or weak lacks thrust only where it is commanded.

So for each thruster i (force direction d_i), from what the flight software commanded of every thruster over each
interval k (``Allocator``: guidance's wrench allocated as the plant allocates it, ``actuators.allocate_wrench`` with
``actuators.fire``'s minimum impulse bit, and a maneuver's burn as ``actuators.plan_burn`` plans it; the layout's
nominal geometry, not the plant's truth), two hypotheses predict the residual r_k [m/s^2, chaser_body]:

* leak (stuck on): the thruster gives at least x whatever it is commanded (the plant gives max(command, leak)), so
  r_k = e_k(x) d_i, e_k(x) the interval's mean of max(0, x - a) over its parts a thruster is commanded a in,
  0 <= x <= its maximum thrust over the mass;
* deficit (off or weak): it lacks a share s of what it is commanded, r_k = -s c_ik d_i (c_ik its mean commanded
  thrust acceleration), 0 <= s <= 1.

Each from an onset: nothing in the intervals before one interval j, a share t in [0, 1] of the prediction in it (the
fault began inside it), all of it after; x (or s) fitted by least squares to the intervals after j, t to j's, j
scanned over the window. Each interval is weighted by its variance per axis: the accelerometer's, the thrusters'
specified errors on every commanded thruster and on the hypothesis's own predicted thrust (1 sigma, independent: a
leaking thruster's misalignment shows across its direction; campaign faults_single run 34's 1 N leak, about 2 deg
off its nominal direction, failed its test by 0.3 mm/s^2 across it without) and a third of ``THRUST_RELATIVE`` of
the thrust expected (the attitude estimate a burn is turned by). The fit's chi-square over the K intervals, 3K - 2
degrees of freedom, must lie within its ``1 - FALSE_REJECTION`` quantile (a hypothesis that explains the series
leaves noise). The hypotheses that pass within ``MARGIN`` of the best chi-square (a likelihood ratio of e^4.5, about
90) are the candidates: parallel thrusters commanded alike predict the same and are named together. Where they are
all of one kind, that kind and those thrusters are named; where none passes, or leaks and deficits explain the
series alike (a thruster off through a window where its partner fires steadily looks like the partner's leak
there, and a leak named a deficit would go unanswered where a thruster stuck on is catastrophic), ``isolate``
returns None and the monitor names by direction as before.
"""

import math
from typing import NamedTuple

import numpy as np
from scipy.stats import chi2

from flyby_msgs_py.stamped import put_bounded
from flyby_sim.dynamics.actuators import allocate_wrench, plan_burn

FALSE_REJECTION = 1e-3  # the probability the true hypothesis fails its chi-square test
MARGIN = 9.0  # chi-square within this of the best: not told apart (a likelihood ratio of e^4.5)
CACHED = 64  # allocations kept (a wrench held over many intervals is allocated once)


class BurnShare(NamedTuple):
    """A maneuver's burn over part of an interval, as the navigation filter models it: its force direction
    [unit, chaser_body] at its start (the plant fixes it in the body then), its delta-v [m/s], thrust [N] and starting
    mass [kg] (what ``plan_burn`` allocates from), its thrust acceleration [m/s^2] and its overlap with the interval
    [s]."""

    seq: int
    direction_body: tuple
    dv_mps: float
    thrust_n: float
    mass_kg: float
    accel_mps2: float
    overlap_s: float


class Commanded(NamedTuple):
    """What the flight software commanded of the thrusters over one interval of dt_s [s] at mass_kg [kg]: guidance's
    wrench held over it (force [N], torque [N m], chaser_body) and the burns in it (``BurnShare``)."""

    dt_s: float
    mass_kg: float
    force_body_n: tuple
    torque_body_n_m: tuple
    burns: tuple


class Firing(NamedTuple):
    """An interval's commanded thrusts as the hypotheses use them: its parts (fraction of the interval, each
    thruster's thrust acceleration [m/s^2] in it), their mean and the force the allocation does not deliver
    [m/s^2, chaser_body] (the wrench beyond the thrusters, thrusters left off below the minimum impulse bit)."""

    parts: tuple
    mean: np.ndarray
    undelivered: np.ndarray


class Isolation(NamedTuple):
    """The hypotheses' verdict: ``thrust_excess`` (a leak) or ``thrust_deficit`` (off or weak), the thrusters, the
    best chi-square and its degrees of freedom."""

    kind: str
    candidates: list
    chi2: float
    dof: int


class Allocator:
    """Each interval's commanded thrusts from its ``Commanded``, allocated as the plant allocates them (module doc),
    each allocation made once."""

    def __init__(self, layout):
        """layout: the chaser's ``ThrusterLayout`` (its nominal geometry and limits)."""
        self.layout = layout
        self._wrenches = {}  # (force, torque, hold) -> thrusts [N] fired and the force [N] not delivered
        self._burns = {}  # (seq, direction, dv, thrust, mass) -> thrusts [N] per newton of the burn's force

    def firing(self, commanded):
        """The interval's ``Firing``."""
        m, dt = commanded.mass_kg, commanded.dt_s
        wrench, undelivered = self.wrench(commanded.force_body_n, commanded.torque_body_n_m, dt)
        limit = self.layout.max_thrust_n
        parts, left = [], 1.0
        for burn in commanded.burns:  # the burn's share first, each thruster at most its maximum (the plant's)
            share = min(burn.overlap_s / dt, left)
            thrusts = np.minimum(self._burn(burn) * burn.accel_mps2 * m + wrench, limit)
            parts.append((share, thrusts / m))
            left -= share
        if left > 0.0:
            parts.append((left, wrench / m))
        mean = sum(share * a for share, a in parts)
        return Firing(tuple(parts), mean, undelivered / m)

    def wrench(self, force, torque, hold_s):
        """Thrusts [N] of a wrench held over hold_s (``allocate_wrench``, a thruster whose impulse would be below the
        minimum impulse bit left off, as ``fire`` does) and its force [N] not delivered."""
        key = (tuple(force), tuple(torque), hold_s)
        if key not in self._wrenches:
            thrusts = np.zeros(self.layout.count)
            if any(force) or any(torque):
                thrusts = allocate_wrench(self.layout, force, torque).thrusts_n
                thrusts = np.where(thrusts * hold_s < self.layout.min_impulse_bit_n_s, 0.0, thrusts)
            undelivered = np.asarray(force, dtype=float) - self.layout.wrench_matrix[:3] @ thrusts
            put_bounded(self._wrenches, key, (thrusts, undelivered), CACHED)
        return self._wrenches[key]

    def _burn(self, burn):
        """A burn's thrusts per newton of its force (``plan_burn`` at the filter's thrust, as the plant plans it)."""
        key = (burn.seq, burn.direction_body, burn.dv_mps, burn.thrust_n, burn.mass_kg)
        if key not in self._burns:
            plan = plan_burn(self.layout, burn.direction_body, burn.dv_mps, burn.mass_kg, burn.thrust_n)
            put_bounded(self._burns, key, plan.allocation.thrusts_n / plan.allocation.force_n, CACHED)
        return self._burns[key]


def isolate(residuals, firings, variances, directions, max_accel, relative):
    """The ``Isolation`` of a window (module doc), or None where no hypothesis names one kind.

    residuals (K, 3): each interval's residual against the thrusts the allocation delivers [m/s^2, chaser_body];
    firings: their ``Firing``; variances (K,): each interval's variance per axis [m^2/s^4]; directions (M, 3): the
    thrusters' force directions; max_accel (M,): each thruster's largest thrust acceleration [m/s^2]; relative: a
    thruster's specified error, 1 sigma of its thrust (the hypothesis's own thrust errs by it too)."""
    residuals = np.asarray(residuals, dtype=float)
    variances = np.asarray(variances, dtype=float)
    along = residuals @ np.asarray(directions, dtype=float).T  # (K, M): each residual along each thruster
    squares = np.sum(residuals**2, axis=1)
    dof = 3 * len(residuals) - 2
    bound = chi2.ppf(1.0 - FALSE_REJECTION, dof)
    fits = []
    for i in range(len(directions)):
        parts = [[(share, float(a[i])) for share, a in f.parts] for f in firings]
        mean = np.array([f.mean[i] for f in firings])
        for kind, model in (('thrust_excess', _Leak(parts, float(max_accel[i]))), ('thrust_deficit', _Deficit(mean))):
            fits.append((kind, i, _best_onset(model, along[:, i], squares, variances, relative)))
    passing = [f for f in fits if f[2] <= bound]
    if not passing:
        return None
    best = min(f[2] for f in passing)
    tied = [f for f in passing if f[2] <= best + MARGIN]
    kinds = {kind for kind, _, _ in tied}
    if len(kinds) > 1:
        return None
    return Isolation(kinds.pop(), sorted(i for _, i, _ in tied), float(best), dof)


def _best_onset(model, along, squares, variances, relative):
    """The least chi-square of a hypothesis over its onset j: nothing before j, a share t of its prediction in j,
    all of it after; its amplitude fitted to the intervals after j (all of it allowed where none is). Each
    interval's variance grows by the predicted thrust's own specified error (a leaking thruster's misalignment
    shows across its direction)."""
    best = math.inf
    k = np.arange(len(along))
    for j in range(len(along)):
        after = slice(j + 1, None)
        h = model.predictions(model.fit(after, along[after], squares[after], 1.0 / variances[after]))
        t = min(max(along[j] * h[j] / (h[j] * h[j]), 0.0), 1.0) if h[j] != 0.0 else 0.0
        h = np.where(k < j, 0.0, np.where(k == j, t * h, h))
        best = min(best, _cost(h, along, squares, 1.0 / (variances + (relative * h)**2)))
    return best


def _cost(h, along, squares, weights):
    """The chi-square of predictions h along a thruster's direction."""
    return float(np.sum(weights * (squares - 2.0 * h * along + h * h)))


class _Deficit:
    """A thruster off or weak: r_k = -s c_k d, 0 <= s <= 1 (c_k: its mean commanded thrust acceleration)."""

    def __init__(self, mean):
        self.mean = mean

    def predictions(self, s):
        """The residual along its direction in each interval for the share s it lacks."""
        return -s * self.mean

    def fit(self, after, along, _squares, weights):
        """s over the intervals ``after``: least squares, clipped to [0, 1] (1 where none is)."""
        c = self.mean[after]
        normal = float(np.sum(weights * c * c))
        return 1.0 if normal == 0.0 else min(max(-float(np.sum(weights * c * along)) / normal, 0.0), 1.0)


class _Leak:
    """A thruster stuck on: it gives max(command, x), so r_k = e_k(x) d with e_k(x) the interval's mean of
    max(0, x - a) over its parts (share, commanded a), 0 <= x <= its largest thrust acceleration."""

    def __init__(self, parts, largest):
        self.parts, self.largest = parts, largest

    def predictions(self, x):
        """The residual along its direction in each interval for a leak of x [m/s^2]."""
        return np.array([sum(share * max(0.0, x - a) for share, a in p) for p in self.parts])

    def fit(self, after, along, squares, weights):
        """x over the intervals ``after`` (the largest where none is): e_k(x) is piecewise linear, so the
        chi-square is piecewise quadratic in x between the commanded thrusts; its least is at a piece's stationary
        point or an end."""
        parts = self.parts[after]
        if not parts:
            return self.largest
        ends = sorted({0.0, self.largest} | {a for p in parts for _, a in p if 0.0 < a < self.largest})
        best_x, best = 0.0, math.inf
        for lo, hi in zip(ends[:-1], ends[1:], strict=True):
            # on (lo, hi) e_k(x) = slope_k x - offset_k, over the parts commanded at most lo
            slope = np.array([sum(s for s, a in p if a <= lo) for p in parts])
            offset = np.array([sum(s * a for s, a in p if a <= lo) for p in parts])
            normal = float(np.sum(weights * slope * slope))
            x = lo if normal == 0.0 else min(max(float(np.sum(weights * slope * (offset + along))) / normal, lo), hi)
            cost = _cost(slope * x - offset, along, squares, weights)
            if cost < best:
                best_x, best = x, cost
        return best_x
