"""The one check of a numeric parameter, shared by the controllers, the agents and the tasks."""

import math
import numbers

import numpy as np


def positive(name, value, integer=False, allow_zero=False):
    """`value` as a float (an int with integer=True), or a ValueError naming `name` when it is
    not a finite number > 0 (>= 0 with allow_zero=True)."""
    ok_type = isinstance(value, numbers.Integral) if integer else isinstance(value, numbers.Real)
    if isinstance(value, bool) or not ok_type or not math.isfinite(value):
        kind = "an integer" if integer else "a finite number"
        raise ValueError(f"{name} must be {kind}; got {value!r}")
    if value < 0 or (value == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be {bound}; got {value!r}")
    return int(value) if integer else float(value)


def finite(name, value):
    """`value` as a float, or a ValueError naming `name` when it is not a finite number."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number; got {value!r}")
    return float(value)


def floats(name, value):
    """`value` as a float64 array, or a ValueError naming `name` when it holds no numbers."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must hold numbers; got {value!r}") from None
