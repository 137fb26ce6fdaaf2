r"""What ``omegahat calibrate`` finds, applied to a gyroscope log, written and read as JSON.

The record of :func:`omegahat.calibration.calibrate` (the fit and its equations are there and in ``docs/calibrate.md``):
the fitted model ``g(t + δ) = A ω(t) + b`` (C1) with each parameter's standard deviation, applied as
``ω(t) = A⁻¹ (g(t + δ) − b)`` (C3).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field, fields

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["CONVENTION", "Calibration"]

CONVENTION = (
    "gyro(t + offset) = matrix @ omega_body(t) + bias; omega_body(t) = inv(matrix) @ (gyro(t + offset) - bias); "
    "offset: gyro clock - attitude clock, s; rotation: gyro <- body; rotation_std: rad about the gyro axes"
)


@dataclass(frozen=True)
class Calibration:
    """The fitted (C1): ``offset`` δ (s, gyro clock − attitude clock), ``matrix`` A (gyro ← body, gyro units per
    rad/s), its ``rotation`` R_c (the nearest rotation for a general A) and ``scale`` (per gyro axis; a general A:
    its rows' norms), ``bias`` b (gyro units), each with its standard deviation (``rotation_std``: the rotation
    vector φ of ``Exp(φ) R_c``, rad, gyro axes; ``matrix_std`` for a general A only); ``residual_rms`` per axis (in
    band, gyro units), ``n_samples`` fitted, ``cutoff_hz``, the two ``rates_hz`` (attitude, gyro), ``excitation``
    (principal standard deviations of the band-limited rate, rad/s) and the ``covariance`` of the parameters
    (``parameters`` names them). ``free_axis`` (gyro axes, unit) where the body turned about one axis only: the
    rotation about it is not identified (the covariance has no part along it, so neither has ``rotation_std``: the
    unknown turn is not in it), and ``rotation`` is the least rotation that takes the body's axis onto it
    (:func:`omegahat.calibration.calibrate`)."""

    mode: str
    offset: float
    offset_std: float
    matrix: np.ndarray
    rotation: np.ndarray
    rotation_std: np.ndarray
    bias: np.ndarray
    bias_std: np.ndarray
    scale: np.ndarray
    scale_std: np.ndarray | None
    matrix_std: np.ndarray | None
    residual_rms: np.ndarray
    n_samples: int
    cutoff_hz: float
    rates_hz: tuple[float, float]
    excitation: np.ndarray
    covariance: np.ndarray = field(repr=False)
    parameters: tuple[str, ...] = field(repr=False, default=())
    notes: tuple[str, ...] = ()
    free_axis: np.ndarray | None = None

    def apply(self, t_gyro: ArrayLike, gyro: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(C3): the gyroscope's samples as body rates on the attitude's clock: ``(t − δ, A⁻¹(g − b))``."""
        t = np.asarray(t_gyro, dtype=float)
        g = np.asarray(gyro, dtype=float)
        if g.ndim != 2 or g.shape[1] != 3 or g.shape[0] != t.size:
            raise ValueError(f"gyro must have shape ({t.size}, 3) like its times; got {g.shape}")
        return t - self.offset, np.linalg.solve(self.matrix, (g - self.bias).T).T

    def axis_map(self) -> str:
        """Which body axis each gyro axis reads (``gx = +by, ...``) when A is close to a signed permutation."""
        words = []
        for i, row in enumerate(self.matrix):
            j = int(np.argmax(np.abs(row)))
            if abs(row[j]) < 0.9 * np.linalg.norm(row):
                return "no single body axis per gyro axis"
            words.append(f"g{'xyz'[i]} = {'+' if row[j] > 0 else '-'}b{'xyz'[j]}")
        return ", ".join(words)

    def to_dict(self) -> dict:
        """JSON-ready: every field (arrays as lists; seconds, radians, gyro units) and the convention (C1)."""
        d: dict = {"convention": CONVENTION}
        for f in fields(self):
            v = getattr(self, f.name)
            d[f.name] = v.tolist() if isinstance(v, np.ndarray) else list(v) if isinstance(v, tuple) else v
        return d

    def to_json(self) -> str:
        """:meth:`to_dict` as JSON text, what :meth:`save` writes and :meth:`load` reads."""
        return json.dumps(self.to_dict(), indent=1) + "\n"

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write :meth:`to_json`."""
        with open(path, "w", encoding="utf-8") as f:
            f.write(self.to_json())

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Calibration:
        """Read what :meth:`save` wrote."""
        with open(path, encoding="utf-8") as f:
            d = json.load(f)
        try:  # a file written before free_axis was a field has none: its rotation was identified whole
            values = {f.name: d[f.name] for f in fields(cls) if f.name != "free_axis" or f.name in d}
        except KeyError as exc:
            raise ValueError(f"{path}: not a calibration written by omegahat calibrate (no {exc})") from None
        for k, v in values.items():
            if isinstance(v, list):
                values[k] = tuple(v) if k in ("rates_hz", "parameters", "notes") else np.array(v, dtype=float)
        return cls(**values)
