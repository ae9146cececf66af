"""Tests of the CRCs of a bag (flyby_msgs_py.bag.integrity): written by BagWriter and the repair, checked by
``verify_bag``, ``python -m flyby_msgs_py.bag info`` and ``repair``; bytes flipped anywhere are reported in one line.

Every bag is made with BagWriter in ``tmp_path``.
"""

import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.records import DataEnd, Footer
from mcap.stream_reader import StreamReader
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer

from flyby_msgs_py import bag as fb
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert
from flyby_testing import OP_CHUNK, OP_DATA_END, OP_MESSAGE_INDEX, record_spans

S_NS = 1_000_000_000
ODOM = c.absolute(c.SIM_CHASER_ODOM)
N = 100


def make_bag(bag_dir):
    """A closed bag of N odometry messages, 0.1 s apart, a chunk per second."""
    rng = np.random.default_rng(3)
    with fb.BagWriter(bag_dir, {ODOM: 'nav_msgs/msg/Odometry'}, S_NS, fsync=False) as writer:
        for k in range(N):
            q = rng.normal(size=4)
            msg = convert.odometry(k * 0.1, 'hill', 'chaser_body', rng.normal(size=3), q / np.linalg.norm(q),
                                   rng.normal(size=3), rng.normal(size=3), np.zeros(36), np.zeros(36))
            writer.write(ODOM, k * 100_000_000, serialize_message(msg))
    return bag_dir


def mcap_of(bag_dir):
    (path,) = Path(bag_dir).glob('*.mcap')
    return path


def flip(path, start, n=64):
    """Invert ``n`` bytes of the file from ``start``."""
    data = bytearray(path.read_bytes())
    data[start:start + n] = bytes(b ^ 0xFF for b in data[start:start + n])
    path.write_bytes(bytes(data))


def bag_cli(*args):
    return subprocess.run([sys.executable, '-m', 'flyby_msgs_py.bag', *map(str, args)], capture_output=True,
                          text=True, timeout=120)


def test_writer_puts_crcs_in_every_chunk_the_data_section_and_the_summary(tmp_path):
    bag_dir = make_bag(tmp_path / 'bag')
    data = mcap_of(bag_dir).read_bytes()
    chunks = [start for op, start, _ in record_spans(data) if op == OP_CHUNK]
    assert len(chunks) >= 10
    assert all(struct.unpack_from('<I', data, start + 9 + 24)[0] for start in chunks)
    assert fb.verify_bag(bag_dir) == len(chunks)
    # mcap's own reader checks the chunk and the data-section CRCs and finds them right.
    with mcap_of(bag_dir).open('rb') as f:
        records = list(StreamReader(f, validate_crcs=True).records)
    data_end = next(r for r in records if isinstance(r, DataEnd))
    footer = next(r for r in records if isinstance(r, Footer))
    assert data_end.data_section_crc and footer.summary_crc
    assert fb.read_bag(bag_dir)[ODOM].position.shape == (N, 3)
    info = bag_cli('info', bag_dir)
    assert info.returncode == 0 and f'CRCs: {len(chunks)} chunks checked' in info.stdout


def test_bag_written_without_crcs_still_reads(tmp_path):
    """A bag of rosbags' own writer (every CRC 0) is not checked, and not refused."""
    writer = Writer(tmp_path / 'bag', version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    connection = writer.add_connection(ODOM, 'nav_msgs/msg/Odometry', typestore=fb.jazzy_typestore())
    writer.write(connection, 0, serialize_message(convert.odometry(
        0.0, 'hill', 'b', np.zeros(3), np.array([0, 0, 0, 1.0]), np.zeros(3), np.zeros(3), np.zeros(36),
        np.zeros(36))))
    writer.close()
    assert fb.verify_bag(tmp_path / 'bag') == 0
    assert 'CRCs: none written' in bag_cli('info', tmp_path / 'bag').stdout


def test_info_and_repair_refuse_flipped_bytes_in_the_middle_of_a_chunk(tmp_path):
    bag_dir = make_bag(tmp_path / 'bag')
    data = mcap_of(bag_dir).read_bytes()
    spans = [(start, end) for op, start, end in record_spans(data) if op == OP_CHUNK]
    k = len(spans) // 2
    start, end = spans[k]
    flip(mcap_of(bag_dir), (start + end) // 2 - 32)
    with pytest.raises(fb.BagError, match=f'chunk {k} \\(bytes {start}..{end}\\) is corrupted: CRC'):
        fb.verify_bag(bag_dir)
    info = bag_cli('info', bag_dir)
    assert info.returncode == 1 and info.stdout == '' and info.stderr.count('\n') == 1
    assert f'chunk {k} (bytes {start}..{end}) is corrupted' in info.stderr and 'repair' in info.stderr
    repaired = bag_cli('repair', bag_dir)
    assert repaired.returncode == 0, repaired.stderr
    assert f'damaged: {mcap_of(bag_dir)}: chunk {k} (bytes {start}..{end}) is corrupted' in repaired.stdout
    assert 'bag is valid' not in repaired.stdout
    # Every message of the other chunks is salvaged, into a bag with CRCs of its own: only the damaged chunk's
    # second of messages is lost.
    assert f'1 corrupted chunk(s) skipped: bytes {start}..{end}' in repaired.stdout
    salvaged = fb.read_bag(bag_dir)[ODOM]
    assert N - 11 <= len(salvaged.t) < N
    kept = np.round(salvaged.t * 10).astype(int)
    assert set(kept) < set(range(N)) and np.all(np.diff(kept) > 0)
    assert fb.verify_bag(bag_dir) >= 1
    assert bag_cli('info', bag_dir).returncode == 0


def test_info_and_repair_refuse_flipped_bytes_outside_the_chunks(tmp_path):
    """A message index (between chunks) is covered by the data-section CRC; the repair salvages every message."""
    bag_dir = make_bag(tmp_path / 'bag')
    data = mcap_of(bag_dir).read_bytes()
    start, end = next((s, e) for op, s, e in record_spans(data) if op == OP_MESSAGE_INDEX)
    flip(mcap_of(bag_dir), start + 20, end - start - 20)
    info = bag_cli('info', bag_dir)
    assert info.returncode == 1 and info.stderr.count('\n') == 1 and 'data-section CRC' in info.stderr
    repaired = bag_cli('repair', bag_dir)
    assert repaired.returncode == 0 and 'data-section CRC' in repaired.stdout
    assert len(fb.read_bag(bag_dir)[ODOM].t) == N


def test_info_refuses_flipped_bytes_in_the_summary(tmp_path):
    bag_dir = make_bag(tmp_path / 'bag')
    data = mcap_of(bag_dir).read_bytes()
    data_end = next(e for op, _, e in record_spans(data) if op == OP_DATA_END)
    flip(mcap_of(bag_dir), data_end + 30, 8)
    info = bag_cli('info', bag_dir)
    assert info.returncode == 1 and info.stderr.count('\n') == 1 and 'summary' in info.stderr


def test_info_refuses_a_bag_whose_first_bytes_are_zeroed(tmp_path):
    bag_dir = make_bag(tmp_path / 'bag')
    path = mcap_of(bag_dir)
    path.write_bytes(bytes(64) + path.read_bytes()[64:])
    info = bag_cli('info', bag_dir)
    assert info.returncode == 1 and info.stderr.count('\n') == 1 and 'no MCAP magic' in info.stderr
    repaired = bag_cli('repair', bag_dir)
    assert repaired.returncode == 1 and repaired.stderr.count('\n') == 1
    assert 'nothing to salvage' in repaired.stderr


def test_bag_command_line_misuse_exits_2(tmp_path):
    assert bag_cli('nope', tmp_path).returncode == 2
    assert bag_cli('info').returncode == 2
