"""Validation of configuration numbers, shared by the plant, thruster and filter configurations."""

import math
import numbers


def require_positive(name, value, allow_zero=False):
    """Raise ValueError naming ``name`` unless ``value`` is a finite real > 0 (>= 0 with allow_zero)."""
    ok = (isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
          and (value >= 0.0 if allow_zero else value > 0.0))
    if not ok:
        raise ValueError(f'{name} must be finite and {">=" if allow_zero else ">"} 0, got {value!r}')
