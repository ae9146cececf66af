"""Validation of configuration numbers, shared by the plant, thruster and filter configurations."""

import math
import numbers


def require_positive(name, value, allow_zero=False, allow_inf=False):
    """Raise ValueError naming ``name`` unless ``value`` is a finite real > 0 (>= 0 with allow_zero;
    +inf also accepted with allow_inf, meaning "no limit")."""
    ok = (isinstance(value, numbers.Real) and not isinstance(value, bool) and not math.isnan(value)
          and (math.isfinite(value) or (allow_inf and value > 0.0))
          and (value >= 0.0 if allow_zero else value > 0.0))
    if not ok:
        finite = '' if allow_inf else 'finite and '
        raise ValueError(f'{name} must be {finite}{">=" if allow_zero else ">"} 0, got {value!r}')


def finite_vector(name, value, size):
    """``value`` as a tuple of ``size`` finite Python floats, or ValueError naming ``name``."""
    try:
        v = tuple(float(c) for c in value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f'{name} must be {size} numbers, got {value!r}') from exc
    if len(v) != size or not all(math.isfinite(c) for c in v):
        raise ValueError(f'{name} must be {size} finite numbers, got {value!r}')
    return v
