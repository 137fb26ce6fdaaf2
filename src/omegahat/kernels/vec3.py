"""3-vectors and 3×3 matrices as plain scalars, for the compiled kernels.

Vectors are passed and returned as three floats and 3×3 matrices as a 9-tuple in row-major order (``mat3``):
after inlining, LLVM keeps them in registers, vectorises the lane loops that call them, and hoists a matrix's
loads out of a loop (it cannot prove that an array is not written through another array). Every function performs
its operations in the order written (no fast-math), so kernels that call it get the same bits whether LLVM inlines
it or not. None is inlined at Numba's IR level (``inline="always"``): that copied each 3×3 product's typed IR into
every call site and tripled the EKF's compile time (``benchmarks/first_run.py``); the matrix ones are
``forceinline`` instead (compiled once, always inlined by LLVM).
"""

from __future__ import annotations

import math

import numba

__all__ = [
    "cross", "det", "dot", "inverse", "lincomb", "mat3", "matmul", "matvec", "matvec_transposed", "norm", "polished",
    "skew", "solve", "transposed",
]  # fmt: skip


@numba.njit(cache=True, error_model="numpy")
def mat3(A):
    """The 3×3 array ``A`` as a row-major 9-tuple."""
    return (A[0, 0], A[0, 1], A[0, 2], A[1, 0], A[1, 1], A[1, 2], A[2, 0], A[2, 1], A[2, 2])


@numba.njit(cache=True, error_model="numpy")
def cross(a0, a1, a2, b0, b1, b2):
    """``a × b``."""
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@numba.njit(cache=True, error_model="numpy")
def dot(a0, a1, a2, b0, b1, b2):
    """``a · b``, summed left to right."""
    return a0 * b0 + a1 * b1 + a2 * b2


@numba.njit(cache=True, error_model="numpy")
def norm(a0, a1, a2):
    """``|a|``."""
    return math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)


@numba.njit(cache=True, error_model="numpy")
def matvec(M, x0, x1, x2):
    """``M x`` for a 9-tuple ``M`` (:func:`mat3`), each row summed left to right."""
    return (
        M[0] * x0 + M[1] * x1 + M[2] * x2,
        M[3] * x0 + M[4] * x1 + M[5] * x2,
        M[6] * x0 + M[7] * x1 + M[8] * x2,
    )


@numba.njit(cache=True, error_model="numpy")
def matvec_transposed(M, x0, x1, x2):
    """``Mᵀ x`` for a 9-tuple ``M``, each component summed left to right (``r_i = Rᵀ v_i``: a direction seen in
    the body)."""
    return (
        M[0] * x0 + M[3] * x1 + M[6] * x2,
        M[1] * x0 + M[4] * x1 + M[7] * x2,
        M[2] * x0 + M[5] * x1 + M[8] * x2,
    )


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def solve(M, y0, y1, y2):
    """``M⁻¹ y`` by the adjugate (Cramer's rule, :func:`inverse`), for a well-conditioned 9-tuple ``M``."""
    return matvec(inverse(M), y0, y1, y2)


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def matmul(A, B):
    """``A B`` for 9-tuples, each entry summed left to right."""
    return (
        A[0] * B[0] + A[1] * B[3] + A[2] * B[6], A[0] * B[1] + A[1] * B[4] + A[2] * B[7],
        A[0] * B[2] + A[1] * B[5] + A[2] * B[8], A[3] * B[0] + A[4] * B[3] + A[5] * B[6],
        A[3] * B[1] + A[4] * B[4] + A[5] * B[7], A[3] * B[2] + A[4] * B[5] + A[5] * B[8],
        A[6] * B[0] + A[7] * B[3] + A[8] * B[6], A[6] * B[1] + A[7] * B[4] + A[8] * B[7],
        A[6] * B[2] + A[7] * B[5] + A[8] * B[8],
    )  # fmt: skip


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def polished(R):
    """``R (3I − RᵀR)/2`` for a 9-tuple ``R`` near a rotation: one Newton–Schulz step towards its polar factor (the
    nearest rotation), which turns a deviation ε of ``RᵀR`` from I into about ``3ε²/4``."""
    G = matmul(transposed(R), R)
    return matmul(R, lincomb(1.5, (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), -0.5, G))


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def det(M):
    """``det M`` of a 9-tuple, by the first row's cofactors."""
    return M[0] * (M[4] * M[8] - M[5] * M[7]) + M[1] * (M[5] * M[6] - M[3] * M[8]) + M[2] * (M[3] * M[7] - M[4] * M[6])


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def inverse(M):
    """``M⁻¹`` by the adjugate, for a well-conditioned 9-tuple ``M``."""
    c00 = M[4] * M[8] - M[5] * M[7]
    c01 = M[5] * M[6] - M[3] * M[8]
    c02 = M[3] * M[7] - M[4] * M[6]
    det = M[0] * c00 + M[1] * c01 + M[2] * c02
    c10 = M[2] * M[7] - M[1] * M[8]
    c11 = M[0] * M[8] - M[2] * M[6]
    c12 = M[1] * M[6] - M[0] * M[7]
    c20 = M[1] * M[5] - M[2] * M[4]
    c21 = M[2] * M[3] - M[0] * M[5]
    c22 = M[0] * M[4] - M[1] * M[3]
    return (c00 / det, c10 / det, c20 / det, c01 / det, c11 / det, c21 / det, c02 / det, c12 / det, c22 / det)


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def skew(a0, a1, a2):
    """``a×`` as a 9-tuple: ``skew(a) x = a × x``."""
    return (0.0, -a2, a1, a2, 0.0, -a0, -a1, a0, 0.0)


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def transposed(A):
    """``Aᵀ`` of a 9-tuple."""
    return (A[0], A[3], A[6], A[1], A[4], A[7], A[2], A[5], A[8])


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def lincomb(a, A, b, B):
    """``a A + b B`` for 9-tuples and scalars a, b."""
    return (
        a * A[0] + b * B[0], a * A[1] + b * B[1], a * A[2] + b * B[2], a * A[3] + b * B[3], a * A[4] + b * B[4],
        a * A[5] + b * B[5], a * A[6] + b * B[6], a * A[7] + b * B[7], a * A[8] + b * B[8],
    )  # fmt: skip
