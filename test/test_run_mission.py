"""The launcher end to end: real processes over Fast DDS, a real MCAP bag read back with rosbags."""

import os
import re
import signal
from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from flyby_msgs_py import contract as c
from flyby_msgs_py.bag import read_bag
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario
from flyby_testing import analyze_bag, launch_and_wait, read_summary, run_mission, with_duration, write_scenario

SIM_TOPICS = {c.absolute(t): c.TOPIC_TYPES[t] for t in (
    c.CLOCK, c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM, c.SIM_CHASER_THRUST,
    c.SENSOR_RELATIVE_POSITION, c.SENSOR_TARGET_ATTITUDE, c.MISSION_EVENTS, c.MARKERS)}


def shm_segments():
    """Fast DDS per-participant data segments. (The fastrtps_port<N> files are per port number and
    reused by the next run on that port, so they cannot pile up.)"""
    return sorted(p.name for p in Path('/dev/shm').glob('fastrtps_*')
                  if not p.name.startswith('fastrtps_port'))


def shm_segments_in_use():
    """The Fast DDS segments some live process maps or holds open (another run on the machine meanwhile), by
    /proc/*/maps and /proc/*/fd."""
    used = set()
    for proc in Path('/proc').glob('[0-9]*'):
        try:
            used.update(re.findall(r'/dev/shm/(fastrtps_\S+)', (proc / 'maps').read_text()))
            used.update(Path(os.readlink(fd)).name for fd in (proc / 'fd').iterdir()
                        if os.readlink(fd).startswith('/dev/shm/fastrtps_'))
        except OSError:  # the process ended, or is not ours to read
            continue
    return used


@pytest.mark.slow
def test_coasting_run_leaves_bag_and_summary(tmp_path):
    scenario = write_scenario(tmp_path, edit=with_duration(60.0))
    out = tmp_path / 'run'
    done = run_mission('--scenario', scenario, '--out', out)
    assert done.returncode == 3, done.stderr + done.stdout
    assert 'outcome' in done.stdout and 'TIME_LIMIT' in done.stdout
    assert (out / 'scenario.yaml').read_bytes() == scenario.read_bytes()

    summary = read_summary(out)
    for key in ('outcome', 'final_phase', 'seed', 't_grasp_s', 'capture_position_error_m',
                'capture_velocity_error_mps', 'delta_v_total_mps', 'fuel_used_kg',
                'min_clearance_m', 'restriction_sphere_radius_m',
                'thrust_inside_restriction_sphere', 'late_maneuvers', 'sim_time_s',
                'wall_time_s', 'real_time_factor'):
        assert key in summary
    assert summary['outcome'] == 'TIME_LIMIT'
    assert summary['sim_time_s'] == pytest.approx(60.0)
    assert summary['delta_v_total_mps'] == 0.0
    assert summary['min_clearance_m'] > 40.0

    typestore = get_typestore(Stores.ROS2_JAZZY)
    with AnyReader([out / 'bag'], default_typestore=typestore) as reader:
        types = {conn.topic: conn.msgtype for conn in reader.connections}
        counts = {conn.topic: conn.msgcount for conn in reader.connections}
        for topic, type_name in c.TOPIC_TYPES.items():
            assert types[c.absolute(topic)] == type_name
        for topic in SIM_TOPICS:
            assert counts[topic] > 0, topic
        # 20 Hz truth: one sample per 0.05 s step plus the initial one.
        assert counts['/sim/chaser/odom'] == 60 / 0.05 + 1
        assert counts['/sensors/target/attitude'] == pytest.approx(600, abs=2)
        for conn, _t, raw in reader.messages(
                connections=[x for x in reader.connections if x.topic == '/sim/target/odom']):
            msg = reader.deserialize(raw, conn.msgtype)
            assert msg.header.frame_id == 'hill' and msg.child_frame_id == 'target_body'
            q = msg.pose.pose.orientation
            assert abs(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2 - 1.0) < 1e-12
    assert list((out / 'bag').glob('*.mcap'))

    # What the bag decodes to is what the simulator published: the core's truth, to the bit.
    plant = Plant(PlantConfig.from_scenario(load_scenario(scenario)))
    truth = [plant.truth()] + [plant.step() for _ in range(1200)]
    data = read_bag(out / 'bag', topics=['/sim/chaser/odom', '/sim/target/odom'])
    chaser, target = data['/sim/chaser/odom'], data['/sim/target/odom']
    assert np.allclose(chaser.t, [s.t for s in truth], rtol=0, atol=1e-9)  # stamps are whole ns
    assert np.array_equal(chaser.position, [s.r_hill for s in truth])
    assert np.array_equal(chaser.linear, [s.v_hill for s in truth])
    assert np.array_equal(target.orientation_xyzw, [s.q_hill_from_body for s in truth])
    assert np.array_equal(target.angular, [s.omega_body for s in truth])


@pytest.mark.slow
def test_truth_identical_at_rtf_10_and_full_speed(tmp_path):
    scenario = write_scenario(tmp_path, edit=with_duration(20.0))
    runs = {}
    for label, rtf in (('rtf10', 10.0), ('max', 0.0)):
        out = tmp_path / label
        done = run_mission('--scenario', scenario, '--out', out, '--rtf', rtf)
        assert done.returncode == 3, done.stderr
        runs[label] = read_bag(out / 'bag', topics=['/sim/chaser/odom', '/sim/target/odom'])
        assert read_summary(out)['real_time_factor'] > 0
    for topic in ('/sim/chaser/odom', '/sim/target/odom'):
        a, b = runs['rtf10'][topic], runs['max'][topic]
        assert np.array_equal(a.t, b.t)
        assert np.array_equal(a.position, b.position)
        assert np.array_equal(a.linear, b.linear)
        assert np.array_equal(a.orientation_xyzw, b.orientation_xyzw)
        assert np.array_equal(a.angular, b.angular)


@pytest.mark.slow
def test_seed_override_is_recorded(tmp_path):
    scenario = write_scenario(tmp_path, edit=with_duration(5.0))
    out = tmp_path / 'run'
    done = run_mission('--scenario', scenario, '--out', out, '--seed', 42)
    assert done.returncode == 3, done.stderr
    assert read_summary(out)['seed'] == 42


@pytest.mark.slow
def test_ctrl_c_leaves_readable_bag_and_interrupted_summary(tmp_path):
    scenario = write_scenario(tmp_path, edit=with_duration(1000.0))
    out = tmp_path / 'run'
    launcher, _info, t_seen = launch_and_wait(scenario, out, 20.0, '--rtf', 20.0)
    launcher.send_signal(signal.SIGINT)
    stdout, stderr = launcher.communicate(timeout=120)
    assert launcher.returncode == 130, stderr
    summary = read_summary(out)
    assert summary['outcome'] == 'INTERRUPTED'
    assert summary['nodes_killed'] == []
    data = read_bag(out / 'bag', topics=['/sim/chaser/odom'])
    # The simulator publishes the clock of t before the truth of t: the interrupt may fall between the two.
    step_s = load_scenario(scenario).simulation.step_s
    assert data['/sim/chaser/odom'].t[-1] >= t_seen - step_s - 1e-9
    assert summary['sim_time_s'] == data['/sim/chaser/odom'].t[-1]
    assert 'INTERRUPTED' in stdout
    checked = analyze_bag(out)  # the interrupted run's figures, recomputed from its bag
    assert checked.returncode == 0 and 'every figure agrees' in checked.stdout, checked.stdout + checked.stderr


@pytest.mark.slow
def test_recorder_sigkill_loses_at_most_10s_and_leaves_no_shm(tmp_path):
    shm_before = set(shm_segments())
    scenario = write_scenario(tmp_path, edit=with_duration(2000.0))
    out = tmp_path / 'run'
    launcher, info, t_kill = launch_and_wait(scenario, out, 40.0, '--rtf', 20.0)
    os.kill(info['pids']['flyby_recorder'], signal.SIGKILL)
    launcher.communicate(timeout=120)
    assert launcher.returncode == 1
    summary = read_summary(out)
    assert summary['outcome'] == 'ERROR'
    assert 'flyby_recorder' in summary['end_reason']
    assert summary['bag_repair'] is not None
    data = read_bag(out / 'bag', topics=['/sim/chaser/odom'])
    t = data['/sim/chaser/odom'].t
    assert t[-1] >= t_kill - 10.0, (t[-1], t_kill)
    assert np.all(np.diff(t) > 0)
    # Orphans only: a segment of another process running on the machine meanwhile is not this run's leak.
    assert set(shm_segments()) - shm_before - shm_segments_in_use() == set()


@pytest.mark.parametrize('edit, culprit', [
    (lambda d: d['chaser'].__setitem__('mass_kgg', 100.0), 'chaser.mass_kgg'),
    (lambda d: d['chaser'].__setitem__('mass_kg', -5.0), 'chaser.mass_kg'),
    (lambda d: d['chaser']['thrusters'].pop('isp_s'), 'chaser.thrusters.isp_s'),
])
def test_bad_scenario_is_one_line_naming_the_key(tmp_path, edit, culprit):
    scenario = write_scenario(tmp_path, edit=edit)
    out = tmp_path / 'run'
    done = run_mission('--scenario', scenario, '--out', out, timeout=60)
    assert done.returncode == 1
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert culprit in lines[0] and str(scenario) in lines[0]
    assert not (out / 'bag').exists()
