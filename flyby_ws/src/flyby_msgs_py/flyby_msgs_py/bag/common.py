"""What every part of ``flyby_msgs_py.bag`` shares: its error type and the typestore of ROS 2 Jazzy."""

from rosbags.typesys import Stores, get_typestore


class BagError(Exception):
    """A bag that cannot be written, read or repaired; the message names the path."""


def jazzy_typestore():
    """A fresh rosbags typestore with the ROS 2 Jazzy message types."""
    return get_typestore(Stores.ROS2_JAZZY)
