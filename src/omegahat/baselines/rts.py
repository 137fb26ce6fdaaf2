r"""Fixed-interval (Rauch–Tung–Striebel) smoother on the gyro-less MEKF: ω̂ at every sample of a whole log, no lag.

References: H. E. Rauch, F. Tung, C. T. Striebel, "Maximum likelihood estimates of linear dynamic systems",
AIAA Journal 3(8), 1965; for the multiplicative (error-state) form on rotations, F. L. Markley, J. L. Crassidis,
*Fundamentals of Spacecraft Attitude Determination and Control*, Springer, 2014 (the MEKF's error state).

The forward pass is the filter of :mod:`omegahat.baselines.mekf` (its NumPy step, :meth:`MEKF.step`), which
records at every sample ``k`` the prior ``(R⁻_k, x⁻_k, P⁻_k)``, the interval's error-state transition ``Φ_k``
(from sample ``k−1`` to ``k``) and the posterior ``(R⁺_k, x⁺_k, P⁺_k)``; ``x`` is ``ω̂`` or ``[ω̂, â]``. The backward
pass, from the last sample, ``s`` marking the smoothed estimate::

    C_k   = P⁺_k Φ_{k+1}ᵀ (P⁻_{k+1})⁻¹                                                            (R1)
    δ_k   = [Log((R⁻_{k+1})ᵀ R^s_{k+1});  x^s_{k+1} − x⁻_{k+1}]     (the smoothed state seen from the prior)
    δx_k  = C_k δ_k                                                                                  (R2)
    R^s_k = R⁺_k Exp(δx_k[:3]),   x^s_k = x⁺_k + δx_k[3:]                                            (R3)
    P^s_k = P⁺_k + C_k (P^s_{k+1} − P⁻_{k+1}) C_kᵀ                                                   (R4)

(R1)–(R4) are the linear RTS equations written in the filter's error state ``R = R̂ Exp(δθ)``: the error of
the smoothed estimate about the filtered one at ``k`` is propagated by ``Φ_{k+1}`` to the error about the prior
at ``k+1``, which is the smoothed-minus-prior difference ``δ_k``. At the last sample the smoothed estimate is
the filtered one. Samples before the first fix (no attitude yet) keep the filtered output.

What it assumes: the filter's linearisation along its own estimate, as the EKF itself; it is exact for the
linear part (the rates, when ``J`` is a multiple of the identity and no torque is known). Its cost: the NumPy
filter (not the compiled one) plus one 6×6 or 9×9 solve per sample.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat import so3
from omegahat.baselines.mekf import MEKF, FilterStep
from omegahat.interface import Estimate, Estimator, Measurement, Measurements, batch_status

__all__ = ["DIVERGED_TURN", "RTSSmoother", "Smoothed", "rts_backward", "smooth_log"]

#: rad: a predicted turn between two samples beyond this (16 π) means the forward filter has diverged
DIVERGED_TURN = 16 * np.pi


@dataclass(frozen=True)
class Smoothed:
    """A smoothed log: ``omega (T, 3)`` rad/s body axes, ``accel (T, 3)`` (zeros without the acceleration state),
    ``R (T, 3, 3)`` (NaN before the first fix), ``P (T, n, n)`` the smoothed covariances, the forward
    (filtered) rates ``omega_filtered (T, 3)``, and ``usable (T,)``: False where the filter skipped the sample
    (all True from :func:`rts_backward` alone: :func:`smooth_log` fills it)."""

    omega: np.ndarray
    accel: np.ndarray
    R: np.ndarray
    P: np.ndarray
    omega_filtered: np.ndarray
    usable: np.ndarray


def rts_backward(steps: list[FilterStep]) -> Smoothed:
    """(R1)–(R4) over the forward pass's records, one per sample."""
    T = len(steps)
    n = steps[-1].P.shape[0]
    na = n // 3 - 1  # rate components per block: x = [ω] (6×6 P) or [ω, a] (9×9 P)
    x_s = np.full((T, 3 * na), np.nan)
    R_s = np.full((T, 3, 3), np.nan)
    P_s = np.full((T, n, n), np.nan)
    filtered = np.array([s.x[:3] for s in steps])
    x_s[-1], P_s[-1] = steps[-1].x, steps[-1].P
    if steps[-1].R is not None:
        R_s[-1] = steps[-1].R
    for k in range(T - 2, -1, -1):
        here, nxt = steps[k], steps[k + 1]
        if here.R is None or nxt.Phi is None or nxt.R_prior is None:  # before the first fix: nothing to smooth
            x_s[k], P_s[k] = here.x, here.P
            continue
        C = np.linalg.solve(nxt.P_prior, nxt.Phi @ here.P).T  # (R1): P⁺ Φᵀ (P⁻)⁻¹, both symmetric
        delta = np.concatenate([so3.log(nxt.R_prior.T @ R_s[k + 1]), x_s[k + 1] - nxt.x_prior])
        dx = C @ delta  # (R2)
        R_s[k] = here.R @ so3.exp(dx[:3])  # (R3)
        x_s[k] = here.x + dx[3:]
        P = here.P + C @ (P_s[k + 1] - nxt.P_prior) @ C.T  # (R4)
        P_s[k] = 0.5 * (P + P.T)
    accel = x_s[:, 3:6] if na == 2 else np.zeros((T, 3))
    return Smoothed(x_s[:, :3].copy(), accel.copy(), R_s, P_s, filtered, np.ones(T, dtype=bool))


def smooth_log(filt: MEKF, times: ArrayLike, measurements: Measurements, torques: ArrayLike | None = None) -> Smoothed:
    """Run ``filt`` forward over a whole log (from its current state) recording every step, then (R1)–(R4).

    Every sample goes through the filter's own checks (:meth:`MEKF.step`); a rejected one raises. A filter that
    diverges (its rate predicts a turn beyond :data:`DIVERGED_TURN` to the next sample) raises
    ``FloatingPointError``."""
    t = np.asarray(times, dtype=float)
    samples = cast("Sequence[Measurement]", measurements)  # indexable: an array, a Rotation or a sequence
    taus = None if torques is None else np.asarray(torques, dtype=float)
    steps = []
    usable = np.ones(t.size, dtype=bool)
    for j in range(t.size):
        skipped = filt.n_skipped
        steps.append(filt.step(float(t[j]), samples[j], None if taus is None else taus[j]))
        usable[j] = filt.n_skipped == skipped
        turn = float(np.linalg.norm(filt.omega)) * (t[j + 1] - t[j] if j + 1 < t.size else 0.0)
        if not np.isfinite(turn) or turn > DIVERGED_TURN:
            # Sampled attitudes cannot tell turns beyond π apart: the filter has diverged. Stop here rather than
            # propagate it in tens of thousands of NumPy substeps per sample.
            raise FloatingPointError(
                f"the forward filter diverged at sample {j} (t = {t[j]:g} s): |ω̂| = {np.linalg.norm(filt.omega):.3g} "
                "rad/s"
            )
    if not steps:
        empty = np.empty((0, 3))
        return Smoothed(empty, empty, np.empty((0, 3, 3)), np.empty((0, 0, 0)), empty, usable)
    return replace(rts_backward(steps), usable=usable)


class RTSSmoother(Estimator):
    """The MEKF's fixed-interval smoother, (R1)–(R4), behind the estimator contract: offline only (``run``).

    ``causal = False``. ``last`` keeps the last run's :class:`Smoothed` (the smoothed and the filtered rates, the
    attitudes and covariances). Statuses: ``unavailable`` before the filter's first fix (no attitude yet),
    ``predicted`` at a skipped sample, ``corrected`` elsewhere.

    Parameters
    ----------
    filter_factory : callable
        Keyword-only: a function of no arguments that builds the forward filter (an
        :class:`omegahat.baselines.mekf.MEKF`) afresh for each ``run``.

    Examples
    --------
    Noisy attitudes (1 mrad per axis) of a body turning at a constant rate, 100 Hz. Near the start, where the
    forward filter is still converging, the smoothed rate already has it:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import MEKF, RTSSmoother
    >>> w = np.array([0.3, -0.2, 0.5])  # rad/s, body axes
    >>> t = np.arange(0.0, 2.0, 0.01)
    >>> noise = Rotation.from_rotvec(1e-3 * np.random.default_rng(0).standard_normal((t.size, 3)))
    >>> q = (Rotation.from_rotvec(np.outer(t, w)) * noise).as_quat()
    >>> smoother = RTSSmoother(filter_factory=lambda: MEKF(model="kinematic", q=1e-6, measurement_noise=1e-3))
    >>> est = smoother.run(t, q)
    >>> print("smoothed:", " ".join(f"{x:.2f}" for x in est.omega[5]))
    smoothed: 0.30 -0.20 0.50
    >>> print("filtered:", " ".join(f"{x:.2f}" for x in smoother.last.omega_filtered[5]))
    filtered: 0.26 -0.21 0.47
    """

    causal = False

    def __init__(self, *, filter_factory: Callable[[], MEKF]) -> None:
        self.filter_factory = filter_factory
        self.last: Smoothed | None = None

    def run(self, t: ArrayLike, data: Measurements, torque: ArrayLike | None = None) -> Estimate:
        """Smoothed ω̂ at every sample, ``(T, 3)``, and the statuses."""
        filt = self.filter_factory()
        checks = {k: getattr(filt, k) for k in ("references", "scalar_first", "rotation_tol", "quat_norm_tol")}
        ms.checked_log(t, data, torque, min_angle_deg=filt.min_angle_deg, **checks)  # refused whole, sample named
        self.last = smooth_log(filt, t, data, torque)
        omega = np.where(np.isfinite(self.last.R[:, 0, 0])[:, None], self.last.omega, np.nan)
        self.n_skipped = filt.n_skipped
        return Estimate(omega, batch_status(self.last.usable, omega))
