"""The guidance node: terminal approach, trajectory adjusting and the restriction-sphere interlock.

A new plan (``planner/flyby_initial`` X_Fi at t_i, ``planner/flyby_target`` X_Ft at t_f, and
``planner/path`` whose header stamp is the plan time; the first burn is planner.maneuver_lead_s
after it, as the planner assumed) starts ``FlybyGuidance`` (flyby_guidance.guidance, no ROS). Each
chaser estimate on ``estimation/chaser/odom`` steps it; the maneuvers it returns are published on
``guidance/maneuver`` (geometry_msgs/Vector3Stamped, stamp = start time, frame hill) ahead of their
start. Before each adjusting burn the grasp is re-solved from the target estimate
(``estimation/target/odom``) of the deciding chaser estimate's stamp and the burn aims at it
(``guidance.refine_target``). In the phases
CAPTURE, ESCAPE, COMPLETE and ABORTED (``mission/phase``) nothing is commanded. On
``mission/events``: ``maneuver_commanded`` per burn, ``adjust_skipped``, ``thrusting_ended``,
``target_refined``. Nothing reads the wall clock; every decision is at an estimate's stamp.
"""

import collections

import numpy as np
from rclpy.node import Node

from flyby_estimation.target_motion import ErrorStateDynamics, prediction_from_estimate
from flyby_guidance.guidance import FlybyGuidance, FlybyTarget, guidance_config_from_scenario, refined_flyby_target
from flyby_msgs_py import contract as c
from flyby_msgs_py import qos
from flyby_msgs_py import convert
from flyby_msgs_py.runtime import StampedBuffer, main_for, publish_event, scenario_of

QUIET_PHASES = (c.PHASE_CAPTURE, c.PHASE_ESCAPE, c.PHASE_COMPLETE, c.PHASE_ABORTED)


class GuidanceNode(Node):
    """Fly-by guidance; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_guidance', **kwargs)
        self.scenario = scenario_of(self)
        self.guidance = FlybyGuidance(guidance_config_from_scenario(self.scenario))
        self.dynamics = ErrorStateDynamics(self.scenario.target_inertia)
        self.n = self.scenario.mean_motion_rad_s
        self.x_grasp_body = np.array(self.scenario.target.grasp_point_body_m)
        self.phase = None
        self.flyby_initial = self.flyby_target = None
        self.plan_stamp = None  # the plan time of the plan being flown
        self.targets = StampedBuffer()  # (q_hill_from_body, omega_body) of the target estimates
        self.waiting = collections.deque()  # chaser estimates not yet stepped, in order
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
            qos = qos.QOS_LATCHED if topic in c.LATCHED_TOPICS else qos.QOS_STREAM
            self.create_subscription(c.message_class(c.TOPIC_TYPES[topic]), topic, callback, qos)

    # -- the plan -------------------------------------------------------------------------------
    def on_flyby_initial(self, msg):
        self.flyby_initial = convert.odometry_to_numpy(msg)

    def on_flyby_target(self, msg):
        self.flyby_target = convert.odometry_to_numpy(msg)

    def on_path(self, msg):
        """The planner publishes the path last: a new plan is complete."""
        t_plan = convert.stamp_to_sec(msg.header.stamp)
        if self.flyby_initial is None or self.flyby_target is None or t_plan == self.plan_stamp:
            return
        self.plan_stamp = t_plan
        fi, ft = self.flyby_initial, self.flyby_target
        target = FlybyTarget(t_ti=t_plan + self.scenario.planner.maneuver_lead_s, t_i=fi.t, x_fi=fi.position,
                             v_fi=fi.linear, t_f=ft.t, x_ft=ft.position, v_ft=ft.linear)
        self.guidance.set_target(target)
        self.emit(t_plan, 'OK', 'guidance_started',
                  f'flying the plan of t = {t_plan:.2f} s: transfer at {target.t_ti:.2f} s, injection at '
                  f'{target.t_i:.2f} s, fly-by target at {target.t_f:.2f} s', {'t_plan_s': t_plan})

    def on_phase(self, msg):
        self.phase = convert.string_to_str(msg)

    def on_target(self, msg):
        o = convert.odometry_to_numpy(msg)
        self.targets.add(o.t, (o.orientation_xyzw, o.angular))
        self.step_waiting()

    # -- stepping -------------------------------------------------------------------------------
    def on_chaser(self, msg):
        self.waiting.append(convert.odometry_to_numpy(msg))
        self.step_waiting()

    def step_waiting(self):
        """Step with the chaser estimates in order. One that re-aims waits for the target estimate of its
        own stamp, so the aim is the same at any pace of the run (not whichever estimate came first)."""
        g = self.guidance
        while self.waiting:
            est = self.waiting[0]
            if g.next_burn_time is None or self.phase in QUIET_PHASES:
                self.waiting.clear()
                return
            if self.scenario.guidance.refine_target and g.wants_refined_target(est.t):
                target = self.targets.first_at_or_after(est.t)
                if target is None:
                    return
                self.refine(est.t, target)
            self.waiting.popleft()
            self.step(est)

    def step(self, est):
        g = self.guidance
        maneuvers, events = g.step(est.t, est.position, est.linear)
        for mv in maneuvers:
            self.pub_maneuver.publish(convert.vector3_stamped(mv.t, c.FRAME_HILL, mv.dv_hill))
            self.emit(est.t, 'OK', 'maneuver_commanded',
                      f'{mv.kind} burn of {np.linalg.norm(mv.dv_hill) * 1e3:.2f} mm/s at t = {mv.t:.2f} s',
                      {'kind': mv.kind, 't_burn_s': mv.t, 'dv_hill_mps': [float(x) for x in mv.dv_hill],
                       **mv.values})
        for e in events:
            self.emit(e.t, e.level, e.name, e.message, e.values)

    def refine(self, t, target):
        """Re-aim at the grasp re-solved from the target estimate (stamp, (q, omega)) (seed 000 section 4.6)."""
        t_est, (q_hb, omega_body) = target
        t_f = self.guidance.target.t_f
        if t_f <= t_est:
            return
        prediction = prediction_from_estimate(self.dynamics, self.n, t_est, q_hb, omega_body, t_f + 60.0)
        aim = refined_flyby_target(prediction, self.x_grasp_body, t_f, self.scenario.planner.offset_m, self.n)
        if aim is None:
            self.emit(t, 'WARN', 'target_refined', 'no convex grasp near the planned one; keeping the aim', {})
            return
        shift = float(np.linalg.norm(aim[1] - self.guidance.target.x_ft))
        self.guidance.retarget(*aim)
        self.emit(t, 'OK', 'target_refined', f'grasp re-solved at t = {aim[0]:.3f} s, aim moved {shift * 1e3:.1f} mm',
                  {'t_grasp_s': aim[0], 'shift_m': shift})

    def emit(self, t, level, name, message, values):
        publish_event(self, self.pub_events, t, level, name, message, values)


def main(args=None):
    main_for(GuidanceNode, args)


if __name__ == '__main__':
    main()
