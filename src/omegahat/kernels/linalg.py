"""Small dense matrices for the compiled kernels (the MEKF's 6 × 6 covariance and 12 × 12 Van Loan matrix).

Products are explicit loops (no BLAS call overhead, the same summation order as the textbook product); the
exponential is a degree-12 Taylor polynomial after scaling to ``‖M/2^s‖₁ ≤ 0.5`` (truncation below
``0.5¹³/13! ≈ 2e-14`` relative), squared s times, for block upper-triangular matrices whose products skip the zero
lower-left block; symmetric positive definite systems are solved by Cholesky.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["expm_block_upper", "mm", "mm_block_upper", "solve_spd", "transpose"]


@numba.njit(cache=True)
def mm(A, B):
    """A @ B by loops (summed over k in order, like the textbook product)."""
    n, m, p = A.shape[0], A.shape[1], B.shape[1]
    C = np.zeros((n, p))
    for i in range(n):
        for k in range(m):
            a = A[i, k]
            for j in range(p):
                C[i, j] += a * B[k, j]
    return C


@numba.njit(cache=True)
def transpose(A):
    n, m = A.shape
    T = np.empty((m, n))
    for i in range(n):
        for j in range(m):
            T[j, i] = A[i, j]
    return T


@numba.njit(cache=True)
def mm_block_upper(A, B, C, n):
    """C = A @ B for ``2n × 2n`` block upper-triangular A, B (lower-left blocks exactly 0), which the Van Loan
    matrix of (E4) and all its powers are: the products with the zero blocks are skipped (3 of the 8 block
    products are done); every other term is summed in the order of the textbook full product, to which the
    result is identical (the skipped terms are exact zeros)."""
    N = 2 * n
    for i in range(N):
        for j in range(N):
            C[i, j] = 0.0
    for i in range(n):
        for k in range(N):
            a = A[i, k]
            for j in range(0 if k < n else n, N):
                C[i, j] += a * B[k, j]
    for i in range(n, N):
        for k in range(n, N):
            a = A[i, k]
            for j in range(n, N):
                C[i, j] += a * B[k, j]


@numba.njit(cache=True)
def expm_block_upper(M, n):
    """The matrix exponential (degree-12 Taylor, scaled to ‖M/2^s‖₁ ≤ 0.5, squared s times) of a ``2n × 2n`` block
    upper-triangular M, with :func:`mm_block_upper` for the products."""
    N = M.shape[0]
    norm = 0.0
    for j in range(N):
        c = 0.0
        for i in range(N):
            c += abs(M[i, j])
        norm = max(norm, c)
    s = max(0, int(np.ceil(np.log2(norm / 0.5)))) if norm > 0.5 else 0
    A = M / 2.0**s
    E = np.eye(N)
    term = np.eye(N)
    prod = np.empty((N, N))
    for k in range(1, 13):
        mm_block_upper(term, A, prod, n)
        term = prod / k
        E = E + term
    for _ in range(s):
        mm_block_upper(E, E, prod, n)
        E = prod.copy()
    return E


@numba.njit(cache=True)
def solve_spd(S, B):
    """S⁻¹ B for symmetric positive definite S, by Cholesky S = L Lᵀ and two triangular solves."""
    m, p = B.shape
    L = np.zeros((m, m))
    for j in range(m):
        d = S[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, m):
            v = S[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / L[j, j]
    X = B.copy()
    for c in range(p):
        for i in range(m):  # L y = b
            v = X[i, c]
            for k in range(i):
                v -= L[i, k] * X[k, c]
            X[i, c] = v / L[i, i]
        for i in range(m - 1, -1, -1):  # Lᵀ x = y
            v = X[i, c]
            for k in range(i + 1, m):
                v -= L[k, i] * X[k, c]
            X[i, c] = v / L[i, i]
    return X
