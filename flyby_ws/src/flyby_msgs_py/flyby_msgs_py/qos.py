"""QoS profiles of the contract topics (DESIGN §4) (rclpy side; the names are ``contract``)."""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from flyby_msgs_py.contract import EVENTS_HISTORY, LATCHED_TOPICS, MISSION_EVENTS


def _reliable(depth, durability):
    """Every flyby profile is reliable keep-last; they differ in depth and durability."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                      durability=durability)


# Streams (truth, sensors, estimates, commands): reliable so that nothing is lost on the way to
# the recorder; the depth covers the burst between two flow-control points of the simulator.
QOS_STREAM = _reliable(200, DurabilityPolicy.VOLATILE)
# Latched state: late joiners get the last value (mission phase, the plan, markers).
QOS_LATCHED = _reliable(1, DurabilityPolicy.TRANSIENT_LOCAL)
# Events: a late joiner gets the recent history. Deep: a plan publishes one plan_candidate event per candidate
# in one burst (hundreds, a slow tumbler's extended window thousands), and a keep-last writer or reader that
# overflows drops the oldest, delivered or not.
QOS_EVENTS = _reliable(EVENTS_HISTORY, DurabilityPolicy.TRANSIENT_LOCAL)
# The recorder subscribes deeper than any publisher keeps, so a slow callback never drops a sample.
QOS_RECORDER = _reliable(5000, DurabilityPolicy.VOLATILE)
QOS_RECORDER_LATCHED = _reliable(100, DurabilityPolicy.TRANSIENT_LOCAL)
QOS_RECORDER_EVENTS = _reliable(5000, DurabilityPolicy.TRANSIENT_LOCAL)


def qos_for(topic):
    """Publisher QoS of a contract topic."""
    if topic == MISSION_EVENTS:
        return QOS_EVENTS
    if topic in LATCHED_TOPICS:
        return QOS_LATCHED
    return QOS_STREAM


def recorder_qos_for(topic):
    """Subscription QoS the recorder uses for a contract topic (compatible with ``qos_for``)."""
    if topic == MISSION_EVENTS:
        return QOS_RECORDER_EVENTS
    if topic in LATCHED_TOPICS:
        return QOS_RECORDER_LATCHED
    return QOS_RECORDER
