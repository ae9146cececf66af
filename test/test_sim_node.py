"""The simulator node in-process with a test node: time-tagged maneuvers and bad commands."""

import json
import math
import time

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import String

from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, events, qos
from flyby_msgs_py.bag import bag_topics
from flyby_msgs_py.runtime import READY_TOPIC, announce_ready, run_loop
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario
from flyby_sim.sim_node import SimNode
from flyby_testing import collect, run_mission, spin_until, with_duration, write_scenario

G0 = 9.80665


class Probe(Node):
    """Sends maneuvers and records what the simulator publishes."""

    def __init__(self, context):
        super().__init__('probe', context=context)
        self.maneuvers = self.create_publisher(
            c.message_class(c.TOPIC_TYPES[c.GUIDANCE_MANEUVER]), c.GUIDANCE_MANEUVER, qos.QOS_STREAM)
        self.thrust = collect(self, c.SIM_CHASER_THRUST)
        self.odom = collect(self, c.SIM_CHASER_ODOM)
        self.events = collect(self, c.MISSION_EVENTS)

    def send(self, t, dv_hill):
        msg = c.message_class(c.TOPIC_TYPES[c.GUIDANCE_MANEUVER])()
        msg.header.stamp = convert.sec_to_stamp(t)
        msg.header.frame_id = c.FRAME_HILL
        msg.vector.x, msg.vector.y, msg.vector.z = (float(v) for v in dv_hill)
        self.maneuvers.publish(msg)

    def event_names(self):
        return [e['name'] for m in self.events for e in convert.events_from_msg(m)]


def zero_errors(data):
    data['chaser']['thrusters']['magnitude_error_sigma'] = 0.0
    data['chaser']['thrusters']['direction_error_sigma_deg'] = 0.0
    data['simulation']['duration_s'] = 30.0


@pytest.fixture
def started(ros_context, executor, tmp_path):
    """A simulator (no thruster errors) and a probe on one executor, time started."""
    scenario_path = write_scenario(tmp_path, edit=zero_errors)
    probe = Probe(ros_context)
    announcer = announce_ready(probe)
    sim = SimNode(context=ros_context, parameter_overrides=[
        Parameter('scenario_file', value=str(scenario_path)),
        Parameter('wait_for_nodes', value=['probe'])])
    executor.add_node(sim)
    executor.add_node(probe)

    def tick():
        announcer.update()  # the probe's maneuver publisher announces its match with the simulator
        return sim.tick()
    spin_until(executor, lambda: sim.started, 10.0, tick)
    return scenario_path, sim, probe


def run_sim(executor, sim, probe, until_s):
    """Step the simulator until ``until_s``, handling every message each step caused."""
    run_loop(executor, [sim, probe], lambda: sim.plant.t >= until_s - 1e-9, drain=True)


def test_time_tagged_maneuver_starts_at_its_stamp_and_delivers_its_dv(started, executor):
    scenario_path, sim, probe = started
    dv_cmd = np.array([0.05, -0.02, 0.03])
    t_burn = 5.0
    probe.send(t_burn, dv_cmd)
    run_sim(executor, sim, probe, 15.0)

    t_thrust = np.array([convert.stamp_to_sec(m.header.stamp) for m in probe.thrust])
    force = np.array([[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z] for m in probe.thrust])
    firing = t_thrust[np.linalg.norm(force, axis=1) > 0]
    step = sim.step_s
    assert t_burn < firing[0] <= t_burn + step + 1e-9  # starts in the step that contains its stamp

    # The node's truth is the core's: a twin plant given the same command agrees to the bit.
    scenario = load_scenario(scenario_path)
    twin = Plant(PlantConfig.from_scenario(scenario))
    twin.command_maneuver(t_burn, dv_cmd)
    while twin.t < 15.0 - 1e-9:
        sample = twin.step()
    last = convert.odometry_to_numpy(probe.odom[-1])
    assert last.t == pytest.approx(sample.t)
    assert np.array_equal(last.position, sample.r_hill)
    assert np.array_equal(last.linear, sample.v_hill)
    # Force x step is the impulse: the delivered delta-v is the command (no errors configured).
    m0 = scenario.chaser.mass_kg
    impulse = np.sum(force, axis=0) * step
    mean_mass = m0 - 0.5 * sample.fuel_used_kg
    assert np.linalg.norm(impulse / mean_mass - dv_cmd) / np.linalg.norm(dv_cmd) < 1e-4
    fuel_expected = m0 * np.linalg.norm(dv_cmd) / (scenario.chaser.thrusters.isp_s * G0)
    assert sim.plant.step().fuel_used_kg == pytest.approx(fuel_expected, rel=0.01)
    assert 'burn_started' in probe.event_names()


def test_nan_and_late_maneuvers_are_reported(started, executor):
    _scenario_path, sim, probe = started
    run_sim(executor, sim, probe, 2.0)
    probe.send(3.0, [math.nan, 0.0, 0.0])
    probe.send(1.0, [0.01, 0.0, 0.0])  # already past
    run_sim(executor, sim, probe, 4.0)
    names = probe.event_names()
    # The NaN burn never reaches the plant: the simulator's admission refuses it (flyby_msgs_py.admission).
    assert names.count(events.MESSAGE_REJECTED) == 1 and names.count('maneuver_rejected') == 0
    assert names.count('late_maneuver') == 1
    rejected = [e for m in probe.events for e in convert.events_from_msg(m)
                if e['name'] == events.MESSAGE_REJECTED][0]
    assert rejected['values']['reason'] == 'nan' and rejected['values']['topic'] == c.GUIDANCE_MANEUVER
    # Only the late 0.01 m/s burn was applied.
    impulse = sum(np.linalg.norm([m.wrench.force.x, m.wrench.force.y, m.wrench.force.z])
                  for m in probe.thrust) * sim.step_s
    assert impulse == pytest.approx(0.01 * 100.0, rel=1e-3)


def test_in_process_mode_records_every_message(tmp_path):
    scenario = write_scenario(tmp_path, edit=with_duration(100.0))
    out = tmp_path / 'run'
    done = run_mission('--scenario', scenario, '--out', out, '--in-process')
    assert done.returncode == 3, done.stderr
    topics = bag_topics(out / 'bag')
    assert topics['/sim/chaser/odom'][1] == 2001
    assert topics['/sim/target/odom'][1] == 2001
    assert topics['/clock'][1] == 2001
    assert topics['/sensors/chaser/relative_position'][1] == pytest.approx(1000, abs=1)


def test_a_namespaced_simulator_publishes_under_its_namespace(ros_context, executor, tmp_path):
    scenario_path = write_scenario(tmp_path, edit=zero_errors)
    listener = Node('listener', context=ros_context)
    odom = collect(listener, c.SIM_CHASER_ODOM, namespace='/chaser1')
    sim = SimNode(context=ros_context, namespace='/chaser1', parameter_overrides=[
        Parameter('scenario_file', value=str(scenario_path))])
    executor.add_node(sim)
    executor.add_node(listener)
    run_loop(executor, [sim, listener], lambda: sim.plant.t >= 1.0 - 1e-9, drain=True)
    assert sim.pubs[c.SIM_CHASER_ODOM].topic_name == '/chaser1/sim/chaser/odom'
    assert sim.pubs[c.CLOCK].topic_name == '/clock'
    assert len(odom) == 21


def test_time_waits_until_each_announced_subscription_has_matched_its_publishers(ros_context, executor, tmp_path):
    """Discovery is one-sided for a while: a publisher can match a reader that has not yet matched it, and
    what it sends meanwhile is lost to that reader. The simulator starts only once both sides have matched."""
    scenario_path = write_scenario(tmp_path, edit=zero_errors)
    probe = Probe(ros_context)
    ready = probe.create_publisher(String, READY_TOPIC, qos.QOS_EVENTS)
    odom = c.absolute(c.SIM_CHASER_ODOM)
    sim = SimNode(context=ros_context, parameter_overrides=[
        Parameter('scenario_file', value=str(scenario_path)), Parameter('wait_for_nodes', value=['probe'])])
    executor.add_node(sim)
    executor.add_node(probe)

    def announce(matched_publishers):
        ready.publish(String(data=json.dumps({'node': 'probe', 'subscriptions': [odom], 'publications': {},
                                              'subscribed': {odom: matched_publishers}})))
    announce(0)
    spin_until(executor, lambda: 'probe' in sim.subscriptions_of and sim.pubs[c.SIM_CHASER_ODOM]
               .get_subscription_count() >= 1, 10.0, sim.tick)
    deadline = time.monotonic() + 1.0
    while time.monotonic() < deadline:
        executor.spin_once(timeout_sec=min(max(sim.tick(), 0.0), 0.05))
    assert not sim.started
    announce(1)
    spin_until(executor, lambda: sim.started, 10.0, sim.tick)
