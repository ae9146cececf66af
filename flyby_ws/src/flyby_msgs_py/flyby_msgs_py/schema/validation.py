"""Validation of data against a schema: defaults filled in, or ``Invalid`` naming the dotted key."""

import copy
import difflib
import math

import numpy as np

from flyby_msgs_py.schema.blocks import (
    BOOL,
    ENUM,
    FLOAT,
    FLOAT_LIST,
    INT,
    QUAT,
    STR,
    VEC3,
    VEC3_LIST,
    Invalid,
    ListOf,
    Section,
    _is_required,
    describe,
    short_repr,
)


def _is_number(v):
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


# Every number's magnitude is at most the upper bound, and that of one whose range excludes 0 ('> 0') at least the
# lower: every quantity of a configuration is within 30 orders of magnitude of its SI unit (the Earth's mass is 6e24 kg,
# a gyro's noise 1e-5 rad/s), and beyond it a square or a product of a few of them over- or underflows a double: 1e300
# is no longer finite once squared, and 1e-300 no longer above 0.
MAGNITUDE_RANGE = (1e-30, 1e30)


def _number(v, key, field):
    if not _is_number(v):
        raise Invalid(key, f'must be a number, got {describe(v)}')
    try:
        x = float(v)
    except OverflowError:  # an integer beyond a double
        raise Invalid(key, f'must be finite, got {short_repr(v)}') from None
    if not math.isfinite(x):
        raise Invalid(key, f'must be finite, got {x!r}')
    r = field._range
    if r is not None and not r.contains(x):
        why = f' ({field.why})' if field.why else ''
        raise Invalid(key, f'must be {r.describe()}, got {x!r}{why}')
    lo, hi = MAGNITUDE_RANGE
    if abs(x) > hi:
        raise Invalid(key, f'must be at most {hi:g} in magnitude (its square or a product would overflow), got {x!r}')
    if abs(x) < lo and r is not None and not r.contains(0.0):
        raise Invalid(key, f'must be at least {lo:g} (it must be {r.describe()}, and a smaller value is 0 in a square '
                           f'or a product), got {x!r}')
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
            why = f' ({field.why})' if field.why else ''
            raise Invalid(key, f'must be {r.describe()}, got {short_repr(out)}{why}')
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
            raise Invalid(key, f'must be one of {choices}, got {short_repr(v)}')
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
