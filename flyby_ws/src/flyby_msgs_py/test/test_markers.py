"""Marker builders: hill-frame values in, posed and coloured markers out (through CDR), bad input rejected."""

import math

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker

from flyby_msgs_py import markers as mk
from flyby_msgs_py.contract import FRAME_HILL

RNG = np.random.default_rng(20240602)


def cdr(msg):
    """The message after a serialize/deserialize round trip (what a subscriber or a bag sees)."""
    return deserialize_message(serialize_message(msg), type(msg))


def test_target_box_markers_are_posed_by_the_attitude():
    # Body z along hill x: a quarter turn about hill y. q = (0, sin 45, 0, cos 45). The body boxes
    # centred at [0, 0, 0], [0, 4.5, 0], [0, 0, 2] of a target at hill [0, 0, 1] are centred in hill at:
    s = math.sqrt(0.5)
    q = [0.0, s, 0.0, s]
    centers_hill = np.array([[0.0, 0.0, 1.0], [0.0, 4.5, 1.0], [2.0, 0.0, 1.0]])
    sizes = np.array([[3.0, 3.0, 3.0], [2.0, 6.0, 0.05], [1.0, 1.0, 1.0]])
    markers = mk.target_box_markers(1.0, q, centers_hill, sizes, names=['bus', 'panel_plus_y', 'antenna'])
    arr = cdr(mk.marker_array(markers))
    assert [(m.ns, m.id, m.type) for m in arr.markers] == [(mk.NS_TARGET_GEOMETRY, i, Marker.CUBE) for i in range(3)]
    m2 = arr.markers[2]
    np.testing.assert_allclose([m2.pose.position.x, m2.pose.position.y, m2.pose.position.z], [2.0, 0.0, 1.0],
                               atol=1e-15)
    np.testing.assert_allclose([m2.pose.orientation.x, m2.pose.orientation.y, m2.pose.orientation.w], [0, s, s])
    assert (arr.markers[1].scale.y, arr.markers[1].scale.z) == (6.0, 0.05)
    assert arr.markers[1].color.b > arr.markers[1].color.r  # panels are blue
    assert arr.markers[0].header.frame_id == FRAME_HILL and arr.markers[0].action == Marker.ADD
    with pytest.raises(ValueError, match='^sizes_m: must be > 0'):
        mk.target_box_markers(1.0, q, centers_hill, -sizes)
    with pytest.raises(ValueError, match='^centers_hill_m: must be finite'):
        mk.target_box_markers(1.0, q, np.full((3, 3), math.nan), sizes)
    with pytest.raises(ValueError, match='^names: must have 3 entries'):
        mk.target_box_markers(1.0, q, centers_hill, sizes, names=['bus'])


def test_sphere_point_and_line_markers():
    sphere = cdr(mk.sphere_marker(2.0, [0.0, 0.0, 0.0], 15.0))
    assert (sphere.ns, sphere.id, sphere.type) == (mk.NS_RESTRICTION_SPHERE, 0, Marker.SPHERE)
    assert sphere.scale.x == 30.0 and 0.0 < sphere.color.a < 0.5
    grasp = cdr(mk.point_marker(2.0, [1.0, 2.0, 3.0]))
    assert (grasp.ns, grasp.type, grasp.pose.position.z, grasp.color.a) == (mk.NS_GRASP_POINT, Marker.SPHERE, 3.0, 1.0)
    pts = RNG.normal(size=(5, 3))
    line = cdr(mk.line_strip_marker(2.0, pts, ns='planner_path', marker_id=3))
    assert (line.ns, line.id, line.type, line.scale.x) == ('planner_path', 3, Marker.LINE_STRIP, 0.05)
    np.testing.assert_array_equal([[p.x, p.y, p.z] for p in line.points], pts)
    with pytest.raises(ValueError, match='^radius_m: must be > 0'):
        mk.sphere_marker(0.0, [0, 0, 0], 0.0)
    with pytest.raises(ValueError, match='^center: must be finite'):
        mk.sphere_marker(0.0, np.array([0, 0, math.nan]), 1.0)
    with pytest.raises(ValueError, match='^positions: must be finite'):
        mk.line_strip_marker(0.0, [[0, 0, 0], [math.nan, 0, 0]])
    assert mk.delete_all_markers(0.0).action == Marker.DELETEALL


def test_cylinder_marker_rejects_bad_input():
    with pytest.raises(ValueError, match='^radius_m and height_m: must be > 0'):
        mk.cylinder_marker(0.0, [0, 0, 0], [0, 0, 0, 1], 1.0, 0.0)
    with pytest.raises(ValueError, match='^q_hill_from_cylinder: must be a unit quaternion'):
        mk.cylinder_marker(0.0, [0, 0, 0], [0, 0, 0, 0], 1.0, 1.0)
