#!/usr/bin/env python3
"""The acceptance of the input hardening (docs/hardening.md): every leaf of every shipped scenario and campaign file
mutated as a new user would, each mutant loaded and classified; a sample through the real command lines.

    nice -n 10 .venv/bin/python scripts/bench/input_mutations.py [--sample N] [--leaves N] [--jobs J]
                                                                 [--timeout S] [--json FILE] [--only TEXT]

Mutations of each leaf (a scalar, a vector or a matrix of the file): delete, a string, a list, a mapping, NaN, inf,
-inf, negative, zero, 1e300, 1e-300, a short and a long vector, a typo of its key; of each number key a scenario leaves
at its default: NaN, 1e300 and 1e-300; and the geometric and physical cases of the issue (physical_cases,
campaign_cases; docs/hardening.md lists them).

Each mutant is written to a file and loaded by flyby_sim.scenario.load_scenario or
flyby_mission.campaign.dispersions.load_campaign (its first CAMPAIGN_DRAWS runs drawn and validated) in-process, under a
per-case SIGALRM timeout, in --jobs processes. Classes:

    refused        one line naming the file and the key (the mutated key, a key within it or the group holding it,
                   or a message that names the mutated key: a check across keys)
    unnamed        refused, but the line names neither the file nor the key
    accepted       a legitimate value (a default deleted, a negative position, a long wheel-axes list, ...)
    meaningless    accepted, but of a class that must never be: NaN or inf, a wrong type, a typo, 1e300, a value out
                   of the key's declared range, a fixed-length vector of another length, a physical case
    traceback      any other exception
    hang           no answer within --timeout

--sample N mutants (and every command-line misuse of MISUSES) also go through the scripts in subprocesses:
closed_loop.py --scenario MUTANT --out DIR (an accepted mutant of a fast scenario flies), run_campaign.py --campaign
MUTANT --runs 1 --workers 1; a refusal there is exit code 1 or 2 and one line ``error: ...`` naming the file and key,
a misuse one line naming the option with exit code 2. Prints a table of counts; exit code 1 if any hang, traceback,
unnamed refusal or meaningless acceptance remains. docs/hardening.md gives the command and the counts.
"""

import argparse
import collections
import concurrent.futures
import copy
import json
import math
import random
import re
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

from flyby_msgs_py.schema import REQUIRED, Field, ListOf, ScenarioError, Section
from flyby_sim.scenario import SCHEMA

ROOT = Path(__file__).resolve().parents[2]
CAMPAIGN_DRAWS = 5  # runs of a mutated campaign drawn and validated at load (its draws past them: docs/hardening.md)
FAST_SCENARIOS = ('paper_flyby', 'jacobsen_optimal', 'paper_flyby_6dof')  # an accepted mutant of these may fly
BAD = ('hang', 'traceback', 'unnamed', 'meaningless')
ALWAYS_MEANINGLESS = {'string', 'list', 'mapping', 'nan', 'inf', '-inf', '1e300', 'typo', 'physical'}


class Hang(BaseException):
    """A case that outlived its timeout (raised by SIGALRM)."""


# --------------------------------------------------------------------------------------------------
# Leaves, keys and the schema

def key_text(path):
    """('target', 'geometry', 1, 'size_m') as the loader names it: 'target.geometry[1].size_m'."""
    out = ''
    for part in path:
        out += f'[{part}]' if isinstance(part, int) else (f'.{part}' if out else str(part))
    return out


def _is_numbers(v):
    return isinstance(v, list) and bool(v) and all(
        (isinstance(x, (int, float)) and not isinstance(x, bool)) or _is_numbers(x) for x in v)


def leaves(data, path=()):
    """Every leaf path of a parsed file: scalars, vectors and matrices of numbers (lists of mappings walked)."""
    if isinstance(data, dict):
        for k, v in data.items():
            yield from leaves(v, (*path, k))
    elif isinstance(data, list) and not _is_numbers(data):
        for i, v in enumerate(data):
            yield from leaves(v, (*path, i))
    else:
        yield path


_ENTRY_FIELDS = {  # the keys of a chasers: entry beside the chaser block's (flyby_sim.chasers.ENTRY_KEYS)
    'name': Field('str', REQUIRED, desc='The chaser\'s namespace.'),
    'grasp_point_body_m': Field('3-vector', None, desc='Its own grasp point (else the target\'s).'),
}


def schema_node(path):
    """The schema node of a scenario path ('chasers' entries read as the chaser block), or None."""
    node = SCHEMA
    if path[:1] == ('chasers',) and len(path) >= 3:
        if path[2] in _ENTRY_FIELDS and len(path) == 3:
            return _ENTRY_FIELDS[path[2]]
        node, path = SCHEMA.fields['chaser'], path[2:]
    for part in path:
        if isinstance(node, ListOf) and isinstance(part, int):
            node = node.item
        elif isinstance(node, Section) and part in node.fields:
            node = node.fields[part]
        else:
            return None
    return node


def absent_number_keys(data, node=SCHEMA, path=()):
    """The number keys of the schema a single-chaser scenario leaves at their default (its sections given)."""
    if not isinstance(data, dict):
        return
    for k, sub in node.fields.items():
        if isinstance(sub, Section) and k in data:
            yield from absent_number_keys(data[k], sub, (*path, k))
        elif isinstance(sub, Section) and not sub.optional and not sub.one_of:
            yield from absent_number_keys({}, sub, (*path, k))
        elif isinstance(sub, Field) and k not in data and sub.kind == 'float' and k not in node.alternatives:
            yield (*path, k)


def _get(d, path):
    for part in path:
        d = d[part]
    return d


def _set(d, path, value):
    _get(d, path[:-1])[path[-1]] = value


# --------------------------------------------------------------------------------------------------
# Mutations

def _typo(name):
    """The key with its last two letters swapped, or (when they are alike: 'hill') its middle letter dropped."""
    swapped = name[:-2] + name[-1] + name[-2] if len(name) > 2 else name + 'x'
    return swapped if swapped != name else name[:len(name) // 2] + name[len(name) // 2 + 1:]


def _scalar_at(v, x):
    """v with x put in its first number (v itself when a scalar)."""
    if isinstance(v, list):
        return [_scalar_at(v[0], x), *copy.deepcopy(v[1:])]
    return x


def _negate(v):
    if isinstance(v, list):
        return [_negate(x) for x in v]
    return -v if isinstance(v, (int, float)) and not isinstance(v, bool) and v else -1.0


def leaf_mutations(v, path):
    """(name, value or DELETE, mutated path) of one leaf."""
    out = [('delete', DELETE, path), ('string', 'abc', path), ('list', ['abc', 'abc'], path),
           ('mapping', {'abc': 1.0}, path), ('nan', _scalar_at(v, math.nan), path),
           ('inf', _scalar_at(v, math.inf), path), ('-inf', _scalar_at(v, -math.inf), path),
           ('negative', _negate(v), path), ('zero', _scalar_at(v, 0.0), path),
           ('1e300', _scalar_at(v, 1e300), path), ('1e-300', _scalar_at(v, 1e-300), path)]
    if isinstance(v, list):
        out += [('short', copy.deepcopy(v[:-1]), path), ('long', copy.deepcopy(v + v[-1:]), path)]
    if isinstance(path[-1], str):
        out.append(('typo', RENAME, (*path[:-1], _typo(path[-1]))))
    return out


DELETE, RENAME = object(), object()


def apply(data, path, original, value):
    """A deep copy of data with the mutation applied (path: the mutated key, original: the leaf's path)."""
    d = copy.deepcopy(data)
    parent = _get(d, original[:-1])
    if value is DELETE:
        del parent[original[-1]]
    elif value is RENAME:
        parent[path[-1]] = parent.pop(original[-1])
    else:
        _set(d, original, value)
    return d


def _single(d):
    """The chaser block of a file (the first of ``chasers:``)."""
    return d['chaser'] if 'chaser' in d else d['chasers'][0]


def physical_cases(data):
    """(name, mutate(d) -> mutated key path) of the issue's geometric and physical cases for a scenario."""
    chaser = ('chaser',) if 'chaser' in data else ('chasers', 0)
    box = data['target']['geometry'][0]
    cases = {
        'chaser start at the target CoM': (lambda d: _set(d, (*chaser, 'initial_position_hill_m'), [0.0, 0.0, 0.0]),
                                           (*chaser, 'initial_position_hill_m')),
        'chaser start inside the bus': (lambda d: _set(d, (*chaser, 'initial_position_hill_m'), [0.3, 0.0, 0.0]),
                                        (*chaser, 'initial_position_hill_m')),
        'grasp point at the box centre': (lambda d: _set(d, ('target', 'grasp_point_body_m'), box['center_m']),
                                          ('target', 'grasp_point_body_m')),
        'grasp point 100 m off': (lambda d: _set(d, ('target', 'grasp_point_body_m'), [100.0, 0.0, 0.0]),
                                  ('target', 'grasp_point_body_m')),
        'orbit inside the Earth': (lambda d: d.update(orbit={'radius_m': 1000.0}), ('orbit', 'radius_m')),
        'orbit 6000 km': (lambda d: d.update(orbit={'radius_m': 6.0e6}), ('orbit', 'radius_m')),
        'mu 1e-300': (lambda d: d['orbit'].update(mu_m3_s2=1e-300), ('orbit', 'mu_m3_s2')),
        'mu 1e5': (lambda d: d['orbit'].update(mu_m3_s2=1e5), ('orbit', 'mu_m3_s2')),
        'target inertia 1e-300': (lambda d: d['target'].update(inertia_kg_m2=_diag(1e-300)),
                                  ('target', 'inertia_kg_m2')),
        'target inertia 1e-6': (lambda d: d['target'].update(inertia_kg_m2=_diag(1e-6)), ('target', 'inertia_kg_m2')),
        'target inertia 1e9': (lambda d: d['target'].update(inertia_kg_m2=_diag(1e9)), ('target', 'inertia_kg_m2')),
        'step 1e-9': (lambda d: d.setdefault('simulation', {}).update(step_s=1e-9), ('simulation', 'step_s')),
        'duration 1e300': (lambda d: d['simulation'].update(duration_s=1e300), ('simulation', 'duration_s')),
        'duration 1e7 s': (lambda d: d['simulation'].update(duration_s=1e7), ('simulation', 'duration_s')),
        'duration half a step': (lambda d: d['simulation'].update(duration_s=0.5 * d['simulation'].get('step_s', 0.05)),
                                 ('simulation', 'duration_s')),
        'seed 2**32': (lambda d: d.update(seed=2**32), ('seed',)),
        'seed 1e23': (lambda d: d.update(seed=10**23), ('seed',)),
        'rpy 1e300': (lambda d: d['target'].update(initial_attitude={'rpy_rad': [1e300, 0.0, 0.0]}),
                      ('target', 'initial_attitude', 'rpy_rad')),
        'rpy 100 rad': (lambda d: d['target'].update(initial_attitude={'rpy_rad': [100.0, 0.0, 0.0]}),
                        ('target', 'initial_attitude', 'rpy_rad')),
        'target rate 1e4 deg/s': (lambda d: d['target'].update(initial_rate={'omega_body_deg_s': [1e4, 0.0, 0.0]}),
                                  ('target', 'initial_rate', 'omega_body_deg_s')),
        'sensor faster than the step': (lambda d: d.setdefault('sensors', {}).update(
            relative_position={'rate_hz': 1000.0}), ('sensors', 'relative_position', 'rate_hz')),
        'parallel wheel axes': (lambda d: _set(d, (*chaser, 'wheels'), {'axes': [[1, 0, 0], [1, 0, 0], [0, 0, 1]]}),
                                (*chaser, 'wheels', 'axes')),
        'chaser speed 1e4 m/s': (lambda d: _set(d, (*chaser, 'initial_velocity_hill_mps'), [1e4, 0.0, 0.0]),
                                 (*chaser, 'initial_velocity_hill_mps')),
        'midcourse corrections 1e9': (lambda d: d.setdefault('guidance', {}).update(midcourse_corrections=10**9),
                                      ('guidance', 'midcourse_corrections')),
    }
    if _attached(data):  # the chaser holds the target from the start: its attitude and rate derived from the chaser's
        for name in ('rpy 1e300', 'rpy 100 rad', 'target rate 1e4 deg/s', 'chaser start at the target CoM',
                     'chaser start inside the bus'):
            del cases[name]
    return cases


def _attached(data):
    return (data.get('post_capture') or {}).get('start') == 'attached'


def _diag(x):
    return [[x, 0.0, 0.0], [0.0, x, 0.0], [0.0, 0.0, x]]


def campaign_cases(data, base):
    """(name, mutate(d) -> mutated key path) of the issue's campaign cases (``base``: its base scenario's data)."""
    first = next(iter(data['dispersions']))

    def disperse(key, spec):
        return lambda d: d['dispersions'].update({key: spec})
    hill = 'target.initial_attitude.body_axis_along_hill.hill'
    cases = {
        'exclusion cone leaving no direction': (disperse(hill, {'kind': 'direction', 'exclude_cone': {
            'axis': [0, 1, 0], 'half_angle_deg': 179.0, 'both_ways': True}}), ('dispersions', hill)),
        "half angle 'abc'": (disperse(hill, {'kind': 'direction', 'exclude_cone': {
            'axis': [0, 1, 0], 'half_angle_deg': 'abc'}}), ('dispersions', hill)),
        "both_ways 'no'": (disperse(hill, {'kind': 'direction', 'exclude_cone': {
            'axis': [0, 1, 0], 'half_angle_deg': 10, 'both_ways': 'no'}}), ('dispersions', hill)),
        'axis_probability true': (disperse('target.initial_rate.omega_body_deg_s', {
            'kind': 'direction', 'axis_probability': True}), ('dispersions', 'target.initial_rate.omega_body_deg_s')),
        'low and high of different lengths': (disperse(first, {'kind': 'uniform', 'low': [0, 0], 'high': [1, 1, 1]}),
                                              ('dispersions', first)),
        'box_surface_point chaser start': (disperse('chaser.initial_position_hill_m', {'kind': 'box_surface_point'}),
                                           ('dispersions', 'chaser.initial_position_hill_m')),
        'campaign seed 2**32': (lambda d: d.update(seed=2**32), ('seed',)),
        'runs 1e9': (lambda d: d.update(runs=10**9), ('runs',)),
    }
    if _attached(base):
        del cases['box_surface_point chaser start']
    return cases


# --------------------------------------------------------------------------------------------------
# One case

def _accepted_class(case):
    """'accepted' or 'meaningless' for a mutant the loader took (module doc)."""
    name, path = case['mutation'], tuple(case['path'])
    node = schema_node(path) if case['kind'] == 'scenario' else None
    if name == 'string' and isinstance(node, Field) and node.kind == 'str':
        return 'accepted'  # another name or description
    if name in ALWAYS_MEANINGLESS:
        return 'meaningless'
    if name == 'delete':
        return 'meaningless' if isinstance(node, Field) and node.default is REQUIRED and \
            not _is_alternative(path) else 'accepted'
    if case['kind'] == 'campaign':
        return 'meaningless' if name in ('short', 'long') and path[-1] not in ('values', 'weights', 'boxes') \
            else 'accepted'
    if not isinstance(node, Field):
        return 'accepted'
    if name in ('short', 'long'):
        return 'meaningless' if node.kind in ('3-vector', 'quaternion', '3x3 matrix') else 'accepted'
    value = {'negative': -1.0, 'zero': 0.0, '1e-300': 1e-300}[name]
    return 'meaningless' if node._range is not None and not node._range.contains(value) else 'accepted'


def _is_alternative(path):
    parent = schema_node(path[:-1]) if len(path) > 1 else SCHEMA
    return isinstance(parent, Section) and path[-1] in parent.alternatives


def named(case, file, key, message):
    """Does a refusal name the file and the right key (module doc)? The key named: the mutated key (for a typo also
    the key it misspells), a key within it or a section holding it, or a key the message names (a check across keys:
    itself, or a section holding it; a ``chasers:`` entry's keys as its chaser block, chaser.*, spells them)."""
    if not message.startswith(f'{file}: ') or '\n' in message or not key:
        return False
    candidates = {_dotted(key_text(case['path']))}
    if case['mutation'] == 'typo' and case.get('original'):
        candidates.add(_dotted(key_text(case['original'])))
    for mutated in list(candidates):
        candidates.add(re.sub(r'^chasers\.\d+\.', 'chaser.', mutated))
    key = _dotted(key)
    stem = re.sub(r'(\.\d+)+$', '', key)
    mentioned = {_dotted(m) for m in re.findall(r'[a-z_]+(?:\.[a-z0-9_]+|\[\d+\])+', message.split(': ', 2)[-1])}
    return any(stem == m or m.startswith((stem + '.', stem + '[')) or stem.startswith(m + '.')
               or any(m == t or m.startswith(t + '.') for t in mentioned) for m in candidates)


def _dotted(key):
    """A key with its list indices dotted (a campaign names target.geometry.1.size_m what the loader names
    target.geometry[1].size_m)."""
    return re.sub(r'\[(\d+)\]', r'.\1', key)


def run_case(case):
    """Load one mutant (written into case['dir']) in this process under a SIGALRM timeout; its class and message."""
    from flyby_mission.campaign.dispersions import load_campaign
    from flyby_sim.scenario import load_scenario

    file = Path(case['dir']) / case['name']
    file.write_text(yaml_text(case['data']))
    signal.signal(signal.SIGALRM, _on_alarm)
    signal.setitimer(signal.ITIMER_REAL, case['timeout'])
    try:
        if case['kind'] == 'scenario':
            load_scenario(file)
        else:
            load_campaign(file, checked_draws=CAMPAIGN_DRAWS)
        result = (_accepted_class(case), '')
    except ScenarioError as err:
        result = ('refused' if named(case, file, err.key, str(err)) else 'unnamed', str(err))
    except Hang:
        result = ('hang', f'no answer within {case["timeout"]} s')
    except BaseException as err:  # noqa: BLE001 - every other exception is what the harness counts
        result = ('traceback', f'{type(err).__name__}: {err}'[:300])
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    return {**{k: case[k] for k in ('file', 'kind', 'mutation', 'path')}, 'class': result[0], 'message': result[1]}


def _on_alarm(signum, frame):
    raise Hang()


# --------------------------------------------------------------------------------------------------
# All cases

def _case(kind, source, name, path, mutated, timeout):
    return {'file': source.name, 'kind': kind, 'mutation': name, 'path': list(path), 'timeout': timeout,
            'name': source.name, 'data': mutated}


def yaml_text(data):
    """A mutant as the file a user would write (libyaml's dumper where there is one: the slow part otherwise)."""
    return yaml.dump(data, Dumper=getattr(yaml, 'CSafeDumper', yaml.SafeDumper), sort_keys=False)


def scenario_cases(path, timeout, leaf_limit, rng):
    data = yaml.safe_load(path.read_text())
    paths = list(leaves(data))
    if leaf_limit:
        paths = sorted(rng.sample(paths, min(leaf_limit, len(paths))))
    for p in paths:
        for name, value, mutated_path in leaf_mutations(_get(data, p), p):
            yield {**_case('scenario', path, name, mutated_path, apply(data, mutated_path, p, value), timeout),
               'original': list(p)}
    if 'chaser' in data:
        absent = list(absent_number_keys(data))
        for p in (rng.sample(absent, min(leaf_limit, len(absent))) if leaf_limit else absent):
            for name, value in (('nan', math.nan), ('1e300', 1e300), ('1e-300', 1e-300)):
                d = copy.deepcopy(data)
                for i in range(1, len(p)):
                    _get(d, p[:i - 1]).setdefault(p[i - 1], {})
                _set(d, p, value)
                yield _case('scenario', path, name, p, d, timeout)
    for name, (mutate, p) in physical_cases(data).items():
        d = copy.deepcopy(data)
        mutate(d)
        yield {**_case('scenario', path, 'physical', p, d, timeout), 'case': name}


def campaign_case_list(path, timeout, leaf_limit, rng):
    data = yaml.safe_load(path.read_text())
    paths = [p for p in leaves(data) if p[0] not in ('name', 'description')]
    if leaf_limit:
        paths = sorted(rng.sample(paths, min(leaf_limit, len(paths))), key=str)
    for p in paths:
        for name, value, mutated_path in leaf_mutations(_get(data, p), p):
            yield {**_case('campaign', path, name, mutated_path, apply(data, mutated_path, p, value), timeout),
                   'original': list(p)}
    base = yaml.safe_load((path.parent / data['base_scenario']).read_text())
    for name, (mutate, p) in campaign_cases(data, base).items():
        d = copy.deepcopy(data)
        mutate(d)
        yield {**_case('campaign', path, 'physical', p, d, timeout), 'case': name}


def _init_worker(directory):
    """Each worker writes its mutants into a directory of its own (the campaign's base_scenario resolves there)."""
    global _WORKER_DIR
    _WORKER_DIR = tempfile.mkdtemp(dir=directory)
    (Path(_WORKER_DIR) / 'scenarios').symlink_to(ROOT / 'scenarios')
    (Path(_WORKER_DIR) / 'campaigns').mkdir()


def _run_in_worker(case):
    sub = 'campaigns' if case['kind'] == 'campaign' else ''
    return run_case({**case, 'dir': str(Path(_WORKER_DIR) / sub)})


def load_all(cases, jobs, directory):
    if jobs == 1:
        _init_worker(directory)
        return [_run_in_worker(c) for c in cases]
    with concurrent.futures.ProcessPoolExecutor(jobs, initializer=_init_worker, initargs=(directory,)) as pool:
        return list(pool.map(_run_in_worker, cases, chunksize=50))


# --------------------------------------------------------------------------------------------------
# The command lines

_PAPER = 'scenarios/paper_flyby.yaml'
_SMOKE = 'campaigns/smoke.yaml'
# (script, arguments, the option the one-line refusal must name[, its exit codes: 2 unless the OS refuses it when the
# run starts, 1]); {out} is a fresh directory.
MISUSES = (
    ('closed_loop.py', ('--runs', '1', '--jobs', '1', '--first-seed', '-1'), '--first-seed'),
    ('closed_loop.py', ('--runs', '1', '--first-seed', '4294967296'), '--first-seed'),
    ('closed_loop.py', ('--runs', '2', '--first-seed', '4294967295'), '--runs'),
    ('closed_loop.py', ('--runs', '1', '--jobs', '1', '--nav-noise-scale', '-1'), '--nav-noise-scale'),
    ('closed_loop.py', ('--runs', '0'), '--runs'),
    ('closed_loop.py', ('--runs', '1', '--jobs', '0'), '--jobs'),
    ('closed_loop.py', ('--runs', '1', '--jobs', '100000'), '--jobs'),
    ('closed_loop.py', ('--runs', '1', '--json', '/sys/x/y.json'), '--json'),
    ('closed_loop.py', ('--out', '{out}', '--seed', '-1'), '--seed'),
    ('closed_loop.py', ('--out', '{out}', '--seed', '100000000000000000000000'), '--seed'),
    ('closed_loop.py', ('--out', '{out}', '--seed', '1e23'), '--seed'),
    ('closed_loop.py', ('--out', '/sys/x'), '--out', (1,)),
    ('closed_loop.py', ('--out', '.', '--force'), '--out'),
    ('run_mission.py', ('--scenario', _PAPER, '--out', '{out}', '--seed', '-1'), '--seed'),
    ('run_mission.py', ('--scenario', _PAPER, '--out', '{out}', '--seed', '4294967296'), '--seed'),
    ('run_mission.py', ('--scenario', _PAPER, '--out', '{out}', '--rtf', 'nan'), '--rtf'),
    ('run_mission.py', ('--scenario', _PAPER, '--out', '{out}', '--wall-timeout', '-5'), '--wall-timeout'),
    ('run_mission.py', ('--scenario', _PAPER, '--out', '.', '--force'), '--out'),
    ('run_mission.py', ('--scenario', _PAPER), '--out'),
    ('run_campaign.py', ('--campaign', _SMOKE, '--out', '{out}', '--workers', '-1'), '--workers'),
    ('run_campaign.py', ('--campaign', _SMOKE, '--out', '{out}', '--workers', '0'), '--workers'),
    ('run_campaign.py', ('--campaign', _SMOKE, '--out', '{out}', '--workers', '100000'), '--workers'),
    ('run_campaign.py', ('--campaign', _SMOKE, '--out', '{out}', '--runs', 'inf'), '--runs'),
    ('run_campaign.py', ('--campaign', _SMOKE, '--out', '{out}', '--runs', '0'), '--runs'),
    ('run_campaign.py', ('--campaign', _SMOKE, '--out', '{out}', '--scheduler', 'tcp://127.0.0.1:9'), '--scheduler'),
)


def _script(args, timeout):
    """(exit code or None on a timeout, stderr) of one script run."""
    try:
        done = subprocess.run([sys.executable, *args], capture_output=True, text=True, cwd=ROOT, timeout=timeout,
                              stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return None, ''
    return done.returncode, done.stderr


def _cli_class(code, stderr, must_name, refused_codes=(1, 2)):
    """A script's run as one of the classes (module doc); ``must_name``: the words a refusal line must hold."""
    if code is None:
        return 'hang'
    if 'Traceback' in stderr:
        return 'traceback'
    lines = stderr.strip().splitlines()
    if code in refused_codes and lines:
        last = lines[-1]
        ok = len(lines) == 1 and last.startswith('error: ') and all(w in last for w in must_name)
        return 'refused' if ok else 'unnamed'
    return 'accepted'


def misuse_results(directory, timeout):
    out = []
    for i, (script, args, option, *codes) in enumerate(MISUSES):
        argv = [str(ROOT / 'scripts' / script), *(a.format(out=f'{directory}/misuse{i}') for a in args)]
        code, stderr = _script(argv, timeout)
        cls = _cli_class(code, stderr, (option,), refused_codes=codes[0] if codes else (2,))
        out.append({'file': script, 'kind': 'command line', 'mutation': 'misuse', 'path': [' '.join(args)],
                    'class': 'meaningless' if cls == 'accepted' else cls, 'message': stderr.strip()[-300:]})
    return out


def command_line_results(cases, loaded, sample, directory, timeout, rng):
    """A sample of the mutants through closed_loop.py (``sample`` refused scenarios, a quarter as many accepted ones of
    FAST_SCENARIOS, which fly) and run_campaign.py (a quarter as many refused campaigns)."""
    out = []
    def pick(n, keep):
        candidates = [i for i, r in enumerate(loaded) if keep(r)]
        return rng.sample(candidates, min(n, len(candidates)))
    picks = pick(sample, lambda r: r['kind'] == 'scenario' and r['class'] == 'refused')
    picks += pick(max(1, sample // 4), lambda r: r['kind'] == 'scenario' and r['class'] == 'accepted'
                  and Path(r['file']).stem in FAST_SCENARIOS)
    picks += pick(max(1, sample // 4), lambda r: r['kind'] == 'campaign' and r['class'] == 'refused')
    for n, i in enumerate(sorted(picks)):
        case, loaded_case = cases[i], loaded[i]
        run_dir = Path(directory) / f'cli{n}'
        sub = run_dir / 'campaigns' if case['kind'] == 'campaign' else run_dir
        sub.mkdir(parents=True)
        (run_dir / 'scenarios').symlink_to(ROOT / 'scenarios')
        file = sub / case['name']
        file.write_text(yaml_text(case['data']))
        if case['kind'] == 'scenario':
            argv = [str(ROOT / 'scripts' / 'closed_loop.py'), '--scenario', str(file), '--out', str(run_dir / 'out')]
        else:
            argv = [str(ROOT / 'scripts' / 'run_campaign.py'), '--campaign', str(file), '--out',
                    str(run_dir / 'out'), '--runs', '1', '--workers', '1']
        code, stderr = _script(argv, timeout)
        key = loaded_case['message'].split(': ')[1] if loaded_case['class'] == 'refused' else ''
        cls = _cli_class(code, stderr, (str(file), key))
        if cls == 'accepted':
            cls = loaded_case['class']  # flown: its class is the loader's (accepted or meaningless)
        out.append({**{k: loaded_case[k] for k in ('file', 'kind', 'mutation', 'path')}, 'kind':
                    f'{case["kind"]} command line', 'class': cls, 'message': stderr.strip()[-300:]})
    return out


# --------------------------------------------------------------------------------------------------
# The table

def table(results):
    """Counts by kind and class, and the bad cases (at most 40 lines)."""
    counts = collections.Counter((r['kind'], r['class']) for r in results)
    kinds = sorted({r['kind'] for r in results})
    classes = ('refused', 'accepted', *BAD)
    lines = ['| what | tried | ' + ' | '.join(classes) + ' |', '|---|---|' + '---|' * len(classes)]
    for kind in kinds:
        row = [counts[kind, c] for c in classes]
        lines.append(f'| {kind} | {sum(row)} | ' + ' | '.join(map(str, row)) + ' |')
    total = [sum(counts[k, c] for k in kinds) for c in classes]
    lines.append(f'| total | {sum(total)} | ' + ' | '.join(map(str, total)) + ' |')
    bad = [r for r in results if r['class'] in BAD]
    for r in bad[:40]:
        lines.append(f'{r["class"]}: {r["file"]} {key_text(r["path"]) if r["kind"] != "command line" else ""} '
                     f'{r["mutation"]} {r.get("case", "")}: {r["message"][:200]}')
    if len(bad) > 40:
        lines.append(f'... and {len(bad) - 40} more')
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--sample', type=int, default=20, help='mutants also run through the scripts (0: none)')
    ap.add_argument('--leaves', type=int, default=0, help='leaves of each file drawn (0: every leaf)')
    ap.add_argument('--jobs', type=int, default=2, help='processes loading the mutants')
    ap.add_argument('--timeout', type=float, default=10.0, help='seconds a load may take before it is a hang')
    ap.add_argument('--cli-timeout', type=float, default=180.0, help='seconds a script may take')
    ap.add_argument('--seed', type=int, default=37, help='of the drawn leaves and sample')
    ap.add_argument('--json', help='write every case and its class here')
    ap.add_argument('--only', help='only the files whose name holds this text')
    args = ap.parse_args(argv)
    rng = random.Random(args.seed)
    cases = []
    pattern = f'*{args.only}*.yaml' if args.only else '*.yaml'
    for path in sorted((ROOT / 'scenarios').glob(pattern)):
        cases += scenario_cases(path, args.timeout, args.leaves, rng)
    for path in sorted((ROOT / 'campaigns').glob(pattern)):
        cases += campaign_case_list(path, args.timeout, args.leaves, rng)
    with tempfile.TemporaryDirectory(prefix='input_mutations_') as directory:
        results = load_all(cases, args.jobs, directory)
        for r, c in zip(results, cases, strict=True):
            if 'case' in c:
                r['case'] = c['case']
        if args.sample:
            results += misuse_results(directory, args.cli_timeout)
            results += command_line_results(cases, results, args.sample, directory, args.cli_timeout, rng)
    print('\n'.join(table(results)))
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 1 if any(r['class'] in BAD for r in results) else 0


if __name__ == '__main__':
    sys.exit(main())
