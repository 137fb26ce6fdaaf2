r"""Attitudes as files write them: rounded and interpolated rotations normalised, what is no rotation named.

Real exports round their numbers (a quaternion written with 5 significant digits) and interpolate between frames (a
linear blend of two unit quaternions is shorter than 1: ``cos(θ/4)`` for frames θ apart), so their attitudes are
rotations only to some precision; SciPy normalises them without a word. omegahat's estimators accept
``|‖q‖ − 1| ≤ quat_norm_tol`` and ``‖RᵀR − I‖_F ≤ rotation_tol`` (1e-3 by default, :mod:`omegahat.measurements`,
policy P). This module is the **one policy for what a file carries**, applied by
:func:`omegahat.io.registry.checked_stream` to every stream (files of every format and DataFrames), before the
timestamp policy and the estimator see the samples:

1. **As written** (P1). A sample within the estimators' own tolerances is handed on unchanged (the estimator
   normalises a quaternion itself and uses such a matrix as given).
2. **Normalised** (P2). A sample off by more than that but by at most the file tolerance

   .. math::  τ_q = \min(\max(10^{-2},\; 10^{1-s}),\; 0.05), \qquad τ_R = \min(\max(10^{-2},\; 3·10^{1-s}),\; 0.05)
      \tag{P2}

   is taken as the rotation it approximates: a quaternion is divided by its norm, a matrix replaced by the nearest
   rotation (:func:`omegahat.so3.project`). ``s`` is the number of significant digits the file's attitude fields
   carry (the most found in the first lines, :func:`significant_digits`; binary formats: none known, ``τ = 10⁻²``):
   rounding each component to ``s`` digits moves it by at most ``½·10^{1-s}``, so ``|‖q‖ − 1|`` by at most
   ``10^{1-s}`` (four components) and ``‖RᵀR − I‖_F`` by at most ``2·‖ΔR‖_F ≤ 3·10^{1-s}``; below 3 digits rounding
   alone exceeds ``10⁻²``. The tolerance never exceeds :data:`CAP` (half of :data:`PLAIN`): a file of short,
   exact numbers (``0,0,0,1``) counts as one digit, and no such count makes ``|q| = 2`` a rotation. The samples
   normalised are counted, and the stream's notes (printed by ``omegahat estimate`` in its summary) say how many,
   the largest deviation and where.
3. **Not a rotation.** Beyond ``τ`` a sample is handed on unchanged, so that the estimator's check decides with the
   caller's tolerances (``--quat-norm-tol``, ``--rotation-tol``) and ``--skip-bad-samples`` still works on a stray
   sample. But when more than half of the first :data:`HEAD` valid samples are **plainly** no rotation —
   ``|‖q‖ − 1| > 0.1`` (``|q| = 0.5`` or ``2``), ``‖RᵀR − I‖_F > 0.1``, or a reflection (``det R < 0``) — the columns
   read are not an attitude: :class:`~omegahat.io.LogFormatError` names the first such sample and the columns read,
   and prints the ``--columns`` line that read them, to be corrected.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable

import numpy as np

from omegahat.io.columns import LogFormatError

__all__ = ["CAP", "FLOOR", "HEAD", "PLAIN", "Normaliser", "file_tolerance", "significant_digits"]

FLOOR = 1e-2  #: (P2) the file tolerance is never below this: interpolated exports differ from unit by ~1e-3
PLAIN = 0.1  #: (3) deviation beyond which a sample is plainly no rotation
CAP = PLAIN / 2  #: (P2) the file tolerance never exceeds this, whatever the digits
HEAD = 1000  #: (3) valid samples from the start on which "more than half plainly no rotation" is judged
# a decimal comma too; the fraction's digits only after its separator: with both runs optional, a long field that
# is no number took time quadratic in its length to refuse (the regex tried every split of its digits)
_NUMBER = re.compile(r"\s*[-+]?(\d*)(?:[.,](\d*))?(?:[eE][-+]?\d+)?\s*")


def significant_digits(fields: Iterable[str]) -> int | None:
    """The most significant digits among the number fields ``fields`` (``"0.12340"``: 5, ``"-1.2e-03"``: 2;
    leading zeros do not count, trailing ones do); None if no field is a non-zero number."""
    best = None
    for f in fields:
        m = _NUMBER.fullmatch(f)
        if not m:
            continue
        digits = (m.group(1) + (m.group(2) or "")).lstrip("0")
        if digits:
            best = max(best or 0, len(digits))
    return best


def file_tolerance(kind: str, digits: int | None) -> tuple[float, float]:
    """``(rounding bound, τ)`` of (P2) for ``kind`` ``"quaternion"`` or ``"matrix"`` written with ``digits``
    significant digits (None: not known, the rounding bound 0)."""
    rounding = 0.0 if digits is None else (3.0 if kind == "matrix" else 1.0) * 10.0 ** (1 - digits)
    return rounding, min(max(FLOOR, rounding), CAP)


def _deviation(kind: str, data: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per sample: ``|‖q‖ − 1|`` or ``‖RᵀR − I‖_F`` (NaN for missing samples), and whether it is a reflection."""
    if kind == "quaternion":
        return np.abs(np.linalg.norm(data, axis=1) - 1.0), np.zeros(len(data), dtype=bool)
    gram = np.einsum("tki,tkj->tij", data, data) - np.eye(3)
    dev = np.sqrt(np.einsum("tij,tij->t", gram, gram))
    reflection = np.zeros(len(data), dtype=bool)
    ok = np.isfinite(dev)
    reflection[ok] = np.linalg.det(data[ok]) < 0.0
    return dev, reflection


class Normaliser:
    """(P1)–(3) on the consecutive chunks of one stream (module docstring). ``where(label, column)`` names a sample
    (:meth:`omegahat.io.registry.LogStream.where`), ``columns`` the attitude's columns, ``hint`` the ``--columns``
    line that read them (empty if none applies), ``label`` the word for a row's place."""

    def __init__(self, kind: str, digits: int | None, where: Callable[..., str], columns: str, hint: str, label: str):
        from omegahat.measurements import QUAT_NORM_TOL, ROTATION_TOL  # the estimators' own tolerances (P1)

        self.kind, self.digits, self.where, self.columns, self.hint, self.label = (
            kind,
            digits,
            where,
            columns,
            hint,
            label,
        )
        self.active = kind in ("quaternion", "matrix")
        self.as_is = QUAT_NORM_TOL if kind == "quaternion" else ROTATION_TOL
        self.rounding, self.tol = file_tolerance(kind, digits) if self.active else (0.0, 0.0)
        self.count, self.largest, self.at = 0, 0.0, 0
        self.head_valid, self.head_plain = 0, 0
        self.first_plain: tuple[int, float, bool] = (0, 0.0, False)  # (label, deviation, reflection) of the first

    def feed(self, data: np.ndarray, labels: np.ndarray) -> np.ndarray:
        """The chunk's attitudes with (P2) applied (a copy where anything changed); raises (3)."""
        if not self.active or len(data) == 0:
            return data
        dev, reflection = _deviation(self.kind, data)
        valid = np.isfinite(dev)
        if self.head_valid < HEAD:
            self._judge_head(dev, reflection, valid, labels)
        fix = np.flatnonzero(valid & (dev > self.as_is) & (dev <= self.tol) & ~reflection)
        if not fix.size:
            return data
        out = data.copy()
        if self.kind == "quaternion":
            out[fix] /= np.linalg.norm(out[fix], axis=1)[:, None]
        else:
            from omegahat.so3 import project  # compiled: loaded only for files that need it

            out[fix] = project(out[fix])
        k = int(fix[np.argmax(dev[fix])])
        if dev[k] > self.largest:
            self.largest, self.at = float(dev[k]), int(labels[k])
        self.count += fix.size
        return out

    def _judge_head(self, dev, reflection, valid, labels) -> None:
        idx = np.flatnonzero(valid)[: HEAD - self.head_valid]
        plain = (dev[idx] > PLAIN) | reflection[idx]
        if not self.head_plain and plain.any():
            k = int(idx[np.argmax(plain)])
            self.first_plain = (int(labels[k]), float(dev[k]), bool(reflection[k]))
        self.head_valid += idx.size
        self.head_plain += int(plain.sum())
        if self.head_valid >= HEAD:
            self.check_head()

    def check_head(self) -> None:
        """Raise (3) if more than half of the valid samples seen so far (at most :data:`HEAD`) are plainly no
        rotation; called at each chunk and once at the end of the stream."""
        if not self.head_plain or 2 * self.head_plain <= self.head_valid:
            return
        label, dev, reflection = self.first_plain
        if reflection:
            what = "a reflection (det R < 0), not a rotation"
        elif self.kind == "quaternion":
            what = f"a quaternion far from unit norm (|‖q‖ − 1| = {dev:.3g})"
        else:
            what = f"not a rotation matrix (‖RᵀR − I‖ = {dev:.3g})"
        fix = f"; the columns read: {self.hint} — correct it to name the attitude's columns" if self.hint else ""
        raise LogFormatError(
            f"{self.where(label, self.columns)}: {what}, and so are {self.head_plain} of the first {self.head_valid} "
            f"samples: these columns do not hold a rotation{fix} (or the right --scalar-first/--scalar-last)"
        )

    def notes(self) -> list[str]:
        """What (P2) changed, for the stream's notes (empty when nothing was)."""
        if not self.count:
            return []
        what = "quaternion(s) normalised" if self.kind == "quaternion" else "matrices projected onto SO(3)"
        size = "|‖q‖ − 1|" if self.kind == "quaternion" else "‖RᵀR − I‖"
        digits = (
            f"; the file's {self.digits} significant digits explain up to {self.rounding:.2g}" if self.digits else ""
        )
        return [
            f"{self.count} {what}: {size} above the estimators' {self.as_is:g} (largest {self.largest:.3g}, "
            f"{self.label} {self.at}), within the file tolerance {self.tol:.2g}{digits} (omegahat.io.precision)"
        ]
