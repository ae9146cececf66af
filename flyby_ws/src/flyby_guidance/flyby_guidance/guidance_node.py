"""The guidance node: terminal approach, trajectory adjusting and the restriction-sphere interlock.

Converts messages for ``flyby_guidance.guidance_core.GuidanceCore`` (no ROS), which holds every rule:
a new plan (``planner/flyby_initial``, ``planner/flyby_target``, then ``planner/path``, whose stamp
is the plan time) starts the fly-by guidance, each chaser estimate on ``estimation/chaser/odom`` steps
it, the target estimates (``estimation/target/odom``) re-aim the adjusting burns, ``mission/phase``
silences it after the fly-by. Publishes the maneuvers on ``guidance/maneuver``
(geometry_msgs/Vector3Stamped, stamp = start time, frame hill) ahead of their start; with the
six-degree-of-freedom chaser the attitude commands of every chaser estimate on ``guidance/wheels`` (motor
torques as efforts) and ``guidance/wrench`` (the thrusters' torque, chaser_body), stamped one control period
after the estimate (the simulator holds time there until both are in); and on
``mission/events`` ``maneuver_commanded`` per burn, ``adjust_skipped``, ``thrusting_ended``,
``target_refined``. An optimization-based approach (``planner/trajectory``) is tracked with the force on
``guidance/wrench`` (chaser_body) of every attitude command; ``replan_requested``, ``tracking_ended`` on
``mission/events``. The events of ``mission/events`` come in too: the supervisor's ``node_error`` (its core raised:
no burn or thrust commanded from then on, ``propulsion_idled``); with the six-degree-of-freedom chaser the
supervisor's ``wheels_reallocated`` (its wheels commanded nothing from its stamp on) and with a post_capture section
the simulator's ``grasp_damped`` (the arm locked, the combined body is commanded from its stamp on).
"""

from flyby_guidance.guidance import Maneuver
from flyby_guidance.guidance_core import GuidanceCore
from flyby_guidance.modes.interface import AttitudeCommandStamped
from flyby_guidance.params import GuidanceParams
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert
from flyby_msgs_py.node_base import CoreNode
from flyby_msgs_py.runtime import main_for, publish_event
from flyby_sim.dynamics.rotation import quat_rotate
from flyby_sim.scenario import scenario_of


class GuidanceNode(CoreNode):
    """Fly-by guidance; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_guidance', **kwargs)
        scenario = scenario_of(self)
        self.core = GuidanceCore(GuidanceParams.from_scenario(scenario), self.get_name())
        self.pub_maneuver = self.publisher(c.GUIDANCE_MANEUVER)
        chaser = self.core.params.chaser
        if chaser is not None:  # the rigid-body chaser's command chain
            self.pub_wheels, self.pub_wrench = self.publisher(c.GUIDANCE_WHEELS), self.publisher(c.GUIDANCE_WRENCH)
            self.wheel_names = c.wheel_names(chaser.wheels.count)
        self.pub_events = self.publisher(c.MISSION_EVENTS)
        # The gate weighs the target estimate's uncertainty; the attitude control takes the chaser's attitude.
        estimates = self.estimate_inputs(quat_rotate, target_covariance=True, chaser_attitude=chaser is not None)
        self.subscribe_inputs(scenario, {
            **estimates, c.PLANNER_FLYBY_INITIAL: (self.odometry_input(self.core.on_flyby_initial, 'position',
                                                                       'linear'), True),
            c.PLANNER_FLYBY_TARGET: (self.odometry_input(self.core.on_flyby_target, 'position', 'linear'), True),
            c.PLANNER_PATH: self.on_path, c.PLANNER_TRAJECTORY: self.on_trajectory,
            c.MISSION_PHASE: self.on_phase_message, c.MISSION_EVENTS: self.on_events_message})

    def on_path(self, msg):
        self.publish(self.core.on_path(convert.stamp_to_sec(msg.header.stamp)))

    def on_trajectory(self, msg):
        traj = convert.multi_dof_trajectory_to_numpy(msg)
        self.publish(self.core.on_trajectory(traj.times, traj.positions, traj.velocities, traj.accelerations))

    def publish(self, outputs):
        for out in outputs:
            if isinstance(out, Maneuver):
                self.pub_maneuver.publish(convert.vector3_stamped(out.t, c.FRAME_HILL, out.dv_hill))
            elif isinstance(out, AttitudeCommandStamped):
                # Every control period: as CDR bytes (convert.*_cdr), no Python messages on the hot path.
                self.pub_wheels.publish(convert.joint_state_cdr(out.t, c.FRAME_CHASER_BODY, self.wheel_names,
                                                                effort=out.wheel_torque_n_m))
                self.pub_wrench.publish(convert.wrench_stamped_cdr(out.t, c.FRAME_CHASER_BODY, out.force_body_n,
                                                                   out.thruster_torque_body_n_m))
            else:
                publish_event(self, self.pub_events, out)


def main(args=None):
    main_for(GuidanceNode, args)


if __name__ == '__main__':
    main()
