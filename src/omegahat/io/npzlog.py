r"""NPZ logs (``numpy.savez``): arrays by name, every error naming the array.

Arrays: ``t (T,)``; the attitude as ``q (T, 4)``, ``R (T, 3, 3)`` or ``b (T, n, 3)``, or column by column under the
CSV names (:mod:`omegahat.io.columns`); optionally ``tau (T, 3)`` or ``tau_x, tau_y, tau_z``. A row with any
non-finite entry is a missing sample.

**Quaternion order of ``q``.** An array cannot say which component is the scalar. The order comes from, in this
order: a ``scalar_first`` entry in the file, which must be a true boolean (``numpy.bool_`` or a 0-d bool array;
the string ``"False"`` or the number 0 are refused rather than guessed); the ``scalar_first`` option
(``--scalar-first``/``--scalar-last``); else SciPy's scalar-last ``(x, y, z, w)``, and the stream's notes say it was
assumed.
A file entry and an option that disagree are an error.

NPZ files are read whole (``numpy.load`` of each array) and handed on in chunks
(:meth:`~omegahat.io.registry.LogStream.from_arrays`).
"""

from __future__ import annotations

import os
import zipfile

import numpy as np

from omegahat.io.columns import MATRIX_COLUMNS, QUATERNION_COLUMNS, TORQUE_COLUMNS, direction_columns, layout
from omegahat.io.columns import LogFormatError as _Err
from omegahat.io.registry import LogStream, ReadOptions

__all__ = ["open_npz"]


def _scalar_first(z, path: str, option: bool | None) -> tuple[bool, str]:
    """``(scalar_first, note)`` for a ``q`` array (module docstring)."""
    if "scalar_first" in z.files:
        a = z["scalar_first"]
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
        z = np.load(path, allow_pickle=False)
        if not hasattr(z, "files"):
            raise ValueError("it holds a single array, not named arrays")
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise _Err(f"{path}: not a readable .npz file ({exc})") from None
    notes = []
    with z:
        names = list(z.files)

        def get(name, want: str, shape_ok):
            try:
                a = z[name]
            except (ValueError, OSError, zipfile.BadZipFile, EOFError) as exc:
                raise _Err(f"{path}, array {name}: cannot be read ({exc})") from None
            if not (np.issubdtype(a.dtype, np.number) or a.dtype == np.bool_):
                raise _Err(f"{path}, array {name}: expected numbers, got dtype {a.dtype}")
            a = np.asarray(a, dtype=float)
            if not shape_ok(a.shape):
                raise _Err(f"{path}, array {name}: expected shape {want}, got {a.shape}")
            return a

        if "t" not in names:
            raise _Err(f"{path}: no array 't' (found: {', '.join(names) or 'none'})")
        t = get("t", "(T,)", lambda s: len(s) == 1 and s[0] > 0)
        T = t.size
        whole = [n for n in ("q", "R", "b") if n in names]
        columns = [n for n in names if n in QUATERNION_COLUMNS + MATRIX_COLUMNS or direction_columns([n])]
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
        else:
            lay = layout([n for n in names if n not in ("tau",)], path, "t", options.scalar_first)
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

    return LogStream.from_arrays(path, kind, t, data, torque, notes=notes, attitude_name=name)
