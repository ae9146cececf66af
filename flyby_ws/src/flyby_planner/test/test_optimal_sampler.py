"""Tests of flyby_planner.optimal.sampler and its message (DESIGN §10: /planner/trajectory)."""

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from trajectory_msgs.msg import MultiDOFJointTrajectory

from flyby_msgs_py.convert import multi_dof_trajectory, multi_dof_trajectory_to_numpy
from flyby_planner.optimal.sampler import sample_trajectory
from flyby_planner.optimal.scp import ZohPlan, zoh_input_matrix
from flyby_planner.optimal.spline import parabolic_path
from flyby_sim.dynamics.orbital import cw_transition_matrix

N = 1.08e-3


def _zoh_plan():
    rng = np.random.default_rng(21)
    u = rng.normal(size=(8, 3)) * 0.02
    x = [np.array([20.0, 1.0, -3.0, 0.0, 0.0, 0.0])]
    for k in range(8):
        x.append(cw_transition_matrix(N, 2.5) @ x[-1] + zoh_input_matrix(N, 2.5) @ u[k])
    return ZohPlan(100.0, 20.0, np.array(x), u, N)


@pytest.mark.parametrize('plan', [_zoh_plan(), parabolic_path([20.0, 0.0, 0.0], np.zeros(3), [[10.0, 2.0, 1.0]],
                                                              [3.0, 0.0, 0.0], [0.0, 0.1, 0.0], 20.0, N, 100.0)])
def test_sampler_points_span_the_plan(plan):
    traj = sample_trajectory(plan, step_s=0.75)
    assert traj.t_s[0] == 100.0 and traj.t_s[-1] == 120.0
    assert np.all(np.diff(traj.t_s) > 0.0) and np.diff(traj.t_s).max() == pytest.approx(0.75)
    again = plan.sample(traj.t_s - 100.0)
    np.testing.assert_array_equal(traj.r_hill, again.r_hill)
    np.testing.assert_array_equal(traj.a_hill, again.a_hill)
    later = sample_trajectory(plan, step_s=1.0, t_from_s=110.2)
    assert later.t_s[0] == 110.2 and later.t_s[-1] == 120.0
    with pytest.raises(ValueError, match='outside the plan'):
        sample_trajectory(plan, t_from_s=99.0)


def test_planner_trajectory_message_round_trip():
    """MultiDOFJointTrajectory in hill, stamped at the start, points at time_from_start, through CDR."""
    traj = sample_trajectory(_zoh_plan(), step_s=0.5)
    msg = multi_dof_trajectory(traj.t_s[0], 'hill', traj.t_s, traj.r_hill, traj.v_hill, traj.a_hill)
    back = multi_dof_trajectory_to_numpy(deserialize_message(serialize_message(msg), MultiDOFJointTrajectory))
    assert back.t == 100.0 and back.frame_id == 'hill' and back.joint_name == 'chaser'
    np.testing.assert_allclose(back.times, traj.t_s, atol=1e-9)
    np.testing.assert_array_equal(back.positions, traj.r_hill)
    np.testing.assert_array_equal(back.velocities, traj.v_hill)
    np.testing.assert_array_equal(back.accelerations, traj.a_hill)
    assert msg.points[3].time_from_start.sec == 1 and msg.points[3].time_from_start.nanosec == 500_000_000
    with pytest.raises(ValueError, match='before the stamp'):
        multi_dof_trajectory(101.0, 'hill', traj.t_s, traj.r_hill, traj.v_hill, traj.a_hill)
    with pytest.raises(ValueError, match='positions'):
        multi_dof_trajectory(100.0, 'hill', traj.t_s, traj.r_hill * np.nan, traj.v_hill, traj.a_hill)
