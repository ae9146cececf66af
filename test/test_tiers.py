"""The two test tiers (docs/testing.md): `make test` runs the tests not marked `slow`, `make test-all` every test.

A test is marked slow or not, so the two tiers together are the whole suite by construction. What could still lose
a test from both is a test file outside pytest's `testpaths` (never collected) or a misspelled marker (pytest would
take it for another marker and the test would run in the fast tier by mistake); these tests refuse both, and check
that the fast tier keeps a real graph mission and a headless one.
"""

import configparser
import re
import subprocess
import sys

from flyby_testing import ROOT

SKIPPED_DIRS = {'.venv', '.git', 'build', 'install', 'log', 'runs', 'node_modules'}
FAST_GRAPH_MISSION = 'test/test_mission.py::test_abort_during_the_terminal_approach'
FAST_HEADLESS_MISSION = ('flyby_ws/src/flyby_mission/test/test_headless_6dof.py::'
                         'test_paper_flyby_6dof_captures_pointing_at_the_target_without_thrust_in_the_sphere')
SLOW_GRAPH_MISSION = 'test/test_mission.py::test_target_rate_fault_ends_in_a_safe_escape_over_one_orbit'


def _pytest_ini():
    parser = configparser.ConfigParser()
    parser.read(ROOT / 'pytest.ini')
    return parser['pytest']


def _recipe(target):
    """The recipe lines of one Makefile target, joined."""
    lines = (ROOT / 'Makefile').read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f'{target}:'))
    recipe = []
    for line in lines[start + 1:]:
        if not line.startswith('\t'):
            break
        recipe.append(line.strip())
    return ' '.join(recipe)


def _test_files():
    for path in ROOT.rglob('*.py'):
        relative = path.relative_to(ROOT)
        if SKIPPED_DIRS.intersection(relative.parts[:-1]):
            continue
        if path.name.startswith('test_') or path.name.endswith('_test.py'):
            yield relative


def test_make_test_leaves_the_slow_tests_out_and_make_test_all_selects_none_out():
    fast, full = _recipe('test'), _recipe('test-all')
    assert '-m "not slow"' in fast
    options = full.split(' -m pytest ', 1)[1]
    assert ' -m ' not in f' {options}' and '-k ' not in options
    assert fast.replace('-m "not slow" ', '') == full  # the same run otherwise, PYTEST_ARGS included
    ci = (ROOT / '.ci' / 'run').read_text().splitlines()
    assert 'make test-all' in ci and 'make test' not in ci


def test_the_slow_marker_is_registered_and_an_unknown_marker_is_an_error():
    ini = _pytest_ini()
    assert re.search(r'^\s*slow:', ini['markers'], re.MULTILINE)
    assert '--strict-markers' in ini['addopts'].split()


def test_every_test_file_is_under_a_testpath():
    roots = [ROOT / p for p in _pytest_ini()['testpaths'].split()]
    files = list(_test_files())
    assert files
    lost = [str(f) for f in files if not any((ROOT / f).is_relative_to(r) for r in roots)]
    assert lost == []


def test_the_fast_tier_keeps_a_graph_mission_and_a_headless_one():
    done = subprocess.run(
        [sys.executable, '-m', 'pytest', '--collect-only', '-q', '-p', 'no:cacheprovider', '-m', 'not slow',
         FAST_GRAPH_MISSION.split('::')[0], FAST_HEADLESS_MISSION.split('::')[0]],
        cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    collected = done.stdout.splitlines()
    assert FAST_GRAPH_MISSION in collected and FAST_HEADLESS_MISSION in collected
    assert SLOW_GRAPH_MISSION not in collected
