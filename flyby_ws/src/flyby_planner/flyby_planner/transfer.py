"""CW two-impulse transfer of the terminal approach, seed 000 section 4.7 (eq 27-29).

Pure numpy, no ROS. Frames and units as in flyby_planner.flyby.grasp_search (hill, velocities relative to the
rotating frame, SI).
"""

import math

import numpy as np

from flyby_sim.dynamics.orbital import cw_transition_matrix


def terminal_impulses(r_hill, v_hill, r_target_hill, v_target_hill, duration_s, n):
    """The two impulses from (r, v) now to (r_target, v_target) after duration_s, seed 000 eq 28-29.

    .. math:: \\Delta V_{Ti} = \\Phi_{12}^{-1}(X_{Fi} - \\Phi_{11} X_T(t_{Ti})) - V_T(t_{Ti})   (28)

    .. math:: \\Delta V_{Tf} = V_{Fi} - \\Phi_{21} X_T(t_{Ti}) - \\Phi_{22}(V_T(t_{Ti}) + \\Delta V_{Ti})   (29)

    with Phi = cw_transition_matrix(n, duration_s) (eq 22). The first impulse is applied at the
    current state, the second on arrival.

    Args:
        r_hill, v_hill: chaser state at the first impulse [m], [m/s].
        r_target_hill, v_target_hill: state to reach (the fly-by initial point X_Fi, V_Fi).
        duration_s: t_Tf - t_Ti [s], > 0.
        n: mean motion [rad/s], > 0.

    Returns:
        (dv_first [m/s] (3,), dv_second [m/s] (3,)). ValueError when Phi12 is singular (a transfer
        of a whole number of orbits in the out-of-plane or along-track sense).
    """
    if not (math.isfinite(duration_s) and duration_s > 0.0):
        raise ValueError(f'duration_s must be finite and positive, got {duration_s}')
    phi = cw_transition_matrix(n, duration_s)
    phi11, phi12, phi21, phi22 = phi[:3, :3], phi[:3, 3:], phi[3:, :3], phi[3:, 3:]
    r0 = np.asarray(r_hill, dtype=float)
    v0 = np.asarray(v_hill, dtype=float)
    if np.linalg.cond(phi12) > 1e12:
        raise ValueError(f'CW transfer of {duration_s} s is singular (Phi12 not invertible, n t = '
                         f'{n * duration_s:.6g} rad)')
    dv_first = np.linalg.solve(phi12, np.asarray(r_target_hill, dtype=float) - phi11 @ r0) - v0  # eq 28
    dv_second = np.asarray(v_target_hill, dtype=float) - phi21 @ r0 - phi22 @ (v0 + dv_first)  # eq 29
    return dv_first, dv_second
