"""scripts/analyze_bag.py refuses a damaged or wrong input in one line, as a user runs it: flipped bytes in the bag,
a bag that salvages nothing, a non-finite truth message, a garbage summary.json (exit 1), another scenario than the
run's own (exit 2). The run directory is made in ``tmp_path``: the scenario copied, a small bag of truth written
with BagWriter (the figures of a flown run: test_run_mission.py).
"""

import shutil
import subprocess
import sys

import numpy as np
from rclpy.serialization import serialize_message

from flyby_msgs_py import bag as fb
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert
from flyby_testing import ROOT, SCENARIOS

S_NS = 1_000_000_000
CHASER, TARGET = c.absolute(c.SIM_CHASER_ODOM), c.absolute(c.SIM_TARGET_ODOM)
N = 60


def make_run(tmp_path, nan_at=None):
    """A run directory of paper_flyby with every contract topic, N truth messages per body, 0.1 s apart; the
    chaser's position NaN in message ``nan_at``."""
    run = tmp_path / 'run'
    run.mkdir()
    shutil.copyfile(SCENARIOS / 'paper_flyby.yaml', run / 'scenario.yaml')
    topics = {c.absolute(topic): type_name for topic, type_name in c.TOPIC_TYPES.items()}  # as the recorder
    with fb.BagWriter(run / 'bag', topics, S_NS, fsync=False) as writer:
        for k in range(N):
            for topic in (CHASER, TARGET):
                msg = convert.odometry(k * 0.1, 'hill', 'body', [-100.0 + k, 0.0, 0.0], [0, 0, 0, 1.0],
                                       np.zeros(3), np.zeros(3), np.zeros(36), np.zeros(36))
                if k == nan_at and topic == CHASER:
                    msg.pose.pose.position.y = float('nan')  # convert refuses it: a rogue writer's
                writer.write(topic, k * 100_000_000, serialize_message(msg))
    return run


def analyze(run, *args):
    return subprocess.run([sys.executable, str(ROOT / 'scripts' / 'analyze_bag.py'), str(run), *map(str, args)],
                          capture_output=True, text=True, timeout=300)


def one_error_line(done, code):
    assert done.returncode == code, (done.returncode, done.stderr)
    assert done.stderr.startswith('analyze_bag: error: ') and done.stderr.count('\n') == 1, done.stderr
    assert 'Traceback' not in done.stderr
    return done.stderr


def test_analyze_bag_refuses_a_bag_with_flipped_bytes(tmp_path):
    run = make_run(tmp_path)
    (mcap,) = (run / 'bag').glob('*.mcap')
    data = bytearray(mcap.read_bytes())
    mid = len(data) // 2
    data[mid:mid + 64] = bytes(b ^ 0xFF for b in data[mid:mid + 64])
    mcap.write_bytes(bytes(data))
    err = one_error_line(analyze(run), 1)
    assert str(mcap) in err and 'corrupted' in err and 'python -m flyby_msgs_py.bag repair' in err


def test_analyze_bag_refuses_a_cut_bag_that_salvages_nothing(tmp_path):
    run = make_run(tmp_path)
    (mcap,) = (run / 'bag').glob('*.mcap')
    mcap.write_bytes(bytes(64) + mcap.read_bytes()[64:])
    (run / 'bag' / 'metadata.yaml').unlink()
    err = one_error_line(analyze(run), 1)
    assert 'nothing to salvage' in err and str(mcap) in err


def test_analyze_bag_refuses_a_non_finite_truth_position(tmp_path):
    run = make_run(tmp_path, nan_at=20)
    err = one_error_line(analyze(run), 1)
    assert f'{CHASER}: non-finite position' in err and 't = 2.000 s' in err and 'message 21 of 60' in err


def test_analyze_bag_refuses_a_garbage_summary(tmp_path):
    run = make_run(tmp_path)
    for garbage in ('{"sim_time_s": 1', '[1, 2]', '\xff\xfe'):
        (run / 'summary.json').write_text(garbage, encoding='latin-1')
        err = one_error_line(analyze(run), 1)
        assert str(run / 'summary.json') in err and 'not a summary' in err


def test_analyze_bag_refuses_the_scenario_of_another_run(tmp_path):
    run = make_run(tmp_path)
    err = one_error_line(analyze(run, '--scenario', SCENARIOS / 'seweryn_tumbling.yaml'), 2)
    assert 'seweryn_tumbling' in err and 'is not the scenario of this run' in err and 'paper_flyby' in err
    # The run's own scenario, under another path, is accepted: the input is then refused for what it is.
    (run / 'summary.json').write_text('[]')
    err = one_error_line(analyze(run, '--scenario', SCENARIOS / 'paper_flyby.yaml'), 1)
    assert 'not a summary' in err


def test_analyze_bag_command_line_misuse_exits_2(tmp_path):
    assert analyze(tmp_path, '--nope').returncode == 2
    err = one_error_line(analyze(tmp_path / 'missing'), 2)
    assert str(tmp_path / 'missing') in err
