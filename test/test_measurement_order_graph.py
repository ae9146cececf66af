"""A sensor that stops does not stop the graph (flyby_estimation.measurement_order): the relative position of
paper_flyby_6dof dropped for 3 s in its estimation held every IMU sample behind it in the estimator node, and the
simulator, which waits for the attitude command of each IMU sample, held the run at 10.15 s. Now the run reaches its
end, the dropout is found stale by the estimator's monitor at the stamp the headless driver finds it, and the chaser
is estimated at every IMU sample, the dropout's included. A relative position delayed by 1 s (its samples given up,
then handed on late) leaves the graph's truth the headless loop's to the bit."""

import numpy as np
import pytest
from fault_testing import assert_found_stale_as_headless

from flyby_mission.headless import HeadlessGraph
from flyby_msgs_py import contract as c
from flyby_msgs_py.bag import read_bag
from flyby_sim.scenario import load_scenario
from flyby_testing import read_summary, run_mission, write_scenario

pytestmark = pytest.mark.slow

DURATION_S = 16.0


def _position_dropout(data):
    data['faults'] = [{'type': 'sensor_dropout', 'sensor': 'relative_position', 'start_phase': 'ESTIMATION',
                       'delay_s': 10.0, 'duration_s': 3.0}]
    data['simulation']['duration_s'] = DURATION_S


def test_a_relative_position_dropout_in_estimation_runs_to_the_end_found_stale_as_headless(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby_6dof', name='position_dropout', edit=_position_dropout)
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run', '--in-process', '--wall-timeout', 300)
    summary = read_summary(tmp_path / 'run')
    assert summary['outcome'] == 'TIME_LIMIT', done.stdout[-2000:] + done.stderr[-2000:]
    assert_found_stale_as_headless(summary, scenario, done.stdout[-2000:])
    data = read_bag(tmp_path / 'run' / 'bag', topics=['/sensors/chaser/imu', '/estimation/chaser/odom',
                                                      '/sensors/chaser/relative_position'])
    assert len(data['/sensors/chaser/relative_position'].t) == 10 * (DURATION_S - 3.0)  # 10 Hz, none in the dropout
    # One chaser estimate per IMU sample once the navigation has started, none held back by the missing positions.
    imu_ms = [m.header.stamp.sec * 1000 + round(m.header.stamp.nanosec * 1e-6)
              for m in data['/sensors/chaser/imu'].messages]
    estimate_ms = [round(t * 1000) for t in data['/estimation/chaser/odom'].t]
    assert imu_ms[-1] == estimate_ms[-1] == DURATION_S * 1000
    assert estimate_ms == [t for t in imu_ms if t >= estimate_ms[0]]


def _position_delayed(data):
    data['faults'] = [{'type': 'topic_delay', 'topic': 'sensors/chaser/relative_position', 'start_phase': 'ESTIMATION',
                       'delay_s': 10.0, 'duration_s': 3.0, 'value': 1.0}]
    data['simulation']['duration_s'] = DURATION_S


def test_a_relative_position_delayed_in_estimation_leaves_the_truth_the_headless_loops(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby_6dof', name='position_delayed', edit=_position_delayed)
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run', '--in-process', '--wall-timeout', 300)
    assert read_summary(tmp_path / 'run')['outcome'] == 'TIME_LIMIT', done.stdout[-2000:] + done.stderr[-2000:]
    graph = HeadlessGraph(load_scenario(scenario))
    graph.start()
    while graph.plant.t < DURATION_S - 1e-9:
        graph.step()
    chaser, _target, _thrust, _wheels = graph.truth.series()
    odom = read_bag(tmp_path / 'run' / 'bag', topics=[c.absolute(c.SIM_CHASER_ODOM)])[c.absolute(c.SIM_CHASER_ODOM)]
    assert len(odom.t) == len(chaser.t) == DURATION_S / 0.05 + 1
    assert np.array_equal(odom.position, chaser.position)
    assert np.array_equal(odom.orientation_xyzw, chaser.orientation_xyzw)
