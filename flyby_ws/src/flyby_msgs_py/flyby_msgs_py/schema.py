"""A declarative schema for YAML configuration files: validation, strict loading, a read-only view, docs.

A schema is a tree of ``Section`` (a mapping of keys), ``ListOf`` (a non-empty list of mappings) and
``Field`` (one leaf: kind, default or REQUIRED, range text, one-line description). A Section or ListOf
marked ``optional`` may be left out (or written as null): it then resolves to None, and the code that
reads it supplies what its absence means. The engine knows
no particular key; the flyby scenario schema that uses it is ``flyby_sim.scenario.SCHEMA``.

    data = load_yaml_mapping('scenarios/x.yaml')   # strict YAML, one-line ScenarioError on any problem
    resolved = validate(SCHEMA, data)               # defaults filled in, or Invalid(key, problem)
    view = Namespace(resolved, SCHEMA)              # view.chaser.mass_kg, read-only
    schema_markdown(SCHEMA)                         # the key table of a docs page

Every problem of a file is a ``ScenarioError`` (a ``ValueError``) whose message is one line naming
the file, the dotted key path and the problem, e.g. ``scenarios/x.yaml: chaser.mass_kg: must be > 0,
got -5.0``. The unit of a key comes from its name's suffix (STYLE.md: units live in the names).
"""

import copy
import dataclasses
import difflib
import math
import re
from pathlib import Path

import numpy as np
import yaml


class ScenarioError(ValueError):
    """An invalid scenario. ``str(err)`` is one line: ``<file>: <key.path>: <problem>``.

    Attributes: ``file`` (as given), ``key`` (dotted path, '' for file-level problems), ``problem``.
    """

    def __init__(self, file, key, problem):
        self.file = str(file)
        self.key = key
        self.problem = problem
        super().__init__(f'{self.file}: {key}: {problem}' if key else f'{self.file}: {problem}')


class Invalid(Exception):
    """A validation problem at a dotted key path, before the file name is known; the loader turns it
    into ScenarioError. Raised by ``validate`` and by checks across keys."""

    def __init__(self, key, problem):
        super().__init__(key, problem)
        self.key = key
        self.problem = problem


# --------------------------------------------------------------------------------------------------
# Schema building blocks

class _Marker:
    def __init__(self, name):
        self._name = name

    def __repr__(self):
        return self._name


REQUIRED = _Marker('REQUIRED')


@dataclasses.dataclass(frozen=True)
class Range:
    """A numeric interval written as text: '> 0', '>= 0', '<= 5', '(0, 1000]', '[0, 0.5]'."""

    text: str
    lo: float = -math.inf
    hi: float = math.inf
    lo_closed: bool = False
    hi_closed: bool = False

    @classmethod
    def parse(cls, text):
        t = text.strip()
        m = re.fullmatch(r'(>=|>|<=|<)\s*(\S+)', t)
        if m:
            op, x = m.group(1), float(m.group(2))
            if op[0] == '>':
                return cls(t, lo=x, lo_closed=op == '>=')
            return cls(t, hi=x, hi_closed=op == '<=')
        m = re.fullmatch(r'([\[(])\s*([^,\s]+)\s*,\s*([^\])\s]+)\s*([\])])', t)
        if not m:
            raise ValueError(f'bad range text {text!r}')
        return cls(t, lo=float(m.group(2)), hi=float(m.group(3)),
                   lo_closed=m.group(1) == '[', hi_closed=m.group(4) == ']')

    def contains(self, x):
        lo_ok = x >= self.lo if self.lo_closed else x > self.lo
        hi_ok = x <= self.hi if self.hi_closed else x < self.hi
        return lo_ok and hi_ok

    def describe(self):
        return self.text if self.text[0] in '<>' else f'in {self.text}'


# Field kinds. VEC3_LIST: a non-empty list of 3-vectors (e.g. N wheel axes); FLOAT_LIST: a non-empty list
# of numbers (e.g. one value per wheel).
FLOAT, INT, STR, BOOL, VEC3, QUAT, MAT3, ENUM, VEC3_LIST, FLOAT_LIST = (
    'float', 'int', 'str', 'bool', '3-vector', 'quaternion', '3x3 matrix', 'enum', 'list of 3-vectors',
    'list of numbers')
KINDS = (FLOAT, INT, STR, BOOL, VEC3, QUAT, MAT3, ENUM, VEC3_LIST, FLOAT_LIST)

# Units derived from the key's suffix (units live in the names, STYLE.md); longest suffix first.
_UNIT_SUFFIXES = (
    ('_n_m_s_per_rad', 'N m s/rad'), ('_n_m_per_rad', 'N m/rad'), ('_n_s_per_m', 'N s/m'), ('_n_per_m', 'N/m'),
    ('_kg_m2_s', 'kg m^2/s'), ('_per_s', '1/s'), ('_rad_s_sqrt_s', 'rad/s/sqrt(s)'), ('_m3_s2', 'm^3/s^2'),
    ('_n_m_s', 'N m s'), ('_kg_m2', 'kg m^2'),
    ('_deg_s', 'deg/s'), ('_rad_s', 'rad/s'), ('_mps2', 'm/s^2'), ('_n_m', 'N m'), ('_mps', 'm/s'),
    ('_deg', 'deg'), ('_rad', 'rad'), ('_kg', 'kg'), ('_hz', 'Hz'),
    ('_ns', 'N s'), ('_n', 'N'), ('_s', 's'), ('_m', 'm'),
)


def _unit_of(name):
    for suffix, unit in _UNIT_SUFFIXES:
        if name.endswith(suffix):
            return unit
    return ''


@dataclasses.dataclass(frozen=True)
class Field:
    """One leaf key. ``range`` applies to every component of a vector; ``check(value)`` returns a
    problem string or None (for constraints a range cannot say); ``why`` is appended to a range
    violation message."""

    kind: str
    default: object = REQUIRED
    range: str = None
    desc: str = ''
    choices: tuple = ()
    check: object = None
    why: str = ''

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f'Field kind {self.kind!r} is not one of {list(KINDS)}')
        object.__setattr__(self, '_range', Range.parse(self.range) if self.range is not None else None)


@dataclasses.dataclass(frozen=True)
class Section:
    """A mapping of keys. Each tuple in ``one_of`` names keys of which exactly one must be given;
    those keys are neither required nor defaulted individually. ``optional``: the whole section may be
    left out (or null) and then resolves to None (its one_of and required keys apply only when given)."""

    fields: dict
    desc: str = ''
    one_of: tuple = ()
    optional: bool = False

    @property
    def alternatives(self):
        return {k for group in self.one_of for k in group}

    @property
    def required(self):
        if self.optional:
            return False
        if self.one_of:
            return True
        alt = self.alternatives
        return any(_is_required(node) for k, node in self.fields.items() if k not in alt)


@dataclasses.dataclass(frozen=True)
class ListOf:
    """A non-empty list of mappings (``item``); ``check(list)`` returns (index, key, problem) or None.
    ``optional``: the list may be left out (or null) and then resolves to None."""

    item: Section
    desc: str = ''
    min_len: int = 1
    check: object = None
    optional: bool = False


def _is_required(node):
    if isinstance(node, Field):
        return node.default is REQUIRED
    if isinstance(node, Section):
        return node.required
    return not node.optional  # ListOf


# --------------------------------------------------------------------------------------------------
# Messages and checks that any schema may use

def describe(v):
    """How a value reads in an error message: 'null', "string 'x'", 'a list of length 2', ..."""
    if v is None:
        return 'null'
    if isinstance(v, (bool, np.bool_)):
        return 'true (bool)' if v else 'false (bool)'
    if isinstance(v, str):
        return f'string {v!r}'
    if isinstance(v, dict):
        return 'a mapping'
    if isinstance(v, (list, tuple)):
        return f'a list of length {len(v)}'
    if isinstance(v, np.ndarray):
        return f'an array of shape {v.shape}'
    return repr(v)


def format_floats(a):
    """'[1.0, 2.5]' for the numbers of a."""
    return '[' + ', '.join(repr(float(x)) for x in a) + ']'


def check_nonzero(v):
    """Field check: a vector or quaternion with a nonzero component."""
    if not any(v):
        return 'must be nonzero, got [0.0, 0.0, 0.0]' if len(v) == 3 else f'must be nonzero, got {v}'
    return None


def check_nonempty(s):
    """Field check: a string that is not blank."""
    return 'must not be empty' if not s.strip() else None


# --------------------------------------------------------------------------------------------------
# Validation

def _is_number(v):
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _number(v, key, field):
    if not _is_number(v):
        raise Invalid(key, f'must be a number, got {describe(v)}')
    x = float(v)
    if not math.isfinite(x):
        raise Invalid(key, f'must be finite, got {x!r}')
    r = field._range
    if r is not None and not r.contains(x):
        why = f' ({field.why})' if field.why else ''
        raise Invalid(key, f'must be {r.describe()}, got {x!r}{why}')
    return x


def _sequence(v):
    if isinstance(v, np.ndarray):
        return v.tolist() if v.ndim >= 1 else None
    return list(v) if isinstance(v, (list, tuple)) else None


def _vector(v, n, key, field, what):
    seq = _sequence(v)
    if seq is None:
        raise Invalid(key, f'must be {what}, got {describe(v)}')
    if len(seq) != n:
        raise Invalid(key, f'must be {what}, got a list of length {len(seq)}')
    return [_number(x, f'{key}[{i}]', field) for i, x in enumerate(seq)]


def validate_field(field, v, key):
    """The value of one leaf key, converted to its kind (int -> float where a float is expected),
    or Invalid(key, problem)."""
    kind = field.kind
    if kind == FLOAT:
        out = _number(v, key, field)
    elif kind == INT:
        if not isinstance(v, (int, np.integer)) or isinstance(v, (bool, np.bool_)):
            raise Invalid(key, f'must be an integer, got {describe(v)}')
        out = int(v)
        r = field._range
        if r is not None and not r.contains(out):
            raise Invalid(key, f'must be {r.describe()}, got {out}')
    elif kind == STR:
        if not isinstance(v, str):
            raise Invalid(key, f'must be a string, got {describe(v)}')
        out = v
    elif kind == BOOL:
        if not isinstance(v, (bool, np.bool_)):
            raise Invalid(key, f'must be true or false, got {describe(v)}')
        out = bool(v)
    elif kind == ENUM:
        if v not in field.choices or not isinstance(v, str):
            choices = '[' + ', '.join(repr(c) for c in field.choices) + ']'
            raise Invalid(key, f'must be one of {choices}, got {v!r}')
        out = v
    elif kind == VEC3:
        out = _vector(v, 3, key, field, 'a 3-vector [x, y, z]')
    elif kind == QUAT:
        out = _vector(v, 4, key, field, 'a quaternion [x, y, z, w]')
    elif kind == VEC3_LIST:
        rows = _sequence(v)
        what = 'a non-empty list of 3-vectors [[x, y, z], ...]'
        if not rows:
            raise Invalid(key, f'must be {what}, got {describe(v)}')
        out = [_vector(row, 3, f'{key}[{i}]', field, 'a 3-vector [x, y, z]') for i, row in enumerate(rows)]
    elif kind == FLOAT_LIST:
        seq = _sequence(v)
        if not seq:
            raise Invalid(key, f'must be a non-empty list of numbers, got {describe(v)}')
        out = [_number(x, f'{key}[{i}]', field) for i, x in enumerate(seq)]
    else:  # MAT3 (Field checks its kind)
        rows = _sequence(v)
        what = 'a 3x3 matrix (a list of 3 rows of 3 numbers)'
        if rows is None or len(rows) != 3:
            raise Invalid(key, f'must be {what}, got {describe(v)}')
        out = [_vector(row, 3, f'{key}[{i}]', field, 'a row of 3 numbers') for i, row in enumerate(rows)]
    if field.check is not None:
        problem = field.check(out)
        if problem:
            raise Invalid(key, problem)
    return out


def _join(prefix, key):
    return f'{prefix}.{key}' if prefix else key


def _section(section, v, prefix):
    if v is None and prefix:
        v = {}  # a section whose keys are all commented out
    if not isinstance(v, dict):
        if not prefix:
            raise Invalid('', f'top level must be a mapping of sections, got {describe(v)}')
        raise Invalid(prefix, f'must be a mapping, got {describe(v)}')
    allowed = list(section.fields)
    for k in v:
        if not isinstance(k, str) or k not in section.fields:
            hint = difflib.get_close_matches(str(k), allowed, n=1, cutoff=0.6)
            msg = f"unknown key (did you mean '{hint[0]}'?)" if hint else \
                f'unknown key (expected one of: {", ".join(allowed)})'
            raise Invalid(_join(prefix, str(k)), msg)
    for group in section.one_of:
        given = [k for k in group if k in v]
        if len(given) != 1:
            names = ', '.join(repr(k) for k in group)
            got = 'none' if not given else ', '.join(repr(k) for k in given)
            raise Invalid(prefix, f'exactly one of {names} must be given, got {got}')
    alternatives = section.alternatives
    out = {}
    for k, node in section.fields.items():
        key = _join(prefix, k)
        if k not in v:
            if k in alternatives:
                continue
            if getattr(node, 'optional', False):
                out[k] = None
                continue
            if isinstance(node, Section) and not node.required:
                out[k] = _section(node, {}, key)
                continue
            if _is_required(node):
                raise Invalid(key, 'missing required key')
            out[k] = _plain(node.default)
            continue
        out[k] = _node(node, v[k], key)
    return out


def _plain(default):
    """A field's default as a fresh plain value (tuples, nested too, as lists)."""
    if isinstance(default, tuple):
        return [_plain(x) for x in default]
    return copy.deepcopy(default)


def _node(node, v, key):
    if v is None and getattr(node, 'optional', False):  # an optional section or list written out as null
        return None
    if isinstance(node, Section):
        return _section(node, v, key)
    if isinstance(node, ListOf):
        if not isinstance(v, (list, tuple)) or len(v) < node.min_len:
            raise Invalid(key, f'must be a non-empty list, got {describe(v)}')
        items = []
        for i, item in enumerate(v):
            if not isinstance(item, dict):
                raise Invalid(f'{key}[{i}]', f'must be a mapping, got {describe(item)}')
            items.append(_section(node.item, item, f'{key}[{i}]'))
        if node.check is not None:
            bad = node.check(items)
            if bad:
                i, k, problem = bad
                raise Invalid(f'{key}[{i}].{k}', problem)
        return items
    if v is None and node.default is None:  # an optional key written out as null
        return None
    return validate_field(node, v, key)


def validate(schema, data):
    """Validate a parsed mapping against the ``schema`` Section; return the resolved dict (plain
    Python, defaults filled in, alternatives not given left out). Raises ``Invalid``."""
    return _section(schema, data, '')


# --------------------------------------------------------------------------------------------------
# YAML

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


# --------------------------------------------------------------------------------------------------
# The read-only view

class Namespace:
    """Read-only attribute view of a resolved ``Section``: ``ns.key``, ``ns['key']``, ``'key' in ns``.

    ``schema`` is the Section the values were validated against; it goes with the view (also through
    pickle) and tells which keys are alternatives. Vectors and matrices are read-only float arrays;
    lists of mappings are tuples of Namespaces; an alternative that was not given (e.g.
    ``orbit.altitude_m`` when ``radius_m`` is) reads as None.
    """

    __slots__ = ('_key', '_values', '_schema')

    def __init__(self, values, schema, key=''):
        object.__setattr__(self, '_key', key)
        object.__setattr__(self, '_schema', schema)
        object.__setattr__(self, '_values', {k: _freeze(v, schema.fields[k], _join(key, k))
                                             for k, v in values.items()})

    def __getattr__(self, name):
        values = object.__getattribute__(self, '_values')
        if name in values:
            return values[name]
        if name in object.__getattribute__(self, '_schema').fields:
            return None  # an alternative that was not given
        where = object.__getattribute__(self, '_key') or 'scenario'
        raise AttributeError(f'{where} has no key {name!r}')

    def __setattr__(self, name, value):
        raise AttributeError('scenario values are read-only')

    def __delattr__(self, name):
        raise AttributeError('scenario values are read-only')

    def __getitem__(self, name):
        return self._values[name]

    def __contains__(self, name):
        return name in self._values

    def __iter__(self):
        return iter(self._values)

    def keys(self):
        return self._values.keys()

    def to_dict(self):
        return {k: _thaw(v) for k, v in self._values.items()}

    def __eq__(self, other):
        return isinstance(other, Namespace) and self.to_dict() == other.to_dict()

    def __reduce__(self):  # pickle / deepcopy (Monte Carlo workers)
        return Namespace, (self.to_dict(), self._schema, self._key)

    __hash__ = None

    def __repr__(self):
        return f'Namespace({self._key or "scenario"}: {", ".join(self._values)})'


def _freeze(v, node, key):
    """A resolved value as the view holds it: node is its schema node."""
    if v is None:
        return None  # an optional value left out
    if isinstance(node, Section):
        return Namespace(v, node, key)
    if isinstance(node, ListOf):
        return tuple(Namespace(x, node.item, f'{key}[{i}]') for i, x in enumerate(v))
    if isinstance(v, list):
        a = np.array(v, dtype=float)
        a.flags.writeable = False
        return a
    return v


def _thaw(v):
    if isinstance(v, Namespace):
        return v.to_dict()
    if isinstance(v, tuple):
        return [_thaw(x) for x in v]
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


# --------------------------------------------------------------------------------------------------
# Documentation from the schema

def _fmt_default(node, alternative):
    if alternative:
        return 'one of'
    if isinstance(node, Field):
        d = node.default
        if d is REQUIRED:
            return '**required**'
        if isinstance(d, tuple) and d and isinstance(d[0], tuple):
            return '[' + ', '.join('[' + ', '.join(f'{x:g}' for x in row) + ']' for row in d) + ']'
        if isinstance(d, tuple):
            return '[' + ', '.join(f'{x:g}' for x in d) + ']'
        if isinstance(d, str):
            return f"'{d}'"
        return f'{d:.10g}' if isinstance(d, float) else str(d)
    if getattr(node, 'optional', False):
        return '(optional)'
    return '**required**' if _is_required(node) else '(defaults)'


def _fmt_type(node):
    if isinstance(node, ListOf):
        return 'list of mappings'
    if isinstance(node, Section):
        return 'mapping'
    if node.kind == ENUM:
        return ' \\| '.join(f"'{c}'" for c in node.choices)
    return node.kind


def _schema_rows(section, prefix):
    alt = section.alternatives
    for k, node in section.fields.items():
        key = _join(prefix, k)
        if isinstance(node, Field):
            rng = node._range.describe() if node._range is not None else ''
            if node.kind in (VEC3, QUAT, MAT3, VEC3_LIST, FLOAT_LIST) and not rng:
                rng = 'finite'
            elif node.kind in (VEC3, QUAT, VEC3_LIST, FLOAT_LIST) and rng:
                rng = f'each {rng}'
            yield key, _fmt_type(node), _unit_of(k), _fmt_default(node, k in alt), rng, node.desc
        else:
            note = ''
            if isinstance(node, Section) and node.one_of:
                note = ' Exactly one of ' + '; '.join(', '.join(f'`{x}`' for x in g) for g in node.one_of) + '.'
            yield key, _fmt_type(node), '', _fmt_default(node, k in alt), \
                'non-empty' if isinstance(node, ListOf) else '', node.desc + '.' + note
            inner = node.item if isinstance(node, ListOf) else node
            yield from _schema_rows(inner, f'{key}[]' if isinstance(node, ListOf) else key)


def schema_markdown(schema):
    """A markdown table of every key of ``schema``: key, type, unit, default, range, meaning."""
    lines = ['| key | type | unit | default | range | meaning |', '|---|---|---|---|---|---|']
    for key, kind, unit, default, rng, desc in _schema_rows(schema, ''):
        lines.append(f'| `{key}` | {kind} | {unit} | {default} | {rng} | {desc} |')
    return '\n'.join(lines) + '\n'
