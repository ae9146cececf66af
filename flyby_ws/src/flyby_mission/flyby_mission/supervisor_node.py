"""The supervisor node: mission phases, the capture decision, the abort service and the watchdog.

Converts messages for ``flyby_mission.supervisor.SupervisorCore`` (no ROS), which holds every rule:
it is fed the target and chaser estimates, the events of the other nodes (``mission/events``), their
progress reports (``/flyby/progress``, the watchdog's heartbeat) and ``/clock`` (through the run loop's
subscription, runtime.ProgressReporter); the node publishes
what it returns: ``mission/phase`` (latched), a ``phase_changed`` event per transition with its
reason, and after an abort outside the restriction sphere at most one collision-avoidance burn on
``guidance/maneuver``. ``mission/abort`` (std_srvs/Trigger) aborts.
"""

from std_msgs.msg import Header
from std_srvs.srv import Trigger

from flyby_mission.abort_escape import AvoidanceBurn
from flyby_mission.supervisor import WATCHED_NODES, SupervisorCore, SupervisorParams, Transition
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, qos
from flyby_msgs_py.node_base import CoreNode
from flyby_msgs_py.runtime import PROGRESS_TOPIC, main_for, publish_event
from flyby_sim.dynamics.rotation import quat_rotate
from flyby_sim.scenario import scenario_of


class SupervisorNode(CoreNode):
    """Mission phase supervisor; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_supervisor', **kwargs)
        self.declare_parameter('watched_nodes', list(WATCHED_NODES))
        watched = tuple(w for w in self.get_parameter('watched_nodes').value if w)
        scenario = scenario_of(self)
        self.core = SupervisorCore(SupervisorParams.from_scenario(scenario), watched, self.get_name())
        self.pub_phase, self.pub_events, self.pub_maneuver = (
            self.publisher(c.MISSION_PHASE), self.publisher(c.MISSION_EVENTS), self.publisher(c.GUIDANCE_MANEUVER))
        self.subscribe_inputs(scenario, {**self.estimate_inputs(quat_rotate), c.MISSION_EVENTS: self.on_events_message})
        ns = self.get_namespace().strip('/')
        self.progress_prefix = ns + '/' if ns else ''  # how our chaser's nodes label their progress
        self.create_subscription(Header, PROGRESS_TOPIC, self.guard(self.on_progress, PROGRESS_TOPIC), qos.QOS_STREAM,
                                 raw=True)
        self.create_service(Trigger, c.MISSION_ABORT_SERVICE,
                            self.guard(self.on_abort, c.MISSION_ABORT_SERVICE, service=True))
        self.publish(self.core.start())

    def on_progress(self, data):
        # Under a chaser's namespace its nodes report as <ns>/<name> (runtime.node_label): the core knows them by
        # name; other chasers' nodes are not ours to watch. Read from the CDR bytes (every node, 4 Hz of sim time).
        t_ns, label = convert.header_cdr_to_ns(data)
        if self.progress_prefix:
            if not label.startswith(self.progress_prefix):
                return
            label = label[len(self.progress_prefix):]
        self.core.on_progress(label, t_ns / 1e9)

    def on_clock(self, t):
        """Called from the run loop's one /clock subscription (runtime.ProgressReporter) with its time [s]."""
        self.publish(self.core.on_clock(t))

    def on_abort(self, _request, response):
        aborted, outputs = self.core.abort('abort requested on mission/abort')
        response.success = aborted
        response.message = ('aborted: guidance stops, the chaser escapes' if aborted else
                            f'nothing to abort in phase {self.core.phase}')
        self.publish(outputs)
        return response

    def publish(self, outputs):
        for out in outputs:
            if isinstance(out, Transition):
                self.pub_phase.publish(convert.string(out.phase_to))
            elif isinstance(out, AvoidanceBurn):
                self.pub_maneuver.publish(convert.vector3_stamped(out.t, c.FRAME_HILL, out.dv_hill))
            else:
                publish_event(self, self.pub_events, out, log_ok=True)


def main(args=None):
    main_for(SupervisorNode, args)


if __name__ == '__main__':
    main()
