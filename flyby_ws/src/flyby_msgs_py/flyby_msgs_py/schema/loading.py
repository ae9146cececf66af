"""Strict YAML: duplicate keys are errors, YAML 1.2 floats without a dot and booleans (true and false only),
files at most ``MAX_YAML_BYTES`` and aliases (``*name``) expanding to at most ``MAX_ALIAS_NODES`` values (a
"billion laughs" chain of a few KB would otherwise expand to gigabytes in any message or loop that walks it);
every problem a one-line ``ScenarioError``."""

import os
import re
import stat

import yaml

from flyby_msgs_py.schema.blocks import ScenarioError, describe, short_repr

MAX_YAML_BYTES = 1 << 20  # a scenario or campaign file is a few KB; 1 MiB parses in about a second
MAX_ALIAS_NODES = 100_000  # values that aliases may add to a document once expanded


class _ExpansionError(yaml.composer.ComposerError):
    """Aliases that expand a document too far or refer to themselves."""


def _expanded_sizes(root):
    """{id(node): its size with every alias expanded} over the distinct nodes, or None for a recursive alias.

    Aliases share nodes, so the walk memoizes each node's size: linear in the distinct nodes.
    """
    sizes, active = {}, set()

    def size(node):
        if id(node) in sizes:
            return sizes[id(node)]
        if id(node) in active:
            return None
        active.add(id(node))
        children = node.value if isinstance(node.value, list) else ()
        total = 1
        for child in children:
            for part in child if isinstance(child, tuple) else (child,):
                n = size(part)
                if n is None:
                    return None
                total += n
        active.discard(id(node))
        sizes[id(node)] = total
        return total

    return None if size(root) is None else sizes


def _expanding_path(root, sizes):
    """The dotted key path, through mappings, to where an alias chain is used: at each level the last value that
    expands beyond the bound alone (an anchor comes before its aliases), else the one that expands the most."""
    path, node = [], root
    while isinstance(node, yaml.MappingNode) and node.value:
        over = [kv for kv in node.value if sizes[id(kv[1])] > MAX_ALIAS_NODES]
        key, node = over[-1] if over else max(node.value, key=lambda kv: sizes[id(kv[1])])
        text = str(key.value) if isinstance(key, yaml.ScalarNode) else '?'
        path.append(text if len(text) <= 80 else text[:77] + '...')
    return '.'.join(path)


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
                        None, None, f'duplicate key {short_repr(key)}', key_node.start_mark)
        return super().construct_mapping(node, deep=deep)

    def compose_document(self):
        """The document's node graph, refused when its aliases expand it by more than MAX_ALIAS_NODES values
        or refer to themselves (checked before any value is built)."""
        node = super().compose_document()
        if node is not None:
            sizes = _expanded_sizes(node)
            if sizes is None:
                raise _ExpansionError(None, None, 'an alias refers to the value that contains it', None)
            if sizes[id(node)] - len(sizes) > MAX_ALIAS_NODES:
                raise _ExpansionError(None, None, f'aliases (*name) expand the document by more than '
                                                  f'{MAX_ALIAS_NODES} values (at {_expanding_path(node, sizes)})', None)
        return node


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _Loader.construct_mapping)
_Loader.add_implicit_resolver(
    'tag:yaml.org,2002:float', re.compile(r'^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$'),
    list('-+0123456789'))
# YAML 1.2 booleans: true and false only; YAML 1.1's yes, no, on, off, y, n stay strings (a key written
# `both_ways: no` is refused as a string rather than read as a boolean the writer may not have meant).
_BOOL = 'tag:yaml.org,2002:bool'
for _first, _resolvers in _Loader.yaml_implicit_resolvers.items():
    _resolvers[:] = [(tag, regexp) for tag, regexp in _resolvers if tag != _BOOL]
_Loader.add_implicit_resolver(_BOOL, re.compile(r'^(?:true|True|TRUE|false|False|FALSE)$'), list('tTfF'))


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
        semantic = isinstance(e, (yaml.constructor.ConstructorError, _ExpansionError))
        kind = 'YAML error' if semantic else 'YAML syntax error'
        raise ScenarioError(file, '', f'{kind}{where}: {problem}') from None
    except yaml.YAMLError as e:
        raise ScenarioError(file, '', f'YAML error: {" ".join(str(e).split())}') from None
    except RecursionError:
        raise ScenarioError(file, '', 'YAML error: values nested too deeply') from None


def load_yaml_mapping(path):
    """The top-level mapping of a YAML file, read strictly (duplicate keys are errors).

    Raises ScenarioError with a one-line message ``<path>: <problem>`` (unreadable file, larger than
    MAX_YAML_BYTES, YAML error with its line and column, aliases expanding too far, top level not a mapping).
    """
    file = str(path)
    try:
        mode = os.stat(path).st_mode
        if not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):  # a pipe or a device could block or never end
            raise ScenarioError(file, '', 'not a regular file')
        with open(path, 'rb') as f:
            raw = f.read(MAX_YAML_BYTES + 1)
        if len(raw) > MAX_YAML_BYTES:
            size = max(os.stat(path).st_size, len(raw))
            raise ScenarioError(file, '', f'file is {size} bytes, more than the {MAX_YAML_BYTES} bytes (1 MiB) '
                                          f'a scenario or campaign file may hold')
        text = raw.decode('utf-8')
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
