"""The planner node: fly-by capture task planning on request (seed 000 §2.2 (2), §4.3-4.5, 4.7).

Converts messages for ``flyby_planner.planner_core.PlannerCore`` (no ROS), which decides when and from
which estimates to plan (the supervisor's PLANNING, or ``planner/replan``, std_srvs/Trigger) and plans.
Publishes (latched): ``planner/grasp`` (stamp t_g; the grasp point in hill, with the predicted target
attitude as orientation of the child frame ``grasp_point`` and, by nav_msgs' rule, its velocity
relative to hill and the target's body rate in that frame's axes), ``planner/flyby_target`` (stamp
t_g; X_Ft, V_Ft, child frame ``flyby_target`` aligned with hill), ``planner/flyby_initial`` (stamp
t_i; X_Fi, V_Fi, child ``flyby_initial`` aligned with hill), ``planner/path`` and markers (swept
keep-out cylinders, restriction sphere, grasp point, X_Ft, X_Fi, path); grasp and fly-by target again
whenever guidance re-aims. An optimization-based approach (planner.method, seed 003 section 4) publishes
``planner/trajectory`` (trajectory_msgs/MultiDOFJointTrajectory, frame hill, stamp = its start, DESIGN §10) with
the grasp, the end point X_Ft, V_Ft on ``planner/flyby_target``, the path and markers (the plume sphere), and
plans again on guidance's ``replan_requested``. On ``mission/events``: the candidate table, ``method_chosen``,
then ``plan_selected`` or ``plan_refused`` with the reason. A chaser of a ``chasers:`` scenario also takes its
leaders' (the chasers before it in the file) ``/<leader>/mission/events`` and ``/<leader>/planner/trajectory``:
it plans after them and keeps off their planned motion (planner_core module doc).
"""

from functools import partial

from std_srvs.srv import Trigger

from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, qos
from flyby_msgs_py.markers import cylinder_marker, line_strip_marker, marker_array, point_marker, sphere_marker
from flyby_msgs_py.node_base import AdmissionGate, CoreNode
from flyby_msgs_py.runtime import main_for, publish_event
from flyby_msgs_py.wire import Event
from flyby_planner.params import PlannerParams
from flyby_planner.plan_outputs import AimUpdate, PlanPublished, PlanRefused, TrajectoryPublished
from flyby_planner.planner_core import PlannerCore
from flyby_sim.dynamics.rotation import quat_conjugate, quat_rotate, quat_shortest_arc
from flyby_sim.scenario import scenario_of

FRAME_FLYBY_TARGET = 'flyby_target'
FRAME_FLYBY_INITIAL = 'flyby_initial'
RGBA_FLYBY_POINTS = (1.0, 0.9, 0.1, 1.0)
_IDENTITY = (0.0, 0.0, 0.0, 1.0)
_ZERO = (0.0, 0.0, 0.0)
_Z_AXIS = (0.0, 0.0, 1.0)  # a cylinder marker's axis in its own frame


def grasp_odometry(grasp):
    """planner/grasp: orientation = target attitude at t_g, twist in the child frame's (body) axes."""
    body_from_hill = quat_conjugate(grasp.q_hill_from_body)
    return convert.odometry(grasp.t, c.FRAME_HILL, c.FRAME_GRASP_POINT, grasp.x_g, grasp.q_hill_from_body,
                            quat_rotate(body_from_hill, grasp.v_g), grasp.omega_body)


def plan_marker_array(t, m):
    """MarkerArray of plan_outputs.PlanMarkers at t."""
    markers = [sphere_marker(t, _ZERO, m.sphere_radius_m)]
    for i, (center, axis, radius, height) in enumerate(m.cylinders):
        markers.append(cylinder_marker(t, center, quat_shortest_arc(_Z_AXIS, axis), radius, height, marker_id=i))
    if m.grasp_point is not None:
        markers.append(point_marker(t, m.grasp_point))
        for i, p in enumerate(m.flyby_points):
            markers.append(point_marker(t, p, diameter_m=0.3, ns='flyby_points', marker_id=i, rgba=RGBA_FLYBY_POINTS))
        markers.append(line_strip_marker(t, m.path_r_hill))
    return marker_array(markers)


class PlannerNode(CoreNode):
    """Fly-by capture planner; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_planner', **kwargs)
        scenario = scenario_of(self)
        self.core = PlannerCore(PlannerParams.from_scenario(scenario), self.get_name())
        self.pubs = {topic: self.publisher(topic) for topic in (
            c.PLANNER_GRASP, c.PLANNER_FLYBY_TARGET, c.PLANNER_FLYBY_INITIAL, c.PLANNER_PATH, c.PLANNER_TRAJECTORY,
            c.MARKERS, c.MISSION_EVENTS)}
        # The target estimate's covariance: the re-aim check starts from it.
        self.subscribe_inputs(scenario, {**self.estimate_inputs(quat_rotate, target_covariance=True),
                                         c.MISSION_EVENTS: self.on_events_message,
                                         c.MISSION_PHASE: self.on_phase_message})
        self.create_service(Trigger, c.PLANNER_REPLAN_SERVICE,
                            self.guard(self.on_replan, c.PLANNER_REPLAN_SERVICE, service=True))
        # Another chaser's topics, by their absolute names, behind an admission of their own (its stamps).
        self.leader_gates = [AdmissionGate(self, self.known_time_s, self._report, label=leader)
                             for leader in self.core.leaders]
        for leader, gate in zip(self.core.leaders, self.leader_gates, strict=True):
            for topic, callback in ((c.MISSION_EVENTS, self.on_leader_events),
                                    (c.PLANNER_TRAJECTORY, self.on_leader_trajectory)):
                self.create_subscription(c.message_class(c.TOPIC_TYPES[topic]), f'/{leader}/{topic}',
                                         gate.admit(topic, self.guard(partial(callback, leader), f'/{leader}/{topic}')),
                                         qos.qos_for(topic))

    def destroy_node(self):
        for gate in self.leader_gates:
            gate.log_counts()
        return super().destroy_node()

    def on_leader_events(self, leader, msg):
        for e in convert.events_from_msg(msg):
            self.publish(self.core.on_leader_event(leader, Event(e['t'], e['level'], e['name'], e['message'],
                                                                 e['values'], e['source'])))

    def on_leader_trajectory(self, leader, msg):
        traj = convert.multi_dof_trajectory_to_numpy(msg)
        self.publish(self.core.on_leader_trajectory(leader, traj.times, traj.positions, traj.velocities))

    def on_replan(self, _request, response):
        self.publish(self.core.on_replan())
        response.success = True
        response.message = 'planning at the next target estimate'
        return response

    def publish(self, outputs):
        pubs = self.pubs
        for out in outputs:
            if isinstance(out, PlanPublished):
                pubs[c.PLANNER_GRASP].publish(grasp_odometry(out.grasp))
                pubs[c.PLANNER_FLYBY_TARGET].publish(convert.odometry(
                    out.t_f, c.FRAME_HILL, FRAME_FLYBY_TARGET, out.x_ft, _IDENTITY, out.v_ft, _ZERO))
                pubs[c.PLANNER_FLYBY_INITIAL].publish(convert.odometry(
                    out.t_i, c.FRAME_HILL, FRAME_FLYBY_INITIAL, out.x_fi, _IDENTITY, out.v_fi, _ZERO))
                pubs[c.PLANNER_PATH].publish(convert.path(out.t_plan, c.FRAME_HILL, out.path_t, out.path_r_hill))
                pubs[c.MARKERS].publish(plan_marker_array(out.t_plan, out.markers))
            elif isinstance(out, TrajectoryPublished):
                traj = out.trajectory
                pubs[c.PLANNER_GRASP].publish(grasp_odometry(out.grasp))
                pubs[c.PLANNER_FLYBY_TARGET].publish(convert.odometry(
                    out.t_f, c.FRAME_HILL, FRAME_FLYBY_TARGET, out.x_ft, _IDENTITY, out.v_ft, _ZERO))
                pubs[c.PLANNER_TRAJECTORY].publish(convert.multi_dof_trajectory(
                    out.t_start, c.FRAME_HILL, traj.t_s, traj.r_hill, traj.v_hill, traj.a_hill))
                pubs[c.PLANNER_PATH].publish(convert.path(out.t_plan, c.FRAME_HILL, traj.t_s, traj.r_hill))
                pubs[c.MARKERS].publish(plan_marker_array(out.t_plan, out.markers))
            elif isinstance(out, PlanRefused):
                pubs[c.MARKERS].publish(plan_marker_array(out.t_plan, out.markers))
            elif isinstance(out, AimUpdate):
                pubs[c.PLANNER_GRASP].publish(grasp_odometry(out.grasp))
                pubs[c.PLANNER_FLYBY_TARGET].publish(convert.odometry(
                    out.grasp.t, c.FRAME_HILL, FRAME_FLYBY_TARGET, out.x_ft, _IDENTITY, out.v_ft, _ZERO))
            else:
                publish_event(self, pubs[c.MISSION_EVENTS], out)


def main(args=None):
    main_for(PlannerNode, args)


if __name__ == '__main__':
    main()
