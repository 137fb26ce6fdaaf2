r"""What to estimate a stream with, and how messages name the options: shared by the loop and the estimators' pickers.

:class:`EstimateSettings` says what to estimate with; :class:`Choice` is what a picker
(:func:`omegahat.io.choice.attitude_choice`, :func:`omegahat.io.single_direction.single_direction_choice`, one per
kind of stream) hands the loop (:func:`omegahat.io.pipeline.estimate_stream`): the estimator and what to say about
it.

**Options in messages.** The loop and the pickers know options by their keys only (the field names of
:class:`EstimateSettings` and :class:`~omegahat.io.registry.ReadOptions`: ``rotation_tol``, ``skip_bad_samples``,
...). Each message names them through a :data:`Spelling`, ``spell(key, value)``, that the caller passes:
:func:`omegahat.measurements.python_option` (``rotation_tol=0.02``, the default, :func:`omegahat.estimate_frame`'s
spelling) or the command's flags (``--rotation-tol 0.02``, :mod:`omegahat.cli.estimate`). An error that a setting
would solve also carries the ``(key, suggested value)`` pairs it names, as its ``options`` attribute
(:func:`naming`), so that a caller can act on them without reading the text.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, TypeAlias, TypeVar, get_args

import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat.interface import Estimate, Estimator, one_of
from omegahat.observer.presets import PRESETS, Preset

if TYPE_CHECKING:
    from omegahat.io.registry import LogChunk
    from omegahat.observer.gains import ObserverGains

__all__ = [
    "ESTIMATORS",
    "PRESETS",
    "STARTS",
    "Choice",
    "EstimateSettings",
    "EstimatorName",
    "Preset",
    "Spelling",
    "Start",
    "naming",
]

#: how the estimate starts: a least-squares rate over the first window, from the first two samples, or from rest
Start: TypeAlias = Literal["fit", "warm", "zero"]
#: auto: omegahat when the inertia is given (and no gains), else sarras
EstimatorName: TypeAlias = Literal["auto", "omegahat", "sarras"]
STARTS: tuple[str, ...] = get_args(Start)
ESTIMATORS: tuple[str, ...] = get_args(EstimatorName)

#: ``spell(key, value)``: an option as the caller writes it in a message (value None: the option alone)
Spelling: TypeAlias = Callable[[str, object], str]

_E = TypeVar("_E", bound=BaseException)


def naming(exc: _E, *options: tuple[str, object]) -> _E:
    """``exc`` carrying the ``(option key, suggested value)`` pairs its message names (``exc.options``)."""
    exc.options = options  # type: ignore[attr-defined]
    return exc


@dataclass(frozen=True)
class EstimateSettings:
    """What to estimate with: ``inertia`` (3×3, 3 or 9 numbers; default identity: a locally constant rate),
    ``references`` (inertial directions ``(n, 3)``; required for direction input, default the three rows of R),
    ``gains`` or ``bandwidth_hz`` (default: chosen from the log), ``start`` (``fit``, ``warm`` or ``zero``),
    ``estimator`` (``auto``: the default estimator — the observer supervising a gyro-less EKF — when the inertia is
    given and no gains or bandwidth are, else the fixed-gain observer; or ``omegahat`` / ``sarras`` to choose),
    ``skip_bad_samples`` and the tolerances of :mod:`omegahat.measurements`; ``preset`` and ``smooth``
    (:mod:`omegahat.observer.presets`). Combinations are checked by :meth:`check`, which names the options as the
    caller spells them."""

    inertia: ArrayLike | None = None
    references: np.ndarray | Sequence[ArrayLike] | None = None
    gains: ObserverGains | None = None
    bandwidth_hz: float | None = None
    start: Start = "fit"
    estimator: EstimatorName = "auto"
    skip_bad_samples: bool = False
    rotation_tol: float = ms.ROTATION_TOL
    quat_norm_tol: float = ms.QUAT_NORM_TOL
    preset: Preset | None = None
    smooth: bool = False

    def __post_init__(self) -> None:
        one_of("start", self.start, Start)
        one_of("estimator", self.estimator, EstimatorName)
        if self.preset is not None:
            one_of("preset", self.preset, Preset)
        if self.gains is not None:  # an int or a dict failed deep in the gain check (AttributeError: no 'k')
            from omegahat.observer import gains as observer_gains

            if not isinstance(self.gains, observer_gains.ObserverGains):
                raise TypeError(
                    f"gains must be an ObserverGains (omegahat.observer.gains; e.g. from sensor_gains), not "
                    f"{type(self.gains).__name__}; or give bandwidth_hz"
                )

    def check(self, spell: Spelling = ms.python_option) -> None:
        """Refuse combinations that cannot run (``ValueError`` naming the options with ``spell``)."""
        if self.smooth and (self.estimator == "sarras" or self.gains is not None or self.bandwidth_hz is not None):
            given = [spell("estimator", "sarras")] if self.estimator == "sarras" else []
            given += [
                spell(k, None) for k, v in (("gains", self.gains), ("bandwidth_hz", self.bandwidth_hz)) if v is not None
            ]
            raise naming(
                ValueError(
                    f"{spell('smooth', True)} smooths with the model identified from the log (or the preset's); it "
                    f"takes no fixed gains: drop {', '.join(given)}"
                ),
                ("smooth", None),
            )
        if self.preset is not None:
            given = [
                k
                for k, v in (("inertia", self.inertia), ("bandwidth_hz", self.bandwidth_hz), ("gains", self.gains))
                if v is not None
            ] + (["estimator"] if self.estimator != "auto" else [])
            if given:
                raise naming(
                    ValueError(
                        f"{spell('preset', self.preset)} chooses the model and gains itself (inertia and torque "
                        f"unknown); drop {', '.join(spell(k, None) for k in given)} or the preset"
                    ),
                    *((k, None) for k in given),
                )


@dataclass
class Choice:
    """The estimator a picker chose for a stream: ``estimator`` (streaming, or batch: the loop then reads the whole
    stream first), the ``gains`` and the line saying why (``gains_text``); ``used()`` the closing line saying what
    ran (called after the run); ``spacing`` the median sample spacing (s; None: the loop takes the first chunk's),
    gaps being intervals longer than twice it; ``after_chunk(chunk, estimate)`` a hook the loop calls after each
    chunk (the one-direction observer's excitation report), and ``closing()`` the estimator's own closing lines."""

    estimator: Estimator
    gains: ObserverGains | None
    gains_text: str
    used: Callable[[], str]
    spacing: float | None = None
    after_chunk: Callable[[LogChunk, Estimate], None] | None = None
    closing: Callable[[], list[str]] = field(default=list)
