"""The least delta-v of a transfer in a given time under an acceleration bound, whatever the path's shape: the bound
every planner of the same time and acceleration bound meets from above (seed 003 Table 1's case, docs/optimal.md).

Clohessy-Wiltshire dynamics (seed 000 eq 22) with thrust held over equal steps (scp.zoh_input_matrix).
"""

import dataclasses

import cvxpy as cp
import numpy as np
from scipy.optimize import minimize

from flyby_planner.optimal.scp import zoh_input_matrix
from flyby_sim.dynamics.orbital import cw_transition_matrix


@dataclasses.dataclass(frozen=True)
class DeltaVBound:
    """The least delta-v of a transfer in a given time under an acceleration bound (delta_v_lower_bound).

    lower_mps: no thrust history a(t), |a| <= a_max, of any shape does it with less [m/s] (weak duality);
    held_mps: the least delta-v of thrust held over ``steps`` equal steps [m/s], which a path reaches (without
    keep-out or plume), so the true least delta-v lies between the two; multiplier: the dual vector used.
    """

    lower_mps: float
    held_mps: float
    steps: int
    multiplier: np.ndarray


def delta_v_lower_bound(r0_hill, v0_hill, r_f_hill, v_f_hill, duration_s, accel_max_mps2, n, steps=200,
                        quadrature=6000):
    """The least delta-v int |a| dt taking (r0, v0) to (r_f, v_f) in duration_s on the CW dynamics, |a| <= a_max.

    Keep-out, the plume rule and the robots' separation only remove paths, so what holds without them bounds every
    planner of the same time and acceleration bound from below. Two numbers bracket it:

    * Held thrust (the relaxation as a second-order cone program, cvxpy Clarabel): with d = x_f - Phi(T) x_0 and
      G_k = Phi(T - t_k+1) Gamma(h), min sum |u_k| h subject to sum G_k u_k = d, |u_k| <= a_max. Its optimum is
      reached by a path, so it is at least the continuous-time least delta-v.
    * Weak duality, valid for any thrust history: for every multiplier lambda (6,),
      int |a| >= int |a| - lambda' (int Phi(T - s) B a ds - d)
              >= lambda' d - a_max int max(0, |B' Phi(T - s)' lambda| - 1) ds
      with B = [0; I], since min over |a| <= a_max of |a| - c' a is -a_max max(0, |c| - 1). lambda starts from the
      cone program's equality multiplier (either sign convention) and is polished by Nelder-Mead on that concave
      function; the integral is the midpoint rule on ``quadrature`` points.

    Returns:
        DeltaVBound.
    """
    phi_t = cw_transition_matrix(n, duration_s)
    d = np.concatenate((r_f_hill, v_f_hill)) - phi_t @ np.concatenate((r0_hill, v0_hill))
    h = duration_s / steps
    g = np.einsum('kij,jl->kil', cw_transition_matrix(n, duration_s - (np.arange(steps) + 1) * h),
                  zoh_input_matrix(n, h))  # (N, 6, 3)
    u = cp.Variable((steps, 3))
    reach = np.transpose(g, (1, 0, 2)).reshape(6, 3 * steps) @ cp.vec(u, order='C') == d  # sum G_k u_k = d
    program = cp.Problem(cp.Minimize(h * cp.sum(cp.norm(u, 2, axis=1))),
                         [reach, cp.norm(u, 2, axis=1) <= accel_max_mps2])
    program.solve(solver='CLARABEL')
    if program.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise ValueError(f'no thrust of at most {accel_max_mps2} m/s^2 makes the transfer in {duration_s} s '
                         f'({program.status})')
    s = (np.arange(quadrature) + 0.5) * duration_s / quadrature
    psi = cw_transition_matrix(n, duration_s - s)[:, :, 3:]  # Phi(T - s) B, (Q, 6, 3)

    def dual(lam):
        c = np.linalg.norm(np.einsum('qij,i->qj', psi, lam), axis=1)
        return float(lam @ d) - accel_max_mps2 * float(np.maximum(c - 1.0, 0.0).sum()) * duration_s / quadrature

    lam0 = max((sign * np.asarray(reach.dual_value, dtype=float) for sign in (1.0, -1.0)), key=dual)
    polished = minimize(lambda lam: -dual(lam), lam0, method='Nelder-Mead',
                        options={'xatol': 1e-10, 'fatol': 1e-12, 'maxfev': 4000})
    lam = polished.x if -polished.fun > dual(lam0) else lam0
    return DeltaVBound(lower_mps=dual(lam), held_mps=float(program.value), steps=steps, multiplier=lam)
