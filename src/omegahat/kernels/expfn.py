r"""The exponential and the φ-functions for the compiled kernels: plain arithmetic, the same bits scalar and SIMD.

**The exponential.** libm's ``exp`` is a call: in the lockstep engine (:mod:`omegahat.simulation.engine`) it had
to be taken lane by lane, outside the vectorised loops. :func:`exp_kernel` is written with multiplications,
additions and integer operations on the bit patterns only, so LLVM vectorises the lane loops that call it, and a
run gets the same bits whether its lane loop is vectorised or not (the kernels are compiled without fast-math: no
fused multiply-adds, no reassociation).

Method (Cody & Waite's argument reduction, as in fdlibm's ``e_exp.c``):

* ``k = round(x / ln 2)``, by adding and subtracting ``1.5·2⁵²`` (the sum's last bit is the integer k, for
  ``|x/ln 2| < 2⁵¹``);
* ``r = (x − k ln2_hi) − k ln2_lo`` with ``ln2_hi`` the 32 leading bits of ln 2 (``k ln2_hi`` is exact for
  ``|k| < 2²¹``) and ``ln2_lo = ln 2 − ln2_hi``: ``|r| ≤ ln2/2 + 1e-16``;
* ``e^r`` by its Taylor polynomial of degree 13 (Horner): the first omitted term, ``r¹⁴/14! ≤ 4.5e-18``, is far
  below the rounding of the sum, about 2⁻⁵³;
* ``e^x = e^r · 2^{k₁} · 2^{k₂}`` with ``k₁ = ⌊k/2⌋``, ``k₂ = k − k₁``, each power of two built from its bit pattern
  ``(k_j + 1023) · 2⁵²`` (two factors keep each one a normal number down to ``x = −745``, where e^x is the
  smallest subnormal; multiplying by a power of two is exact while the product is normal).

Domain: ``x ≤ 709`` (no overflow handling); ``x < −745.2`` is taken as −745.2 (e^x rounds to 0 or the smallest
subnormal there); NaN gives NaN. Accuracy against ``numpy.exp``: within 2 units in the last place on ``[−745, 709]``
(``tests/test_exp.py``, which also checks it against 40-digit ``decimal`` arithmetic).

**The φ-functions** of exponential integrators, ``φ₀(x) = eˣ`` and ``φ_k(x) = Σ_j x^j/(j + k)!``, i.e.
``φ₁ = (eˣ − 1)/x``, ``φ₂ = (eˣ − 1 − x)/x²``, ``φ₃ = (eˣ − 1 − x − x²/2)/x³``: by their closed forms for
``|x| ≥ 1/2`` and by their Taylor series (Horner, degree 16: the first omitted term is below 1.2e-21) below, where
the closed forms cancel.

**sin and cos of small angles** (|x| ≤ 1/4) by their Taylor polynomials (degree 11 and 12), accurate to rounding:
plain arithmetic again, for the torque's sinusoids in the engine's lane loops.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

__all__ = [
    "PHI_TAYLOR_BELOW",
    "SINCOS_SMALL",
    "exp_kernel",
    "phi1_half_closed",
    "phi1_taylor",
    "phi123",
    "phi123_closed",
    "phi123_taylor",
    "sin_cos_small",
]

_SHIFT = 6755399441055744.0  # 1.5·2⁵²: x + _SHIFT rounds x to an integer held in the last bits of the sum
_INV_LN2 = 1.4426950408889634
_LN2_HI = 6.93147180369123816490e-01  # 0x3fe62e42fee00000: ln 2 to 32 bits, so k·_LN2_HI is exact
_LN2_LO = 1.90821492927058770002e-10  # ln 2 − _LN2_HI
_X_MIN = -745.2  # below: e^x < the smallest subnormal / 2


@intrinsic
def _bits_of(typingctx, x):
    """The IEEE-754 bit pattern of a float64, as an int64 (a bitcast: no instruction)."""
    if x != types.float64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def _float_of(typingctx, b):
    """The float64 whose bit pattern is the int64 ``b``."""
    if b != types.int64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


@numba.njit(cache=True, inline="always", error_model="numpy")
def exp_kernel(x):
    """e^x for x ≤ 709 by plain arithmetic (module docstring): the same bits wherever it is inlined."""
    x = x if not x < _X_MIN else _X_MIN  # NaN passes through
    shifted = x * _INV_LN2 + _SHIFT
    kf = shifted - _SHIFT
    k = _bits_of(shifted) - _bits_of(_SHIFT)
    r = (x - kf * _LN2_HI) - kf * _LN2_LO
    p = 1.0 + r * (
        1.0
        + r
        * (
            1.0 / 2
            + r
            * (
                1.0 / 6
                + r
                * (
                    1.0 / 24
                    + r
                    * (
                        1.0 / 120
                        + r
                        * (
                            1.0 / 720
                            + r
                            * (
                                1.0 / 5040
                                + r
                                * (
                                    1.0 / 40320
                                    + r
                                    * (
                                        1.0 / 362880
                                        + r
                                        * (
                                            1.0 / 3628800
                                            + r * (1.0 / 39916800 + r * (1.0 / 479001600 + r * (1.0 / 6227020800)))
                                        )
                                    )
                                )
                            )
                        )
                    )
                )
            )
        )
    )
    k1 = k >> 1
    k2 = k - k1
    return p * _float_of((k1 + 1023) << 52) * _float_of((k2 + 1023) << 52)


# Taylor coefficients 1/(j + k)! of φ_k(x) = Σ_j x^j/(j + k)!, k = 1, 2, 3, j = 0..16: for |x| < 1/2 the first
# omitted term is below 2^-17/18! < 1.2e-21, far under the rounding of the sum.
_PHI_DEGREE = 16
_PHI1_TAYLOR = np.array([1.0 / math.factorial(j + 1) for j in range(_PHI_DEGREE + 1)])
_PHI2_TAYLOR = np.array([1.0 / math.factorial(j + 2) for j in range(_PHI_DEGREE + 1)])
_PHI3_TAYLOR = np.array([1.0 / math.factorial(j + 3) for j in range(_PHI_DEGREE + 1)])
PHI_TAYLOR_BELOW = 0.5  #: |x| below which the φ-functions are taken from their Taylor series


@numba.njit(cache=True, inline="always", error_model="numpy")
def phi123_taylor(x):
    """φ₁, φ₂, φ₃ and exp of x by the Taylor series (Horner), for |x| < 1/2 where the closed forms cancel."""
    t1 = _PHI1_TAYLOR[_PHI_DEGREE]
    t2 = _PHI2_TAYLOR[_PHI_DEGREE]
    t3 = _PHI3_TAYLOR[_PHI_DEGREE]
    for j in range(_PHI_DEGREE - 1, -1, -1):
        t1 = t1 * x + _PHI1_TAYLOR[j]
        t2 = t2 * x + _PHI2_TAYLOR[j]
        t3 = t3 * x + _PHI3_TAYLOR[j]
    return t1, t2, t3, 1.0 + x * t1


@numba.njit(cache=True, inline="always", error_model="numpy")
def phi123_closed(x, ex):
    """φ₁, φ₂, φ₃ and exp of x by the closed forms, given ``ex = exp(x)`` (|x| ≥ 1/2); one division (1/x), the
    powers of 1/x by multiplication (a division costs several multiplications' time, and divisions and square
    roots share one unit)."""
    inv = 1.0 / x
    e1 = ex - 1.0
    return e1 * inv, (e1 - x) * (inv * inv), (e1 - x - 0.5 * x * x) * (inv * inv * inv), ex


@numba.njit(cache=True, inline="always", error_model="numpy")
def phi1_half_closed(x, ex2):
    """φ₁(x/2) = (e^{x/2} − 1)·(2/x) given ``ex2 = e^{x/2}`` (|x/2| ≥ 1/2), through the 1/x of
    :func:`phi123_closed` (LLVM computes the shared division once when both are inlined)."""
    return (ex2 - 1.0) * (2.0 * (1.0 / x))


@numba.njit(cache=True, inline="always", error_model="numpy")
def phi1_taylor(x):
    """φ₁ and exp of x by the Taylor series, as :func:`phi123_taylor`."""
    t1 = _PHI1_TAYLOR[_PHI_DEGREE]
    for j in range(_PHI_DEGREE - 1, -1, -1):
        t1 = t1 * x + _PHI1_TAYLOR[j]
    return t1, 1.0 + x * t1


@numba.njit(cache=True)
def phi123(x):
    """φ₁, φ₂, φ₃ and exp of x ≤ 0: :func:`phi123_taylor` for |x| < 1/2, :func:`phi123_closed` beyond."""
    if abs(x) < PHI_TAYLOR_BELOW:
        return phi123_taylor(x)
    return phi123_closed(x, exp_kernel(x))


SINCOS_SMALL = 0.25  #: |x| up to which :func:`sin_cos_small` is accurate (first omitted terms below 3e-18)


@numba.njit(cache=True, inline="always", error_model="numpy")
def sin_cos_small(x):
    """sin x and cos x by their Taylor polynomials (degree 11 and 12, Horner in x²), accurate to rounding for
    |x| ≤ 1/4."""
    x2 = x * x
    s = x * (
        1.0
        + x2
        * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362880.0 + x2 * (-1.0 / 39916800.0)))))
    )
    c = 1.0 + x2 * (
        -0.5
        + x2
        * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0 + x2 * (-1.0 / 3628800.0 + x2 * (1.0 / 479001600.0)))))
    )
    return s, c
