"""The read-only view of resolved values: ``Namespace``."""

import numpy as np

from flyby_msgs_py.schema.blocks import ListOf, Section
from flyby_msgs_py.schema.validation import _join


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
