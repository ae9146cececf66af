"""visualization_msgs markers for Foxglove / RViz on /visualization/markers (DESIGN §4).

The builders take values already in the marker's frame (``hill`` by default): positions, and
orientations as unit quaternions (x, y, z, w), scalar last. They do no rotation maths; the callers
get box centres and a cylinder's orientation from ``flyby_sim`` (``Boxes.centers_hill_m``,
``flyby_sim.dynamics.rotation.quat_shortest_arc``).

Namespaces and ids are stable, so a newer array replaces the old markers. Inputs are checked as in
``convert`` (ValueError naming the field, no NaN into a message).
"""

from geometry_msgs.msg import Point
from visualization_msgs.msg import Marker, MarkerArray

from flyby_msgs_py.contract import FRAME_HILL
from flyby_msgs_py.convert.fields import _array, _frame, _quat, _scalar, _set_xyz, _set_xyzw, _vec3
from flyby_msgs_py.convert.stamps import _stamp_into

NS_TARGET_GEOMETRY = 'target_geometry'
NS_RESTRICTION_SPHERE = 'restriction_sphere'
NS_GRASP_POINT = 'grasp_point'
NS_PATH = 'path'
NS_KEEP_OUT = 'keep_out'
NS_CHASER = 'chaser'

RGBA_TARGET_BUS = (0.75, 0.75, 0.78, 1.0)
RGBA_SOLAR_PANEL = (0.15, 0.25, 0.65, 1.0)
RGBA_RESTRICTION_SPHERE = (1.0, 0.55, 0.0, 0.15)
RGBA_GRASP_POINT = (0.1, 0.9, 0.2, 1.0)
RGBA_PATH = (0.2, 0.6, 1.0, 1.0)
RGBA_KEEP_OUT = (0.9, 0.1, 0.1, 0.25)
RGBA_CHASER_BODY = (0.95, 0.8, 0.2, 0.6)
RGBA_CHASER_AXIS = (1.0, 0.1, 0.1, 1.0)


def _marker(t, frame_id, ns, marker_id, kind, rgba):
    m = Marker()
    _stamp_into(m.header.stamp, t)
    m.header.frame_id = _frame(frame_id)
    m.ns = ns
    m.id = int(marker_id)
    m.type = kind
    m.action = Marker.ADD
    r, g, b, a = (_scalar(c, 'rgba') for c in rgba)
    m.color.r, m.color.g, m.color.b, m.color.a = r, g, b, a
    m.pose.orientation.w = 1.0
    return m


def target_box_markers(t, q_hill_from_body, centers_hill_m, sizes_m, names=None, frame_id=FRAME_HILL,
                       ns=NS_TARGET_GEOMETRY, rgba=None):
    """One CUBE per target box: centred at ``centers_hill_m`` (N, 3), edges ``sizes_m`` (N, 3) along
    the body axes, which the cube takes as its orientation ``q_hill_from_body``. Marker id = box
    index. Boxes whose name contains 'panel' are drawn blue unless ``rgba`` is given."""
    q = _quat(q_hill_from_body, 'q_hill_from_body')
    centers = _array(centers_hill_m, 3, 'centers_hill_m')
    sizes = _array(sizes_m, 3, 'sizes_m')
    if sizes.shape != centers.shape:
        raise ValueError(f'sizes_m: must have {len(centers)} rows like centers_hill_m, got {len(sizes)}')
    if (sizes <= 0.0).any():
        raise ValueError('sizes_m: must be > 0')
    if names is not None and len(names) != len(centers):
        raise ValueError(f'names: must have {len(centers)} entries like centers_hill_m, got {len(names)}')
    markers = []
    for i, (c, s) in enumerate(zip(centers.tolist(), sizes.tolist(), strict=True)):
        colour = rgba if rgba is not None else (
            RGBA_SOLAR_PANEL if names is not None and 'panel' in names[i] else RGBA_TARGET_BUS)
        m = _marker(t, frame_id, ns, i, Marker.CUBE, colour)
        _set_xyz(m.pose.position, c)
        _set_xyzw(m.pose.orientation, q)
        _set_xyz(m.scale, s)
        markers.append(m)
    return markers


def sphere_marker(t, center, radius_m, frame_id=FRAME_HILL, ns=NS_RESTRICTION_SPHERE, marker_id=0,
                  rgba=RGBA_RESTRICTION_SPHERE):
    """A translucent SPHERE of radius_m (default: the thruster-restriction sphere)."""
    r = _scalar(radius_m, 'radius_m')
    if r <= 0.0:
        raise ValueError(f'radius_m: must be > 0, got {r!r}')
    m = _marker(t, frame_id, ns, marker_id, Marker.SPHERE, rgba)
    _set_xyz(m.pose.position, _vec3(center, 'center'))
    _set_xyz(m.scale, (2.0 * r, 2.0 * r, 2.0 * r))
    return m


def cylinder_marker(t, center, q_hill_from_cylinder, radius_m, height_m, frame_id=FRAME_HILL, ns=NS_KEEP_OUT,
                    marker_id=0, rgba=RGBA_KEEP_OUT):
    """A CYLINDER of radius_m and height_m centred on center (the swept keep-out region of a spinning
    target). Its axis is the z axis of its orientation ``q_hill_from_cylinder``: for an axis given
    as a direction, ``quat_shortest_arc((0, 0, 1), axis)``."""
    r, h = _scalar(radius_m, 'radius_m'), _scalar(height_m, 'height_m')
    if r <= 0.0 or h <= 0.0:
        raise ValueError(f'radius_m and height_m: must be > 0, got {r!r}, {h!r}')
    m = _marker(t, frame_id, ns, marker_id, Marker.CYLINDER, rgba)
    _set_xyz(m.pose.position, _vec3(center, 'center'))
    _set_xyzw(m.pose.orientation, _quat(q_hill_from_cylinder, 'q_hill_from_cylinder'))
    _set_xyz(m.scale, (2.0 * r, 2.0 * r, h))
    return m


def point_marker(t, position, diameter_m=0.2, frame_id=FRAME_HILL, ns=NS_GRASP_POINT, marker_id=0,
                 rgba=RGBA_GRASP_POINT):
    """A small opaque SPHERE at position (default: the grasp point)."""
    return sphere_marker(t, position, 0.5 * _scalar(diameter_m, 'diameter_m'), frame_id, ns, marker_id, rgba)


def line_strip_marker(t, positions, width_m=0.05, frame_id=FRAME_HILL, ns=NS_PATH, marker_id=0,
                      rgba=RGBA_PATH):
    """A LINE_STRIP through positions (N, 3) (a path); scale.x is the line width."""
    pos = _array(positions, 3, 'positions')
    w = _scalar(width_m, 'width_m')
    if w <= 0.0:
        raise ValueError(f'width_m: must be > 0, got {w!r}')
    m = _marker(t, frame_id, ns, marker_id, Marker.LINE_STRIP, rgba)
    m.scale.x = w
    points = m.points
    for p in pos.tolist():
        pt = Point()
        _set_xyz(pt, p)
        points.append(pt)
    return m


def chaser_markers(t, r_hill, q_hill_from_body, envelope_radius_m, axis_length_m=None, frame_id=FRAME_HILL,
                   ns=NS_CHASER):
    """The six-degree-of-freedom chaser: a CUBE inscribed in its envelope sphere, turned with its attitude
    ``q_hill_from_body`` (id 0), and an ARROW along its body +x (camera and manipulator; id 1), of
    ``axis_length_m`` (default three envelope radii). An ARROW's shaft runs along its pose's x axis, so it
    takes the body's orientation too."""
    r = _vec3(r_hill, 'r_hill')
    q = _quat(q_hill_from_body, 'q_hill_from_body')
    radius = _scalar(envelope_radius_m, 'envelope_radius_m')
    if radius <= 0.0:
        raise ValueError(f'envelope_radius_m: must be > 0, got {radius!r}')
    length = 3.0 * radius if axis_length_m is None else _scalar(axis_length_m, 'axis_length_m')
    if length <= 0.0:
        raise ValueError(f'axis_length_m: must be > 0, got {length!r}')
    edge = 2.0 * radius / 3.0 ** 0.5
    body = _marker(t, frame_id, ns, 0, Marker.CUBE, RGBA_CHASER_BODY)
    axis = _marker(t, frame_id, ns, 1, Marker.ARROW, RGBA_CHASER_AXIS)
    for m in (body, axis):
        _set_xyz(m.pose.position, r)
        _set_xyzw(m.pose.orientation, q)
    _set_xyz(body.scale, (edge, edge, edge))
    _set_xyz(axis.scale, (length, 0.1 * radius, 0.1 * radius))  # ARROW: length, shaft and head width
    return [body, axis]


def delete_all_markers(t, frame_id=FRAME_HILL):
    """A DELETEALL marker: put it first in an array to clear what an earlier array drew."""
    m = Marker()
    _stamp_into(m.header.stamp, t)
    m.header.frame_id = _frame(frame_id)
    m.action = Marker.DELETEALL
    return m


def marker_array(markers):
    msg = MarkerArray()
    msg.markers = list(markers)
    return msg
