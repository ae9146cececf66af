"""An exception in a core: reported once as an ERROR ``node_error`` event, the core fed no more (docs/runtime.md).

A core (estimator, planner, guidance, supervisor) that raises while handling an input is left half-updated: what
it would command next is not to be trusted. Its driver (``flyby_msgs_py.node_base.CoreNode`` in the graph; the
headless driver alike) catches the exception, turns it into one ``node_error`` Event stamped at the input being
handled, and from then on gives that core nothing more, so nothing more comes out of it. The supervisor reads a
``node_error`` of any node as a fault and takes the mission to ABORTED (flyby_mission.supervisor). Its own
``node_error`` leaves the mission without a judge: guidance idles propulsion on it (flyby_guidance.guidance_core),
the independent CAM monitor stays armed, and the run's outcome is ERROR unless the truth shows a collision
(flyby_mission.summary; docs/runtime.md). No ROS here: the headless driver uses the same guard.
"""

from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.wire import Event


def failed_node(name, values):
    """The node whose core raised, of a mission/events event's name and values (an Event's or a bag's dict), or
    None for any other event."""
    return event_payloads.decode_values(name, values).node if name == events.NODE_ERROR else None


class CoreGuard:
    """The guard of one node's core: ``failed`` is None until the core raises, then its node_error Event."""

    def __init__(self, node):
        self.node = node  # the node's name: the event's source
        self.failed = None

    def fail(self, t, callback, err):
        """The node_error Event of ``err`` raised at sim time t [s] while ``callback`` (the topic, service or
        timer whose input the core was handling) ran; the core is fenced off from now on."""
        kind = type(err).__name__
        self.failed = Event(t, 'ERROR', events.NODE_ERROR, f'{self.node}: {kind}: {err}',
                            event_payloads.encode(event_payloads.NodeError(self.node, kind, callback)), self.node)
        return self.failed
