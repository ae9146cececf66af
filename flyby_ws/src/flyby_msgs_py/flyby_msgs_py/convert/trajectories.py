"""Trajectories: nav_msgs/Path and the planned trajectory on /planner/trajectory
(trajectory_msgs/MultiDOFJointTrajectory, DESIGN §10)."""

from typing import NamedTuple

import numpy as np
from geometry_msgs.msg import PoseStamped, Transform, Twist
from nav_msgs.msg import Path
from trajectory_msgs.msg import MultiDOFJointTrajectory, MultiDOFJointTrajectoryPoint

from flyby_msgs_py.convert.fields import _array, _frame, _quat, _set_xyz, _set_xyzw
from flyby_msgs_py.convert.stamps import NS_PER_S, _stamp_into, sec_to_ns, stamp_to_ns, stamp_to_sec


class PathArrays(NamedTuple):
    t: float
    times: np.ndarray          # (N,) stamps of the poses [s]
    positions: np.ndarray      # (N, 3)
    orientations: np.ndarray   # (N, 4) (x, y, z, w)
    frame_id: str


def path(t, frame_id, times, positions, orientations=None):
    """nav_msgs/Path in frame_id; pose i is stamped times[i]; orientations default to identity."""
    frame_id = _frame(frame_id)
    pos = _array(positions, 3, 'positions')
    try:
        ts = np.array(times, dtype=float).reshape(-1) if np.ndim(times) <= 1 else None
    except (TypeError, ValueError):
        ts = None
    if ts is None or ts.shape[0] != pos.shape[0]:
        raise ValueError(f'times: must be a sequence of {pos.shape[0]} numbers (one per position)')
    if not np.isfinite(ts).all():
        raise ValueError('times: must be finite')
    if orientations is None:
        quats = [(0.0, 0.0, 0.0, 1.0)] * len(pos)
    else:
        quats = _array(orientations, 4, 'orientations')
        if quats.shape[0] != pos.shape[0]:
            raise ValueError(f'orientations: must have {pos.shape[0]} rows (one per position), '
                             f'got {quats.shape[0]}')
        quats = [_quat(q, f'orientations[{i}]') for i, q in enumerate(quats.tolist())]
    msg = Path()
    _stamp_into(msg.header.stamp, t)
    msg.header.frame_id = frame_id
    poses = []
    for ti, p, q in zip(ts.tolist(), pos.tolist(), quats, strict=True):
        ps = PoseStamped()
        _stamp_into(ps.header.stamp, ti)
        ps.header.frame_id = frame_id
        _set_xyz(ps.pose.position, p)
        _set_xyzw(ps.pose.orientation, q)
        poses.append(ps)
    msg.poses = poses
    return msg


def path_to_numpy(msg):
    n = len(msg.poses)
    times = np.empty(n)
    positions = np.empty((n, 3))
    orientations = np.empty((n, 4))
    for i, ps in enumerate(msg.poses):
        p, q = ps.pose.position, ps.pose.orientation
        times[i] = stamp_to_sec(ps.header.stamp)
        positions[i] = (p.x, p.y, p.z)
        orientations[i] = (q.x, q.y, q.z, q.w)
    return PathArrays(stamp_to_sec(msg.header.stamp), times, positions, orientations, msg.header.frame_id)


class MultiDofTrajectoryArrays(NamedTuple):
    t: float                   # header.stamp: the trajectory's start [s]
    times: np.ndarray          # (N,) stamp + time_from_start of each point [s]
    positions: np.ndarray      # (N, 3) translation
    velocities: np.ndarray     # (N, 3) linear velocity
    accelerations: np.ndarray  # (N, 3) linear acceleration
    joint_name: str
    frame_id: str


def multi_dof_trajectory(t, frame_id, times, positions, velocities, accelerations, joint_name='chaser'):
    """trajectory_msgs/MultiDOFJointTrajectory of one joint in frame_id, header.stamp t [s]; point i at times[i] [s]
    (time_from_start = times[i] - t, >= 0) with its translation, linear velocity and linear acceleration (the
    rotation identity, angular terms zero)."""
    frame_id = _frame(frame_id)
    pos = _array(positions, 3, 'positions')
    vel = _array(velocities, 3, 'velocities')
    acc = _array(accelerations, 3, 'accelerations')
    ts = _array(np.reshape(np.asarray(times, dtype=float), (-1, 1)), 1, 'times')[:, 0]
    if not (len(ts) == len(pos) == len(vel) == len(acc)):
        raise ValueError(f'times, positions, velocities, accelerations: need one row each per point, got '
                         f'{len(ts)}, {len(pos)}, {len(vel)}, {len(acc)}')
    t0_ns = sec_to_ns(t)
    msg = MultiDOFJointTrajectory()
    _stamp_into(msg.header.stamp, t)
    msg.header.frame_id = frame_id
    msg.joint_names = [joint_name]
    points = []
    for i, (ti, p, v, a) in enumerate(zip(ts.tolist(), pos.tolist(), vel.tolist(), acc.tolist(), strict=True)):
        offset_ns = round(ti * 1e9) - t0_ns
        if offset_ns < 0:
            raise ValueError(f'times[{i}]: {ti!r} s is before the stamp {t!r} s')
        point = MultiDOFJointTrajectoryPoint()
        transform, twist, accel = Transform(), Twist(), Twist()
        _set_xyz(transform.translation, p)
        transform.rotation.w = 1.0
        _set_xyz(twist.linear, v)
        _set_xyz(accel.linear, a)
        point.transforms, point.velocities, point.accelerations = [transform], [twist], [accel]
        point.time_from_start.sec, point.time_from_start.nanosec = divmod(offset_ns, NS_PER_S)
        points.append(point)
    msg.points = points
    return msg


def multi_dof_trajectory_to_numpy(msg):
    """MultiDOFJointTrajectory (first joint) -> MultiDofTrajectoryArrays."""
    n = len(msg.points)
    t0_ns = stamp_to_ns(msg.header.stamp)
    times, pos, vel, acc = np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    for i, point in enumerate(msg.points):
        d = point.time_from_start
        times[i] = (t0_ns + d.sec * NS_PER_S + d.nanosec) / 1e9
        tr, tw, ac = point.transforms[0].translation, point.velocities[0].linear, point.accelerations[0].linear
        pos[i], vel[i], acc[i] = (tr.x, tr.y, tr.z), (tw.x, tw.y, tw.z), (ac.x, ac.y, ac.z)
    return MultiDofTrajectoryArrays(stamp_to_sec(msg.header.stamp), times, pos, vel, acc,
                                    msg.joint_names[0] if msg.joint_names else '', msg.header.frame_id)
