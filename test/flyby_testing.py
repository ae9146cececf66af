"""Helpers of the integration tests: scenario variants, running the launcher, spinning."""

import json
import struct
import subprocess
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / 'scenarios'
RUN_MISSION = ROOT / 'scripts' / 'run_mission.py'


def paper_dict(name='paper_flyby'):
    """scenarios/<name>.yaml (paper_flyby's by default) as a dict, to mutate."""
    return yaml.safe_load((SCENARIOS / f'{name}.yaml').read_text())


def write_yaml(tmp_path, data, name='x.yaml'):
    """data (text, or a dict dumped as YAML) written to tmp_path/name; the path."""
    p = Path(tmp_path) / name
    p.write_text(data if isinstance(data, str) else yaml.safe_dump(data, sort_keys=False))
    return p


def scenario_error_of(tmp_path, mutate, base='paper_flyby'):
    """Load scenarios/<base>.yaml mutated by ``mutate(d)`` from a file; return (path, the refusal's one-line
    message)."""
    import pytest

    from flyby_msgs_py.schema import ScenarioError
    from flyby_sim.scenario import load_scenario

    d = paper_dict(base)
    mutate(d)
    p = write_yaml(tmp_path, d)
    with pytest.raises(ScenarioError) as info:
        load_scenario(p)
    msg = str(info.value)
    assert '\n' not in msg
    assert msg.startswith(f'{p}: ')
    return p, msg


def perturbed(q, omega, dx):
    """The attitude state whose error relative to (q, omega) is dx = [dtheta_body, domega_body] (the target filter's
    error state, seed 000 eq 4)."""
    from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_multiply

    return quat_multiply(q, quat_from_rotation_vector(dx[:3])), omega + dx[3:]


def error_between(q_ref, omega_ref, q, omega):
    """The attitude error state [dtheta_body, domega_body] of (q, omega) relative to (q_ref, omega_ref)."""
    import numpy as np

    from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, rotation_vector_from_quat

    return np.concatenate((rotation_vector_from_quat(quat_multiply(quat_conjugate(q_ref), q)), omega - omega_ref))


def write_scenario(tmp_path, base='paper_flyby', name='variant', edit=None):
    """A copy of ``scenarios/<base>.yaml`` changed by ``edit(dict)``, written into tmp_path."""
    data = yaml.safe_load((SCENARIOS / f'{base}.yaml').read_text())
    if edit is not None:
        edit(data)
    path = Path(tmp_path) / f'{name}.yaml'
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def with_duration(duration_s):
    """A scenario edit (for write_scenario) that sets simulation.duration_s."""
    def edit(data):
        data['simulation']['duration_s'] = duration_s
    return edit


def run_mission(*args, timeout=600):
    """The launcher as a user runs it: a subprocess; returns the CompletedProcess."""
    return subprocess.run([sys.executable, str(RUN_MISSION), '--quiet', *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, cwd=ROOT)


def fly_variant(tmp_dir, base, name, edit):
    """A variant of ``scenarios/<base>.yaml`` (``write_scenario``) flown in the graph by the launcher into
    tmp_dir/run, asserted to exit 0: (the run directory, the scenario file)."""
    scenario = write_scenario(tmp_dir, base=base, name=name, edit=edit)
    out = Path(tmp_dir) / 'run'
    done = run_mission('--scenario', scenario, '--out', out)
    assert done.returncode == 0, done.stderr[-3000:] + done.stdout[-3000:]
    return out, scenario


def tug_short(data):
    """A short variant of scenarios/paper_flyby_tug.yaml: 30 m ahead instead of 50, 20 s of observation, a 60 s
    fly-by after a 40-80 s transfer (the grasp at about 309 s instead of 813 s), the wheels' momentum dumped at 0.2/s
    and a 4 N m couple (about 70 s of damping instead of 190 s), 600 s at most: about 410 s of simulated time."""
    data['chaser']['initial_position_hill_m'] = [30.0, 0.0, 0.0]
    data['chaser']['initial_attitude']['body_axis_along_hill']['hill'] = [-1.0, 0.0, 0.0]
    data['planner'].update(method='flyby', min_observation_s=20.0, flyby_duration_s=60.0, transfer_min_s=40.0,
                           transfer_max_s=80.0)
    data['post_capture']['damping'].update(max_thruster_torque_n_m=4.0, dump_rate_per_s=0.2)
    data['simulation']['duration_s'] = 600.0


def analyze_bag(run_dir):
    """scripts/analyze_bag.py on a run directory, as a user runs it; returns the CompletedProcess."""
    return subprocess.run([sys.executable, str(ROOT / 'scripts' / 'analyze_bag.py'), str(run_dir)],
                          capture_output=True, text=True, cwd=ROOT)


def read_summary(run_dir):
    return json.loads((Path(run_dir) / 'summary.json').read_text())


def spin_until(executor, predicate, timeout_s=30.0, tick=None):
    """Spin (and tick) until ``predicate()``; fail the test on timeout."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f'condition not met within {timeout_s} s')
        wait = tick() if tick is not None else 0.05
        executor.spin_once(timeout_sec=min(max(wait, 0.0), 0.05))


def spin_for(executor, seconds):
    """Spin for a while (to show that something does *not* happen)."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)


class ClockWatcher:
    """Listens to /clock on another run's ROS domain (from its run.json), from this process."""

    def __init__(self, run_dir):
        import rclpy
        from rclpy.context import Context
        from rclpy.experimental import EventsExecutor
        from rclpy.node import Node
        from rosgraph_msgs.msg import Clock

        from flyby_msgs_py import qos

        self.info = json.loads((Path(run_dir) / 'run.json').read_text())
        self.context = Context()
        rclpy.init(context=self.context, domain_id=self.info['ros_domain_id'])
        self.node = Node('test_clock_watcher', context=self.context)
        self.sim_time_s = 0.0
        self.node.create_subscription(Clock, '/clock', self._on_clock, qos.QOS_STREAM)
        self.executor = EventsExecutor(context=self.context)
        self.executor.add_node(self.node)

    def _on_clock(self, msg):
        self.sim_time_s = msg.clock.sec + 1e-9 * msg.clock.nanosec

    def wait_until(self, sim_time_s, timeout_s=60.0):
        spin_until(self.executor, lambda: self.sim_time_s >= sim_time_s, timeout_s)
        return self.sim_time_s

    def close(self):
        import rclpy
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def wait_for_file(path, timeout_s=30.0):
    deadline = time.monotonic() + timeout_s
    while not Path(path).exists():
        if time.monotonic() > deadline:
            raise AssertionError(f'{path} did not appear within {timeout_s} s')
        time.sleep(0.05)


def start_launcher(scenario, out, *extra):
    """The launcher as a background process (stdout/stderr piped)."""
    return subprocess.Popen([sys.executable, str(RUN_MISSION), '--quiet', '--scenario',
                             str(scenario), '--out', str(out), *map(str, extra)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)


def launch_and_wait(scenario, out, sim_time_s, *extra):
    """Start the launcher and return (process, run.json contents, sim time) once the run's clock
    has reached ``sim_time_s``."""
    launcher = start_launcher(scenario, out, *extra)
    wait_for_file(Path(out) / 'run.json')
    watcher = ClockWatcher(out)
    try:
        reached = watcher.wait_until(sim_time_s)
    finally:
        watcher.close()
    return launcher, json.loads((Path(out) / 'run.json').read_text()), reached  # with the pids, written once started


def collect(node, topic, namespace=''):
    """Subscribe ``node`` to a contract topic (under ``namespace`` if given); return the list its
    messages are appended to."""
    from flyby_msgs_py import contract as c
    from flyby_msgs_py import qos
    received = []
    profile = qos.recorder_qos_for(topic)  # deep, and transient-local where the publisher latches
    name = c.absolute(topic, namespace) if namespace else topic
    node.create_subscription(c.message_class(c.TOPIC_TYPES[topic]), name, received.append, profile)
    return received


def envelope_run(values):
    """A scenario edit (for write_scenario) setting a run's values by their dotted scenario keys, as
    campaigns/flyby_envelope.yaml draws them (campaign seed 2026), and the campaign's override (no lighting)."""
    def edit(d):
        from flyby_mission.campaign.dispersions import set_values
        set_values(d, {'planner.sun_direction_hill': None, **values})
    return edit


# Envelope run 569: an 8.2 deg/s spin about the intermediate principal axis (body x), the grasp point on the +y face.
envelope_run_569 = envelope_run({
    'target.initial_rate.omega_body_deg_s': [-8.175128388491231, -0.636680740332563, -0.15726095827891964],
    'target.initial_attitude.body_axis_along_hill.hill': [0.2727377174418644, -0.7387481216378883,
                                                          -0.6163321752603003],
    'target.grasp_point_body_m': [-1.3307346145151664, 1.5, 0.46957523398567913],
    'target.geometry.1.size_m': [2.010558977059335, 5.712148812400723, 0.05],
    'target.geometry.2.size_m': [1.7481567402253142, 6.084190090071806, 0.05],
    'chaser.initial_position_hill_m': [36.03019711630237, -26.076948318751352, -78.41055905044796],
    'chaser.thrusters.magnitude_error_sigma': 0.005757055901678327,
    'chaser.thrusters.direction_error_sigma_deg': 0.7593258264653564,
    'sensors.relative_position.noise_sigma_m': 0.016113209381107767,
    'sensors.target_attitude.noise_sigma_deg': 1.7537225542714447})

# Envelope run 340: a 5.7 deg/s tumbler, the grasp point on the +y face by the panel's root, the chaser 78 m away
# off-plane and below.
envelope_run_340 = envelope_run({
    'target.initial_attitude.body_axis_along_hill.hill': [-0.09278677218054109, 0.2295665228374612,
                                                          -0.9688600654896629],
    'target.initial_rate.omega_body_deg_s': [5.374623889591393, -0.9272282582590962, 1.6371492101706349],
    'target.grasp_point_body_m': [-0.31502373010731066, 1.5, 0.4952350983208653],
    'target.geometry.1.size_m': [2.1679599903158895, 6.831801153721422, 0.05],
    'target.geometry.2.size_m': [1.9457552554429, 5.197391235915042, 0.05],
    'chaser.initial_position_hill_m': [-3.1038567585339956, 54.05183265722474, 56.71057469823575],
    'chaser.thrusters.magnitude_error_sigma': 0.013933381310087634,
    'chaser.thrusters.direction_error_sigma_deg': 0.3904937534561491,
    'sensors.relative_position.noise_sigma_m': 0.014883731004898053,
    'sensors.target_attitude.noise_sigma_deg': 1.025316864343389,
    'simulation.duration_s': 3000.0})

# Envelope run 323 (values to 4-5 digits): a 6 deg/s tumbler, the grasp point on the -y face by the bus edge, the
# chaser 42 m away below and behind.
envelope_run_323 = envelope_run({
    'target.initial_attitude.body_axis_along_hill.hill': [-0.6719, -0.3901, -0.6296],
    'target.initial_rate.omega_body_deg_s': [-1.6203, 0.3315, -5.6986],
    'target.grasp_point_body_m': [1.4617, -1.5, 0.4524],
    'target.geometry.1.size_m': [1.6808, 6.0826, 0.05],
    'target.geometry.2.size_m': [2.0623, 5.8524, 0.05],
    'chaser.initial_position_hill_m': [24.875, -12.248, -31.949],
    'chaser.thrusters.magnitude_error_sigma': 0.0159,
    'chaser.thrusters.direction_error_sigma_deg': 0.853,
    'sensors.relative_position.noise_sigma_m': 0.0172,
    'sensors.target_attitude.noise_sigma_deg': 0.937,
    'simulation.duration_s': 3000.0})


# MCAP record opcodes (https://mcap.dev/spec#records), for the tests that walk or damage a bag's file.
OP_FOOTER, OP_CHUNK, OP_MESSAGE_INDEX, OP_DATA_END = 0x02, 0x06, 0x07, 0x0F


def record_spans(data):
    """``(opcode, start, end)`` of the top-level records of a closed MCAP file up to its footer, walked
    by their 9-byte heads (opcode uint8, body length uint64; https://mcap.dev/spec#records)."""
    from flyby_msgs_py.bag import MCAP_MAGIC

    spans, pos = [], len(MCAP_MAGIC)
    while True:
        op, length = struct.unpack_from('<BQ', data, pos)
        spans.append((op, pos, pos + 9 + length))
        if op == OP_FOOTER:
            return spans
        pos += 9 + length


def step_to(plant, t_end):
    """Step a flyby_sim.plant.Plant until t_end [s]; the TruthSamples and every event."""
    samples, events = [], []
    while plant.t < t_end - 1e-9:
        samples.append(plant.step())
        events.extend(plant.drain_events())
    return samples, events
