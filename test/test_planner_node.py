"""The planner node with real nodes: it plans on PLANNING and on a replan request, and refuses with the reason."""

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, qos
from flyby_planner.flyby.config import PlannerConfig, truth_prediction
from flyby_planner.flyby.search import plan_capture
from flyby_planner.planner_node import PlannerNode
from flyby_sim.dynamics.orbital import cw_coast
from flyby_sim.dynamics.rotation import quat_rotate
from flyby_sim.scenario import load_scenario
from flyby_testing import SCENARIOS, collect, spin_for, spin_until, write_scenario


class EstimateProbe(Node):
    """Plays the estimator (true states as estimates) and the supervisor's phase; listens to the planner."""

    def __init__(self, context, scenario):
        super().__init__('estimate_probe', context=context)
        self.scenario = scenario
        self.truth = truth_prediction(scenario, 3000.0)
        self.pub_target, self.pub_chaser, self.pub_events, self.pub_phase = (
            self.create_publisher(c.message_class(c.TOPIC_TYPES[t]), t, qos.qos_for(t))
            for t in (c.EST_TARGET_ODOM, c.EST_CHASER_ODOM, c.MISSION_EVENTS, c.MISSION_PHASE))
        self.received = {t: collect(self, t) for t in (
            c.PLANNER_GRASP, c.PLANNER_FLYBY_TARGET, c.PLANNER_FLYBY_INITIAL, c.PLANNER_PATH, c.MARKERS,
            c.MISSION_EVENTS)}
        self.replan = self.create_client(Trigger, c.PLANNER_REPLAN_SERVICE)

    def chaser_state(self, t):
        sc = self.scenario
        return cw_coast(sc.chaser.initial_position_hill_m, sc.chaser.initial_velocity_hill_mps, t, sc.mean_motion_rad_s)

    def send_estimates(self, t):
        x = self.chaser_state(t)
        self.pub_chaser.publish(convert.odometry(t, c.FRAME_HILL, c.FRAME_CHASER_BODY, x[:3], (0.0, 0.0, 0.0, 1.0),
                                                 x[3:], (0.0, 0.0, 0.0)))
        s = self.truth.state(t)
        self.pub_target.publish(convert.odometry(t, c.FRAME_HILL, c.FRAME_TARGET_BODY, (0.0, 0.0, 0.0),
                                                 s.q_hill_from_body, (0.0, 0.0, 0.0), s.omega_body))

    def stream_until(self, executor, predicate, t0):
        """Send estimates every 0.1 s of sim time from t0 until predicate() (as the estimator would)."""
        t = [t0]

        def tick():
            self.send_estimates(t[0])
            t[0] += 0.1
            return 0.01
        spin_until(executor, predicate, tick=tick)

    def enter_planning(self, t):
        """What the supervisor publishes when it turns the mission to PLANNING at t: the phase and its event."""
        self.pub_phase.publish(convert.string(c.PHASE_PLANNING))
        self.pub_events.publish(convert.event(t, 'OK', 'phase_changed', 'ESTIMATION -> PLANNING: test',
                                              {'from': c.PHASE_ESTIMATION, 'to': c.PHASE_PLANNING},
                                              source='flyby_supervisor'))

    def events(self, name):
        return [e for m in self.received[c.MISSION_EVENTS] for e in convert.events_from_msg(m) if e['name'] == name]


def _start(ros_context, executor, scenario_path):
    planner = PlannerNode(context=ros_context,
                          parameter_overrides=[Parameter('scenario_file', value=str(scenario_path))])
    probe = EstimateProbe(ros_context, load_scenario(scenario_path))
    executor.add_node(planner)
    executor.add_node(probe)
    spin_until(executor, lambda: all(p.get_subscription_count() > 0 for p in
                                     (probe.pub_target, probe.pub_chaser, probe.pub_events, probe.pub_phase)))
    return planner, probe


def test_plans_on_planning_phase_and_on_replan_like_the_core(ros_context, executor):
    scenario_path = SCENARIOS / 'paper_flyby.yaml'
    _, probe = _start(ros_context, executor, scenario_path)
    probe.send_estimates(29.9)  # no request yet: no plan
    spin_for(executor, 1.0)
    assert not probe.events('plan_selected')

    probe.enter_planning(30.0)
    probe.stream_until(executor, lambda: probe.events('plan_selected') and probe.received[c.MARKERS], 30.0)

    selected = probe.events('plan_selected')[0]
    t_plan = selected['t']
    assert t_plan == pytest.approx(30.0)  # the first target estimate stamped at or after the request
    sc = load_scenario(scenario_path)
    cfg = PlannerConfig.from_scenario(sc)
    x = probe.chaser_state(t_plan)
    truth = truth_prediction(sc, t_plan + cfg.prediction_span_s(sc.omega_body0_rad_s))
    core = plan_capture(truth, x[:3], x[3:], t_plan, cfg)
    chosen = core.selected
    assert selected['values']['request'] == 'phase PLANNING'
    assert float(selected['values']['t_grasp_s']) == pytest.approx(chosen.t_grasp, abs=1e-3)
    assert len(probe.events('plan_candidate')) == len(core.candidates)

    grasp = convert.odometry_to_numpy(probe.received[c.PLANNER_GRASP][0])
    assert grasp.t == pytest.approx(chosen.t_grasp, abs=1e-6)
    np.testing.assert_allclose(grasp.position, chosen.x_g, atol=1e-6)
    # nav_msgs' rule: the twist is in the child frame (the target's body axes at t_g), rotated into hill here.
    np.testing.assert_allclose(quat_rotate(grasp.orientation_xyzw, grasp.linear), chosen.v_g, atol=1e-7)
    assert grasp.child_frame_id == 'grasp_point'
    target = convert.odometry_to_numpy(probe.received[c.PLANNER_FLYBY_TARGET][0])
    np.testing.assert_allclose(target.position, chosen.x_ft, atol=1e-6)
    np.testing.assert_allclose(target.linear, chosen.v_ft, atol=1e-7)  # child frame aligned with hill
    initial = convert.odometry_to_numpy(probe.received[c.PLANNER_FLYBY_INITIAL][0])
    assert initial.t == pytest.approx(chosen.t_i, abs=1e-6)
    np.testing.assert_allclose(initial.linear, chosen.v_fi, atol=1e-7)
    path = convert.path_to_numpy(probe.received[c.PLANNER_PATH][0])
    assert len(path.times) == len(core.path_t) and path.times[0] == pytest.approx(t_plan)
    namespaces = [m.ns for m in probe.received[c.MARKERS][0].markers]
    assert namespaces.count('keep_out') == 3 and 'restriction_sphere' in namespaces and 'path' in namespaces

    assert probe.replan.wait_for_service(timeout_sec=5.0)
    future = probe.replan.call_async(Trigger.Request())
    spin_until(executor, future.done)
    assert future.result().success
    probe.stream_until(executor, lambda: len(probe.events('plan_selected')) == 2, 40.0)
    assert probe.events('plan_selected')[1]['values']['request'] == 'replan requested'


def test_refuses_a_spin_along_hill_y_with_the_reason(ros_context, executor, tmp_path):
    scenario_path = write_scenario(tmp_path, edit=lambda d: d['target']['initial_attitude']['body_axis_along_hill']
                                   .update(hill=[0.0, 1.0, 0.0]))
    _, probe = _start(ros_context, executor, scenario_path)
    probe.enter_planning(30.0)
    probe.stream_until(executor, lambda: probe.events('plan_refused'), 30.0)
    refused = probe.events('plan_refused')[0]
    assert refused['level'] == 'ERROR' and 'condition (b)' in refused['message']
    assert not probe.received[c.PLANNER_GRASP]
