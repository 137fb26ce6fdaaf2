"""The BROAD real recordings and the in-band score of an angular-velocity estimate against their gyroscope.

Data: D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A Benchmark for Robust Inertial Orientation
Estimation", Data 6(7), 2021, doi:10.3390/data6070072 (CC BY 4.0). Three trials and a 60 s CSV cut live in
``<repository>/../shared/data/broad/`` (``NOTICE.md`` there); they are never copied into the project.

Loading. ``opt_quat`` is the optical attitude, a unit quaternion **scalar first** ``(w, x, y, z)``, sensor → ENU,
so ``R = from_quat(q, scalar_first=True)`` is body → inertial; it has NaN gaps. ``imu_gyr`` (rad/s, sensor
axes) is the reference, biased: the bias is its mean over the rest samples (``movement == 0``).

Score (:func:`score`): the in-band error of NOTICE.md, with the best time shift found **continuously** and for
every method alike, and the zero-shift score beside it:

1. reference ``g(t)``: the bias-corrected gyroscope at its own (native) sample times, interpolated by a cubic
   spline (``scipy.interpolate.CubicSpline``); error ``e_k(s) = ω̂_k − g(t_k + s h)`` for a shift ``s`` in samples
   of the scored log (``h`` its sample period; ``s > 0``: the estimate leads the reference by ``s`` samples).
   Shifting the densely sampled reference instead of the estimate is the same comparison, and exact at the
   estimate's own samples whatever its rate (a decimated log is scored against the native gyro);
2. zero-phase low-pass of the error: Butterworth of order ``order`` (default 4) at ``cutoff_hz`` (default
   10 Hz, or 0.4 × the log's rate if that is less), forward and backward (``scipy.signal.sosfiltfilt``:
   magnitude ``|H|²``, −6 dB at the cut-off, no delay); non-finite estimates are bridged by linear
   interpolation for the filter only;
3. RMS of the vector error's norm, ``sqrt(mean |e_f|²)`` in rad/s, over the motion samples (``movement == 1``)
   farther than ``gap_margin_s`` (default 1.0 s) from any attitude gap or non-finite estimate, and from the
   ends of the record; the same samples for every shift;
4. the score is the smallest RMS over ``s ∈ [−max_shift, max_shift]`` (default ±3 samples): a grid of
   ``resolution`` (default 0.1 sample), then refined to 0.001 sample by a bounded scalar search around the
   best grid point; ``zero_shift_rms`` is the RMS at ``s = 0`` (what a controller sees).

Why continuous: the optical and inertial clocks of a trial are offset by a fraction of a sample, and a score
that forgives only whole-sample shifts rewards an estimator whose lag happens to line the two up.

With ``resolution=1`` and ``max_shift=5`` the score is NOTICE.md's own (whole-sample shifts): it reproduces its
numbers for causal raw differencing (:func:`differencing_bar`): trial 01 0.0450 (NOTICE 0.045), 06 0.0941
(0.094), 10 0.0385 (0.039) rad/s, each at shift +1 (the differenced attitude leads the gyroscope by about one
sample, as NOTICE.md says), and the reference's own RMS over the scored samples, 1.678 / 5.213 / 0.853 rad/s, is
NOTICE.md's "gyro RMS" 1.68 / 5.21 / 0.85 (``tests/test_broad.py``). A 1 s margin also gives an estimator that
lost track in a gap time to recover; it keeps 85–95 % of the motion samples.

Low-rate motion capture: :meth:`Trial.decimated` keeps every ``n``-th sample (attitude, labels and the gyro at
those instants) and remembers the native trial, whose gyro the score interpolates.

Any recording: :func:`score` takes anything shaped like a :class:`Trial` (:class:`Scorable`: sample times, rate,
gaps, motion labels, and a reference rate at its own times on the log's clock), so the recordings of the
development corpus (:mod:`omegahat.lab.evaluation.corpus`) are scored by this one definition. A reference on its own
clock and rate (a calibrated gyroscope) may end before the log or have gaps: samples whose shifted instants
``t_k ± max_shift·h`` leave it, or fall in a step of the reference longer than 2.5 × its median, are unusable like
attitude gaps. ``cutoff_hz=math.inf`` scores without the low-pass (a simulation's exact truth).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np
import scipy.io
from numpy.typing import ArrayLike
from scipy.interpolate import CubicSpline
from scipy.ndimage import binary_dilation
from scipy.optimize import minimize_scalar
from scipy.signal import butter, sosfiltfilt

from omegahat import so3

__all__ = [
    "DEFAULT_CUTOFF_HZ",
    "NOTICE_DIFFERENCING_RMS",
    "TRIALS",
    "Scorable",
    "Score",
    "Trial",
    "data_dir",
    "differencing_bar",
    "load_csv_cut",
    "load_trial",
    "score",
    "score_cutoff_hz",
]

TRIALS = {
    "01": "01_undisturbed_slow_rotation_A.mat",
    "06": "06_undisturbed_fast_rotation_A.mat",
    "10": "10_undisturbed_slow_translation_A.mat",
}
CSV_CUT = "01_slow_rotation_A_60s.csv"
DEFAULT_CUTOFF_HZ = 10.0  #: the score's band (NOTICE.md), lowered to 0.4 × the rate for slower logs
#: NOTICE.md: causal raw log-map differencing, scored in band, rad/s.
NOTICE_DIFFERENCING_RMS = {"01": 0.045, "06": 0.094, "10": 0.039}


def data_dir() -> Path:
    """Where the BROAD recordings are: ``$OMEGAHAT_BROAD_DIR`` if set, else ``../shared/data/broad`` relative to
    the working directory (the repository root, where the tests and benchmarks run), else relative to this
    package's source tree (an editable install). The first that exists; the working-directory one otherwise."""
    env = os.environ.get("OMEGAHAT_BROAD_DIR")
    if env:
        return Path(env).resolve()
    candidates = [
        Path.cwd() / ".." / "shared" / "data" / "broad",
        Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "broad",
    ]
    for c in candidates:
        if c.is_dir():
            return c.resolve()
    return candidates[0].resolve()


@dataclass(frozen=True)
class Trial:
    """One recording. ``t (N,)`` s; ``R (N, 3, 3)`` body → ENU, NaN rows in gaps; ``gyro (N, 3)`` raw rad/s;
    ``movement (N,)`` bool or None (the CSV cut has none); ``acc``, ``mag`` ``(N, 3)`` or None; ``fs`` Hz."""

    name: str
    t: np.ndarray
    R: np.ndarray
    gyro: np.ndarray
    fs: float
    movement: np.ndarray | None = None
    acc: np.ndarray | None = field(default=None, repr=False)
    mag: np.ndarray | None = field(default=None, repr=False)
    #: the trial this one was decimated from (its gyro is the score's reference), or None
    native: Trial | None = field(default=None, repr=False)

    def decimated(self, step: int) -> Trial:
        """Every ``step``-th sample (a low-rate motion-capture log: ``step`` 10 and 30 give about 29 and 10 Hz on
        BROAD), the gyro bias and the score's reference still taken from the native trial."""
        if int(step) != step or step < 1:
            raise ValueError(f"step must be a positive integer; got {step!r}")
        step = int(step)
        if step == 1:
            return self
        base = self.native or self
        pick = slice(None, None, step)

        def sub(x):
            return None if x is None else x[pick]

        return Trial(
            f"{self.name}@{self.fs / step:.3g}Hz", self.t[pick], self.R[pick], self.gyro[pick], self.fs / step,
            sub(self.movement), sub(self.acc), sub(self.mag), native=base,
        )  # fmt: skip

    def head(self, seconds: float) -> Trial:
        """The first ``seconds`` of the trial (its gyro bias then comes from its own rest samples)."""
        n = int(np.searchsorted(self.t, self.t[0] + seconds, side="right"))
        cut = lambda x: None if x is None else x[:n]  # noqa: E731
        return Trial(self.name, self.t[:n], self.R[:n], self.gyro[:n], self.fs, cut(self.movement), cut(self.acc),
                     cut(self.mag))  # fmt: skip

    @property
    def gaps(self) -> np.ndarray:
        """Samples without an optical attitude ``(N,)``."""
        return ~np.all(np.isfinite(self.R), axis=(1, 2))

    @property
    def reference_times(self) -> np.ndarray:
        """Times of the score's reference: the native trial's samples."""
        return (self.native or self).t

    @property
    def reference_rates(self) -> np.ndarray:
        """The score's reference ``(N_native, 3)``: the native trial's bias-corrected gyroscope."""
        return (self.native or self).gyro_corrected

    def _need_movement(self, what: str) -> np.ndarray:
        if self.movement is None:
            raise ValueError(f"trial {self.name!r} has no movement labels: {what} needs them (use a .mat trial)")
        return self.movement

    @property
    def gyro_bias(self) -> np.ndarray:
        """Mean gyroscope over the rest samples (``movement == 0``), ``(3,)``."""
        if self.native is not None:
            return self.native.gyro_bias
        rest = ~self._need_movement("the gyro bias")
        if not rest.any():
            raise ValueError(f"trial {self.name!r} has no rest samples (movement == 0) to estimate the gyro bias")
        return self.gyro[rest].mean(axis=0)

    @property
    def gyro_corrected(self) -> np.ndarray:
        """``gyro − gyro_bias``, the angular-velocity reference ``(N, 3)``."""
        return self.gyro - self.gyro_bias


def _resolve(name_or_path, directory) -> Path:
    if str(name_or_path) in TRIALS:
        return Path(directory or data_dir()) / TRIALS[str(name_or_path)]
    p = Path(name_or_path)
    if p.suffix != ".mat":
        raise ValueError(f"a BROAD trial is one of {sorted(TRIALS)} or a path to a .mat file; got {name_or_path!r}")
    return p


def load_trial(name_or_path: str | os.PathLike[str], directory: str | os.PathLike[str] | None = None) -> Trial:
    """Load a ``.mat`` trial: by short name (``"01"``, ``"06"``, ``"10"``) from ``directory`` (default
    :func:`data_dir`), or by path."""
    path = _resolve(name_or_path, directory)
    if not path.exists():
        raise FileNotFoundError(f"BROAD trial not found: {path} (see NOTICE.md in the shared data directory)")
    d = scipy.io.loadmat(os.fspath(path))
    missing = [k for k in ("opt_quat", "imu_gyr", "movement", "sampling_rate") if k not in d]
    if missing:
        raise ValueError(f"{path}: not a BROAD trial, missing field(s) {', '.join(missing)}")
    fs = float(np.asarray(d["sampling_rate"]).ravel()[0])
    q = np.asarray(d["opt_quat"], dtype=float)
    N = q.shape[0]
    R = so3.from_quat(q, scalar_first=True)  # NaN rows stay NaN
    R[~np.all(np.isfinite(q), axis=1)] = np.nan
    name = str(name_or_path) if str(name_or_path) in TRIALS else path.stem
    return Trial(
        name=name,
        t=np.arange(N) / fs,
        R=R,
        gyro=np.asarray(d["imu_gyr"], dtype=float),
        fs=fs,
        movement=np.asarray(d["movement"]).ravel() == 1,
        acc=np.asarray(d["imu_acc"], dtype=float) if "imu_acc" in d else None,
        mag=np.asarray(d["imu_mag"], dtype=float) if "imu_mag" in d else None,
    )


def load_csv_cut(path: str | os.PathLike[str] | None = None) -> Trial:
    """The 60 s CSV cut of trial 01 (``t, qw, qx, qy, qz, gyr_x, gyr_y, gyr_z``; empty fields in gaps).

    It has no movement labels, so :func:`score` needs them from elsewhere (or use the ``.mat`` trial).
    """
    from omegahat.io import read_csv  # io imports nothing from here; keep the dependency one-way and late

    path = Path(path) if path is not None else data_dir() / CSV_CUT
    log = read_csv(path)
    with open(path, encoding="utf-8") as f:
        names = [h.strip() for h in f.readline().split(",")]
    cols = [names.index(c) for c in ("gyr_x", "gyr_y", "gyr_z")]
    gyro = np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols)
    R = so3.from_quat(log.data)  # AttitudeLog stores quaternions scalar last
    R[log.missing] = np.nan
    fs = 1.0 / float(np.median(np.diff(log.t)))
    return Trial(name=path.stem, t=log.t, R=R, gyro=gyro, fs=fs)


# ------------------------------------------------------------------------------------------------- scoring


class Scorable(Protocol):
    """What :func:`score` needs of a recording (a :class:`Trial`, a corpus recording): ``name``; sample times
    ``t (N,)`` s and rate ``fs`` Hz; ``gaps (N,)`` (no attitude); ``movement (N,)`` the samples to score (None:
    unlabelled, not scorable); the reference rate ``reference_rates (M, 3)`` (rad/s, body axes) at
    ``reference_times (M,)`` on the log's clock, strictly increasing."""

    @property
    def name(self) -> str: ...
    @property
    def t(self) -> np.ndarray: ...
    @property
    def fs(self) -> float: ...
    @property
    def movement(self) -> np.ndarray | None: ...
    @property
    def gaps(self) -> np.ndarray: ...
    @property
    def reference_times(self) -> np.ndarray: ...
    @property
    def reference_rates(self) -> np.ndarray: ...


@dataclass(frozen=True)
class Score:
    """``rms`` (rad/s) at the best ``shift`` (samples of the scored log; the estimate ω̂_k is compared with
    g(t_k + shift·h)), ``zero_shift_rms`` at shift 0, the number of scored samples, the RMS on the shift grid
    (``rms_by_shift``: shift → RMS) and the RMS of the reference |g − b| itself over the scored samples."""

    rms: float
    shift: float
    zero_shift_rms: float
    n_samples: int
    rms_by_shift: dict
    gyro_rms: float

    def __str__(self) -> str:
        return (
            f"{self.rms:.4f} rad/s (shift {self.shift:+.2f}; {self.zero_shift_rms:.4f} at shift 0; "
            f"{self.n_samples} samples)"
        )


def _bridge(e, ok):
    """Linear interpolation across the rows where ``ok`` is False (for the filter only)."""
    out = e.copy()
    idx = np.flatnonzero(ok)
    bad = np.flatnonzero(~ok)
    for j in range(e.shape[1]):
        out[bad, j] = np.interp(bad, idx, e[idx, j])
    return out


def _check_score_options(trial, cutoff_hz, order, gap_margin_s, max_shift, resolution):
    if not (0 < cutoff_hz < trial.fs / 2 or cutoff_hz == math.inf):
        raise ValueError(f"cutoff_hz must be in (0, fs/2 = {trial.fs / 2:g}); got {cutoff_hz!r} (or inf: no low-pass)")
    if int(order) != order or order < 1:
        raise ValueError(f"order must be a positive integer; got {order!r}")
    if not gap_margin_s >= 0:
        raise ValueError(f"gap_margin_s must be >= 0; got {gap_margin_s!r}")
    if not max_shift >= 0:
        raise ValueError(f"max_shift must be >= 0 samples; got {max_shift!r}")
    if not 0 < resolution <= 1:
        raise ValueError(f"resolution must be in (0, 1] samples; got {resolution!r}")


def _outside_reference(t: np.ndarray, reach: float, ref_t: np.ndarray) -> np.ndarray:
    """Samples whose instants ``t ± reach`` leave the reference's span or meet one of its long steps."""
    lo, hi = t - reach, t + reach
    out = (lo < ref_t[0]) | (hi > ref_t[-1])
    steps = np.diff(ref_t)
    for j in np.flatnonzero(steps > 2.5 * np.median(steps)):
        out |= (hi >= ref_t[j]) & (lo <= ref_t[j + 1])
    return out


def score_cutoff_hz(fs: float, cutoff_hz: float | None = None) -> float:
    """The score's low-pass corner (Hz) for a log sampled at ``fs`` Hz: ``cutoff_hz`` where given (``math.inf``:
    no low-pass), else :data:`DEFAULT_CUTOFF_HZ` lowered to 0.4 × the rate for slower logs."""
    return min(DEFAULT_CUTOFF_HZ, 0.4 * fs) if cutoff_hz is None else cutoff_hz


def score(
    trial: Scorable,
    estimate: ArrayLike,
    cutoff_hz: float | None = None,
    order: int = 4,
    gap_margin_s: float = 1.0,
    max_shift: float = 3.0,
    resolution: float = 0.1,
) -> Score:
    """In-band RMS error of ``estimate (N, 3)`` (rad/s, one row per sample of ``trial``, a :class:`Trial` or any
    :class:`Scorable` recording), module docstring.

    ``resolution=1`` searches whole-sample shifts only (NOTICE.md's rule; no refinement); ``cutoff_hz=math.inf``
    leaves out the low-pass."""
    w = np.asarray(estimate, dtype=float)
    N = trial.t.size
    if w.shape != (N, 3):
        raise ValueError(
            f"estimate must have shape ({N}, 3), one row per sample of trial {trial.name!r}; got {w.shape}"
        )
    cutoff_hz = score_cutoff_hz(trial.fs, cutoff_hz)
    _check_score_options(trial, cutoff_hz, order, gap_margin_s, max_shift, resolution)
    movement = trial.movement
    if movement is None:
        raise ValueError(f"trial {trial.name!r} has no movement labels: scoring needs them (use a .mat trial)")
    ref_t = trial.reference_times
    reference = CubicSpline(ref_t, trial.reference_rates, axis=0)
    h = 1.0 / trial.fs

    # Scored samples: motion, away (margin + max shift) from gaps, non-finite estimates and the record's ends.
    finite = np.all(np.isfinite(w), axis=1)
    if not finite.any():
        raise ValueError(f"the estimate has no finite row for trial {trial.name!r}")
    reach_shift = math.ceil(max_shift)
    unusable = trial.gaps | ~finite | _outside_reference(trial.t, reach_shift * h, ref_t)
    unusable[: reach_shift + 1] = True
    unusable[-(reach_shift + 1) :] = True
    reach = round(gap_margin_s * trial.fs) + reach_shift
    if reach > 0:
        unusable = binary_dilation(unusable, iterations=reach)
    scored = movement & ~unusable
    if not scored.any():
        raise ValueError(f"no motion sample of trial {trial.name!r} is {gap_margin_s} s away from gaps")

    if cutoff_hz == math.inf:
        band = lambda x: x  # noqa: E731
    else:
        sos = butter(int(order), cutoff_hz, fs=trial.fs, output="sos")
        band = lambda x: sosfiltfilt(sos, x, axis=0)  # noqa: E731
    # The filter is linear: filter the estimate once, and the shifted reference for each shift.
    w_f = band(_bridge(w, finite))

    def rms_at(s: float) -> float:
        g = reference(np.clip(trial.t + s * h, ref_t[0], ref_t[-1]))
        e_f = w_f - band(g)
        return float(np.sqrt(np.mean(np.sum(e_f[scored] ** 2, axis=1))))

    n_grid = round(max_shift / resolution)
    grid = [k * resolution for k in range(-n_grid, n_grid + 1)] if n_grid else [0.0]
    by_shift = {s: rms_at(s) for s in grid}
    best = min(by_shift, key=by_shift.__getitem__)
    best_rms = by_shift[best]
    if resolution < 1 and max_shift > 0:
        lo, hi = max(best - resolution, -max_shift), min(best + resolution, max_shift)
        found = minimize_scalar(rms_at, bounds=(lo, hi), method="bounded", options={"xatol": 1e-3})
        if found.fun < best_rms:
            best, best_rms = float(found.x), float(found.fun)
    zero = by_shift[0.0] if 0.0 in by_shift else rms_at(0.0)
    g0 = reference(trial.t[scored])  # the reference at the log's own samples (its knots, for a native trial)
    gyro_rms = float(np.sqrt(np.mean(np.sum(g0**2, axis=1))))
    return Score(best_rms, best, zero, int(scored.sum()), by_shift, gyro_rms)


def differencing_bar(trial: Trial) -> np.ndarray:
    """The bar to beat: causal raw log-map differencing, one sample, no filter, ``(N, 3)``
    (:func:`omegahat.baselines.differencing.log_difference`, backward scheme)."""
    from omegahat.baselines.differencing import log_difference

    return log_difference(trial.t, trial.R, scheme="backward")
