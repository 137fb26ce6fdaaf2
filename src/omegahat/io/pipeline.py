r"""From an open log to written estimates: the one path of ``omegahat estimate`` and :func:`omegahat.estimate_frame`.

:func:`estimate_stream` takes a :class:`~omegahat.io.registry.LogStream` (any format, already converted and
checked by :func:`~omegahat.io.registry.open_log`: time unit, rotation convention, timestamp policy) and a writer
(:func:`omegahat.io.output.open_output`, or the DataFrame collector of :mod:`omegahat.io.frames`), and does, in
order:

1. **What was read**: the stream's description (``detected OptiTrack Motive CSV ...``) and notes are reported.
2. **The head** (the first :data:`omegahat.observer.autogain.HEAD_SAMPLES` samples) is checked by the
   estimator's own compiled checks on a throwaway estimator, which also compiles (or loads from the cache) the
   kernels the run needs, announced when it takes long. A sample that is not a rotation stops the run with a
   message naming its line and column and the options that would accept or skip it, unless
   ``skip_bad_samples`` (:class:`BadSamples`): then it is treated as missing, counted and reported.
3. **Gains** from the head's rate, noise and motion (:func:`omegahat.observer.autogain.select_gains`: automatic
   unless gains or a bandwidth are given); a warning when the sample spacing is implausible for the time unit,
   and, with J and τ given, when Euler's equations fit the other rotation convention markedly better.
4. **Start**: ``fit`` (least-squares rate over the first window), ``warm`` (from the first two samples) or
   ``zero``.
5. **Estimation** chunk by chunk through one :class:`~omegahat.observer.estimator.SarrasEstimator` (memory does
   not grow with the log), each chunk written with its per-row status (``corrected``, ``predicted``,
   ``unavailable``: :mod:`omegahat.io.output`); gaps longer than twice the median spacing are counted.
6. **Summary**: rows written, samples skipped and why, bad samples, gaps, the gains used.

Messages name options as the caller spells them (:class:`EstimateSettings`: ``--rotation-tol`` on the command
line, ``rotation_tol=`` in Python).
"""

from __future__ import annotations

import re
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat.io.columns import LogFormatError
from omegahat.io.output import CORRECTED, PREDICTED, RESTARTED, UNAVAILABLE
from omegahat.io.registry import ROTATIONS, TIME_UNITS, LogChunk, LogStream, prefetch
from omegahat.io.single_direction import estimate_single_direction
from omegahat.io.smoothing import write_smoothed
from omegahat.kernels import compiling
from omegahat.observer import autogain
from omegahat.observer.estimator import SarrasEstimator, SkippedSamplesWarning
from omegahat.observer.gains import ObserverGains
from omegahat.observer.kalman import SupervisedKalmanEstimator
from omegahat.observer.presets import MOCAP_SWITCH_HZ, MOCAP_TUNED_NOISE, PRESETS, mocap_estimator, mocap_model
from omegahat.validation import as_directions, as_inertia

__all__ = [
    "STARTS",
    "BadSamples",
    "ChunkWriter",
    "EstimateSettings",
    "RunSummary",
    "estimate_stream",
    "time_unit_warning",
]

STARTS = autogain.STARTS
ESTIMATORS = ("auto", "omegahat", "sarras")  #: auto: omegahat when the inertia is given (and no gains), else sarras
_CLI_FLAGS = {
    "inertia": "--inertia",
    "estimator": "--estimator",
    "start": "--start",
    "references": "--references",
    "rotation_tol": "--rotation-tol",
    "quat_norm_tol": "--quat-norm-tol",
    "skip_bad_samples": "--skip-bad-samples",
    "bandwidth": "--bandwidth",
    "rotation": "--rotation",
    "time_unit": "--time-unit",
    "quaternion_order": "--quaternion-order",
    "preset": "--preset",
    "smooth": "--smooth",
    "gains": "--k/--l",
}
_PY_NAMES = {"bandwidth": "bandwidth_hz", "quaternion_order": "the order of the quaternion= columns (x, y, z, w)"}


class ChunkWriter(Protocol):
    """What :func:`estimate_stream` writes through (inside a ``with`` block): :class:`omegahat.io.OmegaWriter`,
    :class:`omegahat.io.rosbag.TwistBagWriter`, or the DataFrame collector of :mod:`omegahat.io.frames`;
    a writer that has a ``describe()`` method says with it what it wrote."""

    def write(self, chunk: LogChunk, omega: np.ndarray, status: np.ndarray) -> None: ...


@dataclass(frozen=True)
class EstimateSettings:
    """What to estimate with: ``inertia`` (3×3, 3 or 9 numbers; default identity: a locally constant rate),
    ``references`` (inertial directions ``(n, 3)``; required for direction input, default the three rows of R),
    ``gains`` or ``bandwidth_hz`` (default: chosen from the log), ``start`` (``fit``, ``warm`` or ``zero``),
    ``estimator`` (``auto``: the default estimator — the observer supervising a gyro-less EKF — when the inertia is
    given and no gains or bandwidth are, else the fixed-gain observer; or ``omegahat`` / ``sarras`` to choose),
    ``skip_bad_samples`` and the tolerances of :mod:`omegahat.measurements`; ``cli``: name options as the
    command line does (``--rotation-tol``) rather than as Python does (``rotation_tol=``)."""

    inertia: ArrayLike | None = None
    references: np.ndarray | Sequence[ArrayLike] | None = None
    gains: ObserverGains | None = None
    bandwidth_hz: float | None = None
    start: str = "fit"
    estimator: str = "auto"
    skip_bad_samples: bool = False
    rotation_tol: float = ms.ROTATION_TOL
    quat_norm_tol: float = ms.QUAT_NORM_TOL
    cli: bool = False
    preset: str | None = None
    smooth: bool = False

    def __post_init__(self):
        if self.start not in STARTS:
            raise ValueError(f"start must be one of {', '.join(STARTS)}; got {self.start!r}")
        if self.estimator not in ESTIMATORS:
            raise ValueError(f"estimator must be one of {', '.join(ESTIMATORS)}; got {self.estimator!r}")
        if self.preset is not None and self.preset not in PRESETS:
            raise ValueError(f"preset must be one of {', '.join(PRESETS)}; got {self.preset!r}")
        if self.smooth and self.preset is None:
            raise ValueError(f"{self.opt('smooth')} needs {self.opt('preset', 'mocap')} (the smoother's model)")
        if self.preset is not None:
            given = [
                self.name(k)
                for k, v in (("inertia", self.inertia), ("bandwidth", self.bandwidth_hz), ("gains", self.gains))
                if v is not None
            ] + ([self.name("estimator")] if self.estimator != "auto" else [])
            if given:
                raise ValueError(
                    f"{self.opt('preset', self.preset)} chooses the model and gains itself (inertia and torque "
                    f"unknown); drop {', '.join(given)} or the preset"
                )

    def name(self, key: str) -> str:
        """An option's name as the caller writes it: ``--rotation-tol`` or ``rotation_tol``."""
        return _CLI_FLAGS[key] if self.cli else _PY_NAMES.get(key, key)

    def opt(self, key: str, value: object = None) -> str:
        """An option with a value as the caller writes it: ``--rotation-tol 0.02`` or ``rotation_tol=0.02``; a
        switch without one: ``--skip-bad-samples`` or ``skip_bad_samples=True``."""
        if self.cli:
            return self.name(key) + (
                "" if value is None else f" {value:g}" if isinstance(value, float) else f" {value}"
            )
        return self.name(key) + "=" + ("True" if value is None else repr(value))


@dataclass
class RunSummary:
    """What :func:`estimate_stream` did: ``rows`` written, the ``gains`` and the ``gains_text`` saying why,
    ``n_missing``/``n_collinear`` samples skipped by the estimator, ``n_bad`` treated as missing
    (``skip_bad_samples``), ``gaps`` and the ``largest_gap`` ``(seconds, label after it)``, ``elapsed`` seconds
    estimating, ``compile_s`` seconds checking the head (compilation included), ``output``: what the writer says
    it wrote (its ``describe()``), and ``lines``: the report."""

    rows: int = 0
    output: str = ""
    gains: ObserverGains | None = None
    gains_text: str = ""
    n_missing: int = 0
    n_collinear: int = 0
    n_bad: int = 0
    gaps: int = 0
    largest_gap: tuple[float, int | None] = (0.0, None)
    elapsed: float = 0.0
    compile_s: float = 0.0
    lines: list[str] = field(default_factory=list)


def _g2(x: float) -> float:
    """``x`` to 2 significant digits (a tolerance to suggest)."""
    return float(f"{x:.2g}")


def _rejection(status: int, info: float, s: EstimateSettings) -> str:
    skip = s.opt("skip_bad_samples")
    if status == ms.NOT_ORTHOGONAL:
        return (
            f"not a rotation matrix: |R^T R - I| = {info:.3g} exceeds {s.opt('rotation_tol', s.rotation_tol)} "
            f"(pass {s.opt('rotation_tol', _g2(2 * info))} to accept it, or {skip} to skip such samples)"
        )
    if status == ms.NOT_PROPER:
        return f"a reflection, not a rotation: det R = {info:.6g} < 0 ({skip} skips such samples)"
    if status == ms.QUAT_NORM:
        return (
            f"a quaternion far from unit norm: |q| = {info:.6g}, |(|q| - 1)| exceeds "
            f"{s.opt('quat_norm_tol', s.quat_norm_tol)} (pass {s.opt('quat_norm_tol', _g2(2 * abs(info - 1)))} to "
            f"accept it, {skip} to skip such samples, or check {s.name('quaternion_order')})"
        )
    if status == ms.ZERO_DIRECTION:
        return f"measured direction b{int(info) + 1} has zero length ({skip} skips such samples)"
    return f"rejected (status {status})"


class BadSamples:
    """Rejected samples: checked chunk by chunk, dropped (NaN) with ``skip_bad_samples``, else an error naming the
    line (index, message, frame, row) and the attitude's columns."""

    def __init__(self, settings: EstimateSettings, stream: LogStream):
        self.settings, self.stream, self.count = settings, stream, 0
        self.first: list[tuple[int, str]] = []  # (label, why) of the first few bad samples, for the summary

    def check(self, chunk: LogChunk) -> None:
        s = self.settings
        st, info = ms.sample_status(
            chunk.data,
            directions=self.stream.kind == "directions",
            rotation_tol=s.rotation_tol,
            quat_norm_tol=s.quat_norm_tol,
        )
        bad = np.flatnonzero(st >= ms.ERROR)
        if not bad.size:
            return
        k = int(bad[0])
        if not s.skip_bad_samples:
            where = self.stream.where(int(chunk.labels[k]), self.stream.attitude_name)
            raise LogFormatError(f"{where}: {_rejection(int(st[k]), float(info[k]), s)}")
        chunk.data[bad] = np.nan
        self.count += bad.size
        for j in bad[: max(0, 5 - len(self.first))]:
            self.first.append((int(chunk.labels[j]), _rejection(int(st[j]), float(info[j]), s)))


def _references(settings: EstimateSettings, stream: LogStream) -> np.ndarray:
    refs = settings.references
    if stream.kind == "directions":
        n = stream.n_directions
        if refs is None:
            how = '"--references=X,Y,Z;X,Y,Z" (one per direction, quoted)' if settings.cli else "references= (n, 3)"
            raise ValueError(
                f"{stream.source} holds {n} body-frame directions (b1..b{n}): give their inertial directions with {how}"
            )
        if len(refs) != n:
            raise ValueError(
                f"{stream.source} holds {n} directions but {settings.name('references')} gives {len(refs)}"
            )
    if refs is None:
        return np.eye(3)
    return as_directions(np.array(refs, dtype=float), name="--references" if settings.cli else "references")


def time_unit_warning(h: float, t0: float, unit: str, settings: EstimateSettings) -> str | None:
    """A warning when samples ``h`` s apart (first time ``t0``) are implausible in ``unit`` (rates outside
    0.5 Hz – 5 kHz, or times beyond 1e11), suggesting the unit that would make them plausible."""
    rate = 1.0 / h
    if abs(t0) > 1e11 or not (0.5 <= rate <= 5000.0):
        scale = TIME_UNITS[unit]
        better = [u for u, f in TIME_UNITS.items() if u != unit and 0.5 <= 1.0 / (h / scale * f) <= 5000.0]
        tip = "".join(
            f"; if the times are in {u}, pass {settings.opt('time_unit', u)} ({scale / (h * TIME_UNITS[u]):.4g} Hz)"
            for u in better[:1]
        )
        return f"warning: samples are {h:.4g} s apart ({rate:.4g} Hz) with {settings.opt('time_unit', unit)}{tip}"
    return None


def _check_head(head, stream, refs, bad, settings) -> None:
    """Validate the head with the estimator's own compiled checks (a throwaway estimator: this also compiles, or
    loads from the cache, the kernels the run needs); only if it rejects a sample are the samples checked one by one
    (:class:`BadSamples`)."""
    probe = SarrasEstimator(
        np.eye(3),
        gains=ObserverGains.constant(1.0, 1.0, n=refs.shape[0]),
        references=refs,
        measurement="directions" if stream.kind == "directions" else "attitude",
        warm_start=False,
        rotation_tol=settings.rotation_tol,
        quat_norm_tol=settings.quat_norm_tol,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SkippedSamplesWarning)
        for c in head:
            try:
                probe.run(c.t, c.data, c.torque)
            except ms.MeasurementError:
                bad.check(c)  # raises naming the line, or (skip_bad_samples) turns bad samples into missing
                probe.run(c.t, c.data, c.torque)


class _Run:
    """One pass over the stream: bad samples, estimation, gaps, output (state kept across chunks)."""

    def __init__(self, est, stream, writer, bad, start: str, h: float, summary: RunSummary):
        self.est, self.stream, self.writer, self.bad, self.start = est, stream, writer, bad, start
        self.summary = summary
        self.valid_seen = 0  # valid samples so far (the estimate exists from the 1st (fit) or 2nd (warm, zero))
        self.gap_limit = 2.0 * h
        self.t_prev: float | None = None

    def _estimate(self, chunk) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SkippedSamplesWarning)  # counted and reported once, at the end
            return self.est.run(chunk.t, chunk.data, chunk.torque)

    def feed(self, chunk) -> None:
        s = self.summary
        t0, c0 = time.perf_counter(), compiling.seconds()
        try:
            W = self._estimate(chunk)
        except ms.MeasurementError:  # a sample is not a rotation: find it (line, column), skip it or stop there
            self.bad.check(chunk)  # run() is atomic: the estimator is as before the call
            W = self._estimate(chunk)
        except ValueError as exc:  # not expected after the reader's checks; name the line anyway
            lab = chunk.labels
            raise ValueError(
                re.sub(r"sample (\d+)", lambda m: f"{self.stream.label} {lab[int(m.group(1))]}", str(exc))
            ) from None
        s.elapsed += time.perf_counter() - t0 - (compiling.seconds() - c0)  # compiling is not estimating
        st = self.est.last_status
        ok = np.flatnonzero(st == ms.OK)
        need = 1 if self.start == "fit" else 2  # the valid sample from which on there is an estimate
        if self.valid_seen >= need:  # estimates from the chunk's start (even if it holds no valid sample)
            first = 0
        elif self.valid_seen + ok.size < need:
            first = len(chunk)
        else:
            first = int(ok[need - 1 - self.valid_seen])
        self.valid_seen += ok.size
        status = np.where(st == ms.OK, CORRECTED, PREDICTED).astype(np.int8)
        status[:first] = UNAVAILABLE
        status[~np.all(np.isfinite(W), axis=1)] = UNAVAILABLE  # no estimate (after a restart): never labelled one
        status[st == ms.RESTARTED] = RESTARTED
        W[(status == UNAVAILABLE) | (status == RESTARTED)] = np.nan
        self.writer.write(chunk, W, status)
        s.rows += len(chunk)
        dt = np.diff(chunk.t if self.t_prev is None else np.concatenate([[self.t_prev], chunk.t]))
        big = np.flatnonzero(dt > self.gap_limit)
        s.gaps += big.size
        if big.size:
            j = int(big[np.argmax(dt[big])])
            if dt[j] > s.largest_gap[0]:
                s.largest_gap = (float(dt[j]), int(chunk.labels[j + 1 if self.t_prev is None else j]))
        self.t_prev = float(chunk.t[-1])


def _head(chunks) -> tuple[list, int]:
    """Chunks from the start until HEAD_SAMPLES rows (kept for the real pass), and the rows in them."""
    head, rows = [], 0
    for chunk in chunks:
        head.append(chunk)
        rows += len(chunk)
        if rows >= autogain.HEAD_SAMPLES:
            break
    return head, rows


def estimate_stream(
    stream: LogStream,
    settings: EstimateSettings,
    open_writer: Callable[[LogStream], AbstractContextManager[ChunkWriter]],
    report: Callable[[str], None] = print,
    progress: Callable[[int], None] | None = None,
    announce: Callable[[str], None] | None = None,
) -> RunSummary:
    """Estimate the rate of every sample of ``stream`` and write it (module docstring: the steps).

    ``open_writer(stream)`` makes the writer (a context manager with ``write(chunk, omega, status)``; the output
    is whole or absent); it is called only once the head has been checked and the gains chosen. ``report`` gets
    what was read and chosen as it happens; the closing lines (what the timestamp policy changed, samples skipped,
    gaps, the gains used) are in the returned ``RunSummary.lines``. ``progress(rows)`` is called after each chunk;
    ``announce`` (default: standard error) gets the notice that the kernels are being compiled. Raises
    :class:`~omegahat.io.LogFormatError` or ``ValueError`` naming the place and the option to use.
    """
    if stream.description:
        report(f"detected {stream.description}")
    for note in stream.notes:
        report(f"note: {note}")
    n_notes = len(stream.notes)
    if stream.kind == "directions" and stream.n_directions == 1:  # one direction: its own observer (no attitude)
        if settings.preset is not None:
            raise ValueError(f"{settings.opt('preset', settings.preset)} needs attitudes or two directions or more")
        return estimate_single_direction(stream, settings, open_writer, RunSummary(), report, progress)
    J = (
        np.eye(3)
        if settings.inertia is None
        else as_inertia(np.asarray(settings.inertia, dtype=float), name=settings.name("inertia"))
    )
    refs = _references(settings, stream)
    bad = BadSamples(settings, stream)
    summary = RunSummary()
    chunks = prefetch(stream.chunks())
    head, n_head = _head(chunks)
    compiled_before = compiling.seconds()
    compiling.announce_with(announce or _stderr)  # said when a compilation starts (here or at the first chunk)
    _check_head(head, stream, refs, bad, settings)
    t_h = np.concatenate([c.t for c in head])
    data_h = np.concatenate([c.data for c in head])
    tau_h = np.concatenate([c.torque for c in head]) if stream.has_torque else None
    ok = np.all(np.isfinite(data_h.reshape(t_h.size, -1)), axis=1)
    if ok.sum() < 3:
        raise LogFormatError(
            f"{stream.source}: only {int(ok.sum())} usable samples in the first {n_head}; at least 3 "
            "are needed to estimate a rate"
        )
    tv, rot = autogain.log_rotations(t_h, data_h, stream.kind, refs)
    motion = autogain.measure_motion(tv, rot, J, None if tau_h is None else tau_h[ok])
    finished = n_head < autogain.HEAD_SAMPLES or stream.n_rows_hint == n_head
    duration = float(t_h[-1] - t_h[0])
    if not finished:
        total = stream.n_rows_hint or (stream.size / max(stream.done, 1) * n_head)
        duration *= total / n_head
    options = stream.options
    unit = options.time_unit if options is not None else "s"
    warning = time_unit_warning(motion.h, float(stream.t0 + t_h[0]), unit, settings)
    if warning:
        report(warning)
    gains, text, omega_b = autogain.select_gains(
        motion,
        duration,
        settings.start,
        refs,
        gains=settings.gains,
        bandwidth_hz=settings.bandwidth_hz,
        flag=settings.name("bandwidth"),
    )
    summary.gains, summary.gains_text = gains, text
    if settings.preset is None:
        report(text)
    elif stream.has_torque:
        raise ValueError(
            f"{settings.opt('preset', settings.preset)} is for bodies whose torque is unknown, but the log has torque "
            f"columns; to use them, drop the preset and give {settings.name('inertia')}"
        )
    elif settings.smooth and stream.kind == "directions":
        raise ValueError(f"{settings.opt('smooth')} takes attitudes (quaternions or rotation matrices)")
    rotation = options.rotation if options is not None else ROTATIONS[0]
    if settings.inertia is not None and stream.has_torque and stream.kind != "directions":
        given, other = autogain.convention_check(motion)
        if other < 0.5 * given:
            flip = ROTATIONS[1 - ROTATIONS.index(rotation)]
            report(
                f"warning: Euler's equations with this J and torque fit the data {given / other:.1f}x better with "
                f"the attitude inverted (residual {other:.3g} against {given:.3g} N m): is the log {flip}? "
                f"(pass {settings.opt('rotation', flip)})"
            )
    omega0 = None
    if settings.start == "fit":
        window = autogain.fit_window(omega_b, motion.rate_hz)
        omega0 = autogain.initial_rate(tv, rot, window, J, motion.torque)
    est = _estimator(settings, motion, J, gains, refs, stream, omega0, report)
    h = motion.h
    rate_hz, noise_std, smoothed_missing = motion.rate_hz, motion.sigma, 0
    del t_h, data_h, tau_h, tv, rot, motion
    with open_writer(stream) as writer:
        job = _Run(est, stream, writer, bad, settings.start, h, summary)
        if settings.smooth:
            tols = (settings.rotation_tol, settings.quat_norm_tol)
            done = write_smoothed([*head, *chunks], bad.check, writer.write, rate_hz, noise_std, *tols)
            summary.rows, summary.elapsed, smoothed_missing = done.rows, done.elapsed, done.n_missing
            head.clear()
        while head:  # the head first (releasing it as it goes), then the rest of the stream
            job.feed(head.pop(0))
        for chunk in chunks:
            job.feed(chunk)
            if progress is not None:
                progress(summary.rows)
    compiling.announce_with(None)
    summary.compile_s = compiling.seconds() - compiled_before
    describe = getattr(writer, "describe", None)
    summary.output = describe() if describe is not None else f"{summary.rows} estimates"
    summary.n_missing, summary.n_collinear, summary.n_bad = est.n_missing, est.n_collinear, bad.count
    if settings.smooth:  # the causal estimator did not run: the smoother's count
        summary.n_missing = smoothed_missing
    summary.lines = _summary_lines(summary, est, stream, bad, J, settings, stream.notes[n_notes:])
    return summary


def _estimator(settings: EstimateSettings, motion, J, gains, refs, stream, omega0, report):
    """The estimator of the run: the default one (the observer supervising a gyro-less EKF, its process noise chosen
    from the log) when the model is given, or asked for; else the fixed-gain observer with ``gains``."""
    common = {
        "references": refs,
        "measurement": "directions" if stream.kind == "directions" else "attitude",
        "warm_start": settings.start == "warm",
        "omega_hat0": omega0 if omega0 is not None else (None if settings.start == "warm" else np.zeros(3)),
        "rotation_tol": settings.rotation_tol,
        "quat_norm_tol": settings.quat_norm_tol,
    }
    if settings.preset is not None:
        how = "forward and backward passes averaged (zero lag)" if settings.smooth else "causal"
        described = mocap_model(motion.rate_hz, motion.sigma).describe()
        report(f"estimator: {settings.opt('preset', settings.preset)} ({how}): {described}")
        if motion.rate_hz >= MOCAP_SWITCH_HZ and motion.sigma > MOCAP_TUNED_NOISE:
            report(
                f"warning: the log's attitude noise ({motion.sigma:.2g} rad) is above that of the recordings the "
                f"preset was tuned on (optical motion capture of a hand, up to {MOCAP_TUNED_NOISE:g} rad): on a "
                "slow or smooth motion, omegahat without the preset (gains chosen from this log) may be more accurate"
            )
        return mocap_estimator(motion.rate_hz, motion.sigma, **common)
    choice = settings.estimator
    if choice == "auto":
        model = settings.inertia is not None and settings.gains is None and settings.bandwidth_hz is None
        choice = "omegahat" if model else "sarras"
    if choice == "sarras":
        return SarrasEstimator(J=J, gains=gains, **common)
    sigma_a, text = autogain.choose_rate_noise(motion)
    report(
        "estimator: omegahat (the observer supervising a gyro-less EKF, as the inertia is given); "
        f"{text}; its observer runs at {motion.rate_hz:.4g} rad/s (the sample rate), not at the bandwidth above"
    )
    return SupervisedKalmanEstimator(
        J, rate_hz=motion.rate_hz, measurement_sigma=max(motion.sigma, 1e-6), rate_noise=sigma_a, **common
    )


def _summary_lines(
    s: RunSummary, est: SarrasEstimator | SupervisedKalmanEstimator, stream, bad: BadSamples, J,
    settings: EstimateSettings, notes,
) -> list[str]:  # fmt: skip
    lines = [f"note: {note}" for note in notes]  # what the timestamp policy changed, known once the stream is read
    skipped = s.n_missing + s.n_collinear
    if skipped:
        lines.append(
            f"skipped {skipped} of {s.rows} samples ({s.n_missing} missing, {s.n_collinear} with nearly "
            "collinear directions): predicted through (status 'predicted')"
        )
    if getattr(est, "n_restarts", 0):
        lines.append(
            f"restarted {est.n_restarts} times: a step's result was not finite (a gap too long for the model, a "
            "torque or gains too large); no estimate there until the next warm start (status 'restarted')"
        )
    if bad.count:
        first = "; ".join(f"{stream.label} {lab}: {why.split(' (')[0]}" for lab, why in bad.first)
        lines.append(
            f"{settings.name('skip_bad_samples')}: {bad.count} bad samples treated as missing (first: {first})"
        )
    if s.gaps:
        lines.append(
            f"gaps: {s.gaps} intervals longer than twice the median spacing; the longest {s.largest_gap[0]:.4g} s "
            f"before {stream.label} {s.largest_gap[1]} (predicted through)"
        )
    if isinstance(est, SupervisedKalmanEstimator):
        lines.append(
            f"estimator used: omegahat (observer at {est.observer_rate:.4g} rad/s, EKF rate noise {est.rate_noise:.3g} "
            f"rad/s^1.5, {est.restarts} restarts), J diag = {np.diag(J).tolist()}, start: {settings.start}"
        )
        return lines
    k_text, l_text = (np.array2string(a, precision=4) for a in (est.gains.k, est.gains.l_offset))
    lines.append(f"gains used: k = {k_text}, l = {l_text}, J diag = {np.diag(J).tolist()}, start: {settings.start}")
    return lines


def _stderr(text: str) -> None:
    print(text, file=sys.stderr)
