r"""The development corpus: recordings with a reference rate, every method run as a user runs it, one score.

**A recording** is one NPZ file (written by :func:`save_recording`, read by :func:`load_recording`; made by
``benchmarks/corpus.py`` from local copies of public data sets and from an independent MuJoCo plant). It is an
omegahat NPZ log, so ``omegahat estimate NAME.npz -o out.csv`` reads it as it is (``meta["command"]`` says which
options its model needs), plus arrays the reader ignores:

====================  ===================================================================================
``t (N,)``            attitude sample times, s from the recording's start
``q (N, 4)``          attitude quaternion, scalar first (``scalar_first = True``), body → inertial; or
``b (N, n, 3)``       body-frame directions of the inertial ``references (n, 3)``
``tau (N, 3)``        the torque (N·m, body axes), only when the estimator is to be given it
``inertia (3, 3)``    J, only when the estimator is to be given it
``ref_t (M,)``        the reference's times on the attitude clock (a calibrated gyroscope: ``t − δ``)
``ref_w (M, 3)``      the reference rate, rad/s, body axes (``A⁻¹(g − b)`` of the calibration, or the truth)
``motion (N,)``       the samples to score (BROAD's ``movement``; all for UPenn; after the start-up for a plant)
``meta``              JSON: name, source, licence, description, the calibration applied, the decimations to
                      score (``decimate``), the score's options (``score``), notes, the command line
====================  ===================================================================================

**The score** is :func:`omegahat.lab.evaluation.broad.score`, the one definition: in band (default 10 Hz or 0.4 ×
the rate), at the best continuous shift within ±3 samples, for every method alike. A simulation's exact truth is
scored without the low-pass and without a shift (``meta["score"]``: ``cutoff_hz = "none"``, ``max_shift = 0``):
its error is what a controller would see.

**Methods** (:data:`METHODS`, a list to extend): each turns a :class:`Recording` into an :class:`Outcome` (the rate
at every sample, and the method's own prediction of its RMS error when it makes one). omegahat's own are run
through :func:`omegahat.io.pipeline.estimate_stream`, the path of ``omegahat estimate``, on a stream of the
recording's arrays (:meth:`Recording.stream`): what is measured is what a user gets. The table: backward and
central differencing, RotationSpline, Savitzky–Golay (:data:`SAVGOL`), ``omegahat estimate`` with no option (but the
inertia and references a recording gives), ``--estimator sarras`` (with J only), the fixed-gain observer at the
best ``--bandwidth`` in hindsight (an oracle: :data:`HINDSIGHT_BANDWIDTHS`, scored on the recording itself),
``--preset mocap`` and ``--preset mocap --smooth`` (not on logs with torque), and the gyro-less MEKF.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from omegahat import so3
from omegahat.cli.many_run import expected_error
from omegahat.io import LogStream, ReadOptions
from omegahat.io.pipeline import EstimateSettings, estimate_stream
from omegahat.io.registry import checked_stream
from omegahat.lab.evaluation.broad import Score, score

__all__ = [
    "METHODS",
    "Method",
    "Outcome",
    "Recording",
    "Row",
    "corpus_dir",
    "evaluate",
    "group_of",
    "load_recording",
    "pipeline_method",
    "recordings",
    "save_recording",
]

FORMAT_VERSION = 1


def corpus_dir() -> Path:
    """``$OMEGAHAT_CORPUS_DIR`` if set, else ``../corpus`` relative to the working directory (where
    ``benchmarks/corpus.py`` is suggested to write it)."""
    env = os.environ.get("OMEGAHAT_CORPUS_DIR")
    return Path(env).resolve() if env else (Path.cwd() / ".." / "corpus").resolve()


@dataclass(frozen=True)
class Recording:
    """One recording (module docstring). ``kind`` is ``"quaternion"`` (``data (N, 4)`` scalar **last**, SciPy's
    order, NaN rows missing) or ``"directions"`` (``data (N, n, 3)`` with ``references (n, 3)``); ``torque`` and
    ``inertia`` are given to the estimators only when present; ``movement`` marks the scored samples. A decimated
    recording keeps its ``native`` one's reference."""

    name: str
    t: np.ndarray
    kind: str
    data: np.ndarray
    reference_times: np.ndarray
    reference_rates: np.ndarray
    movement: np.ndarray
    meta: dict = field(default_factory=dict)
    references: np.ndarray | None = None
    torque: np.ndarray | None = None
    inertia: np.ndarray | None = None
    native: Recording | None = field(default=None, repr=False)

    @property
    def fs(self) -> float:
        """Sample rate, Hz (from the median step)."""
        return 1.0 / float(np.median(np.diff(self.t)))

    @property
    def gaps(self) -> np.ndarray:
        """Samples without a measurement ``(N,)``."""
        return ~np.all(np.isfinite(self.data.reshape(self.t.size, -1)), axis=1)

    @property
    def R(self) -> np.ndarray:
        """Attitudes ``(N, 3, 3)`` body → inertial, NaN in gaps; for directions the least-squares attitude of each
        sample (Wahba's problem: the rotation nearest to ``Σ v_i b_iᵀ``)."""
        R = np.full((self.t.size, 3, 3), np.nan)
        ok = ~self.gaps
        if self.kind == "quaternion":
            R[ok] = so3.from_quat(self.data[ok])
        else:
            R[ok] = so3.wahba(self.data[ok], np.asarray(self.references, dtype=float))
        return R

    def decimated(self, step: int) -> Recording:
        """Every ``step``-th sample, scored against the native reference (as :meth:`broad.Trial.decimated`)."""
        if int(step) != step or step < 1:
            raise ValueError(f"step must be a positive integer; got {step!r}")
        if step == 1:
            return self
        pick = slice(None, None, int(step))
        base = self.native or self
        return replace(
            self, name=f"{base.name}@{base.fs / step:.3g}Hz", t=self.t[pick], data=self.data[pick],
            movement=self.movement[pick], torque=None if self.torque is None else self.torque[pick], native=base,
        )  # fmt: skip

    def score_options(self) -> dict:
        """The options of :func:`broad.score` this recording is scored with (``meta["score"]``)."""
        opts = dict((self.native or self).meta.get("score", {}))
        if opts.get("cutoff_hz") == "none":
            opts["cutoff_hz"] = math.inf
        return opts

    def stream(self) -> LogStream:
        """The recording as a checked :class:`omegahat.io.LogStream`, as :func:`omegahat.io.open_log` gives a file."""
        stream = LogStream.from_arrays(
            self.name, self.kind, self.t, self.data.copy(), None if self.torque is None else self.torque.copy()
        )
        return checked_stream(stream, ReadOptions())


def save_recording(path: str | os.PathLike[str], rec: Recording) -> None:
    """Write ``rec`` as the NPZ of the module docstring."""
    arrays: dict[str, np.ndarray] = {"t": rec.t, "ref_t": rec.reference_times, "ref_w": rec.reference_rates}
    if rec.kind == "quaternion":
        arrays["q"] = np.roll(rec.data, 1, axis=1)  # scalar first, and say so: the reader needs no option
        arrays["scalar_first"] = np.array(True)
    else:
        arrays["b"] = rec.data
        arrays["references"] = np.asarray(rec.references)
    if rec.torque is not None:
        arrays["tau"] = rec.torque
    if rec.inertia is not None:
        arrays["inertia"] = rec.inertia
    arrays["motion"] = rec.movement.astype(bool)
    meta = {"format": FORMAT_VERSION, "name": rec.name} | rec.meta
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez_compressed(path, **arrays)  # type: ignore[arg-type]


def load_recording(path: str | os.PathLike[str]) -> Recording:
    """Read a recording written by :func:`save_recording`."""
    with np.load(path, allow_pickle=False) as z:
        a = {k: z[k] for k in z.files}
    meta = json.loads(str(a["meta"]))
    if meta.get("format") != FORMAT_VERSION:
        raise ValueError(
            f"{path}: not a corpus recording of format {FORMAT_VERSION} (rebuild with benchmarks/corpus.py)"
        )
    if "q" in a:
        kind, data, refs = "quaternion", np.roll(a["q"].astype(float), -1, axis=1), None
    else:
        kind, data, refs = "directions", a["b"].astype(float), a["references"].astype(float)
    return Recording(
        meta["name"], a["t"].astype(float), kind, data, a["ref_t"].astype(float), a["ref_w"].astype(float),
        a["motion"].astype(bool), meta, refs, a.get("tau"), a.get("inertia"),
    )  # fmt: skip


def group_of(name: str) -> str:
    """The group a recording's ``name`` belongs to in the tables: its source (``broad``, ``upenn``, ``plant``), and
    the rate it was decimated to if it was (``"broad @28.6Hz"``)."""
    return name.split("-")[0] + ("" if "@" not in name else " @" + name.split("@")[1])


def recordings(directory: str | os.PathLike[str] | None = None) -> list[Path]:
    """The recordings (``*.npz``) of a corpus directory, sorted by name; empty when it does not exist."""
    d = Path(directory) if directory is not None else corpus_dir()
    return sorted(d.glob("*.npz")) if d.is_dir() else []


# ------------------------------------------------------------------------------------------------------ methods


@dataclass(frozen=True)
class Outcome:
    """A method's rate ``omega (N, 3)`` (rad/s, body axes; NaN where it has none), its own ``predicted`` RMS
    error (rad/s) when it states one, and a ``note``."""

    omega: np.ndarray
    predicted: float | None = None
    note: str = ""


@dataclass(frozen=True)
class Method:
    """``name`` (the table's column), ``run(recording) -> Outcome``, ``causal``, and ``skip(recording)``: why the
    method does not apply to a recording (None: it does)."""

    name: str
    run: Callable[[Recording], Outcome]
    causal: bool
    skip: Callable[[Recording], str | None] = lambda rec: None


class _Collector:
    """The writer :func:`pipeline_method` gives the pipeline: each row's estimate by its index."""

    def __init__(self, n: int):
        self.omega = np.full((n, 3), np.nan)

    def write(self, chunk, omega, status) -> None:
        self.omega[chunk.labels] = omega


def _predicted(summary, lines: list[str], smooth: bool) -> float | None:
    """The run's own expected RMS error, as the many-files table reads it (:func:`omegahat.cli.many_run.
    expected_error`): the fixed-gain observer's, or the identification's for what ran (causal runs only)."""
    fixed_gain = any(line.startswith("gains used:") for line in summary.lines)
    label = "sarras" if fixed_gain else "omegahat --smooth" if smooth else "omegahat"
    return expected_error(label, summary, lines)


def pipeline_method(name: str, causal: bool = True, given_model: bool = True, **settings: Any) -> Method:
    """A method running :func:`omegahat.io.pipeline.estimate_stream` with ``EstimateSettings(**settings)`` (the
    recording's ``references``, and with ``given_model`` its ``inertia``, added), as ``omegahat estimate`` does."""

    def run(rec: Recording) -> Outcome:
        extra: dict[str, Any] = {"references": rec.references}
        if given_model and rec.inertia is not None:
            extra["inertia"] = rec.inertia
        collector, lines = _Collector(rec.t.size), list[str]()
        summary = estimate_stream(
            rec.stream(), EstimateSettings(**(extra | settings)), lambda s: contextlib.nullcontext(collector),
            report=lines.append, announce=lambda text: None,
        )  # fmt: skip
        smooth = bool(settings.get("smooth"))
        return Outcome(collector.omega, _predicted(summary, lines, smooth), " | ".join(lines + summary.lines))

    def skip(rec: Recording) -> str | None:
        if settings.get("preset") is not None:
            if rec.torque is not None:
                return "the preset refuses a log with torque"
            if rec.kind == "directions" and (settings.get("smooth") or rec.data.shape[1] < 2):
                return "the preset's smoother takes attitudes"
        return None

    return Method(name, run, causal, skip)


def _baseline(fn) -> Callable[[Recording], Outcome]:
    return lambda rec: Outcome(fn(rec.t, rec.R))


def _differencing(scheme: Literal["backward", "central"]):
    from omegahat.baselines.differencing import log_difference

    return lambda t, R: log_difference(t, R, scheme=scheme)


def _spline(t, R):
    from omegahat.baselines.spline import spline_rate

    return spline_rate(t, R)


SAVGOL = (7, 6)  #: (window, order): the grid value benchmarks/real_data.py chose on BROAD at 286 and 10 Hz


def _savgol(t, R):
    from omegahat.baselines.savgol import savgol_rate

    return savgol_rate(t, R, *SAVGOL)


def _mekf(rec: Recording) -> Outcome:
    """The gyro-less MEKF baseline (kinematic, or dynamic with J given), its attitude noise measured and its rate
    noise chosen on the log's head as ``omegahat estimate`` chooses the default estimator's
    (:func:`omegahat.observer.autogain.choose_rate_noise`)."""
    from omegahat.baselines.mekf import MEKF
    from omegahat.observer import autogain

    n = min(rec.t.size, autogain.HEAD_SAMPLES)
    tv, rot = autogain.log_rotations(rec.t[:n], rec.data[:n], rec.kind, rec.references)
    J = rec.inertia
    motion = autogain.measure_motion(tv, rot, J, None if rec.torque is None else rec.torque[:n][~rec.gaps[:n]])
    sigma_a, why = autogain.choose_rate_noise(motion)
    if J is None:
        est = MEKF(model="kinematic", q=sigma_a**2, measurement_noise=max(motion.sigma, 1e-6), sigma_omega0=10.0,
                   references=rec.references)  # fmt: skip
    else:
        q = (np.trace(J) / 3 * sigma_a) ** 2
        est = MEKF(J, model="dynamic", q=q, measurement_noise=max(motion.sigma, 1e-6), sigma_omega0=10.0,
                   references=rec.references)  # fmt: skip
    measurements = rec.R if rec.kind == "quaternion" else rec.data
    return Outcome(est.run(rec.t, measurements, rec.torque).omega, note=why)


HINDSIGHT_BANDWIDTHS = (0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.4)  #: × the sample rate, Hz


def _best_bandwidth(rec: Recording) -> Outcome:
    """The fixed-gain observer (``omegahat estimate --bandwidth B``, with J and the torque when the recording gives
    them) at the bandwidth of :data:`HINDSIGHT_BANDWIDTHS` that scores best on this very recording: an oracle, the
    bar of issue 24's acceptance ("the best fixed gain in hindsight")."""
    best: tuple[float, Outcome, float] | None = None
    for k in HINDSIGHT_BANDWIDTHS:
        b = k * rec.fs
        out = pipeline_method("", bandwidth_hz=b).run(rec)
        try:
            rms = score(rec, out.omega, **rec.score_options()).rms
        except ValueError:
            continue
        if best is None or rms < best[2]:
            best = (b, out, rms)
    if best is None:
        raise ValueError("no bandwidth of the grid gave a scorable estimate")
    return Outcome(best[1].omega, note=f"--bandwidth {best[0]:.4g} Hz (of {len(HINDSIGHT_BANDWIDTHS)} tried)")


def _needs_model(rec: Recording) -> str | None:
    return None if rec.inertia is not None else "no inertia given: the same as omegahat estimate"


def _attitudes_only(rec: Recording) -> str | None:
    return None if rec.kind == "quaternion" or rec.data.shape[1] >= 2 else "needs attitudes or two directions"


METHODS: list[Method] = [
    Method("backward diff.", _baseline(_differencing("backward")), True, _attitudes_only),
    Method("central diff.", _baseline(_differencing("central")), False, _attitudes_only),
    Method("RotationSpline", _baseline(_spline), False, _attitudes_only),
    Method(f"Savitzky-Golay {SAVGOL}", _baseline(_savgol), False, _attitudes_only),
    pipeline_method("omegahat estimate"),
    pipeline_method("omegahat estimate --smooth", causal=False, smooth=True),
    replace(pipeline_method("--estimator sarras", estimator="sarras"), skip=_needs_model),
    Method("--bandwidth, best in hindsight", _best_bandwidth, True),
    pipeline_method("--preset mocap", given_model=False, preset="mocap"),
    pipeline_method("--preset mocap --smooth", causal=False, given_model=False, preset="mocap", smooth=True),
    Method("MEKF", _mekf, True, _attitudes_only),
]
"""The methods of the table, in its order: append a :class:`Method` (or a :func:`pipeline_method`) to add one."""

BASELINE = "backward diff."  #: the ratio column's denominator
OFFLINE_PEERS = ("central diff.", "RotationSpline")  #: the offline column's denominator: the best of these


@dataclass(frozen=True)
class Row:
    """One method on one recording of ``samples`` samples: its :class:`Score` (None when it failed or did not
    apply, ``note`` says why), CPU seconds, the prediction, and the ratios to :data:`BASELINE` and to the best of
    :data:`OFFLINE_PEERS`."""

    recording: str
    samples: int
    method: str
    causal: bool
    score: Score | None
    cpu_s: float
    predicted: float | None = None
    ratio: float | None = None
    offline_ratio: float | None = None
    note: str = ""


def evaluate(rec: Recording, methods: list[Method] | None = None) -> list[Row]:
    """Every method on ``rec``, scored by :func:`broad.score` with the recording's options; a method that raises
    gets a row saying so (the table shows every method)."""
    rows: list[Row] = []
    options = rec.score_options()
    for m in METHODS if methods is None else methods:
        why = m.skip(rec)
        if why:
            rows.append(Row(rec.name, rec.t.size, m.name, m.causal, None, 0.0, note=why))
            continue
        t0 = time.process_time()
        try:
            out = m.run(rec)
            cpu = time.process_time() - t0
            s = score(rec, out.omega, **options)
        except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
            rows.append(
                Row(rec.name, rec.t.size, m.name, m.causal, None, time.process_time() - t0, note=f"failed: {exc}")
            )
            continue
        rows.append(Row(rec.name, rec.t.size, m.name, m.causal, s, cpu, out.predicted, note=out.note))
    by = {r.method: r.score.rms for r in rows if r.score is not None}
    base = by.get(BASELINE)
    peers = [by[p] for p in OFFLINE_PEERS if p in by]
    best = min(peers) if peers else None
    return [
        replace(
            r,
            ratio=None if r.score is None or not base else r.score.rms / base,
            offline_ratio=None if r.score is None or not best else r.score.rms / best,
        )
        for r in rows
    ]
