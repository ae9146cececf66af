"""The guidance node: terminal approach, trajectory adjusting and the restriction-sphere interlock.

Converts messages for ``flyby_guidance.guidance_core.GuidanceCore`` (no ROS), which holds every rule:
a new plan (``planner/flyby_initial``, ``planner/flyby_target``, then ``planner/path``, whose stamp
is the plan time) starts the fly-by guidance, each chaser estimate on ``estimation/chaser/odom`` steps
it, the target estimates (``estimation/target/odom``) re-aim the adjusting burns, ``mission/phase``
silences it after the fly-by. Publishes the maneuvers on ``guidance/maneuver``
(geometry_msgs/Vector3Stamped, stamp = start time, frame hill) ahead of their start, and on
``mission/events`` ``maneuver_commanded`` per burn, ``adjust_skipped``, ``thrusting_ended``,
``target_refined``.
"""

from rclpy.node import Node

from flyby_guidance.guidance import Maneuver
from flyby_guidance.guidance_core import GuidanceCore
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, qos
from flyby_msgs_py.runtime import main_for, publish_event
from flyby_sim.scenario import scenario_of


class GuidanceNode(Node):
    """Fly-by guidance; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_guidance', **kwargs)
        self.core = GuidanceCore(scenario_of(self), self.get_name())
        self.pub_maneuver = self.create_publisher(c.message_class(c.TOPIC_TYPES[c.GUIDANCE_MANEUVER]),
                                                  c.GUIDANCE_MANEUVER, qos.qos_for(c.GUIDANCE_MANEUVER))
        self.pub_events = self.create_publisher(c.message_class(c.TOPIC_TYPES[c.MISSION_EVENTS]),
                                                c.MISSION_EVENTS, qos.qos_for(c.MISSION_EVENTS))
        for topic, callback in ((c.PLANNER_FLYBY_INITIAL, self.on_flyby_initial),
                                (c.PLANNER_FLYBY_TARGET, self.on_flyby_target),
                                (c.PLANNER_PATH, self.on_path),
                                (c.MISSION_PHASE, self.on_phase),
                                (c.EST_TARGET_ODOM, self.on_target),
                                (c.EST_CHASER_ODOM, self.on_chaser)):
            self.create_subscription(c.message_class(c.TOPIC_TYPES[topic]), topic, callback, qos.qos_for(topic))

    def on_flyby_initial(self, msg):
        o = convert.odometry_to_numpy(msg)
        self.publish(self.core.on_flyby_initial(o.t, o.position, o.linear))

    def on_flyby_target(self, msg):
        o = convert.odometry_to_numpy(msg)
        self.publish(self.core.on_flyby_target(o.t, o.position, o.linear))

    def on_path(self, msg):
        self.publish(self.core.on_path(convert.stamp_to_sec(msg.header.stamp)))

    def on_phase(self, msg):
        self.publish(self.core.on_phase(convert.string_to_str(msg)))

    def on_target(self, msg):
        o = convert.odometry_to_numpy(msg)
        self.publish(self.core.on_target_estimate(o.t, o.orientation_xyzw, o.angular))

    def on_chaser(self, msg):
        o = convert.odometry_to_numpy(msg)
        self.publish(self.core.on_chaser_estimate(o.t, o.position, o.linear))

    def publish(self, outputs):
        for out in outputs:
            if isinstance(out, Maneuver):
                self.pub_maneuver.publish(convert.vector3_stamped(out.t, c.FRAME_HILL, out.dv_hill))
            else:
                publish_event(self, self.pub_events, out)


def main(args=None):
    main_for(GuidanceNode, args)


if __name__ == '__main__':
    main()
