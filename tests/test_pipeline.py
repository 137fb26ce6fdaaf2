"""The one loop of ``omegahat estimate`` and ``estimate_frame`` (omegahat.io.pipeline): the same data get the same
gains whatever the format (issue 23, item 8), options are spelled by the caller (errors carry them as data), and the
loop runs any estimator, streaming or batch, writing the estimator's own statuses."""

from __future__ import annotations

import contextlib
import io
import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import omegahat
from logmaker import Angle, attitude, noisy, write_csv
from omegahat.cli import main
from omegahat.io import LogFormatError, LogStream
from omegahat.io.pipeline import estimate_stream
from omegahat.io.registry import ReadOptions, checked_stream
from omegahat.io.settings import EstimateSettings


def _printed(argv: list[str]) -> list[str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(argv) == 0
    return out.getvalue().splitlines()


def test_the_same_data_get_the_same_gains_as_csv_and_as_npz(tmp_path):
    """100,000 rows: the CSV reader hands on chunks of ~2 MB (~30,000 rows), the NPZ reader of 131,072 rows, so the
    head of the log (the chunks up to 32,768 rows) was 66,000 rows of one and 100,000 of the other, and the gains
    chosen from it differed (2.82 Hz against 2.61 Hz before). The head analysed is now 32,768 rows of both, and the
    log's length is extrapolated from the bytes read for the head alone (not those read ahead)."""
    t = np.arange(100_000) / 200.0
    rot, _ = attitude(t, Angle(0.1, [(0.3, 0.2, 0.0)]), Angle(0.0, [(0.2, 0.13, 1.0)]), Angle(0.0, [(0.4, 0.07, 2.0)]))
    rot = noisy(rot, 1e-3, 1)
    write_csv(tmp_path / "a.csv", t, rot)
    q = rot.as_quat()
    np.savez(tmp_path / "a.npz", t=t, qw=q[:, 3], qx=q[:, 0], qy=q[:, 1], qz=q[:, 2])
    said = {}
    for name in ("a.csv", "a.npz"):
        lines = _printed(["estimate", str(tmp_path / name), "-o", str(tmp_path / f"{name}.out.csv"), "--no-progress"])
        said[name] = [line for line in lines if line.startswith(("gains:", "gains used:"))]
    assert said["a.csv"] == said["a.npz"] and len(said["a.csv"]) == 2  # the gains and why, to the last digit
    a, b = (np.loadtxt(tmp_path / f"{n}.out.csv", delimiter=",", skiprows=1, usecols=(1, 2, 3)) for n in said)
    np.testing.assert_array_equal(a, b)


def _stream(q: np.ndarray, t: np.ndarray) -> LogStream:
    return checked_stream(LogStream.from_arrays("test", "quaternion", t, q, attitude_name="q"), ReadOptions())


class _Sink:
    def __init__(self):
        self.status: list[np.ndarray] = []

    def write(self, chunk, omega, status):
        self.status.append(status)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return None


def test_messages_name_options_as_the_caller_spells_them_and_errors_carry_them():
    t = np.arange(200) / 50.0
    q = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()
    q[7] *= 1.5  # not a unit quaternion

    def spell(key, value=None):  # any caller's way: the loop itself knows none
        return f"<{key}{'' if value is None else '=' + str(value)}>"

    with pytest.raises(LogFormatError) as raised:
        estimate_stream(_stream(q, t), EstimateSettings(), lambda _: _Sink(), report=lambda _: None, spell=spell)
    message = str(raised.value)
    assert message.startswith("test, array q, index 7: a quaternion far from unit norm: |q| = 1.5")
    assert "exceeds <quat_norm_tol=0.001> (pass <quat_norm_tol=1.0> to accept it, or <skip_bad_samples=True>" in message
    assert raised.value.options == (("skip_bad_samples", True), ("quat_norm_tol", 1.0))
    assert "--" not in message
    with pytest.raises(ValueError, match=re.escape("<smooth=True> needs <preset=mocap>")) as raised:
        estimate_stream(_stream(q, t), EstimateSettings(smooth=True), lambda _: _Sink(), spell=spell)
    assert raised.value.options == (("preset", "mocap"),)


def test_the_command_and_estimate_frame_each_spell_them_their_way(tmp_path, capsys):
    pd = pytest.importorskip("pandas")
    t = np.arange(200) / 50.0
    q = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()
    q[7] *= 1.5
    df = pd.DataFrame({"t": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})
    with pytest.raises(LogFormatError, match=r"pass quat_norm_tol=1\.0 to accept it, or skip_bad_samples=True to"):
        omegahat.estimate_frame(df)
    out = omegahat.estimate_frame(df, quat_norm_tol=1.0)  # the argument it named: accepted
    assert out["status"][7] == "corrected"
    df.to_csv(tmp_path / "q.csv", index=False)
    assert main(["estimate", str(tmp_path / "q.csv"), "-o", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "pass --quat-norm-tol 1 to accept it, or --skip-bad-samples to skip such samples" in err


def test_a_batch_estimator_runs_in_the_same_loop_with_its_own_statuses():
    """--smooth: the smoother (offline) is run once over the whole stream by the loop, chunk by chunk written."""
    t = np.arange(300) / 100.0
    q = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()
    q[[100, 101]] = np.nan
    sink = _Sink()
    settings = EstimateSettings(preset="mocap", smooth=True)
    summary = estimate_stream(_stream(q, t), settings, lambda _: sink, report=lambda _: None)
    status = np.concatenate(sink.status)
    assert status.size == 300 and summary.rows == 300
    assert np.all(status[[100, 101]] == omegahat.Status.PREDICTED) and summary.n_skipped == 2
    assert np.all(np.delete(status, [100, 101]) == omegahat.Status.CORRECTED)
