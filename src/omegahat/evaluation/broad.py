"""The BROAD real recordings and the in-band score of an angular-velocity estimate against their gyroscope.

Data: D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A Benchmark for Robust Inertial Orientation
Estimation", Data 6(7), 2021, doi:10.3390/data6070072 (CC BY 4.0). Three trials and a 60 s CSV cut live in
``<repository>/../shared/data/broad/`` (``NOTICE.md`` there); they are never copied into the project.

Loading. ``opt_quat`` is the optical attitude, a unit quaternion **scalar first** ``(w, x, y, z)``, sensor → ENU,
so ``R = from_quat(q, scalar_first=True)`` is body → inertial; it has NaN gaps. ``imu_gyr`` (rad/s, sensor
axes) is the reference, biased: the bias is its mean over the rest samples (``movement == 0``).

Score (:func:`score`), as NOTICE.md describes, with the details it leaves open fixed here:

1. error ``e_k = ω̂_{k−s} − (g_k − b)`` (estimate shifted by ``s`` samples, bias-corrected gyro), for every
   integer shift ``s`` in ``[−max_shift, max_shift]`` (default ±5 samples, ±17.5 ms);
2. zero-phase low-pass: Butterworth of order ``order`` (default 4) at ``cutoff_hz`` (default 10 Hz), applied
   forward and backward (``scipy.signal.sosfiltfilt``: magnitude ``|H|²``, −6 dB at the cut-off, no delay);
   non-finite errors are bridged by linear interpolation for the filter only;
3. RMS of the vector error's norm, ``sqrt(mean |e_f|²)`` in rad/s, over the motion samples (``movement == 1``)
   farther than ``gap_margin_s`` (default 1.0 s) from any attitude gap or non-finite estimate, and from the
   ends of the record; the same samples for every shift;
4. the reported score is the smallest RMS over the shifts, with its shift.

These choices reproduce NOTICE.md's numbers for causal raw differencing (:func:`differencing_bar`): trial 01
0.0450 (NOTICE 0.045), 06 0.0941 (0.094), 10 0.0385 (0.039) rad/s, each at shift +1 (the differenced
attitude leads the gyroscope by one sample, as NOTICE.md says), and the reference's own RMS over the scored
samples, 1.678 / 5.213 / 0.853 rad/s, is NOTICE.md's "gyro RMS" 1.68 / 5.21 / 0.85 (``tests/test_broad.py``).
The details matter (same scorer, one option changed): ``gap_margin_s=0.25`` gives 0.0450 / 0.0949 / 0.0381,
``order=2`` 0.0425 / 0.0887 / 0.0362, no shift (``max_shift=0``) 0.0598 / 0.1545 / 0.0554. A 1 s margin also
gives an estimator that lost track in a gap time to recover; it keeps 85–95 % of the motion samples.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.io
from numpy.typing import ArrayLike
from scipy.ndimage import binary_dilation
from scipy.signal import butter, sosfiltfilt

from omegahat import so3

__all__ = [
    "NOTICE_DIFFERENCING_RMS",
    "TRIALS",
    "Score",
    "Trial",
    "data_dir",
    "differencing_bar",
    "load_csv_cut",
    "load_trial",
    "score",
]

TRIALS = {
    "01": "01_undisturbed_slow_rotation_A.mat",
    "06": "06_undisturbed_fast_rotation_A.mat",
    "10": "10_undisturbed_slow_translation_A.mat",
}
CSV_CUT = "01_slow_rotation_A_60s.csv"
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

    @property
    def gaps(self) -> np.ndarray:
        """Samples without an optical attitude ``(N,)``."""
        return ~np.all(np.isfinite(self.R), axis=(1, 2))

    def _need_movement(self, what: str) -> np.ndarray:
        if self.movement is None:
            raise ValueError(f"trial {self.name!r} has no movement labels: {what} needs them (use a .mat trial)")
        return self.movement

    @property
    def gyro_bias(self) -> np.ndarray:
        """Mean gyroscope over the rest samples (``movement == 0``), ``(3,)``."""
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


@dataclass(frozen=True)
class Score:
    """``rms`` (rad/s) at the best ``shift`` (samples; the estimate ω̂_{k−shift} is compared with g_k), the
    number of scored samples, the RMS at every shift tried, and the RMS of the reference |g − b| itself."""

    rms: float
    shift: int
    n_samples: int
    rms_by_shift: dict
    gyro_rms: float

    def __str__(self) -> str:
        return f"{self.rms:.4f} rad/s (shift {self.shift:+d}, {self.n_samples} samples)"


def _shifted(x, s):
    """``y[k] = x[k − s]`` with NaN where undefined."""
    y = np.full_like(x, np.nan)
    if s >= 0:
        y[s:] = x[: x.shape[0] - s]
    else:
        y[:s] = x[-s:]
    return y


def _bridge(e, ok):
    """Linear interpolation across the rows where ``ok`` is False (for the filter only)."""
    out = e.copy()
    idx = np.flatnonzero(ok)
    bad = np.flatnonzero(~ok)
    for j in range(e.shape[1]):
        out[bad, j] = np.interp(bad, idx, e[idx, j])
    return out


def score(
    trial: Trial,
    estimate: ArrayLike,
    cutoff_hz: float = 10.0,
    order: int = 4,
    gap_margin_s: float = 1.0,
    max_shift: int = 5,
) -> Score:
    """In-band RMS error of ``estimate (N, 3)`` (rad/s, one row per sample of ``trial``), module docstring."""
    w = np.asarray(estimate, dtype=float)
    N = trial.t.size
    if w.shape != (N, 3):
        raise ValueError(
            f"estimate must have shape ({N}, 3), one row per sample of trial {trial.name!r}; got {w.shape}"
        )
    if not 0 < cutoff_hz < trial.fs / 2:
        raise ValueError(f"cutoff_hz must be in (0, fs/2 = {trial.fs / 2:g}); got {cutoff_hz!r}")
    if int(order) != order or order < 1:
        raise ValueError(f"order must be a positive integer; got {order!r}")
    if not gap_margin_s >= 0:
        raise ValueError(f"gap_margin_s must be >= 0; got {gap_margin_s!r}")
    if int(max_shift) != max_shift or max_shift < 0:
        raise ValueError(f"max_shift must be a non-negative integer; got {max_shift!r}")
    movement = trial._need_movement("scoring")
    ref = trial.gyro_corrected

    # Scored samples: motion, away (margin + max shift) from gaps, non-finite estimates and the record's ends.
    unusable = trial.gaps | ~np.all(np.isfinite(w), axis=1)
    unusable[: max_shift + 1] = True
    unusable[-(max_shift + 1) :] = True
    reach = round(gap_margin_s * trial.fs) + max_shift
    if reach > 0:
        unusable = binary_dilation(unusable, iterations=reach)
    scored = movement & ~unusable
    if not scored.any():
        raise ValueError(f"no motion sample of trial {trial.name!r} is {gap_margin_s} s away from gaps")

    sos = butter(int(order), cutoff_hz, fs=trial.fs, output="sos")
    by_shift: dict[int, float] = {}
    for s in range(-int(max_shift), int(max_shift) + 1):
        e = _shifted(w, s) - ref
        ok = np.all(np.isfinite(e), axis=1)
        e_f = sosfiltfilt(sos, _bridge(e, ok), axis=0)
        by_shift[s] = float(np.sqrt(np.mean(np.sum(e_f[scored] ** 2, axis=1))))
    best = min(by_shift, key=by_shift.__getitem__)
    gyro_rms = float(np.sqrt(np.mean(np.sum(ref[scored] ** 2, axis=1))))
    return Score(by_shift[best], best, int(scored.sum()), by_shift, gyro_rms)


def differencing_bar(trial: Trial) -> np.ndarray:
    """The bar to beat: causal raw log-map differencing, one sample, no filter, ``(N, 3)``
    (:func:`omegahat.baselines.differencing.log_difference`, backward scheme)."""
    from omegahat.baselines.differencing import log_difference

    return log_difference(trial.t, trial.R, scheme="backward")
