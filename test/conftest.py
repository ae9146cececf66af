"""Fixtures of the integration tests: each test gets its own ROS domain and context."""

import pytest
import rclpy
from rclpy.context import Context
from rclpy.experimental import EventsExecutor

from flyby_msgs_py.domain import lease_domain
from flyby_testing import fly_variant, tug_short


@pytest.fixture
def ros_context(monkeypatch):
    """An rclpy context of its own on a ROS domain no other run holds, discovery kept in-process."""
    lease = lease_domain()
    monkeypatch.setenv('ROS_DOMAIN_ID', str(lease.domain_id))
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'OFF')
    context = Context()
    rclpy.init(context=context, domain_id=lease.domain_id)
    try:
        yield context
    finally:
        rclpy.try_shutdown(context=context)
        lease.release()


@pytest.fixture(scope='session')
def tug_short_run(tmp_path_factory):
    """flyby_testing.tug_short flown once in the graph for the session (the post-capture tests and the report's):
    (the run directory, the scenario file)."""
    return fly_variant(tmp_path_factory.mktemp('tug'), 'paper_flyby_tug', 'tug_short', tug_short)


@pytest.fixture
def executor(ros_context):
    ex = EventsExecutor(context=ros_context)
    try:
        yield ex
    finally:
        ex.shutdown()
