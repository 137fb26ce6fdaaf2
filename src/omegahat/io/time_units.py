"""Time units: the unit names the readers take (``--time-unit``), the unit a time column's name states, and the
unit a log's own times reveal when they cannot be seconds.

**Plausible times** (:func:`plausible`): a first time of at most :data:`PLAUSIBLE_SECONDS` (3,000 years, in any
origin) and samples :data:`PLAUSIBLE_RATES_HZ` apart. Epoch stamps show their unit by their size: 2026 is
1.8e9 s, 1.8e12 ms, 1.8e15 µs or 1.8e18 ns since 1970, and a sample rate then tells the units apart.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from omegahat.io.columns import LogFormatError, time_unit_in_name

__all__ = [
    "PLAUSIBLE_RATES_HZ",
    "PLAUSIBLE_SECONDS",
    "POSSIBLE_RATES_HZ",
    "TIME_UNITS",
    "magnitude_note",
    "named_unit_note",
    "plausible",
    "time_unit_in_name",
    "unit_by_magnitude",
    "unit_stated",
    "whole_times",
]

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}  #: seconds per unit
PLAUSIBLE_SECONDS = 1e11  #: no log's time (s from any origin) is larger: 3,000 years
PLAUSIBLE_RATES_HZ = (0.5, 5000.0)  #: the sample rates of the logs omegahat reads
#: no log is estimated outside these rates (Hz): beyond them the spacing is not the time unit's (a column that is
#: not a time, or a unit off by many orders) and the model's noise powers (h to the fifth) leave floating point
POSSIBLE_RATES_HZ = (1e-9, 1e12)


def named_unit_note(named: str, column: str, given: str) -> str:
    """What was done where the time column's name states a unit other than ``--time-unit``'s (default s)."""
    if given == "s":
        return f"time unit: {named}, as the time column's name says ({column!r}; converted to s)"
    return f"the time column's name says {named} ({column!r}); read in {given}, as --time-unit says"


def plausible(t0: float, h: float) -> bool:
    """Whether a log whose first time is ``t0`` s and whose samples are ``h`` s apart is plausible (module
    docstring)."""
    return abs(t0) <= PLAUSIBLE_SECONDS and h > 0 and PLAUSIBLE_RATES_HZ[0] <= 1.0 / h <= PLAUSIBLE_RATES_HZ[1]


def implausible_spacing(
    h: float, t0: float, unit: str, reading: str, remedy: Callable[[str], str], rows: str = "samples"
) -> str | None:
    """The words for ``rows`` ``h`` s apart (first time ``t0``, read in ``unit`` as ``reading`` says: "with
    --time-unit s") where that is implausible (:func:`plausible`), with ``remedy(u)`` for the first other unit ``u``
    in which it would not be ("pass --time-unit ms", "name its time column time_ms"); None where it is plausible.
    Beyond :data:`POSSIBLE_RATES_HZ` the same words are an error (no estimate is made of such a log)."""
    if plausible(t0, h):
        return None
    scale = TIME_UNITS[unit]
    fits = [u for u, f in TIME_UNITS.items() if u != unit and plausible(t0 / scale * f, h / scale * f)]
    tip = "".join(f"; if the times are in {u}, {remedy(u)} ({scale / (h * TIME_UNITS[u]):.4g} Hz)" for u in fits[:1])
    said = f"{rows} are {h:.4g} s apart ({1.0 / h:.4g} Hz) {reading}{tip}"
    low, high = POSSIBLE_RATES_HZ
    if not low <= 1.0 / h <= high:
        raise ValueError(f"{said}; no log is estimated at less than {low:g} Hz or more than {high:g} Hz")
    return said


def unit_by_magnitude(t0: float, h: float) -> str | None:
    """The unit in which times whose first is ``t0`` and whose samples are ``h`` apart (both as written) are
    plausible, when seconds are not because ``t0`` is too large and exactly one unit is (``1.7e18`` stamps 1e7
    apart: ns, 100 Hz); else None."""
    if abs(t0) <= PLAUSIBLE_SECONDS:
        return None
    fits = [u for u, f in TIME_UNITS.items() if plausible(t0 * f, h * f)]
    return fits[0] if len(fits) == 1 else None


def magnitude_note(unit: str, t0: float, h: float) -> str:
    """The note of a unit found by :func:`unit_by_magnitude` (first time ``t0``, spacing ``h``, as written)."""
    f = TIME_UNITS[unit]
    return (
        f"time unit: {unit}, by the times themselves ({t0:.4g} cannot be seconds; in {unit} they are {t0 * f:.4g} s "
        f"since their origin, samples {h * f:.4g} s apart; another unit: --time-unit)"
    )


def unit_stated(column: str, given: str, head: ArrayLike) -> tuple[str | None, str | None]:
    """The unit a time ``column`` is read in where the log states it, and the note that says so: the unit its name
    states (``timestamp_ns``) where ``given`` (``--time-unit``) is s, its default; else, for a name that states none,
    the unit its first times ``head`` (as written; NaN where unknown) fit by their first value and median spacing
    (:func:`unit_by_magnitude`). ``(None, note or None)`` where ``given`` applies."""
    named = time_unit_in_name(column)
    if named is not None:
        if named == given:
            return None, None
        return (named if given == "s" else None), named_unit_note(named, column, given)
    times = np.asarray(head, dtype=float)
    times = times[np.isfinite(times)]
    if given != "s" or times.size < 2:
        return None, None
    t0, h = float(times[0]), float(np.median(np.diff(times)))
    found = unit_by_magnitude(t0, h) if h > 0 else None
    return (None, None) if found in (None, "s") else (found, magnitude_note(found, t0, h))


def whole_times(values: ArrayLike, where: Callable[[int], str]) -> np.ndarray:
    """Integer times (no missing one) as int64, exactly (as floats, epoch nanoseconds would be off by up to 256 ns);
    a value beyond int64 (a uint64 past 2^63) is an error, ``where(k)`` naming its row ``k``."""
    raw = np.asarray(values)
    if raw.dtype.kind == "u" and raw.size and raw.max() > np.iinfo(np.int64).max:
        k = int(np.argmax(raw > np.iinfo(np.int64).max))
        raise LogFormatError(f"{where(k)}: time {int(raw[k])} beyond what int64 holds")
    return raw.astype(np.int64)
