"""The supervisor node: mission phases, the capture decision, the abort service and the watchdog.

Feeds ``flyby_planner.supervisor.PhaseMachine`` (no ROS) with the target and chaser estimates, the
events of the other nodes (``mission/events``), their progress reports (``/flyby/progress``, the
watchdog's heartbeat) and ``/clock``; publishes ``mission/phase`` (latched) and, for each transition,
a ``phase_changed`` event with its reason. At the grasp time it decides capture from the *estimated*
chaser state against the fly-by target point recomputed from the latest target estimate
(supervisor.capture_decision). ``mission/abort`` (std_srvs/Trigger), a silent watched node or a fault
event end the mission in ABORTED: guidance then commands nothing; outside the restriction sphere
(and before the fly-by) the supervisor itself may fire one collision-avoidance burn on
``guidance/maneuver`` if the chaser's coast is not passively safe (plan.avoidance_burn); inside it,
never. All decisions are at message stamps, none at the wall clock.
"""


import numpy as np
from rclpy.node import Node
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from flyby_estimation.target_motion import ErrorStateDynamics, prediction_from_estimate, q_eci_from_body
from flyby_msgs_py import contract as c
from flyby_msgs_py import qos
from flyby_msgs_py import convert
from flyby_msgs_py.runtime import PROGRESS_TOPIC, StampedBuffer, main_for, publish_event, scenario_of
from flyby_planner.grasp import flyby_target_point, grasp_from_attitude
from flyby_planner.keepout import swept_region
from flyby_planner.plan import avoidance_burn, planner_config_from_scenario
from flyby_planner.supervisor import PhaseMachine, capture_decision, supervisor_config_from_scenario
from flyby_sim.dynamics.orbital import cw_transition_matrix

_LEVEL_OF = {c.PHASE_ABORTED: 'ERROR', c.PHASE_ESCAPE: 'WARN'}


class SupervisorNode(Node):
    """Mission phase supervisor; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_supervisor', **kwargs)
        self.declare_parameter('watched_nodes', ['flyby_estimator', 'flyby_guidance'])
        self.scenario = scenario_of(self)
        watched = tuple(w for w in self.get_parameter('watched_nodes').value if w)
        self.machine = PhaseMachine(supervisor_config_from_scenario(self.scenario, watched))
        self.planner_config = planner_config_from_scenario(self.scenario)
        self.dynamics = ErrorStateDynamics(self.scenario.target_inertia)
        self.n = self.scenario.mean_motion_rad_s
        self.targets = StampedBuffer()  # (t, q_hill_from_body, omega_body) of the target estimates
        self.chaser = None  # (t, r_hill, v_hill) of the latest chaser estimate
        self.decision_at = None  # the chaser estimate the capture decision waits to be made at
        self.t_clock = 0.0

        def pub(topic):
            return self.create_publisher(c.message_class(c.TOPIC_TYPES[topic]), topic, qos.qos_for(topic))
        self.pub_phase, self.pub_events, self.pub_maneuver = (
            pub(c.MISSION_PHASE), pub(c.MISSION_EVENTS), pub(c.GUIDANCE_MANEUVER))
        for topic, callback in ((c.EST_TARGET_ODOM, self.on_target), (c.EST_CHASER_ODOM, self.on_chaser),
                                (c.MISSION_EVENTS, self.on_event)):
            qos = qos.QOS_EVENTS if topic == c.MISSION_EVENTS else qos.QOS_STREAM
            self.create_subscription(c.message_class(c.TOPIC_TYPES[topic]), topic, callback, qos)
        self.create_subscription(Header, PROGRESS_TOPIC, self.on_progress, qos.QOS_STREAM)
        self.create_subscription(c.message_class(c.TOPIC_TYPES[c.CLOCK]), '/clock', self.on_clock, qos.QOS_STREAM)
        self.create_service(Trigger, c.MISSION_ABORT_SERVICE, self.on_abort)
        self.pub_phase.publish(convert.string(self.machine.phase))
        self.emit(0.0, 'OK', 'phase_changed', f'mission starts in {self.machine.phase}',
                  {'from': '', 'to': self.machine.phase})

    # -- inputs ---------------------------------------------------------------------------------
    def on_target(self, msg):
        o = convert.odometry_to_numpy(msg)
        self.targets.add(o.t, (o.t, o.orientation_xyzw, o.angular))
        self.apply(self.machine.target_estimate(o.t))
        self.try_decision()

    def on_chaser(self, msg):
        o = convert.odometry_to_numpy(msg)
        self.chaser = (o.t, o.position, o.linear)
        self.apply(self.machine.chaser_estimate(o.t, o.position))
        if self.decision_at is None and self.machine.wants_decision(o.t):
            self.decision_at = self.chaser
        self.try_decision()

    def try_decision(self):
        """Decide at the first chaser estimate at or after t_g, with the target estimate of its stamp."""
        if self.decision_at is None or not self.machine.wants_decision(self.decision_at[0]):
            return
        target = self.targets.first_at_or_after(self.decision_at[0])
        if target is not None:
            self.apply(self.machine.decide(self.decision_at[0], self.decide_capture(self.decision_at, target[1])))

    def on_event(self, msg):
        for e in convert.events_from_msg(msg):
            if e['source'] != self.get_name():
                values = dict(e['values'], reason=e['message'])
                self.apply(self.machine.event(e['t'], e['level'], e['name'], e['source'], values))

    def on_progress(self, msg):
        self.machine.node_progress(msg.frame_id, convert.stamp_to_sec(msg.stamp))

    def on_clock(self, msg):
        self.t_clock = convert.clock_to_sec(msg)
        self.apply(self.machine.clock(self.t_clock))

    def on_abort(self, _request, response):
        transitions = self.machine.abort(self.t_clock, 'abort requested on mission/abort')
        response.success = bool(transitions)
        response.message = ('aborted: guidance stops, the chaser escapes' if transitions else
                            f'nothing to abort in phase {self.machine.phase}')
        self.apply(transitions)
        return response

    # -- decisions ------------------------------------------------------------------------------
    def decide_capture(self, chaser, target):
        """The capture decision at the grasp time from a chaser and a target estimate (both carried to t_g)."""
        t_g = self.machine.t_grasp
        t_c, r, v = chaser
        state = cw_transition_matrix(self.n, t_g - t_c) @ np.concatenate((r, v))
        t_t, q_hb, omega_body = target
        t_at = max(t_g, t_t)  # the estimate may be a little newer than t_g: then its own time
        s = prediction_from_estimate(self.dynamics, self.n, t_t, q_hb, omega_body, t_at).state(t_at)
        x_g, v_g = grasp_from_attitude(s.q_hill_from_body, s.omega_body, self.planner_config.x_grasp_body_m, self.n)
        x_ft, v_ft = flyby_target_point(x_g, v_g, self.scenario.planner.offset_m)
        return capture_decision(state[:3], state[3:], x_g, x_ft, v_ft, self.machine.config)

    def escape_burn(self, t):
        """After an abort outside the sphere, before the fly-by: one avoidance burn if the coast is unsafe."""
        latest = self.targets.latest
        if self.chaser is None or latest is None:
            return
        lead = self.scenario.guidance.command_lead_s
        t_c, r, v = self.chaser
        t_burn = max(t, t_c) + lead
        state = cw_transition_matrix(self.n, t_burn - t_c) @ np.concatenate((r, v))
        sphere = self.scenario.planner.restriction_sphere_radius_m + self.scenario.guidance.sphere_margin_m
        if np.linalg.norm(state[:3]) < sphere:
            self.emit(t, 'WARN', 'no_avoidance_burn', 'inside the restriction sphere: coasting, never thrusting', {})
            return
        t_t, q_hb, omega_body = latest[1]
        region = swept_region(self.scenario.boxes, self.scenario.target_inertia, [q_eci_from_body(t_t, self.n, q_hb)],
                              [omega_body])
        dv, before, after = avoidance_burn(state[:3], state[3:], t_burn, region, self.planner_config,
                                           self.scenario.supervisor.avoidance_delta_v_mps)
        if dv is None:
            self.emit(t, 'OK', 'no_avoidance_burn', f'the coast is passively safe (least clearance {before:.2f} m)',
                      {'clearance_m': before})
            return
        self.pub_maneuver.publish(convert.vector3_stamped(t_burn, c.FRAME_HILL, dv))
        self.emit(t, 'WARN', 'avoidance_burn', f'coast would come {before:.2f} m from the keep-out region; '
                                               f'burn of {np.linalg.norm(dv):.3f} m/s at t = {t_burn:.2f} s '
                                               f'keeps {after:.2f} m', {'dv_hill_mps': [float(x) for x in dv]})

    # -- outputs --------------------------------------------------------------------------------
    def apply(self, transitions):
        for tr in transitions:
            self.pub_phase.publish(convert.string(tr.phase_to))
            self.emit(tr.t, _LEVEL_OF.get(tr.phase_to, 'OK'), 'phase_changed',
                      f'{tr.phase_from} -> {tr.phase_to}: {tr.reason}',
                      {'from': tr.phase_from, 'to': tr.phase_to, **tr.values})
            if tr.phase_to == c.PHASE_ABORTED and tr.phase_from in (
                    c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH, c.PHASE_TRAJECTORY_ADJUST):
                self.escape_burn(tr.t)

    def emit(self, t, level, name, message, values):
        publish_event(self, self.pub_events, t, level, name, message, values, log_ok=True)


def main(args=None):
    main_for(SupervisorNode, args)


if __name__ == '__main__':
    main()
