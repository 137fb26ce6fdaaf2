"""Issue 12, the output-safety and error cases: output whole or absent, messages that name line, column and an
option that exists, the input dialects real tools write."""

from __future__ import annotations

import os
import re
import time

import numpy as np
import pytest
from numba.core import event

from logmaker import DiscardWriter, constant_rate, read_output, write_csv
from omegahat.cli import main
from omegahat.io import ReadOptions, read_log
from omegahat.kernels import compiling
from omegahat.observer import estimator as estimator_module

OMEGA = np.array([0.1, -0.2, 0.3])


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def log(tmp_path):
    t = np.arange(400) / 100.0
    return write_csv(tmp_path / "log.csv", t, constant_rate(t, OMEGA, sigma=1e-4))


@pytest.mark.parametrize("spacing", [1e100, 1e-20])
@pytest.mark.parametrize("option", [[], ["--smooth"], ["--estimator", "sarras"]])
def test_samples_no_sensor_takes_are_refused_by_their_spacing(tmp_path, capsys, spacing, option):
    """Times k·1e100 s overflowed the model's noise power (a traceback), k·1e-20 s gave NumPy's own "maximum
    allowed dimension exceeded": both are named by their spacing, and nothing is written."""
    t = np.arange(400) / 100.0
    src = write_csv(tmp_path / "log.csv", t, constant_rate(t, OMEGA, sigma=1e-4), t_scale=100.0 * spacing)
    code, _, err = run(capsys, "estimate", src, "-o", tmp_path / "o.csv", *option)
    assert code == 2 and "Traceback" not in err
    assert f"samples are {spacing:.4g} s apart" in err and "no log is estimated at less than 1e-09 Hz" in err
    assert not (tmp_path / "o.csv").exists()


def leftovers(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".part"))


# ------------------------------------------------------------------------------------------------ output


def test_output_equal_to_input_is_refused_in_any_spelling(log, tmp_path, capsys):
    before = log.read_bytes()
    (tmp_path / "sub").mkdir()
    os.symlink(log, tmp_path / "link.csv")
    for out in (log, tmp_path / "sub" / ".." / "log.csv", tmp_path / "link.csv"):
        code, _, err = run(capsys, "estimate", log, "-o", out)
        assert code == 2
        assert "is the input" in err and "write the estimate to another file" in err
    assert log.read_bytes() == before


def test_missing_output_directory_is_found_before_reading(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,qw,qx,qy,qz\n0,1,0,0,0\n0.1,1,zero,0,0\n")  # a format error the reader would report
    code, _, err = run(capsys, "estimate", bad, "-o", tmp_path / "nodir" / "o.csv")
    assert code == 2
    assert "the output's directory" in err and "nodir does not exist" in err and "mkdir -p" in err
    assert "zero" not in err  # the input was not read


def test_a_failure_midway_leaves_no_output_and_no_temporary_file(log, tmp_path, capsys, monkeypatch):
    dst = tmp_path / "o.csv"
    dst.write_text("previous complete result\n")
    calls = {"n": 0}
    real_run = estimator_module.SarrasEstimator.run

    def failing(self, *a):
        calls["n"] += 1
        if calls["n"] == 4:  # after three chunks have been written
            raise OSError("disk full (simulated)")
        return real_run(self, *a)

    monkeypatch.setattr(estimator_module.SarrasEstimator, "run", failing)
    import omegahat.cli.estimate as cli_estimate

    small = lambda **kw: ReadOptions(chunk_bytes=4096, **kw)  # noqa: E731  (many chunks)
    monkeypatch.setattr(cli_estimate, "ReadOptions", small)
    code, _, err = run(capsys, "estimate", log, "-o", dst)
    assert code == 2 and "disk full (simulated)" in err
    assert calls["n"] == 4
    assert dst.read_text() == "previous complete result\n"  # untouched: the new result is whole or absent
    assert leftovers(tmp_path) == []


def test_output_status_column_and_nan_before_the_first_estimate(tmp_path, capsys):
    t = np.arange(300) / 100.0
    src = write_csv(tmp_path / "g.csv", t, constant_rate(t, OMEGA))
    lines = src.read_text().splitlines()
    for k in (1, 2, 150, 151):  # rows 0, 1 (no attitude yet) and 149, 150 (a glitch): empty attitude fields
        lines[k] = lines[k].split(",")[0] + ",,,,"
    src.write_text("\n".join(lines) + "\n")
    code, out, _ = run(capsys, "estimate", src, "-o", tmp_path / "o.csv", "--warm-start")
    assert code == 0
    _, w, status = read_output(tmp_path / "o.csv")
    # rows 0, 1 have no sample; row 2 is the first valid sample (warm start: no rate from one sample)
    assert status[:3] == ["unavailable"] * 3 and np.all(np.isnan(w[:3]))
    assert status[3] == "corrected" and status[149:151] == ["predicted", "predicted"]
    np.testing.assert_allclose(w[3:], np.broadcast_to(OMEGA, (297, 3)), atol=1e-9)
    assert "skipped 4 of 300 samples (4 missing" in out


def test_gaps_are_reported(tmp_path, capsys):
    t = np.concatenate([np.arange(100), np.arange(130, 300)]) / 100.0  # 0.31 s without samples
    src = write_csv(tmp_path / "gap.csv", t, constant_rate(t, OMEGA))
    code, out, _ = run(capsys, "estimate", src, "-o", tmp_path / "o.csv")
    assert code == 0
    assert "gaps: 1 intervals longer than twice the median spacing; the longest 0.31 s before line 102" in out


@pytest.mark.parametrize("columns", ["quaternion", "matrix"])
def test_a_reset_of_the_attitude_source_is_stitched_and_a_jump_reported(tmp_path, capsys, columns):
    """As an iPhone's attitude that jumped 132° in one 9 ms step: a reset of the attitude source (its reference turned
    132° at sample 150, then 80° at 300) is stitched, the sample it reached predicted, and every other rate is the
    body's constant one (the closed form); the same reset beside a missing sample (120° at 350, 348 missing), which
    (P2) cannot judge, is reported as a jump with its line. Both are found between two chunks too."""
    from scipy.spatial.transform import Rotation

    t = np.arange(400) / 100.0
    R = constant_rate(t, OMEGA)
    reset = Rotation.from_rotvec([0.0, np.radians(132.0), 0.0])
    second = Rotation.from_rotvec([np.radians(80.0), 0.0, 0.0])
    third = Rotation.from_rotvec([0.0, 0.0, np.radians(120.0)])
    R = Rotation.concatenate(
        [R[:150], reset * R[150:300], second * reset * R[300:350], third * second * reset * R[350:]]
    )
    if columns == "matrix":
        M = R.as_matrix().reshape(-1, 9)
        rows = [f"{float(t[k])!r}," + ",".join(repr(float(v)) for v in M[k]) for k in range(t.size)]
        header = "t," + ",".join(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
        lines = [header, *rows]
    else:
        lines = write_csv(tmp_path / "jump.csv", t, R).read_text().splitlines()
    lines[1 + 348] = lines[1 + 348].split(",")[0] + "," * (len(lines[1].split(",")) - 1)  # sample 348: missing
    src = tmp_path / "jump.csv"
    src.write_text("\n".join(lines) + "\n")
    code, out, _ = run(capsys, "estimate", src, "-o", tmp_path / "o.csv")
    assert code == 0
    assert "resets: 2 steps far larger than the steps beside them; the largest 132° before line 152: the attitude " \
        "source restarted from another reference" in out  # fmt: skip
    assert "jumps: 1 step between consecutive samples turns the attitude more than 90°; the largest 120° before line " \
        "352: faster than the samples can follow, or a reset or glitch of the attitude source" in out  # fmt: skip
    _, w, status = read_output(tmp_path / "o.csv")
    assert [status[k] for k in (150, 300, 348)] == ["predicted"] * 3
    body = np.ones(t.size, bool)
    body[[0, 150, 300]] = False
    body[345:] = False  # the jump is read as it is
    np.testing.assert_allclose(w[body], np.broadcast_to(OMEGA, w[body].shape), rtol=0, atol=1e-3)
    smooth = write_csv(tmp_path / "smooth.csv", t, constant_rate(t, OMEGA))
    assert "jumps:" not in run(capsys, "estimate", smooth, "-o", tmp_path / "s.csv")[1]
    from omegahat.io import LogChunk, LogStream, pipeline
    from omegahat.io.registry import checked_stream

    q = R.as_quat()
    q[348] = np.nan
    for cut in (150, 151, 350, 351):  # the time policy holds the last row back: the estimator sees the cut a row on

        def chunks(cut=cut):
            for a, b in ((0, cut), (cut, 400)):
                yield LogChunk(t[a:b], q[a:b], None, np.arange(a, b) + 2)

        stream = LogStream("jump", "quaternion", 0, False, "line", chunks)
        checked_stream(stream, ReadOptions())
        summary = pipeline.estimate_stream(stream, pipeline.EstimateSettings(), lambda s: DiscardWriter(), report=print)
        assert (summary.resets, round(np.degrees(summary.largest_reset[0])), summary.largest_reset[1]) == (2, 132, 152)
        assert (summary.jumps, round(np.degrees(summary.largest_jump[0])), summary.largest_jump[1]) == (1, 120, 352)


def test_a_bad_sample_names_its_line_and_the_options(tmp_path, capsys):
    t = np.arange(50) / 100.0
    src = write_csv(tmp_path / "q.csv", t, constant_rate(t, OMEGA))
    lines = src.read_text().splitlines()
    lines[6] = lines[6].split(",")[0] + ",2,0,0,0"  # line 7 of the file: |q| = 2
    src.write_text("\n".join(lines) + "\n")
    code, _, err = run(capsys, "estimate", src, "-o", tmp_path / "o.csv")
    assert code == 2
    assert "q.csv, line 7, columns qw,qx,qy,qz: a quaternion far from unit norm: |q| = 2" in err
    assert "--quat-norm-tol" in err and "--skip-bad-samples" in err and "sample 5" not in err
    assert not (tmp_path / "o.csv").exists()
    code, out, _ = run(capsys, "estimate", src, "-o", tmp_path / "o.csv", "--skip-bad-samples")
    assert code == 0
    assert "--skip-bad-samples: 1 bad samples treated as missing (first: line 7: a quaternion far from unit norm" in out
    _, w, status = read_output(tmp_path / "o.csv")
    assert status[5] == "predicted"
    np.testing.assert_allclose(w, np.broadcast_to(OMEGA, (50, 3)), atol=1e-9)


def test_tolerances_are_options(tmp_path, capsys):
    # Within the file tolerance (1e-2, omegahat.io.precision) imprecise rotations are normalised and reported
    # (issue 25); beyond it the estimator's tolerances decide, and they are options.
    t = np.arange(50) / 100.0
    src = tmp_path / "q.csv"
    printed = {}
    for scale in (1.004, 1.02):
        q = constant_rate(t, OMEGA).as_quat() * scale
        src.write_text(
            "t,qx,qy,qz,qw\n" + "".join(",".join(repr(float(x)) for x in (t[k], *q[k])) + "\n" for k in range(50))
        )
        printed[scale] = run(capsys, "estimate", src, "-o", tmp_path / "o.csv")
    assert printed[1.004][0] == 0 and "note: 50 quaternion(s) normalised" in printed[1.004][1]
    assert printed[1.02][0] == 2 and "pass --quat-norm-tol 0.04 to accept it" in printed[1.02][2]
    assert run(capsys, "estimate", src, "-o", tmp_path / "o.csv", "--quat-norm-tol", "0.04")[0] == 0
    R = constant_rate(t, OMEGA).as_matrix() * 1.01  # |R^T R - I| = 0.0348
    np.savez(tmp_path / "r.npz", t=t, R=R)
    code, _, err = run(capsys, "estimate", tmp_path / "r.npz", "-o", tmp_path / "o.csv")
    assert code == 2 and "r.npz, array R, index 0: not a rotation matrix" in err and "--rotation-tol" in err
    assert run(capsys, "estimate", tmp_path / "r.npz", "-o", tmp_path / "o.csv", "--rotation-tol", "0.07")[0] == 0


@pytest.mark.parametrize(
    ("inertia", "match"),
    [
        (
            ["1", "1", "5"],
            r"--inertia is not the inertia of a rigid body: .* violate the triangle inequality J1 \+ J2 >= J3",
        ),
        (["1", "-1", "1"], r"--inertia must be positive definite"),
    ],
)
def test_inertia_is_physically_checked(log, tmp_path, capsys, inertia, match):
    code, _, err = run(capsys, "estimate", log, "-o", tmp_path / "o.csv", "--inertia", *inertia)
    assert code == 2
    assert pytest.importorskip("re").search(match, err), err


def test_a_flat_plate_is_a_body():
    from omegahat.validation import as_inertia

    np.testing.assert_array_equal(as_inertia([1.0, 2.0, 3.0]), np.diag([1.0, 2.0, 3.0]))  # J1 + J2 = J3: a plate
    with pytest.raises(ValueError, match=r"J is not the inertia of a rigid body"):
        as_inertia([1.0, 2.0, 3.01])


def test_npz_scalar_first_must_be_a_real_boolean(tmp_path, capsys):
    t = np.arange(20) / 100.0
    q = constant_rate(t, OMEGA).as_quat(scalar_first=True)
    for bad in ("False", 0):
        np.savez(tmp_path / "q.npz", t=t, q=q, scalar_first=bad)
        code, _, err = run(capsys, "estimate", tmp_path / "q.npz", "-o", tmp_path / "o.csv")
        assert code == 2
        assert "q.npz, array scalar_first: must be a single boolean (numpy True or False)" in err
    np.savez(tmp_path / "q.npz", t=t, q=q, scalar_first=True)
    code, _, err = run(capsys, "estimate", tmp_path / "q.npz", "-o", tmp_path / "o.csv", "--scalar-last")
    assert code == 2 and "array scalar_first: True contradicts --scalar-last" in err


def test_npz_errors_name_the_array(tmp_path, capsys):
    np.savez(tmp_path / "x.npz", t=np.arange(3.0), q=np.zeros((3, 3)))
    code, _, err = run(capsys, "estimate", tmp_path / "x.npz", "-o", tmp_path / "o.csv")
    assert code == 2 and "x.npz, array q: expected shape (3, 4), got (3, 3)" in err


# ----------------------------------------------------------------------------------------------- dialects


def _dialect(tmp_path, text: str, encoding="utf-8", name="d.csv"):
    p = tmp_path / name
    p.write_bytes(text.encode(encoding))
    return p


def _rows(sep=",", decimal="."):
    t = np.arange(30) / 100.0
    q = constant_rate(t, OMEGA).as_quat()
    fmt = lambda x: repr(float(x)).replace(".", decimal)  # noqa: E731
    return t, "".join(sep.join(fmt(x) for x in (t[k], q[k, 3], *q[k, :3])) + "\r\n" for k in range(30))


@pytest.mark.parametrize(
    ("header", "sep", "decimal", "encoding"),
    [
        ("t,qw,qx,qy,qz", ",", ".", "utf-8-sig"),  # spreadsheet export with a byte-order mark
        ("T,QW,QX,QY,QZ", ",", ".", "utf-8"),  # upper-case names
        (" t ; qw ; qx ; qy ; qz", ";", ",", "utf-8"),  # European spreadsheet: ';' and decimal comma
        ("t\tqw\tqx\tqy\tqz", "\t", ".", "utf-16"),  # "Unicode text" export: UTF-16, tab-separated
    ],
)
def test_dialects_real_tools_write(tmp_path, capsys, header, sep, decimal, encoding):
    t, body = _rows(sep, decimal)
    src = _dialect(tmp_path, header + "\r\n" + body, encoding)
    log = read_log(src)
    np.testing.assert_array_equal(log.t, t)
    code, _, err = run(capsys, "estimate", src, "-o", tmp_path / "o.csv")
    assert code == 0, err
    np.testing.assert_allclose(read_output(tmp_path / "o.csv")[1], np.broadcast_to(OMEGA, (30, 3)), atol=1e-9)


def test_an_unknown_delimiter_is_named(tmp_path):
    src = _dialect(tmp_path, "t qw qx qy qz\n0 1 0 0 0\n")
    with pytest.raises(ValueError, match=r"no ',' ';' or tab between the column names 't qw qx qy qz' \(it has spaces"):
        read_log(src)


def test_time_column_option(tmp_path):
    # one column named as a time is read without the option, said in a note; of two, the option chooses
    one = _dialect(tmp_path, "Time,qw,qx,qy,qz\n0.5,1,0,0,0\n")
    log = read_log(one)
    assert log.t.tolist() == [0.5]
    assert "time column: 'time', the one named as a time (the log has no column 't')" in log.notes
    src = tmp_path / "two.csv"
    src.write_text("Time,Stamp,qw,qx,qy,qz\n0,7,1,0,0,0\n")
    with pytest.raises(
        ValueError,
        match=r"no time column 't' \(found: time, stamp, qw, qx, qy, qz\); several columns are named as a time "
        r"\(time, stamp\): pass --time-column with the one to read",
    ):
        read_log(src)
    assert read_log(src, options=ReadOptions(time_column="stamp")).t.tolist() == [7.0]
    assert read_log(src, options=ReadOptions(time_column="time")).t.tolist() == [0.0]


def test_a_bad_sample_after_the_head_is_found_too(tmp_path, capsys):
    # Past the samples analysed for the gains, a rejected sample is located when the estimator meets it.
    from omegahat.observer.autogain import HEAD_SAMPLES

    n = HEAD_SAMPLES + 2000
    t = np.arange(n) / 100.0
    src = write_csv(tmp_path / "long.csv", t, constant_rate(t, OMEGA))
    lines = src.read_text().splitlines()
    k = HEAD_SAMPLES + 1000  # row index; the file line is k + 2
    lines[k + 1] = lines[k + 1].split(",")[0] + ",0.5,0,0,0"
    src.write_text("\n".join(lines) + "\n")
    code, _, err = run(capsys, "estimate", src, "-o", tmp_path / "o.csv")
    assert code == 2
    assert f"long.csv, line {k + 2}, columns qw,qx,qy,qz: a quaternion far from unit norm: |q| = 0.5" in err
    assert not (tmp_path / "o.csv").exists()
    code, out, _ = run(capsys, "estimate", src, "-o", tmp_path / "o.csv", "--skip-bad-samples")
    assert code == 0 and f"1 bad samples treated as missing (first: line {k + 2}" in out
    _, _, status = read_output(tmp_path / "o.csv")
    assert status[k] == "predicted"


def test_compilation_is_announced_and_reported_whole(log, tmp_path, capsys, monkeypatch):
    """The notice when a compilation starts, once, and the closing note: the run's whole time and the compilation's
    share, the estimation's own time without it. A stand-in compilation of 0.8 s on a stand-in clock, fired as
    Numba fires its own (deterministic: no sleep, no wall-clock bound on the compilation)."""
    ticks = iter([100.0, 100.8])
    monkeypatch.setattr(compiling, "clock", lambda: next(ticks, None) or time.perf_counter())
    monkeypatch.setattr(compiling, "NOTICE_DELAY", 0.0)  # said at once (the real delay is half a second)
    real_run = estimator_module.SarrasEstimator.run
    calls = {"n": 0}

    def compiling_first(self, *a):
        calls["n"] += 1
        if calls["n"] == 1:  # the head check's first call, standing in for a compilation
            with event.trigger_event("numba:compile", data={"dispatcher": None, "args": (), "return_type": None}):
                pass
        return real_run(self, *a)

    monkeypatch.setattr(estimator_module.SarrasEstimator, "run", compiling_first)
    code, out, err = run(capsys, "estimate", log, "-o", tmp_path / "o.csv")
    assert code == 0
    assert err.count(compiling.NOTICE) == 1
    whole, share = re.search(
        r"; (\d+\.\d) s in all, (\d+\.\d) s of it compiling the kernels \(once: later", out
    ).groups()
    assert float(share) >= 0.8 and float(whole) > 0.0
    assert float(out.split("estimated in ")[1].split(" s")[0]) < 0.5


def test_brief_compilation_is_not_announced(monkeypatch):
    """A compilation that ends before the notice's delay says nothing (a cached kernel asking for literal arguments
    first makes such an attempt); the notice stays pending for the next, longer one."""
    said = []
    monkeypatch.setattr(compiling, "NOTICE_DELAY", 3600.0)
    compiling.announce_with(said.append)
    data = {"dispatcher": None, "args": (), "return_type": None}
    with event.trigger_event("numba:compile", data=data):
        pass
    assert said == []
    monkeypatch.setattr(compiling, "NOTICE_DELAY", 0.0)
    with event.trigger_event("numba:compile", data=data):
        pass
    compiling.announce_with(None)
    assert said == [compiling.NOTICE]


def test_nested_compilations_count_once(monkeypatch):
    """A kernel compiling the kernels it calls: the outer compilation's time, not the sum of the nested ones."""
    ticks = iter([10.0, 12.0])  # the outer start and end: the nested one must not even read the clock
    monkeypatch.setattr(compiling, "clock", lambda: next(ticks))
    before = compiling.seconds()
    data = {"dispatcher": None, "args": (), "return_type": None}
    with event.trigger_event("numba:compile", data=data), event.trigger_event("numba:compile", data=data):
        pass
    assert compiling.seconds() - before == pytest.approx(2.0, abs=1e-9)


def test_a_table_with_an_attitude_every_few_seconds_among_rows_10_ms_apart_gets_no_time_unit_advice(tmp_path, capsys):
    """The rows' spacing, not the attitudes', tells the unit: rows 10 ms apart with an attitude every 3 s (other
    sensors' rows between) are in seconds; the run advised --time-unit ms."""
    t = np.arange(1000) / 100.0
    src = write_csv(tmp_path / "log.csv", t, constant_rate(t, OMEGA))
    lines = src.read_text().splitlines()
    for k in range(1, len(lines)):
        if (k - 1) % 300:
            lines[k] = lines[k].split(",")[0] + ",nan,nan,nan,nan"
    src.write_text("\n".join(lines) + "\n")
    code, out, err = run(capsys, "estimate", src, "-o", tmp_path / "o.csv")
    assert code == 0 and "--time-unit" not in out + err and "most rows have no attitude at all" in out
