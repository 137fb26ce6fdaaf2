r"""The base of the estimators whose step is compiled: conversion, refusal, counting, statuses and warnings, once.

:class:`~omegahat.observer.estimator.SarrasEstimator`, :class:`~omegahat.observer.kalman.SupervisedKalmanEstimator`
and :class:`~omegahat.baselines.mekf.MEKF` subclass :class:`CompiledEstimator` and supply only their own
computation: the step of one sample and the run over a log, both *pure* (they return a new state and never change
the estimator), and how to commit a state. The base does the rest, the same way for all of them:

1. **Conversion** (:mod:`omegahat.measurements`): the time, the sample (or log) and the torque are turned into the
   compiled step's arrays, their types and shapes checked, before anything runs: a time that is not a real number
   (``"1.0"``), a complex or textual measurement, a wrong shape are refused (``TypeError``, ``ValueError``).
2. **Refusal.** The step's own checks return a code (:mod:`omegahat.kernels.checks`); from ``ERROR`` on the base
   raises :func:`omegahat.measurements.rejection_error` (naming ``the sample``, or ``sample j`` of a log) and the
   new state is not committed: **a refused sample leaves the estimator exactly as it was** (its next good sample is
   taken as if the refused one had never come). ``run`` is atomic: the compiled run stops at the first refused
   sample and nothing of the log is committed.
3. **Counting** (the contract's one counter, :mod:`omegahat.interface`): ``n_skipped`` the samples skipped (missing:
   NaN or inf; or nearly collinear directions), of which ``n_collinear`` collinear, their times in
   ``skipped_times``; ``largest_interval`` the longest interval between two samples seen.
4. **Statuses** (:class:`omegahat.interface.Status`, from the step's codes by :data:`STATUS_OF_CODE`): a used
   sample is CORRECTED, a skipped one PREDICTED, one whose step could not be taken RESTARTED (the step then
   returns NaN there and starts again from the sample), except that there is no estimate (UNAVAILABLE, ``omega`` NaN)
   before the first valid sample, nor at it unless the initial rate was given (``rate_given``: one attitude gives
   no rate; a warm start waits for the second sample).
5. **Restarts.** A step whose result is not finite (a gap too long for the model, a torque or gains beyond
   floating point) restarts the estimator from that sample (code ``RESTARTED``, :mod:`omegahat.kernels.checks`):
   status RESTARTED, ``omega`` NaN there and until the next estimate, never a diverged value; counted in
   ``n_restarts``.
6. **Warnings**: ``run`` warns once per call when it skipped samples (:class:`SkippedSamplesWarning`) and when it
   restarted (:class:`RestartedWarning`).
"""

from __future__ import annotations

import abc
import math
import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat.interface import Estimate, Measurement, Measurements, Status, StreamingEstimator

__all__ = ["STATUS_OF_CODE", "CompiledEstimator", "RestartedWarning", "SkippedSamplesWarning"]

#: The compiled steps' per-sample codes below ``ERROR`` (:mod:`omegahat.kernels.checks`) and the estimate's status
#: they give, in one place: a used sample is corrected, a skipped one predicted through. A code a compiled step adds
#: (a state that could not be propagated, restarted from the sample: ``Status.RESTARTED``) is mapped here.
STATUS_OF_CODE: dict[int, Status] = {
    ms.OK: Status.CORRECTED,
    ms.MISSING: Status.PREDICTED,
    ms.COLLINEAR: Status.PREDICTED,
    ms.RESTARTED: Status.RESTARTED,
    ms.HELD: Status.PREDICTED,
}
_SKIPPED = (ms.MISSING, ms.COLLINEAR)  # the codes n_skipped counts
# STATUS_OF_CODE as a table indexed by code (a run's codes are all below ERROR): one indexing per run
_STATUS_TABLE = np.zeros(ms.ERROR, dtype=np.int8)
for _code, _status in STATUS_OF_CODE.items():
    _STATUS_TABLE[_code] = _status

_NAN3 = np.full(3, np.nan)
_NAN3.flags.writeable = False
_UNAVAILABLE, _CORRECTED = Status.UNAVAILABLE, Status.CORRECTED  # (hot path)
_OK, _ERROR = ms.OK, ms.ERROR
_new = tuple.__new__


class SkippedSamplesWarning(UserWarning):
    """``run`` skipped samples (missing or collinear); their times are in ``estimator.skipped_times``."""


class RestartedWarning(SkippedSamplesWarning):
    """``run`` restarted the estimator at samples whose step could not be taken (status ``RESTARTED``)."""


class CompiledEstimator(StreamingEstimator):
    """Conversion, refusal, counting, statuses and warnings of a compiled estimator (module docstring).

    A subclass calls :meth:`_configure_input` in its constructor (before :meth:`reset`) and implements
    :meth:`_reset_state`, :meth:`_step`, :meth:`_run` and :meth:`_commit`.
    """

    _n_directions: int | None = None  # None: attitude samples; n: n body-frame directions per sample
    _need: int = 1  # valid samples after which an estimate exists (1: the initial rate was given, else 2)

    #: the converter's settings (:func:`omegahat.measurements.conversion`) of an estimator that checks its samples
    #: itself before its filter (the peers: :meth:`_check_one`, :meth:`_check_log`); set by its constructor
    _conversion: tuple[np.ndarray, bool, float, float, float]

    def _configure_input(self, *, n_directions: int | None, rate_given: bool) -> None:
        """What a sample is (attitude, or ``n_directions`` directions) and whether the initial rate was given."""
        self._n_directions = n_directions
        self._need = 1 if rate_given else 2

    # -- what a subclass supplies ------------------------------------------------------------------------------

    @abc.abstractmethod
    def _reset_state(self) -> None:
        """Back to the initial state (the base clears the counters)."""

    @abc.abstractmethod
    def _step(self, t: float, m: np.ndarray, kind: int, tau: np.ndarray) -> tuple[Any, np.ndarray, int, float]:
        """One sample, pure: ``(new state, ω̂ (3,), code, info)``; a code from ``ERROR`` on refuses it."""

    @abc.abstractmethod
    def _run(
        self, times: np.ndarray, m: np.ndarray, kind: int, taus: np.ndarray
    ) -> tuple[Any, np.ndarray, np.ndarray, int, float]:
        """A log, pure: ``(new state, ω̂ (T, 3), codes (T,), first refused index or -1, its info)``."""

    @abc.abstractmethod
    def _commit(self, state: Any) -> None:
        """Make ``state`` (from :meth:`_step` or :meth:`_run`) the estimator's."""

    # -- the one input path, for a subclass that checks its samples itself -------------------------------------

    def _check_one(self, t: float, m: np.ndarray, kind: int, tau: np.ndarray, value: np.ndarray) -> tuple[int, float]:
        """(M1)–(M3) and (T) of one sample after the last one taken: ``(code, info)``, its converted value (a
        rotation's rows or the unit directions) written into ``value``."""
        code, info = ms.check_sample(t, self._t_last, tau, m, kind, *self._conversion, value, np.empty((3, 3)))
        return int(code), float(info)

    def _check_log(
        self, times: np.ndarray, m: np.ndarray, kind: int, taus: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, tuple[Any, np.ndarray, np.ndarray, int, float] | None]:
        """(M1)–(M3) and (T) over a log after the last sample taken: ``(values, codes, refusal)``, ``refusal`` what
        :meth:`_run` returns when a sample is refused (None when none is)."""
        values, codes, first_bad, info = ms.check_batch(times, self._t_last, taus, True, m, kind, *self._conversion)
        refusal = None if first_bad < 0 else (None, np.empty((times.size, 3)), codes, int(first_bad), float(info))
        return values, codes, refusal

    # -- the contract ------------------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget every sample: back to the initial state, counters cleared."""
        self._reset_state()
        self.n_skipped = 0
        self.n_collinear = 0
        self.n_restarts = 0
        self.skipped_times: list[float] = []
        self.largest_interval = 0.0
        self._n_valid = 0
        self._t_last = np.nan  # the last sample's time

    def update(self, t: float, sample: Measurement, torque: ArrayLike | None = None) -> Estimate:
        """Take the sample at ``t`` (``torque`` known from ``t`` on; None: zero) and return the estimate there,
        ``omega (3,)`` and its :class:`~omegahat.interface.Status`; a refused sample raises and changes nothing."""
        if not isinstance(t, float):  # a float (np.float64 too) is one already: the hot path
            t = ms.sample_time(t)
        m, kind = ms.sample_array(sample, self._n_directions)
        tau = ms.torque_vector(torque)
        state, w, code, info = self._step(t, m, kind, tau)
        if code >= _ERROR:
            raise ms.rejection_error(code, info, "the sample", t)
        self._commit(state)
        if t - self._t_last > self.largest_interval:  # NaN before the first sample: False
            self.largest_interval = t - self._t_last
        self._t_last = t
        if code == _OK:
            if self._n_valid < 2:
                self._n_valid += 1
            status = _CORRECTED
        else:
            status = STATUS_OF_CODE[code]
            if code == ms.HELD and self._n_valid < 2:  # a valid sample, its rate held: (S5)
                self._n_valid += 1
            if code == ms.RESTARTED:
                self.n_restarts += 1
                return Estimate(_NAN3.copy(), status)
            if code in _SKIPPED:
                self.n_skipped += 1
                self.n_collinear += code == ms.COLLINEAR
                self.skipped_times.append(float(t))
        if self._n_valid < self._need or (status is not _CORRECTED and not math.isfinite(w[0])):
            return Estimate(_NAN3.copy(), _UNAVAILABLE)  # (or predicted after a restart: nothing to predict from)
        return _new(Estimate, (w.copy(), status))  # Estimate(w, status) at half the cost (the hot path)

    def run(self, t: ArrayLike, data: Measurements, torque: ArrayLike | None = None) -> Estimate:
        """The estimate at every sample of a log, continuing from the current state (:meth:`reset` first for a
        fresh start): the same computation as :meth:`update` sample by sample, in one compiled call; atomic (the
        error names the first refused sample, and the estimator is left as it was before the call)."""
        times = ms.times_array(t)
        T = times.size
        m, kind = ms.log_array(data, T, self._n_directions)
        taus = ms.torques_array(torque, T)
        if T == 0:
            return Estimate(np.empty((0, 3)), np.empty(0, dtype=np.int8))
        t_prev = self._t_last
        state, W, codes, first_bad, info = self._run(times, m, kind, taus)
        if first_bad >= 0:
            raise ms.rejection_error(int(codes[first_bad]), info, f"sample {first_bad}", times[first_bad])
        self._commit(state)
        self._t_last = float(times[-1])
        if T:
            gaps = np.diff(times) if np.isnan(t_prev) else np.diff(times, prepend=t_prev)
            if gaps.size:
                self.largest_interval = max(self.largest_interval, float(gaps.max()))
        valid = (codes == ms.OK) | (codes == ms.HELD)
        status = _STATUS_TABLE[codes]
        if self._n_valid < self._need:  # no estimate until the `need`-th valid sample of the stream
            seen = self._n_valid + np.cumsum(valid)
            status[seen < self._need] = Status.UNAVAILABLE
            W[seen < self._need] = np.nan
        self._n_valid = min(self._n_valid + int(np.count_nonzero(valid)), 2)
        restarted = codes == ms.RESTARTED
        W[restarted] = np.nan
        n_restarts = int(np.count_nonzero(restarted))
        if n_restarts:
            self.n_restarts += n_restarts
            warnings.warn(
                f"restarted {n_restarts} times in {T} samples: a step's result was not finite (a gap too long for the "
                "model, a torque or gains too large); the estimate is NaN there until the next warm start (status "
                "'restarted')",
                RestartedWarning,
                stacklevel=2,
            )
        skipped = (codes == _SKIPPED[0]) | (codes == _SKIPPED[1])
        if skipped.any():
            n_skip = int(np.count_nonzero(skipped))
            n_col = int(np.count_nonzero(codes == ms.COLLINEAR))
            self.n_skipped += n_skip
            self.n_collinear += n_col
            self.skipped_times.extend(times[skipped].tolist())
            warnings.warn(
                f"skipped {n_skip} of {T} samples ({n_skip - n_col} missing: NaN/inf, {n_col} with nearly "
                "collinear directions); the estimate was predicted through them (times in skipped_times)",
                SkippedSamplesWarning,
                stacklevel=2,
            )
        status[(status == Status.PREDICTED) & ~np.isfinite(W[:, 0])] = (
            Status.UNAVAILABLE
        )  # after a restart: no estimate
        return Estimate(W, status)
