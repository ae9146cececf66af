"""The guidance node with real nodes: it flies a published plan with eq 28 impulses and stays quiet when told."""

import numpy as np
from rclpy.node import Node
from rclpy.parameter import Parameter

from flyby_guidance.guidance_node import GuidanceNode
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, qos
from flyby_planner.flyby.config import PlannerConfig, truth_prediction
from flyby_planner.flyby.search import plan_capture
from flyby_planner.transfer import terminal_impulses
from flyby_sim.dynamics.orbital import cw_coast
from flyby_sim.scenario import load_scenario
from flyby_testing import SCENARIOS, collect, spin_for, spin_until

SCENARIO = SCENARIOS / 'paper_flyby.yaml'
T_PLAN = 30.0


class PlanProbe(Node):
    """Plays the planner (a plan of the true state at T_PLAN) and the estimator (true chaser states)."""

    def __init__(self, context):
        super().__init__('plan_probe', context=context)
        self.scenario = load_scenario(SCENARIO)
        cfg = PlannerConfig.from_scenario(self.scenario)
        x = self.chaser_state(T_PLAN)
        truth = truth_prediction(self.scenario, T_PLAN + cfg.prediction_span_s(self.scenario.omega_body0_rad_s))
        self.plan = plan_capture(truth, x[:3], x[3:], T_PLAN, cfg)
        self.pubs = {t: self.create_publisher(c.message_class(c.TOPIC_TYPES[t]), t, qos.qos_for(t))
                     for t in (c.PLANNER_FLYBY_INITIAL, c.PLANNER_FLYBY_TARGET, c.PLANNER_PATH, c.EST_CHASER_ODOM,
                               c.MISSION_PHASE)}
        self.maneuvers = collect(self, c.GUIDANCE_MANEUVER)
        self.events = collect(self, c.MISSION_EVENTS)

    def chaser_state(self, t):
        sc = self.scenario
        return cw_coast(sc.chaser.initial_position_hill_m, sc.chaser.initial_velocity_hill_mps, t, sc.mean_motion_rad_s)

    def publish_plan(self):
        s = self.plan.selected
        ident = (0.0, 0.0, 0.0, 1.0)
        self.pubs[c.PLANNER_FLYBY_TARGET].publish(convert.odometry(s.t_grasp, c.FRAME_HILL, c.FRAME_CHASER_BODY, s.x_ft,
                                                                   ident, s.v_ft, (0.0, 0.0, 0.0)))
        self.pubs[c.PLANNER_FLYBY_INITIAL].publish(convert.odometry(s.t_i, c.FRAME_HILL, c.FRAME_CHASER_BODY, s.x_fi,
                                                                    ident, s.v_fi, (0.0, 0.0, 0.0)))
        self.pubs[c.PLANNER_PATH].publish(convert.path(T_PLAN, c.FRAME_HILL, self.plan.path_t, self.plan.path_r_hill))

    def stream(self, executor, t0, t1):
        """Chaser estimates every 0.1 s of sim time over [t0, t1), spinning in between."""
        for t in np.arange(t0, t1, 0.1):
            x = self.chaser_state(t)
            self.pubs[c.EST_CHASER_ODOM].publish(convert.odometry(t, c.FRAME_HILL, c.FRAME_CHASER_BODY, x[:3],
                                                                  (0.0, 0.0, 0.0, 1.0), x[3:], (0.0, 0.0, 0.0)))
            executor.spin_once(timeout_sec=0.01)


def _start(ros_context, executor):
    guidance = GuidanceNode(context=ros_context, parameter_overrides=[Parameter('scenario_file', value=str(SCENARIO))])
    probe = PlanProbe(ros_context)
    executor.add_node(guidance)
    executor.add_node(probe)
    spin_until(executor, lambda: all(p.get_subscription_count() > 0 for p in probe.pubs.values()))
    spin_for(executor, 1.0)  # a large latched message (the path) sent right at matching can be lost
    return probe


def test_flies_the_plan_with_the_eq28_transfer_burn(ros_context, executor):
    probe = _start(ros_context, executor)
    probe.publish_plan()
    spin_until(executor, lambda: any(e['name'] == 'guidance_started'
                                     for m in probe.events for e in convert.events_from_msg(m)))
    s = probe.plan.selected
    probe.stream(executor, T_PLAN, s.t_ti + 0.05)
    spin_until(executor, lambda: probe.maneuvers)
    t_burn, dv = convert.vector3_stamped_to_numpy(probe.maneuvers[0])
    assert t_burn == s.t_ti
    # Same chaser state and target as the plan: the burn is the plan's eq 28 impulse.
    x = probe.chaser_state(s.t_ti)
    expected, _ = terminal_impulses(x[:3], x[3:], s.x_fi, s.v_fi, s.t_i - s.t_ti, probe.scenario.mean_motion_rad_s)
    np.testing.assert_allclose(dv, expected, atol=1e-9)
    np.testing.assert_allclose(dv, s.dv_ti, atol=1e-9)
    commanded = [e for m in probe.events for e in convert.events_from_msg(m) if e['name'] == 'maneuver_commanded']
    assert commanded[0]['values']['kind'] == 'transfer'


def test_commands_nothing_once_escaping(ros_context, executor):
    probe = _start(ros_context, executor)
    probe.pubs[c.MISSION_PHASE].publish(convert.string(c.PHASE_ESCAPE))
    probe.publish_plan()
    s = probe.plan.selected
    probe.stream(executor, T_PLAN, s.t_ti + 5.0)
    spin_for(executor, 0.5)
    assert not probe.maneuvers
