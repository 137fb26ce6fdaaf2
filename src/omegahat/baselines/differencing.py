r"""Angular velocity by differencing the attitude on SO(3) (the baseline most users reach for first).

Reference: ``docs/baselines.md``, "Differencing the attitude". With samples ``R_k`` (body → inertial) at times
``t_k``, steps ``h_k = t_k − t_{k−1}``, and ``Log`` the rotation vector of a rotation (:func:`omegahat.so3.log`)::

    backward (causal):   ω̂(t_k) = Log(R_{k−1}ᵀ R_k) / h_k                                          (D1)
    central:             ω̂(t_k) = Log(R_{k−1}ᵀ R_{k+1}) / (h_k + h_{k+1})
                                  − (h_{k+1} − h_k) (d_f − d_b) / (h_k + h_{k+1})                  (D2)
    with  d_b = Log(R_{k−1}ᵀ R_k) / h_k,  d_f = Log(R_kᵀ R_{k+1}) / h_{k+1}

``Log(R_{k−1}ᵀ R_k) / h_k`` is the mean body rate over the step, exact to second order at the step's
midpoint ``t_k − h_k/2`` and therefore first order when assigned to ``t_k`` (D1). The first term of (D2) is
the mean rate over two steps, second order at their midpoint; the second term moves it to ``t_k`` when the
steps differ (``(d_f − d_b) / ((h_k + h_{k+1})/2)`` estimates ω̇), so (D2) is second order at ``t_k`` for any
step sizes and is exactly ``Log(R_{k−1}ᵀ R_{k+1}) / (2h)`` for uniform steps.

Being on rotation matrices, both are unaffected by the sign of a quaternion (q and −q give the same R).

**Jittered stamps.** Where the samples are regular and only their stamps jitter (a message's arrival time, stamps
rounded to the millisecond), dividing by the stamped step adds ``ε |ω|`` of noise for a jitter ``ε`` of the step.
Given the samples' own step ``step`` (``omegahat estimate`` reads it from the log, (S8) of
:mod:`omegahat.identification.spectral`), each stamped interval is read as the whole number of steps nearest to it,
at least one (a dropped sample, an interval of about two steps, counts two)::

    h_k = step · max(1, round((t_k − t_{k−1}) / step))                                             (D3)

A causal filter of the backward differences, (D4)–(D5) of :mod:`omegahat.baselines.stretch_filter` (``omegahat
estimate`` designs one from the log's spectrum, (C1)–(C3) of :mod:`omegahat.identification.causal`), runs where
``taps`` are given.

Noise: i.i.d. attitude noise σ (rad per axis) gives about ``√2 σ / h`` per axis for (D1) and ``σ / (√2 h)``
for (D2), so differencing is usually followed by a low-pass. The optional one here is first order and causal,
with cut-off ``f_c`` Hz, discretised exactly for any step (zero-order-hold discretisation of
``ẏ = 2π f_c (x − y)``)::

    y_k = y_{k−1} + (1 − exp(−2π f_c h_k)) (x_k − y_{k−1}),   y_first = x_first                      (LP)

Delay, stated plainly:

* ``scheme="backward"`` is causal: ``update`` at ``t_k`` returns ω̂(t_k).
* ``scheme="central"`` needs the next sample: ``update`` at ``t_{k+1}`` returns ω̂(t_k), the estimate for the
  **previous** sample time (one sample of delay; ``estimate_time`` says which time the returned value is for).
  ``run`` and :func:`log_difference` align their rows with the sample times (row k is ω̂(t_k); the last row
  is NaN).
  ``causal`` is ``False`` for this scheme.

Samples that are not finite (NaN or inf anywhere) are skipped: the next valid sample is differenced against
the last valid one over the longer interval, and the outputs at skipped samples hold the last estimate
(``n_skipped`` counts them; their status is ``predicted``). Until two (backward) or three (central) valid samples
have been seen there is no estimate: NaN (status ``unavailable``).

**Across an interval the last rate turns half a turn.** ``Log`` is the shortest rotation, at most π, so a
difference over an interval in which the body may have turned more than half a turn can be anything (a body at
0.06 rad/s seen again after 940 s gives 0.0015 rad/s). Where the last estimate ``ω̂`` says so, the estimator
(backward scheme) does not difference across the interval: it holds ``ω̂`` (status ``predicted``, as at a skipped
sample), takes the new attitude as the next difference's start, and a filter's stretch (D4) starts afresh::

    |ω̂_{k−1}| h_k ≥ π   ⇒   ω̂_k = ω̂_{k−1}, predicted                                                   (D6)

:func:`log_difference` is the formula itself, as peers compute it; so is the central scheme.
"""

from __future__ import annotations

from typing import Literal, TypeAlias, get_args, overload

import numba
import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat import so3
from omegahat.baselines.stretch_filter import Stretch, checked_taps, filtered_differences, next_in_stretch
from omegahat.interface import Estimate, Measurement, Measurements, Status, StreamingEstimator, batch_status, one_of
from omegahat.validation import as_directions, as_positive, as_vector3

__all__ = [
    "SCHEMES",
    "DifferencingEstimator",
    "Scheme",
    "log_difference",
    "lowpass",
    "lowpass_reference",
    "sample_clock",
    "whole_steps",
]

#: (D1), causal, or (D2), one sample late
Scheme: TypeAlias = Literal["backward", "central"]
SCHEMES: tuple[str, ...] = get_args(Scheme)


def _check_cutoff_hz(cutoff_hz):
    if cutoff_hz is None:
        return None
    c = float(cutoff_hz)
    if not np.isfinite(c) or c <= 0:
        raise ValueError(f"cutoff_hz must be a positive finite frequency in Hz or None; got {cutoff_hz!r}")
    return c


def _hold(values, valid):
    """Rows where ``valid`` is False take the last valid row before them (NaN before the first)."""
    idx = np.maximum.accumulate(np.where(valid, np.arange(valid.size), -1))
    out = np.full_like(values, np.nan)
    ok = idx >= 0
    out[ok] = values[idx[ok]]
    return out


def _differences(t, R, scheme):
    """(D1) or (D2) at the valid (finite) samples, NaN elsewhere or without neighbours: ``(T, 3)``."""
    valid = np.all(np.isfinite(R), axis=(1, 2))
    iv = np.flatnonzero(valid)
    Rv, tv = R[iv], t[iv]
    est = np.full((iv.size, 3), np.nan)  # estimate at each valid sample
    if iv.size >= 2:
        h = np.diff(tv)
        # d[j]: mean rate over (tv[j], tv[j+1])
        d = so3.increments(Rv) / h[:, None]
        if scheme == "backward":
            est[1:] = d  # (D1)
        elif iv.size >= 3:
            hb, hf = h[:-1, None], h[1:, None]
            mean2 = so3.log(np.swapaxes(Rv[:-2], -1, -2) @ Rv[2:]) / (hb + hf)
            est[1:-1] = mean2 - (hf - hb) * (d[1:] - d[:-1]) / (hb + hf)  # (D2)
    out = np.full((t.size, 3), np.nan)
    out[iv] = est
    return out, valid


def _hold_skipped(est, valid, scheme):
    """Skipped samples hold the last estimate; for ``"central"`` nothing after the last valid sample."""
    out = _hold(est, valid)
    if scheme == "central" and valid.any():
        out[np.flatnonzero(valid)[-1] :] = np.nan
    return out


def _half_turns(out: np.ndarray, valid: np.ndarray, clock: np.ndarray) -> np.ndarray:
    """(D6): the valid rows ``(T,)`` whose interval turns the output ``out`` at the valid row before by π or more."""
    iv, turns = np.flatnonzero(valid), np.zeros(valid.shape, bool)
    turns[iv[1:]] = np.linalg.norm(out[iv[:-1]], axis=1) * np.diff(clock[iv]) >= np.pi  # NaN (no output) is none
    return turns


def log_difference(
    times: ArrayLike,
    attitudes: ArrayLike | Rotation,
    scheme: Scheme = "backward",
    scalar_first: bool = False,
    rotation_tol: float = ms.ROTATION_TOL,
    quat_norm_tol: float = ms.QUAT_NORM_TOL,
) -> np.ndarray:
    """ω̂ at every sample by (D1) or (D2), shape ``(T, 3)``, row k for ``times[k]``.

    ``attitudes``: a ``Rotation``, matrices ``(T, 3, 3)`` or quaternions ``(T, 4)``, checked with the times by
    :func:`omegahat.measurements.checked_log` (the tolerances are its). NaN before the first estimate (and, for
    ``"central"``, from the last valid sample on); skipped non-finite samples hold the last estimate.
    """
    one_of("scheme", scheme, Scheme)
    log = ms.checked_log(
        times, attitudes, scalar_first=scalar_first, rotation_tol=rotation_tol, quat_norm_tol=quat_norm_tol
    )
    est, valid = _differences(log.times, log.values, scheme)
    return _hold_skipped(est, valid, scheme)


def lowpass_reference(x: np.ndarray, times: np.ndarray, cutoff_hz: float) -> np.ndarray:
    """(LP) on rows of ``x`` ``(T, 3)``, a plain loop: the readable oracle :func:`lowpass` is tested against. NaN
    rows pass through as NaN and leave the filter state unchanged; the state starts at the first finite row."""
    y = np.full_like(x, np.nan)
    state = None
    t_prev = 0.0
    for k in range(x.shape[0]):
        if not np.all(np.isfinite(x[k])):
            continue
        if state is None:
            state = x[k].copy()
        else:
            a = 1.0 - np.exp(-2.0 * np.pi * cutoff_hz * (times[k] - t_prev))
            state = state + a * (x[k] - state)
        t_prev = times[k]
        y[k] = state
    return y


@numba.njit(cache=True)
def _lowpass_kernel(x, times, cutoff_hz):  # pragma: no cover - compiled; tested against lowpass_reference
    y = np.full_like(x, np.nan)
    state = np.empty(3)
    started = False
    t_prev = 0.0
    w = 2.0 * np.pi * cutoff_hz
    for k in range(x.shape[0]):
        if not (np.isfinite(x[k, 0]) and np.isfinite(x[k, 1]) and np.isfinite(x[k, 2])):
            continue
        if not started:
            state[:] = x[k]
            started = True
        else:
            a = 1.0 - np.exp(-w * (times[k] - t_prev))
            for i in range(3):
                state[i] += a * (x[k, i] - state[i])
        t_prev = times[k]
        y[k] = state
    return y


def lowpass(x: ArrayLike, times: ArrayLike, cutoff_hz: float) -> np.ndarray:
    """Causal first-order low-pass (LP) of a sampled vector signal ``x`` ``(T, 3)`` at ``times`` ``(T,)``.

    The filter's time of row k is ``times[k]``; NaN rows give NaN and are ignored by the filter.
    """
    c = _check_cutoff_hz(cutoff_hz)
    x = np.ascontiguousarray(x, dtype=float)
    t = np.ascontiguousarray(times, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3 or t.shape != (x.shape[0],):
        raise ValueError(f"lowpass expects x of shape (T, 3) and times of shape (T,); got {x.shape} and {t.shape}")
    return _lowpass_kernel(x, t, c)


@overload
def whole_steps(intervals: float, step: float) -> float: ...
@overload
def whole_steps(intervals: ArrayLike, step: float) -> np.ndarray: ...
def whole_steps(intervals: ArrayLike, step: float) -> np.ndarray | float:
    """(D3): stamped ``intervals`` (s) read as the whole number of ``step`` nearest to each, at least one (a float
    for a float: one streaming step's; ``round`` rounds half to even as ``np.round`` does)."""
    if isinstance(intervals, float):
        return step * max(1.0, round(intervals / step))
    return step * np.maximum(1.0, np.round(np.asarray(intervals, dtype=float) / step))


def sample_clock(times: ArrayLike, step: float) -> np.ndarray:
    """(D3) for a whole log: the samples' times from the first stamp, each stamped interval as :func:`whole_steps`.
    ``(T,) -> (T,)``."""
    t = np.asarray(times, dtype=float)
    if t.size < 2:
        return t.copy()
    return np.concatenate([t[:1], t[0] + np.cumsum(whole_steps(np.diff(t), step))])


class DifferencingEstimator(StreamingEstimator):
    """Log-map differencing of attitudes (D1 or D2), optionally followed by the causal low-pass (LP).

    The equations, the delay of each scheme and the handling of non-finite samples are in the module docstring.
    Statuses: ``unavailable`` until two (backward) or three (central) valid samples, ``predicted`` at a skipped
    sample (the last estimate held), ``corrected`` elsewhere. Attributes after ``update``: ``estimate_time`` (the
    time the returned ω̂ is for), ``n_skipped`` (non-finite samples skipped so far). The parameters are keyword-only.

    Parameters
    ----------
    scheme : {"backward", "central"}, optional
        ``"backward"`` (default; (D1), causal) or ``"central"`` ((D2); one sample of delay: ``update`` returns ω̂
        for the previous sample time, see the module docstring).
    cutoff_hz : float or None, optional
        Cut-off of the first-order low-pass (LP) in Hz, or ``None`` (default) for raw differences.
    scalar_first, rotation_tol, quat_norm_tol : optional
        Quaternion order and the tolerances of the input checks (:mod:`omegahat.measurements`, the same for every
        estimator).
    omega_hat0 : array_like, optional
        Backward only: the rate at the first valid sample (rad/s, body axes; a rate known otherwise, such as
        ``omegahat estimate``'s least-squares start), which has no difference yet; default: none (NaN there).
    step : float, optional
        The samples' own step (s) where only their stamps jitter: each stamped interval is read as (D3); default
        None (each interval as stamped).
    taps : array_like, optional
        Backward only: the causal filter (D4) of the differences, ``(L,)`` or one column per body axis ``(L, 3)``,
        ``taps[0]`` for the newest; default None (the differences themselves).
    references : array_like, optional
        The inertial directions ``(n, 3)`` (n ≥ 2) of direction input: each sample's body-frame directions are
        checked as every estimator checks them, then turned into its least-squares attitude (Wahba's problem,
        :func:`omegahat.so3.wahba`), which is differenced; default None (attitudes).

    Raises
    ------
    ValueError
        If ``scheme`` is unknown, ``cutoff_hz`` is not a positive finite frequency, or ``omega_hat0`` is given
        with the central scheme.

    Examples
    --------
    A body turning at a constant rate, sampled at 100 Hz (quaternions, scalar last):

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import DifferencingEstimator
    >>> w = np.array([0.3, -0.2, 0.5])  # rad/s, body axes
    >>> t = np.arange(0.0, 1.0, 0.01)
    >>> q = Rotation.from_rotvec(np.outer(t, w)).as_quat()
    >>> est = DifferencingEstimator().run(t, q)
    >>> print(" ".join(f"{x:.3f}" for x in est.omega[-1]))
    0.300 -0.200 0.500
    >>> bool(np.isnan(est.omega[0]).all())  # the first sample has no difference yet
    True

    The central scheme, sample by sample: the third sample gives ω̂ for the second one's time.

    >>> central = DifferencingEstimator(scheme="central")
    >>> for k in range(3):
    ...     out = central.update(t[k], q[k])
    >>> print(f"t = {central.estimate_time:.2f} s:", " ".join(f"{x:.3f}" for x in out.omega))
    t = 0.01 s: 0.300 -0.200 0.500
    """

    def __init__(
        self,
        *,
        scheme: Scheme = "backward",
        cutoff_hz: float | None = None,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
        omega_hat0: ArrayLike | None = None,
        step: float | None = None,
        taps: ArrayLike | None = None,
        references: ArrayLike | None = None,
    ) -> None:
        self.scheme: Scheme = one_of("scheme", scheme, Scheme)
        self.references = None if references is None else as_directions(references)
        self.taps = None if taps is None else checked_taps(taps)
        if self.taps is not None and self.scheme != "backward":
            raise ValueError("taps filter the backward differences (scheme='backward')")
        self.step = None if step is None else float(as_positive(step, "step", n=1)[0])
        if omega_hat0 is not None and self.scheme != "backward":
            raise ValueError("omega_hat0 is for the backward scheme (central has no estimate at the first sample)")
        self.omega_hat0 = None if omega_hat0 is None else as_vector3(omega_hat0, "omega_hat0")
        self.cutoff_hz = _check_cutoff_hz(cutoff_hz)
        self.scalar_first = bool(scalar_first)
        self.rotation_tol, self.quat_norm_tol = ms.tolerances(rotation_tol, quat_norm_tol)
        self.causal = scheme == "backward"  # per instance: the scheme decides
        self.reset()

    @property
    def delay_samples(self) -> int:
        """How many samples late the output of ``update`` is (0 backward, 1 central)."""
        return 0 if self.scheme == "backward" else 1

    def reset(self) -> None:
        """Forget every sample."""
        self._R: list[np.ndarray] = []  # the last valid attitudes, at most 2 kept: [R_{k-1}, R_k]
        self._t: list[float] = []
        self._y = np.full(3, np.nan)  # last output (after the low-pass)
        self._y_time: float | None = None
        self._t_last: float | None = None  # the last sample's time, skipped or not (the time check's previous time)
        self.estimate_time: float | None = None
        self.n_skipped = 0
        self._stretch = Stretch([], [], None, None)  # (D4)–(D5): the current stretch
        self._skipped_since = False  # a sample was skipped since the last valid one

    def _span(self, interval: float) -> float:
        """A stamped interval as the differences take it: itself, or (D3) where the samples' step is given."""
        return interval if self.step is None else whole_steps(interval, self.step)

    def _checks(self) -> dict:
        return {
            "references": self.references,
            "scalar_first": self.scalar_first,
            "rotation_tol": self.rotation_tol,
            "quat_norm_tol": self.quat_norm_tol,
        }

    def _output(self, status: Status) -> Estimate:
        if not np.all(np.isfinite(self._y)):
            return Estimate(self._y.copy(), Status.UNAVAILABLE)
        return Estimate(self._y.copy(), status)

    def update(self, t: float, sample: Measurement, torque: ArrayLike | None = None) -> Estimate:
        """Take the attitude sampled at ``t``; return ω̂ (for ``t`` if backward, for the previous sample time
        if central), NaN (``unavailable``) until enough samples. A non-finite sample is skipped (the output held,
        ``predicted``); ``torque`` is checked like every estimator's but not used."""
        sample_ = ms.checked_sample(t, sample, torque, t_prev=self._t_last, **self._checks())  # raises: kept
        t, R = sample_.t, sample_.value
        self._t_last = t
        if self.references is not None and sample_.status == ms.OK:  # directions: the least-squares attitude
            R = so3.wahba(R[None], self.references)[0]
        if sample_.status != ms.OK:
            self.n_skipped += 1
            self._skipped_since = True
            return self._output(Status.PREDICTED)
        raw, when = None, np.nan  # the new estimate, if any, and its time (set together)
        if self.scheme == "backward":
            span = self._span(t - self._t[-1]) if self._t else np.nan
            if np.linalg.norm(self._y) * span >= np.pi:  # (D6): no difference across half a turn
                self._R, self._t, self._skipped_since = [R], [t], False
                self._stretch = Stretch([], [], None, span)
                return self._output(Status.PREDICTED)
            if self._t:
                raw = so3.log(self._R[-1].T @ R) / span  # (D1)
                when = t
                if self.taps is not None:
                    raw = self._filter(raw, span)
            elif self.omega_hat0 is not None:  # the first valid sample: the given rate
                raw, when = self.omega_hat0.copy(), t
            self._R, self._t = [R], [t]
            self._skipped_since = False
        else:
            if len(self._t) == 2:
                (R0, R1), (t0, t1) = self._R, self._t
                hb, hf = self._span(t1 - t0), self._span(t - t1)
                db = so3.log(R0.T @ R1) / hb
                df = so3.log(R1.T @ R) / hf
                raw = so3.log(R0.T @ R) / (hb + hf) - (hf - hb) * (df - db) / (hb + hf)  # (D2)
                when = t1
            self._R, self._t = [*self._R, R][-2:], [*self._t, t][-2:]
        if raw is not None:
            if self.cutoff_hz is None or self._y_time is None:
                self._y = raw
            else:
                a = 1.0 - np.exp(-2.0 * np.pi * self.cutoff_hz * (when - self._y_time))  # (LP)
                self._y = self._y + a * (raw - self._y)
            self._y_time = when
            self.estimate_time = when
        return self._output(Status.CORRECTED)

    def _filter(self, difference: np.ndarray, span: float) -> np.ndarray:
        """(D4)–(D5) with the newest ``difference`` over the interval ``span``: the filtered rate, or the difference
        where its stretch has fewer than L of them (or it breaks the stretch)."""
        assert self.taps is not None
        rate, self._stretch = next_in_stretch(self._stretch, self.taps, difference, span, self._skipped_since)
        return rate

    def _rates(self, differences, valid, held, clock, times, p) -> tuple[np.ndarray, Stretch]:
        """``run``'s rows from the ``differences`` at the ``valid`` samples, those ``held`` by (D6) holding the
        last rate (``p``: the first row is the last sample fed, whose output is the last one), and the filter's
        stretch after them."""
        est, stretch = differences.copy(), self._stretch
        if self.taps is not None:
            stretch = filtered_differences(est, valid, clock, self.taps, self._stretch if p else None, cut=held)
        if self.omega_hat0 is not None and valid.any() and not p:  # the first valid sample: the given rate
            est[np.flatnonzero(valid)[0]] = self.omega_hat0
        if p:
            est[0] = self._y  # the last output: the low-pass's state, held through skipped rows
        est[held] = np.nan
        if self.cutoff_hz is not None:  # (LP) from the last output's time; NaN rows are ignored by the filter
            since = np.r_[self._y_time, times[1:]] if p and self._y_time is not None else times
            est = lowpass(est, since, self.cutoff_hz)
        return _hold_skipped(est, valid & ~held, self.scheme), stretch

    def run(self, t: ArrayLike, data: Measurements, torque: ArrayLike | None = None) -> Estimate:
        """ω̂ for every sample time, ``(T, 3)``, row k for ``t[k]`` (for ``"central"`` too: rows are not delayed,
        and the last is ``unavailable``). Vectorised differences, the filter (D4)–(D5) by stretches and the compiled
        low-pass, equal on the valid samples to feeding ``update`` (shifted by ``delay_samples``), leaving the
        streaming state as if the log had been fed through ``update``. After samples were fed, the backward scheme
        continues from them the same way (the last valid attitude, a skipped sample after it, the filter's stretch
        and the low-pass carried over), so that a log run in pieces gives the rows of one run; the central scheme
        then runs the ``update`` loop itself, its rows moved back by ``delay_samples`` (the last ones then have no
        estimate yet: ``unavailable``). ``torque`` is checked like every estimator's but not used."""
        if self._t_last is not None and self.scheme == "central":
            fed = super().run(t, data, torque)
            d = self.delay_samples
            if fed.status.size == 0:
                return fed
            omega = np.full_like(fed.omega, np.nan)
            status = np.full_like(fed.status, Status.UNAVAILABLE)
            omega[:-d], status[:-d] = fed.omega[d:], fed.status[d:]  # update's answer at sample k is for k - d
            return Estimate(omega, status)
        log = ms.checked_log(t, data, torque, t_prev=self._t_last, **self._checks())  # raises: nothing changed
        times, R = log.times, log.values
        if self.references is not None:  # directions: each valid sample's least-squares attitude
            R = np.where(log.valid[:, None, None], so3.wahba(R, self.references), np.nan)
        # Carried over from the samples fed before (backward only): the last valid attitude, and after it one
        # skipped sample where any was (it breaks the filter's stretch, as in update).
        carried_t = [*self._t[-1:], *([self._t_last] if self._t and self._skipped_since else [])]
        carried_R = [*self._R[-1:], *([np.full((3, 3), np.nan)] if len(carried_t) == 2 else [])]
        p = len(carried_t)
        times = np.concatenate([carried_t, times]) if p else times
        R = np.concatenate([np.reshape(carried_R, (p, 3, 3)), R]) if p else R
        clock = times if self.step is None else sample_clock(times, self.step)  # (D3)
        differences, valid = _differences(clock, R, self.scheme)
        held = np.zeros(valid.shape, bool)  # (D6): rows held rather than differenced across half a turn
        while True:  # a row's (D6) depends on the rows before it: the first disagreement is decided, the rest guessed
            est, stretch = self._rates(differences, valid, held, clock, times, p)
            turns = _half_turns(est, valid, clock) if self.scheme == "backward" else held
            wrong = np.flatnonzero(turns != held)
            if not wrong.size:
                break
            held[wrong[0] :] = turns[wrong[0] :]
        self._stretch = stretch
        status = batch_status(valid & ~held, est)
        # Streaming state consistent with the log.
        iv = np.flatnonzero(valid)
        keep = 1 if self.scheme == "backward" else 2
        self._R = [R[j] for j in iv[-keep:]]
        self._t = [float(times[j]) for j in iv[-keep:]]
        self.n_skipped += int(np.count_nonzero(~log.valid))
        if iv.size:
            self._skipped_since = bool(iv[-1] < times.size - 1)
        elif times.size:  # nothing valid yet: every sample skipped
            self._skipped_since = True
        self._t_last = float(times[-1]) if times.size else self._t_last
        own = np.flatnonzero(valid & ~held)  # the samples with an estimate of their own
        last = own[-keep] if own.size >= keep else None  # the sample the last estimate is for (p: 0 is the last one)
        fresh = last is not None and not (p and last == 0) and (self.scheme == "backward" or own.size >= 3)
        if fresh and np.all(np.isfinite(est[last])):
            self._y, self._y_time = est[last].copy(), float(times[last])
        self.estimate_time = self._y_time
        return Estimate(est[p:], status[p:])
