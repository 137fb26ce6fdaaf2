"""The lockstep engine's data, named: its inputs, its outputs, and the rows of its workspace.

Inputs: :class:`Model` (what all runs of a batch share), :class:`RunSet` (each run's own initial state and torque,
stacked), :class:`StepControl`; :func:`check_inputs` checks their shapes by name before the engine, which does not
check bounds, runs. Outputs: :class:`RunOutputs`, in one of two modes (:data:`STATES`, :data:`ENVELOPES`).

Workspace: every per-lane quantity of :mod:`omegahat.simulation.engine` is a row (or a block of rows) of lanes of
one flat array, row ``r`` of lane ``w`` at ``S[r * lanes + w]``. :func:`workspace_rows` generates the row offsets
from the number of directions n and of torque terms M; the engine's phases call it themselves, so that with n and M
compile-time constants every offset is a constant.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "ENVELOPES",
    "STATES",
    "Model",
    "Rows",
    "RunOutputs",
    "RunSet",
    "StepControl",
    "check_inputs",
    "workspace_rows",
]


class Model(NamedTuple):
    """What every run of a batch shares: the inertia, its inverse, and the observer's gains ``k_i``,
    ``l_i(ω̂) = l_offset_i + l_slope_i |ω̂|`` (``(n,)`` each)."""

    J: np.ndarray
    Jinv: np.ndarray
    k: np.ndarray
    l_offset: np.ndarray
    l_slope: np.ndarray


class RunSet(NamedTuple):
    """Each run's own data, stacked over ``N`` runs: the initial state ``y0 (N, 6n + 6)`` in the layout
    ``[r (3n), ω, z, e (3n)]``, the first step ``h0 (N,)`` and the torque ``c + Σ_j a_j ∘ sin(ν_j t + φ_j)``:
    ``torque_constant (N, 3)``, ``torque_amplitudes (N, M, 3)``, ``torque_frequencies (N, M)``,
    ``torque_phases (N, M, 3)``."""

    y0: np.ndarray
    h0: np.ndarray
    torque_constant: np.ndarray
    torque_amplitudes: np.ndarray
    torque_frequencies: np.ndarray
    torque_phases: np.ndarray


class StepControl(NamedTuple):
    """Step-size control: the mixed tolerance per block, the longest step and the budget of trials per run."""

    rtol: float
    atol: float
    h_max: float
    max_steps: int


STATES = 0  #: output mode: every run's states at the output times
ENVELOPES = 1  #: output mode: each run's envelope diagnostics (:mod:`omegahat.simulation.envelope`)


class RunOutputs(NamedTuple):
    """Where the engine puts what it keeps of each run: ``accepted``, ``rejected``, ``ok`` ``(N,)`` always; in mode
    :data:`STATES` the states ``Y (N, T, 6n + 6)``; in mode :data:`ENVELOPES` the diagnostics ``rho (N, T)`` and
    ``diagnostics (6, N)`` (E0, omega_peak, λ_run, c_run, t_f, v_increase) computed with ``J`` and
    ``rho_floor``. Arrays a mode does not use are empty."""

    accepted: np.ndarray
    rejected: np.ndarray
    ok: np.ndarray
    Y: np.ndarray
    rho: np.ndarray
    diagnostics: np.ndarray
    J: np.ndarray
    rho_floor: float


def check_inputs(model: Model, runs: RunSet, t_out: ArrayLike) -> tuple[Model, RunSet, np.ndarray, int, int]:
    """The engine's inputs checked by name (the compiled engine does not check bounds) and converted to the types
    it is compiled for; returns them with ``n`` and ``M``."""
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    n = int(np.size(model.k))
    N = np.shape(runs.y0)[0] if np.ndim(runs.y0) == 2 else -1
    M = np.shape(runs.torque_frequencies)[1] if np.ndim(runs.torque_frequencies) == 2 else -1
    expected = {
        "J": (model.J, (3, 3)), "Jinv": (model.Jinv, (3, 3)), "k": (model.k, (n,)),
        "l_offset": (model.l_offset, (n,)), "l_slope": (model.l_slope, (n,)), "y0": (runs.y0, (N, 6 * n + 6)),
        "h0": (runs.h0, (N,)), "torque_constant": (runs.torque_constant, (N, 3)),
        "torque_amplitudes": (runs.torque_amplitudes, (N, M, 3)),
        "torque_frequencies": (runs.torque_frequencies, (N, M)), "torque_phases": (runs.torque_phases, (N, M, 3)),
    }  # fmt: skip
    for name, (value, want) in expected.items():
        if N < 0 or M < 0 or np.shape(value) != want:
            raise ValueError(
                f"{name} must have shape {want} (N runs, n = {n} directions, M torque terms); got {np.shape(value)}"
            )
    if np.ndim(t_out) != 1 or np.size(t_out) < 1:
        raise ValueError(f"t_out must be a non-empty 1-D array; got shape {np.shape(t_out)}")
    return Model(*map(f64, model)), RunSet(*map(f64, runs)), f64(t_out), n, M


class Rows(NamedTuple):
    """Row offsets of the workspace (one row per quantity per lane); ``count`` rows in all."""

    y: int  # state
    y_new: int  # the trial's new point
    Nu: int  # rates at (t, y), decay frozen at y
    N_new: int  # rates at the new point with its own decay: the next step's Nu (first same as last)
    Na: int  # rates at the stages
    Nb: int
    Nc: int
    ya: int  # stage points (yb is also yc: y_b is not needed once N(b) is known)
    yb: int
    yc: int
    coef: int  # φ-weights E, E₂, Q, f₁, f₂, f₃ per direction
    lf: int  # decay rates l_i frozen at y
    lf_new: int
    tau: int  # torque at t, t + h/2, t + h: row tau + 3 s + d
    N_fresh: int  # a newly loaded run's first rates, decay and torque, in rows a trial overwrites anyway
    lf_fresh: int
    tau_fresh: int
    tc: int  # the lane's torque: constant, a_j cos φ_j, a_j sin φ_j (row + 3 j + d), ν_j
    acos: int
    asin: int
    freq: int
    sn: int  # sin ν_j t, cos ν_j t, and at t + h
    cs: int
    sn_new: int
    cs_new: int
    sd: int  # sin, cos of ν_j h/2
    cd: int
    hh: int  # the trial's step, h/2, h/6
    half: int
    h6: int
    err: int  # the trial's error ratio
    factor: int  # the next step over this one
    mask: int  # all bits set where the trial was accepted (read through an int64 view)
    t: int  # the lane's time
    t_new: int  # the trial's end
    h: int  # the next trial's step, before h_max and the last step clip it
    last: int  # 1 where the trial ends on the last output time
    acc: int  # accepted and rejected trials of the lane's run (exact in float64)
    rej: int
    next: int  # the lane's next output time (+∞: none)
    flag: int  # 1 where the trial needs the per-lane code: an output time reached, a non-finite error
    count: int  # type: ignore[assignment]  # the field hides the method tuple.count, never used on Rows


@numba.njit(cache=True, inline="always")
def workspace_rows(n, M):
    """:class:`Rows` for n directions and M torque terms. The rows that depend on M come last, so that every other
    offset is a constant as soon as n is (the one-lane engine takes M at run time)."""
    m = 6 * n + 6
    y = 0
    y_new = y + m
    Nu = y_new + m
    N_new = Nu + m
    Na = N_new + m
    Nb = Na + m
    Nc = Nb + m
    ya = Nc + m
    yb = ya + m
    coef = yb + m
    lf = coef + 6 * n
    lf_new = lf + n
    tau = lf_new + n
    tc = tau + 9
    hh = tc + 3  # hh, half, h6, err, factor, mask
    t = hh + 6  # t, t_new, h, last, acc, rej, next, flag
    acos = t + 8
    asin = acos + 3 * M
    freq = asin + 3 * M
    sn = freq + M
    cs = sn + M
    sn_new = cs + M
    cs_new = sn_new + M
    sd = cs_new + M
    cd = sd + M
    return Rows(
        y, y_new, Nu, N_new, Na, Nb, Nc, ya, yb, yb, coef, lf, lf_new, tau, Na, lf_new, tau, tc, acos, asin, freq,
        sn, cs, sn_new, cs_new, sd, cd, hh, hh + 1, hh + 2, hh + 3, hh + 4, hh + 5,
        t, t + 1, t + 2, t + 3, t + 4, t + 5, t + 6, t + 7, cd + M,
    )  # fmt: skip
