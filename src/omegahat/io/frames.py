r"""DataFrames in, angular velocity out: :func:`estimate_frame` for pandas and Polars.

The frame holds one sample per row with the column names of omegahat's logs (:mod:`omegahat.io.columns`: any
case): a quaternion ``qx, qy, qz, qw`` (or the names given by ``quaternion=``, in ``x, y, z, w`` order), or a
rotation matrix ``r11 … r33``, or body-frame directions ``b1x, b1y, b1z, b2x, …`` with ``references=``, or
without any of those the one quaternion named by its parts (``orientation.w``, ``quat_x``:
:func:`omegahat.io.colmap.named_quaternion`, said in a note); optionally the torque ``tau_x, tau_y, tau_z``. Time
is the column ``t`` (seconds, or ``time_unit``) or the one named by ``time=``; for pandas, without such a column, a
``DatetimeIndex``, ``TimedeltaIndex`` or floating-point index; else the one column named as a time (``time``,
``Timestamp``), whose ISO 8601 date texts are read as a CSV's (:mod:`omegahat.io.frame_columns`). Datetime and
duration times are used as integer nanoseconds, so that equal stamps compare exactly; a
timezone-aware time is the instant it names (a clock change is no gap). Integer times are taken relative to the
first in integers (exact), in the unit their column's name states (``time_ms``) or, where they cannot be seconds
(epoch nanoseconds), the one unit their size and spacing fit, said in a note (as a CSV's); float times too (epoch
nanoseconds held as floats, as pandas holds an integer column with a missing value), to float precision. A Polars
``LazyFrame`` is collected first (the estimate needs every row; the result is a ``DataFrame``); anything else (a
``Series``, an array) is refused.

:func:`open_frame` turns the frame into a :class:`~omegahat.io.registry.LogStream` (rows in time order, labelled by
their position in the frame) and passes it through :func:`~omegahat.io.registry.checked_stream`, so a frame gets
exactly what a file gets: the rotation convention, the timestamp policy of :mod:`omegahat.io.timestamps` (rows in
any order are sorted; exact duplicates dropped; conflicting ones refused, naming both rows), and then, in
:func:`estimate_frame`, the path of ``omegahat estimate`` (:func:`omegahat.io.pipeline.estimate_stream`):
automatic gains by default, the fit start, bad samples named by row.

Missing values (NaN, ``None``, ``pd.NA``, Polars nulls; also ±inf, as in every input) in the attitude make the
sample missing: skipped and
predicted through. The output is **indexed like the input**: for pandas a frame with the input's index and
columns ``wx, wy, wz`` (rad/s, body axes) and ``status`` (``corrected``, ``predicted``, ``unavailable``, as in
the command's output; join it to the input with ``df.join(out)``), for Polars a frame with the input's rows in the
input's order, the time column (when there is one) and the same columns. A dropped duplicate row gets the estimate
of the row kept in its place.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from omegahat.interface import STATUS_WORDS
from omegahat.io.colmap import (
    COLUMNS_TEMPLATE,
    apply_columns,
    frame_names,
    named_quaternion,
    named_quaternion_note,
    suggest_columns,
)
from omegahat.io.columns import (
    QUATERNION_COLUMNS,
    LogFormatError,
    layout,
    normalise_name,
    shown_value,
    time_column_by_name,
    time_or_capital_t,
)
from omegahat.io.frame_columns import frame_numbers, pandas_times, polars_times, time_index
from omegahat.io.registry import TIME_UNITS, LogStream, ReadOptions, checked_stream
from omegahat.io.time_units import unit_stated
from omegahat.io.timestamps import late_rows, sort_by_time

if TYPE_CHECKING:
    import pandas as pd  # optional, like polars: imported where a frame of theirs is read
    import polars as pl
    from numpy.typing import ArrayLike

    from omegahat.io.settings import EstimatorName, Start
    from omegahat.observer.gains import ObserverGains  # loads the compiled kernels: imported when estimate_frame runs
    from omegahat.observer.presets import Preset

__all__ = ["estimate_frame", "open_frame"]


def _as_frame(df) -> tuple[pd.DataFrame | pl.DataFrame, str]:
    """``(frame, "pandas" | "polars")``: a DataFrame as it is, a Polars LazyFrame collected; anything else (a
    Series, an array) refused with a message."""
    module = type(df).__module__.split(".")[0]
    if module == "pandas":
        import pandas as pd

        if isinstance(df, pd.DataFrame):
            return df, "pandas"
    elif module == "polars":
        import polars as pl

        if isinstance(df, pl.LazyFrame):
            return df.collect(), "polars"
        if isinstance(df, pl.DataFrame):
            return df, "polars"
    raise TypeError(
        f"estimate_frame takes a pandas or Polars DataFrame; got {module}.{type(df).__name__}"
        + (" (a single column: pass the whole frame)" if type(df).__name__ == "Series" else "")
        + " (a Polars LazyFrame is collected first)"
    )


def open_frame(
    df: pd.DataFrame | pl.DataFrame | pl.LazyFrame,
    options: ReadOptions | None = None,
    *,
    time: str | None = None,
    quaternion: Sequence[str] | None = None,
) -> LogStream:
    """A checked stream of a pandas or Polars frame's rows in time order (module docstring); ``meta`` holds the
    frame's kind, the time column used (None: the index) and each row's time (``"row_t"``, seconds since ``t0``)."""
    options = ReadOptions() if options is None else options
    df, frame_kind = _as_frame(df)
    names = frame_names(list(df.columns), options.header_rows)
    if frame_kind == "pandas" and [str(c) for c in df.columns] != names:
        df = df.set_axis(names, axis=1)  # type: ignore[union-attr]  # a MultiIndex's levels joined (header_rows)
    if options.column_map:  # a column map (omegahat.io.colmap): the mapped columns read under their keys
        mapped = apply_columns(names, options.column_map, "DataFrame")
        if "t" in mapped:
            if time is not None:
                raise ValueError("give the time column once: columns={'t': ...} or time=")
            time = names[mapped.index("t")]
        if quaternion is not None:
            raise ValueError("give the quaternion's columns once: columns= or quaternion=")
    auto = None  # the map of a quaternion named by its parts (colmap.named_quaternion), where one is read
    indexed = frame_kind == "pandas" and time_index(getattr(df, "index", None))  # the index holds the times
    if quaternion is not None:
        q = [str(c) for c in quaternion]
        if len(q) != 4:
            raise ValueError(f"quaternion= names 4 columns in x, y, z, w order; got {q}")
        missing = [c for c in q if c not in names]
        if missing:
            raise LogFormatError(f"DataFrame: missing quaternion column(s) {', '.join(missing)} (quaternion=)")
        as_named = dict(zip(q, QUATERNION_COLUMNS, strict=True))
    else:
        auto = None if options.column_map else named_quaternion(names, time or "t", time is not None or indexed)
        if auto:  # no attitude columns of omegahat's names: the one quaternion named by its parts
            mapped = apply_columns(names, auto, "DataFrame")
        as_named = {n: m for n, m in zip(names, mapped, strict=True) if m != "t"} if options.column_map or auto else {}
    named = None
    if time is None and "t" not in names and not indexed:
        if ask := time_or_capital_t(names, "t", None):  # Time,T,...: T may be a temperature
            raise LogFormatError(f"DataFrame: {ask}: give time= the one that is")
        found, named = time_column_by_name(names, "t")  # no column t: T, or the one named as a time, if there is one
        time = next((n for n in names if normalise_name(n) == normalise_name(found)), None)
    if frame_kind == "pandas":
        times, time_name, clock = pandas_times(df, time)
    else:
        times, time_name, clock = polars_times(df, time)
    used = [as_named.get(n, n) for n in names]
    try:
        lay = layout([u for u, n in zip(used, names, strict=True) if n != time_name], "DataFrame", None)
    except LogFormatError as exc:  # the columns= that reads them, where their names suggest one (as a CSV's)
        line = None if options.column_map else suggest_columns(names)
        if line in (None, COLUMNS_TEMPLATE):  # a map given, or names that suggest none
            raise
        raise LogFormatError(f"{exc}; columns= reads others, as the command line's --columns does: {line}") from None
    original = {normalise_name(u): n for u, n in zip(used, names, strict=True)}
    data = frame_numbers(df, [original[c] for c in lay.attitude], frame_kind)
    T = data.shape[0]
    if T == 0:
        raise LogFormatError("DataFrame: no rows")
    if lay.kind == "matrix":
        data = data.reshape(T, 3, 3)
    elif lay.kind == "directions":
        data = data.reshape(T, -1, 3)
    torque = None
    if lay.torque:
        torque = frame_numbers(df, [original[c] for c in lay.torque], frame_kind)
        bad = np.flatnonzero(~np.all(np.isfinite(torque), axis=1))
        if bad.size:
            raise LogFormatError(f"DataFrame, row {int(bad[0])}: torque {torque[bad[0]].tolist()} is not finite")
    order, n_late = sort_by_time(times)
    unit_note, shown = None, {}  # shown: how messages give the times back as the frame holds them
    if np.issubdtype(times.dtype, np.integer):  # relative to the first in integers, then floats: exact steps
        base = int(times[order[0]])
        row_t = (times - base).astype(np.float64)
        # a clock's nanoseconds; else numbers in the unit their name or size states (as a CSV's), or --time-unit's
        unit: str | None = "ns"
        if not clock:
            unit, unit_note = unit_stated(time_name or "", options.time_unit, times[order[:64]])
        scale = TIME_UNITS[unit] if unit else 1.0  # a unit: in s now, the checks' scale (--time-unit s) is 1
        row_t, t0 = row_t * scale, base * (scale if unit else TIME_UNITS[options.time_unit])
        shown = {"time_base": base, "time_scale": scale}
    else:  # floats: as written, or in the unit their name or size states (epoch ns through a missing value)
        row_t, t0 = np.asarray(times, dtype=float), 0.0
        unit, unit_note = unit_stated(time_name or "", options.time_unit, row_t[order[:64]])
        if unit:
            origin = float(row_t[order[0]])
            row_t, t0 = (row_t - origin) * TIME_UNITS[unit], origin * TIME_UNITS[unit]
            shown = {"time_base": origin, "time_scale": TIME_UNITS[unit]}
    late = f"{n_late} row(s) came after a later one: sorted by time" if n_late else ""
    if n_late:  # rows in any order are read, but a clock that stepped back interleaves the samples around the step
        first = int(np.flatnonzero(late_rows(times))[0])
        at, before = (shown_value(x.item()) for x in (times[first], np.max(times[:first])))
        warnings.warn(
            f"DataFrame: {late} (the first: row {first}, {time_name or 'index'} {at} after {before}); where a clock "
            "stepped back, the rows around the step are interleaved and their rates wrong: sort the frame yourself, "
            "or cut it there",
            UserWarning,
            stacklevel=3,
        )
    notes = [n for n in (named_quaternion_note(auto) if auto else "", named, late, unit_note) if n]
    cols = ", ".join(original[c] for c in lay.attitude)
    stream = LogStream.from_arrays(
        "DataFrame",
        lay.kind,
        row_t[order],
        data[order],
        None if torque is None else torque[order],
        labels=order,
        label="row",
        time_name=time_name or "index",
        t0=t0,
        description=f"DataFrame ({frame_kind}): {lay.kind} columns {cols}",
        notes=notes,
        attitude_name=cols,
        meta={"frame": frame_kind, "time_column": time_name, "row_t": row_t, **shown},
        format="dataframe",
    )
    return checked_stream(stream, options)


class _Collector:
    """The writer :func:`estimate_frame` gives :func:`~omegahat.io.pipeline.estimate_stream`: keeps each row's
    estimate and status by its position in the frame."""

    def __init__(self, n: int):
        self.omega = np.full((n, 3), np.nan)
        self.status = np.zeros(n, dtype=np.int8)
        self.written = np.zeros(n, dtype=bool)
        self.times: list[np.ndarray] = []
        self.rows: list[np.ndarray] = []

    def write(self, chunk, omega, status) -> None:
        self.omega[chunk.labels] = omega
        self.status[chunk.labels] = status
        self.written[chunk.labels] = True
        self.times.append(chunk.t)
        self.rows.append(chunk.labels)

    def spread(self, row_t: np.ndarray) -> None:
        """Give every row the timestamp policy dropped the estimate of the row kept at its time."""
        dropped = np.flatnonzero(~self.written)
        if not dropped.size:
            return
        kept_t, kept_rows = np.concatenate(self.times), np.concatenate(self.rows)
        src = kept_rows[np.searchsorted(kept_t, row_t[dropped])]
        self.omega[dropped], self.status[dropped] = self.omega[src], self.status[src]

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None


def estimate_frame(
    df: pd.DataFrame | pl.DataFrame | pl.LazyFrame,
    *,
    gains: ObserverGains | None = None,
    bandwidth_hz: float | None = None,
    inertia: ArrayLike | None = None,
    references: np.ndarray | Sequence[ArrayLike] | None = None,
    time: str | None = None,
    quaternion: Sequence[str] | None = None,
    time_unit: str = "s",
    rotation: str = "body-to-inertial",
    columns: str | dict | None = None,
    header_rows: int | None = None,
    duplicate_times: str = "error",
    euler: str | None = None,
    angle_unit: str | None = None,
    start: Start = "fit",
    estimator: EstimatorName = "auto",
    smooth: bool = False,
    preset: Preset | None = None,
    skip_bad_samples: bool = False,
    rotation_tol: float | None = None,
    quat_norm_tol: float | None = None,
    verbose: bool = False,
) -> pd.DataFrame | pl.DataFrame:
    """Angular velocity (rad/s, body axes) for every row of a pandas or Polars DataFrame (module docstring).

    The path of ``omegahat estimate``, option for option. By default the model and noises are identified from the
    frame (:func:`omegahat.identification.identify`) and its filter runs where it expects less error than
    differencing, else backward differencing through the log's own causal filter; ``smooth=True`` is
    ``--smooth`` (the whole frame, forwards and backwards); ``bandwidth_hz`` or ``gains`` fix the observer's gains;
    ``preset`` and ``estimator`` are ``--preset`` and ``--estimator``. All parameters but ``df`` are keyword-only;
    errors name them (and carry them: ``exc.options``).

    Parameters
    ----------
    df : pandas.DataFrame, polars.DataFrame or polars.LazyFrame
        One sample per row, the columns of the module docstring (a LazyFrame is collected first).
    gains : ObserverGains, optional
        An :class:`~omegahat.observer.gains.ObserverGains`, e.g. from :func:`omegahat.observer.tuning.sensor_gains`.
    bandwidth_hz : float, optional
        Hz, below half the sample rate, as ``--bandwidth``.
    inertia : array_like, optional
        3 or 9 numbers or 3×3 (default identity, i.e. a locally constant rate).
    references : array_like, optional
        The inertial directions (required for ``b1x, ...`` columns; for attitude input the default is the three rows
        of R).
    time : str, optional
        The time column (default ``t``; pandas without one: the index).
    quaternion : sequence of str, optional
        The quaternion's four columns, in ``x, y, z, w`` order (default: the columns' own names, module docstring).
    time_unit : {"s", "ms", "us", "ns"}, optional
        The unit of numeric times (integer ones: unless their name or size states another, module docstring).
    rotation : {"body-to-inertial", "inertial-to-body"}, optional
        What the attitude maps (default ``body-to-inertial``).
    columns : str or dict, optional
        A column map, as ``--columns``: ``{"t": "Time", "qw": "W", ...}`` or positions (:mod:`omegahat.io.colmap`).
    header_rows : int, optional
        A ``MultiIndex``'s levels, joined per column (:mod:`omegahat.io.colmap`).
    duplicate_times : {"error", "first", "last"}, optional
        Rows at one time whose attitudes differ are refused (``"error"``, the default) or the ``"first"`` or
        ``"last"`` of them is kept, the others getting its estimate (:mod:`omegahat.io.timestamps`, rule 3), with a
        warning that counts them.
    euler, angle_unit : str, optional
        For ``roll, pitch, yaw`` columns, as ``--euler`` and ``--angle-unit``: the sequence (``"ZYX"``) and
        ``"deg"`` or ``"rad"`` (:mod:`omegahat.io.euler`); required for such frames.
    start : {"fit", "warm", "zero"}, optional
        ``fit`` (default: a least-squares rate over the first window), ``warm`` (from the first two samples) or
        ``zero``.
    estimator : {"auto", "omegahat", "sarras"}, optional
        As ``--estimator``: ``auto`` (default) as above, ``omegahat`` the identified model's filter (with ``smooth``
        its smoother) even where differencing is expected to do better, ``sarras`` the fixed-gain observer.
    smooth : bool, optional
        As ``--smooth``: the zero-lag estimate of the identified model, or the log's own Wiener smoother where the
        model is declined (the whole frame is read first).
    preset : {"mocap"}, optional
        As ``--preset`` (:mod:`omegahat.observer.presets`); not with ``inertia``, ``gains``, ``bandwidth_hz`` or
        ``estimator``.
    skip_bad_samples : bool, optional
        Treat samples that are not rotations as missing instead of raising.
    rotation_tol, quat_norm_tol : float, optional
        The input checks' tolerances (None: :mod:`omegahat.measurements`' defaults).
    verbose : bool, optional
        Print what was read and chosen.

    Returns
    -------
    pandas.DataFrame or polars.DataFrame
        Indexed like the input: columns ``wx, wy, wz`` (rad/s, body axes) and ``status``; for Polars also the time
        column, when there is one (module docstring).

    Raises
    ------
    TypeError
        If ``df`` is not a pandas or Polars DataFrame (or LazyFrame).
    LogFormatError
        If the frame cannot be read as a log, naming the row and column.

    Warns
    -----
    SkippedSamplesWarning
        When samples were skipped (missing): :class:`~omegahat.observer.estimator.SkippedSamplesWarning`.

    Examples
    --------
    Noisy quaternions (1 mrad per axis) of a body turning at a constant rate, 100 Hz, in a Polars frame:

    >>> import numpy as np
    >>> import polars as pl
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import estimate_frame
    >>> t = np.arange(0.0, 2.0, 0.01)
    >>> noise = Rotation.from_rotvec(1e-3 * np.random.default_rng(0).standard_normal((t.size, 3)))
    >>> q = (Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])) * noise).as_quat()  # rad/s, body axes
    >>> df = pl.DataFrame({"t": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    >>> out = estimate_frame(df)
    >>> out.columns
    ['t', 'wx', 'wy', 'wz', 'status']
    >>> last = out.row(-1, named=True)
    >>> print(" ".join(f"{last[c]:.2f}" for c in ("wx", "wy", "wz")), last["status"])
    0.30 -0.20 0.50 corrected
    """
    from omegahat.io.pipeline import estimate_stream
    from omegahat.io.settings import EstimateSettings

    df, _ = _as_frame(df)
    options = ReadOptions(
        time_unit=time_unit,
        rotation=rotation,
        columns=columns,
        header_rows=header_rows,
        duplicate_times=duplicate_times,
        euler=euler,
        angle_unit=angle_unit,
    )
    stream = open_frame(df, options, time=time, quaternion=quaternion)
    settings = EstimateSettings(
        inertia=inertia,
        references=references,
        gains=gains,
        bandwidth_hz=bandwidth_hz,
        start=start,
        estimator=estimator,
        preset=preset,
        smooth=smooth,
        skip_bad_samples=skip_bad_samples,
    )
    if rotation_tol is not None:  # else the measurements' default
        settings = replace(settings, rotation_tol=rotation_tol)
    if quat_norm_tol is not None:
        settings = replace(settings, quat_norm_tol=quat_norm_tol)
    n = len(df)
    collector = _Collector(n)
    report = print if verbose else _quiet
    summary = estimate_stream(stream, settings, lambda _: collector, report=report, spell=_argument)
    collector.spread(stream.meta["row_t"])
    if verbose:
        print("\n".join(summary.lines))
    if summary.n_skipped:  # missing, held, spikes, resets: each kind's line (only missing ones start "skipped")
        from omegahat.observer.estimator import SkippedSamplesWarning

        for line in summary.lines:
            if line.startswith(("skipped", "held:", "spikes:", "resets:")):
                warnings.warn(SkippedSamplesWarning(line), stacklevel=2)
    for note in summary.lines:  # rows dropped as the caller chose (duplicate_times): said even when not verbose
        if note.startswith("note: --duplicate-times"):
            warnings.warn(note.removeprefix("note: "), stacklevel=2)
    W, status = collector.omega, np.array(STATUS_WORDS)[collector.status]
    if stream.meta["frame"] == "pandas":
        return _pandas_output(df, W, status)
    return _polars_output(df, W, status, stream.meta["time_column"])


def _pandas_output(df: pd.DataFrame, W: np.ndarray, status: np.ndarray) -> pd.DataFrame:
    import pandas as pd

    columns = {"wx": W[:, 0], "wy": W[:, 1], "wz": W[:, 2], "status": pd.Categorical(status, STATUS_WORDS)}
    return pd.DataFrame(columns, index=df.index)


def _polars_output(df: pl.DataFrame, W: np.ndarray, status: np.ndarray, time_name: str | None) -> pl.DataFrame:
    import polars as pl

    out = pl.DataFrame({"wx": W[:, 0], "wy": W[:, 1], "wz": W[:, 2], "status": status})
    return out.insert_column(0, df.get_column(time_name)) if time_name else out


def _quiet(text: str) -> None:
    """What the command prints, kept quiet, but for its warnings (an implausible time unit, an attitude that Euler's
    equations fit better inverted): raised as Python warnings, since the estimate may be wrong without them."""
    if text.startswith("warning: "):
        warnings.warn(text.removeprefix("warning: "), UserWarning, stacklevel=4)


def _argument(key: str, value: object = None) -> str:
    """An option as :func:`estimate_frame` takes it: its argument (``rotation_tol=0.02``)."""
    if key == "scalar_first":  # a frame's quaternion columns are named, or given in x, y, z, w order
        return "the order of the quaternion= columns (x, y, z, w)"
    if key == "references" and value is not None:  # an example of the form, not a value
        return "references=[(x, y, z)]" if value == "X,Y,Z" else "references= (n, 3)"
    from omegahat.measurements import python_option  # loaded by then (the pipeline calls this)

    return python_option(key, value)
