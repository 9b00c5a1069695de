"""sin, cos and log for compiled loops that vectorise: fdlibm's kernels without branches,
Cephes' float32 ones; and numpy's complex absolute value.

numba calls libm's sin, cos and log one element at a time, so a loop that takes them does not
vectorise. These are fdlibm's polynomials (k_sin.c, k_cos.c, e_log.c; errors below 1 ulp of
their reduced arguments) behind branch-free argument reductions: within 2 ulp of libm for
|x| < 1e5 (sincos) and on (0, 1] (log_unit), the same values on every machine (no fused
multiply-add: numba compiles without fast-math). The rollouts (dcmppi.control.kernels.dynamics) use
them. `log_unit32` and `sincos_turn32` are Cephes' float32 polynomials for the perturbation
draws (dcmppi.control.kernels.perturbations), which AVX2 evaluates eight at a time. `cabs` is
numpy's np.abs of a complex number as its SIMD loop computes it, whose multiply-add is fused: it
calls LLVM's fma (`fma`) explicitly, so it too gives the same values on every machine (the physics'
clearances, tasks/physics.py, through `cabs_or_nan`, its branch-free form). `nan_min` is
numpy's min (nan when any value is), for the clearances and the MPPI weights' minimum cost.
"""

import math

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

# k_sin.c, k_cos.c
_S1, _S2 = -1.66666666666666324348e-01, 8.33333333332248946124e-03
_S3, _S4 = -1.98412698298579493134e-04, 2.75573137070700676789e-06
_S5, _S6 = -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2 = 4.16666666666666019037e-02, -1.38888888888741095749e-03
_C3, _C4 = 2.48015872894767294178e-05, -2.75573143513906633035e-07
_C5, _C6 = 2.08757232129817482790e-09, -1.13596475577881948265e-11
_TWO_OVER_PI = 6.36619772367581382433e-01
_PIO2_1, _PIO2_1T = 1.57079632673412561417e00, 6.07710050650619224932e-11  # pi / 2, two parts
_ROUND = 6755399441055744.0  # 1.5 2^52: (y + _ROUND) - _ROUND rounds y to an integer
_I1, _I2 = np.int32(1), np.int32(2)
# e_log.c
_LG1, _LG2 = 6.666666666666735130e-01, 3.999999999940941908e-01
_LG3, _LG4 = 2.857142874366239149e-01, 2.222219843214978396e-01
_LG5, _LG6, _LG7 = 1.818357216161805012e-01, 1.531383769920937332e-01, 1.479819860511658591e-01
_LN2_HI, _LN2_LO = 6.93147180369123816490e-01, 1.90821492927058770002e-10
_SQRT2 = 1.4142135623730951


@numba.njit(inline="always")
def sincos(x):
    """(sin x, cos x) for |x| < 1e5: x = k pi / 2 + r with |r| <= pi / 4, the kernels on r,
    and the quadrant k mod 4 picked by arithmetic (no branch; k as a 32-bit integer, which
    |k| < 1e5 fits)."""
    k = (x * _TWO_OVER_PI + _ROUND) - _ROUND
    r = (x - k * _PIO2_1) - k * _PIO2_1T
    z = r * r
    s = r + r * z * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    c = 1.0 - 0.5 * z + z * z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    q = np.int32(k)  # 32-bit: AVX2 converts those four at a time, 64-bit ones one by one
    odd = np.float64(q & _I1)
    sin_sign = np.float64(_I1 - _I2 * ((q >> _I1) & _I1))
    cos_sign = np.float64(_I1 - _I2 * (((q + _I1) >> _I1) & _I1))
    return sin_sign * (s * (1.0 - odd) + c * odd), cos_sign * (c * (1.0 - odd) + s * odd)


@intrinsic
def _bits(typingctx, x):
    """The IEEE bits of a float64 as an int64, of a float32 as an int32."""
    width = x.bitwidth

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(width))

    return getattr(types, f"int{width}")(x), codegen


@intrinsic
def from_bits(typingctx, bits):
    """The float64 of IEEE bits given as an int64, the float32 of an int32."""
    width = bits.bitwidth
    float_type = ir.DoubleType() if width == 64 else ir.FloatType()

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], float_type)

    return getattr(types, f"float{width}")(bits), codegen


@numba.njit(inline="always")
def log_unit(u):
    """ln u for normal u in (0, 1]: u = 2^e m with m in [sqrt(2) / 2, sqrt(2)), then e_log.c's
    series in s = (m - 1) / (m + 1)."""
    b = _bits(u)
    m = from_bits((b & 0x000FFFFFFFFFFFFF) | 0x3FF0000000000000)  # in [1, 2)
    big = np.float64(m > _SQRT2)
    m = m * (1.0 - 0.5 * big)
    k = np.float64((b >> 52) - 1023) + big
    f = m - 1.0
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    t1 = w * (_LG2 + w * (_LG4 + w * _LG6))
    t2 = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
    hfsq = 0.5 * f * f
    return k * _LN2_HI - ((hfsq - (s * (hfsq + (t2 + t1)) + k * _LN2_LO)) - f)


# Cephes' logf, sinf and cosf (float32; errors near 1 ulp of float32)

_F = np.float32
_LF0, _LF1, _LF2 = _F(7.0376836292e-2), _F(-1.1514610310e-1), _F(1.1676998740e-1)
_LF3, _LF4, _LF5 = _F(-1.2420140846e-1), _F(1.4249322787e-1), _F(-1.6668057665e-1)
_LF6, _LF7, _LF8 = _F(2.0000714765e-1), _F(-2.4999993993e-1), _F(3.3333331174e-1)
_LN2F_LO, _LN2F_HI = _F(-2.12194440e-4), _F(0.693359375)  # ln 2 = _HI + _LO, _HI exact
_SF1, _SF2, _SF3 = _F(-1.6666654611e-1), _F(8.3321608736e-3), _F(-1.9515295891e-4)
_CF1, _CF2, _CF3 = _F(4.166664568298827e-2), _F(-1.388731625493765e-3), _F(2.443315711809948e-5)
_HALF_PI_F, _SQRT2_F = _F(math.pi / 2), _F(math.sqrt(2.0))
_ROUND_F = _F(12582912.0)  # 1.5 2^23: (y + _ROUND_F) - _ROUND_F rounds y to an integer
_ONE_F, _HALF_F, _FOUR_F = _F(1.0), _F(0.5), _F(4.0)
_MANTISSA_F, _ONE_F_BITS = np.int32(0x007FFFFF), np.int32(0x3F800000)
_I23, _I127 = np.int32(23), np.int32(127)


@numba.njit(inline="always")
def log_unit32(u):
    """ln u for a normal float32 u in (0, 1], in float32: u = 2^e m with m in [sqrt(2) / 2,
    sqrt(2)), then Cephes' logf series in f = m - 1 (no division)."""
    b = _bits(u)
    m = from_bits(np.int32((b & _MANTISSA_F) | _ONE_F_BITS))  # in [1, 2)
    big = _F(m > _SQRT2_F)
    m = m * (_ONE_F - _HALF_F * big)
    e = _F(np.int32(b >> _I23) - _I127) + big
    f = m - _ONE_F
    z = f * f
    p = ((((_LF0 * f + _LF1) * f + _LF2) * f + _LF3) * f + _LF4) * f + _LF5
    y = f * z * (((p * f + _LF6) * f + _LF7) * f + _LF8)
    y = y + _LN2F_LO * e - _HALF_F * z
    return (f + y) + _LN2F_HI * e


@numba.njit(inline="always")
def sincos_turn32(u):
    """(sin 2 pi u, cos 2 pi u) for a float32 u in [0, 1], in float32: 4 u = k + t with k an
    integer and |t| <= 1 / 2, both exact, Cephes' sinf and cosf kernels on t pi / 2, and the
    quadrant k mod 4 picked by arithmetic as in sincos."""
    t4 = _FOUR_F * u
    k = (t4 + _ROUND_F) - _ROUND_F
    x = (t4 - k) * _HALF_PI_F
    z = x * x
    s = ((_SF3 * z + _SF2) * z + _SF1) * z * x + x
    c = ((_CF3 * z + _CF2) * z + _CF1) * z * z - _HALF_F * z + _ONE_F
    q = np.int32(k)
    odd = _F(q & _I1)
    sin_sign = _F(_I1 - _I2 * ((q >> _I1) & _I1))
    cos_sign = _F(_I1 - _I2 * (((q + _I1) >> _I1) & _I1))
    return sin_sign * (s * (_ONE_F - odd) + c * odd), cos_sign * (c * (_ONE_F - odd) + s * odd)


@intrinsic
def fma(typingctx, a, b, c):
    """a b + c rounded once (LLVM's fma: the processor's instruction, or exact in software)."""

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(fn, args)

    return types.float64(types.float64, types.float64, types.float64), codegen


@numba.njit(inline="always")
def cabs(x, y):
    """|x + iy| as numpy's complex absolute computes it with SIMD (numpy 2's OpCabs, whose
    MulAdd is fused on processors with FMA): larger * sqrt(ratio^2 + 1), inf where either part
    is inf, else nan where either is nan, 0 where both are 0."""
    re, im = abs(x), abs(y)
    if math.isinf(re) or math.isinf(im):
        return np.inf
    if re != re or im != im:
        return np.nan
    larger, smaller = max(re, im), min(re, im)
    if larger == 0.0:
        return 0.0
    ratio = smaller / larger
    return math.sqrt(fma(ratio, ratio, 1.0)) * larger


@numba.njit(inline="always")
def cabs_or_nan(x, y):
    """cabs(x, y) wherever this is not nan; nan where x and y are both 0, both infinite or either
    nan (there cabs gives the value): cabs's operations without its branches, so that a loop of
    it vectorises."""
    re, im = abs(x), abs(y)
    swap = re > im  # false where either is nan: the nan goes into ratio
    larger, smaller = (re if swap else im), (im if swap else re)
    ratio = smaller / larger  # nan where both are 0 or both inf (numba: error_model="numpy")
    return math.sqrt(fma(ratio, ratio, 1.0)) * larger


@numba.njit(inline="always")
def nan_min(values):
    """numpy's min of a non-empty (n,): nan when any is nan (its order does not matter)."""
    low, unordered = np.inf, False
    for v in values:
        if v < low:
            low = v
        elif v != v:
            unordered = True
    return np.nan if unordered else low
