r"""The offline, zero-lag estimate of the identified model: a forward and a backward pass of its EKF, combined.

``omegahat estimate LOG --smooth`` and :class:`ModelSmoother`: for every input kind (attitudes or directions), with
or without J, the model and noises of :func:`omegahat.identification.identify`. Two passes of the same compiled EKF
(:func:`omegahat.identification.likelihood.filter_pass`), one forward in time and one backward, each give a rate
and its covariance at every sample; the smoothed rate is their information-weighted mean (the two-filter smoother
of Fraser and Potter, IEEE TAC 14(4), 1969, for the rate's marginal)::

    ω̂_s = (P_f⁻¹ + P_b⁻¹)⁻¹ (P_f⁻¹ ω̂_f + P_b⁻¹ ω̂_b)                                                    (T1)

**Time reversed.** With ``s = −t`` the attitude ``R(s)`` runs the log backwards and its body rate is ``−ω``; Euler's
equations keep their form, ``J dω'/ds = (Jω') × ω' + τ`` for ``ω' = −ω`` (both ``(Jω) × ω`` and the time
derivative change sign), so the same model with the same torque describes the reversed log. A torque held over
each step, ``τ_k`` on ``[t_k, t_{k+1}]``, is in reversed time the torque of the step's far end: the backward pass,
which holds each of its samples' torque over the step that follows it, takes at ``t_{k+1}`` the torque ``τ_k``
(`tests/test_torque_hold.py`). A torque interpolated between samples is the same line either way. The backward
pass's rate is negated back.

The two passes each use the sample at ``t_k`` (the measurement is counted twice in (T1)): the weights are then
those of two filters that agree on it, which leaves a constant rate exact and halves nothing that matters for the
rate; at each end of the log one pass has only just started and its covariance (large) gives it no weight. Where a
pass restarted (its guard: NaN) the other alone is used; where both did, there is no estimate (``unavailable``).

**Which smoother.** The smoother expects the error ``tr (P_f⁻¹ + P_b⁻¹)⁻¹`` at each sample (the model's own
account); the log's own Wiener smoother (:mod:`omegahat.identification.spectral`) expects (S7) from the log's
spectrum (for directions, of each sample's least-squares attitude). ``--smooth`` runs both and keeps the one
expecting the lower RMS error (:class:`ChosenSmoother`): where the model describes the log its expectation is the
lower one (a constant rate, a torque given), where it does not the spectrum's is.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat.identification.identify import Identification
from omegahat.identification.likelihood import filter_pass
from omegahat.identification.spectral import SpectralSmoother
from omegahat.interface import Estimate, Estimator, Measurements, Status
from omegahat.validation import as_directions

__all__ = ["ChosenSmoother", "ModelSmoother", "combine", "combined"]


def combine(omega_f: np.ndarray, P_f: np.ndarray, omega_b: np.ndarray, P_b: np.ndarray) -> np.ndarray:
    """(T1) sample by sample: ``(T, 3)`` rates and ``(T, 3, 3)`` covariances of two passes (NaN rows where one
    has none: the other alone; NaN where both)."""
    return combined(omega_f, P_f, omega_b, P_b)[0]


def _usable(omega: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``(T,)``: True where a pass's rate is finite and its covariance positive definite (Sylvester's criterion:
    the leading minors positive). A pass that ran away has a covariance so large that rounding leaves it
    singular or indefinite; it is not averaged in (the other pass alone is used there)."""
    finite = np.all(np.isfinite(omega), axis=1) & np.all(np.isfinite(P), axis=(1, 2))
    Q = np.where(finite[:, None, None], P, np.eye(3))
    minor2 = Q[:, 0, 0] * Q[:, 1, 1] - Q[:, 0, 1] * Q[:, 1, 0]
    return finite & (Q[:, 0, 0] > 0.0) & (minor2 > 0.0) & (np.linalg.det(Q) > 0.0)


def combined(
    omega_f: np.ndarray, P_f: np.ndarray, omega_b: np.ndarray, P_b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`combine`'s rates and the variance (T1) expects of them, ``tr (P_f⁻¹ + P_b⁻¹)⁻¹`` per sample ``(T,)``
    ((rad/s)², the three axes together; one pass's own where the other has none, NaN where neither has)."""
    out = np.full(omega_f.shape, np.nan)
    variance = np.full(omega_f.shape[0], np.nan)
    ok_f, ok_b = _usable(omega_f, P_f), _usable(omega_b, P_b)
    both = ok_f & ok_b
    if both.any():
        I_f, I_b = np.linalg.inv(P_f[both]), np.linalg.inv(P_b[both])
        P_s = np.linalg.inv(I_f + I_b)
        info = np.einsum("tij,tj->ti", I_f, omega_f[both]) + np.einsum("tij,tj->ti", I_b, omega_b[both])
        out[both] = np.einsum("tij,tj->ti", P_s, info)
        variance[both] = np.trace(P_s, axis1=1, axis2=2)
    for alone, omega, P in ((ok_f & ~ok_b, omega_f, P_f), (ok_b & ~ok_f, omega_b, P_b)):
        out[alone] = omega[alone]
        variance[alone] = np.trace(P[alone], axis1=1, axis2=2)
    return out, variance


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
        self.expected_rms = math.nan  # after run: the RMS error (T1) expects over the log (rad/s)

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
        linear = c.torque_hold == "linear"
        kw = {"h": h, "J": self.identification.J, "references": self.references, "covariances": True,
              "linear_hold": linear}  # fmt: skip
        sigma = max(c.sigma, 1e-9)
        fwd = filter_pass(log.times, log.values, log.valid, c.model, c.tracking_index, sigma=sigma,
                          torque=log.torques, **kw)  # type: ignore[arg-type]  # fmt: skip
        rev = slice(None, None, -1)
        # held: the reversed step from t_{k+1} to t_k holds τ_k, its next sample's (module docstring)
        torque_back = log.torques[rev] if linear else np.roll(log.torques[rev], -1, axis=0)
        bwd = filter_pass(-log.times[rev], log.values[rev], log.valid[rev], c.model, c.tracking_index, sigma=sigma,
                          torque=torque_back, **kw)  # type: ignore[arg-type]  # fmt: skip
        omega, variance = combined(fwd.omega, fwd.P, -bwd.omega[rev], bwd.P[rev])
        self.expected_rms = float(np.sqrt(np.nanmean(variance))) if np.isfinite(variance).any() else math.nan
        status = np.where(log.valid, Status.CORRECTED, Status.PREDICTED).astype(np.int8)
        status[~np.all(np.isfinite(omega), axis=1)] = Status.UNAVAILABLE
        return Estimate(omega, status)


class ChosenSmoother(Estimator):
    """``--smooth`` where the identification chose a model: the model's smoother (T1) and the log's own Wiener
    smoother (S2)–(S6) both run, and the one whose own expected RMS error is the lower is kept (the model's from its
    two passes' covariances, the Wiener smoother's (S7) from the log's spectrum): the log's evidence decides between
    the model and the spectrum. For directions the Wiener smoother takes each sample's least-squares attitude
    (:func:`omegahat.so3.wahba`). After ``run``: ``chosen`` (the smoother kept), ``expected`` (``{"model": …,
    "spectrum": …}``, rad/s).

    Parameters
    ----------
    identification : what :func:`omegahat.identification.identify` found on the log.
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
        tols = {"rotation_tol": rotation_tol, "quat_norm_tol": quat_norm_tol}
        self.model = ModelSmoother(identification, references=references, scalar_first=scalar_first, **tols)
        self.spectrum = SpectralSmoother(references=references, scalar_first=scalar_first, **tols)
        self.chosen: Estimator = self.model
        self.expected = {"model": math.nan, "spectrum": math.nan}
        self.n_skipped = 0

    def run(self, t: ArrayLike, data: Measurements, torque: ArrayLike | None = None) -> Estimate:
        """Both smoothers' estimates; the one expecting the lower error is returned."""
        by_model = self.model.run(t, data, torque)
        by_spectrum = self.spectrum.run(t, data, torque)
        self.expected = {"model": self.model.expected_rms, "spectrum": self.spectrum.expected_rms}
        self.n_skipped = self.model.n_skipped
        if self.spectrum.expected_rms < self.model.expected_rms:  # False when either is NaN: the model
            self.chosen = self.spectrum
            return by_spectrum
        self.chosen = self.model
        return by_model
