"""Tests of flyby_msgs_py.bag: durability of the writer (flush, SIGKILL), salvage and repair of cut-off bags,
the command line.

Every bag lives in ``tmp_path``; the readers' round trip is test_bag_read.py.
"""

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.rosbag2.storage_mcap import McapWriter
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock

from flyby_msgs_py import bag as fb
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert
from flyby_testing import OP_CHUNK, OP_MESSAGE_INDEX, record_spans

S_NS = 1_000_000_000
ODOM = c.absolute(c.SIM_CHASER_ODOM)


def odometry(t_ns, rng):
    """A nav_msgs/Odometry of the chaser in hill at t_ns [ns] with random values (``convert.odometry``)."""
    p, q, lin, ang = rng.normal(size=3), rng.normal(size=4), rng.normal(size=3), rng.normal(size=3)
    return convert.odometry(t_ns / S_NS, 'hill', 'chaser_body', p, q / np.linalg.norm(q), lin, ang,
                            rng.normal(size=36), rng.normal(size=36))


def mcap_of(bag_dir):
    (path,) = Path(bag_dir).glob('*.mcap')
    return path


def test_internals_flush_forces_chunk_to_disk(tmp_path):
    """Guard on the rosbags 0.11.9 internals BagWriter relies on (McapWriter.close_chunk, bio).

    If this fails after a rosbags upgrade, ``_force_pending_chunk_to_disk`` must be rewritten.
    """
    assert callable(getattr(McapWriter, 'close_chunk', None)), 'rosbags McapWriter.close_chunk gone'
    bag_dir = tmp_path / 'bag'
    rng = np.random.default_rng(1)
    writer = fb.BagWriter(bag_dir, {ODOM: 'nav_msgs/msg/Odometry'}, 1000 * S_NS)
    mcap = mcap_of(bag_dir)
    assert writer._writer.storage.bio.fileno() >= 0
    raws = [serialize_message(odometry(k * S_NS, rng)) for k in range(10)]
    for k, raw in enumerate(raws):
        writer.write(ODOM, k * S_NS, raw)
    size_before = mcap.stat().st_size
    assert writer.flush_count == 0
    writer.flush()
    assert writer.flush_count == 1
    size_after = mcap.stat().st_size
    assert size_after >= size_before + sum(len(r) for r in raws), (size_before, size_after)
    # What is on disk now (the writer still open) is enough to rebuild every message.
    copy = tmp_path / 'copy'
    copy.mkdir()
    shutil.copyfile(mcap, copy / 'copy.mcap')
    report = fb.repair_bag(copy)
    assert report['messages'] == {ODOM: 10}
    with AnyReader([copy], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        assert [bytes(raw) for _, _, raw in reader.messages()] == [bytes(r) for r in raws]
    # Nothing pending: flush writes no (empty) chunk.
    writer.flush()
    assert (writer.flush_count, mcap.stat().st_size) == (1, size_after)
    writer.close()
    assert (bag_dir / 'metadata.yaml').is_file()
    writer.close()  # twice is fine


def test_flush_period_is_message_time(tmp_path):
    topic = c.absolute(c.CLOCK)
    raw = serialize_message(Clock())
    with fb.BagWriter(tmp_path / 'bag', {topic: 'rosgraph_msgs/msg/Clock'}, 2 * S_NS,
                      fsync=False) as writer:
        for k in range(101):  # 10 s of message time at 10 Hz
            writer.write(topic, k * S_NS // 10, raw)
        assert writer.flush_count == 5  # at t = 2, 4, 6, 8, 10 s
        writer.write(topic, 3 * S_NS, raw)  # time jumped back (simulation restarted)
        assert writer.flush_count == 6
        writer.write(topic, 4 * S_NS, raw)
        assert writer.flush_count == 6


CHILD = textwrap.dedent('''
    import sys, time
    import numpy as np
    from rclpy.serialization import serialize_message
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import String
    from builtin_interfaces.msg import Time
    from flyby_msgs_py.bag import BagWriter

    STEP_NS = 50_000_000
    topics = {'/clock': 'rosgraph_msgs/msg/Clock', '/sim/chaser/odom': 'nav_msgs/msg/Odometry',
              '/mission/phase': 'std_msgs/msg/String'}
    writer = BagWriter(sys.argv[1], topics, 2_000_000_000)
    writer.write('/mission/phase', 0, serialize_message(String(data='ESTIMATION')))
    odom = Odometry()
    k = 0
    while True:
        t = k * STEP_NS
        stamp = Time(sec=t // 10**9, nanosec=t % 10**9)
        writer.write('/clock', t, serialize_message(Clock(clock=stamp)))
        odom.header.stamp = stamp
        odom.pose.pose.position.x = float(k)
        writer.write('/sim/chaser/odom', t, serialize_message(odom))
        print(f'WROTE {t} {k}', flush=True)
        k += 1
        if k % 20 == 0:
            time.sleep(0.002)
''')


KILL_AFTER_NS = 31_350_000_000


def test_sigkill_loses_at_most_one_flush_period(tmp_path):
    """A writer killed with SIGKILL mid-stream; the repaired bag reaches within one flush period
    (2 s) plus one message of the last message the child reported writing."""
    script = tmp_path / 'child.py'
    script.write_text(CHILD)
    bag_dir = tmp_path / 'bag'
    proc = subprocess.Popen([sys.executable, str(script), str(bag_dir)], stdout=subprocess.PIPE,
                            text=True)
    line = ''
    try:
        deadline = time.monotonic() + 20.0
        for line in proc.stdout:
            # Kill off the flush grid (flushes at 2, 4, ... s): 1.35 s after the last flush.
            if int(line.split()[1]) >= KILL_AFTER_NS or time.monotonic() > deadline:
                break
        os.kill(proc.pid, signal.SIGKILL)
        rest = proc.stdout.read().split('\n')
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    reported = [x for x in [line] + rest if x.startswith('WROTE')]
    assert reported, 'the child wrote nothing (see its stderr above)'
    last_line = reported[-1]
    t_reported, k_reported = map(int, last_line.split()[1:])
    assert t_reported >= KILL_AFTER_NS, 'child too slow to reach 31.35 s of message time'

    assert not (bag_dir / 'metadata.yaml').exists()
    with pytest.raises(Exception, match='metadata'):
        with AnyReader([bag_dir], default_typestore=get_typestore(Stores.ROS2_JAZZY)):
            pass
    with pytest.raises(fb.BagError, match='repair'):
        fb.read_bag(bag_dir)

    report = fb.repair_bag(bag_dir)
    assert report['status'] == 'repaired'
    data = fb.read_bag(bag_dir)
    odom = data['/sim/chaser/odom']
    step_ns, period_ns = 50_000_000, 2 * S_NS
    print(f'\nSIGKILL: reported {t_reported * 1e-9:.2f} s, salvaged up to '
          f'{report["last_timestamp_ns"] * 1e-9:.2f} s, {report["message_count"]} messages; '
          f'{report["bytes_salvaged"]} of {report["bytes_total"]} bytes')
    assert report['last_timestamp_ns'] >= t_reported - period_ns - step_ns
    assert odom.t[-1] * S_NS >= t_reported - period_ns - step_ns - 1
    # What was salvaged is an unbroken prefix of what was written.
    np.testing.assert_array_equal(odom.position[:, 0], np.arange(len(odom.t)))
    # A flush falls between the clock and the odometry of one step: one clock more at most.
    clock_t = data['/clock'].t
    assert len(clock_t) - len(odom.t) in (0, 1)
    np.testing.assert_array_equal(clock_t[:len(odom.t)], odom.t)
    assert data['/mission/phase'].data == ['ESTIMATION']
    assert report['messages']['/sim/chaser/odom'] == len(odom.t) <= k_reported + 1
    # The damaged original is kept; a second repair finds a valid bag.
    assert Path(report['damaged_file']).is_file()
    assert Path(report['damaged_file']).name.endswith('.mcap.damaged')
    again = fb.repair_bag(bag_dir)
    assert (again['status'], again['messages']) == ('valid', report['messages'])


@pytest.fixture(scope='module')
def flushed_bag(tmp_path_factory):
    """A closed bag with many chunks and the (file size, messages written) after each flush."""
    bag_dir = tmp_path_factory.mktemp('good') / 'bag'
    rng = np.random.default_rng(11)
    topic = ODOM
    marks = []
    raws = [serialize_message(odometry(k * 100_000_000, rng)) for k in range(200)]
    writer = fb.BagWriter(bag_dir, {topic: 'nav_msgs/msg/Odometry'}, S_NS, fsync=False)
    mcap = mcap_of(bag_dir)
    for k, raw in enumerate(raws):
        flushes = writer.flush_count
        writer.write(topic, k * 100_000_000, raw)
        if writer.flush_count != flushes:
            marks.append((mcap.stat().st_size, k + 1))
    writer.close()
    return bag_dir, marks, raws


def cut_copy(bag_dir, offset, dest):
    dest.mkdir()
    src = mcap_of(bag_dir)
    with src.open('rb') as f:
        (dest / src.name).write_bytes(f.read(offset))
    return dest


def salvaged_raws(bag_dir):
    with AnyReader([bag_dir], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        return [bytes(raw) for _, _, raw in reader.messages()]


def test_cut_at_chosen_offsets_repairs_to_complete_prefix(tmp_path, flushed_bag):
    bag_dir, marks, raws = flushed_bag
    assert len(marks) >= 15
    full = mcap_of(bag_dir).stat().st_size
    (s1, n1), s2, (s9, n9) = marks[0], marks[1][0], marks[8]
    cases = {
        0: 0, 5: 0, 8: 0, 30: 0,             # nothing, half magic, magic, inside the header
        s1 - 1: n1,                          # chunk 1 complete, its message index cut
        s1: n1, (s1 + s2) // 2: n1,          # chunk 2 half-written
        s9: n9, s9 + 9: n9, s9 + 10: n9,     # a next record's head / first byte of its body
        full - 1: len(raws),                 # only the closing magic cut
        full: len(raws),                     # complete file, metadata.yaml missing
    }
    for i, (offset, expected) in enumerate(sorted(cases.items())):
        cut = cut_copy(bag_dir, offset, tmp_path / f'cut{i}')
        if not expected:
            continue  # test_repair_that_salvages_nothing_refuses_and_leaves_the_bag
        report = fb.repair_bag(cut)
        assert report['message_count'] == expected, (offset, report)
        assert salvaged_raws(cut) == [bytes(r) for r in raws[:expected]], offset
        assert (cut / 'metadata.yaml').is_file()
        damaged = Path(report['damaged_file'])
        assert damaged.stat().st_size == offset  # the original is kept byte for byte
        assert report['last_timestamp_ns'] == (expected - 1) * 100_000_000
        assert fb.read_bag(cut)[ODOM].position.shape == (expected, 3)


def test_repair_that_salvages_nothing_refuses_and_leaves_the_bag(tmp_path, flushed_bag):
    """A file cut before its first chunk, or whose first 64 bytes are zeroed, holds no message: repair
    raises ``BagError`` naming the file and leaves it unchanged (no empty bag passing for a valid one)."""
    bag_dir, _, _ = flushed_bag
    data = mcap_of(bag_dir).read_bytes()
    cases = {'cut0': b'', 'cut30': data[:30], 'zeroed': bytes(64) + data[64:]}
    for name, content in cases.items():
        cut = tmp_path / name
        cut.mkdir()
        (cut / 'bag.mcap').write_bytes(content)
        with pytest.raises(fb.BagError, match='nothing to salvage') as err:
            fb.repair_bag(cut)
        assert str(cut / 'bag.mcap') in str(err.value) and '\n' not in str(err.value)
        assert [p.name for p in cut.iterdir()] == ['bag.mcap']
        assert (cut / 'bag.mcap').read_bytes() == content
    cmd = [sys.executable, '-m', 'flyby_msgs_py.bag', 'repair', str(tmp_path / 'zeroed')]
    failed = subprocess.run(cmd, capture_output=True, text=True)
    assert failed.returncode == 1 and failed.stdout == ''
    assert failed.stderr.count('\n') == 1 and 'nothing to salvage' in failed.stderr


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fraction=st.floats(0.0, 1.0))
def test_cut_anywhere_repairs_to_a_prefix(flushed_bag, fraction):
    bag_dir, marks, raws = flushed_bag
    data = mcap_of(bag_dir).read_bytes()
    offset = int(fraction * len(data))
    first_chunk_end = min(end for op, _, end in record_spans(data) if op == OP_CHUNK)
    with tempfile.TemporaryDirectory() as tmp:
        cut = cut_copy(bag_dir, offset, Path(tmp) / 'cut')
        if offset < first_chunk_end:  # not even the first chunk complete (its flush mark lies after its end)
            with pytest.raises(fb.BagError, match='nothing to salvage'):
                fb.repair_bag(cut)
            return
        report = fb.repair_bag(cut)
        n = report['message_count']
        assert n in {0, len(raws)} | {m for _, m in marks}
        # Every chunk that reached the file before the cut is salvaged.
        assert n >= max([m for size, m in marks if size <= offset], default=0)
        assert salvaged_raws(cut) == [bytes(r) for r in raws[:n]]


def test_salvage_cut_inside_last_chunk_and_record_heads(tmp_path, flushed_bag):
    """A file cut inside its last chunk (its head, its fixed fields, its records) or inside the head
    of a record is salvaged without exception: every message of the chunks before the cut, and the
    salvage stops where the cut record starts."""
    bag_dir, marks, raws = flushed_bag
    data = mcap_of(bag_dir).read_bytes()
    spans = record_spans(data)
    chunks = [(start, end) for op, start, end in spans if op == OP_CHUNK]
    # One chunk per flush, each on disk when the flush returned, then the one close() wrote.
    assert len(chunks) == len(marks) + 1
    assert all(end <= size for (_, end), (size, _) in zip(chunks[:-1], marks, strict=True))
    first_start = chunks[0][0]
    last_start, last_end = chunks[-1]
    index_start = next(start for op, start, _ in spans if op == OP_MESSAGE_INDEX and start >= last_end)
    # rosbags 0.11.9 writes chunks uncompressed: the compression string (body offset 28) is empty,
    # so the records length is at body offset 32 and the records start at 40.
    assert data[last_start + 9 + 28:last_start + 9 + 32] == b'\0\0\0\0'
    n_before = marks[-1][1]
    cases = [  # (cut offset, start of the record cut, messages salvaged)
        *[(last_start + k, last_start, n_before) for k in (1, 4, 8)],        # in the last chunk's head
        *[(last_start + 9 + k, last_start, n_before)                        # in its body: empty, times,
          for k in (0, 5, 24, 30, 36, 40, 41)],                            # crc, compression, length, records
        ((last_start + last_end) // 2, last_start, n_before),               # halfway through its records
        (last_end - 1, last_start, n_before),                               # all but its last byte
        *[(index_start + k, index_start, len(raws)) for k in (1, 8)],       # in the next record's head
        *[(first_start + k, first_start, 0) for k in (1, 8)],               # in the first chunk's head
    ]
    for i, (offset, cut_record, n) in enumerate(cases):
        cut = cut_copy(bag_dir, offset, tmp_path / f'cut{i}')
        found = fb.salvage_mcap(mcap_of(cut))
        assert [bytes(raw) for _, _, raw in found.messages] == [bytes(r) for r in raws[:n]], offset
        assert [t for _, t, _ in found.messages] == [k * 100_000_000 for k in range(n)], offset
        assert found.complete_until == cut_record, (offset, found.stop_reason)
        assert found.stop_reason == f'record after byte {cut_record} cut off', offset
        assert [topic for _, topic, _, _ in found.channels.values()] == ([ODOM] if n else []), offset
        if not n:
            with pytest.raises(fb.BagError, match='nothing to salvage'):
                fb.repair_bag(cut)
            continue
        report = fb.repair_bag(cut)
        assert (report['message_count'], report['bytes_salvaged']) == (n, cut_record), offset
        assert salvaged_raws(cut) == [bytes(r) for r in raws[:n]], offset


def test_salvage_zstd_chunks(tmp_path):
    """Chunks compressed with zstd (rosbags' storage compression; BagWriter writes none) are salvaged
    the same way: every complete chunk, nothing of the one cut."""
    rng = np.random.default_rng(5)
    raws = [serialize_message(odometry(k * S_NS, rng)) for k in range(12)]
    writer = Writer(tmp_path / 'bag', version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    writer.open()
    connection = writer.add_connection(ODOM, 'nav_msgs/msg/Odometry', typestore=get_typestore(Stores.ROS2_JAZZY))
    for k, raw in enumerate(raws):
        writer.write(connection, k * S_NS, raw)
        if k in (3, 7):
            writer.storage.close_chunk()  # the rosbags 0.11.9 internal BagWriter.flush uses
    writer.close()
    data = mcap_of(tmp_path / 'bag').read_bytes()
    chunks = [(start, end) for op, start, end in record_spans(data) if op == OP_CHUNK]
    assert len(chunks) == 3
    assert data[chunks[0][0] + 9 + 28:chunks[0][0] + 9 + 36] == b'\4\0\0\0zstd'
    for offset, n in [(chunks[1][0] + 20, 4), ((chunks[2][0] + chunks[2][1]) // 2, 8), (len(data) - 1, 12)]:
        path = tmp_path / f'cut{offset}.mcap'
        path.write_bytes(data[:offset])
        found = fb.salvage_mcap(path)
        assert [bytes(raw) for _, _, raw in found.messages] == [bytes(r) for r in raws[:n]], offset


def test_interrupted_repair_resumes_from_damaged_file(tmp_path, flushed_bag):
    bag_dir, marks, raws = flushed_bag
    size, n = marks[3]
    cut = cut_copy(bag_dir, size + 100, tmp_path / 'cut')
    # A repair that died after renaming the original, before writing the new bag.
    mcap = mcap_of(cut)
    mcap.rename(mcap.with_name(mcap.name + '.damaged'))
    report = fb.repair_bag(cut)
    assert report['messages'] == {ODOM: n}
    assert salvaged_raws(cut) == [bytes(r) for r in raws[:n]]


def test_valid_bag_is_left_alone(tmp_path, flushed_bag):
    bag_dir, _, raws = flushed_bag
    before = sorted((p.name, p.stat().st_mtime_ns) for p in bag_dir.iterdir())
    report = fb.repair_bag(bag_dir)
    assert (report['status'], report['repaired'], report['message_count']) == (
        'valid', False, len(raws))
    assert sorted((p.name, p.stat().st_mtime_ns) for p in bag_dir.iterdir()) == before


def test_command_line(tmp_path, flushed_bag):
    bag_dir, marks, raws = flushed_bag
    cmd = [sys.executable, '-m', 'flyby_msgs_py.bag']
    info = subprocess.run(cmd + ['info', str(bag_dir)], capture_output=True, text=True, check=True)
    assert ODOM in info.stdout and 'nav_msgs/msg/Odometry' in info.stdout
    assert str(len(raws)) in info.stdout and '19.900 s' in info.stdout

    cut = cut_copy(bag_dir, marks[2][0] + 50, tmp_path / 'cut')
    failed = subprocess.run(cmd + ['info', str(cut)], capture_output=True, text=True)
    assert failed.returncode == 1 and str(cut) in failed.stderr and 'repair' in failed.stderr
    repaired = subprocess.run(cmd + ['repair', str(cut)], capture_output=True, text=True,
                              check=True)
    assert f'{marks[2][1]} messages salvaged' in repaired.stdout
    again = subprocess.run(cmd + ['repair', str(cut)], capture_output=True, text=True, check=True)
    assert 'valid' in again.stdout
    missing = subprocess.run(cmd + ['repair', str(tmp_path / 'nope')], capture_output=True,
                             text=True)
    assert missing.returncode == 1 and str(tmp_path / 'nope') in missing.stderr
