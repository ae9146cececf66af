"""An exclusive ROS_DOMAIN_ID per run on this machine (DESIGN §8), so two runs never hear each other.

A lease is an flock on ``DOMAIN_LOCK_DIR/<id>.lock``: the kernel drops it when the holder exits, so
a crashed run leaves no stale lease. No rclpy: the launcher and the test fixtures take a domain
before any node exists.
"""

import fcntl
import os
import tempfile

DOMAIN_LOCK_DIR = os.path.join(tempfile.gettempdir(), 'flyby_ros_domains')
# Fast DDS derives ports from the domain id; ids up to 100 keep well inside the valid 0-232.
DOMAIN_RANGE = range(1, 101)


class DomainLease:
    """An exclusive ROS_DOMAIN_ID on this machine, held (flock) until released or the process exits."""

    def __init__(self, domain_id, lock_file):
        self.domain_id = domain_id
        self._lock_file = lock_file

    def release(self):
        if self._lock_file is not None:
            self._lock_file.close()
            self._lock_file = None


def lease_domain():
    """Take the first ROS domain no other flyby run or test on this machine holds."""
    os.makedirs(DOMAIN_LOCK_DIR, exist_ok=True)
    for domain_id in DOMAIN_RANGE:
        lock_file = open(os.path.join(DOMAIN_LOCK_DIR, f'{domain_id}.lock'), 'w')
        try:
            fcntl.flock(lock_file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock_file.close()
            continue
        return DomainLease(domain_id, lock_file)
    raise RuntimeError(f'no free ROS domain in {DOMAIN_RANGE.start}-{DOMAIN_RANGE.stop - 1} '
                       f'(locks in {DOMAIN_LOCK_DIR})')
