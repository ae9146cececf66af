"""Validation of the values going into a message (plain floats, no per-call array allocation on the hot path):
each raises ValueError naming the field."""

import math

import numpy as np

_QUAT_NORM_TOL = 1e-3  # |q| farther from 1 than this is a bug, not round-off: rejected

_NUMBER_TYPES = (float, int, np.floating, np.integer)

_BOOL_TYPES = (bool, np.bool_)


def _describe(v):
    if isinstance(v, np.ndarray):
        return f'an array of shape {v.shape}'
    if isinstance(v, (list, tuple)):
        return f'a {type(v).__name__} of length {len(v)}'
    return f'{type(v).__name__} {v!r}'


def _scalar(x, field):
    """x as a finite Python float, or ValueError naming the field."""
    if type(x) is not float:
        if not isinstance(x, _NUMBER_TYPES) or isinstance(x, _BOOL_TYPES):
            raise ValueError(f'{field}: must be a number, got {_describe(x)}')
        x = float(x)
    if not math.isfinite(x):
        raise ValueError(f'{field}: must be finite, got {x!r}')
    return x


def _seq(v, n, field):
    """The n elements of a vector-like v (list, tuple or shape-(n,) numeric array)."""
    if isinstance(v, np.ndarray):
        if v.shape != (n,) or v.dtype.kind not in 'fiu':
            raise ValueError(f'{field}: must be a numeric array of shape ({n},), got '
                             f'{"shape " + str(v.shape) if v.shape != (n,) else "dtype " + str(v.dtype)}')
        return v.tolist()
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise ValueError(f'{field}: must be a sequence of {n} numbers, got {_describe(v)}')
    return v


def _vec3(v, field):
    x, y, z = _seq(v, 3, field)
    if type(x) is not float or type(y) is not float or type(z) is not float:
        x, y, z = _scalar(x, field + '[0]'), _scalar(y, field + '[1]'), _scalar(z, field + '[2]')
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise ValueError(f'{field}: must be finite, got [{x!r}, {y!r}, {z!r}]')
    return x, y, z


def _quat(q, field):
    x, y, z, w = _seq(q, 4, field)
    x, y, z, w = (_scalar(x, field + '[0]'), _scalar(y, field + '[1]'), _scalar(z, field + '[2]'),
                  _scalar(w, field + '[3]'))
    n2 = x * x + y * y + z * z + w * w
    if abs(n2 - 1.0) > 1e-12:
        n = math.sqrt(n2)
        if abs(n - 1.0) > _QUAT_NORM_TOL:
            raise ValueError(f'{field}: must be a unit quaternion (x, y, z, w), got norm {n!r}')
        x, y, z, w = x / n, y / n, z / n, w / n
    return x, y, z, w


def _covariance(c, n, field):
    """A finite n x n (or flat n^2) numeric covariance as a flat array, or ValueError naming the field."""
    try:
        a = np.asarray(c, dtype=float) if not isinstance(c, np.ndarray) else c
    except (TypeError, ValueError):
        raise ValueError(f'{field}: must be a {n}x{n} (or flat {n * n}) numeric covariance') from None
    if a.shape not in ((n, n), (n * n,)) or a.dtype.kind not in 'fiu':
        raise ValueError(f'{field}: must be a {n}x{n} (or flat {n * n}) numeric covariance, got shape {a.shape}')
    if not np.isfinite(a).all():
        raise ValueError(f'{field}: must be finite')
    return a.reshape(n * n)


def _frame(frame_id, field='frame_id'):
    if type(frame_id) is not str or not frame_id:
        raise ValueError(f'{field}: must be a non-empty string, got {frame_id!r}')
    return frame_id


def _array(v, cols, field):
    """A finite (N, cols) float array (N >= 0) from v; a fresh copy."""
    try:
        a = np.array(v, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f'{field}: must be an (N, {cols}) numeric array') from None
    if a.ndim != 2 or a.shape[1] != cols:
        if not (a.size == 0 and cols):
            raise ValueError(f'{field}: must have shape (N, {cols}), got {a.shape}')
        a = a.reshape(0, cols)
    if not np.isfinite(a).all():
        raise ValueError(f'{field}: must be finite')
    return a


def _set_xyz(obj, xyz):
    obj.x, obj.y, obj.z = xyz


def _set_xyzw(obj, xyzw):
    obj.x, obj.y, obj.z, obj.w = xyzw
