"""What the command lines share (scripts/): a parser whose misuse is one line ``error: ...`` and exit code 2,
argparse types with ranges, the reachability of a Dask scheduler, the rule of ``--out`` / ``--force`` and the one-line
report of an expected error (its traceback only with ``--debug``).

The run-directory rule (DESIGN §11): ``--force`` replaces only a directory that holds a run of ours, known by its
``run.json`` (RUN_MARKER, written at the very start of every run, before anything else), and never ``/``, the home
directory, the working directory or one of its parents.
"""

import argparse
import asyncio
import json
import math
import os
import shutil
import socket
import sys
from pathlib import Path
from urllib.parse import urlparse

from flyby_sim.scenario import SEED_MAX

RUN_MARKER = 'run.json'
MAX_LOCAL_PROCESSES = 256  # --jobs, --workers: more processes on one machine only thrash it (a fleet: --scheduler)
SCHEDULER_TIMEOUT_S = 3.0


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose misuse is one line ``error: ...`` on stderr (no usage block) and exit code 2."""

    def error(self, message):
        self.exit(2, f'error: {message}\n')


def _number(text, kind):
    """``text`` as a finite int or float; ArgumentTypeError (argparse names the option) otherwise."""
    try:
        value = kind(text)
    except ValueError:
        what = 'an integer' if kind is int else 'a number'
        raise argparse.ArgumentTypeError(f'expected {what}, got {text!r}') from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f'must be finite, got {text!r}')
    return value


def _ranged(kind, lo, closed):
    """An argparse type: a finite ``kind`` >= lo (closed) or > lo."""
    def parse(text):
        value = _number(text, kind)
        if value < lo or (value == lo and not closed):
            raise argparse.ArgumentTypeError(f'must be {">=" if closed else ">"} {lo:g}, got {text}')
        return value
    parse.__name__ = f'{kind.__name__} {">=" if closed else ">"} {lo:g}'  # argparse's name of the type
    return parse


def seed(text):
    """An argparse type: a seed, an integer in [0, SEED_MAX] (the one range of every seed, flyby_sim.scenario)."""
    value = _number(text, int)
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f'must be an integer in [0, {SEED_MAX}], got {text}')
    return value


def check_seed_span(parser, first_seed, runs):
    """Refuse (parser.error: one line, exit 2) runs whose seeds first_seed .. first_seed + runs - 1 leave the seed
    range."""
    if first_seed + runs - 1 > SEED_MAX:
        parser.error(f'argument --runs: the last seed --first-seed + --runs - 1 = {first_seed + runs - 1} '
                     f'must be <= {SEED_MAX}')


def processes(text):
    """An argparse type: a number of local processes, an integer in [1, MAX_LOCAL_PROCESSES]."""
    value = _number(text, int)
    if not 1 <= value <= MAX_LOCAL_PROCESSES:
        raise argparse.ArgumentTypeError(f'must be an integer in [1, {MAX_LOCAL_PROCESSES}] (more processes only '
                                         f'thrash one machine), got {text}')
    return value


def int_at_least(lo):
    """An argparse type: an integer >= lo."""
    return _ranged(int, lo, True)


def float_at_least(lo):
    """An argparse type: a finite number >= lo (nan and inf refused)."""
    return _ranged(float, lo, True)


def float_above(lo):
    """An argparse type: a finite number > lo (nan and inf refused)."""
    return _ranged(float, lo, False)


def check_scheduler(address, timeout_s=SCHEDULER_TIMEOUT_S):
    """Refuse (ValueError naming --scheduler) a TCP scheduler address that does not answer within ``timeout_s``, so
    an unreachable scheduler is one line after seconds rather than Dask's tracebacks after half a minute."""
    url = urlparse(address if '://' in address else f'tcp://{address}')
    if url.scheme not in ('tcp', 'tls'):
        return
    try:
        host, port = url.hostname, url.port
    except ValueError:
        host = port = None
    if not host or not port:
        raise ValueError(f'--scheduler {address}: expected tcp://HOST:PORT')
    try:
        socket.create_connection((host, port), timeout=timeout_s).close()
    except OSError as err:
        raise ValueError(f'--scheduler {address}: unreachable within {timeout_s:g} s '
                         f'({err.strerror or err or "timed out"})') from None
    try:
        asyncio.run(asyncio.wait_for(_dask_handshake(address, timeout_s), 2 * timeout_s))
    except Exception as err:  # anything but a Dask scheduler's handshake, whatever the peer sent
        raise ValueError(f'--scheduler {address}: answers, but not as a Dask scheduler within {timeout_s:g} s '
                         f'({type(err).__name__})') from None


async def _dask_handshake(address, timeout_s):
    """Connect to ``address`` by Dask's protocol (its handshake included) and close."""
    from distributed.comm import connect

    comm = await connect(address, timeout=timeout_s)
    await comm.close()


def _protected(path):
    """Is ``path`` (resolved) /, the home directory, the working directory or one of its parents?"""
    cwd = Path.cwd().resolve()
    return path in {Path('/'), Path.home().resolve(), cwd, *cwd.parents}


def check_out(out, force):
    """Refuse (ValueError naming --out) an output directory a run may not take: a file, a non-empty directory without
    ``force``, and with it one that holds no run (no RUN_MARKER), a symbolic link or a protected directory."""
    path = Path(out)
    if not path.exists():
        return path
    if not path.is_dir():
        raise ValueError(f'--out {out}: exists and is not a directory')
    if not any(path.iterdir()):
        return path
    if not force:
        raise ValueError(f'--out {out}: exists and is not empty (pass --force to replace a previous run)')
    if _protected(path.resolve()):
        raise ValueError(f'--out {out}: is /, the home directory, the working directory or one of its parents: '
                         f'never replaced')
    if path.is_symlink():
        raise ValueError(f'--out {out}: is a symbolic link: never replaced')
    if not (path / RUN_MARKER).is_file():
        raise ValueError(f'--out {out}: holds no run (no {RUN_MARKER}): --force replaces only a previous run')
    return path


def write_marker(run_dir, info):
    """Write ``run_dir/run.json`` atomically (a reader never sees half of it)."""
    tmp = Path(run_dir) / f'.{RUN_MARKER}.tmp'
    tmp.write_text(json.dumps(info, indent=2) + '\n')
    os.replace(tmp, Path(run_dir) / RUN_MARKER)


def make_run_dir(out, force, info):
    """The run directory, checked (check_out), emptied when it holds a previous run and ``force``, created, and
    marked with run.json (``info``) before anything else is written; ValueError naming --out if it cannot be."""
    path = check_out(out, force)
    try:
        if path.is_dir() and any(path.iterdir()):
            shutil.rmtree(path)
        path.mkdir(parents=True, exist_ok=True)
        write_marker(path, info)
    except OSError as err:
        raise ValueError(f'--out {out}: cannot be made ({err.strerror or err})') from None
    return path


def fail(err, debug, code=1):
    """The command line's end on an expected error: one line ``error: ...`` and ``code``; with ``debug`` the error
    is raised again (its traceback)."""
    if debug:
        raise err
    print(f'error: {err}', file=sys.stderr)
    return code
