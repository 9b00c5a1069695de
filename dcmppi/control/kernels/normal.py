"""Standard normal draws bit-identical to numpy's `Generator.standard_normal`, compiled.

numpy's Generator.standard_normal is a large share of one time-varying MPPI step (it draws
n x nu x K normals). The same draws compiled:
- PCG64 (np.random.default_rng's bit generator): its 128-bit state stepped in registers and
  numpy's ziggurat over it (below), from PCG64_MIN_SIZE normals on;
- any other bit generator: numba's Generator support (numba's port of numpy's ziggurat, with its
  tables, calling the generator's own next_uint64 and next_double); unboxing the generator has a
  fixed cost per call, so draws below NUMBA_MIN_SIZE stay numpy's.
The PCG64 path reads numpy's PCG64 memory through ctypes and numba's private ziggurat tables:
at first use it draws on a throwaway generator and compares values and state after with
numpy's; on a mismatch or an error it warns once and PCG64s take numba's path from then on.
Either way the values are numpy's and the generator's state ends where numpy's would (tests).
"""

import ctypes
import math
import warnings

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

try:  # numba's private copy of numpy's ziggurat tables (the inline PCG64 path only)
    from numba.np.random._constants import (
        fi_double,
        ki_double,
        wi_double,
        ziggurat_nor_inv_r,
        ziggurat_nor_r,
    )

    _TABLES_ERROR = None
except ImportError as error:
    _TABLES_ERROR = error

NUMBA_MIN_SIZE = 2000  # below this many normals numpy's own call is as quick
PCG64_MIN_SIZE = 100  # the same for the inline PCG64 draws (below)


def standard_normal(rng, shape):
    """rng.standard_normal(shape) (float64), the same values and the same generator state after.

    Args:
      rng: np.random.Generator. shape: int or tuple of ints.
    """
    shape = (shape,) if isinstance(shape, (int, np.integer)) else tuple(shape)
    size = math.prod(shape)
    state = _pcg64_state(rng.bit_generator)
    if state is not None and size >= PCG64_MIN_SIZE:
        return _pcg64_normals(state, size).reshape(shape)
    if size < NUMBA_MIN_SIZE:
        return rng.standard_normal(shape)
    return _standard_normal(rng, shape)


@numba.njit(cache=True)
def _standard_normal(rng, shape):
    return rng.standard_normal(shape)


# --- PCG64 (np.random.default_rng's bit generator) inline ---------------------------------------
#
# Through numba's Generator support every draw calls the bit generator's next_uint64 through a
# function pointer, whose 128-bit state then lives in memory. For a PCG64 the state is read once
# through its ctypes address (checked against bit_generator.state), stepped in registers with
# LLVM's 128-bit multiply, and written back: the same outputs, in less time per normal.
# The ziggurat's tables are numpy's, from numba's copy (numba.np.random._constants). Like
# numba's draws, these bypass the generator's lock: one thread per generator.

_PCG64_MULTIPLIER = (
    0x2360ED051FC65DA44385DF649FCCF645  # numpy's pcg64.h, PCG_DEFAULT_MULTIPLIER_128
)
_last_pcg64 = [None, None]  # the last PCG64 seen and the view of its state (or None)
_inline = []  # [True] once the inline draws passed _inline_check, [False] once they failed it
# The check's draw: this seed's 20 000 normals reach the ziggurat's tail and wedges (a test).
_CHECK_SEED, _CHECK_SIZE = 2024, 20_000


def _pcg64_state(bit_generator):
    """A writable uint64 (4,) view of a numpy PCG64's state: state (low, high), increment (low,
    high); None for other bit generators, when the memory does not hold bit_generator.state
    (another layout), or when the inline draws failed their check (at first use)."""
    if type(bit_generator) is not np.random.PCG64:
        return None
    if _last_pcg64[0] is bit_generator:
        return _last_pcg64[1]
    if not _inline:
        cause = _inline_check()
        _inline.append(cause is None)
        if cause is not None:
            warnings.warn(
                f"dcmppi.control.kernels.normal: the inline PCG64 normals are off ({cause}); PCG64 "
                "draws go through numba's Generator instead: the same values, slower. "
                "Use the numba and numpy versions pyproject.toml names to get them back.",
                RuntimeWarning,
                stacklevel=3,
            )
    view = _read_pcg64_state(bit_generator) if _inline[0] else None
    _last_pcg64[:] = bit_generator, view  # keeps the generator, and so the memory, alive
    return view


def _read_pcg64_state(bit_generator):
    """_pcg64_state's view through ctypes, or None when it does not hold bit_generator.state."""
    address = ctypes.c_void_p.from_address(bit_generator.ctypes.state_address).value
    if not address:
        return None
    view = np.ctypeslib.as_array((ctypes.c_uint64 * 4).from_address(address))
    state = bit_generator.state["state"]
    low_high = [int(v) for v in view]
    if low_high[0] | low_high[1] << 64 != state["state"] or (
        low_high[2] | low_high[3] << 64 != state["inc"]
    ):
        return None
    return view


def _inline_check():
    """None when the inline draws equal numpy's on a throwaway PCG64 (the values, and the state
    after), else why not (a phrase)."""
    if _TABLES_ERROR is not None:
        return f"numba's ziggurat tables: {_TABLES_ERROR!r}"
    try:
        ours, numpys = (np.random.Generator(np.random.PCG64(_CHECK_SEED)) for _ in range(2))
        view = _read_pcg64_state(ours.bit_generator)
        if view is None:
            return "numpy's PCG64 state is not where ctypes reads it"
        x = _pcg64_normals(view, _CHECK_SIZE)
        if not np.array_equal(x, numpys.standard_normal(_CHECK_SIZE)):
            return "a check draw differs from numpy's"
        if ours.bit_generator.state != numpys.bit_generator.state:
            return "the generator state after a check draw differs from numpy's"
    except Exception as error:  # any failure of the private paths: numba's public one instead
        return f"{type(error).__name__}: {error}"
    return None


@intrinsic
def _pcg64_step(typingctx, low, high, inc_low, inc_high):
    """PCG64's LCG step, state * multiplier + increment (mod 2^128), on uint64 halves; returns
    the new state (low, high)."""
    u64 = types.uint64
    sig = types.UniTuple(u64, 2)(u64, u64, u64, u64)

    def codegen(context, builder, signature, args):
        i64, i128 = ir.IntType(64), ir.IntType(128)

        def wide(lo, hi):
            hi = builder.shl(builder.zext(hi, i128), ir.Constant(i128, 64))
            return builder.or_(hi, builder.zext(lo, i128))

        state = builder.mul(wide(*args[:2]), ir.Constant(i128, _PCG64_MULTIPLIER))
        state = builder.add(state, wide(*args[2:]))
        lo = builder.trunc(state, i64)
        hi = builder.trunc(builder.lshr(state, ir.Constant(i128, 64)), i64)
        return context.make_tuple(builder, signature.return_type, (lo, hi))

    return sig, codegen


_U8, _U11, _U58, _U63, _U64 = (np.uint64(b) for b in (8, 11, 58, 63, 64))
_LOW_BYTE, _MANTISSA, _ONE_U = np.uint64(0xFF), np.uint64(0x000FFFFFFFFFFFFF), np.uint64(1)


@numba.njit(inline="always")
def _pcg64_next(lo, hi, inc_lo, inc_hi):
    """next_uint64: the step, then the XSL-RR output of the new state; returns it and the state."""
    lo, hi = _pcg64_step(lo, hi, inc_lo, inc_hi)
    x, rot = hi ^ lo, hi >> _U58
    return (x >> rot) | (x << ((_U64 - rot) & _U63)), lo, hi


@numba.njit(inline="always")
def _double(r):
    """next_double from a next_uint64 output: its top 53 bits over 2^53 (below 2^53, an int64
    converts to the same double as the uint64, in fewer instructions)."""
    return np.int64(r >> _U11) * (1.0 / 9007199254740992.0)


@numba.njit(inline="always")
def _pcg64_normal(lo, hi, inc_lo, inc_hi):
    """numpy's random_standard_normal (the 256-layer ziggurat, numpy's tables via numba's copy)
    on PCG64 state (lo, hi); returns the normal and the new state."""
    while True:
        r, lo, hi = _pcg64_next(lo, hi, inc_lo, inc_hi)
        idx = r & _LOW_BYTE
        r >>= _U8
        rabs = (r >> _ONE_U) & _MANTISSA
        x = np.int64(rabs) * wi_double[idx]  # rabs < 2^52: exact as int64 too
        if r & _ONE_U:
            x = -x
        if rabs < ki_double[idx]:
            return x, lo, hi  # 99.3 %
        if idx == 0:  # the tail beyond ziggurat_nor_r
            while True:
                u, lo, hi = _pcg64_next(lo, hi, inc_lo, inc_hi)
                xx = -ziggurat_nor_inv_r * np.log1p(-_double(u))
                u, lo, hi = _pcg64_next(lo, hi, inc_lo, inc_hi)
                yy = -np.log1p(-_double(u))
                if yy + yy > xx * xx:
                    x = -(ziggurat_nor_r + xx) if (rabs >> _U8) & _ONE_U else ziggurat_nor_r + xx
                    return x, lo, hi
        else:  # a wedge
            u, lo, hi = _pcg64_next(lo, hi, inc_lo, inc_hi)
            f0, f1 = fi_double[idx - 1], fi_double[idx]
            if (f0 - f1) * _double(u) + f1 < np.exp(-0.5 * x * x):
                return x, lo, hi


@numba.njit(cache=True)
def _pcg64_normals(state, size):
    """`size` standard normals (size,) from the PCG64 state view (4,) uint64, which ends
    advanced."""
    lo, hi, inc_lo, inc_hi = state[0], state[1], state[2], state[3]
    out = np.empty(size)
    for j in range(size):
        x, lo, hi = _pcg64_normal(lo, hi, inc_lo, inc_hi)
        out[j] = x
    state[0], state[1] = lo, hi
    return out
