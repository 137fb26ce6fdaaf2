"""Parquet tables as input: ``omegahat estimate log.parquet -o omega.csv``.

A Parquet table holds one sample per row under the column names of omegahat's CSV logs (:mod:`omegahat.io.columns`,
any case): the time ``t`` (or the one ``--time-column`` names), a quaternion ``qw, qx, qy, qz`` (or numbered
columns with ``--scalar-first``/``--scalar-last``), a rotation matrix ``r11 … r33`` or body-frame directions
``b1x, b1y, b1z, b2x, …``, and optionally the torque ``tau_x, tau_y, tau_z``; ``--columns`` names other columns as it
does for a CSV. Numeric times are in seconds (or ``--time-unit``); a Parquet timestamp or duration column carries its
unit. Integer and temporal times are counted from the first row's as integers before they become floats, so that
equal stamps stay equal and an epoch time in nanoseconds keeps its precision (a timezone-aware stamp is the instant
it names). The attitude and torque columns, of any numeric type, are read as float64.

It is read with PyArrow, a row group's batches at a time, so memory follows :data:`~omegahat.io.registry.CHUNK_ROWS`
rather than the file. A null or NaN in the attitude makes the sample missing (predicted through), as in every
input; a null time, a null or non-finite torque, or a column that holds no numbers are refused, naming the row (its
position in the table, the first being row 0) and the column. The stream then takes the path every format takes
(:func:`omegahat.io.registry.checked_stream`): the rotation convention and the timestamp policy.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from omegahat.io.colmap import apply_columns, named_quaternion, named_quaternion_note
from omegahat.io.columns import LogFormatError, layout, time_column_by_name, time_or_capital_t
from omegahat.io.registry import CHUNK_ROWS, TIME_UNITS, LogChunk, LogStream, ReadOptions
from omegahat.io.time_units import unit_stated, whole_times

__all__ = ["open_parquet"]


def _numeric(field: pa.Field) -> bool:
    return pa.types.is_integer(field.type) or pa.types.is_floating(field.type) or pa.types.is_null(field.type)


def _floats(column: pa.Array) -> np.ndarray:
    """A numeric column as float64, nulls as NaN."""
    return pc.fill_null(column.cast(pa.float64()), np.nan).to_numpy(zero_copy_only=False)


def _temporal_unit(field: pa.Field) -> float | None:
    """Seconds per unit of a timestamp or duration column (Arrow's units are the time units'); None for a number."""
    if pa.types.is_timestamp(field.type) or pa.types.is_duration(field.type):
        return TIME_UNITS[field.type.unit]
    return None


def _batches(table: pq.ParquetFile, path: str, columns: list[str], size: int) -> Iterator[tuple[int, pa.RecordBatch]]:
    """``(first row, batch)`` of ``columns``, ``size`` rows at a time; a page that cannot be decoded (a damaged
    file) is refused naming the file and the rows read before it."""
    batches = table.iter_batches(batch_size=size, columns=columns)
    row = 0
    while True:
        try:
            batch = next(batches)
        except StopIteration:
            return
        except (OSError, pa.ArrowException) as exc:
            raise LogFormatError(f"{path}: its rows from row {row} on cannot be read ({exc})") from None
        yield row, batch
        row += batch.num_rows


def open_parquet(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """Open a Parquet table (module docstring): its schema now, its rows batch by batch."""
    path = os.fspath(path)
    try:
        table = pq.ParquetFile(path)
    except (OSError, pa.ArrowException) as exc:
        raise LogFormatError(f"{path}: not a readable Parquet file ({exc})") from None
    schema = table.schema_arrow
    original = [str(n) for n in schema.names]
    where = f"{path} (its columns)"
    mapped = options.column_map or named_quaternion(original, options.time_column)  # or the one named by its parts
    names = apply_columns(original, mapped, where, options.time_column)
    time_column = "t" if mapped and "t" in dict(mapped) else options.time_column
    named = None
    if "t" not in dict(mapped or ()):  # no column t: the one named as a time, if there is one
        if ask := time_or_capital_t(original, time_column):
            raise LogFormatError(f"{where}: {ask}")
        time_column, named = time_column_by_name(names, time_column)
    lay = layout(names, where, time_column, options.scalar_first)
    if not lay.time:
        raise LogFormatError(f"{where}: a Parquet log needs a time column (name it t or pass --time-column NAME)")
    column = {n: original[j] for j, n in enumerate(names) if n}
    time_name = column[lay.time]
    unit = _temporal_unit(schema.field(time_name))
    whole = unit is not None or pa.types.is_integer(schema.field(time_name).type)  # read as integers, exactly
    if unit is not None and options.time_unit != "s":
        raise LogFormatError(
            f"{path}, column {time_name}: a {schema.field(time_name).type} column carries its own unit; leave "
            "--time-unit out"
        )
    attitude = [column[c] for c in lay.attitude]
    torque = [column[c] for c in lay.torque] if lay.torque else []
    for name in ([time_name] if unit is None else []) + attitude + torque:
        if not _numeric(schema.field(name)):
            raise LogFormatError(f"{path}, column {name}: holds {schema.field(name).type}, not numbers")
    n_rows = table.metadata.num_rows
    if n_rows == 0:
        raise LogFormatError(f"{path}: no rows")
    first_rows = next(_batches(table, path, [time_name], 64), None)
    if first_rows is None or first_rows[1].num_rows == 0:
        raise LogFormatError(f"{path}: no rows")
    head = first_rows[1].column(0)
    if not head[0].is_valid:
        raise LogFormatError(f"{path}, row 0, column {time_name}: no time (null)")
    # the first row's time is the stream's t0 (s), and the chunks' times count from it: an epoch keeps its digits
    # (integers, nanoseconds since 1970 among them, are subtracted as integers, before they become floats)
    at_row = lambda start: lambda k: f"{path}, row {start + k}, column {time_name}"  # noqa: E731
    first = whole_times(head.to_numpy(zero_copy_only=False), at_row(0))[0] if whole else float(_floats(head)[0])
    scale = unit if unit is not None else 1.0  # to seconds; a number's unit is --time-unit's (the stream's)
    stated, note = None, None  # a number's unit, where its name or size states it (as a CSV's)
    if unit is None:
        stated, note = unit_stated(time_name, options.time_unit, head.to_numpy(zero_copy_only=False))
    scale = TIME_UNITS[stated] if stated else scale
    t0 = first * scale * TIME_UNITS[options.time_unit]
    stream = LogStream(
        path,
        lay.kind,
        lay.n_directions,
        bool(torque),
        "row",
        lambda: iter(()),
        size=n_rows,
        n_rows_hint=n_rows,
        attitude_name=",".join(attitude),
        time_name=time_name,
        description=f"Parquet table: {lay.kind} columns {','.join(attitude)}, time {time_name}",
        t0=t0,
    )
    if math.isfinite(first):  # the chunks' raw times are the file's less it, times scale: messages add it back
        stream.meta["time_base"], stream.meta["time_scale"] = (int(first) if whole else float(first)), scale
    guessed = named_quaternion_note(mapped) if mapped and not options.column_map else ""
    stream.notes.extend(n for n in (guessed, named, note) if n)
    if options.column_map:
        stream.notes.append(f"columns read: {', '.join(f'{k}={v}' for k, v in options.column_map)}")

    def chunks() -> Iterator[LogChunk]:
        for row, batch in _batches(table, path, [time_name, *attitude, *torque], CHUNK_ROWS):
            n = batch.num_rows
            times = batch.column(0)
            if times.null_count:
                k = int(np.flatnonzero(times.is_null().to_numpy(zero_copy_only=False))[0])
                raise LogFormatError(f"{path}, row {row + k}, column {time_name}: no time (null)")
            if whole:
                t = (whole_times(times.to_numpy(zero_copy_only=False), at_row(row)) - first).astype(np.float64) * scale
            else:
                t = (_floats(times) - first) * scale  # the checked stream scales by --time-unit
            data = np.column_stack([_floats(batch.column(1 + j)) for j in range(len(attitude))])
            if lay.kind == "matrix":
                data = data.reshape(n, 3, 3)
            elif lay.kind == "directions":
                data = data.reshape(n, -1, 3)
            tau = None
            if torque:
                tau = np.column_stack([_floats(batch.column(1 + len(attitude) + j)) for j in range(len(torque))])
                bad = np.flatnonzero(~np.all(np.isfinite(tau), axis=1))
                if bad.size:
                    k = int(bad[0])
                    raise LogFormatError(
                        f"{path}, row {row + k}, columns {','.join(torque)}: torque {tau[k].tolist()} is not finite"
                    )
            yield LogChunk(t, data, tau, np.arange(row, row + n))
            stream.done = row + n

    stream._chunks = chunks
    return stream
