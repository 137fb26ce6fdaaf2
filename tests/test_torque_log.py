"""Known torques from a log of their own (``--torque FILE``): the interval means (T2) against hand sums and an
independent overlap computation, the same estimate as the torques written in the attitude log, and a spacecraft
whose commanded torques (10 Hz, held) drive it between 2 Hz star-tracker attitudes, integrated by SciPy's
``solve_ivp`` interval by interval (:mod:`spacecraft`): with the torque log the estimate is far closer to the truth
than without."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import spacecraft
from logmaker import noisy, write_csv
from omegahat.cli import main
from omegahat.io import LogFormatError, ReadOptions, open_log
from omegahat.io.torque_log import TorqueLog, attach_torque, read_torque_log
from recording_files import estimate_file

_write_torques = spacecraft.write_torques


def _overlap_means(rows_t, rows_tau, times, last_hold) -> np.ndarray:
    """(T2) by another route: for each attitude interval, the sum over the torque rows of (value × the length of
    the overlap of the row's hold with the interval)."""
    starts = np.asarray(rows_t, dtype=float)
    ends = np.append(starts[1:], starts[-1] + last_hold)
    out = []
    for a, b in pairwise(times):
        overlap = np.clip(np.minimum(ends, b) - np.maximum(starts, a), 0.0, None)
        out.append(overlap @ rows_tau / (b - a))
    j = np.searchsorted(starts, times[-1], side="right") - 1
    return np.vstack([*out, rows_tau[j]])


def test_interval_means_by_hand():
    log = TorqueLog("tau.csv", np.array([0.0, 0.25, 1.0]), np.array([[1.0, 0, 0], [3.0, 0, 0], [5.0, 0, 0]]), ("t",))
    times = np.array([0.0, 0.1, 0.2, 0.3, 0.5])
    np.testing.assert_allclose(log.interval_means(times, None)[:, 0], [1.0, 1.0, 2.0, 3.0, 3.0], rtol=1e-14)
    np.testing.assert_allclose(log.interval_means(times, 1.1)[-1, 0], (0.5 * 3.0 + 0.1 * 5.0) / 0.6, rtol=1e-14)
    assert log.covers(0.0, 1.0 + 0.5) is None  # the last row held one median step (0.5 s)
    assert "must share one clock" in (log.covers(-0.1, 1.0) or "")
    assert "must share one clock" in (log.covers(0.0, 1.6) or "")


def test_a_torque_log_across_chunks_matches_the_overlap_sums(tmp_path):
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.015, 3000))  # an uneven 100 Hz attitude log
    rot = Rotation.from_rotvec(np.outer(t, [0.1, -0.2, 0.3]))
    src = write_csv(tmp_path / "att.csv", t, rot)
    rows_t = np.arange(t[0] - 0.3, t[-1] + 0.02, 0.037)  # 27 Hz commands, on another schedule
    rows_tau = rng.normal(size=(rows_t.size, 3))
    _write_torques(tmp_path / "tau.csv", rows_t, rows_tau)
    stream = open_log(src, ReadOptions(chunk_bytes=1 << 12))  # many chunks: each chunk's last sample looks ahead
    attach_torque(stream, read_torque_log(tmp_path / "tau.csv"))
    chunks = list(stream.chunks())
    assert len(chunks) > 10
    got = np.vstack([c.torque for c in chunks])
    want = _overlap_means(rows_t, rows_tau, t, np.median(np.diff(rows_t)))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_the_same_estimate_as_the_torques_written_in_the_log(tmp_path, capsys):
    t = np.arange(600) / 10.0
    w = np.column_stack([0.02 * np.sin(0.1 * t), 0.01 * np.cos(0.07 * t), 0.015 + 0 * t])
    rot = Rotation.from_rotvec(np.cumsum(w, axis=0) / 10.0)
    rot = noisy(rot, 1e-5)
    rows_t = np.arange(-1.0, 61.0, 0.25)
    rows_tau = np.column_stack([np.sin(rows_t), np.cos(0.5 * rows_t), 0.1 * rows_t]) * 0.01
    _write_torques(tmp_path / "tau.csv", rows_t, rows_tau)
    means = _overlap_means(rows_t, rows_tau, t, 0.25)
    inline = write_csv(tmp_path / "inline.csv", t, rot, means)
    apart = write_csv(tmp_path / "apart.csv", t, rot)
    inertia = ("--inertia", "300", "250", "200")
    want, _ = estimate_file(inline, tmp_path, capsys, *inertia)
    got, printed = estimate_file(apart, tmp_path, capsys, *inertia, "--torque", str(tmp_path / "tau.csv"))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert "torque: " in printed and "averaged over each interval between attitude samples" in printed


def _spacecraft(tmp_path):
    """A spacecraft slewing under torques commanded at 10 Hz (held) for 120 s, its attitude every 0.5 s as a CCSDS
    AEM with 2e-5 rad of noise (:mod:`spacecraft`); the true rates at those samples."""
    command_t, tau = spacecraft.commands(120.0)
    samples = np.arange(0.0, 119.6, 0.5)
    rot, w = spacecraft.slew(samples, command_t, tau)
    spacecraft.write_aem(tmp_path / "sc.aem", samples, noisy(rot, 2e-5))
    spacecraft.write_torques(tmp_path / "cmd.csv", spacecraft.EPOCH_NS * 1e-9 + command_t, tau)
    return w


def test_a_spacecraft_driven_by_its_commanded_torques(tmp_path, capsys):
    w = _spacecraft(tmp_path)
    inertia = ("--inertia", "300", "250", "200")
    late = slice(len(w) // 3, None)
    without, _ = estimate_file(tmp_path / "sc.aem", tmp_path, capsys, *inertia)
    given, _ = estimate_file(tmp_path / "sc.aem", tmp_path, capsys, *inertia, "--torque", str(tmp_path / "cmd.csv"))
    err_without = np.sqrt(np.mean((without[late, 1:] - w[late]) ** 2))
    err_given = np.sqrt(np.mean((given[late, 1:] - w[late]) ** 2))
    assert err_given < 0.02 * err_without, (err_given, err_without)  # measured: 1.7e-07 against 3.2e-05


def test_a_torque_log_on_another_clock_or_unordered_is_refused(tmp_path, capsys):
    t = np.arange(100) / 10.0
    src = write_csv(tmp_path / "att.csv", t, Rotation.from_rotvec(np.outer(t, [0.1, 0, 0])))
    out = tmp_path / "o.csv"
    cases = [
        (1767225600.0 + t, "they must share one clock and the torque log must cover the attitude's"),
        (np.r_[t[:50], t[49], t[51:]], "the torque log's times do not increase at its row 51"),
    ]
    for rows_t, message in cases:
        _write_torques(tmp_path / "tau.csv", rows_t, np.zeros((t.size, 3)))
        code = main(
            [
                "estimate",
                str(src),
                "-o",
                str(out),
                "--no-progress",
                "--inertia",
                "1",
                "--torque",
                str(tmp_path / "tau.csv"),
            ]
        )
        assert code == 2 and message in capsys.readouterr().err and not out.exists()
    own = write_csv(tmp_path / "own.csv", t, Rotation.from_rotvec(np.outer(t, [0.1, 0, 0])), np.zeros((t.size, 3)))
    _write_torques(tmp_path / "tau.csv", t, np.zeros((t.size, 3)))
    with pytest.raises(LogFormatError, match="torque columns of its own"):
        attach_torque(open_log(own), read_torque_log(tmp_path / "tau.csv"))
    _write_torques(tmp_path / "other.csv", t, np.zeros((t.size, 3)), header="t,mx,my,mz")
    with pytest.raises(LogFormatError, match=r"no torque columns .*--torque-columns X,Y,Z"):
        read_torque_log(tmp_path / "other.csv")
    read = read_torque_log(tmp_path / "other.csv", columns=("mx", "my", "mz"))
    assert read.names == ("t", "mx", "my", "mz")
    assert main(["estimate", str(src), "-o", str(out), "--torque-columns", "a,b,c"]) == 2
    assert "--torque-columns names the columns of a --torque FILE" in capsys.readouterr().err
    assert main(["estimate", str(src), "-o", str(out), "--torque", str(tmp_path / "tau.csv")]) == 2
    assert "--torque needs --inertia" in capsys.readouterr().err and not out.exists()
    assert main(["estimate", str(own), "-o", str(out), "--no-progress"]) == 0  # torque columns, no J: said
    assert "the torques are not used without --inertia" in capsys.readouterr().out


def test_one_torque_log_is_for_one_attitude_log(tmp_path, capsys):
    t = np.arange(50) / 10.0
    for name in ("a.csv", "b.csv"):
        write_csv(tmp_path / name, t, Rotation.from_rotvec(np.outer(t, [0.1, 0, 0])))
    _write_torques(tmp_path / "tau.txt", t, np.zeros((t.size, 3)))
    args = ["estimate", str(tmp_path / "a.csv"), str(tmp_path / "b.csv"), "-o", str(tmp_path / "out")]
    assert main([*args, "--torque", str(tmp_path / "tau.txt")]) == 2
    assert "--torque names the torques of one attitude log" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_the_unit_a_torque_logs_time_column_names(tmp_path):
    t = np.arange(100) / 10.0
    src = write_csv(tmp_path / "att.csv", t, Rotation.from_rotvec(np.outer(t, [0.1, 0, 0])))
    rows_tau = np.column_stack([np.arange(100.0), np.zeros(100), np.zeros(100)])
    _write_torques(tmp_path / "tau.csv", t * 1000.0, rows_tau, header="time_ms,tau_x,tau_y,tau_z")
    stream = attach_torque(open_log(src), read_torque_log(tmp_path / "tau.csv"))
    got = np.vstack([c.torque for c in stream.chunks()])
    np.testing.assert_allclose(got[:, 0], np.arange(100.0), rtol=0, atol=1e-9)  # each interval within one row
    assert any("time unit: ms, as the time column's name says ('time_ms'" in n for n in stream.notes)


def test_a_torque_log_in_milliseconds_read_as_seconds_is_said_and_its_messages_name_no_missing_option(tmp_path):
    """Torque rows 1 s apart written in ms and read as s (1000 s apart) were read without a word, the whole attitude
    log then inside the first row's interval; the note now gives the spacing and the column name that reads it.
    A torque log's time has no option of its own: its messages say how to name the column, not a flag that does
    not exist (they offered --torque-time-column)."""
    tau = np.column_stack([np.arange(11.0), np.zeros(11), np.zeros(11)])
    _write_torques(tmp_path / "tau.csv", np.arange(11) * 1000.0, tau, header="t,tau_x,tau_y,tau_z")
    log = read_torque_log(tmp_path / "tau.csv")
    assert log.note == (
        "its rows are 1000 s apart (0.001 Hz) in s, as --time-unit says; if the times are in ms, name its time "
        "column time_ms, which states its unit (1 Hz)"
    )
    _write_torques(tmp_path / "tau.csv", np.arange(11) * 1.0, tau, header="t,tau_x,tau_y,tau_z")
    assert read_torque_log(tmp_path / "tau.csv").note == ""  # 1 Hz rows in s: plausible, nothing said
    _write_torques(tmp_path / "zeit.csv", np.arange(11) * 1.0, tau, header="zeit,tau_x,tau_y,tau_z")
    with pytest.raises(LogFormatError, match=r"no column 't' \(found: zeit, tau_x, tau_y, tau_z\); name its time co"):
        read_torque_log(tmp_path / "zeit.csv")
    _write_torques(tmp_path / "both.csv", np.arange(11) * 1.0, tau, header="time,T,tau_x,tau_y")
    with pytest.raises(LogFormatError) as caught:
        read_torque_log(tmp_path / "both.csv")
    assert "'T' and 'time' could each be the time" in str(caught.value) and "--torque-time" not in str(caught.value)
