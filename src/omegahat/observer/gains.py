r"""Observer gains: the theorem's conditions, a design that meets them, and a check that says what fails.

The proof (observer.md, "Gains") needs, with ``J_m I ≤ J ≤ J_M I`` and ``|ω(t)| ≤ ω_M``:

* ``μ := λ_min(Σ k_i (I − v_i v_iᵀ)) > J_M (ω_M + 3/2)``, for unit directions ``v_i``. The matrix is
  ``−Σ k_i r_i×²`` at any attitude (``r_i = Rᵀ v_i`` only rotates it), so μ depends on the inertial geometry only.
  The paper prints the condition without the factor ``J_M``; its own choice ``k = 1 + (ω_M + 3/2) J_M`` follows
  the proof. Two orthonormal directions with equal k give μ = k; two at angle θ give ``μ = k (1 − |cos θ|)``.
* ``l_i(ω̂) > (|ω̂| + ω_M)(1 + (k_i/J_m)(1 + 2 k_i/J_m))`` for every ω̂. Written as the affine
  ``l_i(ω̂) = l_offset_i + l_slope_i |ω̂|`` this holds for all ω̂ exactly when
  ``l_slope_i ≥ c_i`` and ``l_offset_i > ω_M c_i`` with ``c_i = 1 + (k_i/J_m)(1 + 2 k_i/J_m)``.
  The theorem's gain is ``l_offset_i = l_i0 + ω_M c_i``, ``l_slope_i = c_i`` (the paper's ``l_i0 = 1``).

These conditions are sufficient, not necessary: much smaller constant ``l_i`` works in practice, and
:func:`check_gains` then warns (it never refuses) so the user knows the guarantee does not apply.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from omegahat.validation import as_directions, as_inertia, as_positive

__all__ = [
    "GainCheck",
    "GainConditionWarning",
    "ObserverGains",
    "check_gains",
    "inertia_bounds",
    "mu",
    "theorem_gains",
]


class GainConditionWarning(UserWarning):
    """Gains that do not satisfy the theorem's sufficient conditions (the global guarantee does not apply)."""


@dataclass(frozen=True)
class ObserverGains:
    """Gains of the observer for ``n`` directions: ``k_i`` and ``l_i(ω̂) = l_offset_i + l_slope_i |ω̂|``.

    Scalars given for ``l_slope`` are repeated for the ``n`` directions; :meth:`constant` builds constant gains
    from two scalars, :meth:`l` evaluates ``l_i(ω̂)``.

    Parameters
    ----------
    k : array_like
        The ``n`` positive gains ``k_i``.
    l_offset : array_like
        The ``n`` positive offsets ``l_offset_i`` of ``l_i(ω̂)``.
    l_slope : array_like, optional
        The non-negative slopes ``l_slope_i`` (one number: the same for every direction; default 0, constant
        ``l_i``).
    isotropic_rate : float, optional
        For the *sampled* estimator only (rad/s, default None): its correction then uses the matrix rate gain
        ``b M⁻¹`` instead of ``J⁻¹`` so that every error mode decays at ``b`` whatever the directions' geometry
        (``docs/theory/tuning.md``); the ``k_i`` then only weigh the directions against each other. The
        continuous observer of the paper has no such gain: the simulator and the campaigns ignore it.

    Raises
    ------
    ValueError
        If a gain is not positive and finite, or the arrays do not have ``n`` entries.

    Examples
    --------
    >>> from omegahat import ObserverGains
    >>> g = ObserverGains(k=[14.5, 14.5], l_offset=[1309.0, 1309.0], l_slope=436.0)
    >>> g.n, g.l_slope.tolist()
    (2, [436.0, 436.0])
    >>> g.l([0.0, 0.0, 1.0]).tolist()  # l_i at |ω̂| = 1 rad/s
    [1745.0, 1745.0]
    >>> c = ObserverGains.constant(2.0, 20.0, n=3)
    >>> c.k.tolist(), c.l_offset.tolist(), c.isotropic_rate
    ([2.0, 2.0, 2.0], [20.0, 20.0, 20.0], None)
    """

    k: np.ndarray
    l_offset: np.ndarray
    l_slope: np.ndarray = field(default=None)  # type: ignore[arg-type]
    isotropic_rate: float | None = None

    def __post_init__(self):
        k = as_positive(self.k, "k")
        n = k.size
        l_offset = as_positive(self.l_offset, "l", n)
        if self.l_slope is None:
            l_slope = np.zeros(n)
        else:
            l_slope = np.atleast_1d(np.asarray(self.l_slope, dtype=float))
            if l_slope.size == 1:
                l_slope = np.full(n, l_slope.item())
            if l_slope.shape != (n,) or not np.all(np.isfinite(l_slope)) or np.any(l_slope < 0):
                raise ValueError(f"l_slope must be {n} non-negative finite numbers; got {self.l_slope!r}")
        object.__setattr__(self, "k", k)
        object.__setattr__(self, "l_offset", l_offset)
        object.__setattr__(self, "l_slope", l_slope)
        if self.isotropic_rate is not None:
            object.__setattr__(self, "isotropic_rate", float(as_positive(self.isotropic_rate, "isotropic_rate")[0]))

    @classmethod
    def constant(cls, k: ArrayLike, l: ArrayLike, n: int = 2) -> ObserverGains:
        """Constant gains ``k_i = k``, ``l_i = l`` (scalars are repeated for ``n`` directions)."""
        k = np.atleast_1d(np.asarray(k, dtype=float))
        if k.size == 1:
            k = np.full(n, k.item())
        return cls(k=k, l_offset=np.broadcast_to(np.asarray(l, dtype=float), k.shape).copy())

    @property
    def n(self) -> int:
        return self.k.size

    def l(self, omega_hat: ArrayLike) -> np.ndarray:
        """``l_i(ω̂)`` for each direction."""
        return self.l_offset + self.l_slope * np.linalg.norm(omega_hat)


def inertia_bounds(J: ArrayLike) -> tuple[float, float]:
    """``(J_m, J_M)``: the smallest and largest eigenvalues of J."""
    eig = np.linalg.eigvalsh(as_inertia(J))
    return float(eig[0]), float(eig[-1])


def mu(k: ArrayLike, references: ArrayLike) -> float:
    """``λ_min(Σ k_i (I − v_i v_iᵀ))`` for the normalised inertial directions ``v_i``."""
    v = as_directions(references, min_angle_deg=0.0)
    k = as_positive(k, "k", v.shape[0])
    M = np.einsum("i,ijk->jk", k, np.eye(3)[None] - v[:, :, None] * v[:, None, :])
    return float(np.linalg.eigvalsh(M)[0])


def _l_factor(k, J_m):
    """``c_i = 1 + (k_i/J_m)(1 + 2 k_i/J_m)`` of the theorem's l-condition."""
    return 1.0 + (k / J_m) * (1.0 + 2.0 * k / J_m)


def theorem_gains(
    J: ArrayLike, omega_max: float, references: ArrayLike | None = None, margin: float = 1.0, l0: float = 1.0
) -> ObserverGains:
    """Equal gains ``k_i = k`` with ``μ = J_M (ω_M + 3/2) + margin`` and the theorem's ``l_i(ω̂)``.

    With the paper's numbers (J = diag(3, 2, 1), ω_M = 3, two rows, margin 1, l0 = 1) this gives the paper's
    ``k = 14.5`` and ``l_i(ω̂) = 1 + 436 (|ω̂| + 3)``.

    Parameters
    ----------
    J : array_like
        The inertia (3 numbers = diagonal, 9 numbers or 3×3), SPD.
    omega_max : float
        ω_M, the bound on ``|ω(t)|`` (rad/s) the guarantee is for.
    references : array_like, optional
        The measured inertial directions ``(n, 3)`` (default: the first two rows of R, as in the paper).
    margin : float, optional
        By how much μ exceeds ``J_M (ω_M + 3/2)`` (default 1).
    l0 : float, optional
        The paper's ``l_i0``: ``l_offset_i = l0 + ω_M c_i`` (default 1).

    Returns
    -------
    ObserverGains
        ``k_i = k``, ``l_offset_i = l0 + ω_M c_i``, ``l_slope_i = c_i`` with ``c_i = 1 + (k/J_m)(1 + 2k/J_m)``.

    Raises
    ------
    ValueError
        If the reference directions span a single axis (no k satisfies the μ condition).

    Examples
    --------
    >>> from omegahat import check_gains, theorem_gains
    >>> J = [3.0, 2.0, 1.0]
    >>> g = theorem_gains(J, omega_max=3.0)
    >>> print(f"k = {g.k[0]:.1f}, l = {g.l_offset[0]:.0f} + {g.l_slope[0]:.0f} |w|")
    k = 14.5, l = 1309 + 436 |w|
    >>> print(check_gains(g, J, omega_max=3.0))
    gains satisfy the theorem: mu = 14.5 > J_M (omega_M + 3/2) = 13.5
    """
    J_m, J_M = inertia_bounds(J)
    omega_max = float(as_positive(omega_max, "omega_max")[0])
    margin = float(as_positive(margin, "margin")[0])
    v = as_directions(np.eye(3)[:2] if references is None else references)
    geometry = mu(np.ones(v.shape[0]), v)  # μ for unit gains; μ is linear in a common k
    if geometry <= 0:
        raise ValueError("the reference directions span a single axis: no k satisfies the μ condition")
    k = (J_M * (omega_max + 1.5) + margin) / geometry
    c = _l_factor(k, J_m)
    n = v.shape[0]
    return ObserverGains(k=np.full(n, k), l_offset=np.full(n, l0 + omega_max * c), l_slope=np.full(n, c))


@dataclass(frozen=True)
class GainCheck:
    """Outcome of :func:`check_gains`: each condition's required and actual values, and what fails."""

    mu: float
    mu_required: float
    l_offset_required: np.ndarray
    l_slope_required: np.ndarray
    failures: tuple[str, ...]

    @property
    def ok(self) -> bool:
        return not self.failures

    def __str__(self) -> str:
        if self.ok:
            return f"gains satisfy the theorem: mu = {self.mu:.6g} > J_M (omega_M + 3/2) = {self.mu_required:.6g}"
        return "; ".join(self.failures)


def check_gains(
    gains: ObserverGains, J: ArrayLike, omega_max: float, references: ArrayLike | None = None, warn: bool = True
) -> GainCheck:
    """Check ``gains`` against the theorem's conditions; warn (:class:`GainConditionWarning`) naming each failure.

    A failure does not mean the observer diverges, only that the theorem no longer guarantees global exponential
    convergence for ``|ω| ≤ omega_max``.

    Parameters
    ----------
    gains : ObserverGains
        The gains to check, for ``n`` directions.
    J : array_like
        The inertia (3 numbers = diagonal, 9 numbers or 3×3), SPD.
    omega_max : float
        ω_M, the bound on ``|ω(t)|`` (rad/s).
    references : array_like, optional
        The inertial directions ``(n, 3)`` (default: the first ``n`` rows of R).
    warn : bool, optional
        Warn :class:`GainConditionWarning` when a condition fails (default True).

    Returns
    -------
    GainCheck
        μ and its required value, the required ``l_offset`` and ``l_slope``, and the failures (``ok`` when none;
        its ``str`` says the verdict).

    Raises
    ------
    ValueError
        If the number of gains is not the number of reference directions.

    Examples
    --------
    >>> import warnings
    >>> from omegahat import ObserverGains, check_gains
    >>> J = [3.0, 2.0, 1.0]
    >>> gains = ObserverGains.constant(5.0, 10.0)  # far from the theorem's gains
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     check = check_gains(gains, J, omega_max=3.0)
    >>> check.ok, [w.category.__name__ for w in caught]
    (False, ['GainConditionWarning'])
    >>> print(check.failures[0])
    mu = lambda_min(sum k_i (I - v_i v_i^T)) = 5 must exceed J_M (omega_M + 3/2) = 13.5 (short by 8.5)
    >>> print(f"{check.mu_required:.1f} {check.l_slope_required[0]:.0f}")
    13.5 56
    """
    J_m, J_M = inertia_bounds(J)
    omega_max = float(as_positive(omega_max, "omega_max")[0])
    v = as_directions(np.eye(3)[: gains.n] if references is None else references, min_angle_deg=0.0)
    if v.shape[0] != gains.n:
        raise ValueError(f"{gains.n} gains were given for {v.shape[0]} reference directions")
    m = mu(gains.k, v)
    m_req = J_M * (omega_max + 1.5)
    c = _l_factor(gains.k, J_m)
    failures = []
    if not m > m_req:
        failures.append(
            f"mu = lambda_min(sum k_i (I - v_i v_i^T)) = {m:.6g} must exceed J_M (omega_M + 3/2) = {m_req:.6g} "
            f"(short by {m_req - m:.6g})"
        )
    for i in range(gains.n):
        if gains.l_slope[i] < c[i]:
            failures.append(
                f"l_{i + 1} grows with |omega_hat| at slope {gains.l_slope[i]:.6g}, needs at least "
                f"1 + (k/J_m)(1 + 2k/J_m) = {c[i]:.6g} (short by {c[i] - gains.l_slope[i]:.6g})"
            )
        if not gains.l_offset[i] > omega_max * c[i]:
            failures.append(
                f"l_{i + 1}(0) = {gains.l_offset[i]:.6g} must exceed omega_M (1 + (k/J_m)(1 + 2k/J_m)) = "
                f"{omega_max * c[i]:.6g} (short by {omega_max * c[i] - gains.l_offset[i]:.6g})"
            )
    result = GainCheck(m, m_req, omega_max * c, c, tuple(failures))
    if warn and failures:
        warnings.warn(
            "gains do not satisfy the theorem's conditions (global exponential convergence is not guaranteed): "
            + "; ".join(failures),
            GainConditionWarning,
            stacklevel=2,
        )
    return result
