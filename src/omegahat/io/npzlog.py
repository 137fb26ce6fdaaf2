r"""NPZ logs (``numpy.savez``): arrays by name, every error naming the array.

Arrays: the times ``t (T,)`` (or the array ``--time-column`` names; where there is no ``t``, the one array named as
a time, ``time`` or ``timestamp_ns`` as a CSV's column, its unit read from its name; names compared ignoring case);
the attitude as ``q (T, 4)``, ``R (T, 3, 3)``, ``b (T, n, 3)`` or ``rotvec (T, 3)`` (rotation
vectors in radians, as SciPy's ``as_rotvec`` gives them: :mod:`omegahat.io.rotvec`), or column by column under the
CSV names (:mod:`omegahat.io.columns`); optionally ``tau (T, 3)`` or ``tau_x, tau_y, tau_z``. A row with any
non-finite entry is a missing sample.

**Quaternion order of ``q``.** An array cannot say which component is the scalar. The order comes from, in this
order: a ``scalar_first`` entry in the file, which must be a true boolean (``numpy.bool_`` or a 0-d bool array;
the string ``"False"`` or the number 0 are refused rather than guessed); the ``scalar_first`` option
(``--scalar-first``/``--scalar-last``); else SciPy's scalar-last ``(x, y, z, w)``, and the stream's notes say it was
assumed.
A file entry and an option that disagree are an error.

NPZ files are read whole and handed on in chunks (:meth:`~omegahat.io.registry.LogStream.from_arrays`), so what
they may hold is checked before anything is read: every array must be a NumPy ``.npy`` array (never unpickled)
of real numbers or booleans, its shape (from its header) the one expected, its header consistent with the bytes
the archive holds for it, and the arrays read must not exceed :data:`MAX_NPZ_BYTES` in memory. An archive whose
headers claim more (a "zip bomb" that expands a megabyte into gigabytes) is refused with a message stating the
limit, before a byte of it is decompressed; so are members compressed otherwise than numpy writes them (stored or
deflated: Python's ``zipfile`` bounds the output of neither bzip2 nor LZMA). Members that are not arrays omegahat
reads are ignored, like other columns of a CSV; a damaged archive (a bad CRC, a truncated member) is an error
naming the array.
"""

from __future__ import annotations

import math
import os
import zipfile
from typing import IO

import numpy as np

from omegahat.io.columns import (
    EULER_COLUMNS,
    MATRIX_COLUMNS,
    QUATERNION_COLUMNS,
    ROTVEC_COLUMNS,
    TORQUE_COLUMNS,
    direction_columns,
    found_names,
    layout,
    normalise_name,
    time_column_by_name,
    time_named_columns,
    time_or_capital_t,
    time_unit_in_name,
)
from omegahat.io.columns import LogFormatError as _Err
from omegahat.io.registry import LogStream, ReadOptions
from omegahat.io.time_units import TIME_UNITS, unit_stated

__all__ = ["MAX_NPZ_BYTES", "open_npz"]

#: bytes of arrays read from one NPZ log at most (it is read whole): 1 GiB, 16 M samples of t, q and tau
MAX_NPZ_BYTES = 1 << 30
_NPY_MAGIC = b"\x93NUMPY"
#: what reading a damaged or unusual archive raises (a bad CRC, a truncated or encrypted member, a method zipfile
#: does not implement, a damaged compressed stream)
_ARCHIVE_ERRORS = (OSError, EOFError, ValueError, zipfile.BadZipFile, RuntimeError, NotImplementedError)


_METHODS = {zipfile.ZIP_BZIP2: "bzip2", zipfile.ZIP_LZMA: "LZMA"}


def _size(n: float) -> str:
    """``32 MB``, ``3.2 kB``: a byte count for a message."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{int(n)} bytes"


class _Archive:
    """The arrays of an NPZ archive by name (``t`` for the member ``t.npy``), checked from their headers before
    they are read (module docstring)."""

    def __init__(self, zf: zipfile.ZipFile, path: str):
        self.zf, self.path, self.read_bytes = zf, path, 0
        self.members: dict[str, zipfile.ZipInfo] = {}
        for info in zf.infolist():
            name = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
            self.members.setdefault(name, info)
        self.headers: dict[str, tuple[tuple[int, ...], bool, np.dtype, int]] = {}

    @property
    def files(self) -> list[str]:
        return list(self.members)

    def _fail(self, name: str, why: str) -> _Err:
        return _Err(f"{self.path}, array {name}: {why}")

    def header(self, name: str) -> tuple[tuple[int, ...], bool, np.dtype, int]:
        """``(shape, fortran_order, dtype, offset of the data)`` from the array's header."""
        if name in self.headers:
            return self.headers[name]
        info = self.members[name]
        if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            # zipfile decompresses bzip2 and LZMA members without a bound on the output of one read, so that even a
            # header could expand to gigabytes; numpy.savez and savez_compressed never write them
            raise self._fail(
                name,
                f"compressed with method {info.compress_type} ({_METHODS.get(info.compress_type, 'unknown')}), which "
                "numpy never writes; omegahat reads the members numpy.savez (stored) and numpy.savez_compressed "
                "(deflate) write",
            )
        try:
            with self.zf.open(info) as f:
                start = f.read(len(_NPY_MAGIC))
                if start != _NPY_MAGIC:
                    shown = start + f.read(8 - len(start))
                    raise self._fail(name, f"not a NumPy .npy array (it starts with {shown!r})")
                f.seek(0)
                version = np.lib.format.read_magic(f)
                if version == (1, 0):
                    shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
                elif version == (2, 0):
                    shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
                else:
                    raise self._fail(
                        name,
                        f"a .npy array of format version {version[0]}.{version[1]}, which "
                        "omegahat does not read (save it with numpy.savez, without field names)",
                    )
                offset = f.tell()
        except _Err:
            raise
        except _ARCHIVE_ERRORS as exc:
            raise self._fail(name, f"cannot be read ({exc})") from None
        self.headers[name] = (tuple(shape), bool(fortran), dtype, offset)
        return self.headers[name]

    def get(self, name: str, want: str, shape_ok, exact: bool = False) -> np.ndarray:
        """The array ``name`` as floats (``exact``: integers kept as stored), its dtype, ``shape_ok(shape)``
        (``want`` says what is expected), size and the memory limit checked from its header before it is read."""
        shape, _, dtype, offset = self.header(name)
        if dtype.kind == "c":
            raise self._fail(name, f"expected real numbers, got dtype {dtype}")
        if dtype.hasobject or dtype.fields is not None or not (np.issubdtype(dtype, np.number) or dtype == np.bool_):
            raise self._fail(name, f"expected numbers, got dtype {dtype}")
        if not shape_ok(shape):
            raise self._fail(name, f"expected shape {want}, got {shape}")
        count = math.prod(shape)
        nbytes = count * dtype.itemsize
        held = self.members[name].file_size - offset
        if nbytes != held:
            raise self._fail(
                name,
                f"damaged: its header says shape {shape} of {dtype} ({nbytes} bytes) but the archive holds "
                f"{held} bytes for it",
            )
        if self.read_bytes + nbytes > MAX_NPZ_BYTES:
            raise self._fail(
                name,
                f"{_size(nbytes)} (shape {shape} of {dtype}) with the arrays before it would be "
                f"{_size(self.read_bytes + nbytes)} in memory; omegahat reads at most {_size(MAX_NPZ_BYTES)} of "
                "arrays from an NPZ log (it is read whole): split the log, or write it as CSV (read in chunks)",
            )
        out = self._read(name)
        self.read_bytes += nbytes
        return out if exact and dtype.kind in "iu" else np.asarray(out, dtype=float)

    def small(self, name: str, limit: int = 64) -> np.ndarray:
        """A small array of any dtype but objects as it is stored (a flag such as ``scalar_first``); a larger one
        as an empty array of its dtype (its values are not needed to refuse it)."""
        shape, _, dtype, _ = self.header(name)
        if dtype.hasobject or math.prod(shape) > limit:
            return np.empty(0, dtype=object if dtype.hasobject else dtype)
        return self._read(name)

    def _read(self, name: str) -> np.ndarray:
        shape, fortran, dtype, offset = self.header(name)
        out = np.empty(math.prod(shape), dtype=dtype)
        try:
            with self.zf.open(self.members[name]) as f:
                f.seek(offset)
                if out.nbytes:
                    _read_into(f, out.view(np.uint8))
                f.read(1)  # at the end: zipfile checks the member's CRC
        except _ARCHIVE_ERRORS as exc:
            raise self._fail(name, f"cannot be read ({exc})") from None
        return out.reshape(shape, order="F" if fortran else "C")


def _read_into(f: IO[bytes], buffer: np.ndarray) -> None:
    """Fill ``buffer`` (bytes) from ``f``; a member that ends early is damaged."""
    done = 0
    while done < buffer.size:
        n = f.readinto(buffer[done:])  # type: ignore[attr-defined]
        if not n:
            raise EOFError(f"the member ends after {done} of {buffer.size} bytes")
        done += n


def _scalar_first(z: _Archive, path: str, option: bool | None) -> tuple[bool, str]:
    """``(scalar_first, note)`` for a ``q`` array (module docstring)."""
    if "scalar_first" in z.files:
        a = z.small("scalar_first")
        if a.dtype != np.bool_ or a.shape != ():
            shown = a.item() if a.size == 1 else a
            raise _Err(
                f"{path}, array scalar_first: must be a single boolean (numpy True or False); got {shown!r} of dtype "
                f"{a.dtype} (write np.savez(..., scalar_first=True), or drop it and pass --scalar-first or "
                "--scalar-last)"
            )
        sf = bool(a)
        if option is not None and sf != option:
            flag = "--scalar-first" if option else "--scalar-last"
            raise _Err(f"{path}, array scalar_first: {sf} contradicts {flag}; drop one of them")
        return sf, ""
    if option is not None:
        return option, ""
    return (
        False,
        f"quaternion order of array q: x, y, z, w (SciPy's default; pass --scalar-first if {path}'s q is scalar first)",
    )


def open_npz(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """Open an NPZ log (module docstring)."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            start = f.read(len(_NPY_MAGIC))
        if start == _NPY_MAGIC:
            raise ValueError("it holds a single array (numpy.save), not named arrays (numpy.savez)")
        zf = zipfile.ZipFile(path)
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise _Err(f"{path}: not a readable .npz file ({exc})") from None
    notes: list[str] = []
    with zf:
        z = _Archive(zf, path)
        names = z.files
        get = z.get

        time_name = _time_array(path, names, options.time_column, notes)
        raw = get(time_name, "(T,)", lambda s: len(s) == 1 and s[0] > 0, exact=True)
        t, clock = _exact_times(raw, time_name, options, notes)
        T = t.size
        whole = [n for n in ("q", "R", "b", "rotvec") if n in names]
        columns = [
            n for n in names if n in QUATERNION_COLUMNS + MATRIX_COLUMNS + ROTVEC_COLUMNS or direction_columns([n])
        ]
        if len(whole) + bool(columns) > 1:
            raise _Err(f"{path}: attitude given more than one way ({', '.join(whole + columns)}); keep one")
        if "q" in whole:
            q = get("q", f"({T}, 4)", lambda s: s == (T, 4))
            sf, note = _scalar_first(z, path, options.scalar_first)
            notes += [note] if note else []
            data, kind, name = (np.roll(q, -1, axis=1) if sf else q), "quaternion", "q"
        elif "R" in whole:
            data, kind, name = get("R", f"({T}, 3, 3)", lambda s: s == (T, 3, 3)), "matrix", "R"
        elif "b" in whole:
            ok = lambda s: len(s) == 3 and s[0] == T and s[1] >= 1 and s[2] == 3  # noqa: E731
            data, kind, name = get("b", f"({T}, n, 3)", ok), "directions", "b"
        elif "rotvec" in whole:
            data, kind, name = get("rotvec", f"({T}, 3)", lambda s: s == (T, 3)), "rotvec", "rotvec"
        else:
            if not columns and not any(n in names for n in EULER_COLUMNS):
                raise _Err(
                    f"{path}: no attitude array; expected q (T, 4), R (T, 3, 3), b (T, n, 3) or rotvec (T, 3), or "
                    f"the CSV's columns one per array (qw, qx, qy, qz, ...) (found: {found_names(names)})"
                )
            lay = layout([n for n in names if n not in ("tau",)], path, time_name, options.scalar_first)
            kind, name = lay.kind, ",".join(lay.attitude)
            flat = np.column_stack([get(c, f"({T},)", lambda s: s == (T,)) for c in lay.attitude])
            data = (
                flat.reshape(T, 3, 3) if kind == "matrix" else flat.reshape(T, -1, 3) if kind == "directions" else flat
            )
        data = np.array(data, dtype=float)
        data[~np.all(np.isfinite(data.reshape(T, -1)), axis=1)] = np.nan
        torque = None
        if "tau" in names:
            torque = get("tau", f"({T}, 3)", lambda s: s == (T, 3))
        elif any(c in names for c in TORQUE_COLUMNS):
            missing = [c for c in TORQUE_COLUMNS if c not in names]
            if missing:
                raise _Err(f"{path}: torque needs tau_x, tau_y and tau_z; missing {', '.join(missing)}")
            torque = np.column_stack([get(c, f"({T},)", lambda s: s == (T,)) for c in TORQUE_COLUMNS])
        if torque is not None and not np.all(np.isfinite(torque)):
            k = int(np.flatnonzero(~np.all(np.isfinite(torque), axis=1))[0])
            raise _Err(f"{path}, torque at index {k}: not finite ({torque[k].tolist()})")

    return LogStream.from_arrays(
        path, kind, t, data, torque, notes=notes, attitude_name=name, time_name=time_name, **clock
    )


def _time_array(path: str, names: list[str], time_column: str, notes: list[str]) -> str:
    """The array holding the times: ``time_column`` (``--time-column``; ``t`` by default), its name compared
    ignoring case as a CSV's columns are; where the file has no ``t``, the one array named as a time (``time``,
    ``timestamp_ns``, ...: :func:`omegahat.io.columns.time_column_by_name`), said in a note."""
    original = {normalise_name(n): n for n in reversed(names)}  # of names alike but for case, the first
    if "t" in names and normalise_name(time_column) == "t":
        return "t"
    if ask := time_or_capital_t(names, time_column):
        raise _Err(f"{path} (its arrays): {ask}")
    chosen, note = time_column_by_name([normalise_name(n) for n in names], time_column)
    if normalise_name(chosen) not in original:
        several = time_named_columns([normalise_name(n) for n in names])
        hint = f"arrays {', '.join(original[n] for n in several)} could each be the time" if several else ""
        raise _Err(
            f"{path}: no array {time_column!r} (found: {found_names(names)}): "
            + (hint or "name the times t")
            + ", or pass --time-column NAME"
        )
    found = original[normalise_name(chosen)]
    if note:  # chosen by its name (time_column_by_name's note speaks of a CSV's columns)
        notes.append(f"time array: {found!r}, the one named as a time (the file has no array 't')")
    elif found != time_column:
        notes.append(f"time array: {found!r} (names are compared ignoring case, as a CSV's columns)")
    return found


def _exact_times(raw: np.ndarray, name: str, options: ReadOptions, notes: list[str]) -> tuple[np.ndarray, dict]:
    """Integer times (epoch nanoseconds) as the CSV reader keeps them: made relative to the first in integers
    before they become floats (a float64 of 1.7e18 is 256 ns coarse), and where they cannot be seconds, read in
    the one unit their array's ``name`` states (``time_ms``) or their size and rate fit, said in a note; times that
    are not integers in the unit their name states; ``(t, the stream's t0 and meta)``."""
    if raw.dtype.kind not in "iu" or not raw.size or (raw.dtype.kind == "u" and int(raw.max()) >= 2**63):
        t = np.asarray(raw, dtype=float)
        if time_unit_in_name(name) is None:  # floats: no unit guessed from their size (the option's, s by default)
            return t, {}
        found, note = unit_stated(name, options.time_unit, t[:64])
        notes.extend([note] if note else [])
        return (t * TIME_UNITS[found] if found else t), {}
    base = int(raw[0])
    t = (raw.astype(np.int64) - np.int64(base)).astype(float)
    found, note = unit_stated(name, options.time_unit, raw[:64])  # by name or size, as a CSV's or a Parquet table's
    if found:
        notes.append(note or "")
        t = t * TIME_UNITS[found]  # in s now: the checks' scale (--time-unit s) is 1
    scale = TIME_UNITS[found or options.time_unit]
    return t, {"t0": base * scale, "meta": {"time_base": base}}
