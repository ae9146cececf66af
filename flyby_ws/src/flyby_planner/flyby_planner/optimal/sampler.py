"""A plan as time-stamped points for /planner/trajectory (DESIGN §10: trajectory_msgs/MultiDOFJointTrajectory,
frame ``hill``, header.stamp = the start, points with time_from_start, translation, linear velocity and
acceleration).

Pure numpy; flyby_msgs_py.convert.multi_dof_trajectory turns the arrays into the message.
"""

import math

import numpy as np


def sample_trajectory(plan, step_s=0.5, t_from_s=None):
    """The plan's points from t_from_s (default its start) to its end every step_s [s], the end included.

    Args:
        plan: a ZohPlan (flyby_planner.optimal.scp) or ParabolicPath (flyby_planner.optimal.spline): anything with
            t0_s, duration_s and sample(tau) -> Trajectory.
        step_s: spacing of the points [s], > 0.
        t_from_s: first time [s] (sim time), within the plan.

    Returns:
        flyby_planner.optimal.cost.Trajectory: t_s (M,) sim times [s], r_hill (M, 3) [m], v_hill (M, 3) [m/s] relative
        to hill, a_hill (M, 3) [m/s^2] the thrust acceleration (what guidance must add to the CW motion; a held
        thrust's value over the step that starts at the point).
    """
    if not (math.isfinite(step_s) and step_s > 0.0):
        raise ValueError(f'step_s must be finite and > 0, got {step_s}')
    t_end = plan.t0_s + plan.duration_s
    t_from = plan.t0_s if t_from_s is None else float(t_from_s)
    if not (plan.t0_s <= t_from <= t_end):
        raise ValueError(f't_from_s {t_from} s is outside the plan [{plan.t0_s}, {t_end}] s')
    count = math.ceil((t_end - t_from) / step_s - 1e-9)
    times = np.append(t_from + step_s * np.arange(count), t_end)
    return plan.sample(times - plan.t0_s)
