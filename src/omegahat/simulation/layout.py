"""The lockstep engine's workspace: one array ``S[row, lane]``, its rows named.

Every per-lane quantity of :mod:`omegahat.simulation.engine` is a row (or a block of rows) of lanes of one
workspace. :func:`workspace_rows` generates the row offsets from the number of directions n and of torque terms M;
the engine's phases call it themselves, so that with n and M compile-time constants every offset is a constant.
"""

from __future__ import annotations

from typing import NamedTuple

import numba

__all__ = ["Rows", "workspace_rows"]


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
    count: int


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
