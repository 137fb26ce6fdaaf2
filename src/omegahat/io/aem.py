r"""CCSDS Attitude Ephemeris Messages (AEM): the attitude histories spacecraft operations exchange, in the
keyword = value text form (KVN) of the CCSDS Attitude Data Messages standard (CCSDS 504.0-B), versions 1.0 and 2.0.

**Recognised** by its first line, ``CCSDS_AEM_VERS = 1.0`` (or ``2.0``), whatever the file's extension (``.aem``,
``.kvn``, ``.txt``). The XML form (``<aem id="CCSDS_AEM_VERS" ...>``, ``.xml``) is read too, through
:mod:`omegahat.io.aem_xml`, for quaternions and spin.

**Layout.** A header (``CCSDS_AEM_VERS``, ``CREATION_DATE``, ``ORIGINATOR`` ...), then one or more segments: a
metadata block (``META_START`` ... ``META_STOP``) and a data block (``DATA_START`` ... ``DATA_STOP``; a version 2.0
file may leave these two words out) of one line per epoch: the epoch, then the attitude's numbers, separated by
blanks. ``COMMENT`` lines and blank lines may stand anywhere and are skipped.

**Epochs** are calendar dates ``YYYY-MM-DDThh:mm:ss.ddd`` or day-of-year dates ``YYYY-DDDThh:mm:ss.ddd``, in the
segment's ``TIME_SYSTEM`` (UTC, TAI, TT, GPS, TDB ...). They are read to the nanosecond as seconds since
1970-01-01T00:00:00 **of that time scale**: only their differences enter the rates, and the output's times are
those seconds (the note names the scale). A leap second (``23:59:60``) is refused with its line: a uniform count of
seconds cannot place it. Every segment must use the same time system.

**Frames and direction.** ``REF_FRAME_A`` and ``REF_FRAME_B`` name two frames; one of them is the spacecraft's (a
name of the standard's spacecraft body frames: ``SC_BODY_1``, ``STARTRACKER_2``, ``INSTRUMENT_A`` ... — an equipment
word of :data:`SPACECRAFT_EQUIPMENT`, ``_`` and a label), the other the external frame (``EME2000``, ``ICRF``, an
orbit frame ...). A file that names its spacecraft frame otherwise (``BCS``, ``BODY``) is refused with a message
until ``--body NAME`` (``body=`` in Python) says which frame it is. ``ATTITUDE_DIR`` (version 1.0; always ``A2B`` in
version 2.0) says which way the attitude maps. The standard's quaternion :math:`q = (q_1, q_2, q_3, q_c)` (vector
part, then the scalar :math:`q_c = \cos\frac\varphi2`) maps the components of a vector from the frame it starts from
to the frame it ends at through the direction cosine matrix

.. math::

   M(q) = \begin{pmatrix}
     q_c^2+q_1^2-q_2^2-q_3^2 & 2(q_1q_2+q_3q_c) & 2(q_1q_3-q_2q_c) \\
     2(q_1q_2-q_3q_c) & q_c^2-q_1^2+q_2^2-q_3^2 & 2(q_2q_3+q_1q_c) \\
     2(q_1q_3+q_2q_c) & 2(q_2q_3-q_1q_c) & q_c^2-q_1^2-q_2^2+q_3^2
   \end{pmatrix} = R(q)^\top,  \tag{A1}

:math:`R(q)` being the rotation matrix of the Hamilton quaternion (SciPy's ``Rotation.from_quat``, scalar last).
omegahat's :math:`R` maps body to external, :math:`v_E = R\,v_B`. So

.. math::

   R = R(q) \quad\text{where the attitude maps external} \to \text{spacecraft}, \qquad
   R = R(q)^\top \quad\text{where it maps spacecraft} \to \text{external},  \tag{A2}

the second by the conjugate quaternion. The rates come out in the spacecraft frame's axes, relative to the
external frame. Euler angles (``EULER_ANGLE`` types, degrees, ``EULER_ROT_SEQ`` ``321`` or ``ZYX``: rotations of the
frame about its own moving axes, in the order of the sequence) give, from external to spacecraft,
:math:`M = R_{a_3}(\theta_3)^\top R_{a_2}(\theta_2)^\top R_{a_1}(\theta_1)^\top`, so
:math:`R = R_{a_1}(\theta_1)R_{a_2}(\theta_2)R_{a_3}(\theta_3)` (SciPy's upper-case, intrinsic sequence), and the
``SPIN`` type's right ascension :math:`\alpha`, declination :math:`\delta` and spin angle :math:`\varphi` are the
``ZXZ`` sequence :math:`(90° + \alpha, 90° - \delta, \varphi)`; each is conjugated as in (A2) for the other
direction. ``--rotation`` is refused: the file states which way its attitude maps.

**Types read**: ``QUATERNION``, ``QUATERNION/DERIVATIVE``, ``QUATERNION/RATE`` (1.0), ``QUATERNION/ANGVEL`` (2.0)
(``QUATERNION_TYPE = FIRST`` or ``LAST`` in version 1.0, where it is required; version 2.0 writes the scalar
last); ``EULER_ANGLE``, ``EULER_ANGLE/RATE`` (1.0), ``EULER_ANGLE/DERIVATIVE`` and ``EULER_ANGLE/ANGVEL`` (2.0);
``SPIN``. The rates and derivatives a line may carry after its attitude are not used (the note says so): the
estimate is made from the attitudes alone. Where their meaning is plain (:func:`_file_rates`: ``.../ANGVEL``,
quaternion derivatives) they go with the rows
(``extra["reference_rate"]``), and the command's closing lines compare the estimate with them
(:mod:`omegahat.io.pipeline`): how a gyro-less estimate would have done on a mission's own data. ``SPIN/NUTATION`` and
``SPIN/NUTATION_MOM`` are refused.

**Segments** are read one after the other; they must describe the same spacecraft frame relative to the same
external frame (their type, direction and quaternion order may differ). An epoch repeated where one segment ends
and the next begins is left to the timestamp policy (:mod:`omegahat.io.timestamps`), which merges equal attitudes
and says so; the time between segments is a gap like any other.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from datetime import date, timedelta

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.io.aem_xml import xml_segments
from omegahat.io.columns import LogFormatError, shown_value
from omegahat.io.precision import significant_digits
from omegahat.io.registry import LogStream, ReadOptions
from omegahat.io.textlines import head_lines, source_blocks

__all__ = ["SPACECRAFT_EQUIPMENT", "epoch_nanoseconds", "epoch_text", "is_aem", "open_aem"]

#: the equipment words of the standard's spacecraft body frames (SANA registry, and ``GYRO`` of version 1.0)
SPACECRAFT_EQUIPMENT = (
    "ACC",
    "ACTUATOR",
    "AST",
    "CSS",
    "DSS",
    "ESA",
    "GYRO",
    "GYRO_FRAME",
    "IMU_FRAME",
    "INSTRUMENT",
    "MTA",
    "RW",
    "SA",
    "SC_BODY",
    "SENSOR",
    "STARTRACKER",
    "TAM",
)
_SPACECRAFT = re.compile(rf"^({'|'.join(sorted(SPACECRAFT_EQUIPMENT, key=len, reverse=True))})_[A-Z0-9]+$")
_EPOCH = re.compile(r"^(\d{4})-(?:(\d{2})-(\d{2})|(\d{3}))T(\d{2}):(\d{2}):(\d{2})(?:\.(\d*))?Z?$")
_EPOCH_FORMS = "YYYY-MM-DDThh:mm:ss.ddd or YYYY-DDDThh:mm:ss.ddd"
_UNIX_DAY = date(1970, 1, 1)
# attitude type -> (numbers on a line after the epoch, how many of them are the attitude)
_TYPES = {
    "QUATERNION": (4, 4),
    "QUATERNION/DERIVATIVE": (8, 4),
    "QUATERNION/RATE": (7, 4),
    "QUATERNION/ANGVEL": (7, 4),
    "EULER_ANGLE": (3, 3),
    "EULER_ANGLE/RATE": (6, 3),
    "EULER_ANGLE/DERIVATIVE": (6, 3),
    "EULER_ANGLE/ANGVEL": (6, 3),
    "SPIN": (4, 3),
}
_AXES = {"1": "X", "2": "Y", "3": "Z", "X": "X", "Y": "Y", "Z": "Z"}


def is_aem(path: str | os.PathLike[str]) -> bool:
    """Whether a text file is an AEM: its first line that is not blank or a comment starts ``CCSDS_AEM_VERS``, or
    (the XML form) its first lines open an ``<aem`` element."""
    lines = [s.strip() for s in head_lines(os.fspath(path), 40) if s.strip()]
    first = next((s for s in lines if not s.startswith("COMMENT")), "")
    return first.startswith("CCSDS_AEM_VERS") or _xml_form(lines)


def _xml_form(lines: list[str]) -> bool:
    """Whether a file's first lines open the XML form's ``<aem`` element."""
    return any(s.strip().startswith("<aem") for s in lines)


def epoch_nanoseconds(text: str) -> int | None:
    """Nanoseconds since 1970-01-01T00:00:00 of an epoch ``YYYY-MM-DDThh:mm:ss[.d...]`` or ``YYYY-DDDThh:mm:ss[.d...]``
    (decimals beyond the ninth rounded), counting every day as 86 400 s; None if the text is no such epoch, or a
    leap second's (``ss`` = 60)."""
    m = _EPOCH.match(text)
    if not m:
        return None
    year, hour, minute, second = int(m[1]), int(m[5]), int(m[6]), int(m[7])
    try:
        if m[4] is None:
            day = date(year, int(m[2]), int(m[3]))
        else:
            day = date(year, 1, 1) + timedelta(days=int(m[4]) - 1)
            if not 1 <= int(m[4]) or day.year != year:
                return None
    except ValueError:
        return None
    if hour > 23 or minute > 59 or second > 59:
        return None
    decimals = m[8] or ""
    fraction = int(decimals[:9].ljust(9, "0")) + (len(decimals) > 9 and decimals[9] >= "5")
    seconds = (((day - _UNIX_DAY).days * 24 + hour) * 60 + minute) * 60 + second
    return seconds * 1_000_000_000 + fraction


def epoch_text(ns: int) -> str:
    """The epoch ``YYYY-MM-DDThh:mm:ss.d...`` of ``ns`` nanoseconds since 1970-01-01T00:00:00 (the inverse of
    :func:`epoch_nanoseconds`; the decimals to the last that is not zero, at least one)."""
    seconds, fraction = divmod(int(ns), 1_000_000_000)
    days, second = divmod(seconds, 86_400)
    day = _UNIX_DAY + timedelta(days=days)
    decimals = f"{fraction:09d}".rstrip("0") or "0"
    return f"{day.isoformat()}T{second // 3600:02d}:{second // 60 % 60:02d}:{second % 60:02d}.{decimals}"


@dataclass
class _Segment:
    """One metadata block (its keywords, the line of its ``META_START``) and its data lines."""

    line: int
    keys: dict[str, str]
    rows: list[tuple[int, list[str]]]


def _lines(path: str) -> list[str]:
    notes: list[str] = []
    data = b"".join(source_blocks(path, 1 << 20, notes, [0]))
    try:
        return data.decode("utf-8").split("\n")
    except UnicodeDecodeError as err:
        line = data[: err.start].count(b"\n") + 1
        raise LogFormatError(f"{path}, line {line}: not text (byte {data[err.start]:#04x})") from None


def _parse(path: str, lines: list[str]) -> tuple[str, list[_Segment]]:
    """The file's version and its segments; every line outside the grammar of the module docstring is refused with
    its number."""
    version = ""
    segments: list[_Segment] = []
    state = "header"  # header -> meta -> data (-> header-like gap between segments: "between")
    for number, raw in enumerate(lines, start=1):
        text = raw.strip()
        if not text or text.startswith("COMMENT"):
            continue
        where = f"{path}, line {number}"
        if text == "META_START" and state in ("header", "between", "data"):
            if not version:
                raise LogFormatError(f"{where}: META_START before CCSDS_AEM_VERS")
            segments.append(_Segment(number, {}, []))
            state = "meta"
        elif text == "META_STOP" and state == "meta":
            state = "data"  # version 2.0 may start the data without DATA_START
        elif text == "DATA_START" and state == "data" and not segments[-1].rows:
            continue
        elif text == "DATA_STOP" and state == "data":
            state = "between"
        elif state == "header" and not ("=" in text and (version or text.startswith("CCSDS_AEM_VERS"))):
            raise LogFormatError(f"{where}: the file does not start with CCSDS_AEM_VERS = ...: it is no CCSDS AEM")
        elif "=" in text and state in ("header", "meta"):
            key, _, value = text.partition("=")
            key, value = key.strip().upper(), value.strip()
            if state == "header":
                version = value if key == "CCSDS_AEM_VERS" else version
            else:
                segments[-1].keys[key] = value
        elif state == "data":
            segments[-1].rows.append((number, text.split()))
        else:
            raise LogFormatError(f"{where}: {text[:60]!r} is out of place in an AEM (expected META_START)")
    if state == "meta":
        raise LogFormatError(f"{path}: the file ends inside a metadata block (no META_STOP)")
    if not segments or not any(s.rows for s in segments):
        raise LogFormatError(f"{path}: an AEM without data lines")
    if version not in ("1.0", "2.0", "1", "2"):
        raise LogFormatError(f"{path}: CCSDS_AEM_VERS = {version}; versions 1.0 and 2.0 are read")
    return version[0], segments


def _key(segment: _Segment, name: str, path: str, default: str | None = None) -> str:
    value = segment.keys.get(name, default)
    if value is None:
        raise LogFormatError(f"{path}, line {segment.line}: the segment's metadata has no {name}")
    return value.upper()


def _frame(name: str) -> str:
    return re.sub(r"[\s_]+", "_", name.strip().upper())


def _direction(segment: _Segment, version: str, path: str, body: str | None) -> tuple[str, str, bool]:
    """(spacecraft frame, external frame, whether the attitude maps external → spacecraft); ``body`` (``--body``)
    names the spacecraft frame where the file's names do not say it."""
    a, b = _frame(_key(segment, "REF_FRAME_A", path)), _frame(_key(segment, "REF_FRAME_B", path))
    direction = _key(segment, "ATTITUDE_DIR", path, None if version == "1" else "A2B")
    if direction not in ("A2B", "B2A"):
        raise LogFormatError(f"{path}, line {segment.line}: ATTITUDE_DIR = {direction}; A2B or B2A")
    named = f"{path}, line {segment.line}: REF_FRAME_A = {a} and REF_FRAME_B = {b}"
    if body is not None:
        if _frame(body) not in (a, b):
            raise LogFormatError(f"{named}: --body {body} is neither")
        craft = [_frame(body)]
    else:
        craft = [f for f in (a, b) if _SPACECRAFT.match(f)]
    if len(craft) != 1:
        raise LogFormatError(
            f"{named}: {'both are' if craft else 'neither is'} named as a spacecraft frame of the standard "
            f"(EQUIPMENT_label, EQUIPMENT one of {', '.join(SPACECRAFT_EQUIPMENT)}); "
            f"say which one is the spacecraft's: --body {b} or --body {a}"
        )
    body_is_b = craft[0] == b
    return craft[0], (a if body_is_b else b), (direction == "A2B") == body_is_b


def _sequence(segment: _Segment, path: str) -> str:
    text = _key(segment, "EULER_ROT_SEQ", path)
    seq = "".join(_AXES.get(c, "?") for c in text)
    if len(text) != 3 or "?" in seq or seq[0] == seq[1] or seq[1] == seq[2]:
        raise LogFormatError(f"{path}, line {segment.line}: EULER_ROT_SEQ = {text} is no rotation sequence")
    return seq


def _numbers(rows: list[tuple[int, list[str]]], expected: int, path: str) -> np.ndarray:
    values = np.empty((len(rows), expected))
    for i, (number, fields) in enumerate(rows):
        if len(fields) != expected + 1:
            raise LogFormatError(
                f"{path}, line {number}: {len(fields) - 1} numbers after the epoch; the segment's type has {expected}"
            )
        for j, text in enumerate(fields[1:]):
            try:
                values[i, j] = float(text)
            except ValueError:
                raise LogFormatError(
                    f"{path}, line {number}, field {j + 2}: {shown_value(text)} is not a number"
                ) from None
    return values


def _epochs(rows: list[tuple[int, list[str]]], path: str) -> np.ndarray:
    out = np.empty(len(rows), dtype=np.int64)
    for i, (number, fields) in enumerate(rows):
        ns = epoch_nanoseconds(fields[0])
        if ns is None:
            leap = ":60" in fields[0]
            raise LogFormatError(
                f"{path}, line {number}, field 1: {fields[0]!r} is "
                + ("a leap second, which a uniform count of seconds cannot place" if leap else "no epoch")
                + f" (read: {_EPOCH_FORMS})"
            )
        out[i] = ns
    return out


def _attitudes(segment: _Segment, version: str, values: np.ndarray, path: str) -> np.ndarray:
    """Quaternions (x, y, z, w) of the body → external rotation ``R`` of (A2), from the segment's attitude type."""
    kind = _key(segment, "ATTITUDE_TYPE", path)
    if kind.startswith("QUATERNION"):
        order = _key(segment, "QUATERNION_TYPE", path, None if version == "1" else "LAST")
        if order not in ("FIRST", "LAST"):
            raise LogFormatError(f"{path}, line {segment.line}: QUATERNION_TYPE = {order}; FIRST or LAST")
        q = values[:, [1, 2, 3, 0]] if order == "FIRST" else values[:, :4]
        return q.copy()
    if kind.startswith("EULER_ANGLE"):
        return Rotation.from_euler(_sequence(segment, path), values[:, :3], degrees=True).as_quat()
    alpha, delta, phi = values[:, 0], values[:, 1], values[:, 2]
    return Rotation.from_euler("ZXZ", np.column_stack([90.0 + alpha, 90.0 - delta, phi]), degrees=True).as_quat()


def _frame_named(segment: _Segment, key: str, path: str) -> str:
    """The frame a metadata value names: a frame's name, or ``REF_FRAME_A`` / ``REF_FRAME_B`` for one of the two."""
    value = _frame(_key(segment, key, path))
    return _frame(_key(segment, value, path)) if value in ("REF_FRAME_A", "REF_FRAME_B") else value


def _file_rates(
    segment: _Segment, kind: str, values: np.ndarray, q: np.ndarray, frames: tuple[str, str, bool], path: str
) -> np.ndarray | None:
    r"""The body rates (rad/s, spacecraft axes) a segment's lines carry after the attitude, where their meaning is
    unambiguous, else None: ``.../ANGVEL`` in either frame's axes (``ANGVEL_FRAME``; deg/s), the rate of the
    attitude's end frame relative to its start frame (the CCSDS registry of attitude elements: "the rotational rate
    of frame B with respect to frame A"; Orekit reads it so), the spacecraft's relative to the external frame or its
    opposite; and quaternion derivatives in either direction,
    :math:`\omega = 2\,\mathrm{vec}(\bar q \otimes \dot q) / |q|^2` for the quaternion :math:`q` of :math:`R`
    (x, y, z, w)."""
    craft, external, external_to_craft = frames
    if kind.endswith("/ANGVEL"):
        axes = _frame_named(segment, "ANGVEL_FRAME", path)
        rate = np.radians(values[:, -3:]) * (1.0 if external_to_craft else -1.0)  # the spacecraft's rate
        if axes == external:
            return Rotation.from_quat(q).inv().apply(rate)  # omega_body = R^T omega_external
        return rate if axes == craft else None
    if kind == "QUATERNION/DERIVATIVE":
        first = _key(segment, "QUATERNION_TYPE", path, "LAST") == "FIRST"
        dq = values[:, [5, 6, 7, 4]] if first else values[:, 4:8].copy()
        if not external_to_craft:
            dq[:, :3] *= -1.0  # the derivative of the conjugate
        v, w, dv, dw = q[:, :3], q[:, 3:], dq[:, :3], dq[:, 3:]
        return 2.0 * (w * dv - dw * v - np.cross(v, dv)) / np.sum(q * q, axis=1)[:, None]
    return None


def open_aem(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """A CCSDS AEM (module docstring) as a stream of quaternions, labelled by line."""
    path = os.fspath(path)
    if options.rotation != "body-to-inertial":
        raise LogFormatError(
            f"{path}: an AEM states which way its attitude maps (ATTITUDE_DIR and its frames); leave --rotation out"
        )
    if _xml_form(head_lines(path, 40)):
        given, raw = xml_segments(path)
        if given not in ("1.0", "2.0"):
            raise LogFormatError(f"{path}: <aem version={given!r}>; versions 1.0 and 2.0 are read")
        version, segments = given[0], [_Segment(*s) for s in raw]
        if not any(s.rows for s in segments):
            raise LogFormatError(f"{path}: an AEM without attitude states")
    else:
        version, segments = _parse(path, _lines(path))
    frames, systems, times, quats, labels, digit_texts = set(), set(), [], [], [], []
    all_quaternions = True
    unused: set[str] = set()
    checks: list[np.ndarray] = []  # the rates the lines carry, where comparable (NaN rows elsewhere)
    for segment in (s for s in segments if s.rows):
        kind = _key(segment, "ATTITUDE_TYPE", path)
        if kind not in _TYPES:
            raise LogFormatError(
                f"{path}, line {segment.line}: ATTITUDE_TYPE = {kind} is not read (read: {', '.join(_TYPES)})"
            )
        craft, external, external_to_craft = _direction(segment, version, path, options.body)
        frames.add((craft, external))
        systems.add(_key(segment, "TIME_SYSTEM", path))
        if len(frames) > 1 or len(systems) > 1:
            raise LogFormatError(
                f"{path}, line {segment.line}: this segment is {craft} relative to {external} in "
                f"{_key(segment, 'TIME_SYSTEM', path)}, unlike the one before; read one kind at a time (split the file)"
            )
        count, attitude = _TYPES[kind]
        values = _numbers(segment.rows, count, path)
        q = _attitudes(segment, version, values, path)
        if not external_to_craft:
            q[:, :3] *= -1.0  # (A2): the conjugate is the inverse rotation
        rates = _file_rates(segment, kind, values, q, (craft, external, external_to_craft), path)
        if count > attitude:
            unused.add(kind)
        checks.append(np.full((len(q), 3), np.nan) if rates is None else rates)
        all_quaternions &= kind.startswith("QUATERNION")
        digit_texts += [f for _, fields in segment.rows[:200] for f in fields[1 : 1 + attitude]]
        times.append(_epochs(segment.rows, path))
        quats.append(q)
        labels += [number for number, _ in segment.rows]
    ns = np.concatenate(times)
    base = int(ns.min())
    (craft, external), system = frames.pop(), systems.pop()
    notes = [f"times in {system}, as seconds since 1970-01-01T00:00:00 {system}; rates of {craft} in its own axes"]
    reference = np.concatenate(checks)
    compared = bool(np.isfinite(reference).any())
    if unused:
        notes.append(
            f"the rates that {', '.join(sorted(unused))} lines carry after the attitude are not used"
            + ("; where their meaning is plain they are compared with the estimate at the end" if compared else "")
        )
    n_seg = sum(1 for s in segments if s.rows)
    first = next(s for s in segments if s.rows).keys
    names = {key.lower(): first[key] for key in ("OBJECT_NAME", "OBJECT_ID", "CENTER_NAME") if key in first}
    meta: dict[str, object] = {
        "aem": {"craft": craft, "external": external, "system": system, "base_ns": base, **names}
    }
    if compared:
        meta["reference_rate"] = f"the rates the AEM's lines carry, in {craft} axes"
    return LogStream.from_arrays(
        path,
        "quaternion",
        (ns - base) * 1e-9,
        np.concatenate(quats),
        labels=np.asarray(labels),
        extra={"reference_rate": reference} if compared else None,
        label="line",
        t0=base * 1e-9,
        time_name="epoch",
        attitude_name="attitude",
        description=(
            f"CCSDS AEM {version}.0: {ns.size} epochs in {n_seg} segment{'s' * (n_seg > 1)}, "
            f"attitude of {craft} relative to {external}"
        ),
        notes=notes,
        meta=meta,
        digits=significant_digits(digit_texts) if all_quaternions else None,  # angles' digits say nothing of q's
    )
