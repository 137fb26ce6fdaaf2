"""omegahat.estimate_frame on pandas and Polars frames: the output indexed like the input, time columns of every
kind, rows in any order, automatic gains by default (the numbers of ``omegahat estimate`` on the same samples), and
every error with its message."""

from __future__ import annotations

import numpy as np
import pandas as pd
import polars as pl
import pytest
from scipy.spatial.transform import Rotation

import omegahat
from omegahat.cli import main
from omegahat.interface import Status
from omegahat.io import LogFormatError
from omegahat.observer.estimator import SarrasEstimator, SkippedSamplesWarning
from omegahat.observer.tuning import bandwidth_gains
from recording_files import J_AXI, flip_signs, noisy, read_omega_csv, torque_free_axisymmetric

N = 200
RATE = 100.0


def motion(n=N):
    t = np.arange(n) / RATE
    R, omega = torque_free_axisymmetric(t)
    return t, R, Rotation.from_matrix(R).as_quat(), omega


GAINS = bandwidth_gains(J_AXI, 30.0 / (2 * np.pi))  # 30 rad/s
FIXED = {"gains": GAINS, "start": "warm", "inertia": J_AXI}  # as the estimator itself is run below
W = ["wx", "wy", "wz"]


def direct(t, q):
    """The same numbers through the estimator itself (the reference for the frame path); the first row has no
    estimate with a warm start (the frame says ``unavailable``, NaN)."""
    out = SarrasEstimator(J_AXI, gains=GAINS, warm_start=True).run(t, q)
    assert out.status[0] == Status.UNAVAILABLE and np.all(np.isnan(out.omega[0]))
    return out.omega


def test_pandas_with_a_time_column_keeps_the_index():
    t, _, q, omega = motion()
    df = pd.DataFrame(q, columns=["qx", "qy", "qz", "qw"], index=pd.Index([f"row{k}" for k in range(N)], name="id"))
    df["t"] = t
    df["gyro_x"] = 0.0  # other columns are ignored
    out = omegahat.estimate_frame(df, **FIXED)
    assert isinstance(out, pd.DataFrame)
    assert list(out.columns) == ["wx", "wy", "wz", "status"]
    assert out.index.equals(df.index)
    np.testing.assert_allclose(out[W].to_numpy(), direct(t, q), rtol=0, atol=1e-13)
    np.testing.assert_allclose(out[W].to_numpy()[2:], omega[2:], atol=2e-4)
    assert list(out["status"][:2]) == ["unavailable", "corrected"]
    joined = df.join(out)
    assert joined.shape == (N, 10)


def test_pandas_datetime_index_and_scalar_first_names():
    t, _, q, _ = motion()
    index = pd.Timestamp("2024-05-01 12:00:00") + pd.to_timedelta(np.round(t * 1e9).astype(np.int64), unit="ns")
    df = pd.DataFrame({"W": q[:, 3], "X": q[:, 0], "Y": q[:, 1], "Z": q[:, 2]}, index=pd.DatetimeIndex(index))
    out = omegahat.estimate_frame(df, **FIXED, quaternion=["X", "Y", "Z", "W"])
    assert out.index.equals(df.index)
    np.testing.assert_allclose(out[W].to_numpy(), direct(t, q), rtol=0, atol=1e-12)


def test_rows_in_any_order_with_duplicates_and_sign_flips():
    t, _, q, _ = motion()
    rng = np.random.default_rng(11)
    extra = np.array([5, 77, 150])
    t_all = np.concatenate([t, t[extra]])
    q_all = flip_signs(np.concatenate([q, q[extra]]), rng)
    order = rng.permutation(t_all.size)
    df = pd.DataFrame(q_all[order], columns=["qx", "qy", "qz", "qw"])
    df["t"] = t_all[order]
    with pytest.warns(UserWarning, match=r"row\(s\) came after a later one: sorted by time \(the first: row \d+"):
        out = omegahat.estimate_frame(df, **FIXED)[W].to_numpy()
    expected = direct(t, q)
    np.testing.assert_allclose(out, np.concatenate([expected, expected[extra]])[order], rtol=0, atol=1e-13)


def test_a_clock_that_steps_back_in_a_frame_is_warned_of():
    """A frame whose clock steps back 55 ms at row 200 was sorted in silence (the note only with verbose=True): the
    rows around the step interleaved, 5.7 rad/s off, 'corrected'. The CSV and Parquet readers refuse such a log."""
    t = 1.7e9 + np.arange(400) / 100.0
    t[200:] -= 0.055
    q = Rotation.from_rotvec(np.outer(t - t[0], [0.3, -0.2, 0.5])).as_quat()
    frame = pd.DataFrame({"t": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    with pytest.warns(UserWarning, match=r"5 row\(s\) came after a later one: sorted by time \(the first: row 200, t "):
        omegahat.estimate_frame(frame)


def test_polars_with_datetime_and_float_times():
    t, _, q, _ = motion()
    stamps = (np.datetime64("2024-05-01T12:00:00") + np.round(t * 1e6).astype("timedelta64[us]")).astype(
        "datetime64[us]"
    )
    df = pl.DataFrame({"time": stamps, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    out = omegahat.estimate_frame(df, **FIXED, time="time")
    assert isinstance(out, pl.DataFrame)
    assert out.columns == ["time", "wx", "wy", "wz", "status"]
    assert out.get_column("time").equals(df.get_column("time"))
    np.testing.assert_allclose(out.select(W).to_numpy(), direct(t, q), rtol=0, atol=1e-12)
    df2 = pl.DataFrame({"t": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    out2 = omegahat.estimate_frame(df2, **FIXED)
    np.testing.assert_allclose(out2.select(W).to_numpy(), direct(t, q), rtol=0, atol=1e-13)


def test_polars_millisecond_durations_and_times_beyond_nanoseconds():
    """A Duration in ms is read as the same seconds; a Datetime in ms past what int64 nanoseconds hold (year 2262)
    is refused, not wrapped round to a time in the past."""
    t, _, q, _ = motion()
    ms = np.round(t * 1e3).astype(np.int64)
    quats = {"qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]}
    df = pl.DataFrame({"t": pl.Series(ms).cast(pl.Duration("ms")), **quats})
    out = omegahat.estimate_frame(df, **FIXED)
    np.testing.assert_allclose(out.select(W).to_numpy(), direct(ms / 1e3, q), rtol=0, atol=1e-12)
    year_3000 = 32_503_680_000_000  # ms since 1970
    far = pl.DataFrame({"t": pl.Series(year_3000 + ms).cast(pl.Datetime("ms")), **quats})
    with pytest.raises(LogFormatError, match="column t: times beyond what nanoseconds hold"):
        omegahat.estimate_frame(far, **FIXED)


def test_matrices_directions_missing_values_and_torque():
    t, R, q, _ = motion()
    cols = {f"r{i + 1}{j + 1}": R[:, i, j] for i in range(3) for j in range(3)}
    df = pd.DataFrame({"t": t, **cols})
    df.loc[40, "r11"] = np.nan  # a missing sample
    with pytest.warns(SkippedSamplesWarning, match="skipped 1 of 200 samples"):
        out = omegahat.estimate_frame(df, **FIXED)
    q_missing = q.copy()
    q_missing[40] = np.nan
    with pytest.warns(SkippedSamplesWarning):
        expected = direct(t, q_missing)
    np.testing.assert_allclose(out[W].to_numpy(), expected, rtol=0, atol=1e-12)
    assert out["status"][40] == "predicted"
    V = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    b = np.einsum("tji,nj->tni", R, V)  # body-frame directions r_i = Rᵀ v_i
    dirs = pl.DataFrame({"t": t, **{f"b{n + 1}{a}": b[:, n, k] for n in range(2) for k, a in enumerate("xyz")}})
    dirs = dirs.with_columns(tau_x=pl.lit(0.0), tau_y=pl.lit(0.0), tau_z=pl.lit(0.0))
    gains = bandwidth_gains(J_AXI, 30.0 / (2 * np.pi), V)
    got = omegahat.estimate_frame(dirs, gains=gains, start="warm", inertia=J_AXI, references=V)
    est = SarrasEstimator(J_AXI, gains=gains, references=V, warm_start=True)
    np.testing.assert_allclose(got.select(W).to_numpy()[1:], est.run(t, b).omega[1:], rtol=0, atol=1e-12)


def test_automatic_gains_by_default_are_those_of_the_command(tmp_path, capsys):
    """No gains given: the frame gets what ``omegahat estimate`` gives on the same samples (one path), accurate
    against the closed-form rate; and the polars and pandas frames agree."""
    t, R, _, omega = motion(600)
    q = Rotation.from_matrix(noisy(R, 1e-3, np.random.default_rng(8))).as_quat()
    df = pd.DataFrame({"t": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    out = omegahat.estimate_frame(df, inertia=J_AXI)
    src, dst = tmp_path / "log.csv", tmp_path / "omega.csv"
    df.to_csv(src, index=False, float_format="%.17g")
    assert main(["estimate", str(src), "-o", str(dst), "--inertia", "1", "1", "1.6", "--no-progress"]) == 0
    assert "model identified from the log" in capsys.readouterr().out
    table, status = read_omega_csv(dst)
    np.testing.assert_allclose(out[W].to_numpy(), table[:, 1:], rtol=0, atol=1e-12)
    assert list(out["status"]) == list(status)
    rms = np.sqrt(np.mean((out[W].to_numpy()[100:] - omega[100:]) ** 2))
    assert rms < 0.03  # 1 mrad at 100 Hz: differencing alone would give about 0.14 rad/s per axis
    polars = omegahat.estimate_frame(pl.from_pandas(df), inertia=J_AXI)
    np.testing.assert_array_equal(polars.select(W).to_numpy(), out[W].to_numpy())


@pytest.mark.parametrize(
    ("options", "flags"),
    [({"smooth": True}, ["--smooth"]), ({"preset": "mocap"}, ["--preset", "mocap"]),
     ({"estimator": "omegahat", "smooth": True}, ["--estimator", "omegahat", "--smooth"])],
)  # fmt: skip
def test_smooth_preset_and_estimator_are_the_commands(tmp_path, capsys, options, flags):
    """``smooth``, ``preset`` and ``estimator`` are the command's options: the frame gets the command's numbers for
    the same samples, and the zero-lag ones are accurate against the closed-form rate (less than half of what the causal
    default gives on the same noisy samples, whose lag costs it at this motion)."""
    t, R, _, omega = motion(600)
    q = Rotation.from_matrix(noisy(R, 1e-3, np.random.default_rng(8))).as_quat()
    df = pd.DataFrame({"t": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    out = omegahat.estimate_frame(df, **options)
    src, dst = tmp_path / "log.csv", tmp_path / "omega.csv"
    df.to_csv(src, index=False, float_format="%.17g")
    assert main(["estimate", str(src), "-o", str(dst), *flags, "--no-progress"]) == 0
    capsys.readouterr()
    table, status = read_omega_csv(dst)
    np.testing.assert_allclose(out[W].to_numpy(), table[:, 1:], rtol=0, atol=1e-12)
    assert list(out["status"]) == list(status)
    if options.get("smooth"):
        default = omegahat.estimate_frame(df)[W].to_numpy()
        rms, rms_default = (np.sqrt(np.mean((w[100:] - omega[100:]) ** 2)) for w in (out[W].to_numpy(), default))
        assert rms < rms_default / 2  # measured: 0.0047 against 0.0145 rad/s


def test_smooth_with_fixed_gains_is_refused_naming_the_arguments():
    t, _, q, _ = motion(50)
    df = pd.DataFrame({"t": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    with pytest.raises(ValueError, match=r"smooth=True smooths with the model .* drop bandwidth_hz$"):
        omegahat.estimate_frame(df, smooth=True, bandwidth_hz=5.0)
    with pytest.raises(
        ValueError, match=r"preset='mocap' chooses the model and gains itself .* drop inertia or the preset$"
    ):
        omegahat.estimate_frame(df, preset="mocap", inertia=J_AXI)
    with pytest.raises(ValueError, match=r"estimator"):
        omegahat.estimate_frame(df, estimator="kalman")


def test_errors_name_what_is_wrong():
    t, _, q, _ = motion(10)
    df = pd.DataFrame(q, columns=["qx", "qy", "qz", "qw"])
    with pytest.raises(LogFormatError, match=r"no time: give a column 't' .* \(the index is RangeIndex of int64\)"):
        omegahat.estimate_frame(df)
    df["t"] = t
    with pytest.raises(ValueError, match=r"give either bandwidth_hz or the gains, not both"):
        omegahat.estimate_frame(df, gains=GAINS, bandwidth_hz=1.0)
    with pytest.raises(ValueError, match=r"bandwidth_hz 60 Hz is not below the Nyquist frequency 50 Hz of this log"):
        omegahat.estimate_frame(df, bandwidth_hz=60.0)
    with pytest.raises(TypeError, match=r"takes a pandas or Polars DataFrame; got numpy.ndarray"):
        omegahat.estimate_frame(q)
    with pytest.raises(LogFormatError, match=r"^DataFrame: missing quaternion column\(s\) qw$"):
        omegahat.estimate_frame(df.drop(columns="qw"))
    bad = df.copy()
    bad.loc[4, "qx"] = 3.0
    with pytest.raises(LogFormatError, match=r"DataFrame, row 4, columns qx, qy, qz, qw: a quaternion far from unit"):
        omegahat.estimate_frame(bad)
    with pytest.warns(SkippedSamplesWarning, match="skipped 1 of 10"):
        assert omegahat.estimate_frame(bad, skip_bad_samples=True)["status"][4] == "predicted"
    df.loc[3, "t"] = t[2]
    with pytest.raises(LogFormatError, match=r"DataFrame, row 2 and row 3: two samples at the same time"):
        omegahat.estimate_frame(df)
    df.loc[3, "t"] = np.nan
    with pytest.raises(LogFormatError, match=r"DataFrame, row 3, column t: time nan is not finite"):
        omegahat.estimate_frame(df)
    pdf = pl.DataFrame({"qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    with pytest.raises(LogFormatError, match=r"no time column 't'; give time='column'"):
        omegahat.estimate_frame(pdf)


# ------------------------------------------------------------------------------ issue 23: what else users pass in


def test_a_timezone_aware_index_counts_real_seconds_across_a_clock_change():
    # 2024-03-31 in Paris: the clocks go from 02:00 to 03:00 local time in the middle of these 2 s. The samples are
    # 10 ms apart in real time; as wall-clock times they would be an hour apart there.
    t, _, q, _ = motion()
    start = pd.Timestamp("2024-03-31 00:59:59", tz="UTC")
    utc = start + pd.to_timedelta(np.round(t * 1e9).astype(np.int64), unit="ns")
    naive = pd.DataFrame(q, columns=["qx", "qy", "qz", "qw"], index=pd.DatetimeIndex(utc.tz_localize(None)))
    paris = naive.set_axis(pd.DatetimeIndex(utc).tz_convert("Europe/Paris"), axis=0)
    assert paris.index[0].hour == 1 and paris.index[-1].hour == 3  # the clock change is inside
    out = omegahat.estimate_frame(paris, **FIXED)
    assert out.index.equals(paris.index)
    np.testing.assert_allclose(out[W].to_numpy(), direct(t, q), rtol=0, atol=1e-12)
    column = naive.reset_index(names="when")  # an aware time column too
    column["when"] = paris.index
    out = omegahat.estimate_frame(column, **FIXED, time="when")
    np.testing.assert_allclose(out[W].to_numpy(), direct(t, q), rtol=0, atol=1e-12)


def test_a_polars_lazyframe_is_collected():
    t, _, q, _ = motion()
    eager = pl.DataFrame({"t": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    out = omegahat.estimate_frame(eager.lazy().filter(pl.col("t") >= 0), **FIXED)
    assert isinstance(out, pl.DataFrame) and out.columns == ["t", "wx", "wy", "wz", "status"]
    np.testing.assert_allclose(out.select(W).to_numpy(), direct(t, q), rtol=0, atol=1e-13)


def test_a_polars_timezone_aware_column():
    t, _, q, _ = motion()
    utc = (np.datetime64("2024-03-31T00:59:59") + np.round(t * 1e6).astype("timedelta64[us]")).astype("datetime64[us]")
    df = pl.DataFrame({"when": utc, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    df = df.with_columns(pl.col("when").dt.replace_time_zone("UTC").dt.convert_time_zone("Europe/Paris"))
    out = omegahat.estimate_frame(df, **FIXED, time="when")
    np.testing.assert_allclose(out.select(W).to_numpy(), direct(t, q), rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda df: df["qx"], r"takes a pandas or Polars DataFrame; got pandas.Series \(a single column: pass the"),
        (lambda df: pl.from_pandas(df)["qx"], r"got polars.Series"),
        (lambda df: df.to_numpy(), r"got numpy.ndarray"),
    ],
)  # fmt: skip
def test_other_objects_are_refused_with_a_message(make, match):
    t, _, q, _ = motion(20)
    df = pd.DataFrame(q, columns=["qx", "qy", "qz", "qw"]).assign(t=t)
    with pytest.raises(TypeError, match=match):
        omegahat.estimate_frame(make(df), **FIXED)


def test_a_frame_with_a_spike_warns_of_it_and_a_frame_in_ns_warns_of_its_unit():
    """A marker swap (one sample far from both neighbours) ended estimate_frame in a bare StopIteration after the
    whole run (only missing samples have a line starting "skipped"); the command's warnings (here, times in ns read
    as s: rates 1e9 times too small, every row 'corrected') were dropped unless verbose."""
    t = np.arange(500) / 100.0
    q = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()
    q[250] = Rotation.from_rotvec([2.0, 0.0, 0.0]).as_quat()  # a misread frame
    frame = pd.DataFrame({"t": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    with pytest.warns(SkippedSamplesWarning, match=r"spikes: 1 isolated sample far from both neighbours"):
        out = omegahat.estimate_frame(frame)
    assert out["status"].iloc[250] == "predicted"
    clean = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()
    frame = pd.DataFrame({"t": (t * 1e9).round().astype(np.int64), "qx": clean[:, 0], "qy": clean[:, 1]})
    frame = frame.assign(qz=clean[:, 2], qw=clean[:, 3])
    with pytest.warns(UserWarning, match=r"if the times are in ns, pass time_unit='ns'"):
        omegahat.estimate_frame(frame)


def test_integer_epoch_times_are_read_exactly_in_the_unit_their_size_or_name_states():
    """An int64 column of epoch nanoseconds was read as seconds (rates 1e9 times too small, every row 'corrected',
    a warning only) and through float64 first (256 ns steps at 1.7e18). Now it is read as the CSV, Parquet and NPZ
    readers read it: relative to the first in integers, in the one unit its size fits, or the unit its name states.
    The truth: the constant turn the quaternions were made from."""
    t = np.arange(500) / 100.0
    w = np.array([0.3, -0.2, 0.5])
    q = Rotation.from_rotvec(np.outer(t, w)).as_quat()
    ns = np.int64(1_700_000_000_000_000_000) + np.round(t * 1e9).astype(np.int64)
    cols = {"qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]}
    for frame in (
        pd.DataFrame({"t": ns, **cols}),
        pl.DataFrame({"t": ns, **cols}),
        pd.DataFrame({"stamp_ms": (t * 1000).round().astype(np.int64), **cols}),
    ):
        out = omegahat.estimate_frame(frame, **({"time": "stamp_ms"} if "stamp_ms" in frame.columns else {}))
        W = (out[["wx", "wy", "wz"]] if isinstance(out, pd.DataFrame) else out.select(["wx", "wy", "wz"])).to_numpy()
        np.testing.assert_allclose(W[1:], np.tile(w, (499, 1)), atol=1e-9)
    too_big = pd.DataFrame(
        {"t": np.array([2**63, 2**63 + 10**7], dtype=np.uint64), **{k: v[:2] for k, v in cols.items()}}
    )
    with pytest.raises(LogFormatError, match=r"row 0, column t: time 9223372036854775808 beyond what int64 holds"):
        omegahat.estimate_frame(too_big)
    gap = pd.DataFrame({"t": pd.array([0, None, 20], dtype="Int64"), **{k: v[:3] for k, v in cols.items()}})
    with pytest.raises(LogFormatError, match=r"row 1, column t: missing time"):
        omegahat.estimate_frame(gap)


def test_a_capital_t_is_the_time_as_in_a_csv_unless_another_column_is_named_as_one():
    """A frame whose time column is ``T`` was refused ("no time"), where the CSV and Parquet readers read it; beside
    a ``Time`` column (``T`` a temperature?) it is asked, as they ask."""
    t = np.arange(200) / 100.0
    w = np.array([0.3, -0.2, 0.5])
    q = Rotation.from_rotvec(np.outer(t, w)).as_quat()
    cols = {"qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]}
    for make in (pd.DataFrame, pl.DataFrame):
        out = omegahat.estimate_frame(make({"T": t, **cols}))
        W = (out[["wx", "wy", "wz"]] if isinstance(out, pd.DataFrame) else out.select(["wx", "wy", "wz"])).to_numpy()
        np.testing.assert_allclose(W[1:], np.tile(w, (199, 1)), atol=1e-9)
        with pytest.raises(LogFormatError, match=r"columns 'T' and 'Time' could each be the time .* give time="):
            omegahat.estimate_frame(make({"Time": t, "T": np.full(t.size, 21.5), **cols}))
        chosen = omegahat.estimate_frame(make({"Time": t, "T": np.full(t.size, 21.5), **cols}), time="Time")
        assert len(chosen) == t.size


@pytest.mark.parametrize("gains", [3, {"k": [1.0]}])
def test_gains_that_are_not_observer_gains_are_named(gains):
    frame = pd.DataFrame({"t": np.arange(50) / 10.0, "qx": 0.0, "qy": 0.0, "qz": 0.0, "qw": 1.0})
    with pytest.raises(
        TypeError, match=rf"gains must be an ObserverGains .*, not {type(gains).__name__}; or give bandw"
    ):
        omegahat.estimate_frame(frame, gains=gains)


def test_a_frames_integer_times_are_quoted_as_it_holds_them():
    """An epoch time_ms column's conflicting stamps were quoted in seconds since the first row ("the same time
    1.17"), which the frame does not hold."""
    t = np.arange(200) / 100.0
    q = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()
    ms = np.int64(1_700_000_000_000) + np.round(t * 1000).astype(np.int64)
    ms[120] = ms[117]
    frame = pd.DataFrame({"time_ms": ms, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    with pytest.warns(UserWarning, match="came after a later one"):
        with pytest.raises(LogFormatError, match=r"row 117 and row 120: two samples at the same time 1700000001170 "):
            omegahat.estimate_frame(frame)


def test_float_epoch_times_are_read_in_the_unit_their_size_or_name_states():
    """Epoch nanoseconds held as float64 (pandas makes an int column with a missing value so) were read as seconds:
    rates 1e9 times too small, 'corrected', a warning only. Now as the integer ones, to float precision (256 ns at
    1.7e18). The truth: the constant turn."""
    t = np.arange(500) / 100.0
    w = np.array([0.3, -0.2, 0.5])
    q = Rotation.from_rotvec(np.outer(t, w)).as_quat()
    cols = {"qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]}
    for frame in (pd.DataFrame({"t": 1.7e18 + np.round(t * 1e9), **cols}), pd.DataFrame({"time_ms": t * 1e3, **cols})):
        out = omegahat.estimate_frame(frame, **({"time": "time_ms"} if "time_ms" in frame.columns else {}))
        np.testing.assert_allclose(out[["wx", "wy", "wz"]].to_numpy()[1:], np.tile(w, (499, 1)), atol=1e-4)
