"""Several chasers in one scenario (DESIGN §10 "Several chasers"; seed 003 Fig 12): the ``chasers:`` list.

A scenario gives either ``chaser:`` (one robot, as always) or ``chasers:``, a list whose every entry is a full
``chaser`` block plus its ``name`` (the ROS namespace of that chaser's topics and nodes: lower case letters,
digits and underscores, starting with a letter) and optionally its own ``grasp_point_body_m`` (else the target's).
Each chaser is then validated as the single-chaser scenario it sees (``single_chaser_dicts``): the file with
``chaser:`` = its entry and its grasp point, and its own seed: the first chaser keeps the scenario's seed (so its
draws are those of the same file with that chaser alone), chaser i > 0 gets
``SeedSequence([seed, i]).generate_state(1)[0]`` (independent sensor noise and thruster errors).
A problem in an entry names it, e.g. ``chasers[1].mass_kg``.

No ROS and no import of ``flyby_sim.scenario`` (which calls this module): plain dicts in, plain dicts out.
"""

import copy
import re

import numpy as np

from flyby_msgs_py.schema import Invalid, describe

_NAME = re.compile(r'^[a-z][a-z0-9_]*$')
# Keys of a chasers entry beside the chaser block's own.
ENTRY_KEYS = ('name', 'grasp_point_body_m')


def chaser_seed(seed, index):
    """The seed of chaser ``index`` of a scenario with seed ``seed`` (module doc)."""
    if index == 0:
        return seed
    return int(np.random.SeedSequence([int(seed), int(index)]).generate_state(1)[0])


def single_chaser_dicts(data):
    """[(name, the single-chaser mapping that chaser sees, its index)] of a scenario mapping with ``chasers:``;
    raises Invalid naming the key."""
    if 'chaser' in data:
        raise Invalid('chasers', 'give either chaser (one robot) or chasers (several), not both')
    entries = data['chasers']
    if not isinstance(entries, list) or len(entries) < 2:
        raise Invalid('chasers', f'must be a list of at least two chasers (one robot: chaser), got {describe(entries)}')
    out, seen = [], {}
    for i, entry in enumerate(entries):
        key = f'chasers[{i}]'
        if not isinstance(entry, dict):
            raise Invalid(key, f'must be a mapping (a chaser block with its name), got {describe(entry)}')
        name = entry.get('name')
        if not isinstance(name, str) or not _NAME.match(name):
            raise Invalid(f'{key}.name', 'must be a namespace token (lower case letters, digits, underscores, '
                                         f'starting with a letter), got {describe(name)}')
        if name in seen:
            raise Invalid(f'{key}.name', f'duplicate chaser name {name!r} (also at index {seen[name]})')
        seen[name] = i
        single = {k: copy.deepcopy(v) for k, v in data.items() if k != 'chasers'}
        single['chaser'] = {k: copy.deepcopy(v) for k, v in entry.items() if k not in ENTRY_KEYS}
        if entry.get('grasp_point_body_m') is not None:
            target = single.get('target')
            if isinstance(target, dict):
                single['target'] = dict(target, grasp_point_body_m=copy.deepcopy(entry['grasp_point_body_m']))
        out.append((name, single, i))
    return out


def entry_key(key, index, data):
    """The key of a single-chaser scenario's problem as the ``chasers:`` file spells it."""
    prefix = f'chasers[{index}]'
    if key == 'chaser' or key.startswith('chaser.'):
        return prefix + key[len('chaser'):]
    grasp = 'target.grasp_point_body_m'
    if key.startswith(grasp) and key[len(grasp):] in ('', *(f'[{j}]' for j in range(3))) \
            and data['chasers'][index].get('grasp_point_body_m') is not None:
        return f'{prefix}.grasp_point_body_m' + key[len(grasp):]
    return key
