"""dcmppi.control.kernels.normal: numpy's standard normals, bit for bit, and the generator state
after."""

import importlib.util
import sys
import warnings

import numpy as np
import pytest

from dcmppi.control.kernels import normal
from dcmppi.control.kernels.normal import _pcg64_state, standard_normal

BIT_GENERATORS = [
    np.random.PCG64,
    np.random.PCG64DXSM,
    np.random.SFC64,
    np.random.Philox,
    np.random.MT19937,
]


@pytest.mark.parametrize("bit_generator", BIT_GENERATORS)
@pytest.mark.parametrize("shape", [(50, 1, 500), (2, 500), (3, 0, 2), 7, 5000, (1,)])
def test_standard_normal_equals_numpy_and_leaves_the_same_state(bit_generator, shape):
    for seed in range(5):
        ours, numpys = (np.random.Generator(bit_generator(seed)) for _ in range(2))
        for _ in range(3):  # successive draws continue alike
            x = standard_normal(ours, shape)
            assert x.dtype == np.float64
            np.testing.assert_array_equal(x, numpys.standard_normal(shape))
        raw = ours.bit_generator.random_raw(4)
        np.testing.assert_array_equal(raw, numpys.bit_generator.random_raw(4))


def test_standard_normal_covers_the_ziggurat_tail_and_wedges():
    """A million draws: about 300 from the tail beyond r = 3.654 (layer 0) and 12 000 wedge
    tests, all equal to numpy's."""
    ours, numpys = np.random.default_rng(11), np.random.default_rng(11)
    x = standard_normal(ours, 10**6)
    np.testing.assert_array_equal(x, numpys.standard_normal(10**6))
    assert (np.abs(x) > 3.6541528853610088).sum() > 100
    assert ours.random() == numpys.random()


def test_pcg64_draws_run_on_its_live_state_and_alternate_between_generators():
    """default_rng's PCG64 takes the inline path (its state read and written in place); draws
    that alternate between two generators continue each one's stream."""
    a, b = np.random.default_rng(1), np.random.default_rng(2)
    view = _pcg64_state(a.bit_generator)
    assert view is not None
    state = a.bit_generator.state["state"]
    assert int(view[0]) | int(view[1]) << 64 == state["state"]
    assert _pcg64_state(np.random.Generator(np.random.MT19937(0)).bit_generator) is None
    numpy_a, numpy_b = np.random.default_rng(1), np.random.default_rng(2)
    for shape in [(5000,), (4, 1, 1000), (3000,)]:
        for ours, numpys in ((a, numpy_a), (b, numpy_b)):
            np.testing.assert_array_equal(
                standard_normal(ours, shape), numpys.standard_normal(shape)
            )
    assert a.bit_generator.state == numpy_a.bit_generator.state
    assert b.bit_generator.state == numpy_b.bit_generator.state


def test_the_inline_check_draw_reaches_the_tail_and_wedges_and_passes():
    """The first-use check compares a draw that takes every branch of the ziggurat: values
    beyond r = 3.654 (the tail) and more next_uint64 calls than the layers and tail take alone
    (wedge tests)."""
    assert normal._inline_check() is None
    numpys = np.random.Generator(np.random.PCG64(normal._CHECK_SEED))
    x = numpys.standard_normal(normal._CHECK_SIZE)
    tail = int((np.abs(x) > 3.6541528853610088).sum())
    assert tail > 0
    raw = np.random.PCG64(normal._CHECK_SEED)
    raw.random_raw(normal._CHECK_SIZE)
    extra = 0
    while raw.state != numpys.bit_generator.state:
        raw.random_raw()
        extra += 1
    assert extra > 2 * tail + 50  # a tail draw takes 2 more per try; the rest are wedge tests


def _fresh_normal():
    """A new copy of dcmppi/control/kernels/normal.py, its first use not yet checked. It keeps the
    module's name (outside sys.modules): numba's cache records it and imports it on loading."""
    spec = importlib.util.spec_from_file_location(normal.__name__, normal.__file__)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _raise(*args):
    raise OSError("no PCG64 memory here")


def _off_by_one_ulp(*args):
    return np.nextafter(normal._pcg64_normals(*args), np.inf)


@pytest.mark.parametrize("cause", ["reader raises", "draws differ", "numba internals missing"])
def test_a_failed_inline_check_warns_once_and_draws_numpys_values_through_numba(cause, monkeypatch):
    if cause == "numba internals missing":
        monkeypatch.setitem(sys.modules, "numba.np.random._constants", None)
    module = _fresh_normal()
    if cause == "reader raises":
        monkeypatch.setattr(module, "_read_pcg64_state", _raise)
    elif cause == "draws differ":
        monkeypatch.setattr(module, "_pcg64_normals", _off_by_one_ulp)
    seeds = (3, 4)
    ours = [np.random.default_rng(s) for s in seeds]
    numpys = [np.random.default_rng(s) for s in seeds]
    with pytest.warns(RuntimeWarning, match="inline PCG64 normals are off") as caught:
        for shape in [(5000,), (4, 1, 1000), (50,)]:
            for g, n in zip(ours, numpys, strict=True):
                np.testing.assert_array_equal(
                    module.standard_normal(g, shape), n.standard_normal(shape)
                )
    assert len(caught) == 1
    assert module._pcg64_state(ours[0].bit_generator) is None  # numba's path from then on
    for g, n in zip(ours, numpys, strict=True):
        assert g.bit_generator.state == n.bit_generator.state


def test_a_passed_inline_check_is_silent_and_takes_the_inline_path():
    module = _fresh_normal()
    ours, numpys = np.random.default_rng(5), np.random.default_rng(5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        x = module.standard_normal(ours, 5000)
    assert module._inline == [True]
    assert module._pcg64_state(ours.bit_generator) is not None
    np.testing.assert_array_equal(x, numpys.standard_normal(5000))
    assert ours.bit_generator.state == numpys.bit_generator.state
