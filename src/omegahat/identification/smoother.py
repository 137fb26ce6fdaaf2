r"""The offline, zero-lag estimate of the identified model: a forward and a backward pass of its EKF, combined.

``omegahat estimate LOG --smooth`` and :class:`ModelSmoother`: for every input kind (attitudes or directions), with
or without J, the model and noises of :func:`omegahat.identification.identify`. Two passes of the same compiled EKF
(:func:`omegahat.identification.likelihood.filter_pass`), one forward in time and one backward, each give a rate
and its covariance at every sample; the smoothed rate is their information-weighted mean (the two-filter smoother
of Fraser and Potter, IEEE TAC 14(4), 1969, for the rate's marginal)::

    ω̂_s = (P_f⁻¹ + P_b⁻¹)⁻¹ (P_f⁻¹ ω̂_f + P_b⁻¹ ω̂_b)                                                    (T1)

**Time reversed.** With ``s = −t`` the attitude ``R(s)`` runs the log backwards and its body rate is ``−ω``; Euler's
equations keep their form, ``J dω'/ds = (Jω') × ω' + τ`` for ``ω' = −ω`` (both ``(Jω) × ω`` and the time
derivative change sign), so the same model with the same torque describes the reversed log; a torque held from
each sample forward is held from each sample backward in reversed time, so the reversed log's torques are moved by
one sample. The backward pass's rate is negated back.

The two passes each use the sample at ``t_k`` (the measurement is counted twice in (T1)): the weights are then
those of two filters that agree on it, which leaves a constant rate exact and halves nothing that matters for the
rate; at each end of the log one pass has only just started and its covariance (large) gives it no weight. Where a
pass restarted (its guard: NaN) the other alone is used; where both did, there is no estimate (``unavailable``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat.identification.identify import Identification
from omegahat.identification.likelihood import filter_pass
from omegahat.interface import Estimate, Estimator, Measurements, Status
from omegahat.validation import as_directions

__all__ = ["ModelSmoother", "combine"]


def combine(omega_f: np.ndarray, P_f: np.ndarray, omega_b: np.ndarray, P_b: np.ndarray) -> np.ndarray:
    """(T1) sample by sample: ``(T, 3)`` rates and ``(T, 3, 3)`` covariances of two passes (NaN rows where one
    has none: the other alone; NaN where both)."""
    out = np.full(omega_f.shape, np.nan)
    ok_f = np.all(np.isfinite(omega_f), axis=1) & np.all(np.isfinite(P_f), axis=(1, 2))
    ok_b = np.all(np.isfinite(omega_b), axis=1) & np.all(np.isfinite(P_b), axis=(1, 2))
    both = ok_f & ok_b
    if both.any():
        I_f, I_b = np.linalg.inv(P_f[both]), np.linalg.inv(P_b[both])
        info = np.einsum("tij,tj->ti", I_f, omega_f[both]) + np.einsum("tij,tj->ti", I_b, omega_b[both])
        out[both] = np.linalg.solve(I_f + I_b, info[..., None])[..., 0]
    out[ok_f & ~ok_b] = omega_f[ok_f & ~ok_b]
    out[ok_b & ~ok_f] = omega_b[ok_b & ~ok_f]
    return out


class ModelSmoother(Estimator):
    """The zero-lag estimate (T1) of an identified model over a whole log (module docstring): batch only.

    Parameters
    ----------
    identification : what :func:`omegahat.identification.identify` found on the log (its model, noises, J).
    references : the inertial directions ``(n, 3)`` of direction input (None: attitude input).
    scalar_first, rotation_tol, quat_norm_tol : as every estimator (:mod:`omegahat.measurements`).
    """

    causal = False

    def __init__(
        self,
        identification: Identification,
        *,
        references: ArrayLike | None = None,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
    ) -> None:
        self.identification = identification
        self.references = None if references is None else as_directions(references)
        self.scalar_first = bool(scalar_first)
        self.rotation_tol, self.quat_norm_tol = ms.tolerances(rotation_tol, quat_norm_tol)
        self.n_skipped = 0

    def run(self, t: ArrayLike, data: Measurements, torque: ArrayLike | None = None) -> Estimate:
        """The smoothed rate at every sample of the log (its samples checked as by every estimator)."""
        log = ms.checked_log(
            t, data, torque, references=self.references, scalar_first=self.scalar_first,
            rotation_tol=self.rotation_tol, quat_norm_tol=self.quat_norm_tol,
        )  # fmt: skip
        T = log.times.size
        self.n_skipped = int(np.count_nonzero(~log.valid))
        if T == 0:
            return Estimate(np.empty((0, 3)), np.empty(0, dtype=np.int8))
        c = self.identification.chosen
        h = 1.0 / self.identification.rate_hz
        kw = {"h": h, "J": self.identification.J, "references": self.references, "covariances": True}
        sigma = max(c.sigma, 1e-9)
        fwd = filter_pass(log.times, log.values, log.valid, c.model, c.tracking_index, sigma=sigma,
                          torque=log.torques, **kw)  # type: ignore[arg-type]  # fmt: skip
        rev = slice(None, None, -1)
        torque_back = np.roll(log.torques[rev], 1, axis=0)  # held backward from each sample (module docstring)
        bwd = filter_pass(-log.times[rev], log.values[rev], log.valid[rev], c.model, c.tracking_index, sigma=sigma,
                          torque=torque_back, **kw)  # type: ignore[arg-type]  # fmt: skip
        omega = combine(fwd.omega, fwd.P, -bwd.omega[rev], bwd.P[rev])
        status = np.where(log.valid, Status.CORRECTED, Status.PREDICTED).astype(np.int8)
        status[~np.all(np.isfinite(omega), axis=1)] = Status.UNAVAILABLE
        return Estimate(omega, status)
