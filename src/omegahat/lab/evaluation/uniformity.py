r"""Is the convergence rate uniform in the initial error? Continuous observers side by side on the same draws.

The paper's claim is *uniform* global exponential convergence: one pair ``(c, λ)`` with
``|ω̂(t) − ω(t)| ≤ c |ω̂₀ − ω₀| e^{−λ t}`` for every initial condition. The observers it positions itself against
are, by its account, globally convergent but not uniformly (Salcudean 1991), uniformly asymptotic but not
exponential (Akella–Thakur–Mazenc 2015), or exponential through switching (Berkane–Abdessameud–Tayebi 2016).
This module measures the property itself, for any continuous-time observer written as a right-hand side, on the
initial conditions of a Monte-Carlo campaign (:mod:`omegahat.lab.campaigns`).

**The same draws for every observer.** Run ``j`` of a campaign is drawn once by
:func:`omegahat.lab.campaigns.draws.draw_runs` (attitude R₀, rate ω₀, the observer's initial filter states r̂_i0, its
initial estimate ω̂₀, the sinusoidal torque); every observer is started from that run's R₀, ω₀, ω̂₀ and r̂_i0 (an
observer without filter states ignores them) and driven by the same true motion. Each result row carries the
draw it was started from, so that the report can show it is the same for every observer.

**Coupled integration.** The truth ``(R, ω)`` — ``Ṙ = R ω×``, ``J ω̇ = (Jω) × ω + τ`` — and the observer's own
state x are integrated together by ``scipy.integrate.solve_ivp`` (Radau: the observers' filter gains make the
system stiff), R carried as its nine entries (its drift from SO(3) stays at the solver's tolerance; the observer
is fed the measured rows ``r_i = Rᵀ v_i`` as they are). A run whose estimate exceeds ``blowup`` rad/s stops there
and counts as diverged.

**What is scored**, with ``ε`` the tolerance (default 1e-3 rad/s) and ``e(t) = |ω̂(t) − ω(t)|`` on the output
grid::

    t_ε   = the time after which e stays ≤ ε          ((S1) of :mod:`omegahat.lab.evaluation.metrics`)      (U1)
    λ_run = ln(e(0) / ε) / t_ε                         the run's mean exponential rate down to ε        (U2)

A uniform bound ``e(t) ≤ c e(0) e^{−λt}`` gives ``t_ε ≤ ln(c e(0)/ε)/λ``, so ``λ_run ≥ λ (1 − ln c / ln(c e(0)/ε))``:
with a uniform exponential observer, λ_run stays bounded away from 0 as e(0) grows and t_ε grows only like
ln e(0). An observer whose rate degrades with the initial error shows λ_run falling and t_ε growing faster than
ln e(0) from one bin of e(0) to the next (:func:`bin_table`). *Counterexamples* (:func:`counterexamples`): runs
that never reach ε and stay there before the horizon (or diverge), and runs whose λ_run is below a stated floor.
For the Sarras observer the rows also say whether the proof's Lyapunov function
``V = |J z| + ½ Σ |e_i|²`` (:func:`omegahat.observer.continuous.lyapunov`) ever increased between output
samples (by more than ``1e-6`` relative, while V is above ``1e-8`` of its initial value: below, the solver's
rounding moves it): with gains inside the theorem's conditions it must not.

**Observers available.** ``sarras``: the observer of :mod:`omegahat.observer.continuous` (the corrected output
map) with a campaign gain set; ``sarras-printed``: the same with the output map as printed in the paper, which the
erratum shows not to converge — a known-bad observer that the report must flag.

**Sampled peers** (issue 26): the published gyro-free filters are discrete-time; they run on the same draws and the
same true motion, sampled (:mod:`omegahat.lab.evaluation.peer_uniformity`: ``min-energy``, ``predictive``,
``sunline-sekf``, each with its one knob tuned once per campaign by the comparison's rule), scored by (U1)–(U2) on
the same output grid.

Salcudean's, Akella–Thakur–Mazenc's and Berkane–Abdessameud–Tayebi's observers are **not** implemented: their
equations could not be obtained from the public record available to this project (``docs/related_observers.md``
says what was searched); any observer with the :class:`ContinuousObserver` interface can be added to the comparison.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from omegahat import so3
from omegahat.lab.campaigns.config import Campaign
from omegahat.lab.campaigns.draws import draw_runs
from omegahat.lab.evaluation import peer_uniformity as PU
from omegahat.lab.evaluation.metrics import convergence_time
from omegahat.observer import continuous as cont
from omegahat.observer.gains import ObserverGains
from omegahat.simulation.torque import Torque
from omegahat.validation import as_inertia

__all__ = [
    "DEFAULT_EDGES",
    "OBSERVERS",
    "ContinuousObserver",
    "CoupledRun",
    "SarrasObserver",
    "UniformityRow",
    "bin_table",
    "counterexamples",
    "markdown",
    "run_rate",
    "run_uniformity",
    "same_draws",
    "simulate_coupled",
    "v_increased",
]

DEFAULT_EDGES = (0.0, 1.0, 3.0, 10.0, 30.0, 101.0)  #: bins of the initial error |ω̂₀ − ω₀| (rad/s)


class ContinuousObserver(Protocol):
    """A continuous-time observer of ω driven by the attitude R and the known torque τ.

    ``initial_state(R0, omega_hat0, r_hat0)`` gives its state x₀ such that its estimate is ``omega_hat0``;
    ``rhs(x, R, tau)`` is ẋ; ``estimate(x, R)`` is ω̂. ``lyapunov(x, R, omega)`` is its proof's Lyapunov
    function, or None when it has none to check.
    """

    name: str

    def initial_state(self, R0: np.ndarray, omega_hat0: np.ndarray, r_hat0: np.ndarray) -> np.ndarray: ...

    def rhs(self, x: np.ndarray, R: np.ndarray, tau: np.ndarray) -> np.ndarray: ...

    def estimate(self, x: np.ndarray, R: np.ndarray) -> np.ndarray: ...

    def lyapunov(self, x: np.ndarray, R: np.ndarray, omega: np.ndarray) -> float | None: ...


class SarrasObserver:
    """Sarras' observer (:mod:`omegahat.observer.continuous`): state ``x = (ξ, r̂_1, …, r̂_n)``, measurements the
    rows ``r_i = Rᵀ v_i``. ``sign`` +1 is the corrected output map, −1 the paper's printed one."""

    def __init__(
        self,
        J: np.ndarray,
        gains: ObserverGains,
        references: np.ndarray,
        sign: float = cont.OUTPUT_SIGN_CORRECTED,
        name: str = "sarras",
    ) -> None:
        self.J = as_inertia(J)
        self.J_inv = np.linalg.inv(self.J)
        self.gains = gains
        self.references = np.asarray(references, dtype=float)
        if self.references.shape != (gains.n, 3):
            raise ValueError(f"{gains.n} gains were given for references of shape {self.references.shape}")
        self.sign = float(sign)
        self.name = name

    def _split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return x[:3], x[3:].reshape(self.gains.n, 3)

    def _rows(self, R: np.ndarray) -> np.ndarray:
        return self.references @ R  # r_i = Rᵀ v_i as rows

    def initial_state(self, R0: np.ndarray, omega_hat0: np.ndarray, r_hat0: np.ndarray) -> np.ndarray:
        r_hat0 = np.asarray(r_hat0, dtype=float).reshape(self.gains.n, 3)
        xi0 = cont.xi_for_omega_hat(omega_hat0, self._rows(R0), r_hat0, self.gains.k, self.J_inv, self.sign)
        return np.concatenate([xi0, r_hat0.ravel()])

    def rhs(self, x: np.ndarray, R: np.ndarray, tau: np.ndarray) -> np.ndarray:
        xi, r_hat = self._split(x)
        g = self.gains
        xi_dot, r_hat_dot = cont.observer_rhs(
            xi, r_hat, self._rows(R), tau, self.J, self.J_inv, g.k, g.l_offset, g.l_slope, self.sign
        )
        return np.concatenate([xi_dot, r_hat_dot.ravel()])

    def estimate(self, x: np.ndarray, R: np.ndarray) -> np.ndarray:
        xi, r_hat = self._split(x)
        return cont.output_map(xi, self._rows(R), r_hat, self.gains.k, self.J_inv, self.sign)

    def lyapunov(self, x: np.ndarray, R: np.ndarray, omega: np.ndarray) -> float | None:
        _, r_hat = self._split(x)
        z = self.estimate(x, R) - omega
        return float(cont.lyapunov(z, r_hat - self._rows(R), self.J))


#: name -> builder from (campaign, gains name): the observers this module can compare
OBSERVERS: dict[str, Callable[[Campaign, str], ContinuousObserver]] = {
    "sarras": lambda c, g: SarrasObserver(c.J, c.gains[g], c.references),
    "sarras-printed": lambda c, g: SarrasObserver(
        c.J, c.gains[g], c.references, cont.OUTPUT_SIGN_PRINTED, name="sarras-printed"
    ),
}


@dataclass(frozen=True)
class CoupledRun:
    """Samples at ``t (T,)`` of the truth ``omega (T, 3)``, ``R (T, 3, 3)`` and the estimate ``omega_hat (T, 3)``
    (rows after a divergence are inf), the Lyapunov function ``V (T,)`` (NaN where the observer has none) and
    ``diverged``."""

    t: np.ndarray
    omega: np.ndarray
    R: np.ndarray
    omega_hat: np.ndarray
    V: np.ndarray
    diverged: bool


def simulate_coupled(
    J: np.ndarray,
    observer: ContinuousObserver,
    R0: np.ndarray,
    omega0: np.ndarray,
    x0: np.ndarray,
    t_out: np.ndarray,
    torque: Torque | None = None,
    *,
    rtol: float = 1e-9,
    atol: float = 1e-11,
    blowup: float = 1e6,
) -> CoupledRun:
    """Integrate the body and ``observer`` together (module docstring) and sample at ``t_out``."""
    J = as_inertia(J)
    J_inv = np.linalg.inv(J)
    torque = Torque.none() if torque is None else torque
    t_out = np.asarray(t_out, dtype=float)
    m = np.asarray(x0).size

    def f(t, y):
        R = y[:9].reshape(3, 3)
        w = y[9:12]
        tau = np.asarray(torque(t, R, w), dtype=float)
        # [ω]× written out, not so3.hat: hat stacks arrays for batches, slow on one vector, and this right-hand
        # side runs tens of thousands of times per run
        R_dot = R @ np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        w_dot = J_inv @ (so3.cross(J @ w, w) + tau)
        return np.concatenate([R_dot.ravel(), w_dot, observer.rhs(y[12:], R, tau)])

    def blown(t, y):  # stops the run once the estimate has left any plausible range
        return blowup - float(np.linalg.norm(observer.estimate(y[12:], y[:9].reshape(3, 3))))

    blown.terminal = True  # type: ignore[attr-defined]
    y0 = np.concatenate([np.asarray(R0, float).ravel(), np.asarray(omega0, float), np.asarray(x0, float)])
    sol = solve_ivp(f, (t_out[0], t_out[-1]), y0, method="Radau", t_eval=t_out, rtol=rtol, atol=atol, events=blown)
    T, got = t_out.size, sol.t.size
    Y = np.full((T, 12 + m), np.nan)
    Y[:got] = sol.y.T
    R = Y[:, :9].reshape(T, 3, 3)
    omega = Y[:, 9:12]
    omega_hat = np.full((T, 3), np.inf)
    V = np.full(T, np.nan)
    for k in range(got):
        omega_hat[k] = observer.estimate(Y[k, 12:], R[k])
        v = observer.lyapunov(Y[k, 12:], R[k], omega[k])
        V[k] = np.nan if v is None else v
    if got < T:  # the truth after a stop is not needed: the estimate is scored as diverged (inf) there
        omega[got:] = omega[got - 1] if got else np.asarray(omega0, float)
    return CoupledRun(sol.t if got == T else t_out, omega, R, omega_hat, V, got < T or sol.status < 0)


def run_rate(t: np.ndarray, err: np.ndarray, tol: float) -> tuple[float, float]:
    """``(t_ε, λ_run)`` of (U1)–(U2) for errors ``err`` at times ``t``: ``(inf, 0)`` if the error never stays
    below ``tol``, ``(t[0], inf)`` if it starts there."""
    if not tol > 0:
        raise ValueError(f"the tolerance must be positive; got {tol!r}")
    t_tol = convergence_time(t, err, tol)
    if math.isinf(t_tol):
        return math.inf, 0.0
    dt = t_tol - float(t[0])
    return t_tol, (math.inf if dt <= 0 else math.log(max(float(err[0]), tol) / tol) / dt)


@dataclass(frozen=True)
class UniformityRow:
    """One run of one observer: the draw it started from (``index``, ``omega0``, ``omega_hat0``, ``q0`` the
    initial attitude as a quaternion x, y, z, w), ``err0 = |ω̂₀ − ω₀|``, (U1) ``t_tol``, (U2) ``rate``, the error
    at the horizon, whether it diverged and whether V increased (None: no Lyapunov function)."""

    observer: str
    index: int
    omega0: tuple[float, float, float]
    omega_hat0: tuple[float, float, float]
    q0: tuple[float, float, float, float]
    err0: float
    t_tol: float
    rate: float
    final_err: float
    diverged: bool
    v_increased: bool | None


def _tuple(v) -> tuple:
    return tuple(float(x) for x in np.asarray(v).ravel())


def run_uniformity(
    campaign: Campaign,
    observers: Sequence[str] = ("sarras",),
    *,
    gains: str | None = None,
    runs: int | None = None,
    horizon: float | None = None,
    dt_out: float | None = None,
    tol: float = 1e-3,
    rtol: float = 1e-9,
    progress: Callable[[int, int], None] | None = None,
) -> list[UniformityRow]:
    """Runs ``0 … runs−1`` of ``campaign`` (default its own runs, horizon and output step) for each observer in
    ``observers`` (names of :data:`OBSERVERS` and of :data:`SAMPLED`), every observer from the same draws;
    ``gains`` names the campaign's gain set (default its first)."""
    unknown = [o for o in observers if o not in OBSERVERS and o not in PU.SAMPLED]
    if unknown:
        raise ValueError(f"unknown observer(s) {unknown}; available: {sorted([*OBSERVERS, *PU.SAMPLED])}")
    gains = next(iter(campaign.gains)) if gains is None else gains
    if gains not in campaign.gains:
        raise ValueError(f"the campaign has no gain set {gains!r}; it has {sorted(campaign.gains)}")
    runs = campaign.runs if runs is None else int(runs)
    horizon = campaign.horizon if horizon is None else float(horizon)
    dt_out = campaign.dt_out if dt_out is None else float(dt_out)
    t_out = np.linspace(0.0, horizon, round(horizon / dt_out) + 1)
    draws = draw_runs(campaign, np.arange(runs))  # drawn once: every observer gets the same numbers
    built = [OBSERVERS[o](campaign, gains) if o in OBSERVERS else PU.tuned(campaign, o, horizon) for o in observers]
    rows = []
    for j in range(runs):
        torque = PU.draw_torque(draws, j)
        R0, w0, wh0 = draws["R0"][j], draws["omega0"][j], draws["omega_hat0"][j]
        q0 = Rotation.from_matrix(R0).as_quat()
        for obs in built:
            if isinstance(obs, PU.TunedPeer):
                err, restarts = PU.errors(campaign, obs, R0, w0, wh0, t_out, torque)
                diverged, v_inc = restarts > 0, None
            else:
                x0 = obs.initial_state(R0, wh0, draws["r_hat0"][j])
                run = simulate_coupled(campaign.J, obs, R0, w0, x0, t_out, torque, rtol=rtol, atol=rtol * 1e-2)
                err = np.linalg.norm(run.omega_hat - run.omega, axis=1)
                err = np.where(np.isfinite(err), err, np.inf)
                diverged, v_inc = run.diverged, None if np.all(np.isnan(run.V)) else v_increased(run.V)
            t_tol, rate = run_rate(t_out, err, tol)
            rows.append(
                UniformityRow(
                    obs.name, j, _tuple(w0), _tuple(wh0), _tuple(q0), float(err[0]), t_tol, rate, float(err[-1]),
                    diverged, v_inc,
                )
            )  # fmt: skip
        if progress is not None:
            progress(j + 1, runs)
    return rows


def v_increased(V: np.ndarray, rel: float = 1e-6, floor: float = 1e-8) -> bool:
    """True when ``V`` rises between consecutive samples by more than ``rel`` of its value, counting only samples
    above ``floor`` times its initial value (below that the integrator's rounding, not the observer, moves it)."""
    V = np.asarray(V, dtype=float)
    live = V[:-1] > floor * V[0]
    return bool(np.any(live & (np.diff(V) > rel * V[:-1])))


def bin_table(rows: Sequence[UniformityRow], edges: Sequence[float] = DEFAULT_EDGES) -> list[dict]:
    """Per observer and bin ``[edges[b], edges[b+1])`` of ``err0``: runs, converged (t_ε finite), the median and
    worst t_ε over the converged, the worst (smallest) λ_run over all runs of the bin (0 if one never
    converged)."""
    e = np.asarray(edges, dtype=float)
    if e.ndim != 1 or e.size < 2 or not np.all(np.diff(e) > 0):
        raise ValueError(f"bin edges must be at least two increasing numbers; got {list(edges)!r}")
    out = []
    for name in dict.fromkeys(r.observer for r in rows):
        mine = [r for r in rows if r.observer == name]
        for lo, hi in itertools.pairwise(e):
            b = [r for r in mine if lo <= r.err0 < hi]
            conv = [r.t_tol for r in b if math.isfinite(r.t_tol)]
            out.append(
                {
                    "observer": name, "lo": float(lo), "hi": float(hi), "runs": len(b), "converged": len(conv),
                    "median_t_tol": float(np.median(conv)) if conv else math.nan,
                    "worst_t_tol": (max(conv) if len(conv) == len(b) else math.inf) if b else math.nan,
                    "worst_rate": min(r.rate for r in b) if b else math.nan,
                }
            )  # fmt: skip
    return out


def counterexamples(rows: Sequence[UniformityRow], rate_floor: float = 0.0) -> list[UniformityRow]:
    """Runs that did not converge to ε (t_ε infinite, diverged included), whose λ_run is below ``rate_floor``,
    or whose Lyapunov function increased."""
    return [r for r in rows if not math.isfinite(r.t_tol) or r.rate < rate_floor or r.v_increased]


def _fmt(x: float, spec: str = ".3g") -> str:
    return "—" if math.isnan(x) else ("never" if math.isinf(x) and x > 0 else format(x, spec))


def markdown(rows: Sequence[UniformityRow], edges: Sequence[float] = DEFAULT_EDGES, rate_floor: float = 0.0) -> str:
    """The bin table, the per-observer worst rate and the counterexamples as Markdown."""
    lines = [
        "| observer | initial error (rad/s) | runs | converged | median t_ε (s) | worst t_ε (s) | worst λ_run (1/s) |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for b in bin_table(rows, edges):
        if b["runs"]:
            lines.append(
                f"| {b['observer']} | [{b['lo']:g}, {b['hi']:g}) | {b['runs']} | {b['converged']} | "
                f"{_fmt(b['median_t_tol'])} | {_fmt(b['worst_t_tol'])} | {_fmt(b['worst_rate'])} |"
            )
    lines.append("")
    for name in dict.fromkeys(r.observer for r in rows):
        mine = [r for r in rows if r.observer == name]
        bad = counterexamples(mine, rate_floor)
        v = [r for r in mine if r.v_increased]
        worst = min(mine, key=lambda r: r.rate)
        lines.append(
            f"* **{name}**: {len(mine)} runs; worst λ_run {_fmt(worst.rate)} /s (run {worst.index}, initial error "
            f"{worst.err0:.3g} rad/s); {len(bad)} counterexample(s)"
            + (f" (runs {', '.join(str(r.index) for r in bad[:12])}{', …' if len(bad) > 12 else ''})" if bad else "")
            + ("" if mine[0].v_increased is None else f"; V increased in {len(v)} run(s)")
            + "."
        )
    return "\n".join(lines) + "\n"


def same_draws(rows: Sequence[UniformityRow]) -> bool:
    """True when every observer's row for run j starts from the same ω₀, ω̂₀ and attitude."""
    by_index: dict[int, list[UniformityRow]] = {}
    for r in rows:
        by_index.setdefault(r.index, []).append(r)
    return all(len({(r.omega0, r.omega_hat0, r.q0) for r in group}) == 1 for group in by_index.values())
