"""The topic contract of DESIGN §4 and §10 in code: names, message types, frame ids, phases, outcomes.

Tools outside the project read our bags by these names; change none of them without changing DESIGN.md.
Topic names are given without the leading slash so that nodes create them relative to their namespace
(several chasers live under ``/chaser1`` ...); ``absolute(name)`` gives the single-chaser form.
No rclpy here (the QoS profiles are ``flyby_msgs_py.qos``), so that the cores can use the names.
"""

import importlib

FRAME_HILL = 'hill'
FRAME_ECI = 'eci'
FRAME_TARGET_BODY = 'target_body'
FRAME_CHASER_BODY = 'chaser_body'
FRAME_GRASP_POINT = 'grasp_point'  # the grasp point, fixed in target_body (/tf_static, planner/grasp)

CLOCK = 'clock'
SIM_CHASER_ODOM = 'sim/chaser/odom'
SIM_TARGET_ODOM = 'sim/target/odom'
SIM_CHASER_THRUST = 'sim/chaser/thrust'
SIM_CHASER_WHEELS = 'sim/chaser/wheels'
SIM_CHASER_THRUSTERS = 'sim/chaser/thrusters'
SENSOR_CHASER_IMU = 'sensors/chaser/imu'
SENSOR_CHASER_WHEELS = 'sensors/chaser/wheels'  # the wheels' tachometers (velocity: spin relative to the body)
SENSOR_RELATIVE_POSITION = 'sensors/chaser/relative_position'
SENSOR_TARGET_ATTITUDE = 'sensors/target/attitude'
EST_TARGET_ODOM = 'estimation/target/odom'
EST_CHASER_ODOM = 'estimation/chaser/odom'
EST_TARGET_INERTIA = 'estimation/target/inertia'
PLANNER_GRASP = 'planner/grasp'
PLANNER_FLYBY_TARGET = 'planner/flyby_target'
PLANNER_FLYBY_INITIAL = 'planner/flyby_initial'
PLANNER_PATH = 'planner/path'
PLANNER_TRAJECTORY = 'planner/trajectory'
GUIDANCE_MANEUVER = 'guidance/maneuver'
GUIDANCE_WRENCH = 'guidance/wrench'
GUIDANCE_WHEELS = 'guidance/wheels'
MISSION_PHASE = 'mission/phase'
MISSION_EVENTS = 'mission/events'
DIAGNOSTICS = 'diagnostics'  # each health monitor's status (diagnostic_msgs, the ROS convention)
SAFETY_CAM = 'safety/cam'  # the independent monitor's collision-avoidance manoeuvre, straight to the plant
MARKERS = 'visualization/markers'
MISSION_ABORT_SERVICE = 'mission/abort'
PLANNER_REPLAN_SERVICE = 'planner/replan'
# The frames for viewers (tf2_msgs/TFMessage, flyby_msgs_py.frames): written by the recorder from the truth.
TF = 'tf'
TF_STATIC = 'tf_static'



def wheel_names(count):
    """Joint names of the reaction wheels on sim/chaser/wheels and guidance/wheels (wheel i = row i of
    chaser.wheels.axes)."""
    return [f'w{i}' for i in range(count)]


def thruster_names(count):
    """Joint names of the thrusters on sim/chaser/thrusters (thruster i of the layout)."""
    return [f't{i}' for i in range(count)]


# Every recorded topic with its ROS type name (rosbags spelling).
TOPIC_TYPES = {
    CLOCK: 'rosgraph_msgs/msg/Clock',
    SIM_CHASER_ODOM: 'nav_msgs/msg/Odometry',
    SIM_TARGET_ODOM: 'nav_msgs/msg/Odometry',
    SIM_CHASER_THRUST: 'geometry_msgs/msg/WrenchStamped',
    SIM_CHASER_WHEELS: 'sensor_msgs/msg/JointState',
    SIM_CHASER_THRUSTERS: 'sensor_msgs/msg/JointState',
    SENSOR_CHASER_IMU: 'sensor_msgs/msg/Imu',
    SENSOR_CHASER_WHEELS: 'sensor_msgs/msg/JointState',
    SENSOR_RELATIVE_POSITION: 'geometry_msgs/msg/PointStamped',
    SENSOR_TARGET_ATTITUDE: 'geometry_msgs/msg/QuaternionStamped',
    EST_TARGET_ODOM: 'nav_msgs/msg/Odometry',
    EST_CHASER_ODOM: 'nav_msgs/msg/Odometry',
    EST_TARGET_INERTIA: 'geometry_msgs/msg/InertiaStamped',
    PLANNER_GRASP: 'nav_msgs/msg/Odometry',
    PLANNER_FLYBY_TARGET: 'nav_msgs/msg/Odometry',
    PLANNER_FLYBY_INITIAL: 'nav_msgs/msg/Odometry',
    PLANNER_PATH: 'nav_msgs/msg/Path',
    PLANNER_TRAJECTORY: 'trajectory_msgs/msg/MultiDOFJointTrajectory',
    GUIDANCE_MANEUVER: 'geometry_msgs/msg/Vector3Stamped',
    GUIDANCE_WRENCH: 'geometry_msgs/msg/WrenchStamped',
    GUIDANCE_WHEELS: 'sensor_msgs/msg/JointState',
    MISSION_PHASE: 'std_msgs/msg/String',
    MISSION_EVENTS: 'diagnostic_msgs/msg/DiagnosticArray',
    DIAGNOSTICS: 'diagnostic_msgs/msg/DiagnosticArray',
    SAFETY_CAM: 'geometry_msgs/msg/Vector3Stamped',
    MARKERS: 'visualization_msgs/msg/MarkerArray',
}

PHASE_ESTIMATION = 'ESTIMATION'
PHASE_PLANNING = 'PLANNING'
# Standby held on a fault until it recovers (the fault table's ``hold``, docs/faults.md): nothing is planned or flown.
PHASE_HOLD = 'HOLD'
# The approach given up on a fault that may recover (the fault table's ``retreat``): the chaser coasts away, safed as
# by an abort, and the mission plans again once the fault has recovered.
PHASE_RETREAT = 'RETREAT'
# The phases the supervisor waits in for a fault's recovery: guidance drops its plan, none is planned or taken.
WAITING_PHASES = (PHASE_HOLD, PHASE_RETREAT)
PHASE_TERMINAL_APPROACH = 'TERMINAL_APPROACH'
PHASE_TRAJECTORY_ADJUST = 'TRAJECTORY_ADJUST'
PHASE_FLYBY = 'FLYBY'
PHASE_OPTIMAL_APPROACH = 'OPTIMAL_APPROACH'
# The synchronized approach (seed 001 section 2, DESIGN §10): stage 1, 2, 3 and 4.
PHASE_SYNC_APPROACH = 'SYNC_APPROACH'
PHASE_ATTITUDE_SYNC = 'ATTITUDE_SYNC'
PHASE_ORBITING = 'ORBITING'
PHASE_DOCKING = 'DOCKING'
SYNC_PHASES = (PHASE_SYNC_APPROACH, PHASE_ATTITUDE_SYNC, PHASE_ORBITING, PHASE_DOCKING)
PHASE_CAPTURE = 'CAPTURE'
PHASE_ESCAPE = 'ESCAPE'
# The phases that end in the capture decision (CAPTURE or ESCAPE) at the grasp time.
DECIDING_PHASES = (PHASE_FLYBY, PHASE_OPTIMAL_APPROACH, PHASE_DOCKING)
# After the capture (DESIGN §10, seed 000 §2.2 (5)-(6), seed 004): the arm's impedance absorbs the relative motion,
# the thrusters and wheels detumble the combined body, known firings excite it for its mass properties.
PHASE_GRASP = 'GRASP'
PHASE_DAMPING = 'DAMPING'
PHASE_MASS_ESTIMATION = 'MASS_ESTIMATION'
# Transport (seed 004 §2.3, §3.2): the combined body moved to a goal on the reference orbit by the tug's thrusters.
PHASE_TRANSPORT = 'TRANSPORT'
POST_CAPTURE_PHASES = (PHASE_GRASP, PHASE_DAMPING, PHASE_MASS_ESTIMATION, PHASE_TRANSPORT)
PHASE_COMPLETE = 'COMPLETE'
PHASE_ABORTED = 'ABORTED'
TERMINAL_PHASES = (PHASE_COMPLETE, PHASE_ABORTED)

# Outcomes of a run (DESIGN §7, §10): summary.json "outcome".
OUTCOME_CAPTURE = 'CAPTURE'
OUTCOME_ESCAPE = 'ESCAPE'
OUTCOME_NO_SAFE_PLAN = 'NO_SAFE_PLAN'
OUTCOME_ABORTED = 'ABORTED'
OUTCOME_TIME_LIMIT = 'TIME_LIMIT'
OUTCOME_COLLISION = 'COLLISION'
OUTCOME_INTERRUPTED = 'INTERRUPTED'
OUTCOME_ERROR = 'ERROR'
OUTCOMES = (OUTCOME_CAPTURE, OUTCOME_ESCAPE, OUTCOME_NO_SAFE_PLAN, OUTCOME_ABORTED, OUTCOME_TIME_LIMIT,
            OUTCOME_COLLISION, OUTCOME_INTERRUPTED, OUTCOME_ERROR)

# mission/events keeps this many of each writer's events for a node that joins late (a respawned one).
EVENTS_HISTORY = 5000
LATCHED_TOPICS = (MISSION_PHASE, PLANNER_GRASP, PLANNER_FLYBY_TARGET, PLANNER_FLYBY_INITIAL,
                  PLANNER_PATH, PLANNER_TRAJECTORY, MARKERS)


# With several chasers (DESIGN §10) every other topic lives under the chaser's namespace; these stay global.
GLOBAL_TOPICS = (CLOCK, SIM_TARGET_ODOM, MARKERS)


def absolute(topic, namespace=''):
    """Fully qualified topic name, e.g. ``absolute('sim/chaser/odom', '/chaser1')``; a global topic keeps its
    root name whatever the namespace."""
    ns = namespace.rstrip('/')
    return f'{ns}/{topic}' if topic not in GLOBAL_TOPICS else f'/{topic}'


def topics_by_name(namespaces):
    """Every contract topic by its fully qualified name in a graph of these chaser namespaces (``['']`` for one
    chaser): name -> (contract topic, type name); a global topic once, at its root name. What the recorder records
    and the live view forwards."""
    return {absolute(topic, ns): (topic, type_name) for topic, type_name in TOPIC_TYPES.items()
            for ns in (namespaces if topic not in GLOBAL_TOPICS else [''])}


def message_class(type_name):
    """The rclpy message class of a type name like ``nav_msgs/msg/Odometry``."""
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)
