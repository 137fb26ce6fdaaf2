"""The columns of a pandas or Polars DataFrame as numbers: its times (a column, or the index; datetimes and durations
as integer nanoseconds, ISO 8601 texts as the CSV reader reads them) and its numeric columns, every value that is
not one named by row and column. Used by :func:`omegahat.io.frames.open_frame`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from omegahat.io.columns import LogFormatError, found_names, shown_value
from omegahat.io.registry import TIME_UNITS
from omegahat.io.time_units import whole_times
from omegahat.io.timestamps import text_dates

__all__ = [
    "frame_numbers",
    "nanoseconds",
    "not_a_number",
    "pandas_times",
    "polars_times",
    "row_of",
    "time_index",
]


def pandas_times(df: Any, time: str | None) -> tuple[np.ndarray, str | None, bool]:
    """The times of a pandas frame (a column: ``time``, or ``t``; else its index), the column read (None: the
    index) and whether they are a clock's: integer nanoseconds for datetimes, durations and date texts (True), the
    numbers as written for an integer column (int64, False), else floats (False)."""
    import pandas as pd

    if time is not None or "t" in df.columns:
        name = time or "t"
        if name not in df.columns:
            raise LogFormatError(f"DataFrame: no time column {name!r} (found: {found_names(map(str, df.columns))})")
        s = df[name]
        if pd.api.types.is_datetime64_any_dtype(s) or pd.api.types.is_timedelta64_dtype(s):
            return nanoseconds(s, name), name, True
        if pd.api.types.is_integer_dtype(s) and not pd.api.types.is_bool_dtype(s):
            if s.hasnans:  # a nullable integer column
                k = int(np.flatnonzero(s.isna().to_numpy())[0])
                raise LogFormatError(f"DataFrame, row {k}, column {name}: missing time (every row needs one)")
            return whole_times(s.to_numpy(), row_of(name)), name, False
        dates = text_dates(s.tolist(), row_of(name)) if pd.api.types.is_string_dtype(s) else None
        return (frame_numbers(df, [name], "pandas")[:, 0] if dates is None else dates[0]), name, dates is not None
    idx = df.index
    if isinstance(idx, pd.DatetimeIndex | pd.TimedeltaIndex):
        return nanoseconds(idx, "index"), None, True
    if time_index(idx):
        return idx.to_numpy(dtype=float), None, False
    raise LogFormatError(
        "DataFrame: no time: give a column 't' (seconds) or time='column', or use a DatetimeIndex, TimedeltaIndex "
        f"or float index in seconds (the index is {type(idx).__name__} of {idx.dtype})"
    )


def row_of(name: str) -> Callable[[int], str]:
    """Names row ``k`` of column ``name`` in messages."""
    return lambda k: f"DataFrame, row {k}, column {name}"


def time_index(idx: Any) -> bool:
    """Whether a pandas index holds times: datetimes, durations or floats (seconds)."""
    import pandas as pd

    return isinstance(idx, pd.DatetimeIndex | pd.TimedeltaIndex) or pd.api.types.is_float_dtype(idx)


def nanoseconds(values: Any, name: str) -> np.ndarray:
    """Integer nanoseconds of pandas datetimes (since 1970, UTC: a timezone-aware time is the instant it names,
    so that a clock change is no gap) or durations."""
    import pandas as pd

    timedelta = pd.api.types.is_timedelta64_dtype(values)
    idx = pd.TimedeltaIndex(values) if timedelta else pd.DatetimeIndex(values)
    missing = np.asarray(idx.isna())
    if missing.any():
        k = int(np.flatnonzero(missing)[0])
        raise LogFormatError(f"DataFrame, row {k}, column {name}: missing time (every row needs one)")
    if not timedelta and idx.tz is not None:
        idx = idx.tz_convert("UTC").tz_localize(None)
    try:
        return np.array(idx.as_unit("ns").asi8, dtype=np.int64)
    except (OverflowError, pd.errors.OutOfBoundsDatetime, pd.errors.OutOfBoundsTimedelta) as exc:
        raise LogFormatError(f"DataFrame, column {name}: times beyond what nanoseconds hold ({exc})") from None


def polars_times(df: Any, time: str | None) -> tuple[np.ndarray, str, bool]:
    """The times of a Polars frame (the column ``time``, or ``t``), the column read and whether they are a clock's,
    as :func:`pandas_times`."""
    import polars as pl

    name = time or "t"
    if name not in df.columns:
        raise LogFormatError(
            f"DataFrame: no time column {name!r}; give time='column' (found: {found_names(map(str, df.columns))})"
        )
    s = df.get_column(name)
    if s.null_count():
        k = int(np.flatnonzero(s.is_null().to_numpy())[0])
        raise LogFormatError(f"DataFrame, row {k}, column {name}: missing time (every row needs one)")
    if s.dtype.is_temporal():
        if isinstance(s.dtype, pl.Datetime | pl.Duration):
            ns_per_tick = round(TIME_UNITS[s.dtype.time_unit] / TIME_UNITS["ns"])
            ticks = s.to_physical().to_numpy().astype(np.int64)
            if ticks.size and np.abs(ticks).max() > np.iinfo(np.int64).max // ns_per_tick:  # no silent wrap-around
                raise LogFormatError(f"DataFrame, column {name}: times beyond what nanoseconds hold")
            return ticks * ns_per_tick, name, True
        raise LogFormatError(f"DataFrame, column {name}: time of type {s.dtype} (use seconds, Datetime or Duration)")
    if s.dtype.is_integer():
        return whole_times(s.to_numpy(), row_of(name)), name, False
    dates = text_dates(s.to_list(), row_of(name)) if s.dtype == pl.String else None
    return (frame_numbers(df, [name], "polars")[:, 0] if dates is None else dates[0]), name, dates is not None


def frame_numbers(df: Any, cols: list[str], frame_kind: str) -> np.ndarray:
    """The columns ``cols`` as floats ``(rows, len(cols))`` (missing values: NaN); a value that is not a number
    (text, a complex number) is an error naming its row and column."""
    if frame_kind == "pandas":
        try:
            return df[cols].to_numpy(dtype=float, na_value=np.nan)
        except (ValueError, TypeError) as exc:
            raise not_a_number(df, cols, frame_kind, exc) from None
    import polars as pl

    out = df.select([pl.col(c).cast(pl.Float64, strict=False) for c in cols])
    lost = [c for c in cols if out.get_column(c).null_count() > df.get_column(c).null_count()]
    if lost:
        raise not_a_number(df, lost, frame_kind, None)
    return out.to_numpy().astype(float)


def not_a_number(df: Any, cols: list[str], frame_kind: str, exc: Exception | None) -> LogFormatError:
    """The error for the first value of ``cols`` that is not a real number."""
    for c in cols:
        values = df[c].to_list() if frame_kind == "polars" else df[c].tolist()
        for k, v in enumerate(values):
            if v is None or isinstance(v, bool | int | float | np.integer | np.floating):
                continue
            try:
                float(v)
            except (ValueError, TypeError):
                return LogFormatError(f"DataFrame, row {k}, column {c}: {shown_value(v)} is not a number")
    return LogFormatError(f"DataFrame, column(s) {', '.join(map(str, cols))}: not numbers ({exc})")
