"""The scenario entry points: validate a mapping or a YAML file into a Scenario, a node's scenario, the schema
table of docs/scenario.md and ``python -m flyby_sim.scenario``."""

import copy

from flyby_msgs_py import schema
from flyby_msgs_py.schema import Invalid, ScenarioError, load_yaml_mapping, validate, validate_field
from flyby_sim import chasers
from flyby_sim.scenario.checks import cross_checks
from flyby_sim.scenario.plausibility import check_grasp_point, plausible_dict, plausible_view
from flyby_sim.scenario.schema import SCHEMA
from flyby_sim.scenario.view import Scenario


def _resolve(data, seed):
    """The resolved dict of a scenario mapping (defaults filled in, ``seed`` overriding the file's),
    checked across keys and for physical plausibility (before any derived quantity); raises Invalid."""
    resolved = validate(SCHEMA, data)
    if seed is not None:
        try:
            resolved['seed'] = validate_field(SCHEMA.fields['seed'], seed, 'seed')
        except Invalid as e:
            raise Invalid('seed', f'{e.problem} (from the seed argument)') from None
    plausible_dict(resolved)
    cross_checks(resolved)
    return resolved


def _view(resolved, raw, path):
    """The Scenario of a resolved dict, checked for what needs its derived initial state; raises Invalid."""
    view = Scenario(resolved, raw, path)
    plausible_view(view)
    return view



def scenario_from_dict(data, name='<dict>', seed=None, path=None):
    """Validate a scenario mapping (as parsed from YAML) into a Scenario; ``name`` labels errors.

    With ``chasers:`` (several robots, flyby_sim.chasers) the result is the first chaser's view; every chaser's
    view is ``for_chaser(name)``."""
    if isinstance(data, dict) and 'chasers' in data:
        return _fleet_from_dict(data, name, seed, path)
    try:
        return _view(_resolve(data, seed), copy.deepcopy(data), path)
    except Invalid as e:
        raise ScenarioError(name, e.key, e.problem) from None


def _fleet_from_dict(data, name, seed, path):
    """The views of a ``chasers:`` scenario (flyby_sim.chasers), each a single-chaser Scenario; the first."""
    try:
        singles = chasers.single_chaser_dicts(data)
    except Invalid as e:
        raise ScenarioError(name, e.key, e.problem) from None
    views = []
    for chaser_name, single, i in singles:
        try:
            base = _resolve(single, seed)
            base_seed = base['seed']
            view = _view(_resolve(single, chasers.chaser_seed(base_seed, i)), single, path)
        except Invalid as e:
            raise ScenarioError(name, chasers.entry_key(e.key, i, data), e.problem) from None
        views.append((chaser_name, view))
    try:
        _check_shared_grasp_point(data, base)
    except Invalid as e:
        raise ScenarioError(name, e.key, e.problem) from None
    fleet = tuple(views)
    for chaser_name, view in fleet:
        object.__setattr__(view, '_fleet', fleet)
        object.__setattr__(view, 'chaser_name', chaser_name)
    return fleet[0][1]


def _check_shared_grasp_point(data, resolved):
    """The top-level target.grasp_point_body_m of a ``chasers:`` file (that of a chaser without its own), checked
    as in a single-chaser file even when every chaser gives its own (never read, but never meaningless either);
    ``resolved`` any chaser's resolved dict (the target is the same); raises Invalid."""
    key = 'target.grasp_point_body_m'
    if 'grasp_point_body_m' not in data['target']:
        raise Invalid(key, 'is required (the grasp point of a chaser without its own grasp_point_body_m)')
    field = SCHEMA.fields['target'].fields['grasp_point_body_m']
    check_grasp_point(validate_field(field, data['target']['grasp_point_body_m'], key), resolved['target']['geometry'])


def load_scenario(path, seed=None):
    """Load and validate a scenario YAML file; ``seed`` (int >= 0) overrides the file's seed.

    Raises ScenarioError with a one-line message ``<path>: <key.path>: <problem>``.
    """
    return scenario_from_dict(load_yaml_mapping(path), name=str(path), seed=seed, path=path)


def scenario_of(node):
    """Declare the node's ``scenario_file``, ``seed`` and ``chaser`` parameters and load the scenario (seed < 0: the
    file's); with ``chaser`` (a ``chasers:`` scenario) that chaser's view."""
    node.declare_parameter('scenario_file', '')
    node.declare_parameter('seed', -1)
    node.declare_parameter('chaser', '')
    seed = node.get_parameter('seed').value
    path = node.get_parameter('scenario_file').value
    scenario = load_scenario(path, seed=None if seed < 0 else seed)
    chaser = node.get_parameter('chaser').value
    if not chaser:
        return scenario
    try:
        return scenario.for_chaser(chaser)
    except KeyError as err:
        raise ScenarioError(path, 'chasers', f'parameter chaser: {err.args[0]}') from None


def schema_markdown():
    """The key table of docs/scenario.md, rendered from SCHEMA."""
    return schema.schema_markdown(SCHEMA)


def main(argv=None):
    """``python -m flyby_sim.scenario FILE [--seed N]`` prints the resolved scenario or the error;
    ``--schema-markdown`` prints the key table of docs/scenario.md."""
    import argparse
    import sys
    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument('file', nargs='?')
    parser.add_argument('--seed', type=int)
    parser.add_argument('--schema-markdown', action='store_true')
    args = parser.parse_args(argv)
    if args.schema_markdown:
        sys.stdout.write(schema_markdown())
        return 0
    if not args.file:
        parser.error('a scenario file is required')
    try:
        sc = load_scenario(args.file, seed=args.seed)
    except ScenarioError as e:
        print(e, file=sys.stderr)
        return 2
    sys.stdout.write(sc.to_yaml())
    return 0
