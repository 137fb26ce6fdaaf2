"""Attitudes held between a sensor's updates (omegahat.io.held): a 10 Hz attitude repeated exactly at 100 Hz, as a
republished topic or a table filled forward gives. Read as samples, the repeats made every method swing between
zero and several times the rate; read as missing, the estimate follows the rate the log is built on (a constant
rate, exact: the reference is the rate itself). A log whose attitude never changes, and one with a few repeats
among its changes, are read as before."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from logmaker import constant_rate, read_output, rms, write_csv
from omegahat.cli import main
from omegahat.io.held import HeldSamples
from omegahat.io.registry import LogChunk

OMEGA = np.array([0.3, -0.2, 0.5])


def held_log(tmp_path, every=10, n=1000, rate=100.0):
    """Times at ``rate`` Hz; the attitude of a constant rate, updated at every ``every``-th row and repeated between."""
    t = np.arange(n) / rate
    fresh = constant_rate(t[::every], OMEGA)
    q = fresh.as_quat()[np.arange(n) // every]

    return write_csv(tmp_path / "held.csv", t, Rotation.from_quat(q))


@pytest.mark.parametrize("option", [[], ["--smooth"]])
def test_a_held_attitude_is_read_as_missing_and_the_rate_follows(tmp_path, capsys, option):
    src, out = held_log(tmp_path), tmp_path / "omega.csv"
    assert main(["estimate", str(src), "-o", str(out), "--no-progress", *option]) == 0
    printed = capsys.readouterr().out
    assert "held: 900 samples repeat the previous attitude exactly" in printed and "first at line 3" in printed
    assert "the attitude changed every 0.1 s in the head" in printed
    t, w, status = read_output(out)
    assert t.size == 1000  # every row has its estimate
    fresh = np.arange(1000) % 10 == 0
    assert all(s == "predicted" for s in np.array(status)[~fresh])
    err = rms(w[100:] - OMEGA)
    assert err < 1e-9, err  # 4e-15; read as samples: 2.16 rad/s by default, 2.00 with --smooth (the rate: 0.62)


def test_a_constant_attitude_and_a_few_repeats_are_read_as_before(tmp_path, capsys):
    t = np.arange(400) / 100.0
    still = write_csv(tmp_path / "still.csv", t, constant_rate(t, np.zeros(3)))
    assert main(["estimate", str(still), "-o", str(tmp_path / "o.csv"), "--no-progress"]) == 0
    assert "held:" not in capsys.readouterr().out
    _, w, status = read_output(tmp_path / "o.csv")
    assert np.all(w[1:] == 0.0) and set(status[1:]) == {"corrected"}
    rot = constant_rate(t, OMEGA, sigma=1e-4)
    q = rot.as_quat()
    q[1::3] = q[0::3][: q[1::3].shape[0]]  # a third of the rows repeat their predecessor: fewer than the changes

    few = write_csv(tmp_path / "few.csv", t, Rotation.from_quat(q))
    assert main(["estimate", str(few), "-o", str(tmp_path / "o.csv"), "--no-progress"]) == 0
    assert "held:" not in capsys.readouterr().out
    assert "predicted" not in read_output(tmp_path / "o.csv")[2]


@pytest.mark.parametrize("size", [1, 7, 64, 1000])
def test_the_rows_set_missing_do_not_depend_on_where_the_chunks_are_cut(size):
    rng = np.random.default_rng(3)
    n = 1000
    data = rng.standard_normal((n, 4))
    data[rng.random(n) < 0.7] = np.nan  # placeholders: filled forward below, so most rows repeat one before
    data[0] = 1.0
    for k in range(1, n):
        if np.isnan(data[k, 0]):
            data[k] = data[k - 1]
    data[rng.choice(n, 50, replace=False)] = np.nan  # and some truly missing rows between
    expected = np.zeros(n, bool)  # by hand: a valid row equal to the last valid row before it
    last = None
    for k in range(n):
        if np.all(np.isfinite(data[k])):
            expected[k] = last is not None and np.array_equal(data[k], last)
            last = data[k]
    t = np.arange(n) * 0.01
    chunks = [
        LogChunk(t[a : a + size], data[a : a + size].copy(), None, np.arange(a, min(a + size, n)) + 2)
        for a in range(0, n, size)
    ]
    held = HeldSamples()
    screened = list(held.screen(iter(chunks)))
    got = np.concatenate([c.data for c in screened])
    assert held.active and held.count == expected.sum()
    assert np.array_equal(np.isnan(got[:, 0]), expected | np.isnan(data[:, 0]))
    assert np.array_equal(got[~np.isnan(got[:, 0])], data[~np.isnan(got[:, 0])])  # the rest as read
    assert held.first == int(np.flatnonzero(expected)[0]) + 2
