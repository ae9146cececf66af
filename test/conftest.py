"""Fixtures of the integration tests: each test gets its own ROS domain and context."""

import pytest
import rclpy
from rclpy.context import Context
from rclpy.experimental import EventsExecutor

from flyby_msgs_py.domain import lease_domain
from flyby_testing import fly_variant, run_mission, tug_short, with_duration, write_scenario


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


@pytest.fixture(scope='session')
def sixdof_short_run(tmp_path_factory):
    """scenarios/paper_flyby_6dof.yaml (make mission's) cut at 60 s, flown once in the graph for the session (the
    bag's frames and Foxglove's readers of it): the run directory."""
    tmp = tmp_path_factory.mktemp('sixdof')
    scenario = write_scenario(tmp, base='paper_flyby_6dof', name='sixdof_short', edit=with_duration(60.0))
    done = run_mission('--scenario', scenario, '--out', tmp / 'run')
    assert done.returncode == 3, done.stderr[-3000:] + done.stdout[-3000:]  # the time limit, safe
    return tmp / 'run'


@pytest.fixture
def executor(ros_context):
    ex = EventsExecutor(context=ros_context)
    try:
        yield ex
    finally:
        ex.shutdown()
