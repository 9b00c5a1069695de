"""The controllers' perturbation draws: standard normals from counter-based streams.

Every block of BLOCK samples has a stream of its own, keyed by the controller's key (drawn from
its Generator at each reset), the step's draw number and the block's index, so that:
- the blocks are independent: threads may draw them in any order or split and get the same
  values (a step's draws run on `threads` threads like its rollouts);
- a draw is a pure function of its position: the n-th 64-bit word of a block is
  mix64(base + n GAMMA) (SplitMix64's output mix of a Weyl sequence; Steele, Lea and Flood
  2014), with no state carried from one word to the next, so the loops vectorise;
- each two words give two normals by Box and Muller's transform, sqrt(-2 ln u1) (cos, sin)(2 pi
  u2), with u1 in (0, 1] and u2 in [0, 1) of 53 bits rounded to float32, and the transform in
  float32 with the branch-free libm of dcmppi.control.kernels.libm: no rejection, no table. The
  words' 64-bit integer work goes four to an AVX2 register, the transform's float32 work eight, so
  they are two loops over a block's row; the normals are then widened and scaled in float64.
Integer arithmetic and rounded float operations only: the same values on every machine.
A Draw names one draw without making it: the planners make per-step draws in the pass that
bounds them (Draw.into_box), row by row while the row is in the cache.
"""

import dataclasses

import numba
import numpy as np

from dcmppi.control.kernels.libm import from_bits, log_unit32, sincos_turn32
from dcmppi.control.kernels.projection import add_row, disc_row
from dcmppi.control.kernels.threads import ALIGN, parts, run

BLOCK = ALIGN  # samples per stream: a part of a step split over threads is whole blocks

_GAMMA = np.uint64(0x9E3779B97F4A7C15)  # SplitMix64's Weyl increment (2^64 / golden ratio)
_M1, _M2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_U1, _U11, _U12, _U27, _U30, _U31 = (np.uint64(b) for b in (1, 11, 12, 27, 30, 31))
_ULP = 1.0 / 9007199254740992.0  # 2^-53
_ONE_BITS = np.int64(0x3FF0000000000000)  # of 1.0
_ULP_BITS = np.int64(0x3CA0000000000000)  # of 2^-53
_MINUS_TWO = np.float32(-2.0)


@numba.njit(inline="always")
def _mix(z):
    """SplitMix64's output function: a bijection of uint64 that scrambles every bit."""
    z = (z ^ (z >> _U30)) * _M1
    z = (z ^ (z >> _U27)) * _M2
    return z ^ (z >> _U31)


@numba.njit(inline="always")
def _unit(z):
    """(z >> 11) 2^-53, exactly, in [0, 1): the top 52 bits as the mantissa of a number in
    [1, 2) less 1, plus 2^-53 where the 53rd bit is set (both sums exact), so that the loops
    vectorise: AVX2 has no conversion of 64-bit integers to floats, which LLVM then makes one
    element at a time."""
    top = from_bits(np.int64(z >> _U12) | _ONE_BITS) - 1.0
    return top + from_bits(-np.int64((z >> _U11) & _U1) & _ULP_BITS)


@numba.njit(inline="always")
def _block_row(base, first, o, s, work):
    """o[:] = the k = len(o) <= BLOCK normals times s of one row of a block from words first ..
    of the stream base: samples j and h + j (h = BLOCK / 2 in a whole block) share the pair of
    words first + 2 j, first + 2 j + 1. work: _work()'s rows."""
    w1, w2 = work
    k = len(o)
    h = (k + 1) // 2
    for j in range(h):  # the pairs' uniforms
        n = first + np.uint64(2 * j)
        w1[j] = np.float32(_unit(_mix(base + n * _GAMMA)) + _ULP)  # (0, 1], rounded
        w2[j] = np.float32(_unit(_mix(base + (n + _U1) * _GAMMA)))  # [0, 1], rounded
    for j in range(h):  # Box-Muller
        radius = np.sqrt(_MINUS_TWO * log_unit32(w1[j]))
        sn, cs = sincos_turn32(w2[j])
        w1[j], w2[j] = radius * cs, radius * sn
    if k == BLOCK:  # the loop vectorises
        for j in range(BLOCK // 2):
            o[j], o[BLOCK // 2 + j] = np.float64(w1[j]) * s, np.float64(w2[j]) * s
    else:
        for j in range(h):
            o[j] = np.float64(w1[j]) * s
            if h + j < k:
                o[h + j] = np.float64(w2[j]) * s


@numba.njit(inline="always")
def _block_bases(key, draw, j0, j1):
    """The streams of the blocks that start at samples j0, j0 + BLOCK, .. < j1 in draw `draw`
    under `key`."""
    step = _mix(key ^ _mix(draw))
    bases = np.empty(-(-(j1 - j0) // BLOCK), dtype=np.uint64)
    for b in range(len(bases)):
        bases[b] = _mix(step + np.uint64((j0 + b * BLOCK) // BLOCK) * _GAMMA)
    return bases


@numba.njit(inline="always")
def _work():
    """_block_row's two float32 work rows."""
    return np.empty(BLOCK // 2, np.float32), np.empty(BLOCK // 2, np.float32)


@numba.njit(inline="always")
def _last(nu, j0, j1, a):
    """_draw_row's row kept for the correlation a: (nu, j1 - j0), or (0, 0) with a = 0."""
    return np.empty((nu, j1 - j0) if a > 0.0 else (0, 0))


@numba.njit(inline="always")
def _draw_row(bases, i, c, out, scale, add, j0, j1, work, a, last):
    """out[i, c, j0:j1] = the normals of row i, control c of the blocks of `bases` times scale[c]
    (+ add[c, j0:j1] when add is (nu, K)); returns that slice. With a correlation a > 0, the
    row is a last[c] + sqrt(1 - a^2) times those normals from the second row on, and last[c]
    (nu, j1 - j0) keeps it for the next row (an AR(1) sequence of variance scale[c]^2)."""
    first = np.uint64((i * out.shape[1] + c) * BLOCK + 1)
    for b in range(len(bases)):
        b0 = j0 + b * BLOCK
        _block_row(bases[b], first, out[i, c, b0 : min(b0 + BLOCK, j1)], scale[c], work)
    o = out[i, c, j0:j1]
    if a > 0.0:
        previous, b = last[c], np.sqrt(1.0 - a * a)
        if i > 0:
            for j in range(len(o)):
                o[j] = a * previous[j] + b * o[j]
        for j in range(len(o)):
            previous[j] = o[j]
    if add.shape[0]:
        a = add[c, j0:j1]
        for j in range(len(o)):
            o[j] += a[j]
    return o


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _draw(key, draw, out, scale, add, a, j0, j1):
    """out[:, :, j0:j1] = z * scale[c] (+ add[c, j] when add is (nu, K)) for standard normals z
    of the blocks j0 // BLOCK .. of draw `draw` under `key`, row by row (correlated along the
    rows by a: _draw_row). out: (R, nu, K)."""
    bases, work, last = _block_bases(key, draw, j0, j1), _work(), _last(out.shape[1], j0, j1, a)
    for i in range(out.shape[0]):
        for c in range(out.shape[1]):
            _draw_row(bases, i, c, out, scale, add, j0, j1, work, a, last)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _draw_box(key, draw, scale, add, a, U0, lower, upper, u, e, sums, products, j0, j1):
    """_draw's eps into the box, row by row while the row is in the cache: u = min(max(U0 + eps,
    lower), upper) and e = u - U0 in columns j0:j1 of u, e (N, nu, K), and when sums is (nu, K)
    the horizon sums of e added to it step by step (projection._clip_box's values; eps itself
    is not kept), when products is (nu, K) U0[i, c] e[i, c] likewise (dcmppi.control.kernels.sums'
    importance sums)."""
    bases, work, last = _block_bases(key, draw, j0, j1), _work(), _last(u.shape[1], j0, j1, a)
    for i in range(u.shape[0]):
        for c in range(u.shape[1]):
            o, r = _draw_row(bases, i, c, u, scale, add, j0, j1, work, a, last), e[i, c, j0:j1]
            u0, lo, hi = U0[i, c], lower[c], upper[c]
            for j in range(len(o)):
                v = min(max(u0 + o[j], lo), hi)
                o[j] = v
                r[j] = v - u0
            add_row(r, u0, c, sums, products, (j0, j1))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _draw_box_disc(key, draw, scale, add, a, U0, lower, upper, p, q, limit, u, e, sums,
                   products, j0, j1):  # fmt: skip
    """_draw_box with controls p and q then scaled back onto |(u_p, u_q)| <= limit, a row at a
    time (projection._clip_box_disc's values)."""
    bases, work, last = _block_bases(key, draw, j0, j1), _work(), _last(u.shape[1], j0, j1, a)
    scales = np.empty(j1 - j0)
    for i in range(u.shape[0]):
        for c in range(u.shape[1]):
            o = _draw_row(bases, i, c, u, scale, add, j0, j1, work, a, last)
            u0, lo, hi = U0[i, c], lower[c], upper[c]
            for j in range(len(o)):
                o[j] = min(max(u0 + o[j], lo), hi)
        disc_row(U0, p, q, limit, sums, products, u, e, i, (j0, j1), scales)


_NO_ADD = np.zeros((0, 0))


def draw_normals(key, draw, shape, scale, add=None, threads=1, correlation=0.0):
    """z * scale[:, None] (+ add) for standard normals z of shape (R, nu, K), the draw number
    `draw` of the stream `key`; the same values for every `threads`.

    Args:
      key, draw: ints in [0, 2^64). shape: (R, nu, K). scale: (nu,). add: (nu, K) or None.
      correlation: a in [0, 1): row i > 0 is a row_{i-1} + sqrt(1 - a^2) z_i scale (before
        add), each sample's AR(1) sequence along the rows, of the same variance scale^2 per row
        and correlation a^|i - i'| between rows i, i'; 0: independent rows.
    Returns:
      (R, nu, K) float64.
    """
    out = np.empty(shape)
    scale = np.asarray(scale, dtype=float)
    add = _NO_ADD if add is None else np.ascontiguousarray(add, dtype=float)
    key, draw = np.uint64(key), np.uint64(draw)

    a = float(correlation)

    def part(j0, j1):
        _draw(key, draw, out, scale, add, a, j0, j1)

    run(part, parts(shape[2], threads))
    return out


def draw_box(key, draw, scale, add, U0, lower, upper, u, e, sums, cols=None, products=_NO_ADD,
             disc=None, correlation=0.0):  # fmt: skip
    """The controls of the draw `draw` of the stream `key` (draw_normals' eps = z * scale[:, None]
    (+ add)) in their box, into the samples cols = (j0, j1) of u, e (N, nu, K) (None: all; j0 a
    multiple of BLOCK, as threads.parts gives): u = min(max(U0 + eps, lower), upper), e = u - U0,
    with the horizon sums of e added to sums (nu, K) (a (0, 0) array: none); the values of
    draw_normals then projection.project_columns, in one pass. products (nu, K), when given,
    gets the importance term's sums over the steps, sum_i U0[i, c] e[i, c]
    (dcmppi.control.kernels.sums' values). disc = (p, q, limit): controls p and q then scaled
    back onto |(u_p, u_q)| <= limit (the holonomic base's bound), as project_columns does.
    correlation: draw_normals' (the rows of eps correlated before they are bounded).

    scale, lower, upper: (nu,); add: (nu, K) or None; U0: (N, nu).
    """
    j0, j1 = cols or (0, u.shape[2])
    add = _NO_ADD if add is None else np.ascontiguousarray(add, dtype=float)
    key, draw, scale = np.uint64(key), np.uint64(draw), np.asarray(scale, dtype=float)
    a = float(correlation)
    if disc is None:
        _draw_box(key, draw, scale, add, a, U0, lower, upper, u, e, sums, products, j0, j1)
    else:
        p, q, limit = disc
        _draw_box_disc(key, draw, scale, add, a, U0, lower, upper, p, q, float(limit), u, e,
                       sums, products, j0, j1)  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Draw:
    """The perturbations eps = z * scale[:, None] (+ add) (N, nu, K) of the draw `draw` of the
    stream `key`, not yet made: `array()` (or np.asarray) makes them at once (draw_normals),
    `into_box` bounds each row as it is drawn (draw_box), both with the same values.

    key, draw: ints in [0, 2^64). shape: (N, nu, K). scale: (nu,). add: (nu, K) or None.
    correlation: of consecutive rows (draw_normals'), 0: independent.
    """

    key: int
    draw: int
    shape: tuple
    scale: np.ndarray
    add: np.ndarray | None = None
    correlation: float = 0.0

    def array(self, threads=1):
        """eps (N, nu, K), drawn on `threads` threads (the same values for every number)."""
        return draw_normals(self.key, self.draw, self.shape, self.scale, self.add, threads,
                            self.correlation)  # fmt: skip

    def __array__(self, dtype=None, copy=None):
        return self.array() if dtype is None else self.array().astype(dtype, copy=False)

    def into_box(self, agent, U0, u, e, sums, products, cols=None):
        """draw_box of these draws for an agent bounded by a box (agent.lower, agent.upper), or a
        box and a disc (agent.norm_axes of two controls, agent.norm_limit)."""
        disc = None if agent.norm_axes is None else (*agent.norm_axes, agent.norm_limit)
        draw_box(self.key, self.draw, self.scale, self.add, U0, agent.lower, agent.upper, u, e,
                 sums, cols, products, disc, self.correlation)  # fmt: skip
