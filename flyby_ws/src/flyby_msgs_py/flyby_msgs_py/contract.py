"""The topic contract of DESIGN §4 in code: names, message types, QoS profiles, frame ids, phases.

Tools outside the project read our bags by these names; change none of them without changing DESIGN.md.
Topic names are given without the leading slash so that nodes create them relative to their namespace
(several chasers live under ``/chaser1`` ...); ``absolute(name)`` gives the single-chaser form.
"""

import importlib

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

FRAME_HILL = 'hill'
FRAME_ECI = 'eci'
FRAME_TARGET_BODY = 'target_body'
FRAME_CHASER_BODY = 'chaser_body'

CLOCK = 'clock'
SIM_CHASER_ODOM = 'sim/chaser/odom'
SIM_TARGET_ODOM = 'sim/target/odom'
SIM_CHASER_THRUST = 'sim/chaser/thrust'
SENSOR_RELATIVE_POSITION = 'sensors/chaser/relative_position'
SENSOR_TARGET_ATTITUDE = 'sensors/target/attitude'
EST_TARGET_ODOM = 'estimation/target/odom'
EST_CHASER_ODOM = 'estimation/chaser/odom'
PLANNER_GRASP = 'planner/grasp'
PLANNER_FLYBY_TARGET = 'planner/flyby_target'
PLANNER_FLYBY_INITIAL = 'planner/flyby_initial'
PLANNER_PATH = 'planner/path'
GUIDANCE_MANEUVER = 'guidance/maneuver'
MISSION_PHASE = 'mission/phase'
MISSION_EVENTS = 'mission/events'
MARKERS = 'visualization/markers'
MISSION_ABORT_SERVICE = 'mission/abort'
PLANNER_REPLAN_SERVICE = 'planner/replan'

# Every recorded topic with its ROS type name (rosbags spelling).
TOPIC_TYPES = {
    CLOCK: 'rosgraph_msgs/msg/Clock',
    SIM_CHASER_ODOM: 'nav_msgs/msg/Odometry',
    SIM_TARGET_ODOM: 'nav_msgs/msg/Odometry',
    SIM_CHASER_THRUST: 'geometry_msgs/msg/WrenchStamped',
    SENSOR_RELATIVE_POSITION: 'geometry_msgs/msg/PointStamped',
    SENSOR_TARGET_ATTITUDE: 'geometry_msgs/msg/QuaternionStamped',
    EST_TARGET_ODOM: 'nav_msgs/msg/Odometry',
    EST_CHASER_ODOM: 'nav_msgs/msg/Odometry',
    PLANNER_GRASP: 'nav_msgs/msg/Odometry',
    PLANNER_FLYBY_TARGET: 'nav_msgs/msg/Odometry',
    PLANNER_FLYBY_INITIAL: 'nav_msgs/msg/Odometry',
    PLANNER_PATH: 'nav_msgs/msg/Path',
    GUIDANCE_MANEUVER: 'geometry_msgs/msg/Vector3Stamped',
    MISSION_PHASE: 'std_msgs/msg/String',
    MISSION_EVENTS: 'diagnostic_msgs/msg/DiagnosticArray',
    MARKERS: 'visualization_msgs/msg/MarkerArray',
}

PHASE_ESTIMATION = 'ESTIMATION'
PHASE_PLANNING = 'PLANNING'
PHASE_TERMINAL_APPROACH = 'TERMINAL_APPROACH'
PHASE_TRAJECTORY_ADJUST = 'TRAJECTORY_ADJUST'
PHASE_FLYBY = 'FLYBY'
PHASE_CAPTURE = 'CAPTURE'
PHASE_ESCAPE = 'ESCAPE'
PHASE_COMPLETE = 'COMPLETE'
PHASE_ABORTED = 'ABORTED'
TERMINAL_PHASES = (PHASE_COMPLETE, PHASE_ABORTED)

# Streams (truth, sensors, estimates, commands): reliable so that nothing is lost on the way to
# the recorder; the depth covers the burst between two flow-control points of the simulator.
QOS_STREAM = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=200,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
# Latched state: late joiners get the last value (mission phase, the plan, markers).
QOS_LATCHED = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
# Events: a late joiner gets the recent history.
QOS_EVENTS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
# The recorder subscribes deeper than any publisher keeps, so a slow callback never drops a sample.
QOS_RECORDER = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=5000,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
QOS_RECORDER_LATCHED = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)

LATCHED_TOPICS = (MISSION_PHASE, PLANNER_GRASP, PLANNER_FLYBY_TARGET, PLANNER_FLYBY_INITIAL,
                  PLANNER_PATH, MARKERS)


def qos_for(topic):
    """Publisher QoS of a contract topic."""
    if topic == MISSION_EVENTS:
        return QOS_EVENTS
    if topic in LATCHED_TOPICS:
        return QOS_LATCHED
    return QOS_STREAM


def recorder_qos_for(topic):
    """Subscription QoS the recorder uses for a contract topic (compatible with ``qos_for``)."""
    if topic == MISSION_EVENTS or topic in LATCHED_TOPICS:
        return QOS_RECORDER_LATCHED
    return QOS_RECORDER


def absolute(topic, namespace=''):
    """Fully qualified topic name, e.g. ``absolute('sim/chaser/odom', '/chaser1')``."""
    ns = namespace.rstrip('/')
    return f'{ns}/{topic}' if topic != CLOCK else '/clock'


def message_class(type_name):
    """The rclpy message class of a type name like ``nav_msgs/msg/Odometry``."""
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)
