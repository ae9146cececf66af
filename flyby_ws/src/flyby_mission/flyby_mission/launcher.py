"""The launcher: the mission's node graph run as processes (or in one process), recorded, watched to its end and
summarized (scripts/run_mission.py is its command line).

A run leaves in its directory: scenario.yaml (the input, seed as flown), bag/ (rosbag2, MCAP), summary.json, logs/ and
params/ (one file per node), run.json (ROS domain and process ids, written at start). Every node runs as its own
process on a ROS domain no other run on this machine holds; ``in_process`` runs them all in this process on one
executor instead. The launcher is ROS by purpose: its Monitor is a node of the graph.
"""

import json
import os
import signal
import sys
import time
from dataclasses import dataclass, field

from flyby_mission import cli, live_view, replay
from flyby_mission.fleet_summary import compute_fleet_summary, format_fleet_summary
from flyby_mission.graph_run import Faults, Interrupted, run_in_process, run_processes
from flyby_mission.summary import compute_summary, format_summary
from flyby_mission.supervisor import WATCHED_NODES
from flyby_msgs_py import frames
from flyby_msgs_py.bag import repair_bag
from flyby_msgs_py.domain import lease_domain
from flyby_msgs_py.runtime import FASTDDS_PROFILES
from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_scenario
from flyby_sim.sim_node import COMMAND_CHAIN


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
