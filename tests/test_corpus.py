"""The development corpus: its recording format, the harness (methods as a user runs them, the one score), the
conversion script on small synthetic copies of the public data sets, and the independent plant.

The real corpus (``benchmarks/corpus.py SRC OUT``, then ``$OMEGAHAT_CORPUS_DIR=OUT``) is checked when present and
skipped cleanly otherwise.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from scipy.spatial.transform import Rotation

from omegahat.baselines.differencing import log_difference
from omegahat.cli import main
from omegahat.lab.evaluation import broad
from omegahat.lab.evaluation.corpus import (
    METHODS,
    Method,
    Outcome,
    Recording,
    evaluate,
    group_of,
    load_recording,
    pipeline_method,
    recordings,
    save_recording,
)

ROOT = Path(__file__).resolve().parents[1]


def _script(name: str):
    """A script of ``benchmarks/`` as a module (they are not a package)."""
    spec = importlib.util.spec_from_file_location(f"bench_{name}", ROOT / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def turning(t):
    """``(R(t), ω(t))``: a turn about a fixed unit axis ``a``, ``R = Exp(θ(t) a)``, so ``ω = θ̇ a`` in body axes
    (and inertial ones) exactly: a closed form."""
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    theta = 0.8 * t + 0.1 * np.sin(1.3 * t)
    rate = (0.8 + 0.13 * np.cos(1.3 * t))[:, None] * axis
    return Rotation.from_rotvec(theta[:, None] * axis).as_matrix(), rate


def synthetic(kind="quaternion", fs=100.0, duration=20.0, noise=0.0, seed=0) -> Recording:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 1 / fs)
    R, _ = turning(t)
    if noise:
        R = R @ Rotation.from_rotvec(rng.normal(0, noise, (t.size, 3))).as_matrix()
    tr = np.arange(0.0, duration, 1e-3)
    _, wr = turning(tr)
    refs = None
    if kind == "quaternion":
        data = Rotation.from_matrix(R).as_quat()
    else:
        refs = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
        data = np.einsum("tji,nj->tni", R, refs)
    meta = {"source": "test", "score": {"cutoff_hz": "none", "max_shift": 0}, "decimate": [5]}
    return Recording("synthetic", t, kind, data, tr, wr, t > 2.0, meta, refs)


def test_a_recording_round_trips_and_is_an_omegahat_log(tmp_path, capsys):
    rec = synthetic(noise=1e-4)
    rec.data[50:53] = np.nan  # a gap
    path = tmp_path / "rec.npz"
    save_recording(path, rec)
    back = load_recording(path)
    np.testing.assert_array_equal(back.t, rec.t)
    np.testing.assert_array_equal(back.data, rec.data)  # scalar first on disk, scalar last in memory
    np.testing.assert_array_equal(back.reference_rates, rec.reference_rates)
    assert back.meta["source"] == "test" and back.gaps.sum() == 3
    # `omegahat estimate` reads it as it is, and the harness's pipeline method gives the same rates
    out = tmp_path / "w.csv"
    assert main(["estimate", str(path), "-o", str(out)]) == 0
    capsys.readouterr()
    cli = np.genfromtxt(out, delimiter=",", skip_header=1, usecols=(1, 2, 3))
    harness = pipeline_method("omegahat estimate").run(back).omega
    ok = np.isfinite(cli).all(axis=1)
    np.testing.assert_allclose(cli[ok], harness[ok], rtol=1e-12, atol=1e-12)


def test_direction_recordings_give_their_wahba_attitude():
    rec = synthetic("directions")
    R, _ = turning(rec.t)
    np.testing.assert_allclose(rec.R, R, atol=1e-12)


def test_decimated_recordings_keep_the_native_reference():
    rec = synthetic()
    low = rec.decimated(5)
    assert low.t.size == rec.t.size // 5 and low.fs == pytest.approx(20.0)
    assert low.reference_times is rec.reference_times and low.score_options()["max_shift"] == 0
    with pytest.raises(ValueError, match="step must be a positive integer; got 0"):
        rec.decimated(0)


def test_score_of_a_recording_without_low_pass_is_the_plain_rms():
    # cutoff "none", no shift: the score is sqrt(mean |ω̂ − ω|²) over the scored samples, computed here by hand.
    rec = synthetic()
    _, w = turning(rec.t)
    err = np.random.default_rng(1).normal(0, 0.01, w.shape)
    s = broad.score(rec, w + err, **rec.score_options())
    scored = rec.movement & (rec.t >= 1.0 + 1e-9) & (rec.t <= rec.t[-1] - 1.0 - 1e-9)  # 1 s from the ends
    expect = math.sqrt(np.mean(np.sum(err[scored] ** 2, axis=1)))
    assert s.n_samples == scored.sum()
    assert s.rms == pytest.approx(expect, rel=1e-12)


def test_score_leaves_out_samples_beyond_or_inside_gaps_of_the_reference():
    rec = synthetic()
    _, w = turning(rec.t)
    keep = (rec.reference_times < 8.0) | (rec.reference_times > 9.0)  # a 1 s hole in the reference
    holed = Recording(
        rec.name, rec.t, rec.kind, rec.data, rec.reference_times[keep], rec.reference_rates[keep], rec.movement,
        rec.meta,
    )  # fmt: skip
    garbage = w.copy()
    inside = (rec.t > 8.0) & (rec.t < 9.0)
    garbage[inside] = 10.0  # must not count: the reference has nothing there
    s = broad.score(holed, garbage, **rec.score_options())
    full = broad.score(rec, w, **rec.score_options())
    assert s.rms < 1e-6  # the spline is exact to 1e-6 on this smooth rate
    assert full.n_samples - s.n_samples == (1.0 + 2 * 1.0) * 100 + 1  # the hole and the 1 s margin either side


def test_evaluate_scores_every_method_and_names_failures():
    rec = synthetic("quaternion", noise=0.0)

    def broken(_: Recording) -> Outcome:
        raise ValueError("boom")

    methods = [
        METHODS[0],
        Method("exact", lambda r: Outcome(turning(r.t)[1], predicted=0.5), False),
        Method("broken", broken, True),
        Method("not here", broken, True, lambda r: "does not apply"),
    ]
    rows = {r.method: r for r in evaluate(rec, methods)}
    assert rows["exact"].score.rms < 1e-12 and rows["exact"].ratio < 1e-6 and rows["exact"].predicted == 0.5
    assert rows["backward diff."].ratio == 1.0
    assert rows["broken"].score is None and rows["broken"].note == "failed: boom"
    assert rows["not here"].score is None and rows["not here"].note == "does not apply"
    # backward differencing on a rate that changes: its O(h) error against the closed form, 0.5 h |ω̇| at most
    h = 1 / rec.fs
    assert 1e-5 < rows["backward diff."].score.rms < 0.5 * h * 0.13 * 1.3 + 1e-9


def test_every_method_of_the_table_runs_on_a_short_log():
    rec = synthetic("quaternion", fs=50.0, duration=12.0, noise=1e-3)
    rows = evaluate(rec)
    assert [r.method for r in rows] == [m.name for m in METHODS]
    for r in rows:
        assert r.score is not None or r.note, r
        if r.score is not None:
            assert np.isfinite(r.score.rms) and r.score.rms < 1.0, (r.method, r.score)


# ---------------------------------------------------------------------------------- the conversion script


def _euler_motion(u: np.ndarray) -> Rotation:
    return Rotation.from_euler("XYZ", np.column_stack([np.sin(0.7 * u), 0.5 * np.sin(1.1 * u + 1), np.cos(0.5 * u)]))


def _body_rate(u: np.ndarray) -> np.ndarray:
    """The body rate of :func:`_euler_motion` at ``u``, from SciPy's spline through it at 1 ms (independent of the
    code under test)."""
    from scipy.spatial.transform import RotationSpline

    fine = np.arange(u.min() - 1, u.max() + 1, 1e-3)
    w = RotationSpline(fine, _euler_motion(fine))(fine, 1)
    return np.array([np.interp(u, fine, w[:, j]) for j in range(3)]).T


def _fake_broad(path: Path, seed: int, offset_s: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A BROAD-like trial: 286 Hz, optical quaternion (scalar first) with a gap, a gyro in a frame turned by 0.5°,
    biased, on a clock ``offset_s`` ahead; ``movement`` from 2 s to the end − 2 s."""
    fs = 2000 / 7
    t = np.arange(0, 30, 1 / fs)
    rng = np.random.default_rng(seed)
    Rc = Rotation.from_rotvec(np.radians([0.5, -0.3, 0.2])).as_matrix()
    bias = np.array([0.004, -0.002, 0.006])
    g = _body_rate(t - offset_s) @ Rc.T + bias
    g += rng.normal(0, 0.003, g.shape)
    q = _euler_motion(t).as_quat(scalar_first=True)
    q[1000:1010] = np.nan
    movement = ((t > 2) & (t < 28)).astype(float)[:, None]
    scipy.io.savemat(path, {"opt_quat": q, "imu_gyr": g, "movement": movement, "sampling_rate": np.array([[fs]])})
    return Rc, bias


def _fake_upenn(src: Path, n: int, stuck: bool) -> None:
    """A UPenn-like set: Vicon rotations (3, 3, N) at 100 Hz with jittered stamps, raw counts with the gyro rows
    permuted (z, x, y) at 59 counts per rad/s around (370, 374, 375), stuck at (382, 383, 384) for 1 s if asked."""
    rng = np.random.default_rng(n)
    t = 1.3e9 + np.arange(0, 40, 0.01)
    u = t - t[0]
    ang = np.column_stack([0.8 * np.sin(0.9 * u), 0.6 * np.sin(1.3 * u + 1), 0.7 * np.cos(0.6 * u)])
    R = Rotation.from_euler("XYZ", ang)
    from scipy.spatial.transform import RotationSpline

    w = RotationSpline(u, R)(u, 1)
    counts = np.column_stack([w[:, 2], w[:, 0], w[:, 1]]) * 59.0 + np.array([370.0, 374.0, 375.0])
    counts = np.round(counts + rng.normal(0, 0.5, counts.shape))
    if stuck:
        counts[1500:1600] = [382, 383, 384]
    vals = np.vstack([np.full((3, t.size), 500.0), counts.T]).astype(np.uint16)
    (src / "vicon").mkdir(parents=True, exist_ok=True)
    (src / "imu").mkdir(parents=True, exist_ok=True)
    jitter = rng.uniform(0, 0.004, t.size)
    scipy.io.savemat(
        src / "vicon" / f"viconRot{n}.mat", {"rots": np.moveaxis(R.as_matrix(), 0, 2), "ts": (t + jitter)[None]}
    )
    scipy.io.savemat(src / "imu" / f"imuRaw{n}.mat", {"vals": vals, "ts": (t + 0.004 + jitter)[None]})


def test_conversion_script_on_synthetic_copies(tmp_path, capsys):
    corpus = _script("corpus")
    src, out = tmp_path / "src", tmp_path / "out"
    (src / "broad").mkdir(parents=True)
    Rc, bias = _fake_broad(src / "broad" / "03_fake_trial.mat", 3, offset_s=0.004)
    _fake_broad(src / "broad" / "07_acceptance_trial.mat", 7)
    _fake_upenn(src / "upenn", 1, stuck=True)
    assert corpus.main([str(src), str(out), "--only", "broad", "upenn"]) == 0
    text = capsys.readouterr().out
    assert "07_acceptance_trial.mat: an acceptance trial: not converted" in text
    names = sorted(p.stem for p in recordings(out))
    assert names == ["broad-03_fake_trial", "upenn-01"]
    rec = load_recording(out / "broad-03_fake_trial.npz")
    cal = rec.meta["calibration"]
    assert abs(cal["offset"] - 0.004) < 5 * cal["offset_std"] + 2e-5
    np.testing.assert_allclose(cal["bias"], bias, atol=5e-4)
    np.testing.assert_allclose(np.array(cal["rotation"]), Rc, atol=2e-4)
    assert rec.meta["decimate"] == [10, 30] and "CC BY 4.0" in rec.meta["licence"]
    up = load_recording(out / "upenn-01.npz")
    assert up.meta["calibration"]["mode"] == "matrix"
    assert "gx = +bz, gy = +bx, gz = +by" in text
    assert any("110 gyroscope samples left out (stuck" in n for n in up.meta["notes"])  # 100 + 5 either side
    np.testing.assert_allclose(np.diff(up.t), np.median(np.diff(up.t)), atol=1e-9)  # stamps regularised
    # its reference is the body rate: differencing the Vicon attitude agrees with it
    s = broad.score(up, METHODS[1].run(up).omega, **up.score_options())
    assert s.rms < 0.02 and s.gyro_rms > 0.5
    assert (out / "NOTICE.md").exists()


def _fake_repoimu(path: Path, Rc: np.ndarray, bias: np.ndarray) -> None:
    """A RepoIMU-like segment file: ``;``-separated, two header rows, millisecond stamps 10-12 ms apart with one
    repeated, Vicon quaternions (scalar first) with one far off unit norm, a gyroscope in a frame turned by ``Rc``,
    biased, held over pairs of rows."""
    rng = np.random.default_rng(5)
    t = np.round(np.cumsum(rng.choice([0.010, 0.011, 0.012], 3000)), 3)
    t[1500] = t[1499]
    q = _euler_motion(t).as_quat(scalar_first=True)
    q[700] *= 0.9
    g = _body_rate(t) @ Rc.T + bias
    g[1::2] = g[:-1:2]  # held: each gyroscope sample fills two rows
    rows = np.column_stack([t, q, np.zeros((t.size, 3)), g, np.zeros((t.size, 3))])
    header = (
        "Time;Vicon Orientation;;;;IMU Acceleration;;;IMU Gyroscope;;;IMU Magnetometer;;\ns;W;X;Y;Z;X;Y;Z;X;Y;Z;X;Y;Z"
    )
    np.savetxt(path, rows, delimiter=";", header=header, comments="", fmt="%.10g")


def _fake_ring(trial: Path, Rc: np.ndarray) -> None:
    """A RING-like trial: ``omc.csv`` at 30 Hz (five segments' quaternions, scalar first, a gap in the first) and
    ``imu_rigid.csv`` at 40 Hz (the gyroscopes, turned by ``Rc``), each with its two comment lines."""
    trial.mkdir(parents=True)
    t_omc, t_imu = np.arange(0, 30, 1 / 30), np.arange(0, 30, 1 / 40)
    q = _euler_motion(t_omc).as_quat(scalar_first=True)
    g = _body_rate(t_imu) @ Rc.T
    omc_cols, imu_cols, omc, imu = [], [], [], []
    for seg in range(1, 6):
        omc_cols += [f"seg{seg}_quat_{c}" for c in "wxyz"]
        imu_cols += [f"seg{seg}_gyr_{c}" for c in "xyz"]
        omc.append(q.copy())
        imu.append(g)
    omc[0][100:110] = np.nan
    units = "# units are seconds/meters/radians/a.u."
    for name, fs, cols, data in (("omc", 30, omc_cols, omc), ("imu_rigid", 40, imu_cols, imu)):
        header = f"# sampling frequency: {fs}\n{units}\n" + ",".join(cols)
        np.savetxt(trial / f"{name}.csv", np.hstack(data), delimiter=",", header=header, comments="", fmt="%.10g")


def _fake_openaxes(src: Path, scenario: str, link: str, Rc: np.ndarray, motion, rate) -> None:
    """An OpenAXES-like pair: ``groundtruth/robot-SCENARIO/LINK.csv`` (microsecond stamps 8 ms apart, scalar-first
    quaternions of ``motion``) and ``synced_imu/SCENARIO/LINK_adx.csv`` (an index, three accelerometer and three
    gyroscope columns on the same rows, the gyroscope ``rate`` turned by ``Rc`` and filled with its first value over the
    first and last 100 rows, as the re-packaging's resampling does outside the IMU's record)."""
    t = np.arange(2500) * 0.008
    robot, imu = src / "groundtruth" / f"robot-{scenario}", src / "synced_imu" / scenario
    robot.mkdir(parents=True, exist_ok=True)
    imu.mkdir(parents=True, exist_ok=True)
    stamps = 1273456000 + np.arange(t.size) * 8000
    header = "TIME,QUATERNION_0,QUATERNION_1,QUATERNION_2,QUATERNION_3"
    rows = np.column_stack([stamps, motion(t).as_quat(scalar_first=True)])
    np.savetxt(robot / f"{link}.csv", rows, delimiter=",", header=header, comments="", fmt="%.12g")
    g = rate(t) @ Rc.T
    g[:100], g[-100:] = g[100], g[100]
    imu_rows = np.column_stack([np.arange(t.size), np.zeros((t.size, 3)), g])
    header = ",acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z"
    np.savetxt(imu / f"{link}_adx.csv", imu_rows, delimiter=",", header=header, comments="", fmt="%.12g")


def _one_axis(t: np.ndarray) -> Rotation:
    return Rotation.from_rotvec(np.outer(np.sin(0.8 * t), [0.0, 0.0, 1.0]))


def _one_axis_rate(t: np.ndarray) -> np.ndarray:
    return np.outer(0.8 * np.cos(0.8 * t), [0.0, 0.0, 1.0])


def _fake_tyrex(datasets: Path, Rc: np.ndarray) -> None:
    """Tyrex-like recordings: Qualisys rotations (body → room, 9 per frame in MATLAB's column order) at 60 Hz for
    40 s with 30 untracked frames, and the phone's gyroscope in a frame turned by ``Rc``, biased, on a clock 15 ms
    off the one the authors' alignment gives: an Android phone at 200 Hz (stamps on its own clock, drift columns
    after the rates) and an iPhone at 94 Hz (stamps from boot); a capture with no phone folder."""
    t = np.arange(2400) / 60.0
    R = _euler_motion(t).as_matrix()
    frames = R.transpose(0, 2, 1).reshape(-1, 9).T  # each frame's matrix in column order
    frames[:, 500:530] = np.nan
    (datasets / "qualisys").mkdir(parents=True)
    for stem in ("Ann_Nexus5_NoDist_AR", "Ann_iPhone5_NoDist_AR", "Ann_iPhone4S_NoDist_AR"):
        capture = {"FrameRate": 60.0, "Frames": float(t.size), "RigidBodies": {"Rotations": frames[None]}}
        scipy.io.savemat(datasets / "qualisys" / f"{stem}.mat", {stem: capture})
    bias = np.array([0.004, -0.002, 0.006])
    for kind, stem, rate, boot, alignment in (
        ("android", "Ann_Nexus5_NoDist_AR", 200.0, 0.0, -2.4),
        ("ios", "Ann_iPhone5_NoDist_AR", 94.0, 7044.7102, 0.98),
    ):
        phone = datasets / kind / stem
        phone.mkdir(parents=True)
        tg = np.arange(-1.0, 41.0, 1.0 / rate)  # on the Qualisys clock
        g = _body_rate(tg) @ Rc.T + bias
        stamps = tg - alignment + 0.015 + boot  # the phone's clock: the alignment is 15 ms off
        columns = [stamps[:, None], g] + ([np.full((tg.size, 3), 0.01)] if kind == "android" else [])
        np.savetxt(phone / "gyroscope.txt", np.hstack(columns), fmt="%.9f")
        (phone / "timeAlignment.txt").write_text(f"  {alignment:.7e}\n")
        if kind == "ios":
            (phone / "description.txt").write_text(f"[Time]\nBootTime = {boot}  -3.0500000e+00\n")


def test_tyrex_smartphones_are_converted_on_the_qualisys_clock(tmp_path, capsys, monkeypatch):
    corpus = _script("corpus")
    monkeypatch.setattr(corpus, "convert_plant", lambda out: [])
    src, out = tmp_path / "src", tmp_path / "out"
    Rc = Rotation.from_rotvec(np.radians([1.5, -0.3, 0.2])).as_matrix()
    _fake_tyrex(src / "tyrex" / "datasets", Rc)
    assert corpus.main([str(src), str(tmp_path / "default")]) == 0  # held out: not in the development corpus
    assert recordings(tmp_path / "default") == []
    assert corpus.main([str(src), str(out), "--only", "heldout"]) == 0
    printed = capsys.readouterr().out
    assert "tyrex-ann-iphone4s-nodist-ar: not converted: no phone folder" in printed
    assert sorted(p.stem for p in recordings(out)) == ["tyrex-ann-iphone5-nodist-ar", "tyrex-ann-nexus5-nodist-ar"]
    for name in ("tyrex-ann-iphone5-nodist-ar", "tyrex-ann-nexus5-nodist-ar"):
        rec = load_recording(out / f"{name}.npz")
        assert rec.fs == pytest.approx(60.0) and int(rec.gaps.sum()) == 30 and rec.meta["decimate"] == [6]
        assert "30 of 2400 Qualisys frames untracked (NaN): missing" in rec.meta["notes"]
        np.testing.assert_allclose(rec.R[~rec.gaps], _euler_motion(rec.t[~rec.gaps]).as_matrix(), atol=1e-9)
        cal = rec.meta["calibration"]
        assert cal["offset"] == pytest.approx(0.015, abs=1e-3)  # what the alignment left
        np.testing.assert_allclose(np.array(cal["rotation"]), Rc, atol=2e-4)
        np.testing.assert_allclose(cal["bias"], [0.004, -0.002, 0.006], atol=5e-4)
        truth = _body_rate(rec.reference_times)
        assert np.sqrt(np.mean(np.sum((rec.reference_rates - truth) ** 2, axis=1))) < 0.02
    assert "CeCILL" in (out / "NOTICE.md").read_text()


def _fake_hinge(src: Path, Rc: np.ndarray) -> None:
    """Hinge-like trials: a shaft turning back and forth, ``θ = 90° (1 − cos(2π t / 2.4 s))``, its encoder angle
    (degrees, to 0.01) and the gyroscope on it in a frame turned by ``Rc`` (deg/s, biased), on one clock at 100 Hz with
    five repeated stamps; ``data_line`` 11 (MATLAB's rows: the first 10 left out)."""
    src.mkdir(parents=True)
    t = 200.0 + np.arange(6000) * 0.01
    t[[700, 1400, 2100, 2800, 3500]] = t[[699, 1399, 2099, 2799, 3499]]  # stamps repeated
    u = t - t[0]
    theta = 90.0 * (1.0 - np.cos(2.0 * np.pi * u / 2.4))
    rate = 90.0 * 2.0 * np.pi / 2.4 * np.sin(2.0 * np.pi * u / 2.4)  # deg/s about the shaft
    g = np.outer(rate, Rc[:, 2]) + np.array([0.3, -0.2, 0.5])
    rng = np.random.default_rng(5)
    mat = {"all_time": t, "all_encoder": np.round(theta, 2), "data_line": 11}
    for j, c in enumerate("xyz"):
        mat[f"all_gyro_2_{c}"] = g[:, j] + rng.normal(0, 0.05, t.size)
    scipy.io.savemat(src / "raw_yaw_medium.mat", mat)


def test_the_hinge_is_converted_with_one_axis_on_one_clock(tmp_path, capsys, monkeypatch):
    """The turn repeats itself: on separate clocks' ±2 s a shift by half its period with the axis reversed fits as
    well as none. On one clock the offset is searched within 0.1 s, and found."""
    corpus = _script("corpus")
    monkeypatch.setattr(corpus, "convert_plant", lambda out: [])
    src, out = tmp_path / "src", tmp_path / "out"
    Rc = Rotation.from_rotvec(np.radians([80.0, -10.0, 5.0])).as_matrix()
    _fake_hinge(src / "hinge", Rc)
    assert corpus.main([str(src), str(out), "--only", "heldout"]) == 0
    assert "(one axis turned: the turn about it is not identified)" in capsys.readouterr().out
    rec = load_recording(out / "hinge-yaw-medium.npz")
    assert rec.t.size == 6000 - 10 - 5 and rec.meta["decimate"] == [10]
    assert "5 rows with a repeated stamp dropped" in rec.meta["notes"]
    cal = rec.meta["calibration"]
    assert abs(cal["offset"]) < 2e-3
    assert abs(abs(np.array(cal["free_axis"]) @ Rc[:, 2]) - 1.0) < 1e-4
    np.testing.assert_allclose(cal["bias"], np.radians([0.3, -0.2, 0.5]), atol=2e-3)
    u = rec.reference_times
    truth = np.radians(90.0 * 2.0 * np.pi / 2.4) * np.sin(2.0 * np.pi * (u + 0.1) / 2.4)  # t[10] is 0.1 s in
    turn = rec.reference_rates[:, 2]  # the body rate about the shaft, the attitude's z axis: its sign and its size
    assert np.sqrt(np.mean((turn - truth) ** 2)) < 0.01


def test_held_out_recordings_are_converted_only_when_named(tmp_path, capsys, monkeypatch):
    corpus = _script("corpus")
    monkeypatch.setattr(corpus, "convert_plant", lambda out: [])  # the plant is the default's too: not this test's
    src, out = tmp_path / "src", tmp_path / "out"
    (src / "ring" / "data" / "repoIMU_dataset").mkdir(parents=True)
    Rc = Rotation.from_rotvec(np.radians([0.5, -0.3, 0.2])).as_matrix()
    bias = np.array([0.004, -0.002, 0.006])
    _fake_repoimu(src / "ring" / "data" / "repoIMU_dataset" / "Pendulum_Test02a_Trial1_Segment_1.csv", Rc, bias)
    _fake_ring(src / "ring" / "data" / "dataset" / "trial1", Rc)
    axes = src / "ring" / "data" / "openaxes_dataset"
    _fake_openaxes(axes, "circle-100", "carpus", Rc, _euler_motion, _body_rate)
    _fake_openaxes(axes, "triangle-100", "carpus", Rc, _one_axis, _one_axis_rate)  # turns about one axis only
    # a gyroscope of another motion (a failed synchronisation): the calibration explains little of it
    _fake_openaxes(axes, "circle-100", "radius", Rc, _euler_motion, lambda t: 2.3 * _body_rate(2.3 * t + 5.0))
    assert corpus.main([str(src), str(tmp_path / "default")]) == 0  # the development parts only
    assert recordings(tmp_path / "default") == []
    assert corpus.main([str(src), str(out), "--only", "heldout"]) == 0
    names = sorted(p.stem for p in recordings(out))
    ring = [f"ring-trial1-seg{k}" for k in range(1, 6)]
    assert names == ["openaxes-circle-100-carpus", "openaxes-triangle-100-carpus", "repoimu-test02a-s1", *ring]
    pendulum = load_recording(out / "repoimu-test02a-s1.npz")
    notes = pendulum.meta["notes"]
    assert "1 rows with a repeated stamp dropped" in notes
    assert "1 Vicon quaternions NaN or off unit norm by more than 0.001: missing" in notes
    assert pendulum.t.size == 2999 and int(pendulum.gaps.sum()) == 1
    assert np.all(np.diff(pendulum.t) > 0)
    assert pendulum.reference_times.size == 1500  # the held rows left out: one sample per pair
    cal = pendulum.meta["calibration"]
    np.testing.assert_allclose(cal["bias"], bias, atol=5e-4)
    np.testing.assert_allclose(np.array(cal["rotation"]), Rc, atol=2e-4)
    chain = load_recording(out / "ring-trial1-seg1.npz")
    assert chain.fs == pytest.approx(30.0) and int(chain.gaps.sum()) == 10
    assert chain.meta["decimate"] == [3] and "not stated" in chain.meta["licence"]
    arm = load_recording(out / "openaxes-circle-100-carpus.npz")
    assert arm.fs == pytest.approx(125.0) and arm.t[0] == 0.0 and arm.meta["decimate"] == [3, 9]
    assert arm.reference_times.size == 2500 - 201  # the fills (rows 0-100 equal row 100's value, 2400-2499) left out
    assert "gyroscope: 201 of 2500 rows equal to a neighbour" in arm.meta["notes"][0]
    np.testing.assert_allclose(np.array(arm.meta["calibration"]["rotation"]), Rc, atol=2e-4)
    # the references are the body rate: against the closed form's spline, to the gyroscope's held-sample error
    for rec in (pendulum, chain, arm):
        truth = _body_rate(rec.reference_times)
        assert np.sqrt(np.mean(np.sum((rec.reference_rates - truth) ** 2, axis=1))) < 0.02
    printed = capsys.readouterr().out
    assert "held out (RepoIMU, RING, OpenAXES):" in printed
    assert "(one axis turned: the turn about it is not identified)" in printed
    hinge = load_recording(out / "openaxes-triangle-100-carpus.npz")  # the turn about z: its rate is calibrated
    assert abs(abs(np.array(hinge.meta["calibration"]["free_axis"]) @ Rc[:, 2]) - 1.0) < 1e-6
    truth = _one_axis_rate(hinge.reference_times)
    assert np.sqrt(np.mean(np.sum((hinge.reference_rates - truth) ** 2, axis=1))) < 0.02
    assert "openaxes-circle-100-radius: not converted: the calibration leaves" in printed


# ---------------------------------------------------------------------------------- the independent plant


def test_plant_truth_agrees_with_its_attitude_and_conserves_momentum():
    pytest.importorskip("mujoco")
    from omegahat.lab.evaluation.plant_logs import J_PLANT, simulate, smooth_torque

    t, R, w, tau = simulate(smooth_torque(0), duration=2.0)
    from scipy.spatial.transform import RotationSpline

    spline = RotationSpline(t, Rotation.from_matrix(R))(t, 1)  # SciPy, independent of MuJoCo and of omegahat
    np.testing.assert_allclose(spline[5:-5], w[5:-5], atol=1e-6)
    assert tau.shape == (t.size, 3) and np.abs(tau).max() > 0.1
    t0, R0, w0, _ = simulate(lambda x: np.zeros((np.size(x), 3)), duration=2.0)
    L = np.einsum("tij,jk,tk->ti", R0, J_PLANT, w0)  # torque-free: R J ω constant in the inertial frame
    np.testing.assert_allclose(L, np.repeat(L[:1], t0.size, axis=0), atol=1e-9)


# ---------------------------------------------------------------------------------- the real corpus, if built

CORPUS = recordings()
needs_corpus = pytest.mark.skipif(not CORPUS, reason="no corpus (benchmarks/corpus.py; $OMEGAHAT_CORPUS_DIR)")


@needs_corpus
def test_the_built_corpus_holds_no_acceptance_trial_and_every_recording_loads():
    for path in CORPUS:
        assert not any(path.stem.startswith(f"broad-{k}") for k in ("02", "07", "09", "16")), path
        rec = load_recording(path)
        assert rec.movement.any() and np.isfinite(rec.reference_rates).all(), path
        json.dumps(rec.meta)


def test_the_self_assessment_benchmark_skips_cleanly_without_a_corpus(tmp_path, monkeypatch, capsys):
    """``benchmarks/self_assessment.py`` on an empty corpus directory says so, exits 0 and leaves RESULTS.md as is."""
    monkeypatch.setenv("OMEGAHAT_CORPUS_DIR", str(tmp_path))
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # the scripts import results_md as a sibling
    results = ROOT / "benchmarks" / "RESULTS.md"
    before = results.read_text()
    assert _script("self_assessment").main() == 0
    assert "nothing to measure" in capsys.readouterr().out
    assert results.read_text() == before


@pytest.mark.parametrize("name", ["midpoint_target", "filter_ceiling"])
def test_a_corpus_benchmark_skips_cleanly_without_a_corpus(name, tmp_path, monkeypatch, capsys):
    """``benchmarks/midpoint_target.py`` and ``filter_ceiling.py`` on an empty corpus directory say so, exit 0 and
    leave RESULTS.md as is, for either corpus."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    results = ROOT / "benchmarks" / "RESULTS.md"
    before = results.read_text()
    bench = _script(name)
    for argv in ([str(tmp_path)], ["--heldout", str(tmp_path)]):
        assert bench.main(argv) == 0
        assert "skipped" in capsys.readouterr().out
    assert results.read_text() == before


def test_the_filter_loss_benchmark_skips_cleanly_without_a_corpus(tmp_path, monkeypatch, capsys):
    """``benchmarks/filter_loss_causes.py --all`` on an empty corpus directory, or on one that is absent, says so
    and exits 0; a named recording that is absent is skipped by name."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    bench = _script("filter_loss_causes")
    assert bench.main(["--all", str(tmp_path)]) == 0
    assert "skipped: no attitude recording with a filter" in capsys.readouterr().out
    assert bench.main(["--all", str(tmp_path / "absent")]) == 0
    assert "skipped:" in capsys.readouterr().out
    assert bench.main([str(tmp_path), "ring-trial1-seg3/3"]) == 0
    assert "ring-trial1-seg3: skipped" in capsys.readouterr().out


def test_the_midpoint_benchmark_s_filter_gives_the_rate_half_a_step_back(monkeypatch):
    """(M-1) of ``benchmarks/midpoint_target.py`` on a fixed-axis turn whose rate is a constant plus a 3 Hz sine,
    sampled at 10 Hz with 10 µrad of noise: row k is the rate at ``t_k − h/2`` (the closed form), where backward
    differencing has the interval mean (the sine's amplitude times sinc(0.3), 14 % low)."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    bench = _script("midpoint_target")
    h, f0, amp = 0.1, 3.0, 1.0
    t = np.arange(0.0, 120.0, h)
    rate = lambda x: 0.4 + amp * np.sin(2 * np.pi * f0 * x)  # noqa: E731
    angle = 0.4 * t - amp / (2 * np.pi * f0) * np.cos(2 * np.pi * f0 * t)  # its integral
    axis = np.array([0.6, 0.0, 0.8])
    rng = np.random.default_rng(3)
    R = Rotation.from_rotvec(np.outer(angle, axis)) * Rotation.from_rotvec(1e-5 * rng.standard_normal((t.size, 3)))
    R = R.as_matrix()
    truth = np.outer(rate(t - h / 2), axis)
    inner = slice(100, -100)
    middle = bench.midpoint_rate(t, R, np.ones(t.size, bool))
    backward = log_difference(t, R, scheme="backward")
    err = lambda w: np.sqrt(np.mean(np.sum((w[inner] - truth[inner]) ** 2, axis=1)))  # noqa: E731
    assert err(backward) == pytest.approx(amp * (1 - np.sinc(f0 * h)) / np.sqrt(2), rel=0.05)
    assert err(middle) < 0.1 * err(backward)


def test_the_noise_bound_benchmark_reads_the_noise_and_whether_the_band_s_top_is_motion(monkeypatch):
    """``benchmarks/noise_bound.py`` against closed forms: with 1 mrad of white noise on a slow turn and the exact rate
    as the reference, (B1) is the noise (the residual is ``n_k − n_{k−1}``) and the reference holds none of the
    band's top; on a noise-free turn whose rate has a 45 Hz wave at 100 Hz, the band's top is all motion, the
    reference's as the increments'."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    bench = _script("noise_bound")
    noisy = synthetic(noise=1e-3, duration=60.0, seed=4)
    np.testing.assert_allclose(bench.noise_bound(noisy), 1e-3, rtol=0.05)
    assert np.all(bench.top_share(noisy) < 1e-3)
    t, fine = np.arange(0.0, 60.0, 0.01), np.arange(-0.01, 60.01, 1e-4)
    axis = np.array([2.0, -1.0, 2.0]) / 3.0
    wave = 2 * np.pi * 45.0
    angle = lambda x: 0.8 * x - 2.0 / wave * np.cos(wave * x)  # noqa: E731  the rate 0.8 + 2 sin(2π 45 x)
    rate = (0.8 + 2.0 * np.sin(wave * fine))[:, None] * axis
    q = Rotation.from_rotvec(angle(t)[:, None] * axis).as_quat()
    meta = {"source": "test", "score": {}, "decimate": []}
    moving = Recording("wave", t, "quaternion", q, fine, rate, np.ones(t.size, bool), meta)
    np.testing.assert_allclose(bench.top_share(moving), 1.0, rtol=0.02)
    assert np.all(bench.noise_bound(moving) < 5e-5)  # no noise: the 8-sub-step midpoint rule's error on the wave


def test_a_recording_s_group_is_its_source_and_its_decimated_rate():
    assert group_of("broad-06_undisturbed_fast_rotation_A@28.6Hz") == "broad @28.6Hz"
    assert group_of("broad-06_undisturbed_fast_rotation_A") == "broad"
    assert group_of("upenn-03") == "upenn"


def test_the_filter_ceiling_s_windows_and_taps(monkeypatch):
    """The oracle's pieces against what they must be: ``_lagged``'s column for lag ``j`` is ``x`` moved ``j`` samples
    later (earlier for ``j < 0``, (O2)'s window), zeros beyond the ends; ``_sum_one_fit`` recovers taps summing to
    1 exactly from data they made, and on any data returns taps summing to 1 that fit at least as well as its
    anchor; (M2)'s white-noise value is the closed form ``∫ sin²(πf) df = f/2 − sin(2πf)/(4π)`` over each band."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    bench = _script("filter_ceiling")
    rng = np.random.default_rng(5)
    x = rng.normal(size=(12, 3))
    lags = np.array([-2, 0, 3])
    out = bench._lagged(x, lags)
    np.testing.assert_array_equal(out[:10, :, 0], x[2:])
    np.testing.assert_array_equal(out[10:, :, 0], 0.0)
    np.testing.assert_array_equal(out[:, :, 1], x)
    np.testing.assert_array_equal(out[3:, :, 2], x[:9])
    np.testing.assert_array_equal(out[:3, :, 2], 0.0)

    A = rng.normal(size=(200, 3, 5))
    c_true = np.array([0.7, 0.5, -0.4, 0.1, 0.1])  # Σ = 1
    anchor = np.eye(5)[0]
    np.testing.assert_allclose(bench._sum_one_fit(A, A @ c_true, anchor), c_true, atol=1e-12)
    target = rng.normal(size=(200, 3))
    c = bench._sum_one_fit(A, target, anchor)
    assert c.sum() == pytest.approx(1.0, abs=1e-12)
    assert np.sum((A @ c - target) ** 2) <= np.sum((A @ anchor - target) ** 2)

    def integral(a: float, b: float) -> float:
        return (b - a) / 2 - (math.sin(2 * math.pi * b) - math.sin(2 * math.pi * a)) / (4 * math.pi)

    low, top = bench.LOW_BAND, bench.SEEN_BAND
    expected = (integral(*low) / (low[1] - low[0])) / (integral(*top) / (top[1] - top[0]))
    assert bench.white_noise_shape() == pytest.approx(expected, rel=1e-3)  # a mean over 1001 points


def test_the_stamped_rates_table_reads_the_errors_at_no_shift(tmp_path, monkeypatch):
    """``benchmarks/stamped_rates.py``'s rows from a CSV written by hand: per group, each method's error at no shift
    over backward differencing's (geometric mean; lowest–highest: here 0.5 and 0.8 give 0.632; 0.500–0.800) and the
    median best shifts; a recording without every method is left out."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    bench = _script("stamped_rates")
    head = (
        "recording,samples,method,causal,rms_rad_s,shift_samples,zero_shift_rms,n_scored,ratio_to_backward,"
        "ratio_to_best_offline,predicted_rad_s,cpu_us_per_sample,note\n"
    )
    methods = ("backward diff.", "omegahat estimate", "omegahat estimate --smooth", "central diff.", "RotationSpline")
    zero = {  # recording -> method -> (zero-shift RMS, best shift)
        "tyrex-a": dict(zip(methods, [(2.0, -0.5), (2.0, -0.5), (1.0, 0.0), (1.2, 0.0), (1.1, 0.1)], strict=True)),
        "tyrex-b": dict(zip(methods, [(1.0, -0.4), (1.0, -0.4), (0.8, 0.0), (0.9, 0.0), (0.9, 0.1)], strict=True)),
        "tyrex-c": {"backward diff.": (1.0, -0.5)},  # no other method: left out
    }
    lines = [
        f"{name},100,{method},True,{z},{s},{z},90,1.0,1.0,–,1.0,\n"
        for name, methods in zero.items()
        for method, (z, s) in methods.items()
    ]
    path = tmp_path / "rows.csv"
    path.write_text(head + "".join(lines))
    (row,) = bench.table(path)
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[:3] == ["rows.csv", "tyrex", "2"]
    assert cells[3] == "1.000; 1.000–1.000"
    assert cells[4] == f"{math.sqrt(0.5 * 0.8):.3f}; 0.500–0.800"
    assert cells[7] == "-0.45 / -0.45 / +0.00 / +0.00 / +0.10"
