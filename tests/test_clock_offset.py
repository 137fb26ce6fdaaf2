"""The coarse clock offset (:mod:`omegahat.clock_offset`): its correlation against NumPy's, offsets of any size
found without a guess, a gyroscope log that rests most of the time, and the search's size checked before it is built.

The references: :func:`numpy.corrcoef` over each lag's overlap, computed sample by sample, for (O1); the simulated
logs' known offsets for the calibration (``calibration_logs``'s, moved onto other clocks)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibration_logs import euler_motion, simulated, z_scores
from omegahat.calibration import calibrate
from omegahat.clock_offset import MAX_GRID, search_offset


def test_the_correlation_at_each_lag_is_pearsons_over_the_overlap():
    """(O1) at every lag equals ``np.corrcoef`` of the samples both series have there (gaps masked on both sides,
    partial overlaps at the ends), and the lag chosen is the one of (O2)'s largest score."""
    rng = np.random.default_rng(1)
    h, n = 0.01, 400
    t = 5.0 + h * np.arange(n)
    x = np.abs(np.sin(0.7 * t) + 0.3 * np.sin(3.1 * t)) + 0.05 * rng.normal(size=n)
    mx = np.ones(n, bool)
    mx[100:130] = False
    tg = (3.0, 12.0)
    scale, shift = 2.0, 0.5

    def gyro(u):  # the same motion 1.23 s later on the gyro's clock, in other units, with a rest before 6 s
        ok = (u >= tg[0]) & (u <= tg[1]) & ~((u > 8.0) & (u < 8.2))
        v = u - 1.23
        y = np.abs(np.sin(0.7 * v) + 0.3 * np.sin(3.1 * v))
        y = np.where(u < 6.0, 0.1 + 0.01 * np.sin(40 * u), y)
        return scale * y + shift + 0.05 * np.sin(17 * u), ok

    found = search_offset(t, x, mx, gyro, tg, 0.0, None, 50, 30.0)
    assert abs(found.offset - 1.23) < 0.5 * h and not found.at_bound
    lo = tg[0] - t[-1] + 50 * h
    size = n + int(np.floor((tg[1] - t[0] - 50 * h - lo) / h + 1e-9))
    y, my = gyro(t[0] + lo + h * np.arange(size))
    scores = []
    for j in range(size - n + 1):
        both = mx & my[j : j + n]
        r = np.corrcoef(x[both], y[j : j + n][both])[0, 1] if both.sum() >= 50 else np.nan
        scores.append(np.arctanh(r) * np.sqrt(both.sum()) if np.isfinite(r) else -np.inf)
    best = int(np.argmax(scores))
    assert abs(found.offset - (lo + best * h)) <= h  # the parabola moves it by less than a sample
    bounded = search_offset(t, x, mx, gyro, tg, 1.0, 0.1, 50, 30.0)
    assert bounded.at_bound and abs(bounded.offset - 1.1) < 1e-9


@pytest.mark.parametrize("seed", [0, 5])
def test_an_offset_of_any_size_is_found_without_a_guess(seed):
    """The gyroscope on a Unix-epoch clock, 1.7e9 s and 12.3 s ahead, its log 15 minutes long of which the attitude
    log covers 30 s, the body at rest (the gyroscope reads its bias and noise) for the first 10 minutes: the default
    search finds the offset, and the fit's uncertainties cover the truth; a bound around the right guess gives the
    same fit."""
    (ta, Ra, tg, g), truth = simulated(seed)
    _, omega = euler_motion(seed)
    rng = np.random.default_rng(seed)
    epoch = 1.7e9 + 12.3
    before = np.arange(tg[0] - 600.0, tg[0] - 1e-9, 0.005)  # 10 minutes at rest
    after = np.arange(tg[-1] + 0.005, tg[-1] + 300.0, 0.005)  # 5 minutes more of the motion
    rest = truth["b"] + rng.normal(0.0, 0.01, (before.size, 3))
    moving = omega(after - truth["delta"]) @ truth["A"].T + truth["b"] + rng.normal(0.0, 0.01, (after.size, 3))
    t_gyro = np.concatenate([before, tg, after]) + epoch
    gyro = np.concatenate([rest, g, moving])
    cal = calibrate(ta, Ra, t_gyro, gyro)
    truth["delta"] += epoch
    assert abs(cal.offset - truth["delta"]) < 1e-3
    assert np.all(np.abs(z_scores(cal, truth)) < 5)
    assert not any("edge of the search" in n or "repeats itself" in n for n in cal.notes), cal.notes
    narrow = calibrate(ta, Ra, t_gyro, gyro, offset_guess=epoch, max_offset=1.0)
    assert abs(narrow.offset - cal.offset) < 0.5 * cal.offset_std  # float64 keeps 2.4e-7 s at 1.7e9 s


def test_a_search_too_long_to_build_is_refused_before_it_is_built():
    """A gyroscope log whose last stamp lies a year after the others (a broken stamp): searching every overlap would
    need more than ``MAX_GRID`` samples; the error asks for a guess and a bound, and with them the fit runs."""
    (ta, Ra, tg, g), truth = simulated(2)
    tg = np.append(tg, tg[-1] + 3.2e7)
    g = np.vstack([g, g[-1]])
    assert 3.2e7 * 100 > MAX_GRID
    with pytest.raises(ValueError, match=r"more than 20,000,000: give a guess of the offset and a bound"):
        calibrate(ta, Ra, tg, g)
    cal = calibrate(ta, Ra, tg, g, max_offset=2.0)
    assert abs(cal.offset - truth["delta"]) < 1e-3
    assert abs(Rotation.from_matrix(cal.rotation.T @ truth["Rc"]).magnitude()) < 0.01


@pytest.mark.parametrize("guess, bound", [(np.nan, 1.0), (np.inf, 1.0), (0.0, np.nan), (0.0, -1.0), (0.0, 0.0)])
def test_a_guess_or_bound_that_is_not_a_number_of_seconds_is_refused(guess, bound):
    (ta, Ra, tg, g), _ = simulated(1)
    with pytest.raises(ValueError, match="must be a finite number of seconds and its bound a positive one"):
        calibrate(ta, Ra, tg, g, offset_guess=guess, max_offset=bound)
    with pytest.raises(ValueError, match="must be a finite number of seconds and its bound a positive one"):
        calibrate(ta[:3], Ra[:3], tg[:3], g[:3], offset_guess=guess, max_offset=bound)  # too few samples: said first
