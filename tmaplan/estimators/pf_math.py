"""Branch-free float64 elementary functions and the Philox4x32-10 generator, for numba.

Helpers of :mod:`tmaplan.estimators.pf_numba` (the particle filter's compiled
kernels). Every function here is scalar and free of branches and calls, so that the loops of
the kernels that inline it vectorise without a vector math library (the same code, hence the
same bits, whatever the SIMD width):

* :func:`philox`: Philox4x32-10 (Salmon, Moraes, Dror & Shaw 2011, "Parallel random numbers:
  as easy as 1, 2, 3"), checked against Random123's known-answer vectors in the tests;
* :func:`box_muller_f32`: Box–Muller (Box & Muller 1958, "A note on the generation of random
  normal deviates", Ann. Math. Stat. 29(2)) on two 32-bit words, in float32 (:func:`_log32`,
  :func:`_sincos_turn32`: Cephes' logf.c, sinf.c, cosf.c, their polynomials evaluated with
  fused multiply-adds, :func:`fma`, 15 % faster than separate roundings and as reproducible:
  LLVM's ``llvm.fma`` rounds once in scalar and in vector code alike);
* :func:`fast_log`, :func:`_atan01` / :func:`abs_atan2`, :func:`fast_exp`: fdlibm's (e_log.c,
  e_exp.c) and Cephes' (atan.c) float64 polynomials.

All accurate to about 1 ulp of their type (tested against numpy).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

try:
    import numba
    from llvmlite import ir
    from numba import get_num_threads, njit, prange, set_num_threads
    from numba.core import types
    from numba.extending import intrinsic
except ImportError as exc:  # a declared dependency: say so plainly
    raise ImportError("the particle filter's numba kernel needs numba, a dependency of tmaplan "
                      "(pip install 'numba>=0.60'); PFConfig(kernel='numpy') runs without it"
                      ) from exc

__all__ = ["MASK32", "SH32", "U64", "abs_atan2", "box_muller_f32", "fast_exp", "fast_log",
           "fma", "get_num_threads", "njit", "numba", "philox", "prange", "set_num_threads"]

U64 = np.uint64
MASK32 = U64(0xFFFFFFFF)
SH32 = U64(32)
_PHILOX_M0, _PHILOX_M1 = U64(0xD2511F53), U64(0xCD9E8D57)
_PHILOX_W0, _PHILOX_W1 = U64(0x9E3779B9), U64(0xBB67AE85)

# fdlibm e_log.c
_LN2_HI, _LN2_LO = 6.93147180369123816490e-01, 1.90821492927058770002e-10
_LG1, _LG2, _LG3 = 6.666666666666735130e-01, 3.999999999940941908e-01, 2.857142874366239149e-01
_LG4, _LG5 = 2.222219843214978396e-01, 1.818357216161805012e-01
_LG6, _LG7 = 1.531383769920937332e-01, 1.479819860511658591e-01
# Cephes logf.c, sinf.c, cosf.c (float32; sin and cos on |x| ≤ π/4)
_F = np.float32
_LF0, _LF1, _LF2 = _F(7.0376836292e-2), _F(-1.1514610310e-1), _F(1.1676998740e-1)
_LF3, _LF4, _LF5 = _F(-1.2420140846e-1), _F(1.4249322787e-1), _F(-1.6668057665e-1)
_LF6, _LF7, _LF8 = _F(2.0000714765e-1), _F(-2.4999993993e-1), _F(3.3333331174e-1)
_LFQ1, _LFQ2 = _F(-2.12194440e-4), _F(0.693359375)
_SF0, _SF1, _SF2 = _F(-1.9515295891e-4), _F(8.3321608736e-3), _F(-1.6666654611e-1)
_CF0, _CF1, _CF2 = _F(2.443315711809948e-5), _F(-1.388731625493765e-3), _F(4.166664568298827e-2)
_SQRTH_F, _ONE_F, _HALF_F, _M2_F = _F(0.70710678118654752), _F(1.0), _F(0.5), _F(-2.0)
_TURN_F = _F(2.0 * math.pi / 2.0**32)  # radians per unit of a 32-bit turn fraction
_TWO_M25_F = _F(2.0**-25)
# Cephes atan.c (|x| ≤ 0.66)
_AP0, _AP1 = -8.750608600031904122785e-01, -1.615753718733365076637e01
_AP2, _AP3 = -7.500855792314704667340e01, -1.228866684490136173410e02
_AP4 = -6.485021904942025371773e01
_AQ0, _AQ1 = 2.485846490142306297962e01, 1.650270098316988542046e02
_AQ2, _AQ3 = 4.328810604912902668951e02, 4.853903996359136964868e02
_AQ4 = 1.945506571482613964425e02
_MOREBITS = 6.123233995736765886130e-17
# fdlibm e_exp.c
_INV_LN2 = 1.44269504088896338700e00
_EP1, _EP2 = 1.66666666666666019037e-01, -2.77777777770155933842e-03
_EP3, _EP4 = 6.61375632143793436117e-05, -1.65339022054652515390e-06
_EP5 = 4.13813679705723846039e-08

_HALF_PI, _PI = 0.5 * math.pi, math.pi


# --------------------------------------------------------------------------------------------
# Elementary functions (scalar, inlined, branch-free: they vectorise inside the block loops)
# --------------------------------------------------------------------------------------------
# Inlined by numba (``inline="always"``), not cached: a function compiled on its own (cached,
# or called from Python first) is linked into its callers as a finished library that LLVM may
# not inline, and the kernels' loops would then not vectorise (4× slower), depending on what
# was compiled first. Inlined, each kernel holds its own copy (and caches it).


def _bits_typer(typingctx: Any, x: Any) -> Any:
    """The IEEE bits of a float64, as an int64 (an LLVM bitcast)."""
    if not isinstance(x, types.Float):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


def _from_bits_typer(typingctx: Any, x: Any) -> Any:
    """The float64 of given IEEE bits (an int64; an LLVM bitcast)."""
    if not isinstance(x, types.Integer):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


def _bits32_typer(typingctx: Any, x: Any) -> Any:
    """The IEEE bits of a float32, as an int32 (an LLVM bitcast)."""
    if not isinstance(x, types.Float):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.bitcast(args[0], ir.IntType(32))

    return types.int32(types.float32), codegen


def _from_bits32_typer(typingctx: Any, x: Any) -> Any:
    """The float32 of given IEEE bits (an int32; an LLVM bitcast)."""
    if not isinstance(x, types.Integer):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.bitcast(args[0], ir.FloatType())

    return types.float32(types.int32), codegen


def _fma_typer(typingctx: Any, a: Any, b: Any, c: Any) -> Any:
    """``a·b + c`` rounded once (LLVM's ``llvm.fma``: the same bits in scalar and vector code,
    one instruction on a CPU with FMA), for three floats of one type."""
    if not (isinstance(a, types.Float) and a == b == c):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        ty = args[0].type
        fn = builder.module.declare_intrinsic("llvm.fma", [ty], ir.FunctionType(ty, [ty] * 3))
        return builder.call(fn, args)

    return a(a, a, a), codegen


_bits: Any = intrinsic(_bits_typer)
_from_bits: Any = intrinsic(_from_bits_typer)
_bits32: Any = intrinsic(_bits32_typer)
_from_bits32: Any = intrinsic(_from_bits32_typer)
fma: Any = intrinsic(_fma_typer)


@njit(inline="always")
def philox(c0: Any, c1: Any, c2: Any, c3: Any, k0: Any, k1: Any) -> tuple[Any, Any, Any, Any]:
    """Philox4x32-10 of counter (c0, c1, c2, c3) under key (k0, k1): 4 words < 2³² (uint64)."""
    for _ in range(10):
        p0 = _PHILOX_M0 * c0
        p1 = _PHILOX_M1 * c2
        c0, c1, c2, c3 = ((p1 >> SH32) ^ c1 ^ k0, p1 & MASK32,
                          (p0 >> SH32) ^ c3 ^ k1, p0 & MASK32)
        k0 = (k0 + _PHILOX_W0) & MASK32
        k1 = (k1 + _PHILOX_W1) & MASK32
    return c0, c1, c2, c3


@njit(inline="always")
def fast_log(x: float) -> float:
    """ln x for a normal float64 x > 0 (fdlibm's e_log.c, < 1 ulp), branch-free."""
    b = _bits(x)
    e = (b >> 52) - 1023
    m = _from_bits((b & 0x000FFFFFFFFFFFFF) | 0x3FF0000000000000)  # [1, 2)
    big = m > 1.4142135623730951
    m = m * 0.5 if big else m
    e = e + 1 if big else e
    f = m - 1.0
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    r = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7))) + w * (_LG2 + w * (_LG4 + w * _LG6))
    hfsq = 0.5 * f * f
    dk = float(e)
    return dk * _LN2_HI - ((hfsq - (s * (hfsq + r) + dk * _LN2_LO)) - f)


@njit(inline="always")
def _log32(x: Any) -> Any:
    """ln x for a normal float32 x > 0 (Cephes' logf.c, ≈ 1 ulp of float32), branch-free."""
    b = _bits32(x)
    e = (b >> 23) - 126  # x = m 2^e, m ∈ [½, 1)
    m = _from_bits32(np.int32((b & 0x007FFFFF) | 0x3F000000))
    small = m < _SQRTH_F
    e = e - 1 if small else e
    f = (m + m - _ONE_F) if small else (m - _ONE_F)
    z = f * f
    p = fma(fma(fma(fma(_LF0, f, _LF1), f, _LF2), f, _LF3), f, _LF4)
    p = fma(fma(fma(fma(p, f, _LF5), f, _LF6), f, _LF7), f, _LF8)
    y = p * f * z
    fe = _F(e)
    y = fma(-_HALF_F, z, fma(_LFQ1, fe, y))
    return fma(_LFQ2, fe, f + y)


@njit(inline="always")
def _sincos_turn32(k: Any) -> tuple[Any, Any]:
    """float32 (sin φ, cos φ) of φ = 2π k/2³² for an integer 0 ≤ k < 2³²: exact reduction to
    the nearest quarter turn, Cephes' sinf/cosf polynomials on [−π/4, π/4] (≈ 1 ulp)."""
    qb = (k + U64(0x20000000)) >> U64(30)  # nearest quarter turn, 0..4
    x = _F(np.int64(k) - np.int64(qb << U64(30))) * _TURN_F
    z = x * x
    s = fma(fma(fma(_SF0, z, _SF1), z, _SF2) * z, x, x)
    c = fma(fma(fma(_CF0, z, _CF1), z, _CF2) * z, z, fma(-_HALF_F, z, _ONE_F))
    q = qb & U64(3)
    odd = (q & U64(1)) != U64(0)
    sq = c if odd else s
    cq = s if odd else c
    sq = -sq if q >= U64(2) else sq
    cq = -cq if (q == U64(1) or q == U64(2)) else cq
    return sq, cq


@njit(inline="always")
def box_muller_f32(a: Any, b: Any) -> tuple[float, float]:
    """Two independent standard normals from two 32-bit words: Box–Muller in float32 (as the
    numpy kernel's default noise), ``u = (2⌊a/2⁸⌋ + 1)/2²⁵`` so that ``ln u`` is finite: the
    radius is at most 5.89, the Gaussian mass beyond (2⁻²⁵ ≈ 3·10⁻⁸ per pair) not drawn."""
    u = _F(np.int64(((a >> U64(8)) << U64(1)) | U64(1))) * _TWO_M25_F
    rho = np.sqrt(_M2_F * _log32(u))
    s, c = _sincos_turn32(b)
    return float(rho * c), float(rho * s)


@njit(inline="always")
def _atan01(t: float) -> float:
    """atan t for 0 ≤ t ≤ 1 (Cephes atan.c, ≈ 1 ulp), branch-free."""
    big = t > 0.66
    x = (t - 1.0) / (t + 1.0) if big else t
    z = x * x
    p = (((_AP0 * z + _AP1) * z + _AP2) * z + _AP3) * z + _AP4
    q = ((((z + _AQ0) * z + _AQ1) * z + _AQ2) * z + _AQ3) * z + _AQ4
    y = x * (z * p / q) + x
    return (0.25 * _PI + y) + 0.5 * _MOREBITS if big else y


@njit(inline="always")
def abs_atan2(s: float, c: float) -> float:
    """|atan2(s, c)| ∈ [0, π] (0 for s = c = 0)."""
    a = abs(s)
    b = abs(c)
    num = min(a, b)
    den = max(a, b)
    phi = _atan01(num / (den if den > 0.0 else 1.0))
    phi = _HALF_PI - phi if a > b else phi
    return _PI - phi if c < 0.0 else phi


@njit(inline="always")
def fast_exp(x: float) -> float:
    """e^x for x ≤ 0 (−inf allowed; fdlibm's e_exp.c, < 1 ulp; 0 below −708)."""
    xc = max(x, -709.0)
    kf = math.floor(xc * _INV_LN2 + 0.5)
    hi = xc - kf * _LN2_HI
    lo = kf * _LN2_LO
    r = hi - lo
    t = r * r
    c = r - t * (_EP1 + t * (_EP2 + t * (_EP3 + t * (_EP4 + t * _EP5))))
    y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi)
    y = y * _from_bits((np.int64(kf) + 1023) << 52)
    return y if x > -708.0 else 0.0
