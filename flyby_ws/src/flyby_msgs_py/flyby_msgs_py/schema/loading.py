"""Strict YAML: duplicate keys are errors, YAML 1.2 floats without a dot; every problem a one-line
``ScenarioError``."""

import re
from pathlib import Path

import yaml

from flyby_msgs_py.schema.blocks import ScenarioError, describe


class _Loader(yaml.SafeLoader):
    """SafeLoader that rejects duplicate keys and reads YAML 1.2 floats without a dot (``1e5``)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            self.flatten_mapping(node)
            seen = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                try:
                    duplicate = key in seen
                    seen.add(key)
                except TypeError:
                    continue  # unhashable key: the base class reports it
                if duplicate:
                    raise yaml.constructor.ConstructorError(
                        None, None, f'duplicate key {key!r}', key_node.start_mark)
        return super().construct_mapping(node, deep=deep)


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _Loader.construct_mapping)
_Loader.add_implicit_resolver(
    'tag:yaml.org,2002:float', re.compile(r'^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$'),
    list('-+0123456789'))


def _parse_yaml(text, file):
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader subclass
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f' at line {mark.line + 1}, column {mark.column + 1}' if mark else ''
        problem = str(e.problem or e.context)
        if e.context and e.problem:
            cm = e.context_mark
            started = f' that starts at line {cm.line + 1}, column {cm.column + 1}' \
                if cm is not None and cm is not mark and cm.line != mark.line else ''
            problem += f' ({e.context}{started})'
        kind = 'YAML error' if isinstance(e, yaml.constructor.ConstructorError) else 'YAML syntax error'
        raise ScenarioError(file, '', f'{kind}{where}: {problem}') from None
    except yaml.YAMLError as e:
        raise ScenarioError(file, '', f'YAML error: {" ".join(str(e).split())}') from None


def load_yaml_mapping(path):
    """The top-level mapping of a YAML file, read strictly (duplicate keys are errors).

    Raises ScenarioError with a one-line message ``<path>: <problem>`` (unreadable file, YAML error
    with its line and column, top level not a mapping).
    """
    file = str(path)
    try:
        text = Path(path).read_text(encoding='utf-8')
    except FileNotFoundError:
        raise ScenarioError(file, '', 'file not found') from None
    except IsADirectoryError:
        raise ScenarioError(file, '', 'is a directory, not a scenario file') from None
    except UnicodeDecodeError as e:
        raise ScenarioError(file, '', f'not UTF-8 text ({e.reason} at byte {e.start})') from None
    except OSError as e:
        raise ScenarioError(file, '', f'cannot read: {e.strerror}') from None
    data = _parse_yaml(text, file)
    if not isinstance(data, dict):
        got = 'an empty file' if data is None else describe(data)
        raise ScenarioError(file, '', f'top level must be a mapping of sections, got {got}')
    return data
