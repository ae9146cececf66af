"""A keep-out cylinder marker drawn along any axis: the marker builder (flyby_msgs_py.markers) with the
orientation the planner node gives it (flyby_sim.dynamics.rotation.quat_shortest_arc), through CDR."""

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker

from flyby_msgs_py import markers as mk
from flyby_sim.dynamics.rotation import quat_rotate, quat_shortest_arc

RNG = np.random.default_rng(20240602)


def cdr(msg):
    """The message after a serialize/deserialize round trip (what a subscriber or a bag sees)."""
    return deserialize_message(serialize_message(msg), type(msg))


@pytest.mark.parametrize('axis', [RNG.normal(size=3) for _ in range(5)] + [[0.0, 0.0, 1.0], [0.0, 0.0, -2.0],
                                                                          [1.0, 0.0, 0.0]])
def test_cylinder_along_an_arbitrary_axis_has_its_z_axis_there(axis):
    """A cylinder marker is drawn along its own z axis; the caller's quat_shortest_arc puts that on ``axis``."""
    m = cdr(mk.cylinder_marker(0.5, [1.0, -2.0, 3.0], quat_shortest_arc((0.0, 0.0, 1.0), axis), 2.0, 7.0,
                               marker_id=4))
    assert (m.ns, m.id, m.type) == (mk.NS_KEEP_OUT, 4, Marker.CYLINDER)
    assert (m.scale.x, m.scale.y, m.scale.z) == (4.0, 4.0, 7.0)
    assert [m.pose.position.x, m.pose.position.y, m.pose.position.z] == [1.0, -2.0, 3.0]
    o = m.pose.orientation
    z_hill = quat_rotate((o.x, o.y, o.z, o.w), (0.0, 0.0, 1.0))
    np.testing.assert_allclose(z_hill, np.asarray(axis) / np.linalg.norm(axis), atol=1e-12)
