r"""What defines a Monte-Carlo campaign (:class:`Campaign`), and its TOML file (``examples/campaign.toml``).

Two equal campaigns give the same numbers: every run draws from its own seed (:mod:`omegahat.lab.campaigns.draws`).
The TOML file has the sections ``[campaign]`` (runs, seed, chunk size, horizon, output step, tolerances and the
envelope's thresholds), ``[body]`` (J, references, omega_max), ``[initial]`` (the initial-condition ranges),
``[torque]`` (terms, amplitude, frequency range) and one ``[gains.NAME]`` table per gain set (``kind`` =
"theorem", "constant" or "affine"); errors name the file, the section, the key and the value.

A campaign holds every run's results in memory (the error ratio E(t)/E(0) at every output time, per gain set:
:attr:`Campaign.result_bytes`); one that would hold more than :data:`MAX_RESULT_BYTES` is refused when it is made,
before any run, with the limit in the message.
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from omegahat.observer.gains import ObserverGains, theorem_gains
from omegahat.validation import as_directions, as_inertia

__all__ = [
    "MAX_RESULT_BYTES",
    "Campaign",
    "campaign_from_dict",
    "campaign_from_toml",
    "load_campaign",
    "replace",
    "run_seed",
]

#: bytes of results a campaign may hold (4 GiB; merging the chunks' results briefly needs about twice as much)
MAX_RESULT_BYTES = 4 << 30


@dataclass(frozen=True)
class Campaign:
    """Everything that defines a campaign (:mod:`omegahat.lab.campaigns`: what each run draws, the envelope, the
    counterexamples); two equal campaigns give the same numbers."""

    J: np.ndarray
    omega_max: float
    gains: dict  # name -> ObserverGains
    references: np.ndarray = field(default_factory=lambda: np.eye(3)[:2])
    runs: int = 1000
    seed: int = 0
    chunk_size: int = 256
    horizon: float = 20.0
    dt_out: float = 0.05
    rtol: float = 1e-6
    atol: float = 1e-15
    h_max: float = 0.05
    max_steps: int = 2_000_000
    omega0_fraction: float = 0.6
    r_hat_radius: float = 10.0
    p_zero: float = 0.05
    p_opposite: float = 0.05
    omega_hat_max: float = 100.0
    torque_terms: int = 2
    torque_amplitude: float = 0.3
    torque_frequency: tuple = (0.5, 5.0)
    rho_floor: float = 1e-8
    converged_below: float = 1e-6
    v_increase_tol: float = 1e-6

    def __post_init__(self):
        object.__setattr__(self, "J", as_inertia(self.J))
        object.__setattr__(self, "references", as_directions(self.references))
        for name, g in self.gains.items():
            if not isinstance(g, ObserverGains):
                raise TypeError(f"gains[{name!r}] must be an ObserverGains; got {type(g).__name__}")
            if g.n != self.references.shape[0]:
                raise ValueError(
                    f"gains[{name!r}] are for {g.n} directions, the campaign has {self.references.shape[0]}"
                )
        if not self.gains:
            raise ValueError("a campaign needs at least one gain set")
        for attr in _RANGES:
            _check_number(attr, attr, "Campaign", getattr(self, attr), attr in _INTEGER)
        lo, hi = self.torque_frequency
        if not 0 < lo <= hi < math.inf:
            raise ValueError(f"Campaign: torque_frequency must be (low, high) with 0 < low <= high; got {(lo, hi)!r}")
        if self.p_zero + self.p_opposite > 1:
            raise ValueError(f"Campaign: p_zero + p_opposite must not exceed 1; got {self.p_zero} + {self.p_opposite}")
        if self.result_bytes > MAX_RESULT_BYTES:
            times = self.horizon / self.dt_out + 1
            raise ValueError(
                f"Campaign: {self.runs:,} runs x {len(self.gains)} gain sets would hold {self.result_bytes:.3g} bytes "
                f"of results ({times:.4g} output times per run and gain set); omegahat holds at most "
                f"{MAX_RESULT_BYTES:.3g} bytes ({MAX_RESULT_BYTES >> 30} GiB): fewer runs, a larger dt_out, or several "
                "campaigns with different seeds"
            )

    @property
    def result_bytes(self) -> float:
        """Bytes of results the campaign holds: per run and gain set, E(t)/E(0) at every output time and a dozen
        numbers (:class:`omegahat.lab.campaigns.diagnostics.GainSetResult`)."""
        return float(self.runs) * len(self.gains) * 8.0 * (self.horizon / self.dt_out + 1 + _RESULT_SCALARS)

    @property
    def t_out(self) -> np.ndarray:
        count = round(self.horizon / self.dt_out)
        return np.linspace(0.0, count * self.dt_out, count + 1)


def run_seed(seed: int, index: int) -> np.random.SeedSequence:
    """The seed sequence of run ``index``: equal to ``SeedSequence(seed).spawn(index + 1)[index]``."""
    return np.random.SeedSequence(seed, spawn_key=(int(index),))


_SECTIONS = {
    "campaign": {
        "runs": "runs",
        "seed": "seed",
        "chunk_size": "chunk_size",
        "horizon": "horizon",
        "dt_out": "dt_out",
        "rtol": "rtol",
        "atol": "atol",
        "h_max": "h_max",
        "max_steps": "max_steps",
        "rho_floor": "rho_floor",
        "converged_below": "converged_below",
        "v_increase_tol": "v_increase_tol",
    },
    "body": {"J": "J", "references": "references", "omega_max": "omega_max"},
    "initial": {
        "omega0_fraction": "omega0_fraction",
        "r_hat_radius": "r_hat_radius",
        "p_zero": "p_zero",
        "p_opposite": "p_opposite",
        "omega_hat_max": "omega_hat_max",
    },
    "torque": {"terms": "torque_terms", "amplitude": "torque_amplitude", "frequency": "torque_frequency"},
}
_RESULT_SCALARS = 11  # per run, at most 8 bytes each: the other fields of GainSetResult (index, flags, rates, steps)
_INTEGER = {"runs", "seed", "chunk_size", "max_steps", "torque_terms"}
# (lower, lower inclusive, upper, upper inclusive) for scalar settings
_RANGES = {
    "runs": (1, True, math.inf, False),
    "seed": (0, True, math.inf, False),
    "chunk_size": (1, True, math.inf, False),
    "max_steps": (1, True, math.inf, False),
    "horizon": (0, False, math.inf, False),
    "dt_out": (0, False, math.inf, False),
    "rtol": (0, False, 1, False),
    "atol": (0, False, math.inf, False),
    "h_max": (0, False, math.inf, False),
    "rho_floor": (0, False, 1, False),
    "converged_below": (0, False, 1, False),
    "v_increase_tol": (0, True, math.inf, False),
    "omega_max": (0, False, math.inf, False),
    "omega0_fraction": (0, True, 1, True),
    "r_hat_radius": (0, True, math.inf, False),
    "p_zero": (0, True, 1, True),
    "p_opposite": (0, True, 1, True),
    "omega_hat_max": (0, True, math.inf, False),
    "torque_terms": (0, True, math.inf, False),
    "torque_amplitude": (0, True, math.inf, False),
}
_GAIN_KEYS = {
    "theorem": {"kind", "margin", "l0"},
    "constant": {"kind", "k", "l"},
    "affine": {"kind", "k", "l_offset", "l_slope"},
}


def _check_number(key: str, attr: str, where: str, value, integer: bool) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{where}: {key} must be a number; got {value!r}")
    if integer and not isinstance(value, int):
        raise ValueError(f"{where}: {key} must be an integer; got {value!r}")
    lo, lo_in, hi, hi_in = _RANGES.get(attr, (-math.inf, False, math.inf, False))
    ok = math.isfinite(value) and (value >= lo if lo_in else value > lo) and (value <= hi if hi_in else value < hi)
    if not ok:
        lo_s = ("[" if lo_in else "(") + f"{lo:g}"
        hi_s = f"{hi:g}" + ("]" if hi_in else ")")
        raise ValueError(f"{where}: {key} = {value!r} is out of range {lo_s}, {hi_s}")
    return value


def _gains_from_table(name: str, table: dict, J, omega_max, references) -> ObserverGains:
    where = f"[gains.{name}]"
    if not isinstance(table, dict):
        raise ValueError(f"{where} must be a table; got {table!r}")
    kind = table.get("kind")
    if kind not in _GAIN_KEYS:
        raise ValueError(f"{where}: kind must be one of {sorted(_GAIN_KEYS)}; got {kind!r}")
    unknown = set(table) - _GAIN_KEYS[kind]
    if unknown:
        raise ValueError(
            f"{where}: unknown key(s) {sorted(unknown)} for kind {kind!r}; allowed: {sorted(_GAIN_KEYS[kind])}"
        )
    try:
        if kind == "theorem":
            return theorem_gains(J, omega_max, references, margin=table.get("margin", 1.0), l0=table.get("l0", 1.0))
        n = references.shape[0]
        if kind == "constant":
            return ObserverGains.constant(table["k"], table["l"], n=n)
        k = np.broadcast_to(np.asarray(table["k"], dtype=float), (n,)).copy()
        return ObserverGains(k=k, l_offset=table["l_offset"], l_slope=table.get("l_slope", 0.0))
    except KeyError as exc:
        raise ValueError(f"{where}: missing key {exc.args[0]!r}") from None
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{where}: {exc}") from None


def campaign_from_dict(config: dict, source: str = "config") -> Campaign:
    """Build a :class:`Campaign` from a parsed TOML document; errors name the section, key and value."""
    unknown = set(config) - set(_SECTIONS) - {"gains"}
    if unknown:
        raise ValueError(f"{source}: unknown section(s) {sorted(unknown)}; allowed: {[*_SECTIONS, 'gains']}")
    kwargs: dict[str, Any] = {}
    for section, keys in _SECTIONS.items():
        table = config.get(section, {})
        if not isinstance(table, dict):
            raise ValueError(f"{source}: [{section}] must be a table; got {table!r}")
        bad = set(table) - set(keys)
        if bad:
            raise ValueError(f"{source}: unknown key(s) {sorted(bad)} in [{section}]; allowed: {sorted(keys)}")
        for key, value in table.items():
            attr = keys[key]
            where = f"{source} [{section}]"
            if attr in ("J", "references"):
                try:
                    kwargs[attr] = as_inertia(value, "J") if attr == "J" else as_directions(value)
                except (ValueError, TypeError) as exc:
                    raise ValueError(f"{where}: {key} = {value!r}: {exc}") from None
            elif attr == "torque_frequency":
                if (
                    not isinstance(value, list)
                    or len(value) != 2
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
                    or not 0 < value[0] <= value[1]
                    or not math.isfinite(value[1])
                ):
                    raise ValueError(f"{where}: frequency must be [low, high] with 0 < low <= high; got {value!r}")
                kwargs[attr] = (float(value[0]), float(value[1]))
            else:
                num = _check_number(key, attr, where, value, attr in _INTEGER)
                kwargs[attr] = num if attr in _INTEGER else float(num)
    if "omega_max" not in kwargs:
        raise ValueError(f"{source}: [body] omega_max is required (the bound |omega| <= omega_M of the theorem)")
    if kwargs.get("p_zero", 0.05) + kwargs.get("p_opposite", 0.05) > 1:
        raise ValueError(
            f"{source} [initial]: p_zero + p_opposite must not exceed 1; got "
            f"{kwargs.get('p_zero', 0.05)} + {kwargs.get('p_opposite', 0.05)}"
        )
    J = kwargs.setdefault("J", np.diag([3.0, 2.0, 1.0]))
    refs = kwargs.setdefault("references", np.eye(3)[:2])
    gains_table = config.get("gains")
    if not isinstance(gains_table, dict) or not gains_table:
        raise ValueError(
            f'{source}: at least one [gains.NAME] table is required (kind = "theorem", "constant" or "affine")'
        )
    kwargs["gains"] = {
        name: _gains_from_table(name, t, J, kwargs["omega_max"], refs) for name, t in gains_table.items()
    }
    return Campaign(**kwargs)


def campaign_from_toml(text: str, source: str = "config") -> Campaign:
    """Parse TOML text; a syntax error is reported with its line and column."""
    try:
        config = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{source}: invalid TOML: {exc}") from None
    return campaign_from_dict(config, source)


def load_campaign(path: str | os.PathLike[str]) -> Campaign:
    """Read a campaign from a TOML file (see ``examples/campaign.toml``)."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{path}: not a TOML file (not UTF-8 text: byte {exc.start} is {exc.object[exc.start]:#04x})"
        ) from None
    return campaign_from_toml(text, str(path))


def replace(campaign: Campaign, **changes: Any) -> Campaign:
    """A copy of ``campaign`` with some settings changed (``dataclasses.replace``)."""
    return dataclasses.replace(campaign, **changes)
