r"""DataFrames in, angular velocity out: :func:`estimate_frame` for pandas and Polars.

The frame holds one sample per row with the same column names as omegahat's CSV logs (:mod:`omegahat.io.logs`):
a quaternion ``qx, qy, qz, qw`` (or the names given by ``quaternion=``, in ``x, y, z, w`` order), or a rotation
matrix ``r11 … r33`` (body → inertial), or body-frame directions ``b1x, b1y, b1z, b2x, …`` with ``references=``;
optionally the torque ``tau_x, tau_y, tau_z``. Time is the column ``t`` (seconds) or the one named by ``time=``;
for pandas, without such a column, a ``DatetimeIndex``, ``TimedeltaIndex`` or floating-point index (seconds).
Datetime and duration times are used as integer nanoseconds, so that equal stamps compare exactly.

Missing values (NaN, ``None``, ``pd.NA``, Polars nulls) in the attitude make the sample missing: skipped and
predicted through. Rows need not be sorted: they are taken in time order, duplicates handled as
:mod:`omegahat.io.timestamps` says, and every result is put back on its own row, so the output is **indexed like
the input**: for pandas a frame with the input's index and columns ``wx, wy, wz`` (rad/s, body axes; join it to
the input with ``df.join(out)``), for Polars a frame with the input's rows in the input's order, the time column
and ``wx, wy, wz``. A dropped duplicate row gets the estimate of the row kept in its place.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from omegahat.io.logs import MATRIX_COLUMNS, QUATERNION_COLUMNS, TORQUE_COLUMNS, LogFormatError
from omegahat.io.recording import build_recording
from omegahat.observer.gains import ObserverGains
from omegahat.validation import as_inertia

__all__ = ["estimate_frame"]


def _kind_of_frame(df) -> str:
    module = type(df).__module__.split(".")[0]
    if module == "pandas":
        return "pandas"
    if module == "polars":
        return "polars"
    raise TypeError(f"estimate_frame takes a pandas or Polars DataFrame; got {type(df).__module__}.{type(df).__name__}")


def _directions_columns(names: Sequence[str]) -> list[str]:
    idx = sorted({int(n[1:-1]) for n in names if len(n) >= 3 and n[0] == "b" and n[1:-1].isdigit() and n[-1] in "xyz"})
    return [f"b{i}{a}" for i in idx for a in "xyz"]


def _attitude_columns(names: Sequence[str], quaternion: Sequence[str] | None) -> tuple[str, list[str]]:
    present = set(names)
    if quaternion is not None:
        cols = list(quaternion)
        if len(cols) != 4:
            raise ValueError(f"quaternion= names 4 columns in x, y, z, w order; got {cols}")
        groups = {"quaternion": cols}
    else:
        groups = {
            "quaternion": list(QUATERNION_COLUMNS),
            "matrix": list(MATRIX_COLUMNS),
            "directions": _directions_columns(names),
        }
    touched = {k: c for k, c in groups.items() if c and present & set(c)}
    if not touched:
        raise LogFormatError(
            "DataFrame: no attitude columns; expected qx,qy,qz,qw (or quaternion=[...]) or r11..r33 or "
            f"b1x,b1y,b1z,b2x,... (found: {', '.join(map(str, names))})"
        )
    if len(touched) > 1:
        raise LogFormatError(f"DataFrame: attitude given more than one way ({' and '.join(touched)}); keep one")
    kind, cols = next(iter(touched.items()))
    missing = [c for c in cols if c not in present]
    if missing:
        raise LogFormatError(f"DataFrame: missing {kind} column(s) {', '.join(missing)}")
    if kind == "directions":
        n = len(cols) // 3
        if n < 2 or [int(c[1:-1]) for c in cols[::3]] != list(range(1, n + 1)):
            raise LogFormatError(f"DataFrame: directions must be b1, b2, ... (at least 2, no gaps); got {n}")
    return kind, cols


def _pandas_times(df, time: str | None):
    import pandas as pd

    if time is not None or "t" in df.columns:
        name = time or "t"
        if name not in df.columns:
            raise LogFormatError(f"DataFrame: no time column {name!r} (found: {', '.join(map(str, df.columns))})")
        s = df[name]
        if pd.api.types.is_datetime64_any_dtype(s) or pd.api.types.is_timedelta64_dtype(s):
            return _nanoseconds(s.to_numpy(), name), name
        return _float_times(s.to_numpy(dtype=float, na_value=np.nan), name), name
    idx = df.index
    if isinstance(idx, pd.DatetimeIndex | pd.TimedeltaIndex):
        return _nanoseconds(idx.to_numpy(), "index"), None
    if pd.api.types.is_float_dtype(idx):
        return _float_times(idx.to_numpy(dtype=float), "index"), None
    raise LogFormatError(
        "DataFrame: no time: give a column 't' (seconds) or time='column', or use a DatetimeIndex, TimedeltaIndex "
        f"or float index in seconds (the index is {type(idx).__name__} of {idx.dtype})"
    )


def _nanoseconds(values: np.ndarray, name: str) -> np.ndarray:
    if np.isnat(values).any():
        k = int(np.flatnonzero(np.isnat(values))[0])
        raise LogFormatError(f"DataFrame, row {k}, column {name}: missing time (every row needs one)")
    return values.astype("datetime64[ns]" if values.dtype.kind == "M" else "timedelta64[ns]").astype(np.int64)


def _float_times(values: np.ndarray, name: str) -> np.ndarray:
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        k = int(bad[0])
        raise LogFormatError(f"DataFrame, row {k}, column {name}: time {float(values[k])!r} is not a finite number")
    return values


def _polars_times(df, time: str | None):
    import polars as pl

    name = time or "t"
    if name not in df.columns:
        raise LogFormatError(f"DataFrame: no time column {name!r}; give time='column' (found: {', '.join(df.columns)})")
    s = df.get_column(name)
    if s.null_count():
        k = int(np.flatnonzero(s.is_null().to_numpy())[0])
        raise LogFormatError(f"DataFrame, row {k}, column {name}: missing time (every row needs one)")
    if s.dtype.is_temporal():
        if isinstance(s.dtype, pl.Datetime | pl.Duration):
            scale = {"ns": 1, "us": 1_000, "ms": 1_000_000}[s.dtype.time_unit]
            return s.to_physical().to_numpy().astype(np.int64) * scale, name
        raise LogFormatError(f"DataFrame, column {name}: time of type {s.dtype} (use seconds, Datetime or Duration)")
    return _float_times(s.cast(pl.Float64).to_numpy(), name), name


def _numbers(df, cols: list[str], frame_kind: str) -> np.ndarray:
    if frame_kind == "pandas":
        return df[cols].to_numpy(dtype=float, na_value=np.nan)
    import polars as pl

    return df.select([pl.col(c).cast(pl.Float64) for c in cols]).to_numpy().astype(float)


def estimate_frame(
    df,
    *,
    gains: ObserverGains | None = None,
    bandwidth: float | None = None,
    inertia=None,
    references=None,
    time: str | None = None,
    quaternion: Sequence[str] | None = None,
    warm_start: bool = True,
):
    """Angular velocity (rad/s, body axes) for every row of a pandas or Polars DataFrame (module docstring).

    Gains: ``gains`` (e.g. :func:`omegahat.observer.tuning.sensor_gains` for your sensor's rate and noise) or
    ``bandwidth`` (rad/s, :func:`omegahat.observer.tuning.bandwidth_gains`); one of them is required, since the
    right bandwidth depends on the sensor's noise and rate. ``inertia``: 3 or 9 numbers or 3×3 (default
    identity, i.e. no model); ``references``: the inertial directions (required for ``b1x, ...`` columns; for
    attitude input the default is the three rows of R). ``warm_start``: take the first rate from the first two
    samples (:class:`~omegahat.observer.estimator.SarrasEstimator`).
    """
    from omegahat.measurements import as_references  # compiled (Numba) modules: imported when first used
    from omegahat.observer.estimator import SarrasEstimator
    from omegahat.observer.tuning import bandwidth_gains

    frame_kind = _kind_of_frame(df)
    names = [str(c) for c in df.columns]
    kind, cols = _attitude_columns(names, quaternion)
    if frame_kind == "pandas":
        times, time_name = _pandas_times(df, time)
    else:
        times, time_name = _polars_times(df, time)
    data = _numbers(df, cols, frame_kind)
    if kind == "matrix":
        data = data.reshape(-1, 3, 3)
    elif kind == "directions":
        data = data.reshape(data.shape[0], -1, 3)
    torque = None
    tau_present = [c for c in TORQUE_COLUMNS if c in names]
    if tau_present:
        if len(tau_present) != 3:
            raise LogFormatError(f"DataFrame: torque needs tau_x, tau_y and tau_z; found {', '.join(tau_present)}")
        torque = _numbers(df, list(TORQUE_COLUMNS), frame_kind)
        bad = np.flatnonzero(~np.all(np.isfinite(torque), axis=1))
        if bad.size:
            raise LogFormatError(f"DataFrame, row {int(bad[0])}: torque {torque[bad[0]].tolist()} is not finite")
    if len(times) == 0:
        raise LogFormatError("DataFrame: no rows")
    recording, tidy = build_recording(
        times,
        kind,
        data,
        torque=torque,
        source="DataFrame",
        description=f"DataFrame ({frame_kind}): {kind} columns {', '.join(cols)}",
        label=lambda k: f"DataFrame, row {k}",
        sort=True,
    )
    log = recording.log
    J = np.eye(3) if inertia is None else as_inertia(inertia, name="inertia")
    if kind == "directions":
        if references is None:
            n = data.shape[1]
            raise ValueError(f"the frame holds {n} body-frame directions (b1..b{n}): give their inertial references=")
    V = as_references(references)
    if gains is None and bandwidth is None:
        h = np.median(np.diff(log.t)) if len(log) > 1 else float("nan")
        raise ValueError(
            f"estimate_frame needs gains= or bandwidth=: the right values depend on the sensor (this frame's median "
            f"sample rate is {1 / h:.4g} Hz); e.g. gains=omegahat.observer.tuning.sensor_gains(J, rate_hz, "
            "noise_std_rad, bandwidth_hz=...)"
        )
    if gains is not None and bandwidth is not None:
        raise ValueError("give gains= or bandwidth=, not both")
    if gains is None:
        gains = bandwidth_gains(J, bandwidth, V)
    estimator = SarrasEstimator(
        J,
        gains=gains,
        references=V if (references is not None or kind == "directions") else None,
        measurement="directions" if kind == "directions" else "attitude",
        warm_start=warm_start,
    )
    W = estimator.run(log.t, log.data, log.torque)[tidy.source_of]
    if frame_kind == "pandas":
        import pandas as pd

        return pd.DataFrame({"wx": W[:, 0], "wy": W[:, 1], "wz": W[:, 2]}, index=df.index)
    import polars as pl

    out = {"wx": W[:, 0], "wy": W[:, 1], "wz": W[:, 2]}
    return pl.DataFrame(out).insert_column(0, df.get_column(time_name)) if time_name else pl.DataFrame(out)
