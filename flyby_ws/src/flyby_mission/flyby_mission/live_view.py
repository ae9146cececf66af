"""The mission seen live in a Foxglove app: ``scripts/run_mission.py --foxglove [PORT]``.

``flyby_mission.live_view_node`` is a node of the graph (its own process, started by the launcher after the
recorder; the simulator waits for it to start, so a viewer sees the run from its first step, but it is left out of
the simulator's flow control and of the run's essential nodes: a viewer never slows or ends a run) that runs a
Foxglove WebSocket server (the ``foxglove-sdk`` package, protocol ``foxglove.sdk.v1``, what the Foxglove app speaks)
on 127.0.0.1:PORT and forwards to it:
- every contract topic as the recorder records it: the CDR bytes as received, on a channel of the topic's name
  with its ROS 2 message definition (encoding ``ros2msg``/``cdr``, what Foxglove reads from a ROS 2 bag);
- ``/tf`` and ``/tf_static`` as in the bag (``flyby_msgs_py.frames``: tf2_msgs/TFMessage from the truth).
The log time of a message is the simulation time of the last ``/clock``, as in the bag, so
``foxglove/flyby_layout.json`` shows a live run as it shows its bag. A channel no client subscribes to costs one
check per message. A client that subscribes late gets the last message of each latched topic (the phase, the plan,
the markers, the static frames) at once.

This module holds what the launcher needs before the run, without rclpy: ``check_port`` (a taken port is refused
before the run starts) and ``static_transforms(scenario)``, the mounts of ``/tf_static`` that the recorder and the
node are given alike.
"""

import socket

from flyby_msgs_py import frames

HOST = '127.0.0.1'
DEFAULT_PORT = 8765


def static_transforms(scenario):
    """The static mounts of a scenario: each chaser's grasp point in target_body (namespaced with several)."""
    if not scenario.chaser_names:
        return [frames.grasp_point_transform(scenario.target.grasp_point_body_m)]
    return [frames.grasp_point_transform(scenario.for_chaser(name).target.grasp_point_body_m, name)
            for name in scenario.chaser_names]


def check_port(port, in_process=False):
    """ValueError naming --foxglove when the live view cannot run: ``port`` out of range or taken at HOST, or the
    graph in one process (the server's node would share the nodes' executor)."""
    if in_process:
        raise ValueError('--foxglove: not with --in-process (the live view runs as its own process)')
    if not 0 < port < 65536:
        raise ValueError(f'--foxglove: the port must be in 1..65535, got {port}')
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        try:
            probe.bind((HOST, port))
        except OSError as err:
            raise ValueError(f'--foxglove: port {port} on {HOST} is taken ({err.strerror})') from None
