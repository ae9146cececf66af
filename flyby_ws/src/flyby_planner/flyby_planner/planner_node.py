"""The planner node: fly-by capture task planning on request (seed 000 §2.2 (2), §4.3-4.5, 4.7).

Plans when the supervisor turns the mission to ``PLANNING`` (its ``phase_changed`` event on
``mission/events``, stamped) or when ``planner/replan`` (std_srvs/Trigger) is called, at the first
target estimate stamped at or after the request (the plan time is that estimate's stamp: the same
at any pace of the run; nothing here reads the wall clock). The target motion is predicted from
that estimate on ``estimation/target/odom`` (attitude, body rate, the scenario's inertia), the
chaser state is the last ``estimation/chaser/odom`` up to the plan time carried to it along CW
(eq 22).

Publishes (latched): ``planner/grasp`` (stamp t_g; the grasp point in hill, its velocity relative to
hill, and the predicted target attitude and body rate at t_g), ``planner/flyby_target`` (stamp t_g;
X_Ft, V_Ft), ``planner/flyby_initial`` (stamp t_i; X_Fi, V_Fi), ``planner/path`` (the predicted
chaser path) and markers (swept keep-out cylinders, restriction sphere, grasp point, X_Ft, X_Fi,
path). On ``mission/events``: one ``plan_candidate`` event per candidate (the candidate table),
then ``plan_selected`` or ``plan_refused`` with the reason. The planning itself is
``flyby_planner.plan`` (no ROS).
"""


import numpy as np
from rclpy.node import Node
from std_srvs.srv import Trigger

from flyby_estimation.target_motion import ErrorStateDynamics, prediction_from_estimate
from flyby_msgs_py import contract as c
from flyby_msgs_py import qos
from flyby_msgs_py import convert
from flyby_msgs_py.runtime import StampedBuffer, main_for, publish_event, scenario_of
from flyby_planner.plan import plan_capture, planner_config_from_scenario
from flyby_sim.dynamics.orbital import cw_transition_matrix

FRAME_GRASP_POINT = 'grasp_point'
RGBA_FLYBY_POINTS = (1.0, 0.9, 0.1, 1.0)


def plan_markers(plan, config, t):
    """MarkerArray of a plan: keep-out cylinders about the spin axis at t_g, sphere, points, path."""
    n = config.mean_motion_rad_s
    chosen = plan.selected
    t_axis = chosen.t_grasp if chosen else plan.t_plan
    markers = [convert.sphere_marker(t, (0.0, 0.0, 0.0), config.restriction_sphere_radius_m)]
    region = plan.region
    if region is not None:
        axis = region.axis_hill(t_axis, n)
        for i, (lo, hi, rad) in enumerate(zip(region.axial_min_m, region.axial_max_m, region.radius_m)):
            markers.append(convert.cylinder_marker(t, 0.5 * (lo + hi) * axis, axis, rad, hi - lo, marker_id=i))
    if chosen is not None:
        markers.append(convert.point_marker(t, chosen.x_g))
        for i, p in enumerate((chosen.x_ft, chosen.x_fi)):
            markers.append(convert.point_marker(t, p, diameter_m=0.3, ns='flyby_points', marker_id=i,
                                                rgba=RGBA_FLYBY_POINTS))
        markers.append(convert.line_strip_marker(t, plan.path_r_hill))
    return convert.marker_array(markers)


class PlannerNode(Node):
    """Fly-by capture planner; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_planner', **kwargs)
        self.scenario = scenario_of(self)
        self.config = planner_config_from_scenario(self.scenario)
        self.dynamics = ErrorStateDynamics(self.scenario.target_inertia)
        self.request = None  # (t_request, why) until the plan is made
        self.targets = StampedBuffer()  # (q_hill_from_body, omega_body) by stamp
        self.chasers = StampedBuffer()  # (r_hill, v_hill) by stamp
        self.plans = 0

        def pub(topic):
            return self.create_publisher(c.message_class(c.TOPIC_TYPES[topic]), topic, qos.qos_for(topic))
        self.pubs = {topic: pub(topic) for topic in (
            c.PLANNER_GRASP, c.PLANNER_FLYBY_TARGET, c.PLANNER_FLYBY_INITIAL, c.PLANNER_PATH, c.MARKERS,
            c.MISSION_EVENTS)}
        for topic, callback, qos in ((c.EST_TARGET_ODOM, self.on_target, qos.QOS_STREAM),
                                     (c.EST_CHASER_ODOM, self.on_chaser, qos.QOS_STREAM),
                                     (c.MISSION_EVENTS, self.on_event, qos.QOS_EVENTS)):
            self.create_subscription(c.message_class(c.TOPIC_TYPES[topic]), topic, callback, qos)
        self.create_service(Trigger, c.PLANNER_REPLAN_SERVICE, self.on_replan)

    def on_event(self, msg):
        """The supervisor's transition to PLANNING, stamped: the plan is made at that time."""
        for e in convert.events_from_msg(msg):
            if e['name'] == 'phase_changed' and e['values'].get('to') == c.PHASE_PLANNING:
                self.request = (e['t'], 'phase PLANNING')
                self.try_plan()

    def on_replan(self, _request, response):
        self.request = (self.targets.latest_t, 'replan requested')
        response.success = True
        response.message = 'planning at the next target estimate'
        return response

    def on_chaser(self, msg):
        o = convert.odometry_to_numpy(msg)
        self.chasers.add(o.t, (o.position, o.linear))
        self.try_plan()

    def on_target(self, msg):
        o = convert.odometry_to_numpy(msg)
        self.targets.add(o.t, (o.orientation_xyzw, o.angular))
        self.try_plan()

    def try_plan(self):
        """Plan at the first target estimate stamped at or after the request, once the chaser estimates
        up to that stamp are in (the same estimates at any pace of the run)."""
        if self.request is None:
            return
        t_request, why = self.request
        target = self.targets.first_at_or_after(t_request)
        if target is None or self.chasers.latest_t < target[0]:
            return
        self.request = None
        self.plan(target[0], *target[1], why)

    def plan(self, t, q_hill_from_body, omega_body, why):
        """Plan at the target estimate of time t (the plan time) and publish the result."""
        cfg = self.config
        n = cfg.mean_motion_rad_s
        t_c, (r_c, v_c) = self.chasers.last_at_or_before(t) or self.chasers.first_at_or_after(t)
        chaser_now = cw_transition_matrix(n, t - t_c) @ np.concatenate((r_c, v_c))
        prediction = prediction_from_estimate(self.dynamics, n, t, q_hill_from_body, omega_body,
                                              t + cfg.search_window[1])
        plan = plan_capture(prediction, chaser_now[:3], chaser_now[3:], t, cfg)
        self.plans += 1
        for cand in plan.candidates:
            d = cand.to_dict()
            self.emit(t, 'OK' if cand.status != 'rejected' else 'WARN', 'plan_candidate',
                      f'{cand.status}: ' + ('; '.join(cand.reasons) if cand.reasons else 'passes every check'),
                      {k: d[k] for k in ('t_grasp_s', 'status', 'dv_total_mps', 'clearance_approach_m',
                                         'clearance_escape_m', 't_i_s', 'convex_value_m2_s2')})
        if not plan.ok:
            self.emit(t, 'ERROR', 'plan_refused', plan.reason, {'request': why, 'plan': str(self.plans)})
            self.pubs[c.MARKERS].publish(plan_markers(plan, cfg, t))
            return
        chosen = plan.selected
        target_at_grasp = prediction.state(chosen.t_grasp)
        self.pubs[c.PLANNER_GRASP].publish(convert.odometry(
            chosen.t_grasp, c.FRAME_HILL, FRAME_GRASP_POINT, chosen.x_g, target_at_grasp.q_hill_from_body,
            chosen.v_g, target_at_grasp.omega_body))
        self.pubs[c.PLANNER_FLYBY_TARGET].publish(convert.odometry(
            chosen.t_grasp, c.FRAME_HILL, c.FRAME_CHASER_BODY, chosen.x_ft, (0.0, 0.0, 0.0, 1.0), chosen.v_ft,
            (0.0, 0.0, 0.0)))
        self.pubs[c.PLANNER_FLYBY_INITIAL].publish(convert.odometry(
            chosen.t_i, c.FRAME_HILL, c.FRAME_CHASER_BODY, chosen.x_fi, (0.0, 0.0, 0.0, 1.0), chosen.v_fi,
            (0.0, 0.0, 0.0)))
        self.pubs[c.PLANNER_PATH].publish(convert.path(t, c.FRAME_HILL, plan.path_t, plan.path_r_hill))
        self.pubs[c.MARKERS].publish(plan_markers(plan, cfg, t))
        d = chosen.to_dict()
        self.emit(t, 'OK', 'plan_selected',
                  f'grasp at t = {chosen.t_grasp:.2f} s, transfer delta-v {chosen.dv_total_mps:.4f} m/s, '
                  f'least clearance {chosen.clearance_min_m:.3f} m',
                  {'request': why, 'plan': str(self.plans), **{k: d[k] for k in (
                      't_grasp_s', 't_i_s', 't_ti_s', 'dv_total_mps', 'clearance_approach_m', 'clearance_escape_m',
                      't_sphere_entry_s', 'x_g_hill_m', 'v_g_hill_mps', 'x_ft_hill_m', 'x_fi_hill_m')}})

    def emit(self, t, level, name, message, values):
        publish_event(self, self.pubs[c.MISSION_EVENTS], t, level, name, message, values)


def main(args=None):
    main_for(PlannerNode, args)


if __name__ == '__main__':
    main()
