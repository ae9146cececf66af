"""The recorder as a process of its own: a signal closes the bag only after what was sent is in it."""

import os
import signal
import subprocess
import sys

import pytest
import rclpy
from rclpy.context import Context
from rclpy.experimental import EventsExecutor
from rclpy.node import Node

from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, qos
from flyby_msgs_py.bag import read_bag, verify_bag
from flyby_msgs_py.domain import lease_domain
from flyby_msgs_py.runtime import FASTDDS_PROFILES
from flyby_testing import spin_until

BURST = 150  # below the publisher's depth (QOS_STREAM, 200): reliable delivery keeps every one


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_signal_right_after_a_burst_loses_no_message(tmp_path, sig):
    lease = lease_domain()
    env = dict(os.environ, ROS_DOMAIN_ID=str(lease.domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
               FASTRTPS_DEFAULT_PROFILES_FILE=str(FASTDDS_PROFILES))
    bag_dir = tmp_path / 'bag'
    recorder = subprocess.Popen(
        [sys.executable, '-m', 'flyby_msgs_py.recorder_node', '--ros-args', '-p', f'bag_dir:={bag_dir}'],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    context = Context()
    rclpy.init(context=context, domain_id=lease.domain_id)
    executor = EventsExecutor(context=context)
    node = Node('burst_publisher', context=context)
    executor.add_node(node)
    try:
        odom = node.create_publisher(c.message_class(c.TOPIC_TYPES[c.SIM_CHASER_ODOM]), c.SIM_CHASER_ODOM,
                                     qos.qos_for(c.SIM_CHASER_ODOM))
        spin_until(executor, lambda: odom.get_subscription_count() > 0)
        for k in range(BURST):
            odom.publish(convert.odometry(0.05 * k, c.FRAME_HILL, c.FRAME_CHASER_BODY, (float(k), 0.0, 0.0),
                                          (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
        recorder.send_signal(sig)  # at once: most of the burst is still on its way or queued
        output, _ = recorder.communicate(timeout=30)
    finally:
        if recorder.poll() is None:
            recorder.kill()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        lease.release()
    assert recorder.returncode == 0, output
    data = read_bag(bag_dir, topics=[c.absolute(c.SIM_CHASER_ODOM)])
    positions = data[c.absolute(c.SIM_CHASER_ODOM)].position[:, 0]
    assert positions.tolist() == [float(k) for k in range(BURST)]
    assert verify_bag(bag_dir) >= 1  # its chunks carry CRCs, and they match
