"""run_mission.py --foxglove: a Foxglove WebSocket client (protocol foxglove.sdk.v1, the websockets package)
connected while the mission runs receives the contract topics and the frames; a taken port is refused before the
run starts."""

import json
import socket
import struct
import subprocess
import sys
import time

import pytest
from websockets.sync.client import connect

from flyby_msgs_py import contract as c
from flyby_msgs_py import frames
from flyby_msgs_py.bag import jazzy_typestore
from flyby_testing import ROOT, RUN_MISSION, run_mission, with_duration, write_scenario

SUBPROTOCOL = 'foxglove.sdk.v1'
WANTED = (frames.TF_TOPIC, frames.TF_STATIC_TOPIC, c.absolute(c.MISSION_PHASE), c.absolute(c.SIM_CHASER_ODOM),
          c.absolute(c.CLOCK))


def free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def _connect(port, proc, timeout_s=120.0):
    """The client, once the live view listens (the mission goes on meanwhile)."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            return connect(f'ws://127.0.0.1:{port}', subprotocols=[SUBPROTOCOL], open_timeout=5)
        except OSError:
            assert proc.poll() is None and time.monotonic() < deadline, 'the live view never listened'
            time.sleep(0.2)


def _receive(ws, proc):
    """{topic: [(log time ns, CDR bytes)]} of the WANTED topics until each has a message, /tf both bodies, and the
    mission is 10 s of simulation time on."""
    typestore = jazzy_typestore()
    channels, by_sub, got, tf_children = {}, {}, {}, set()
    deadline = time.monotonic() + 180.0
    while not (set(WANTED) <= set(got) and {'target_body', 'chaser_body'} <= tf_children
               and got[frames.TF_TOPIC][-1][0] >= 10 * 10**9):
        assert time.monotonic() < deadline and proc.poll() is None, f'got {sorted(got)}, frames {tf_children}'
        msg = ws.recv(timeout=60)
        if isinstance(msg, str):
            op = json.loads(msg)
            if op['op'] == 'advertise':
                channels.update({ch['topic']: ch for ch in op['channels']})
                subs = [{'id': i, 'channelId': channels[t]['id']} for i, t in enumerate(WANTED) if t in channels]
                by_sub.update({s['id']: WANTED[s['id']] for s in subs})
                ws.send(json.dumps({'op': 'subscribe', 'subscriptions': subs}))
            continue
        opcode, sub_id, log_time = struct.unpack_from('<BIQ', msg)
        assert opcode == 1
        topic, raw = by_sub[sub_id], msg[13:]
        got.setdefault(topic, []).append((log_time, raw))
        if topic == frames.TF_TOPIC:
            tf_children |= {t.child_frame_id for t in typestore.deserialize_cdr(raw, frames.TF_TYPE).transforms}
    return channels, got


@pytest.mark.slow
def test_a_foxglove_client_receives_topics_and_frames_while_the_mission_runs(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby_6dof', name='live', edit=with_duration(60.0))
    port = free_port()
    proc = subprocess.Popen([sys.executable, str(RUN_MISSION), '--quiet', '--scenario', str(scenario), '--out',
                             str(tmp_path / 'run'), '--foxglove', str(port)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        with _connect(port, proc) as ws:
            channels, got = _receive(ws, proc)
        stdout, stderr = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 3, stderr[-3000:]  # the time limit: the viewer ended nothing early
    assert channels[frames.TF_TOPIC]['schemaName'] == frames.TF_TYPE
    assert {channels[t]['encoding'] for t in WANTED} == {'cdr'}
    assert {channels[t]['schemaEncoding'] for t in WANTED} == {'ros2msg'}
    typestore = jazzy_typestore()
    phase = typestore.deserialize_cdr(got[c.absolute(c.MISSION_PHASE)][-1][1], 'std_msgs/msg/String').data
    assert phase in (c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH, c.PHASE_TRAJECTORY_ADJUST)
    (static,) = typestore.deserialize_cdr(got[frames.TF_STATIC_TOPIC][0][1], frames.TF_TYPE).transforms
    assert (static.header.frame_id, static.child_frame_id) == ('target_body', 'grasp_point')
    # Log times are the simulation's, as in the bag.
    tf_times = [t for t, _ in got[frames.TF_TOPIC]]
    assert tf_times == sorted(tf_times) and 10 * 10**9 <= tf_times[-1] <= 60 * 10**9


def test_a_taken_port_is_refused_before_the_run(tmp_path):
    with socket.socket() as taken:
        taken.bind(('127.0.0.1', 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = run_mission('--scenario', ROOT / 'scenarios' / 'paper_flyby.yaml', '--out', tmp_path / 'run',
                           '--foxglove', port, timeout=60)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1].endswith(f'--foxglove: port {port} on 127.0.0.1 is taken '
                                                         '(Address already in use)')
    assert not (tmp_path / 'run').exists()


@pytest.mark.parametrize('args,message', [(['--foxglove', '70000'], '--foxglove: the port must be in 1..65535, got '
                                                                     '70000'),
                                          (['--foxglove', '8765', '--in-process'],
                                           '--foxglove: not with --in-process (the live view runs as its own '
                                           'process)')])
def test_a_bad_foxglove_option_is_refused_in_one_line(tmp_path, args, message):
    done = run_mission('--scenario', ROOT / 'scenarios' / 'paper_flyby.yaml', '--out', tmp_path / 'run', *args,
                       timeout=60)
    assert done.returncode == 2 and done.stderr.strip().splitlines()[-1].endswith(message)
    assert 'Traceback' not in done.stderr
