r"""Savitzky–Golay filtering on SO(3): a local polynomial fit of the attitude in the tangent space, offline.

Reference: M. Jongeneel, A. Saccon, "Geometric Savitzky–Golay filtering of noisy rotations on SO(3) with
simultaneous angular velocity and acceleration estimation", IEEE/RSJ IROS 2022 (the idea: fit a polynomial in
the Lie algebra over a sliding window, read the angular velocity from its derivative; window length and
polynomial order are the knobs). Written here from that idea, on rotation matrices (``R`` body → inertial, ω in
body axes), centred on each sample ``k`` with half-width ``n`` (window ``2n + 1`` samples)::

    φ_j = Log(R_kᵀ R_{k+j}),  τ_j = t_{k+j} − t_k,  j = −n … n           (the window seen from R_k)     (G1)
    p(τ) = Σ_{i=0..p} c_i τ^i  fitted to (τ_j, φ_j) by least squares, per component                    (G2)
    ω̂_k = J_r(c_0) c_1,   J_r(u) = I − (1 − cos|u|)/|u|² u× + (|u| − sin|u|)/|u|³ u×²                (G3)

(G3) is the body rate of ``R(t) = R_k Exp(p(t − t_k))`` at ``t_k`` (``J_r`` the right Jacobian of SO(3));
``c_0`` is the fit's offset at the centre, of the order of the noise, so ``ω̂_k ≈ c_1``. On uniform samples the
fit is the classical Savitzky–Golay derivative filter (:func:`scipy.signal.savgol_coeffs`) applied to the
``φ_j``; here the least squares of (G2) is solved per window on the valid samples, so that gaps (non-finite
samples), uneven times and the log's ends (a one-sided window) need no special case. A window with fewer
than ``order + 1`` valid samples, or whose centre is missing, gives NaN. Assumes each window turns by less than π
about any axis from its centre (``Log`` is unique), as any log-map method does.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat import so3
from omegahat.interface import Measurements

__all__ = ["SavitzkyGolayEstimator", "right_jacobian", "savgol_rate"]


def right_jacobian(u: ArrayLike) -> np.ndarray:
    """``J_r(u)`` of (G3) for rotation vectors ``u (..., 3)``, shape ``(..., 3, 3)`` (series near 0)."""
    u = np.asarray(u, dtype=float)
    a = np.linalg.norm(u, axis=-1)[..., None, None]
    small = a < 1e-4
    a_safe = np.where(small, 1.0, a)
    c1 = np.where(small, 0.5 - a**2 / 24, (1 - np.cos(a_safe)) / a_safe**2)
    c2 = np.where(small, 1 / 6 - a**2 / 120, (a_safe - np.sin(a_safe)) / a_safe**3)
    U = so3.hat(u)
    return np.eye(3) - c1 * U + c2 * (U @ U)


def _check_knobs(window, order):
    if int(window) != window or window < 3 or window % 2 == 0:
        raise ValueError(f"window must be an odd integer >= 3; got {window!r}")
    if int(order) != order or not 1 <= order < window:
        raise ValueError(f"order must be an integer in [1, window) = [1, {int(window)}); got {order!r}")


def savgol_rate(
    times: ArrayLike,
    attitudes: ArrayLike | Rotation,
    window: int = 11,
    order: int = 2,
    scalar_first: bool = False,
    rotation_tol: float = ms.ROTATION_TOL,
    quat_norm_tol: float = ms.QUAT_NORM_TOL,
) -> np.ndarray:
    """Body-frame ω̂ ``(T, 3)`` by (G1)–(G3): ``window`` samples (odd, ≥ 3), polynomial ``order`` (1 ≤ order <
    window; ``order = window − 1`` interpolates: the classical central-difference stencils). Attitudes as for
    every estimator (:func:`omegahat.measurements.checked_log`)."""
    _check_knobs(window, order)
    log = ms.checked_log(
        times, attitudes, scalar_first=scalar_first, rotation_tol=rotation_tol, quat_norm_tol=quat_norm_tol
    )
    return _savgol(log, int(window), int(order))


def _savgol(log: ms.CheckedLog, window: int, order: int) -> np.ndarray:
    t, R, valid = log.times, log.values, log.valid
    T, n, p = t.size, int(window) // 2, int(order)
    out = np.full((T, 3), np.nan)
    if T == 0:
        return out
    scale = float(np.median(np.diff(t))) if T > 1 else 1.0  # τ in samples: a well-conditioned fit
    offsets = np.arange(-n, n + 1)
    idx = np.clip(np.arange(T)[:, None] + offsets[None, :], 0, T - 1)  # (T, W)
    inside = (np.arange(T)[:, None] + offsets[None, :] >= 0) & (np.arange(T)[:, None] + offsets[None, :] < T)
    ok = inside & valid[idx] & valid[:, None]  # a missing centre has no tangent space to fit in
    Rc = np.where(valid[:, None, None], R, np.eye(3))
    Rw = np.where(ok[..., None, None], R[idx], np.eye(3))
    phi = so3.log(np.einsum("tji,twjk->twik", Rc, Rw))  # (T, W, 3): (G1)
    tau = (t[idx] - t[:, None]) / scale
    V = tau[..., None] ** np.arange(p + 1)  # (T, W, p+1) Vandermonde
    w = ok.astype(float)
    A = np.einsum("twi,tw,twj->tij", V, w, V)
    b = np.einsum("twi,tw,twc->tic", V, w, phi)
    enough = ok.sum(axis=1) >= p + 1
    A[~enough] = np.eye(p + 1)
    c = np.linalg.solve(A, b)  # (T, p+1, 3): (G2)
    omega = np.einsum("tij,tj->ti", right_jacobian(c[:, 0]), c[:, 1] / scale)  # (G3)
    out[enough] = omega[enough]
    return out


class SavitzkyGolayEstimator(ms.AttitudeBatchEstimator):
    """Savitzky–Golay filtering on SO(3), (G1)–(G3), behind the estimator contract: offline only (``run``).

    ``causal = False``. Where a window has too few valid samples, or its centre is missing, there is no estimate
    (status ``unavailable``). The parameters are keyword-only.

    Parameters
    ----------
    window : int, optional
        The window length in samples (odd, ≥ 3; default 11).
    order : int, optional
        The polynomial order (1 ≤ order < window; default 2; ``order = window − 1`` interpolates: the classical
        central-difference stencils).
    references, scalar_first, rotation_tol, quat_norm_tol : optional
        The inertial directions of direction input (each sample's least-squares attitude is differentiated), the
        quaternion order and the tolerances of the input checks (:mod:`omegahat.measurements`, the same for every
        estimator).

    Raises
    ------
    ValueError
        If ``window`` is not an odd integer ≥ 3 or ``order`` not an integer in ``[1, window)``.

    Examples
    --------
    Noisy attitudes (1 mrad per axis) of a body turning at a constant rate, 100 Hz:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import SavitzkyGolayEstimator
    >>> w = np.array([0.3, -0.2, 0.5])  # rad/s, body axes
    >>> t = np.arange(0.0, 2.0, 0.01)
    >>> noise = Rotation.from_rotvec(1e-3 * np.random.default_rng(0).standard_normal((t.size, 3)))
    >>> q = (Rotation.from_rotvec(np.outer(t, w)) * noise).as_quat()
    >>> est = SavitzkyGolayEstimator(window=31, order=2).run(t, q)
    >>> print(" ".join(f"{x:.2f}" for x in est.omega[100]))
    0.30 -0.20 0.50
    """

    def __init__(
        self,
        *,
        window: int = 11,
        order: int = 2,
        references: ArrayLike | None = None,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
    ) -> None:
        _check_knobs(window, order)
        self.window, self.order = int(window), int(order)
        super().__init__(
            references=references, scalar_first=scalar_first, rotation_tol=rotation_tol, quat_norm_tol=quat_norm_tol
        )

    def rates(self, log: ms.CheckedLog, data: Measurements) -> np.ndarray:
        """(G1)–(G3) at the log's times."""
        return _savgol(log, self.window, self.order)
