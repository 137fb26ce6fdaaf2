"""(W'): the identified filter's ``fit`` start over the longest window the motion allows (Lepski's rule).

References are closed forms: a constant rate, and a turn about a fixed axis ``θ(t) = A sin(2π f t)`` whose rate
``θ̇`` is exact.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.identification.start import balanced_start
from omegahat.observer.autogain import initial_rate

AXIS = np.array([1.0, 2.0, 2.0]) / 3.0


def turn(t: np.ndarray, sigma: float, seed: int = 0) -> tuple[Rotation, float]:
    """The attitude of ``θ(t) = 0.8 sin(2π 0.05 t)`` about :data:`AXIS` under ``sigma`` rad of noise; the rate at 0."""
    theta = 0.8 * np.sin(2 * np.pi * 0.05 * t)
    noise = Rotation.from_rotvec(np.random.default_rng(seed).normal(0.0, sigma, (t.size, 3))) if sigma else None
    rot = Rotation.from_rotvec(np.outer(theta, AXIS))
    return (rot if noise is None else rot * noise), 0.8 * 2 * np.pi * 0.05


def test_a_constant_rate_keeps_the_whole_window_of_the_noise():
    """Every window agrees on a constant rate: the longest, (W)'s, is kept, and the start's error is its noise."""
    t = np.arange(0.0, 20.0, 0.01)
    w = np.array([0.3, -0.2, 0.5])
    rot = Rotation.from_rotvec(np.outer(t, w)) * Rotation.from_rotvec(
        np.random.default_rng(1).normal(0.0, 1e-3, (t.size, 3))
    )
    rate, window, error = balanced_start(t, rot, 8.0, 1e-3, 1e-6)
    assert window == 8.0
    noise = np.sqrt(3 * 12 * 1e-6 * 0.01 / 8.0**3)  # the slope's standard deviation, three axes
    assert np.linalg.norm(rate - w) < 3 * noise and error >= noise


def test_a_turning_body_keeps_a_window_its_motion_allows():
    """A turn whose rate changes within (W)'s window: the kept window is shorter, its start far closer to the true
    rate than the whole window's (measured: 0.31 s, 3.1e-4 against 0.27 rad/s), and no farther than it says
    (6.1e-4: twice its disagreement with the next shorter window; the band of (W') alone said 1.1e-4)."""
    t = np.arange(0.0, 60.0, 0.01)
    rot, w0 = turn(t, 1e-5)
    rate, window, error = balanced_start(t, rot, 40.0, 1e-5, 1e-7)
    whole = np.linalg.norm(initial_rate(t, rot, 40.0) - w0 * AXIS)
    kept = np.linalg.norm(rate - w0 * AXIS)
    assert window < 1.0 and kept < 0.01 * whole
    assert kept <= error


def test_a_noise_free_turn_keeps_the_shortest_window():
    """At the noise floor nothing is noise: any bias shows, and the shortest window of the halvings (4 samples)
    is kept."""
    t = np.arange(0.0, 60.0, 0.01)
    rot, w0 = turn(t, 0.0)
    rate, window, _ = balanced_start(t, rot, 40.0, 1e-9, 1e-9)
    assert window < 0.05 and np.linalg.norm(rate - w0 * AXIS) < 1e-5
