"""Branch-free float64 elementary functions and the Philox4x32-10 generator, for numba.

Private helpers of :mod:`tmaplan.estimators._pf_numba` (the particle filter's compiled
kernels). Every function here is scalar and free of branches and calls, so that the loops of
the kernels that inline it vectorise without a vector math library (the same code, hence the
same bits, whatever the SIMD width):

* :func:`_philox`: Philox4x32-10 (Salmon, Moraes, Dror & Shaw 2011, "Parallel random numbers:
  as easy as 1, 2, 3"), checked against Random123's known-answer vectors in the tests;
* :func:`_normals`: Box–Muller on two 32-bit words;
* :func:`_log`, :func:`_sincos_turn`, :func:`_atan01` / :func:`_abs_atan2`, :func:`_exp`:
  fdlibm's (e_log.c, k_sin.c, k_cos.c, e_exp.c) and Cephes' (atan.c) polynomials, accurate to
  about 1 ulp (tested against numpy).
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

__all__ = ["get_num_threads", "njit", "numba", "prange", "set_num_threads"]

_U = np.uint64
_MASK32 = _U(0xFFFFFFFF)
_SH32 = _U(32)
_PHILOX_M0, _PHILOX_M1 = _U(0xD2511F53), _U(0xCD9E8D57)
_PHILOX_W0, _PHILOX_W1 = _U(0x9E3779B9), _U(0xBB67AE85)

# fdlibm e_log.c
_LN2_HI, _LN2_LO = 6.93147180369123816490e-01, 1.90821492927058770002e-10
_LG1, _LG2, _LG3 = 6.666666666666735130e-01, 3.999999999940941908e-01, 2.857142874366239149e-01
_LG4, _LG5 = 2.222219843214978396e-01, 1.818357216161805012e-01
_LG6, _LG7 = 1.531383769920937332e-01, 1.479819860511658591e-01
# fdlibm k_sin.c, k_cos.c (|x| ≤ π/4)
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
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

_TURN = 2.0 * math.pi / 2.0**32  # radians per unit of a 32-bit turn fraction
_TWO_M32 = 2.0**-32
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


_bits: Any = intrinsic(_bits_typer)
_from_bits: Any = intrinsic(_from_bits_typer)


@njit(inline="always")
def _philox(c0: Any, c1: Any, c2: Any, c3: Any, k0: Any, k1: Any) -> tuple[Any, Any, Any, Any]:
    """Philox4x32-10 of counter (c0, c1, c2, c3) under key (k0, k1): 4 words < 2³² (uint64)."""
    for _ in range(10):
        p0 = _PHILOX_M0 * c0
        p1 = _PHILOX_M1 * c2
        c0, c1, c2, c3 = ((p1 >> _SH32) ^ c1 ^ k0, p1 & _MASK32,
                          (p0 >> _SH32) ^ c3 ^ k1, p0 & _MASK32)
        k0 = (k0 + _PHILOX_W0) & _MASK32
        k1 = (k1 + _PHILOX_W1) & _MASK32
    return c0, c1, c2, c3


@njit(inline="always")
def _log(x: float) -> float:
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
def _sincos_turn(k: Any) -> tuple[float, float]:
    """(sin φ, cos φ) of φ = 2π k/2³² for an integer 0 ≤ k < 2³²: exact reduction to the
    nearest quarter turn, fdlibm's kernels on [−π/4, π/4] (< 1 ulp)."""
    qb = (k + _U(0x20000000)) >> _U(30)  # nearest quarter turn, 0..4
    x = float(np.int64(k) - np.int64(qb << _U(30))) * _TURN
    z = x * x
    s = x + (z * x) * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    hz = 0.5 * z
    w = 1.0 - hz
    c = w + (((1.0 - w) - hz) + z * (z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (
        _C5 + z * _C6)))))))
    q = qb & _U(3)
    odd = (q & _U(1)) != _U(0)
    sq = c if odd else s
    cq = s if odd else c
    sq = -sq if q >= _U(2) else sq
    cq = -cq if (q == _U(1) or q == _U(2)) else cq
    return sq, cq


@njit(inline="always")
def _normals(a: Any, b: Any) -> tuple[float, float]:
    """Two independent standard normals from two 32-bit words (Box–Muller)."""
    rho = math.sqrt(-2.0 * _log((float(a) + 0.5) * _TWO_M32))
    s, c = _sincos_turn(b)
    return rho * c, rho * s


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
def _abs_atan2(s: float, c: float) -> float:
    """|atan2(s, c)| ∈ [0, π] (0 for s = c = 0)."""
    a = abs(s)
    b = abs(c)
    num = min(a, b)
    den = max(a, b)
    phi = _atan01(num / (den if den > 0.0 else 1.0))
    phi = _HALF_PI - phi if a > b else phi
    return _PI - phi if c < 0.0 else phi


@njit(inline="always")
def _exp(x: float) -> float:
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
