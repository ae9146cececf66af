"""The launcher: the mission's node graph run as processes (or in one process), recorded, watched to its end and
summarized (scripts/run_mission.py is its command line).

A run leaves in its directory: scenario.yaml (the input, seed as flown), bag/ (rosbag2, MCAP), summary.json, logs/ and
params/ (one file per node), run.json (ROS domain and process ids, written at start). Every node runs as its own
process on a ROS domain no other run on this machine holds; ``in_process`` runs them all in this process on one
executor instead. The launcher is ROS by purpose: its Monitor is a node of the graph.
"""

import ctypes
import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from flyby_mission import cli, live_view, replay
from flyby_mission.fleet_summary import compute_fleet_summary, format_fleet_summary
from flyby_mission.summary import compute_summary, format_summary
from flyby_mission.supervisor import WATCHED_NODES
from flyby_msgs_py import contract as c
from flyby_msgs_py import frames, qos
from flyby_msgs_py.bag import repair_bag
from flyby_msgs_py.domain import lease_domain
from flyby_msgs_py.runtime import FASTDDS_PROFILES, TICK_TOPIC
from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_scenario
from flyby_sim.sim_node import COMMAND_CHAIN

VENV_PYTHON = sys.executable
FASTDDS_TOOL = Path(sys.prefix) / 'tools' / 'fastdds' / 'fastdds.py'
SIGINT_GRACE_S = 10.0
SIGTERM_GRACE_S = 5.0


class Interrupted(Exception):
    """SIGINT or SIGTERM reached the launcher."""


@dataclass
class NodeSpec:
    """One node of the graph: where its class lives and what it is given."""

    name: str
    module: str
    class_name: str
    params: dict = field(default_factory=dict)
    namespace: str = ''
    remaps: dict = field(default_factory=dict)
    essential: bool = True  # the run cannot go on without it
    nice: int = 0  # scheduling priority of its process (os.nice increment)

    @property
    def label(self):
        """The node's name in the graph (runtime.node_label): ``name``, or ``ns/name`` under a namespace."""
        ns = self.namespace.strip('/')
        return f'{ns}/{self.name}' if ns else self.name


OPTIONAL_NODES = ('flyby_estimator', 'flyby_planner', 'flyby_guidance', 'flyby_supervisor', 'flyby_cam_monitor')
OFF_CHAIN_NICE = 5


def graph_for(scenario_path, seed, rtf, bag_dir, without=(), chasers=()):
    """The nodes of a mission, in start order (the recorder first, the simulator last).

    The simulator holds time still until the other nodes are up and matched, and keeps its pace
    to theirs. ``without`` leaves out optional nodes by name. ``chasers``: the names of a ``chasers:``
    scenario, each chaser's estimator, planner, guidance and supervisor under its namespace (DESIGN §10).
    """
    namespaces = [f'/{name}' for name in chasers] or ['']
    recorder = NodeSpec('flyby_recorder', 'flyby_msgs_py.recorder_node', 'RecorderNode',
                        {'bag_dir': str(bag_dir), 'flush_period_s': 2.0,
                         'namespaces': namespaces})
    # No node reads a ROS clock (they act on message stamps; the recorder logs at the /clock it records): without
    # use_sim_time they are spared rclpy's time-source subscription to the 20 Hz /clock.
    others = [NodeSpec(name, module, cls, {'scenario_file': str(scenario_path), 'seed': seed, 'chaser': ns[1:]},
                       namespace=ns, essential=False)
              for ns in namespaces
              for name, module, cls in (('flyby_estimator', 'flyby_estimation.estimator_node', 'EstimatorNode'),
                                        ('flyby_planner', 'flyby_planner.planner_node', 'PlannerNode'),
                                        ('flyby_guidance', 'flyby_guidance.guidance_node', 'GuidanceNode'),
                                        ('flyby_supervisor', 'flyby_mission.supervisor_node', 'SupervisorNode'),
                                        ('flyby_cam_monitor', 'flyby_mission.cam_monitor_node', 'CamMonitorNode'))]
    others = [n for n in others if n.name not in without]
    names = [n.name for n in others]
    for n in others:
        if n.name == 'flyby_supervisor':
            n.params['watched_nodes'] = [w for w in WATCHED_NODES if w in names] or ['']
    # Flow control every 1 s of sim time: no node lags more than 2 s, well inside the 5 s lead of
    # guidance's commands, so every burn starts on its stamp at any pace (determinism).
    sim = NodeSpec('flyby_sim', 'flyby_sim.sim_node', 'SimNode',
                   {'scenario_file': str(scenario_path), 'seed': seed, 'rtf': float(rtf), 'flow_control_period_s': 1.0,
                    'wait_for_nodes': [n.label for n in [recorder, *others]],
                    'keep_up_with': [n.label for n in [recorder, *others]]})
    # The nodes off the simulator's command chain (sim -> estimator -> guidance -> sim, DESIGN §10) yield the
    # CPU to it: they only have to keep up within the flow-control window, while every turn of the chain holds
    # the simulator's time.
    for spec in [recorder, *others]:
        if spec.name not in COMMAND_CHAIN:
            spec.nice = OFF_CHAIN_NICE
    return [recorder, *others, sim]


def with_viewers(specs, scenario, foxglove_port=None):
    """The frames for viewers: the recorder writes the scenario's static mounts on /tf_static, and with a Foxglove
    port the live view (flyby_mission.live_view) joins the graph after the recorder (so it stops just before it).
    The simulator waits for it to start, as for every node, so a viewer sees the run from its first step, but not
    for its pace (off the flow control); it is not essential to the run and yields the CPU as the recorder does."""
    recorder, sim = specs[0], specs[-1]
    recorder.params['static_transforms'] = [frames.format_static(t) for t in live_view.static_transforms(scenario)]
    if foxglove_port is None:
        return specs
    view = NodeSpec('flyby_live_view', 'flyby_mission.live_view_node', 'LiveViewNode',
                    {'port': foxglove_port, 'namespaces': recorder.params['namespaces'],
                     'static_transforms': recorder.params['static_transforms']}, essential=False, nice=OFF_CHAIN_NICE)
    sim.params['wait_for_nodes'] = [*sim.params['wait_for_nodes'], view.label]
    return [recorder, view, *specs[1:]]


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
            file_name = spec.label.replace('/', '.')
            params_file = self.run_dir / 'params' / f'{file_name}.yaml'
            params_file.write_text(yaml.safe_dump({'/**': {'ros__parameters': spec.params}}))
            cmd = [VENV_PYTHON, '-m', spec.module, '--ros-args', '-r', f'__node:={spec.name}',
                   '--params-file', str(params_file)]
            if spec.namespace:
                cmd += ['-r', f'__ns:={spec.namespace}']
            for src, dst in spec.remaps.items():
                cmd += ['-r', f'{src}:={dst}']
            log = open(self.run_dir / 'logs' / f'{file_name}.log', 'w')
            self.procs[spec.label] = subprocess.Popen(
                cmd, env=self.env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                start_new_session=True, preexec_fn=_child_setup(spec.nice))
            log.close()
        # Lets a user (or a test) find the run's domain and processes while it runs.
        cli.write_marker(self.run_dir, {'ros_domain_id': int(self.env['ROS_DOMAIN_ID']), 'launcher_pid': os.getpid(),
                                        'pids': {name: p.pid for name, p in self.procs.items()}})

    def poll(self):
        """Names of the nodes that have exited since the last call, with their exit codes."""
        ended = {}
        for name, proc in self.procs.items():
            if name not in self.exit_codes and proc.poll() is not None:
                self.exit_codes[name] = ended[name] = proc.returncode
        return ended

    def kill(self, name):
        """SIGKILL one node (an injected crash)."""
        proc = self.procs.get(name)
        if proc is not None and proc.poll() is None:
            proc.kill()

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
    """The launcher's own node: watches the phase and the clock.

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
    try:
        graph.start()
        deadline = time.monotonic() + wall_timeout_s
        while reason is None:
            monitor.spin(0.1)
            progress(monitor.sim_time_s)
            victim = monitor.due_kill()
            if victim:
                graph.kill(victim)
            for name, code in graph.poll().items():
                spec = next(s for s in specs if s.label == name)
                if name == 'flyby_sim' and code == 0:
                    reason = 'time_limit'
                elif spec.essential and name != faults.kill_node:
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

    from flyby_msgs_py.runtime import run_loop

    context = Context()
    rclpy.init(context=context, domain_id=int(env['ROS_DOMAIN_ID']),
               signal_handler_options=SignalHandlerOptions.NO)
    executor = EventsExecutor(context=context)
    nodes = []
    reason = None
    monitor = None
    try:
        for spec in specs:
            cls = getattr(importlib.import_module(spec.module), spec.class_name)
            overrides = [Parameter(k, value=v) for k, v in spec.params.items()]
            node = cls(context=context, parameter_overrides=overrides,
                       namespace=spec.namespace or None, cli_args=None)
            nodes.append(node)
            executor.add_node(node)
        monitor = Monitor(context, abort_hold_s, executor, faults, specs[0].params['namespaces'])
        deadline = time.monotonic() + wall_timeout_s
        sim = nodes[-1]

        def should_stop():
            progress(sim.plant.t)
            victim = monitor.due_kill()
            if victim:
                node = next(n for n in nodes if n.get_name() == victim)
                nodes.remove(node)
                executor.remove_node(node)
                node.destroy_node()
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


def faults_from_args(args):
    """Faults of --abort-at / --kill; ValueError naming the bad option."""
    faults = Faults(abort_at_s=args.abort_at)
    if args.kill:
        name, _, at = args.kill.partition('@')
        try:
            faults.kill_node, faults.kill_at_s = name, float(at)
        except ValueError:
            raise ValueError(f'--kill: expected NODE@T with T a sim time in s, got {args.kill!r}') from None
        if name not in OPTIONAL_NODES:
            raise ValueError(f'--kill: {name!r} is not a node that can be killed ({", ".join(OPTIONAL_NODES)})')
    return faults



class LaunchError(Exception):
    """A bad input or option: the run does not start (the command line's exit code 1; 2 for a misused option that
    scripts/run_mission.py refuses before)."""


@dataclass
class LaunchOptions:
    """What a run is asked for: the options of scripts/run_mission.py, by the same names."""

    scenario: str
    out: str
    seed: int = None
    rtf: float = 0.0
    in_process: bool = False
    force: bool = False
    wall_timeout: float = 1800.0
    without: list = field(default_factory=list)
    quiet: bool = False
    abort_at: float = None
    kill: str = None
    foxglove: int = None  # port of the live Foxglove server (flyby_mission.live_view); None: none


def prepare(options):
    """(scenario, faults, run directory) of a run, its inputs checked in order; LaunchError naming the first
    that is wrong."""
    try:
        scenario = load_scenario(options.scenario, seed=options.seed)
    except ScenarioError as err:
        raise LaunchError(str(err)) from None
    try:
        faults = faults_from_args(options)
    except ValueError as err:
        raise LaunchError(str(err)) from None
    if not options.rtf >= 0 or options.rtf == float('inf'):
        raise LaunchError(f'--rtf: must be a finite number >= 0, got {options.rtf}')
    if not 0 < options.wall_timeout < float('inf'):
        raise LaunchError(f'--wall-timeout: must be a finite number > 0, got {options.wall_timeout}')
    if options.foxglove is not None:
        try:
            live_view.check_port(options.foxglove, options.in_process)
        except ValueError as err:
            raise LaunchError(str(err)) from None
    try:
        run_dir = cli.check_out(options.out, options.force)
    except ValueError as err:
        raise LaunchError(str(err)) from None
    return scenario, faults, run_dir


def _ros_environment(domain_id, in_process):
    """The nodes' environment: the run's own ROS domain, discovery on this host only (none in one process) and the
    Fast DDS profiles; this process takes the same, for its monitor node."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id), PYTHONUNBUFFERED='1',
               ROS_AUTOMATIC_DISCOVERY_RANGE='OFF' if in_process else 'LOCALHOST',
               FASTRTPS_DEFAULT_PROFILES_FILE=str(FASTDDS_PROFILES))
    os.environ.update({k: env[k] for k in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE',
                                           'FASTRTPS_DEFAULT_PROFILES_FILE')})
    return env


def _interrupt_on_signals():
    """SIGINT and SIGTERM raise Interrupted from now on; the handlers they replace, by signal."""
    def on_signal(signum, _frame):
        raise Interrupted(signal.Signals(signum).name)

    return {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}


def _progress_printer(quiet, duration_s):
    """progress(sim_time_s): a line on stderr at most every 2 s of wall time (none when quiet)."""
    last_print = [0.0]

    def progress(sim_time_s):
        now = time.monotonic()
        if not quiet and now - last_print[0] > 2.0:
            last_print[0] = now
            print(f'  sim time {sim_time_s:8.1f} s / {duration_s:.0f} s', file=sys.stderr, flush=True)
    return progress


def _summarize(run_dir, scenario, ended, wall_time_s, faults, kill):
    """The run's summary from its bag (repaired first when cut short), written to run_dir/summary.json."""
    reason, killed, exit_codes, phase = ended
    bag_dir = run_dir / 'bag'
    repair = None
    if not (bag_dir / 'metadata.yaml').exists() and bag_dir.exists():
        repair = repair_bag(bag_dir)
    launcher = dict(node_exit_codes=exit_codes, nodes_killed=killed, bag_repair=repair,
                    faults_injected={'abort_at_s': faults.abort_at_s, 'kill': kill})
    if scenario.chaser_names:
        summary = compute_fleet_summary(bag_dir, scenario, reason, wall_time_s, **launcher)
    else:
        summary = compute_summary(bag_dir, scenario, end_reason=reason, final_phase=phase, wall_time_s=wall_time_s,
                                  **launcher)
    (run_dir / 'summary.json').write_text(json.dumps(summary, indent=2) + '\n')
    return summary


def run(options):
    """One mission: check the inputs (LaunchError), make the run directory, run the graph on a leased ROS domain
    until its end, write and print the summary; the summary."""
    scenario, faults, run_dir = prepare(options)
    replay_command = replay.replay_command('run_mission.py', run_dir, replay.launcher_options(options))
    lease = lease_domain()
    try:  # run.json first (what --force may replace), with the run's domain for a user to join it
        cli.make_run_dir(run_dir, options.force, {'ros_domain_id': lease.domain_id, 'launcher_pid': os.getpid(),
                                                  'pids': {}, replay.REPLAY_KEY: replay_command})
    except ValueError as err:
        lease.release()
        raise LaunchError(str(err)) from None
    scenario_file = replay.write_scenario(run_dir, options.scenario, scenario.seed)  # the effective seed
    bag_dir = run_dir / 'bag'
    env = _ros_environment(lease.domain_id, options.in_process)
    previous_handlers = _interrupt_on_signals()
    progress = _progress_printer(options.quiet, scenario.simulation.duration_s)
    specs = graph_for(scenario_file.resolve(), scenario.seed, options.rtf, bag_dir.resolve(),
                      options.without, scenario.chaser_names)
    specs = with_viewers(specs, scenario, options.foxglove)
    print(f'flyby: scenario {scenario.name}, seed {scenario.seed}, ROS domain {lease.domain_id}, '
          f'{"in-process" if options.in_process else f"{len(specs)} processes"} -> {run_dir}',
          file=sys.stderr, flush=True)
    wall_start = time.monotonic()
    abort_hold_s = scenario.supervisor.abort_observation_s
    try:
        if options.in_process:
            ended = run_in_process(specs, env, options.wall_timeout, progress, abort_hold_s, faults)
        else:
            ended = run_processes(specs, run_dir, env, options.wall_timeout, progress, abort_hold_s, faults)
    finally:
        # A second Ctrl-C must not cost the summary.
        for sig in previous_handlers:
            signal.signal(sig, signal.SIG_IGN)
        lease.release()
    wall_time_s = time.monotonic() - wall_start
    # The nodes' start rewrote run.json with their pids: the replay command joins them again.
    marker = json.loads((run_dir / cli.RUN_MARKER).read_text())
    cli.write_marker(run_dir, {**marker, replay.REPLAY_KEY: replay_command})
    try:
        summary = _summarize(run_dir, scenario, ended, wall_time_s, faults, options.kill)
    finally:
        for sig, handler in previous_handlers.items():
            signal.signal(sig, handler)
    print(format_fleet_summary(summary) if scenario.chaser_names else format_summary(summary))
    return summary
