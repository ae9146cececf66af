"""An exception in a core callback becomes one ERROR node_error event and ends the mission on the safe path.

The guard of node_base.CoreNode with a real node around a core that raises; the supervisor core's answer to a
node_error (the abort path); and the graph, every node real and in this process, with a planner core that raises
while it plans: the run ends ABORTED, safe, with the event in the bag (docs/runtime.md).
"""

import numpy as np
import pytest
from rclpy.node import Node
from std_srvs.srv import Trigger

from flyby_mission.abort_escape import AvoidanceBurn
from flyby_mission.supervisor import SupervisorCore, SupervisorParams, Transition
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, events, qos
from flyby_msgs_py.bag import bag_topics, read_bag
from flyby_msgs_py.core_guard import CoreGuard
from flyby_msgs_py.node_base import CoreNode
from flyby_msgs_py.runtime import publish_event
from flyby_msgs_py.wire import Event, wire_event
from flyby_sim.dynamics.rotation import quat_rotate
from flyby_sim.scenario import load_scenario
from flyby_testing import SCENARIOS, collect, spin_for, spin_until, write_scenario

SERVICE = 'test_core/poke'


class FragileCore:
    """A core without ROS that reports each target estimate and raises at the one stamped ``t_fault``."""

    def __init__(self, t_fault):
        self.t_fault = t_fault
        self.calls = []

    def on_target_estimate(self, t, q_hill_from_body, omega_body):
        self.calls.append(t)
        if t == self.t_fault:
            raise ZeroDivisionError('the filter divided by zero')
        return [Event(t, 'OK', events.TARGET_CONVERGED, f'estimate of t = {t}', {})]

    def on_chaser_estimate(self, t, r_hill, v_hill):
        self.calls.append(t)
        return [Event(t, 'OK', events.TARGET_REFINED, f'chaser estimate of t = {t}', {})]

    def poke(self):
        self.calls.append('poke')
        return [Event(0.0, 'OK', events.PLAN_KEPT, 'poked', {})]


class FragileNode(CoreNode):
    """The shell of a core node: estimates in, events out, and a service that reaches the core."""

    def __init__(self, core, **kwargs):
        super().__init__('fragile_node', **kwargs)
        self.core = core
        self.pub_events = self.publisher(c.MISSION_EVENTS)
        self.subscribe_estimates(quat_rotate)
        self.create_service(Trigger, SERVICE, self.guard(self.on_poke, SERVICE, service=True))

    def on_poke(self, _request, response):
        self.publish(self.core.poke())
        response.success = True
        return response

    def publish(self, outputs):
        for out in outputs:
            publish_event(self, self.pub_events, out)


class Probe(Node):
    """Plays the estimator and listens to mission/events."""

    def __init__(self, context):
        super().__init__('probe', context=context)
        self.pubs = {t: self.create_publisher(c.message_class(c.TOPIC_TYPES[t]), t, qos.qos_for(t))
                     for t in (c.EST_TARGET_ODOM, c.EST_CHASER_ODOM)}
        self.events = collect(self, c.MISSION_EVENTS)
        self.poke = self.create_client(Trigger, SERVICE)

    def target(self, t):
        self.pubs[c.EST_TARGET_ODOM].publish(convert.odometry(
            t, c.FRAME_HILL, c.FRAME_TARGET_BODY, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0),
            (0.0, 0.0, 0.1)))

    def chaser(self, t):
        self.pubs[c.EST_CHASER_ODOM].publish(convert.odometry(
            t, c.FRAME_HILL, c.FRAME_CHASER_BODY, (50.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0),
            (0.0, 0.0, 0.0)))

    def received(self):
        return [e for m in self.events for e in convert.events_from_msg(m)]

    def call_poke(self, executor):
        future = self.poke.call_async(Trigger.Request())
        spin_until(executor, future.done)
        return future.result()


def test_an_exception_in_a_core_callback_is_one_error_event_and_the_core_is_fed_no_more(ros_context, executor):
    core = FragileCore(t_fault=2.0)
    node = FragileNode(core, context=ros_context)
    probe = Probe(ros_context)
    executor.add_node(node)
    executor.add_node(probe)
    spin_until(executor, lambda: all(p.get_subscription_count() > 0 for p in probe.pubs.values())
               and probe.poke.service_is_ready())

    assert probe.call_poke(executor).success
    probe.target(1.0)
    spin_until(executor, lambda: len(probe.received()) == 2)
    probe.target(2.0)  # the core raises
    spin_until(executor, lambda: len(probe.received()) == 3)
    probe.target(3.0)
    probe.chaser(4.0)
    refused = probe.call_poke(executor)
    spin_for(executor, 0.5)

    got = probe.received()
    assert [e['name'] for e in got] == [events.PLAN_KEPT, events.TARGET_CONVERGED, events.NODE_ERROR]
    error = got[-1]
    assert error['level'] == 'ERROR' and error['source'] == 'fragile_node'
    assert error['t'] == 2.0  # the stamp of the estimate being handled
    assert error['message'] == 'fragile_node: ZeroDivisionError: the filter divided by zero'
    assert error['values'] == {'node': 'fragile_node', 'exception': 'ZeroDivisionError',
                               'callback': c.EST_TARGET_ODOM}
    # Fenced off: neither the later estimates nor the service reach the core; the service says why.
    assert core.calls == ['poke', 1.0, 2.0]
    assert not refused.success and refused.message == error['message']
    assert node.core_guard.failed.name == events.NODE_ERROR


def test_the_guard_event_names_the_node_the_exception_and_the_callback():
    guard = CoreGuard('flyby_planner')
    assert guard.failed is None
    event = guard.fail(61.25, c.EST_TARGET_ODOM, RuntimeError('no grasp window'))
    assert event == Event(61.25, 'ERROR', events.NODE_ERROR, 'flyby_planner: RuntimeError: no grasp window',
                          {'node': 'flyby_planner', 'exception': 'RuntimeError', 'callback': c.EST_TARGET_ODOM},
                          'flyby_planner')
    assert guard.failed is event


def _approaching_core(sc):
    """A supervisor core in TERMINAL_APPROACH at t = 100 s, the chaser 20 m out heading at the target."""
    core = SupervisorCore(SupervisorParams.from_scenario(sc))
    core.machine.phase, core.machine.t_i = c.PHASE_TERMINAL_APPROACH, 500.0
    core.on_target_estimate(100.0, sc.q_hill_from_body0, sc.omega_body0_rad_s)
    core.on_chaser_estimate(100.0, np.array((20.0, 0.0, 0.0)), np.array((-0.2, 0.0, 0.0)))
    for node in core.machine.watched_nodes:
        core.on_progress(node, 100.0)
    core.on_clock(100.0)
    return core


def test_the_supervisor_aborts_on_a_node_error_of_any_node_as_on_an_abort():
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    error = wire_event(CoreGuard('flyby_planner').fail(100.0, c.EST_TARGET_ODOM, RuntimeError('boom')))
    core = _approaching_core(sc)
    out = core.on_event(error)  # the planner is not a watched node: a node_error is a fault all the same
    transition = out[0]
    assert isinstance(transition, Transition) and transition.phase_to == c.PHASE_ABORTED
    assert transition.reason == 'node_error: flyby_planner: RuntimeError: boom'
    assert core.phase == c.PHASE_ABORTED
    changed = out[1]
    assert changed.level == 'ERROR' and changed.name == events.PHASE_CHANGED
    assert changed.message == f'{c.PHASE_TERMINAL_APPROACH} -> {c.PHASE_ABORTED}: {transition.reason}'
    # The rest is the abort path's own: the same avoidance burn and its event.
    _, aborted = _approaching_core(sc).abort('abort requested')
    assert any(isinstance(o, AvoidanceBurn) for o in out)
    assert repr(out[2:]) == repr(aborted[2:])
    # Only in an active phase, and never the supervisor's own event.
    core = _approaching_core(sc)
    core.machine.phase = c.PHASE_CAPTURE
    assert core.on_event(error) == []
    core = _approaching_core(sc)
    assert core.on_event(error._replace(source=core.name)) == []


@pytest.fixture
def faulty_planner(monkeypatch):
    """The planner node builds a core that raises where it would plan."""
    from flyby_planner import planner_node

    class FaultyPlannerCore(planner_node.PlannerCore):
        def _plan(self, t, *args, **kwargs):
            raise RuntimeError(f'injected planner fault at t = {t:.2f} s')

    monkeypatch.setattr(planner_node, 'PlannerCore', FaultyPlannerCore)


def _short_planning(data):
    """paper_flyby planning after 20 s of observation, the abort observed for 10 s."""
    data['planner']['min_observation_s'] = 20.0
    data.setdefault('supervisor', {})['abort_observation_s'] = 10.0
    data['simulation']['duration_s'] = 300.0


def test_a_planner_exception_ends_a_graph_run_safely_with_the_event_in_the_bag(tmp_path, monkeypatch, faulty_planner):
    from flyby_mission.launcher import LaunchOptions, run
    from flyby_mission.summary import EXIT_CODES

    for name in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'FASTRTPS_DEFAULT_PROFILES_FILE'):
        monkeypatch.setenv(name, '')  # the launcher sets them for its run; restored afterwards
    scenario = write_scenario(tmp_path, edit=_short_planning)
    out = tmp_path / 'run'
    summary = run(LaunchOptions(scenario=str(scenario), out=str(out), in_process=True, quiet=True,
                                wall_timeout=600.0))

    assert summary['outcome'] == c.OUTCOME_ABORTED and summary['final_phase'] == c.PHASE_ABORTED
    assert EXIT_CODES[summary['outcome']] == 3  # safe, no capture
    assert summary['min_clearance_m'] > 0.0 and not summary['thrust_inside_restriction_sphere']
    recorded = read_bag(out / 'bag', topics=['/mission/events', '/mission/phase'])
    got = recorded['/mission/events']
    errors = [e for e in got if e['name'] == events.NODE_ERROR]
    assert len(errors) == 1
    error = errors[0]
    assert error['level'] == 'ERROR' and error['values']['node'] == 'flyby_planner'
    assert error['values']['exception'] == 'RuntimeError' and 'injected planner fault' in error['message']
    aborted = [e for e in got if e['name'] == events.PHASE_CHANGED and e['values'].get('to') == c.PHASE_ABORTED]
    assert len(aborted) == 1 and aborted[0]['values']['from'] == c.PHASE_PLANNING
    assert aborted[0]['t'] == error['t'] and 'node_error: flyby_planner: RuntimeError' in aborted[0]['message']
    assert list(recorded['/mission/phase'].data)[-1] == c.PHASE_ABORTED
    # Nothing more from the planner: no plan, no event after its error.
    counts = bag_topics(out / 'bag')
    assert all(counts.get(c.absolute(t), ('', 0))[1] == 0 for t in (c.PLANNER_PATH, c.PLANNER_FLYBY_TARGET))
    assert [e for e in got if e['hardware_id'] == 'flyby_planner' and e['t'] >= error['t']] == [error]


@pytest.fixture
def faulty_guidance(monkeypatch):
    """The guidance node builds a core that raises at its first chaser estimate from 30 s on."""
    from flyby_guidance import guidance_node

    class FaultyGuidanceCore(guidance_node.GuidanceCore):
        def on_chaser_estimate(self, t, *args, **kwargs):
            if t >= 30.0:
                raise FloatingPointError(f'injected guidance fault at t = {t:.2f} s')
            return super().on_chaser_estimate(t, *args, **kwargs)

    monkeypatch.setattr(guidance_node, 'GuidanceCore', FaultyGuidanceCore)


def _short_6dof(data):
    data.setdefault('supervisor', {})['abort_observation_s'] = 10.0
    data['simulation']['duration_s'] = 200.0


def test_a_guidance_exception_on_the_command_chain_holds_the_simulator_no_more(tmp_path, monkeypatch,
                                                                               faulty_guidance):
    """The six-degree-of-freedom chaser's simulator waits for guidance's attitude commands; once guidance's core has
    failed it waits no more (node_lost), and the mission ends ABORTED on the supervisor's clock, not on the
    launcher's wall-clock timeout."""
    from flyby_mission.launcher import LaunchOptions, run

    for name in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'FASTRTPS_DEFAULT_PROFILES_FILE'):
        monkeypatch.setenv(name, '')
    scenario = write_scenario(tmp_path, base='paper_flyby_6dof', edit=_short_6dof)
    out = tmp_path / 'run'
    summary = run(LaunchOptions(scenario=str(scenario), out=str(out), in_process=True, quiet=True,
                                wall_timeout=300.0))

    assert summary['outcome'] == c.OUTCOME_ABORTED and summary['end_reason'] == f'phase {c.PHASE_ABORTED}'
    got = read_bag(out / 'bag', topics=['/mission/events'])['/mission/events']
    error = [e for e in got if e['name'] == events.NODE_ERROR]
    assert len(error) == 1 and error[0]['values']['node'] == 'flyby_guidance'
    lost = [e for e in got if e['name'] == events.NODE_LOST and e['hardware_id'] == 'flyby_sim']
    assert len(lost) == 1 and lost[0]['values']['nodes'] == 'flyby_guidance'
    assert summary['min_clearance_m'] > 0.0
