"""The launcher's graph at run time: the nodes as processes (or in one process), the launcher's own monitor node
(the phase, the clock, the injected faults) and the run loop until the mission's end (flyby_mission.launcher
prepares the run and summarizes it).

The faults it injects: an abort request and a killed node (``--abort-at``, ``--kill``), and the scenario's
``node_crash`` faults (flyby_sim.faults), which the simulator reports on mission/events: the node killed at the
fault's start and started again, a respawn, at its end (a fresh node: the latched topics and the events' history
give it what it missed, as they give any late joiner).
"""

import collections
import ctypes
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import yaml

from flyby_mission import cli
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, qos
from flyby_msgs_py.runtime import TICK_TOPIC
from flyby_sim.faults import node_crash_event

VENV_PYTHON = sys.executable
FASTDDS_TOOL = Path(sys.prefix) / 'tools' / 'fastdds' / 'fastdds.py'
SIGINT_GRACE_S = 10.0
SIGTERM_GRACE_S = 5.0


class Interrupted(Exception):
    """SIGINT or SIGTERM reached the launcher."""


def _child_setup(nice):
    """Child side of Popen: get SIGTERM if the launcher dies, so no node outlives a lost run; take the
    node's scheduling priority."""
    def setup():
        libc = ctypes.CDLL('libc.so.6', use_errno=True)
        libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
        if nice:
            os.nice(nice)
            # Each node is its own session, and with the kernel's autogroup scheduling (Debian's default)
            # sessions share the CPU evenly whatever their processes' nice: the session's own nice counts.
            try:
                with open('/proc/self/autogroup', 'w') as f:
                    f.write(str(nice))
            except OSError:
                pass
    return setup


class ProcessGraph:
    """Every node its own process."""

    def __init__(self, specs, run_dir, env):
        self.specs = specs
        self.run_dir = run_dir
        self.env = env
        self.procs = {}
        self.exit_codes = {}

    def start(self):
        (self.run_dir / 'logs').mkdir(exist_ok=True)
        (self.run_dir / 'params').mkdir(exist_ok=True)
        for spec in self.specs:
            self._start(spec)
        # Lets a user (or a test) find the run's domain and processes while it runs.
        self._write_marker()

    def _write_marker(self):
        cli.write_marker(self.run_dir, {'ros_domain_id': int(self.env['ROS_DOMAIN_ID']), 'launcher_pid': os.getpid(),
                                        'pids': {name: p.pid for name, p in self.procs.items()}})

    def respawn(self, name):
        """Start a killed node again (a node_crash's end): a fresh process, its log appended to."""
        spec = next((s for s in self.specs if s.label == name), None)
        if spec is None:
            return
        self.exit_codes.pop(name, None)
        self._start(spec, mode='a')
        self._write_marker()

    def _start(self, spec, mode='w'):
        """The node's process, its parameters written to params/ and its output to logs/."""
        file_name = spec.label.replace('/', '.')
        params_file = self.run_dir / 'params' / f'{file_name}.yaml'
        params_file.write_text(yaml.safe_dump({'/**': {'ros__parameters': spec.params}}))
        cmd = [VENV_PYTHON, '-m', spec.module, '--ros-args', '-r', f'__node:={spec.name}',
               '--params-file', str(params_file)]
        if spec.namespace:
            cmd += ['-r', f'__ns:={spec.namespace}']
        for src, dst in spec.remaps.items():
            cmd += ['-r', f'{src}:={dst}']
        with open(self.run_dir / 'logs' / f'{file_name}.log', mode) as log:
            self.procs[spec.label] = subprocess.Popen(
                cmd, env=self.env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                start_new_session=True, preexec_fn=_child_setup(spec.nice))

    def poll(self):
        """Names of the nodes that have exited since the last call, with their exit codes."""
        ended = {}
        for name, proc in self.procs.items():
            if name not in self.exit_codes and proc.poll() is not None:
                self.exit_codes[name] = ended[name] = proc.returncode
        return ended

    def kill(self, name):
        """SIGKILL one node (an injected crash), and wait for it to go."""
        proc = self.procs.get(name)
        if proc is not None and proc.poll() is None:
            proc.kill()
            try:
                proc.wait(timeout=SIGTERM_GRACE_S)
            except subprocess.TimeoutExpired:
                pass  # poll() sees it go; a respawn before then starts the new process beside it

    def stop(self):
        """Stop in order (simulator first, recorder last): SIGINT, then SIGTERM, then SIGKILL."""
        killed = []
        for spec in reversed(self.specs):
            proc = self.procs.get(spec.label)
            if proc is None or proc.poll() is not None:
                continue
            for sig, grace in ((signal.SIGINT, SIGINT_GRACE_S), (signal.SIGTERM, SIGTERM_GRACE_S),
                               (signal.SIGKILL, None)):
                proc.send_signal(sig)
                if grace is None:
                    proc.wait()
                    killed.append(spec.label)
                    break
                try:
                    proc.wait(timeout=grace)
                    break
                except subprocess.TimeoutExpired:
                    continue
        self.poll()
        return killed


@dataclass
class Faults:
    """Faults the launcher injects (for tests and what-if runs): an abort request, a killed node."""

    abort_at_s: float = None
    kill_node: str = None
    kill_at_s: float = None
    killed: bool = False


class Monitor:
    """The launcher's own node: watches the phase, the clock and the simulator's node_crash faults (``crashes``:
    what to do with which node, in order).

    The run is over once the phase is terminal: at once for COMPLETE, after ``abort_hold_s`` of sim
    time for ABORTED (so the bag records the start of the escape and any avoidance burn).
    """

    def __init__(self, context, abort_hold_s, executor=None, faults=None, namespaces=('',)):
        from rclpy.experimental import EventsExecutor
        from rclpy.node import Node
        from std_srvs.srv import Trigger

        self.node = Node('flyby_launcher', context=context)
        self.phases = dict.fromkeys(namespaces)  # with several chasers the run ends once every one's has ended
        self.sim_time_s = 0.0
        self.abort_hold_s = abort_hold_s
        self.t_terminal = None
        self.faults = faults or Faults()
        self.abort_client = self.node.create_client(Trigger, c.MISSION_ABORT_SERVICE)
        self.abort_future = None
        for ns in namespaces:
            self.node.create_subscription(c.message_class(c.TOPIC_TYPES[c.MISSION_PHASE]),
                                          c.absolute(c.MISSION_PHASE, ns) if ns else c.MISSION_PHASE,
                                          lambda msg, ns=ns: self._on_phase(ns, msg), qos.QOS_LATCHED)
            self.node.create_subscription(c.message_class(c.TOPIC_TYPES[c.MISSION_EVENTS]),
                                          c.absolute(c.MISSION_EVENTS, ns) if ns else c.MISSION_EVENTS,
                                          lambda msg, ns=ns: self._on_events(ns, msg), qos.QOS_EVENTS)
        self.crashes = []  # ('kill' or 'respawn', node label) of the node_crash faults, as they come
        self.node.create_subscription(c.message_class(c.TOPIC_TYPES[c.CLOCK]), TICK_TOPIC,
                                      self._on_clock, qos.QOS_STREAM)
        self.own_executor = executor is None
        self.executor = EventsExecutor(context=context) if executor is None else executor
        self.executor.add_node(self.node)

    @property
    def phase(self):
        """The phase; with several chasers ``name:PHASE`` of each, comma separated."""
        if list(self.phases) == ['']:
            return self.phases['']
        return ','.join(f'{ns.strip("/")}:{p}' for ns, p in self.phases.items())

    def _on_phase(self, ns, msg):
        self.phases[ns] = msg.data
        if all(p in c.TERMINAL_PHASES for p in self.phases.values()) and self.t_terminal is None:
            self.t_terminal = self.sim_time_s

    def _on_events(self, ns, msg):
        for e in convert.events_from_msg(msg):
            crash = node_crash_event(e['name'], e['values'])
            if crash is not None:
                node, down = crash
                self.crashes.append(('kill' if down else 'respawn', f'{ns.strip("/")}/{node}' if ns else node))

    def due_crashes(self):
        """The node_crash actions that have come since the last call."""
        due, self.crashes = self.crashes, []
        return due

    def _on_clock(self, msg):
        self.sim_time_s = msg.clock.sec + 1e-9 * msg.clock.nanosec
        f = self.faults
        if f.abort_at_s is not None and self.abort_future is None and self.sim_time_s >= f.abort_at_s:
            from std_srvs.srv import Trigger
            self.abort_future = self.abort_client.call_async(Trigger.Request())

    def due_kill(self):
        """The node to kill now (once), if the --kill fault is due."""
        f = self.faults
        if f.kill_node and not f.killed and self.sim_time_s >= f.kill_at_s:
            f.killed = True
            return f.kill_node
        return None

    @property
    def done(self):
        if self.t_terminal is None:
            return False
        hold = self.abort_hold_s if c.PHASE_ABORTED in self.phases.values() else 0.0
        return self.sim_time_s >= self.t_terminal + hold

    def spin(self, seconds):
        self.executor.spin_once(timeout_sec=seconds)

    def close(self):
        if self.own_executor:
            self.executor.shutdown()
        else:
            self.executor.remove_node(self.node)
        self.node.destroy_node()


def clean_shared_memory():
    """Remove Fast DDS shared-memory segments left by killed processes (DESIGN §9)."""
    subprocess.run([VENV_PYTHON, str(FASTDDS_TOOL), 'shm', 'clean'], stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, check=False, timeout=60)


def run_processes(specs, run_dir, env, wall_timeout_s, progress, abort_hold_s, faults):
    """Run the graph as processes; return (end reason, nodes killed, node exit codes)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions

    context = Context()
    rclpy.init(context=context, domain_id=int(env['ROS_DOMAIN_ID']),
               signal_handler_options=SignalHandlerOptions.NO)
    monitor = Monitor(context, abort_hold_s, faults=faults, namespaces=specs[0].params['namespaces'])
    graph = ProcessGraph(specs, run_dir, env)
    reason = None
    down = collections.Counter()  # node -> the node_crash faults holding it down: its exit is theirs
    try:
        graph.start()
        deadline = time.monotonic() + wall_timeout_s
        while reason is None:
            monitor.spin(0.1)
            progress(monitor.sim_time_s)
            victim = monitor.due_kill()
            if victim:
                graph.kill(victim)
            for action, label in monitor.due_crashes():  # overlapping crashes: up again after the last
                down[label] += 1 if action == 'kill' else -1 if down[label] else 0
                if action == 'kill' and down[label] == 1:
                    graph.kill(label)
                elif action == 'respawn' and not down[label]:
                    graph.respawn(label)
            for name, code in graph.poll().items():
                spec = next(s for s in specs if s.label == name)
                if name == 'flyby_sim' and code == 0:
                    reason = 'time_limit'
                elif spec.essential and name != faults.kill_node and not down[name]:
                    reason = f'error: node {name} exited with code {code}'
            if monitor.done:
                reason = f'phase {monitor.phase}'
            if time.monotonic() > deadline:
                reason = f'error: wall-clock timeout after {wall_timeout_s} s'
    except Interrupted:
        reason = 'interrupted'
    finally:
        killed = graph.stop()
        monitor.close()
        rclpy.try_shutdown(context=context)
        clean_shared_memory()
    return reason, killed, graph.exit_codes, monitor.phase


def run_in_process(specs, env, wall_timeout_s, progress, abort_hold_s, faults):
    """Every node in this process on one EventsExecutor (what the integration tests use)."""
    import importlib

    import rclpy
    from rclpy.context import Context
    from rclpy.experimental import EventsExecutor
    from rclpy.parameter import Parameter
    from rclpy.signals import SignalHandlerOptions

    from flyby_msgs_py import runtime
    from flyby_msgs_py.runtime import run_loop

    context = Context()
    rclpy.init(context=context, domain_id=int(env['ROS_DOMAIN_ID']),
               signal_handler_options=SignalHandlerOptions.NO)
    executor = EventsExecutor(context=context)
    nodes = []
    reason = None
    monitor = None

    def start(spec):
        cls = getattr(importlib.import_module(spec.module), spec.class_name)
        overrides = [Parameter(k, value=v) for k, v in spec.params.items()]
        node = cls(context=context, parameter_overrides=overrides, namespace=spec.namespace or None, cli_args=None)
        nodes.insert(len(nodes) - 1 if nodes and nodes[-1] is sim else len(nodes), node)  # the simulator stays last
        executor.add_node(node)

    def kill(label):
        node = next((n for n in nodes if runtime.node_label(n) == label), None)
        if node is not None:
            nodes.remove(node)
            executor.remove_node(node)
            node.destroy_node()

    sim = None
    try:
        for spec in specs:
            start(spec)
        sim = nodes[-1]
        monitor = Monitor(context, abort_hold_s, executor, faults, specs[0].params['namespaces'])
        deadline = time.monotonic() + wall_timeout_s

        def should_stop():
            progress(sim.plant.t)
            victim = monitor.due_kill()
            if victim:
                kill(victim)
            for action, label in monitor.due_crashes():  # a node_crash: killed, then a fresh node of its spec
                if action == 'kill':
                    kill(label)
                elif not any(runtime.node_label(n) == label for n in nodes):
                    start(next(s for s in specs if s.label == label))
            return monitor.done or time.monotonic() > deadline

        run_loop(executor, nodes, should_stop, drain=True)
        if monitor.done:
            reason = f'phase {monitor.phase}'
        else:
            reason = 'time_limit' if sim.finished else f'error: wall-clock timeout after {wall_timeout_s} s'
    except Interrupted:
        reason = 'interrupted'
    finally:
        if monitor is not None:
            monitor.close()
        for node in reversed(nodes):
            close = getattr(node, 'close', None)
            if close is not None:
                close()
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()
        rclpy.try_shutdown(context=context)
    return reason, [], {}, monitor.phase if monitor is not None else None
