"""Command-line misuse: every option out of its range refused in one line ``error: ...`` naming it, exit
code 2, before anything flies; nothing hangs (a worker's error crosses the process pool and ends the command in one
line); no traceback for an expected error. Through the scripts as a user runs them."""

import pickle
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from flyby_mission import cli
from flyby_mission.campaign.dispersions import CampaignError
from flyby_msgs_py.schema import ScenarioError
from flyby_msgs_py.schema.blocks import Invalid

ROOT = Path(__file__).resolve().parents[4]
SCRIPTS = ROOT / 'scripts'
PAPER = ROOT / 'scenarios' / 'paper_flyby.yaml'
CAMPAIGN = ROOT / 'campaigns' / 'auto_envelope.yaml'


def script(name, *args, timeout=60):
    return subprocess.run([sys.executable, str(SCRIPTS / name), *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, timeout=timeout)


def assert_one_line(done, *words, code=2):
    """Exit ``code``, one line ``error: ...`` on stderr holding ``words``, no traceback."""
    assert done.returncode == code, done.stderr[-2000:]
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('error: '), done.stderr[-2000:]
    for word in words:
        assert word in lines[0], lines[0]


def test_scenario_errors_cross_a_process_boundary():
    for err in (ScenarioError('f.yaml', 'orbit.radius_m', 'too low'), CampaignError('c.yaml', '', 'bad'),
                Invalid('a.b', 'bad')):
        back = pickle.loads(pickle.dumps(err))
        assert (type(back), str(back), back.key, back.problem) == (type(err), str(err), err.key, err.problem)


@pytest.mark.parametrize('args, option', [
    (('--runs', 1, '--jobs', 1, '--first-seed', -1), '--first-seed'),
    (('--runs', 1, '--jobs', 1, '--nav-noise-scale', -1), '--nav-noise-scale'),
    (('--runs', 1, '--nav-noise-scale', 'nan'), '--nav-noise-scale'),
    (('--runs', 0), '--runs'),
    (('--runs', 1, '--jobs', 0), '--jobs'),
    (('--out', 'x', '--seed', -1), '--seed'),
    (('--out', 'x', '--seed', 'abc'), '--seed'),
])
def test_closed_loop_refuses_an_option_out_of_its_range(args, option):
    assert_one_line(script('closed_loop.py', *args), f'argument {option}')


def test_closed_loop_ends_on_a_worker_error_in_one_line():
    # Valid on the command line, but the run's derived noise overflows in the worker: the pool hands it back.
    done = script('closed_loop.py', '--runs', 1, '--jobs', 1, '--nav-noise-scale', '1e308')
    assert_one_line(done, code=1)  # (a ScenarioError once the schema bounds the derived noise)


@pytest.mark.parametrize('args, option', [
    (('--rtf', 'nan'), '--rtf'), (('--rtf', -1), '--rtf'), (('--wall-timeout', -5), '--wall-timeout'),
    (('--seed', -1), '--seed'), (('--abort-at', -3), '--abort-at'), (('--kill', 'flyby_sim@3'), '--kill'),
])
def test_run_mission_refuses_an_option_out_of_its_range(tmp_path, args, option):
    assert_one_line(script('run_mission.py', '--scenario', PAPER, '--out', tmp_path / 'run', *args), option)
    assert not (tmp_path / 'run').exists()


@pytest.mark.parametrize('args, option', [
    (('--workers', -1), '--workers'), (('--workers', 0), '--workers'), (('--runs', 0), '--runs'),
])
def test_run_campaign_refuses_an_option_out_of_its_range(tmp_path, args, option):
    assert_one_line(script('run_campaign.py', '--campaign', CAMPAIGN, '--out', tmp_path / 'c', *args), option)
    assert not (tmp_path / 'c').exists()


def test_run_campaign_refuses_an_unreachable_scheduler_within_seconds(tmp_path):
    with socket.socket() as s:  # a port nothing listens on
        s.bind(('127.0.0.1', 0))
        port = s.getsockname()[1]
    done = script('run_campaign.py', '--campaign', CAMPAIGN, '--out', tmp_path / 'c', '--scheduler',
                  f'tcp://127.0.0.1:{port}', timeout=120)  # refused in seconds; a loaded machine imports slowly
    assert_one_line(done, '--scheduler', 'unreachable')
    assert_one_line(script('run_campaign.py', '--campaign', CAMPAIGN, '--out', tmp_path / 'c', '--scheduler',
                           'tcp://nowhere'), '--scheduler', 'tcp://HOST:PORT')


def test_run_campaign_refuses_an_out_that_is_a_file(tmp_path):
    (tmp_path / 'f').write_text('')
    assert_one_line(script('run_campaign.py', '--campaign', CAMPAIGN, '--out', tmp_path / 'f'), '--out')


def test_plan_capture_refuses_a_negative_seed():
    assert_one_line(script('plan_capture.py', '--scenario', PAPER, '--seed', -1), 'argument --seed')


def test_ranged_types_refuse_nan_inf_and_bounds():
    import argparse
    for parse, text in ((cli.float_at_least(0), 'nan'), (cli.float_at_least(0), 'inf'), (cli.float_above(0), '0'),
                        (cli.int_at_least(1), '0'), (cli.int_at_least(0), '1.5')):
        with pytest.raises(argparse.ArgumentTypeError):
            parse(text)
    assert (cli.float_at_least(0)('0'), cli.float_above(0)('1e-9'), cli.int_at_least(1)('3')) == (0.0, 1e-9, 3)


@pytest.mark.parametrize('args, option', [
    (('--out', 'x', '--seed', 2**32), '--seed'),
    (('--out', 'x', '--seed', 10**23), '--seed'),
    (('--runs', 1, '--first-seed', 2**32), '--first-seed'),
    (('--runs', 2, '--first-seed', 2**32 - 1), '--runs'),
])
def test_closed_loop_refuses_a_seed_beyond_32_bits(args, option):
    assert_one_line(script('closed_loop.py', *args), f'argument {option}', '4294967295')


@pytest.mark.parametrize('name', ['estimation_consistency.py', 'mass_estimation_consistency.py'])
def test_consistency_scripts_refuse_seeds_running_past_32_bits(name):
    assert_one_line(script(name, '--scenario', PAPER, '--runs', 2, '--first-seed', 2**32 - 1), 'argument --runs',
                    '4294967295')


def test_plan_capture_refuses_a_seed_beyond_32_bits():
    assert_one_line(script('plan_capture.py', '--scenario', PAPER, '--seed', 2**32), 'argument --seed', '4294967295')


def test_seed_type_takes_every_32_bit_seed_and_refuses_the_rest():
    import argparse
    assert (cli.seed('0'), cli.seed(str(2**32 - 1))) == (0, 2**32 - 1)
    for text in ('-1', str(2**32), '1e23', '1.5', 'nan'):
        with pytest.raises(argparse.ArgumentTypeError):
            cli.seed(text)


def test_closed_loop_and_run_campaign_refuse_more_processes_than_one_machine_takes(tmp_path):
    assert_one_line(script('closed_loop.py', '--runs', 1, '--jobs', 100000), 'argument --jobs', '256')
    assert_one_line(script('run_campaign.py', '--campaign', CAMPAIGN, '--out', tmp_path / 'c', '--workers', 100000),
                    'argument --workers', '256')
    assert not (tmp_path / 'c').exists()
