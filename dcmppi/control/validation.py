"""The checks of parameters shared by the controllers, the agents, the predictors and the tasks:
each returns the value checked or raises one ValueError naming the parameter."""

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


def flag(name, value):
    """`value` as a bool, or a ValueError naming `name` when it is not True or False."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be true or false; got {value!r}")
    return bool(value)


def pair(name, value, low=None, strict=False):
    """`value` as a pair of floats (lo, hi) with lo <= hi and low <= lo (low < lo if strict),
    else a ValueError naming `name`."""
    try:
        lo, hi = (float(x) for x in value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (low, high), got {value!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"{name} must be a pair of finite numbers (low, high), got {value!r}")
    below = low is not None and (lo <= low if strict else lo < low)
    if not lo <= hi or below:
        bound = "" if low is None else f"{low} {'<' if strict else '<='} "
        raise ValueError(f"{name} must satisfy {bound}low <= high, got {value!r}")
    return lo, hi


def array(name, value, shape, finite=False):
    """`value` as a new C-contiguous float64 array of `shape`, or a ValueError naming `name`.

    shape: sizes, or letters for any size ((L, 2): rows of two); finite=True: every entry must
    be finite too (the message names the first index that is not).
    """
    value = np.array(floats(name, value), order="C")
    if value.ndim != len(shape) or any(
        isinstance(s, int) and s != n for s, n in zip(shape, value.shape, strict=True)
    ):
        expected = ", ".join(map(str, shape)) + ("," if len(shape) == 1 else "")
        raise ValueError(f"{name} must have shape ({expected}); got {value.shape}")
    if finite and not np.isfinite(value).all():
        index = tuple(int(i) for i in np.argwhere(~np.isfinite(value))[0])
        raise ValueError(f"{name} must be finite; {name}{list(index)} is {value[index]}")
    return value


def choice(name, value, valid):
    """`value` if it is one of `valid` (names), else a ValueError naming `name` and listing
    the valid names."""
    if not isinstance(value, str) or value not in valid:
        raise ValueError(f"{name} must be one of {', '.join(valid)}; got {value!r}")
    return value


def share(name, value):
    """value as a float in (0, 1] (a share of K); a ValueError for anything else."""
    checked = positive(name, value)
    if checked > 1.0:
        raise ValueError(f"{name} must be in (0, 1] (a share of K); got {value!r}")
    return checked


def seed_param(seed):
    """seed unchanged if it is None, an int >= 0 or a np.random.Generator; else a ValueError."""
    generator = isinstance(seed, np.random.Generator)
    if not (seed is None or generator or isinstance(seed, numbers.Integral) and seed >= 0):
        raise ValueError(f"seed must be None, an int >= 0 or a np.random.Generator; got {seed!r}")
    return seed
