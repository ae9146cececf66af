"""numpy <-> ROS message conversions at the boundary of every node (DESIGN §4).

Conventions, once for the module:
- Stamps are simulation time ``t`` in seconds (float) <-> ``builtin_interfaces/Time(sec, nanosec)``,
  rounded to the nearest nanosecond. Integer nanoseconds convert exactly both ways; a simulator that
  keeps time as ``k * step_ns`` and passes ``ns / 1e9`` gets exactly ``k * step_ns`` back.
- Quaternions are (x, y, z, w), scalar last, as in ROS and scipy.
- Vectors are anything of length 3 (list, tuple, shape-(3,) array); covariances are 6x6 (or flat 36;
  3x3 or flat 9 in sensor_msgs/Imu), row-major, order (x, y, z, rot x, rot y, rot z) as in ROS.

Every builder validates shape and finiteness on the way INTO a message and raises ``ValueError``
naming the field, so a message with NaN never leaves a node. Every number is stored as a Python
float: with field checks off (the rclpy default) an ``int`` in a float64 field serializes as garbage.

The ``*_to_numpy`` readers return small NamedTuples of fresh arrays; ``t`` (float seconds) comes
first and frame ids, where returned, come last (``t, dv_hill = vector3_stamped_to_numpy(msg)``).

The modules, by message family: ``stamps`` (time, Clock), ``odometry``, ``geometry`` (stamped vectors, points,
quaternions, wrenches, inertia), ``sensors`` (Imu, JointState), ``trajectories`` (Path, MultiDOFJointTrajectory),
``mission`` (the phase string, events), over ``fields`` (validation) and ``cdr`` (the serialized form).
"""

from flyby_msgs_py.convert.cdr import clock_cdr_to_ns, header_cdr_to_ns
from flyby_msgs_py.convert.geometry import (
    Stamped,
    WrenchArrays,
    inertia_stamped,
    inertia_to_numpy,
    point_stamped,
    point_stamped_cdr,
    point_stamped_cdr_to_numpy,
    point_stamped_to_numpy,
    quaternion_stamped,
    quaternion_stamped_cdr,
    quaternion_stamped_cdr_to_numpy,
    quaternion_stamped_to_numpy,
    vector3_stamped,
    vector3_stamped_to_numpy,
    wrench_stamped,
    wrench_stamped_cdr,
    wrench_stamped_cdr_to_numpy,
    wrench_stamped_to_numpy,
)
from flyby_msgs_py.convert.mission import LEVELS, diagnostics, event, events_from_msg, string, string_to_str
from flyby_msgs_py.convert.odometry import (
    OdometryArrays,
    odometry,
    odometry_cdr,
    odometry_cdr_to_numpy,
    odometry_to_numpy,
)
from flyby_msgs_py.convert.sensors import (
    ImuArrays,
    JointArrays,
    imu,
    imu_cdr,
    imu_cdr_to_numpy,
    imu_to_numpy,
    joint_state,
    joint_state_cdr,
    joint_state_cdr_to_numpy,
    joint_state_to_numpy,
)
from flyby_msgs_py.convert.stamps import (
    NS_PER_S,
    clock,
    clock_to_sec,
    ns_to_sec,
    ns_to_stamp,
    sec_to_ns,
    sec_to_stamp,
    stamp_to_ns,
    stamp_to_sec,
)
from flyby_msgs_py.convert.trajectories import (
    MultiDofTrajectoryArrays,
    PathArrays,
    multi_dof_trajectory,
    multi_dof_trajectory_to_numpy,
    path,
    path_to_numpy,
)

__all__ = [
    'ImuArrays', 'JointArrays', 'LEVELS', 'MultiDofTrajectoryArrays', 'NS_PER_S', 'OdometryArrays', 'PathArrays',
    'Stamped', 'WrenchArrays', 'clock', 'clock_cdr_to_ns', 'clock_to_sec', 'diagnostics', 'event', 'events_from_msg',
    'header_cdr_to_ns', 'imu', 'imu_cdr', 'imu_cdr_to_numpy', 'imu_to_numpy', 'inertia_stamped',
    'inertia_to_numpy', 'joint_state', 'joint_state_cdr', 'joint_state_cdr_to_numpy', 'joint_state_to_numpy',
    'multi_dof_trajectory', 'multi_dof_trajectory_to_numpy', 'ns_to_sec', 'ns_to_stamp', 'odometry',
    'odometry_cdr', 'odometry_cdr_to_numpy', 'odometry_to_numpy', 'path', 'path_to_numpy', 'point_stamped',
    'point_stamped_cdr', 'point_stamped_cdr_to_numpy', 'point_stamped_to_numpy', 'quaternion_stamped',
    'quaternion_stamped_cdr', 'quaternion_stamped_cdr_to_numpy', 'quaternion_stamped_to_numpy', 'sec_to_ns',
    'sec_to_stamp', 'stamp_to_ns', 'stamp_to_sec', 'string', 'string_to_str', 'vector3_stamped',
    'vector3_stamped_to_numpy', 'wrench_stamped', 'wrench_stamped_cdr', 'wrench_stamped_cdr_to_numpy',
    'wrench_stamped_to_numpy'
]
