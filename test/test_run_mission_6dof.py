"""The six-degree-of-freedom chaser in the graph: real processes over Fast DDS, the bag read back with rosbags.

Guidance commands the wheels and the thrusters' torque every IMU period from the start, so a short run has the
continuous commands in the loop that DESIGN §10's determinism rule is about.
"""

import numpy as np
import pytest

from flyby_mission.headless import HeadlessGraph
from flyby_msgs_py import contract as c
from flyby_msgs_py.bag import read_bag
from flyby_sim.scenario import load_scenario
from flyby_testing import read_summary, run_mission, with_duration, write_scenario

pytestmark = pytest.mark.slow

DURATION_S = 20.0
TOPICS = [c.absolute(t) for t in (c.SIM_CHASER_ODOM, c.SIM_CHASER_WHEELS, c.SIM_CHASER_THRUSTERS, c.SIM_CHASER_THRUST,
                                  c.SENSOR_CHASER_IMU, c.GUIDANCE_WHEELS, c.GUIDANCE_WRENCH, c.EST_CHASER_ODOM,
                                  c.MISSION_EVENTS)]


@pytest.fixture(scope='module')
def runs(tmp_path_factory):
    """The same 20 s paper_flyby_6dof run paced at 10x and at full speed."""
    tmp = tmp_path_factory.mktemp('six')
    scenario = write_scenario(tmp, base='paper_flyby_6dof', edit=with_duration(DURATION_S))
    out = {'scenario': scenario}
    for label, rtf in (('rtf10', 10.0), ('max', 0.0)):
        done = run_mission('--scenario', scenario, '--out', tmp / label, '--rtf', rtf)
        assert done.returncode == 3, done.stderr + done.stdout
        out[label] = read_bag(tmp / label / 'bag', topics=TOPICS)
        out[label + '_summary'] = read_summary(tmp / label)
    return out


def test_truth_is_bit_identical_at_rtf_10_and_full_speed_with_continuous_commands(runs):
    a, b = runs['rtf10'], runs['max']
    odom = c.absolute(c.SIM_CHASER_ODOM)
    for field in ('t', 'position', 'orientation_xyzw', 'linear', 'angular'):
        assert np.array_equal(getattr(a[odom], field), getattr(b[odom], field)), field
    for topic, field in ((c.SIM_CHASER_WHEELS, 'velocity'), (c.SIM_CHASER_WHEELS, 'effort'),
                         (c.SIM_CHASER_THRUSTERS, 'effort'), (c.SIM_CHASER_THRUST, 'torque')):
        assert np.array_equal(getattr(a[c.absolute(topic)], field), getattr(b[c.absolute(topic)], field)), topic
    # The commands were in the loop: one per IMU sample after the first control period, none late.
    wheels = a[c.absolute(c.GUIDANCE_WHEELS)]
    assert len(wheels.t) == pytest.approx(DURATION_S * 10.0 - 1, abs=1)
    assert np.abs(wheels.effort).max() > 0.0
    for label in ('rtf10', 'max'):
        names = [e['name'] for e in runs[label][c.absolute(c.MISSION_EVENTS)]]
        assert 'late_command' not in names and 'waiting_for_command' not in names


def test_graph_truth_equals_the_headless_loops(runs):
    """The headless driver runs the same cores by the same rules: the graph's truth, to the bit."""
    graph = HeadlessGraph(load_scenario(runs['scenario']))
    graph.start()
    while graph.plant.t < DURATION_S - 1e-9:
        graph.step()
    chaser, _target, thrust, _wheels = graph.truth.series()
    odom = runs['max'][c.absolute(c.SIM_CHASER_ODOM)]
    n = len(odom.t)
    assert n == len(chaser.t) == DURATION_S / 0.05 + 1
    assert np.array_equal(odom.position, chaser.position)
    assert np.array_equal(odom.orientation_xyzw, chaser.orientation_xyzw)
    np.testing.assert_array_equal(runs['max'][c.absolute(c.SIM_CHASER_THRUSTERS)].effort, thrust.thrusters)


def test_bag_carries_the_six_degree_of_freedom_topics(runs):
    bag = runs['max']
    odom = bag[c.absolute(c.SIM_CHASER_ODOM)]
    assert odom.child_frame_id == c.FRAME_CHASER_BODY
    assert np.allclose(np.linalg.norm(odom.orientation_xyzw, axis=1), 1.0, atol=1e-12)
    wheels, thrusters = bag[c.absolute(c.SIM_CHASER_WHEELS)], bag[c.absolute(c.SIM_CHASER_THRUSTERS)]
    assert wheels.names == ['w0', 'w1', 'w2'] and len(thrusters.names) == 12
    assert wheels.position.shape == (len(wheels.t), 0) and np.isfinite(wheels.velocity).all()  # not given: empty
    assert thrusters.position.shape == thrusters.velocity.shape == (len(thrusters.t), 0)
    imu = bag[c.absolute(c.SENSOR_CHASER_IMU)]
    assert len(imu.messages) == pytest.approx(DURATION_S * 10.0, abs=1)
    with_attitude = [m for m in imu.messages if m.orientation_covariance[0] != -1.0]
    assert len(with_attitude) == pytest.approx(DURATION_S * 2.0, abs=1)  # the 2 Hz star tracker
    estimate = bag[c.absolute(c.EST_CHASER_ODOM)]
    assert len(estimate.t) == len(imu.messages)  # one chaser estimate per IMU sample
    assert estimate.child_frame_id == c.FRAME_CHASER_BODY
    summary = runs['max_summary']
    assert summary['outcome'] == 'TIME_LIMIT' and summary['thrust_inside_restriction_sphere'] is False
