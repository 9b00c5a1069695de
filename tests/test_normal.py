"""dcmppi.control.normal: numpy's standard normals, bit for bit, and the generator state after."""

import numpy as np
import pytest

from dcmppi.control.normal import _pcg64_state, scaled_normal, standard_normal

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


@pytest.mark.parametrize("bit_generator", [np.random.PCG64, np.random.MT19937])
@pytest.mark.parametrize("shape", [(50, 1, 500), (20, 3, 100), (4, 2, 5)])
@pytest.mark.parametrize("offset", [False, True])
def test_scaled_normal_equals_numpys_scale_and_sum(bit_generator, shape, offset):
    scale = np.array([0.3, 1.7, 0.05])[: shape[1]]
    add = np.random.default_rng(1).normal(size=shape[1:]) if offset else None
    ours, numpys = (np.random.Generator(bit_generator(5)) for _ in range(2))
    for _ in range(2):
        x = scaled_normal(ours, shape, scale, add)
        z = numpys.standard_normal(shape)
        z *= scale[:, None]
        if offset:
            z += add
        np.testing.assert_array_equal(x, z)
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
