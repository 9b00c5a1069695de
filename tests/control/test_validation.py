"""dcmppi.control.validation: each check returns the value or one ValueError naming the
parameter."""

import numpy as np
import pytest

from dcmppi.control.validation import array, finite, flag, floats, pair, positive


def test_positive_and_finite_take_numbers_and_name_the_bad_ones():
    assert positive("dt", np.float32(0.5)) == 0.5 and type(positive("dt", 1)) is float
    assert positive("K", np.int64(3), integer=True) == 3
    assert positive("std", 0.0, allow_zero=True) == 0.0
    assert finite("angle", -2) == -2.0
    for value, message in [
        (0.0, "dt must be > 0; got 0.0"),
        (-1, "dt must be > 0; got -1"),
        (np.inf, "dt must be a finite number; got inf"),
        (True, "dt must be a finite number; got True"),
        ("fast", "dt must be a finite number; got 'fast'"),
    ]:
        with pytest.raises(ValueError, match=f"^{message}$"):
            positive("dt", value)
    with pytest.raises(ValueError, match="K must be an integer; got 2.5"):
        positive("K", 2.5, integer=True)
    with pytest.raises(ValueError, match="angle must be a finite number; got nan"):
        finite("angle", float("nan"))
    with pytest.raises(ValueError, match="Sigma must hold numbers; got 'x'"):
        floats("Sigma", "x")


def test_flag_takes_bools_only():
    assert flag("visible", np.bool_(True)) is True and flag("visible", False) is False
    for value in (1, "yes", None):
        with pytest.raises(ValueError, match="visible must be true or false"):
            flag("visible", value)


def test_pair_is_an_ordered_finite_pair_above_its_bound():
    assert pair("speed", [0.5, 1]) == (0.5, 1.0)
    assert pair("speed", (0.0, 0.0), low=0.0) == (0.0, 0.0)
    for value, kwargs, message in [
        (1.0, {}, "speed must be a pair"),
        ((1.0, 2.0, 3.0), {}, "speed must be a pair"),
        ((1.0, np.inf), {}, "speed must be a pair of finite numbers"),
        ((2.0, 1.0), {}, "speed must satisfy low <= high"),
        ((-1.0, 1.0), {"low": 0.0}, "speed must satisfy 0.0 <= low <= high"),
        ((0.0, 1.0), {"low": 0.0, "strict": True}, "speed must satisfy 0.0 < low <= high"),
    ]:
        with pytest.raises(ValueError, match=message):
            pair("speed", value, **kwargs)


def test_array_is_a_new_float_array_of_its_shape():
    given = np.zeros((3, 2), dtype=np.float32).T  # (2, 3), not C-contiguous
    out = array("walls", given, ("W", 3))
    assert out.dtype == np.float64 and out.flags.c_contiguous and out.shape == (2, 3)
    same = np.zeros((2, 2))
    assert array("goal", same, (2, 2)) is not same  # a copy: the caller's array stays
    for value, shape, message in [
        (np.zeros((3, 2)), (2, 2), r"goal must have shape \(2, 2\); got \(3, 2\)"),
        (np.zeros(4), ("L", 2), r"goal must have shape \(L, 2\); got \(4,\)"),
        (np.zeros(3), (2,), r"goal must have shape \(2,\); got \(3,\)"),
        ([[0.0, 1.0], [np.nan, 0.0]], ("L", 2), r"goal must be finite; goal\[1, 0\] is nan"),
        ("far", (2,), "goal must hold numbers"),
    ]:
        with pytest.raises(ValueError, match=message):
            array("goal", value, shape, finite=True)
    assert np.isnan(array("goal", [np.nan, 0.0], (2,))[0])  # finite only when asked
