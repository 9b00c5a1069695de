"""Checks of task kwargs: each returns the value or raises one ValueError naming the kwarg."""

import numpy as np


def check_range(name, value, low=None, strict=False):
    """`value` as a pair of floats (lo, hi) with lo <= hi and low <= lo (low < lo if strict),
    else a ValueError naming `name`."""
    try:
        lo, hi = (float(x) for x in value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (low, high), got {value!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise ValueError(f"{name} must be a pair of finite numbers (low, high), got {value!r}")
    below = low is not None and (lo <= low if strict else lo < low)
    if not lo <= hi or below:
        bound = "" if low is None else f"{low} {'<' if strict else '<='} "
        raise ValueError(f"{name} must satisfy {bound}low <= high, got {value!r}")
    return lo, hi


def check_flag(name, value):
    """`value` if it is True or False, else a ValueError naming `name`."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be true or false; got {value!r}")
    return bool(value)
