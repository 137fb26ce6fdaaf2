r"""PX4 flight logs: ULog files (``.ulg``, read with ``pyulog``: ``pip install "omegahat[px4]"``) and the per-topic
CSV files ``ulog2csv`` writes from them.

PX4's attitude messages (``vehicle_attitude``, ``vehicle_attitude_groundtruth``, ``estimator_attitude``, and the
odometry messages ``vehicle_odometry``, ``vehicle_mocap_odometry``, ``vehicle_visual_odometry``) carry a quaternion
``q`` of four floats, **Hamilton, scalar first** (``q[0] = w``), that rotates the body's FRD axes into the earth's
NED axes: body → inertial, omegahat's ``R``, so the rate comes out in the body's FRD axes. Their times are integers
in **microseconds** since the autopilot started: ``timestamp`` (when the message was published) and
``timestamp_sample`` (when the data it carries were sampled); the sample time is read where the message has it,
else the publication time.

**Which topic.** ``--topic NAME`` (``topic=`` in Python) names one: the message's name, with ``_N`` for its
instance ``N`` when the log has several (``estimator_attitude_1``; ``_0`` may be left out). Without it,
``vehicle_attitude`` is read where the log has it and the note lists the others: it is PX4's own attitude
estimate, made **with** the vehicle's gyroscope, so a rate from it is not independent of that gyroscope; an
external source (``vehicle_mocap_odometry``, ``vehicle_visual_odometry``) is, and is chosen with ``--topic``. A log
without ``vehicle_attitude`` and with several others is refused, naming them.

**Messages** are read in their order in the log and sorted by time where they are not (counted in a note, as for
ROS bags: :func:`omegahat.io.timestamps.sort_by_time`); a quaternion of NaN (an odometry message whose attitude is
invalid) is a missing sample. Resets of PX4's estimator (``quat_reset_counter``, ``delta_q_reset``) are undone
(:func:`_undo_resets`), said in a note. The stream is labelled by message index, so errors name ``message N``. Dropouts
the logger recorded (messages it could not write) are said in a note, with their total length.

**ulog2csv's CSV** (``<log>_<topic>_<instance>.csv``): a header whose first column is ``timestamp`` and which has
``q[0] .. q[3]``; read as above (microseconds, scalar first; ``timestamp_sample`` where present) through the text
reader (:func:`omegahat.io.csvlog.open_by_header`).
"""

from __future__ import annotations

import contextlib
import io
import os
import struct
from collections.abc import Callable
from typing import Any

import numpy as np

from omegahat.io.columns import Layout, LogFormatError, normalise_name
from omegahat.io.csvlog import TextFormat, open_by_header
from omegahat.io.registry import LogStream, ReadOptions
from omegahat.io.textlines import header_fields
from omegahat.io.timestamps import sort_by_time
from omegahat.so3 import quat_product

__all__ = ["ULOG_MAGIC", "is_px4_csv", "is_ulog", "open_px4_csv", "open_ulog", "read_ulog_gyro"]

ULOG_MAGIC = b"ULog\x01\x12\x35"  #: the first 7 bytes of every ULog file
_QUATERNION = ("q[0]", "q[1]", "q[2]", "q[3]")  # w, x, y, z
_DEFAULT_TOPIC = "vehicle_attitude"
_MICROSECONDS = 1e-6


def is_ulog(path: str | os.PathLike[str]) -> bool:
    """Whether a file starts with the ULog magic bytes."""
    try:
        with open(path, "rb") as f:
            return f.read(len(ULOG_MAGIC)) == ULOG_MAGIC
    except OSError:
        return False


def _pyulog():
    """pyulog's reader and the exception it raises for a file it cannot read."""
    try:
        from pyulog import ULog
        from pyulog.exceptions import ULogException
    except ImportError:  # pragma: no cover - the test extra installs it
        raise ImportError('reading PX4 ULog files needs pyulog: pip install "omegahat[px4]"') from None
    return ULog, ULogException


def _field_names(fields: list) -> set[str]:
    """The field names of a message format (pyulog's ``(type, array size, name)``), an array's elements named
    ``name[k]`` as pyulog reads them."""
    return {f"{name}[{k}]" for _, size, name in fields for k in range(size)} | {n for _, s, n in fields if s == 0}


def _display(name: str, multi_id: int, instances: int) -> str:
    return f"{name}_{multi_id}" if instances > 1 or multi_id else name


def _choose(found: dict[str, Any], topic: str | None, path: str, what: str, defaults: tuple[str, ...]) -> str:
    """The display name of the topic to read: ``topic`` (``_0`` optional), else the first of ``defaults`` the log
    has, else its only one; ``what`` (``attitude``, ``gyroscope``) names them in the errors."""
    if not found:
        raise LogFormatError(f"{path}: no {what} topic")
    if topic is not None:
        for name in (topic, topic.removesuffix("_0"), f"{topic}_0"):
            if name in found:
                return name
        article = "an" if what[0] in "aeiou" else "a"
        raise LogFormatError(f"{path}: no topic {topic!r} with {article} {what}; the log has {', '.join(found)}")
    for name in (n for d in defaults for n in (d, f"{d}_0")):
        if name in found:
            return name
    if len(found) == 1:
        return next(iter(found))
    raise LogFormatError(f"{path}: {len(found)} {what} topics ({', '.join(found)}); choose one with --topic NAME")


def _topics(path: str, keep: Callable[[str, list], bool]) -> tuple[Any, dict[str, Any]]:
    """pyulog's reading of the messages whose format ``keep(name, fields)`` accepts, and those topics by display
    name; a file pyulog cannot read is a :class:`LogFormatError`."""
    ULog, ULogException = _pyulog()
    try:  # pyulog prints what it finds damaged, line by line: said once, in a note (_damage)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            head = ULog(path, parse_header_only=True)
            wanted = sorted(n for n, fmt in head.message_formats.items() if keep(n, fmt.fields))
            log = ULog(path, message_name_filter_list=wanted or [""])
    except (ULogException, OSError, ValueError, IndexError, KeyError, TypeError, struct.error) as exc:  # damaged
        raise LogFormatError(f"{path}: not a readable ULog file ({type(exc).__name__}: {exc})") from None
    counts: dict[str, int] = {}
    for d in log.data_list:
        counts[d.name] = counts.get(d.name, 0) + 1
    return log, {_display(d.name, d.multi_id, counts[d.name]): d for d in log.data_list if d.name in wanted}


def _stamps(data: dict, path: str, chosen: str) -> tuple[np.ndarray, str]:
    """A topic's times (int64 µs) and the field they come from: ``timestamp_sample`` where every message has one,
    else ``timestamp``; none, or a stamp beyond what int64 holds (a damaged message), is refused."""
    field = "timestamp_sample" if "timestamp_sample" in data and np.all(data["timestamp_sample"] > 0) else "timestamp"
    raw = np.asarray(data[field])
    if raw.size == 0:
        raise LogFormatError(f"{path}, topic {chosen}: no messages")
    beyond = np.flatnonzero(raw.astype(np.float64) >= 2.0**62)  # no int64 wrap-around
    if beyond.size:
        k = int(beyond[0])
        raise LogFormatError(f"{path}, topic {chosen}, message {k}: {field} {raw[k]} µs is no time since boot")
    return raw.astype(np.int64), field


def open_ulog(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """One attitude topic of a PX4 ULog file (module docstring)."""
    path = os.fspath(path)
    log, found = _topics(path, lambda name, fields: {"timestamp", *_QUATERNION} <= _field_names(fields))
    chosen = _choose(found, options.topic, path, "attitude", (_DEFAULT_TOPIC,))
    data = found[chosen].data
    stamps, field = _stamps(data, path, chosen)
    order, n_late = sort_by_time(stamps)
    base = int(stamps.min())
    q = np.column_stack([np.asarray(data[c], dtype=float) for c in _QUATERNION])  # w, x, y, z
    notes = _late(n_late)
    others = [n for n in found if n != chosen]
    if others:
        own = " (PX4's attitude estimate, made with its gyroscope)" if chosen.startswith(_DEFAULT_TOPIC) else ""
        notes.append(f"topic {chosen}{own}; the log also has {', '.join(others)} (--topic NAME)")
    notes += _damage(log)
    q, undone = _undo_resets(q[order][:, [1, 2, 3, 0]], data, order)  # storage order x, y, z, w
    notes.extend([undone] if undone else [])
    return LogStream.from_arrays(
        path,
        "quaternion",
        (stamps[order] - base) * _MICROSECONDS,
        q,
        labels=order,
        label="message",
        t0=base * _MICROSECONDS,
        time_name=field,
        attitude_name="q[0],q[1],q[2],q[3]",
        description=(
            f"PX4 ULog: topic {chosen}, {stamps.size} messages, quaternion q[0..3] (w first; body FRD to earth NED), "
            f"time from {field} in µs"
        ),
        notes=notes,
        context=f", topic {chosen}",
    )


#: PX4's gyroscope topics and the prefix of their three rate fields (rad/s): the full-rate gyro in body axes, the
#: controllers' filtered and bias-corrected rate, and each raw sensor in its own axes (sensor_gyro_N)
_GYROSCOPES = {"sensor_combined": "gyro_rad", "vehicle_angular_velocity": "xyz", "sensor_gyro": ""}


def _gyro_fields(name: str) -> tuple[str, str, str]:
    prefix = _GYROSCOPES[name]
    return (f"{prefix}[0]", f"{prefix}[1]", f"{prefix}[2]") if prefix else ("x", "y", "z")


def read_ulog_gyro(
    path: str, topic: str | None = None
) -> tuple[np.ndarray, np.ndarray, tuple[str, str, str, str], str]:
    """A PX4 ULog's gyroscope for ``omegahat calibrate``: ``(t (M,) s since boot, g (M, 3) rad/s, the names of the
    time and rate fields, the note saying what was read)``. ``topic`` chooses among :data:`_GYROSCOPES`' topics
    the log has (default ``sensor_combined``, else ``vehicle_angular_velocity``); messages in time order."""
    log, found = _topics(
        path, lambda name, fields: name in _GYROSCOPES and {"timestamp", *_gyro_fields(name)} <= _field_names(fields)
    )
    chosen = _choose(found, topic, path, "gyroscope", ("sensor_combined", "vehicle_angular_velocity"))
    data = found[chosen].data
    stamps, field = _stamps(data, path, chosen)
    order, n_late = sort_by_time(stamps)
    x, y, z = _gyro_fields(found[chosen].name)
    g = np.column_stack([np.asarray(data[f], dtype=float) for f in (x, y, z)])[order]
    said = [f"PX4 ULog topic {chosen}, {field} in µs since boot (converted to s)", *_late(n_late), *_damage(log)]
    return stamps[order] * _MICROSECONDS, g, (field, x, y, z), "; ".join(said)


def _late(n_late: int) -> list[str]:
    return [f"{n_late} message(s) came after a later one: sorted by time"] if n_late else []


def _damage(log: Any) -> list[str]:
    """What the file says was lost: parts pyulog skipped as damaged, and the logger's own dropouts."""
    notes = []
    if log.file_corruption:
        notes.append("pyulog found damaged parts in the file and skipped them: messages may be missing there")
    lost = [float(getattr(d, "duration", 0)) for d in log.dropouts]
    if lost:
        notes.append(f"the logger recorded {len(lost)} dropout(s), {sum(lost):g} ms in all: messages lost there")
    return notes


def _undo_resets(q: np.ndarray, data: dict, order: np.ndarray) -> tuple[np.ndarray, str]:
    """The quaternions ``q`` (scalar last, in time order) with the estimator's resets undone, and the note saying so
    (empty where there were none).

    PX4's estimator resets its attitude (its heading, mostly) by a rotation of the earth frame, ``q_after = Δ ⊗
    q_before``, publishes ``Δ`` as ``delta_q_reset`` and counts the resets in ``quat_reset_counter`` (a ``uint8``).
    From the ``n``-th reset on, ``q̃ = (Δ_n ⊗ … ⊗ Δ_1)⁻¹ ⊗ q`` continues the attitude of before (R1): no step
    carries a reset, and no sample is lost to it. A rate in body axes does not change under a constant rotation of the
    earth frame, so nothing else does."""
    fields = ("quat_reset_counter", *(f"delta_q_reset[{k}]" for k in range(4)))
    if not all(f in data for f in fields) or q.shape[0] < 2:
        return q, ""
    counter = np.asarray(data["quat_reset_counter"])[order].astype(np.int64)
    resets = np.flatnonzero(np.diff(counter) % 256 != 0) + 1
    delta = np.column_stack([np.asarray(data[f"delta_q_reset[{k}]"], dtype=float)[order] for k in (1, 2, 3, 0)])
    total, used, largest = np.array([0.0, 0.0, 0.0, 1.0]), 0, 0.0
    out = q.copy()
    for i, k in enumerate(resets):
        d = delta[k]
        size = float(np.linalg.norm(d))
        if np.isfinite(size) and size > 0:  # a reset without its rotation changes nothing below
            d = d / size
            total = quat_product(d, total)  # Δ_n ⊗ … ⊗ Δ_1
            used += 1
            largest = max(largest, 2.0 * float(np.arccos(min(1.0, abs(d[3])))))
        end = resets[i + 1] if i + 1 < resets.size else q.shape[0]
        out[k:end] = quat_product(total * np.array([-1.0, -1.0, -1.0, 1.0]), q[k:end])
    if not used:
        return q, ""
    return out, (
        f"undid {used} reset(s) of PX4's estimator by its delta_q_reset (the largest {np.degrees(largest):.3g}°): "
        "the attitude continues across them"
    )


def _px4_columns(names: list[str]) -> tuple[tuple[str, int], ...] | None:
    """ulog2csv's columns as a column map (1-based), or None where the header is not one."""
    base = [normalise_name(n) for n in names]
    if not base or base[0] != "timestamp" or not set(_QUATERNION) <= set(base):
        return None
    time = base.index("timestamp_sample") if "timestamp_sample" in base else 0
    return (
        ("t", time + 1),
        *((k, base.index(c) + 1) for k, c in zip(("qw", "qx", "qy", "qz"), _QUATERNION, strict=True)),
    )


def is_px4_csv(path: str | os.PathLike[str]) -> bool:
    """Whether a CSV file is one of ulog2csv's: ``timestamp`` first, and ``q[0] .. q[3]`` columns."""
    return _px4_columns(header_fields(os.fspath(path))) is not None


def _describe(stream: LogStream, lay: Layout, names: list[str]) -> str:
    del lay
    return (
        f"PX4 ulog2csv CSV: quaternion q[0..3] (w first; body FRD to earth NED), time from column "
        f"{stream.time_name!r} in µs"
    )


def open_px4_csv(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """The attitude of one of ulog2csv's CSV files (module docstring)."""
    refusal = "not a PX4 ulog2csv file (no 'timestamp' first and q[0]..q[3])"
    return open_by_header(
        path, options, _px4_columns, refusal, TextFormat(time_scale=_MICROSECONDS, describe=_describe)
    )
