"""The frames a viewer draws (Foxglove's 3D panel, RViz): ``/tf`` and ``/tf_static`` as tf2_msgs/TFMessage,
made from the simulator's truth.

- ``/tf``: ``hill -> target_body`` from ``/sim/target/odom`` and ``hill -> chaser_body`` from each chaser's
  ``sim/chaser/odom``; the pose of an Odometry is its child frame in its frame (nav_msgs), so the transform is
  that pose as it is, at the message's stamp. Under a namespace the chaser's frame is namespaced
  (``chaser1/chaser_body``), as tf2 names the frames of one robot among several; ``hill`` and ``target_body`` are
  the same for every chaser.
- ``/tf_static``: the mounts fixed in a body, e.g. the grasp point in ``target_body`` (``grasp_point``, the frame
  the planner's ``planner/grasp`` names); written once, at the start.

The recorder writes both into every bag and the live view sends the same bytes to a Foxglove app while a mission
runs (``flyby_mission.live_view``). tf2_msgs has no Python package for rclpy here: the TFMessage is encoded straight
to its CDR bytes (as ``convert`` does the contract's types; rosbags' Jazzy typestore reads them,
``test/test_tf_bag.py``). No rclpy.
"""

import math
import struct
from typing import NamedTuple

from flyby_msgs_py import contract as c
from flyby_msgs_py import convert
from flyby_msgs_py.convert.cdr import _CDR_LE, _cdr_header, _cdr_string, _cdr_string_at
from flyby_msgs_py.convert.odometry import _ODOMETRY_DOUBLES

TF_TYPE = 'tf2_msgs/msg/TFMessage'
TF_TOPIC = '/' + c.TF
TF_STATIC_TOPIC = '/' + c.TF_STATIC
_POSE = struct.Struct('<7d')  # position (3), orientation (x, y, z, w): the first doubles of an Odometry


class Transform(NamedTuple):
    """One geometry_msgs/TransformStamped: the pose of ``child`` in ``parent`` at ``t_ns``."""

    t_ns: int
    parent: str
    child: str
    translation_m: tuple     # (x, y, z) of child's origin in parent [m]
    rotation_xyzw: tuple     # q_parent_from_child, (x, y, z, w)


def namespaced_frame(frame_id, namespace=''):
    """A chaser's own frame under its namespace (``chaser1/chaser_body``), the frame itself without one."""
    ns = namespace.strip('/')
    return f'{ns}/{frame_id}' if ns else frame_id


def truth_topics(namespaces=('',)):
    """``{absolute topic: namespace}`` of the truth odometries the transforms are made from: the target's
    (global) and every chaser's."""
    topics = {c.absolute(c.SIM_TARGET_ODOM): ''}
    for ns in namespaces:
        topics[c.absolute(c.SIM_CHASER_ODOM, ns)] = ns
    return topics


def transform_from_odometry_cdr(data, namespace=''):
    """The transform of a serialized truth nav_msgs/Odometry: its child frame (namespaced when it is a chaser's)
    in its frame, at its stamp. Reads the header, the child frame and the pose only (the recorder calls it on
    every truth message)."""
    t_ns, frame_id, offset = _cdr_header(data, 'Odometry')
    child, offset = _cdr_string_at(data, offset, 'child_frame_id')
    offset += -offset % 8
    if 4 + offset + 8 * _ODOMETRY_DOUBLES > len(data):
        raise ValueError(f'Odometry: {len(data)} bytes of CDR, expected {4 + offset + 8 * _ODOMETRY_DOUBLES}')
    pose = _POSE.unpack_from(data, 4 + offset)
    if child != c.FRAME_TARGET_BODY:
        child = namespaced_frame(child, namespace)
    return Transform(t_ns, frame_id, child, pose[:3], pose[3:])


def tf_of_truth(data, namespace=''):
    """The /tf message (CDR bytes) of a serialized truth Odometry, or None when it has no transform (malformed, or
    a non-finite pose): a recorder or a viewer records what arrives and draws what it can."""
    try:
        return tf_message_cdr([transform_from_odometry_cdr(data, namespace)])
    except (ValueError, UnicodeDecodeError, struct.error):
        return None


def grasp_point_transform(grasp_point_body_m, namespace=''):
    """The static mount of a chaser's grasp point in ``target_body`` (axes those of the body)."""
    return Transform(0, c.FRAME_TARGET_BODY, namespaced_frame(c.FRAME_GRASP_POINT, namespace),
                     tuple(float(v) for v in grasp_point_body_m), (0.0, 0.0, 0.0, 1.0))


def tf_message_cdr(transforms):
    """The CDR bytes of a tf2_msgs/TFMessage holding ``transforms`` (ValueError on a non-finite number or an
    empty frame name)."""
    payload = bytearray(struct.pack('<I', len(transforms)))
    for tf in transforms:
        values = (*tf.translation_m, *tf.rotation_xyzw)
        if len(values) != 7 or not all(math.isfinite(v) for v in values):
            raise ValueError(f'transform {tf.parent} -> {tf.child}: translation (3) and rotation (4) must be finite, '
                             f'got {values}')
        if not (tf.parent and tf.child):
            raise ValueError(f'transform {tf.parent!r} -> {tf.child!r}: frame names must not be empty')
        sec, nanosec = divmod(int(tf.t_ns), convert.NS_PER_S)
        payload += b'\0' * (-len(payload) % 4) + struct.pack('<iI', sec, nanosec)
        payload += _cdr_string(tf.parent, len(payload))
        payload += _cdr_string(tf.child, len(payload))
        payload += b'\0' * (-len(payload) % 8) + struct.pack('<7d', *values)
    return _CDR_LE + bytes(payload)


def format_static(transform):
    """A static transform as one line of text (the recorder's ``static_transforms`` parameter)."""
    return ' '.join([transform.parent, transform.child,
                     *(repr(float(v)) for v in (*transform.translation_m, *transform.rotation_xyzw))])


def parse_static(text):
    """``format_static``'s line back to a Transform at t = 0; ValueError naming the line when malformed."""
    parts = text.split()
    try:
        if len(parts) != 9:
            raise ValueError
        values = tuple(float(v) for v in parts[2:])
    except ValueError:
        raise ValueError(f'static transform {text!r}: expected "PARENT CHILD X Y Z QX QY QZ QW"') from None
    return Transform(0, parts[0], parts[1], values[:3], values[3:])
