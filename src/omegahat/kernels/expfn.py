r"""The exponential for the compiled kernels: plain arithmetic, so the same bits scalar and SIMD.

libm's ``exp`` is a call: in the lockstep kernel (:mod:`omegahat.simulation.engine`) it had to be taken lane by lane,
outside the vectorised loops, and was a tenth of a step's cost. :func:`exp_kernel` is written with
multiplications, additions and integer operations on the bit patterns only, so LLVM vectorises the lane loops
that call it, and the single-run kernel (:mod:`omegahat.simulation.coupled`), which calls the same function, gets the very
same bits for each run (no fused multiply-adds: the kernels are compiled without fast-math).

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
"""

from __future__ import annotations

import numba
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

__all__ = ["exp_kernel"]

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


@numba.njit(cache=True, inline="always")
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
