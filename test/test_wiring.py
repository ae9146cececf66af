"""One table wires the graph and the headless driver (flyby_msgs_py.wiring).

Every node, built for real in its own ROS domain, subscribes to exactly the contract topics the table gives it for
the scenario (the point-mass fly-by, the six-degree-of-freedom chaser, the tug after the capture); the headless
driver hands each topic to the same nodes in the table's order, and has a core input for every pair."""

import importlib

import pytest
from rclpy.parameter import Parameter

from flyby_mission.headless import CORE_INPUTS, HeadlessGraph
from flyby_msgs_py import contract as c
from flyby_msgs_py import wiring
from flyby_sim.scenario import load_scenario
from flyby_testing import SCENARIOS

NODE_CLASSES = {
    wiring.ESTIMATOR: ('flyby_estimation.estimator_node', 'EstimatorNode'),
    wiring.PLANNER: ('flyby_planner.planner_node', 'PlannerNode'),
    wiring.GUIDANCE: ('flyby_guidance.guidance_node', 'GuidanceNode'),
    wiring.SUPERVISOR: ('flyby_mission.supervisor_node', 'SupervisorNode'),
    wiring.SIM: ('flyby_sim.sim_node', 'SimNode'),
}
SCENARIO_NAMES = ('paper_flyby', 'paper_flyby_6dof', 'paper_flyby_tug')
CONTRACT_TOPICS = {c.absolute(t) for t in c.TOPIC_TYPES}


def _subscribed(node):
    """The contract topics a node subscribes to (absolute names)."""
    return {s.topic_name for s in node.subscriptions} & CONTRACT_TOPICS


@pytest.mark.parametrize('name', SCENARIO_NAMES)
@pytest.mark.parametrize('node_name', list(NODE_CLASSES))
def test_each_node_subscribes_to_the_topics_the_table_gives_it(ros_context, name, node_name):
    path = SCENARIOS / f'{name}.yaml'
    module, cls = NODE_CLASSES[node_name]
    params = {'scenario_file': str(path)}
    if node_name == wiring.SIM:  # the simulator waits for the command chain: it then reads its node_errors
        params['keep_up_with'] = [wiring.ESTIMATOR, wiring.GUIDANCE]
    node = getattr(importlib.import_module(module), cls)(
        context=ros_context, parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
    try:
        expected = {c.absolute(t) for t in wiring.topics_of(node_name, load_scenario(path))}
        assert _subscribed(node) == expected
    finally:
        node.destroy_node()


@pytest.mark.parametrize('name', SCENARIO_NAMES)
def test_the_headless_driver_routes_by_the_same_table(name):
    scenario = load_scenario(SCENARIOS / f'{name}.yaml')
    graph = HeadlessGraph(scenario)
    for topic in wiring.SUBSCRIPTIONS:
        assert graph.subscribers[topic] == wiring.subscribers(topic, scenario)
        for node in graph.subscribers[topic]:
            assert node == wiring.SIM or (node, topic) in CORE_INPUTS


def test_every_core_input_of_the_headless_driver_is_a_subscription_of_the_table():
    for node, topic in CORE_INPUTS:
        assert node in [n for n, _ in wiring.SUBSCRIPTIONS[topic]], (node, topic)
