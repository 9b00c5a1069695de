"""Standard normal draws, bit-identical to numpy's `Generator.standard_normal`, about twice as fast.

numpy draws each normal with its ziggurat (numpy/random/src/distributions/distributions.c,
`random_standard_normal`) and calls the bit generator through a function pointer per value:
about 9 ns per normal on our 2-core benchmark machine, 0.24 ms of the 25 000 normals a
time-varying MPPI step draws. Here the bit generator's raw 64-bit outputs come in one
`random_raw` call and the same ziggurat (numba's port of it, with numpy's tables) runs as a numba
loop: the same values from the same generator state, and the generator ends in the same state.

The ziggurat takes one raw value per normal, and one or two more for the 1-2 % it rejects, so
the count is known only afterwards. Each round draws as many raw values as normals are still
missing (never more than numpy would take, since every normal needs at least one); a normal whose
extra values are not yet drawn waits for the next round. Three or four rounds fill 25 000 normals.

This holds for bit generators whose raw output is numpy's next_uint64 and whose doubles are
(next_uint64 >> 11) 2^-53: PCG64 (numpy's default), PCG64DXSM, SFC64 and Philox. Others
(MT19937) go to numpy itself.
"""

import numba
import numpy as np
from numba.np.random._constants import (
    fi_double,
    ki_double,
    wi_double,
    ziggurat_nor_inv_r,
    ziggurat_nor_r,
)

RAW_UINT64 = (np.random.PCG64, np.random.PCG64DXSM, np.random.SFC64, np.random.Philox)


def standard_normal(rng, shape):
    """rng.standard_normal(shape) (float64), the same values and the same generator state after.

    Args:
      rng: np.random.Generator. shape: int or tuple.
    """
    bitgen = rng.bit_generator
    if type(bitgen) not in RAW_UINT64:
        return rng.standard_normal(shape)
    out = np.empty(shape)
    flat = out.reshape(-1)
    filled, pending = 0, np.zeros(0, dtype=np.uint64)
    while filled < flat.size:
        raw = bitgen.random_raw(flat.size - filled)
        if len(pending):
            raw = np.concatenate([pending, raw])
        done, used = _ziggurat(raw, flat, filled)
        filled += done
        pending = raw[used:]
    return out


_U53 = 1.0 / 9007199254740992.0  # 2^-53: a double in [0, 1) from the top 53 bits


@numba.njit(inline="always")
def _uniform(r):
    """numpy's next_double from a raw value."""
    return (r >> np.uint64(11)) * _U53


@numba.njit(cache=True)
def _candidates(raw, x, accept):
    """The ziggurat's candidate x (n,) of every raw value (n,) uint64 and whether it falls inside
    its layer's rectangle (accepted at once, 98-99 % of them). Vectorisable: no carried state."""
    for j in range(len(raw)):
        r = raw[j]
        layer = r & np.uint64(0xFF)
        rabs = (r >> np.uint64(9)) & np.uint64(0x000FFFFFFFFFFFFF)
        v = rabs * wi_double[layer]
        x[j] = -v if (r >> np.uint64(8)) & np.uint64(1) else v
        accept[j] = rabs < ki_double[layer]


@numba.njit(cache=True)
def _ziggurat(raw, out, start):
    """Fills out[start:] from the raw values in order, as numpy's random_standard_normal.

    Returns the normals written and the raw values used; it stops before a normal whose
    rejection test needs values beyond `raw` (they come in the next round).
    """
    n, m = len(out), len(raw)
    x = np.empty(m)
    accept = np.empty(m, dtype=np.bool_)
    _candidates(raw, x, accept)
    i, j = start, 0
    while i < n and j < m:
        if accept[j]:
            out[i] = x[j]
            i += 1
            j += 1
            continue
        first = j  # rejection sampling of the wedge (layers 1..255) or the tail (layer 0)
        r = raw[j]
        layer = r & np.uint64(0xFF)
        j += 1
        if layer == 0:
            while j + 2 <= m:
                xx = -ziggurat_nor_inv_r * np.log1p(-_uniform(raw[j]))
                yy = -np.log1p(-_uniform(raw[j + 1]))
                j += 2
                if yy + yy > xx * xx:
                    tail = ziggurat_nor_r + xx
                    out[i] = -tail if (r >> np.uint64(17)) & np.uint64(1) else tail
                    i += 1
                    break
            else:
                return i - start, first
        elif j < m:
            f = (fi_double[layer - 1] - fi_double[layer]) * _uniform(raw[j]) + fi_double[layer]
            j += 1
            if f < np.exp(-0.5 * x[first] * x[first]):
                out[i] = x[first]
                i += 1
        else:
            return i - start, first
    return i - start, j
