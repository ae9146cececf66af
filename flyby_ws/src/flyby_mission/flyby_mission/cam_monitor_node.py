"""The independent collision-avoidance monitor's node (``flyby_mission.cam_monitor``, docs/faults.md).

It reads the sensors' raw relative positions, target attitudes and chaser IMU samples and mission/phase (to stand
down at the capture),
and publishes the CAM on ``safety/cam`` (geometry_msgs/Vector3Stamped, hill, the stamp the burn starts at), which the
simulator's thrusters execute ahead of every other command, and its ``cam_fired`` on mission/events. It takes
nothing from the estimator, the planner, guidance or the supervisor.
"""

from flyby_mission.cam_monitor import CamBurn, CamMonitor, CamParams
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert
from flyby_msgs_py.node_base import CoreNode
from flyby_msgs_py.runtime import main_for, publish_event
from flyby_sim.scenario import scenario_of


class CamMonitorNode(CoreNode):
    """The independent collision-avoidance monitor; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_cam_monitor', **kwargs)
        scenario = scenario_of(self)
        self.core = CamMonitor(CamParams.from_scenario(scenario), self.get_name())
        self.pub_cam, self.pub_events = self.publisher(c.SAFETY_CAM), self.publisher(c.MISSION_EVENTS)
        self.subscribe_inputs(scenario, {
            c.SENSOR_RELATIVE_POSITION: (self.on_position, True), c.SENSOR_TARGET_ATTITUDE: (self.on_attitude, True),
            c.SENSOR_CHASER_IMU: (self.on_imu, True), c.MISSION_PHASE: self.on_phase})

    def on_position(self, data):
        self.publish(self.core.on_position(*convert.point_stamped_cdr_to_numpy(data)))

    def on_attitude(self, data):
        self.publish(self.core.on_attitude(*convert.quaternion_stamped_cdr_to_numpy(data)))

    def on_imu(self, data):
        imu = convert.imu_cdr_to_numpy(data)
        self.core.on_imu(imu.t, imu.orientation_xyzw, imu.linear_acceleration)

    def on_phase(self, msg):
        self.core.on_phase(convert.string_to_str(msg))

    def publish(self, outputs):
        for out in outputs:
            if isinstance(out, CamBurn):
                self.pub_cam.publish(convert.vector3_stamped(out.t, c.FRAME_HILL, out.dv_hill))
            else:
                publish_event(self, self.pub_events, out)


def main(args=None):
    main_for(CamMonitorNode, args)


if __name__ == '__main__':
    main()
