"""The schema's errors, building blocks (Field, Section, ListOf, kinds, ranges, units) and the messages and
checks any schema may use."""

import dataclasses
import math
import re
import reprlib

import numpy as np


class ScenarioError(ValueError):
    """An invalid scenario. ``str(err)`` is one line: ``<file>: <key.path>: <problem>``.

    Attributes: ``file`` (as given), ``key`` (dotted path, '' for file-level problems), ``problem``.
    """

    def __init__(self, file, key, problem):
        self.file = str(file)
        self.key = key
        self.problem = problem
        super().__init__(f'{self.file}: {key}: {problem}' if key else f'{self.file}: {problem}')

    def __reduce__(self):
        """Rebuilt from (file, key, problem), so the error crosses a process pool to the parent."""
        return type(self), (self.file, self.key, self.problem)


class Invalid(Exception):
    """A validation problem at a dotted key path, before the file name is known; the loader turns it
    into ScenarioError. Raised by ``validate`` and by checks across keys."""

    def __init__(self, key, problem):
        super().__init__(key, problem)
        self.key = key
        self.problem = problem

    def __reduce__(self):
        """Rebuilt from (key, problem), so the problem crosses a process pool to the parent."""
        return type(self), (self.key, self.problem)


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
    ('_n_s', 'N s'), ('_ns', 'N s'), ('_n', 'N'), ('_s', 's'), ('_m', 'm'),
)


def unit_of(name):
    """The unit of a key from its name's suffix ('s' for duration_s, '' for none)."""
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
        return f'string {short_repr(v)}'
    if isinstance(v, dict):
        return 'a mapping'
    if isinstance(v, (list, tuple)):
        return f'a list of length {len(v)}'
    if isinstance(v, np.ndarray):
        return f'an array of shape {v.shape}'
    return short_repr(v)


SHORT_REPR_CHARS = 80
_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxstring = 4, SHORT_REPR_CHARS
_SHORT.maxtuple = _SHORT.maxlist = _SHORT.maxdict = _SHORT.maxset = 10
_SHORT.maxother = _SHORT.maxlong = SHORT_REPR_CHARS


def short_repr(v):
    """repr(v) for an error message, at most SHORT_REPR_CHARS characters ('...' where cut): a value that
    aliases expanded, or a long string, never grows a message (nor the time to format it) beyond a line."""
    text = _SHORT.repr(v)
    return text if len(text) <= SHORT_REPR_CHARS else text[:SHORT_REPR_CHARS - 3] + '...'


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

