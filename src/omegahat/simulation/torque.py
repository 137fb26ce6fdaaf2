r"""The torque acting on a body (body axes, N·m), one type for every simulator of the project.

A :class:`Torque` says explicitly what it depends on:

* ``Torque.none()`` — τ = 0 (torque-free motion);
* ``Torque.constant(tau)`` — a constant;
* ``Torque.sinusoidal(constant, amplitudes, frequencies, phases)`` —
  ``τ(t) = c + Σ_j a_j ∘ sin(ν_j t + φ_j)`` (amplitudes and phases ``(M, 3)``, frequencies ``(M,)`` rad/s), given
  as data, so that the compiled engine (:mod:`omegahat.simulation.engine`) evaluates it itself;
* ``Torque.of_time(f)`` — ``τ = f(t)``, and ``Torque.of_state(f)`` — ``τ = f(t, R, ω)``, any Python functions
  (the rigid-body integrator :func:`omegahat.simulation.rigid_body.integrate` accepts them; the engine cannot).

Calling one always takes ``(t, R, omega)`` and returns a checked ``(3,)`` array (``(T, 3)`` for an array of times
when the torque depends on time only). The observer knows the torque exactly (``docs/theory/observer.md`` assumes a
known torque).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from omegahat.validation import as_vector3

__all__ = ["Torque", "as_torque"]

_KINDS = ("none", "constant", "sinusoidal", "time", "state")


@dataclass(frozen=True)
class Torque:
    """A known body torque (body axes, N·m) that says what it depends on; build it with the class methods.

    :meth:`none`, :meth:`constant` and :meth:`sinusoidal` give a torque as data, which the compiled engine
    evaluates itself (``is_data``; ``bound`` is then an upper bound of ``|τ(t)|``); :meth:`of_time` and
    :meth:`of_state` wrap Python functions, which only :func:`omegahat.simulation.rigid_body.integrate` accepts.
    Calling one, ``torque(t, R=None, omega=None)``, returns a checked ``(3,)`` array (``(T, 3)`` for an array of
    times when the torque is data). Frozen; the fields are checked and converted on construction.

    Parameters
    ----------
    kind : str, optional
        One of ``"none"`` (default), ``"constant"``, ``"sinusoidal"``, ``"time"``, ``"state"``.
    constant_term : array_like, optional
        The constant ``c`` of ``τ(t) = c + Σ_j a_j ∘ sin(ν_j t + φ_j)``, 3 numbers (default zero).
    amplitudes : array_like, optional
        The amplitudes ``a_j``, ``(M, 3)`` (default none).
    frequencies : array_like, optional
        The frequencies ``ν_j`` (rad/s), ``(M,)``.
    phases : array_like, optional
        The phases ``φ_j`` (rad), broadcast to ``(M, 3)``.
    func : callable, optional
        ``f(t)`` for kind ``"time"``, ``f(t, R, omega)`` for kind ``"state"`` (R body→inertial ``(3, 3)``, omega
        body rate ``(3,)``); it must return 3 finite numbers.

    Raises
    ------
    ValueError
        If ``kind`` is unknown, or the amplitudes, frequencies or phases are not finite or do not match.
    TypeError
        If a kind ``"time"`` or ``"state"`` torque has no callable.

    Examples
    --------
    >>> import numpy as np
    >>> from omegahat import Torque
    >>> tau = Torque.sinusoidal(constant=[0.0, 0.0, 0.1], amplitudes=[[0.2, 0.0, 0.0]], frequencies=[np.pi])
    >>> print(tau, tau.is_data, f"{tau.bound:.3f}")
    Torque.sinusoidal(constant=[0.0, 0.0, 0.1], 1 terms) True 0.224
    >>> print(tau(np.array([0.0, 0.5])).round(3).tolist())
    [[0.0, 0.0, 0.1], [0.2, 0.0, 0.1]]
    >>> decaying = Torque.of_time(lambda t: [0.0, 0.0, np.exp(-t)])
    >>> print(decaying.kind, decaying.is_data, decaying(0.0).tolist())
    time False [0.0, 0.0, 1.0]
    >>> print(Torque.constant([0.0, 0.0, 1.0]), Torque.none())
    Torque.constant([0.0, 0.0, 1.0]) Torque.none()
    """

    kind: str = "none"
    constant_term: np.ndarray = field(default_factory=lambda: np.zeros(3))
    amplitudes: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    frequencies: np.ndarray = field(default_factory=lambda: np.zeros(0))
    phases: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    func: Callable | None = None

    def __post_init__(self):
        if self.kind not in _KINDS:
            raise ValueError(f"torque kind must be one of {_KINDS}; got {self.kind!r}")
        c = as_vector3(self.constant_term, "torque constant")
        a = np.asarray(self.amplitudes, dtype=float).reshape(-1, 3)
        m = a.shape[0]
        f = np.asarray(self.frequencies, dtype=float).reshape(m)
        p = np.broadcast_to(np.asarray(self.phases, dtype=float), (m, 3)).copy()
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(f)) and np.all(np.isfinite(p))):
            raise ValueError("torque amplitudes, frequencies and phases must be finite")
        if self.kind in ("time", "state") and not callable(self.func):
            raise TypeError(f"a torque of kind {self.kind!r} needs a callable; got {self.func!r}")
        for name, value in (("constant_term", c), ("amplitudes", a), ("frequencies", f), ("phases", p)):
            object.__setattr__(self, name, value)

    @classmethod
    def none(cls) -> Torque:
        """τ = 0 (torque-free motion)."""
        return cls("none")

    @classmethod
    def constant(cls, tau: ArrayLike) -> Torque:
        """A constant body torque."""
        return cls("constant", constant_term=as_vector3(tau, "torque"))

    @classmethod
    def sinusoidal(
        cls,
        constant: ArrayLike = (0.0, 0.0, 0.0),
        amplitudes: ArrayLike = (),
        frequencies: ArrayLike = (),
        phases: ArrayLike = (),
    ) -> Torque:
        """``τ(t) = constant + Σ_j amplitudes[j] ∘ sin(frequencies[j] t + phases[j])``; amplitudes and phases
        ``(M, 3)`` (phases broadcast), frequencies ``(M,)`` in rad/s."""
        a = np.asarray(amplitudes, dtype=float).reshape(-1, 3)
        p = np.zeros((a.shape[0], 3)) if np.size(phases) == 0 else np.asarray(phases, dtype=float)
        c, f = np.asarray(constant, dtype=float), np.asarray(frequencies, dtype=float)  # as __post_init__ would
        return cls("sinusoidal", constant_term=c, amplitudes=a, frequencies=f, phases=p)

    @classmethod
    def of_time(cls, func: Callable) -> Torque:
        """τ = func(t)."""
        if not callable(func):
            raise TypeError(f"Torque.of_time needs a callable f(t); got {func!r}")
        return cls("time", func=func)

    @classmethod
    def of_state(cls, func: Callable) -> Torque:
        """τ = func(t, R, omega) (R body→inertial ``(3, 3)``, omega body rate ``(3,)``)."""
        if not callable(func):
            raise TypeError(f"Torque.of_state needs a callable f(t, R, omega); got {func!r}")
        return cls("state", func=func)

    @property
    def depends_on_state(self) -> bool:
        return self.kind == "state"

    @property
    def is_data(self) -> bool:
        """True when the compiled engine can evaluate it (none, constant, sinusoidal)."""
        return self.kind in ("none", "constant", "sinusoidal")

    @property
    def bound(self) -> float:
        """An upper bound of ``|τ(t)|`` over all t (data kinds only)."""
        self._require_data("bound")
        return float(np.linalg.norm(np.abs(self.constant_term) + np.abs(self.amplitudes).sum(axis=0)))

    def _require_data(self, what: str) -> None:
        if not self.is_data:
            raise TypeError(
                f"{what} needs a torque given as data (Torque.none, .constant or .sinusoidal); this one is a Python "
                f"function of {'time' if self.kind == 'time' else 'time and state'} "
                "(omegahat.simulation.rigid_body.integrate accepts those)"
            )

    def sinusoid(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(constant (3,), amplitudes (M, 3), frequencies (M,), phases (M, 3))`` for the compiled engine."""
        self._require_data("the compiled engine")
        return self.constant_term, self.amplitudes, self.frequencies, self.phases

    def __call__(self, t: float | np.ndarray, R: ArrayLike | None = None, omega: ArrayLike | None = None) -> np.ndarray:
        if self.is_data:
            t = np.asarray(t, dtype=float)
            terms = self.amplitudes * np.sin(self.frequencies[:, None] * t[..., None, None] + self.phases)
            return self.constant_term + terms.sum(axis=-2)
        func: Callable = self.func  # type: ignore[assignment]  # "time" and "state" carry one (__post_init__)
        raw = func(t) if self.kind == "time" else func(t, R, omega)
        tau = np.asarray(raw, dtype=float)
        if tau.shape != (3,) or not np.all(np.isfinite(tau)):
            raise ValueError(f"the torque function must return 3 finite numbers; at t = {float(t)} it returned {raw!r}")
        return tau

    def __repr__(self) -> str:
        if self.kind == "none":
            return "Torque.none()"
        if self.kind == "constant":
            return f"Torque.constant({self.constant_term.tolist()})"
        if self.kind == "sinusoidal":
            return f"Torque.sinusoidal(constant={self.constant_term.tolist()}, {self.frequencies.size} terms)"
        return f"Torque.{'of_time' if self.kind == 'time' else 'of_state'}({self.func!r})"


def as_torque(torque: Torque | ArrayLike | None) -> Torque:
    """None → no torque, a 3-vector → constant, a :class:`Torque` → itself. A bare function is refused."""
    if torque is None:
        return Torque.none()
    if isinstance(torque, Torque):
        return torque
    if callable(torque):
        raise TypeError(
            "a torque function must say what it depends on: wrap it as Torque.of_time(f) for f(t) "
            "or Torque.of_state(f) for f(t, R, omega)"
        )
    return Torque.constant(torque)
