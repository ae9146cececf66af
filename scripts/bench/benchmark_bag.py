#!/usr/bin/env python3
"""Benchmark of the bag layer: BagWriter throughput (durable flush every 2 s of message time, with
fsync) on ~720-byte Odometry messages at 1 kHz message time, and read_bag of the result."""

import tempfile
import time
from pathlib import Path

import numpy as np
from rclpy.serialization import serialize_message

from flyby_msgs_py import bag as fb
from flyby_msgs_py import convert

ODOM = '/sim/chaser/odom'
S_NS = 1_000_000_000


def main(n=150_000):
    rng = np.random.default_rng(5)
    raws = [serialize_message(convert.odometry(
        k * 1e-3, 'hill', 'chaser_body', rng.normal(size=3), (0.0, 0.0, 0.0, 1.0),
        rng.normal(size=3), rng.normal(size=3), np.eye(6), np.eye(6))) for k in range(1000)]
    with tempfile.TemporaryDirectory() as tmp:
        writer = fb.BagWriter(Path(tmp) / 'bag', {ODOM: 'nav_msgs/msg/Odometry'}, 2 * S_NS)
        t0 = time.perf_counter()
        for k in range(n):
            writer.write(ODOM, k * 1_000_000, raws[k % 1000])
        write_s = time.perf_counter() - t0
        writer.close()
        t0 = time.perf_counter()
        odom = fb.read_bag(Path(tmp) / 'bag')[ODOM]
        read_s = time.perf_counter() - t0
    print(f'BagWriter: {n / write_s:,.0f} msg/s ({len(raws[0])} B Odometry, '
          f'{writer.flush_count} durable flushes)')
    print(f'read_bag: {len(odom.t):,} Odometry in {read_s:.2f} s')


if __name__ == '__main__':
    main()
