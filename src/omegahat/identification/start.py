r"""The ``fit`` start of the identified filter: the longest window the noise asks for that the motion allows.

(W) of :func:`noise_window` gives the window ``L_W`` over which the
least-squares rate (F) of :func:`omegahat.observer.autogain.initial_rate` is as accurate as the filter will be: the
better the model, the longer. But (F) fits a line to the attitude, moved to the window's start by half a window of
Euler's equations: exact for a constant rate, first order otherwise. Over a window that long a slewing body's rate
changes, and the filter, told to trust its start to its own expected error, is slow to leave a start that is off.

So the windows of ``n_W 2^{−j}`` samples (``n_W`` those of ``L_W``) are fitted, down to two, and the longest is kept
whose rate agrees with that of every shorter window within their noises (Lepski's rule: a window is given up as soon
as its bias shows against the noise of the shorter ones):

    |ω̂(L_i) − ω̂(L_j)| ≤ κ (s(L_i) + s(L_j))  on each axis, for every j > i,
    s(L) = √(12 σ² h / L³),   κ = 3                                                                    (W')

``s`` the least-squares slope's standard deviation under white attitude noise ``σ`` at the step ``h`` (per axis;
``κ = 3`` its three-sigma band). On a constant rate every window agrees and ``L_W`` is kept; on a noise-free log the
shortest is. The start's own expected error, which the EKF takes as its prior, is the largest of the filter's
expected error, ``κ s(L) √3`` and twice the kept window's disagreement with the next shorter one: a bias below
the shorter windows' noise passes (W') unseen, and a bias growing as ``L^p`` (``p ≥ 1``) at least halves with the
window, so the disagreement is at least half of it. What it gave, measured: ``docs/theory/identification.md``
(step 6 of the decision).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat.observer.autogain import initial_rate

__all__ = ["AGREEMENT", "balanced_start", "noise_window"]

AGREEMENT = 3.0  #: κ of (W'): the windows' rates must agree within this many standard deviations of their noise


def noise_window(expected: float, sigma: float, h: float) -> float:
    """Seconds of log the ``fit`` start fits its rate over as far as the noise goes: the length ``L`` at which the
    least-squares slope's noise (3 axes, ``n = L/h`` samples of attitude noise ``sigma``) equals the filter's
    expected error ``expected`` (rad/s) at the step ``h``::

        3 · 12 σ² h / L³ = e²   ⇒   L = (36 σ² h / e²)^(1/3)                                              (W)

    so that the filter starts about as close as it will stay (a shorter window starts it noisier; a longer one
    averages more of the motion away, which (W') bounds); at least two samples."""
    if not (math.isfinite(expected) and expected > 0.0):
        return 2.0 * h
    return max(math.cbrt(36.0 * sigma**2 * h / expected**2), 2.0 * h)


def balanced_start(
    t: np.ndarray,
    rot: Rotation,
    longest: float,
    sigma: float,
    expected: float,
    J: ArrayLike | None = None,
    torque: ArrayLike | None = None,
) -> tuple[np.ndarray, float, float]:
    """``(ω̂₀, L, e₀)``: the rate (F) over the window of (W') (module docstring), that window (s) and the start's
    expected RMS error (rad/s, three axes), for valid samples ``t``, ``rot``, the window of (W) ``longest``, the
    attitude noise ``sigma`` (rad) and the filter's expected error ``expected`` (rad/s)."""
    t = np.asarray(t, dtype=float)
    h = float(np.median(np.diff(t))) if t.size > 1 else math.inf
    counts = [max(2, int(np.searchsorted(t, t[0] + longest, side="right")))]  # samples in (W)'s window
    while counts[-1] // 2 >= 2:  # halved down to two samples, (F)'s least
        counts.append(counts[-1] // 2)
    # each shorter window ends half a step past its last sample: the same samples whatever the stamps' rounding
    windows = [longest] + [(c - 0.5) * h for c in counts[1:]]
    rates = [initial_rate(t, rot, L, J, torque) for L in windows]
    noise = [math.sqrt(12.0 * sigma**2 * h / ((c - 1) * h) ** 3) for c in counts]
    kept = len(windows) - 1
    for i in range(len(windows)):
        if all(
            np.all(np.abs(rates[i] - rates[j]) <= AGREEMENT * (noise[i] + noise[j])) for j in range(i + 1, len(windows))
        ):
            kept = i
            break
    # what (W') cannot rule out: its band at the kept window, or twice its disagreement with the next shorter one
    # (a bias growing as L^p, p ≥ 1, at least halves with the window: the disagreement is at least half of it)
    step = 2.0 * float(np.linalg.norm(rates[kept] - rates[kept + 1])) if kept + 1 < len(windows) else 0.0
    return rates[kept], windows[kept], max(expected, AGREEMENT * noise[kept] * math.sqrt(3.0), step)
