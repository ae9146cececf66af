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

from flyby_guidance.guidance import Maneuver
from flyby_guidance.guidance_core import GuidanceCore
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert
from flyby_msgs_py.node_base import CoreNode
from flyby_msgs_py.runtime import main_for, publish_event
from flyby_sim.scenario import scenario_of


class GuidanceNode(CoreNode):
    """Fly-by guidance; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_guidance', **kwargs)
        self.core = GuidanceCore(scenario_of(self), self.get_name())
        self.pub_maneuver = self.publisher(c.GUIDANCE_MANEUVER)
        self.pub_events = self.publisher(c.MISSION_EVENTS)
        self.subscribe_odometry(c.PLANNER_FLYBY_INITIAL, self.core.on_flyby_initial, 'position', 'linear')
        self.subscribe_odometry(c.PLANNER_FLYBY_TARGET, self.core.on_flyby_target, 'position', 'linear')
        self.subscribe(c.PLANNER_PATH, self.on_path)
        self.subscribe_phase()
        self.subscribe_estimates(target_covariance=True)  # the gate weighs the estimate's uncertainty

    def on_path(self, msg):
        self.publish(self.core.on_path(convert.stamp_to_sec(msg.header.stamp)))

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
