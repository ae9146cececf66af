"""How flyby nodes run: one process per node, or every node on one executor (in-process mode).

A node that has work of its own (the simulator advancing time) implements ``tick() -> float``:
it does what is due and returns how long the loop may wait for messages before calling it again,
and ``finished`` tells the loop to stop. Other nodes only react to messages; the loop reports how
far each of them has got (``ProgressReporter``), which is how the simulator keeps its pace to what
the slowest node can handle.

EventsExecutor driven by ``spin_once`` is about 3x faster than SingleThreadedExecutor on these
wheels, and its ``spin()`` hangs (DESIGN §9), hence the explicit loops here.
"""

import json
import math
import os
import signal
import time

import rclpy
from rclpy.exceptions import InvalidHandle
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Empty, Header, String

from flyby_msgs_py import convert
from flyby_msgs_py.qos import QOS_EVENTS, QOS_STREAM
from flyby_msgs_py.schema import ScenarioError

# Fast DDS defaults of every flyby process (see the file); the launcher exports it.
FASTDDS_PROFILES = os.path.join(os.path.dirname(__file__), 'config', 'fastdds_profiles.xml')
BARRIER_TOPIC = '_flyby_drain_barrier'
# Not a contract topic (not recorded): header.frame_id = node name, stamp = its sim time. Half the simulator's
# flow-control lag (1 s in a run): every report and tick is a delivery to each of its readers.
PROGRESS_TOPIC = '/flyby/progress'
PROGRESS_PERIOD_NS = 500_000_000
# Not a contract topic: the simulator's time every PROGRESS_PERIOD_NS (and at its first and last step), for the
# nodes that need only to know how far they have got, and the launcher; /clock's every step would cost each of
# them, and the simulator, one delivery per step (5 of the 6-DOF mission's ~20 per step).
TICK_TOPIC = '/flyby/tick'
# Each node announces here, once running, the topics it subscribes (JSON), so that the simulator can
# hold time until every one of those subscriptions is matched (discovery takes 0-3 s).
READY_TOPIC = '/flyby/ready'
# A draining node (the recorder) stops after a signal once no message has come for DRAIN_QUIET_S,
# or after DRAIN_MAX_S; well inside the launcher's SIGINT grace (10 s).
DRAIN_QUIET_S = 0.5
DRAIN_MAX_S = 5.0
# How often (wall) a node looks at its publishers' match counts for ReadyAnnouncer: asking every publisher
# after every message handled cost the graph ~16 ms of CPU per simulated second.
ANNOUNCE_PERIOD_S = 0.1


def node_label(node):
    """How a node names itself on the progress and ready topics: its name, under a namespace ``ns/name``
    (several chasers run nodes of one name, DESIGN §10)."""
    ns = node.get_namespace().strip('/')
    return f'{ns}/{node.get_name()}' if ns else node.get_name()


class ProgressReporter:
    """Tells the simulator how far a node has got: the last simulator time it handled.

    EventsExecutor handles a node's messages in arrival order, so once a node has handled the time message of t it
    has handled everything published before it. The reporter keeps its own reliable subscription: the time source's
    is best effort, and a lost last time message would leave the simulator waiting forever. Reported every
    PROGRESS_PERIOD_NS of sim time, and whenever the node has gone idle with news to tell. It reads ``TICK_TOPIC``
    (the time every PROGRESS_PERIOD_NS), from the CDR bytes; a node that acts on the clock reads ``/clock`` instead,
    every step, and calls from it, inside its core's guard (node_base.CoreNode.guard), its ``on_clock(t)`` [s] (the
    supervisor's watchdog and holds, the rigid-body chaser's estimator's measurement order), then its
    ``on_link_clock(t)`` (a link holding messages of a topic fault releases them, flyby_msgs_py.link_faults: after
    the clock's own work, as the headless driver releases them at the end of its step). Either topic is the node's
    only time subscription. The reporter itself is outside the guard: a node whose core has failed goes on
    reporting, so the simulator is not held for it. It is the node's ``progress_reporter``: its last known sim time,
    for an input without a stamp.
    """

    def __init__(self, node):
        self.node = node
        node.progress_reporter = self
        self.publisher = node.create_publisher(Header, PROGRESS_TOPIC, QOS_STREAM)
        self.clock_ns = 0
        self.reported_ns = -1
        self.due = None  # a Future the loop spins on: done once a report is due
        listeners = (getattr(node, 'on_clock', None), getattr(node, 'on_link_clock', None))
        self.listeners = [node.guard(listener, '/clock') for listener in listeners if listener is not None]
        node.create_subscription(Clock, '/clock' if self.listeners else TICK_TOPIC, self._on_clock, QOS_STREAM,
                                 raw=True)

    def _on_clock(self, data):
        self.clock_ns = convert.clock_cdr_to_ns(data)
        for listener in self.listeners:
            listener(self.clock_ns / 1e9)
        if self.due is not None and self.clock_ns - self.reported_ns >= PROGRESS_PERIOD_NS and not self.due.done():
            self.due.set_result(True)

    def report(self, idle):
        if self.publisher is None:
            return
        now_ns = self.clock_ns
        if now_ns - self.reported_ns >= PROGRESS_PERIOD_NS or (idle and now_ns != self.reported_ns):
            msg = Header(frame_id=node_label(self.node))
            msg.stamp.sec, msg.stamp.nanosec = divmod(now_ns, 1_000_000_000)
            try:
                self.publisher.publish(msg)
            except InvalidHandle:  # the node was destroyed (a fault injected by the launcher)
                self.publisher = None
                return
            self.reported_ns = now_ns


class ReadyAnnouncer:
    """Publishes (latched) the node's name, the topics it subscribes, per topic it publishes how many
    subscriptions its publisher has matched and per topic it subscribes how many publishers its
    subscription has matched; again whenever a match count changes.

    The simulator holds time until every publisher of the graph has matched every announced
    subscription of its topic and every subscription every announced publisher (not only its own): a
    discovery that is slow between two other processes would otherwise lose their first messages (e.g.
    the estimates in the bag). Both sides, because matching is one-sided for a while: a writer that has
    matched a reader which has not yet matched it sends samples the reader drops, resent only once the
    reader's side of discovery completes (the supervisor's watchdog once missed the guidance's first
    progress reports for more than 5 s of sim time that way on a loaded machine).
    """

    def __init__(self, node):
        self.node = node
        self.publisher = node.create_publisher(String, READY_TOPIC, QOS_EVENTS)
        self.subscriptions = sorted(sub.topic_name for sub in node.subscriptions)
        self.matched = None
        self.update()

    def update(self):
        if self.publisher is None:
            return
        try:
            publications = {p.topic_name: p.get_subscription_count() for p in self.node.publishers
                            if p is not self.publisher}
            subscribed = {}
            for sub in self.node.subscriptions:  # the least matched of a topic's subscriptions
                count = sub.get_publisher_count()
                subscribed[sub.topic_name] = min(count, subscribed.get(sub.topic_name, count))
            matched = (publications, subscribed)
            if matched != self.matched:
                self.matched = matched
                self.publisher.publish(String(data=json.dumps(
                    {'node': node_label(self.node), 'subscriptions': self.subscriptions,
                     'publications': publications, 'subscribed': subscribed})))
        except InvalidHandle:  # the node was destroyed (a fault injected by the launcher)
            self.publisher = None


def announce_ready(node):
    """A ReadyAnnouncer for node (call its update() as the loop runs)."""
    return ReadyAnnouncer(node)


def run_loop(executor, nodes, should_stop=lambda: False, idle_s=0.05, drain=False):
    """Spin ``executor`` and tick the ticking nodes until one is finished or ``should_stop()``.

    With ``drain`` (every node in this process) each tick is followed by handling every message it
    caused before the next tick: a marker message published after the tick is delivered (in-process,
    synchronously) behind the messages already sent, and EventsExecutor handles its queue in order.
    (EventsExecutor does not support guard conditions, hence a topic.) Without it a fast ticker
    would outrun the subscribers of its own process and overflow their queues.
    """
    tickers = [n for n in nodes if hasattr(n, 'tick')]
    reporters = {}
    announcers = [announce_ready(node) for node in nodes]
    reached = [True]
    barrier = None
    if drain and nodes:
        barrier = nodes[0].create_publisher(Empty, BARRIER_TOPIC, 1)
        nodes[0].create_subscription(Empty, BARRIER_TOPIC, lambda _m: reached.__setitem__(0, True), 1)
    announced_at = -math.inf
    while executor.context.ok() and not should_stop():
        for node in nodes:  # a node started since (a respawn, graph_run) reports too
            if not hasattr(node, 'tick') and node not in reporters:
                reporters[node] = ProgressReporter(node)
        wait_s = idle_s
        for node in tickers:
            wait_s = min(wait_s, node.tick())
        if barrier is not None:
            reached[0] = False
            barrier.publish(Empty())
            while not reached[0] and executor.context.ok():
                executor.spin_once(timeout_sec=idle_s)
        if any(getattr(n, 'finished', False) for n in tickers):
            return
        wait_s = max(wait_s, 0.0)
        started = time.monotonic()
        if tickers:
            executor.spin_once(timeout_sec=wait_s)
        else:
            # Only reacting: the executor handles messages in C++ until a report is due or wait_s has passed
            # (one Python turn of this loop per message cost these nodes 5-15 % of their CPU on the 6-DOF mission).
            due = Future()
            for reporter in reporters.values():
                reporter.due = due
            executor.spin_until_future_complete(due, timeout_sec=wait_s)
        idle = wait_s > 0.0 and time.monotonic() - started >= 0.9 * wait_s
        for reporter in reporters.values():
            reporter.report(idle)
        now = time.monotonic()
        if now - announced_at >= ANNOUNCE_PERIOD_S:
            announced_at = now
            for announcer in announcers:
                announcer.update()


def main_for(node_class, args=None, drain_on_signal=False):
    """Process entry point of one node: init, build, spin until done or signalled, clean up.

    A bad scenario ends the process with its one-line message (exit code 1).

    SIGINT and SIGTERM do not shut ROS down at once, as rclpy's own handlers would: the loop stops
    between two of its turns, so a node finishes what it was doing (the simulator publishes the whole
    step whose clock went out). drain_on_signal (the recorder; its node counts what it has handled in
    ``count``): the node then goes on taking the messages already on their way until none has come for
    DRAIN_QUIET_S (at most DRAIN_MAX_S), and only then cleans up.
    """
    stop = []
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, _frame: stop.append(signum))
    node = None
    try:
        node = node_class()
        executor = EventsExecutor()
        executor.add_node(node)
        run_loop(executor, [node], should_stop=lambda: bool(stop))
        if stop and drain_on_signal:
            drain(executor, node)
    except ExternalShutdownException:
        pass
    except ScenarioError as err:
        raise SystemExit(f'{node_class.__name__}: {err}') from None
    finally:
        if node is not None:
            close = getattr(node, 'close', None)
            if close is not None:
                close()
            node.destroy_node()
        rclpy.try_shutdown()


def drain(executor, node):
    """Handle messages until node.count has not changed for DRAIN_QUIET_S (at most DRAIN_MAX_S)."""
    deadline = time.monotonic() + DRAIN_MAX_S
    last_count, quiet_since = node.count, time.monotonic()
    while executor.context.ok() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
        if node.count != last_count:
            last_count, quiet_since = node.count, time.monotonic()
        elif time.monotonic() - quiet_since >= DRAIN_QUIET_S:
            return


def publish_event(node, publisher, event, log_ok=False):
    """Publish one wire.Event on mission/events with the node as its source and log it at its level
    (OK events only with log_ok)."""
    t, level, name, message, values, _source = event
    publisher.publish(convert.event(t if math.isfinite(t) else 0.0, level, name, message, values,
                                    source=node.get_name()))
    log = node.get_logger()
    # rclpy refuses one call site logging at varying severities.
    if level == 'ERROR':
        log.error(f'{name}: {message}')
    elif level == 'WARN':
        log.warning(f'{name}: {message}')
    elif log_ok:
        log.info(f'{name}: {message}')
