"""The path as parabolic splines through waypoints, seed 003 section 4.1 (eq 3: T = f(nu)).

"Cubic splines or parabolic splines with an additional spline section fulfill the requirements of position and
velocity boundary conditions ..., and the latter are used." Here: the approach time T is cut into n + 1 equal
intervals; the waypoints W_1..W_n sit at the inner knots. Each interval is one parabola, continuous in position
and velocity (C1) with the one before: from (p_i, v_i) to p_{i+1} in h its acceleration is
a_i = 2 (p_{i+1} - p_i - v_i h) / h^2 and it leaves at v_{i+1} = v_i + a_i h, so the start state fixes every
section. The last interval (W_n to the end point) is the "additional spline section": two half-length parabolas
whose shared knot K is placed so that the end velocity is v_f (from the two sections' equations,
K (2/h1 + 2/h2) = 2 p_f / h2 + 2 W_n / h1 + v_n - v_f). The path then meets r0, v0 at 0 and r_f, v_f at T
exactly (test_seed003_spline_boundary_conditions).

The parameter vector nu of eq 3 is (W_1, ..., W_n, T): 3 n + 1 numbers.
"""

import dataclasses

import numpy as np

from flyby_planner.optimal.cost import Trajectory
from flyby_sim.dynamics.orbital import cw_accel


@dataclasses.dataclass(frozen=True)
class ParabolicPath:
    """A C1 piecewise-parabolic path in hill: knots t (S+1,) [s from the start], positions p (S+1, 3), velocities
    v (S+1, 3) and each section's constant kinematic acceleration acc (S, 3); t0_s its absolute start [s]."""

    t0_s: float
    knots_s: np.ndarray
    p_hill: np.ndarray
    v_hill: np.ndarray
    acc_hill: np.ndarray
    n: float

    @property
    def duration_s(self):
        return float(self.knots_s[-1])

    def kinematics(self, tau):
        """(r_hill (M, 3), v_hill (M, 3), r''_hill (M, 3)) at the times tau (M,) [s from the start]."""
        tau = np.clip(np.asarray(tau, dtype=float), 0.0, self.duration_s)
        i = np.clip(np.searchsorted(self.knots_s, tau, side='right') - 1, 0, len(self.acc_hill) - 1)
        s = (tau - self.knots_s[i])[:, None]
        acc = self.acc_hill[i]
        return self.p_hill[i] + self.v_hill[i] * s + 0.5 * acc * s * s, self.v_hill[i] + acc * s, acc

    def sample(self, tau):
        """Trajectory at tau (M,) [s from the start]: the thrust acceleration is r'' less the CW acceleration."""
        r, v, acc = self.kinematics(tau)
        a_thrust = acc - cw_accel(r.T, v.T, self.n).T  # seed 000 eq 2: r'' = cw_accel + a
        return Trajectory(self.t0_s + np.asarray(tau, dtype=float), r, v, a_thrust)


def parabolic_path(r0_hill, v0_hill, waypoints_hill, r_f_hill, v_f_hill, duration_s, n, t0_s=0.0):
    """ParabolicPath from (r0, v0) through the waypoints (k, 3) to (r_f, v_f) at duration_s (module doc)."""
    w = np.asarray(waypoints_hill, dtype=float).reshape(-1, 3)
    r_f = np.asarray(r_f_hill, dtype=float)
    v_f = np.asarray(v_f_hill, dtype=float)
    if not duration_s > 0.0:
        raise ValueError(f'duration_s must be > 0, got {duration_s}')
    h = duration_s / (len(w) + 1)
    p = [np.asarray(r0_hill, dtype=float)]
    v = [np.asarray(v0_hill, dtype=float)]
    acc = []
    for target in w:
        a = 2.0 * (target - p[-1] - v[-1] * h) / (h * h)
        acc.append(a)
        p.append(target)
        v.append(v[-1] + a * h)
    # the additional section: two half parabolas meeting at K with the end velocity v_f
    h1 = h2 = 0.5 * h
    knot = (2.0 * r_f / h2 + 2.0 * p[-1] / h1 + v[-1] - v_f) / (2.0 / h1 + 2.0 / h2)
    for target, hh in ((knot, h1), (r_f, h2)):
        a = 2.0 * (target - p[-1] - v[-1] * hh) / (hh * hh)
        acc.append(a)
        p.append(target)
        v.append(v[-1] + a * hh)
    knots = np.concatenate((np.arange(len(w) + 1) * h, [duration_s - h2, duration_s]))
    return ParabolicPath(float(t0_s), knots, np.array(p), np.array(v), np.array(acc), float(n))
