"""Which node takes which contract topic: one table that wires the node graph and the headless driver alike.

Each node subscribes to the topics ``topics_of(node, scenario)`` gives it and to no other contract topic
(``flyby_msgs_py.node_base.CoreNode.subscribe`` refuses one it is not given); the headless driver
(``flyby_mission.headless``) hands each output of a core to ``subscribers(topic, scenario)``, in the order the table
lists them. So a topic a node does not read in the graph never reaches its core headless either, and the other way
round. Some subscriptions depend on the scenario (the six-degree-of-freedom chaser's command chain, the phases after
the capture): ``when`` says so. No ROS here.
"""

from flyby_msgs_py import contract as c

ESTIMATOR = 'flyby_estimator'
PLANNER = 'flyby_planner'
GUIDANCE = 'flyby_guidance'
SUPERVISOR = 'flyby_supervisor'
SIM = 'flyby_sim'
CAM = 'flyby_cam_monitor'  # the independent collision-avoidance monitor (flyby_mission.cam_monitor)
NODES = (SUPERVISOR, PLANNER, ESTIMATOR, GUIDANCE, CAM, SIM)


def always(_scenario):
    return True


def rigid(scenario):
    """The six-degree-of-freedom chaser (attitude, wheels, body-fixed thrusters, IMU)."""
    return scenario.chaser.model == 'rigid_body'


def post_capture(scenario):
    """A scenario with phases after the capture (grasp, damping, mass properties, transport)."""
    return scenario.post_capture is not None


# topic -> ((node, when), ...): the nodes whose core takes the topic, in the order the headless driver delivers it.
SUBSCRIPTIONS = {
    c.SENSOR_RELATIVE_POSITION: ((ESTIMATOR, always), (CAM, always)),
    c.SENSOR_TARGET_ATTITUDE: ((ESTIMATOR, always), (CAM, always)),
    c.SENSOR_CHASER_IMU: ((ESTIMATOR, rigid), (CAM, rigid)),
    c.SENSOR_CHASER_WHEELS: ((ESTIMATOR, rigid),),  # the wheel monitor (flyby_estimation.health)
    c.EST_TARGET_ODOM: ((SUPERVISOR, always), (PLANNER, always), (GUIDANCE, always)),
    c.EST_CHASER_ODOM: ((SUPERVISOR, always), (PLANNER, always), (GUIDANCE, always)),
    c.EST_TARGET_INERTIA: (),  # recorded; its numbers reach guidance as the mass_properties_estimated event
    c.PLANNER_FLYBY_TARGET: ((GUIDANCE, always), (SIM, always)),  # the simulator holds the capture decision for it
    c.PLANNER_FLYBY_INITIAL: ((GUIDANCE, always),),
    c.PLANNER_PATH: ((GUIDANCE, always),),
    c.PLANNER_TRAJECTORY: ((GUIDANCE, rigid),),
    c.GUIDANCE_MANEUVER: ((SIM, always), (ESTIMATOR, always)),
    c.GUIDANCE_WHEELS: ((SIM, rigid), (ESTIMATOR, rigid)),
    c.GUIDANCE_WRENCH: ((SIM, rigid), (ESTIMATOR, rigid)),
    c.MISSION_PHASE: ((PLANNER, always), (GUIDANCE, always), (ESTIMATOR, always), (CAM, always), (SIM, always)),
    c.SAFETY_CAM: ((SIM, always), (ESTIMATOR, always)),  # the estimator's monitors: thrust no chain commanded
    # The simulator reads a command-chain node's or the supervisor's node_error (it holds time for their commands or
    # decisions no more), the phase_changed stamps (the faults that start with a phase) and thrusters_isolated; guidance
    # the supervisor's node_error (propulsion idled), a wheel fault's wheels_reallocated and after the capture the arm's
    # lock and the mass-property estimates.
    c.MISSION_EVENTS: ((SUPERVISOR, always), (PLANNER, always), (ESTIMATOR, post_capture),
                       (GUIDANCE, always), (SIM, always)),
}


def subscribers(topic, scenario):
    """The nodes whose core takes ``topic`` in this scenario, in delivery order."""
    return tuple(node for node, when in SUBSCRIPTIONS.get(topic, ()) if when(scenario))


def topics_of(node, scenario):
    """The contract topics ``node`` subscribes to in this scenario, in the table's order."""
    return tuple(topic for topic, entries in SUBSCRIPTIONS.items()
                 if any(name == node and when(scenario) for name, when in entries))
