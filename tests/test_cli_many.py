"""``omegahat estimate DIR_OR_GLOB... -o OUTDIR``: many logs in one command (omegahat.cli.many), each output the
one-file command's own (bit for bit), a broken file named in the summary while the others complete, globs, name
collisions, an existing OUTDIR, Ctrl-C, a Dask cluster, and the one-file command unchanged."""

from __future__ import annotations

import csv
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from logmaker import Angle, attitude, constant_rate, write_csv
from omegahat.cli import main
from omegahat.cli.many import SUMMARY_CSV, SUMMARY_TXT, is_many
from vendor_files import decimal_seconds, write_tum

OPTS = ["--inertia", "1", "1", "1.6", "--no-progress"]


def good_log(path: Path, k: int = 0, n: int = 300) -> Path:
    t = np.arange(n) / 100.0
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_csv(path, t, constant_rate(t, [0.3, -0.2, 0.5 + 0.1 * k], sigma=1e-3, seed=k))


def broken_log(path: Path) -> Path:
    path.write_text("t,qw,qx,qy,qz\n0,1,0,0,0\n0.1,1,zero,0,0\n")
    return path


def one_file(capsys, src: Path, dst: Path, *opts: str) -> str:
    """The output of the one-file command (the reference every batch output must equal), and what it printed."""
    assert main(["estimate", str(src), "-o", str(dst), *OPTS, *opts]) == 0
    return capsys.readouterr().out


def batch(capsys, *argv) -> tuple[int, str, str]:
    code = main(["estimate", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def summary_rows(outdir: Path) -> dict[str, dict[str, str]]:
    with open(outdir / SUMMARY_CSV, newline="") as f:
        return {row["input"]: row for row in csv.DictReader(f)}


def test_a_folder_with_a_broken_file_runs_the_others_and_names_it(tmp_path, capsys):
    d = tmp_path / "takes"
    logs = [good_log(d / f"take{k}.csv", k) for k in range(3)]
    broken_log(d / "broken.csv")
    (d / "README.md").write_text("notes\n")
    (d / "sub").mkdir()
    out = tmp_path / "out"
    code, printed, _ = batch(capsys, d, "-o", out, *OPTS, "--jobs", "2")
    assert code == 1  # some failed
    for k, src in enumerate(logs):
        ref = tmp_path / f"ref{k}.csv"
        one_file(capsys, src, ref)
        assert (out / src.name).read_bytes() == ref.read_bytes()
    assert not (out / "broken.csv").exists()
    assert sorted(p.name for p in out.iterdir()) == sorted([SUMMARY_CSV, SUMMARY_TXT] + [p.name for p in logs])
    assert re.search(
        r"takes/broken\.csv +- +- +- +- +failed: .*broken\.csv, line 3, column qx: 'zero' is not a number", printed
    )
    # the estimator the identification ran, and the expected error it stated for it
    assert re.search(r"takes/take0\.csv +csv +300 +omegahat, J given +[0-9.e+-]+ rad/s +ok", printed)
    assert "4 files (3 ok, 1 failed) in " in printed and "on 2 processes" in printed
    rows = summary_rows(out)
    assert rows[str(d / "broken.csv")]["status"] == "failed"
    assert "line 3, column qx: 'zero' is not a number" in rows[str(d / "broken.csv")]["message"]
    assert rows[str(logs[1])]["rows"] == "300" and rows[str(logs[1])]["output"] == "take1.csv"
    text = (out / SUMMARY_TXT).read_text()
    assert f"skipped {d / 'README.md'}: no format reads .md" in text
    assert f"skipped {d / 'sub'}: a directory (not searched inside" in text
    assert "skipped 2: " in printed


def test_the_expected_error_and_estimator_are_the_one_file_runs(tmp_path, capsys):
    """Without --inertia the fixed-gain observer runs and states its expected error; the table carries it."""
    src = good_log(tmp_path / "in" / "a.csv")
    good_log(tmp_path / "in" / "b.csv", 1)
    printed = one_file(capsys, src, tmp_path / "ref.csv", "--inertia", "1", "1", "1", "--bandwidth", "2")
    expected = float(re.search(r"expected RMS error ([0-9.e+-]+) rad/s", printed).group(1))
    code, _, _ = batch(
        capsys, tmp_path / "in", "-o", tmp_path / "out", "--no-progress", "--jobs", "1", "--bandwidth", "2"
    )
    assert code == 0
    row = summary_rows(tmp_path / "out")[str(src)]
    assert row["estimator"] == "sarras, J = I" and row["status"] == "ok"
    assert float(row["expected_rms_rad_s"]) == pytest.approx(expected, rel=1e-6)  # 2 digits printed, 6 kept


def test_the_default_rows_name_what_the_identification_ran_and_its_expected_error(tmp_path, capsys):
    """With no option each file runs what the identification of its head chose: a noisy log the model's filter, a
    noise-free one backward differencing. The table names that estimator (it said "sarras" for both) and the
    expected error the one-file run states for it (for differencing, the log's spectrum's account of what runs)."""
    noisy = good_log(tmp_path / "in" / "noisy.csv", n=3000)
    t = np.arange(3000) / 100.0  # a hand-like turning motion, no noise: nothing for a filter to remove
    yaw, pitch, roll = Angle(0.0, [(0.8, 0.31, 0.0), (0.3, 0.73, 1.0)]), Angle(0.0, [(0.4, 0.47, 2.0)]), Angle(0.0)
    clean = write_csv(tmp_path / "in" / "clean.csv", t, attitude(t, yaw, pitch, roll)[0])
    said = {}
    for src in (noisy, clean):
        assert main(["estimate", str(src), "-o", str(tmp_path / "ref.csv"), "--no-progress"]) == 0
        printed = capsys.readouterr().out
        found = re.search(
            r"expected RMS error of the model's filter ([0-9.e+-]+) rad/s, of backward differencing ([0-9.e+-]+) "
            r"rad/s: (the model's filter|backward differencing) runs",
            printed,
        )
        assert found is not None, printed
        spectrum = re.search(r"expected RMS error ([0-9.e+-]+) rad/s by the log's spectrum", printed)
        if found.group(3) == "the model's filter":
            stated = found.group(1)
        else:  # differencing: the log's spectrum's account (C2) of what runs (30 s of samples give a spectrum)
            assert spectrum is not None, printed
            stated = spectrum.group(1)
        said[src] = (found.group(3), float(stated), "through the log's causal filter" in printed)
    assert said[noisy][0] == "the model's filter" and said[clean][0] == "backward differencing"
    code, _, _ = batch(capsys, tmp_path / "in", "-o", tmp_path / "out", "--no-progress", "--jobs", "1")
    assert code == 0
    rows = summary_rows(tmp_path / "out")
    assert rows[str(noisy)]["estimator"] == "omegahat, J = I"
    assert rows[str(clean)]["estimator"] == "backward differencing" + (", causal filter" if said[clean][2] else "")
    for src in (noisy, clean):
        assert float(rows[str(src)]["expected_rms_rad_s"]) == pytest.approx(said[src][1], rel=1e-6)


def test_smooth_rows_carry_the_expected_error_of_the_smoother_kept(tmp_path, capsys):
    """With ``--smooth`` the closing line states the smoother's own expected error (the Wiener smoother's where no
    model is chosen; both, where both ran, the lower one kept); the table carries the kept one's."""
    noisy = good_log(tmp_path / "in" / "noisy.csv", n=3000)
    t = np.arange(3000) / 100.0
    yaw, pitch, roll = Angle(0.0, [(0.8, 0.31, 0.0), (0.3, 0.73, 1.0)]), Angle(0.0, [(0.4, 0.47, 2.0)]), Angle(0.0)
    clean = write_csv(tmp_path / "in" / "clean.csv", t, attitude(t, yaw, pitch, roll)[0])
    said = {}
    for src in (noisy, clean):
        assert main(["estimate", str(src), "-o", str(tmp_path / "ref.csv"), "--smooth", "--no-progress"]) == 0
        used = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("estimator used: "))
        both = re.search(r"the model's smoother ([0-9.e+-]+) rad/s, the Wiener smoother ([0-9.e+-]+) rad/s", used)
        alone = re.search(r"Wiener smoother \(offline, zero lag; expected RMS error ([0-9.e+-]+) rad/s", used)
        said[src] = min(float(both.group(1)), float(both.group(2))) if both else float(alone.group(1))
    assert said[clean] > 0 and said[noisy] > 0
    code, _, _ = batch(capsys, tmp_path / "in", "-o", tmp_path / "out", "--no-progress", "--jobs", "1", "--smooth")
    assert code == 0
    rows = summary_rows(tmp_path / "out")
    assert rows[str(clean)]["estimator"] == "Wiener smoother --smooth"
    for src in (noisy, clean):
        assert float(rows[str(src)]["expected_rms_rad_s"]) == pytest.approx(said[src], rel=0.05)  # 2 digits printed


def test_globs_go_down_with_double_star_and_mirror_the_folders(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    good_log(Path("data/day1/a.csv"))
    good_log(Path("data/day2/a.csv"), 1)
    good_log(Path("data/top.csv"), 2)
    Path("data/day2/notes.txt").write_text("no log\n")
    code, printed, _ = batch(capsys, "data/**/*.csv", "-o", "out", *OPTS, "--jobs", "1")
    assert code == 0, printed
    assert sorted(str(p.relative_to("out")) for p in Path("out").rglob("*.csv") if p.name != SUMMARY_CSV) == [
        "day1/a.csv",
        "day2/a.csv",
        "top.csv",
    ]
    code, printed, _ = batch(capsys, "data/*", "-o", "out2", *OPTS, "--jobs", "1")  # one level: folders skipped
    assert code == 0 and "3 " not in printed.splitlines()[-1][:2]
    assert sorted(p.name for p in Path("out2").iterdir()) == [SUMMARY_CSV, SUMMARY_TXT, "top.csv"]
    code, _, err = batch(capsys, "data/*.c3d", "-o", "out3", *OPTS)
    assert code == 2
    assert "no logs found in data/*.c3d (data/*.c3d: the pattern matches nothing)" in err


def test_name_collisions_are_renamed_apart_and_said(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    good_log(Path("a/x.csv"))
    good_log(Path("b/x.csv"), 1)
    t = np.arange(300) / 100.0
    write_tum("a/run.txt", decimal_seconds(1311868163, t), constant_rate(t, [0.1, 0.2, 0.3]).as_quat())
    good_log(Path("a/run.csv"), 2)
    code, printed, _ = batch(capsys, "a", "b/x.csv", "-o", "out", *OPTS, "--jobs", "1")
    assert code == 0, printed
    assert "note: 2 inputs would write x.csv; written as: a/x.csv -> a/x.csv, b/x.csv -> b/x.csv" in printed
    assert "note: 2 inputs would write run.csv; written as: a/run.csv -> run.csv, a/run.txt -> run.txt.csv" in printed
    names = sorted(str(p.relative_to("out")) for p in Path("out").rglob("*") if p.is_file())
    assert names == sorted(["a/x.csv", "b/x.csv", "run.csv", "run.txt.csv", SUMMARY_CSV, SUMMARY_TXT])
    rows = summary_rows(Path("out"))
    assert rows["a/run.txt"]["format"] == "tum" and rows["a/run.txt"]["output"] == "run.txt.csv"


def test_an_existing_outdir_is_never_overwritten_silently(tmp_path, capsys):
    d = tmp_path / "in"
    good_log(d / "a.csv")
    good_log(d / "b.csv", 1)
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.csv").write_text("mine\n")
    code, _, err = batch(capsys, d, "-o", out, *OPTS)
    assert code == 2
    assert "the output directory already holds 1 of the 2 outputs (a.csv); pass --existing overwrite" in err
    assert (out / "a.csv").read_text() == "mine\n" and not (out / "b.csv").exists()
    code, printed, _ = batch(capsys, d, "-o", out, *OPTS, "--existing", "skip", "--jobs", "1")
    assert code == 0
    assert "note: kept 1 existing output(s): a.csv" in printed
    assert re.search(r"in/a\.csv .* kept: its output exists \(--existing skip\)", printed)
    assert (out / "a.csv").read_text() == "mine\n" and (out / "b.csv").exists()
    code, printed, _ = batch(capsys, d, "-o", out, *OPTS, "--existing", "overwrite", "--jobs", "1")
    assert code == 0
    assert "note: replacing 2 existing output(s): a.csv, b.csv" in printed
    assert (out / "a.csv").read_text().startswith("t,wx,wy,wz,status\n")


def test_outputs_that_would_be_inputs_and_file_like_outdirs_are_refused(tmp_path, capsys):
    d = tmp_path / "in"
    good_log(d / "a.csv")
    good_log(d / "b.csv", 1)
    code, _, err = batch(capsys, d, "-o", d, *OPTS, "--existing", "overwrite")
    assert code == 2 and "would overwrite the input" in err
    code, _, err = batch(capsys, d, "-o", tmp_path / "omega.csv", *OPTS)
    assert code == 2 and "looks like a file name: give a directory, e.g. -o" in err
    code, _, err = batch(capsys, d / "a.csv", d / "b.csv", "-o", tmp_path / "o", *OPTS, "--times", "t.txt")
    assert code == 2 and "--times names the times of one pose list" in err
    # the outputs of an earlier batch in the folder are not taken for logs
    code, _, _ = batch(capsys, d, "-o", tmp_path / "o", *OPTS, "--jobs", "1")
    assert code == 0
    code, printed, _ = batch(capsys, d, tmp_path / "o", "-o", tmp_path / "o2", *OPTS, "--jobs", "1")
    assert code == 0 and "2 files (2 ok)" in printed
    text = (tmp_path / "o2" / SUMMARY_TXT).read_text()
    assert "o/a.csv: an output of omegahat (t,wx,wy,wz,status)" in text
    assert "o/omegahat-summary.csv: the summary of an earlier batch" in text


def test_the_one_file_command_is_unchanged_and_refuses_batch_options(tmp_path, capsys):
    src = good_log(tmp_path / "a.csv")
    code, printed, _ = batch(capsys, src, "-o", tmp_path / "o.csv", *OPTS)
    assert code == 0 and "wrote 300 estimates to" in printed and "summary" not in printed
    code, _, err = batch(capsys, src, "-o", tmp_path / "o.csv", *OPTS, "--jobs", "2")
    assert code == 2 and "--jobs: for many inputs" in err
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    assert not is_many([bag]) and is_many([tmp_path]) and is_many([src, src]) and is_many([tmp_path / "*.csv"])
    assert not is_many([tmp_path / "none.csv"])  # a missing file: the one-file command's message


def test_duplicate_times_are_counted_in_the_batch_summary(tmp_path, capsys):
    t = np.arange(300) / 100.0
    q = constant_rate(t, [0.1, 0.2, 0.3]).as_quat()
    stamps = decimal_seconds(1403715529, t)
    other = constant_rate(t[:1] + 1.5, [0.1, 0.25, 0.3]).as_quat()
    good_log(tmp_path / "in" / "b.csv")
    write_tum(
        tmp_path / "in" / "gt.txt", [*stamps[:151], stamps[150], *stamps[151:]], np.vstack([q[:151], other, q[151:]])
    )
    code, _, _ = batch(capsys, tmp_path / "in", "-o", tmp_path / "o", *OPTS, "--jobs", "1")
    assert code == 1
    assert "--duplicate-times first or last" in summary_rows(tmp_path / "o")[str(tmp_path / "in" / "gt.txt")]["message"]
    code, _, _ = batch(
        capsys, tmp_path / "in", "-o", tmp_path / "o2", *OPTS, "--jobs", "1", "--duplicate-times", "last"
    )
    assert code == 0
    notes = summary_rows(tmp_path / "o2")[str(tmp_path / "in" / "gt.txt")]["notes"]
    assert "--duplicate-times last: kept the last sample at each of 1 time(s) whose samples differ, dropped 1" in notes


@pytest.mark.parametrize(("sig", "jobs", "code"), [(signal.SIGINT, "2", 130), (signal.SIGTERM, "1", 143)])
def test_ctrl_c_stops_cleanly_with_no_partial_file_and_exit_130(tmp_path, sig, jobs, code):
    """Stopped once its first output is written, the batch leaves every output whole or absent. 200 files (40
    logs, each copied to four more names): with 40, a CI machine busy with other tests once let the whole batch
    finish between two polls of this test, and the signal then reached no process (exit 0)."""
    d = tmp_path / "in"
    for k in range(40):
        good_log(d / f"t{k:03d}.csv", k, n=3000)
        for copy in range(1, 5):
            shutil.copyfile(d / f"t{k:03d}.csv", d / f"t{k + 40 * copy:03d}.csv")
    out = tmp_path / "out"
    cmd = [
        sys.executable,
        "-c",
        "import sys; from omegahat.cli import entry; entry()",  # the console script's own path
        "estimate",
        str(d),
        "-o",
        str(out),
        *OPTS,
        "--jobs",
        jobs,
    ]
    # the installed package, as every other test imports it (the source tree's copy would compile its kernels again)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while not (out.exists() and any(p.name.startswith("t") for p in out.iterdir())):
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.05)
    assert proc.poll() is None, "the batch ended before it could be interrupted"
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == code, stderr
    assert "Traceback" not in stderr and "stopping: the files running stop at their next chunk" in stderr
    assert f"omegahat estimate: interrupted by {sig.name} (outputs are whole or absent)" in stderr
    assert re.search(r"in/t\d{3}\.csv +- +- +- +- +not run", stdout)
    rows = summary_rows(out)
    status = {Path(k).name: v["status"] for k, v in rows.items()}
    assert len(status) == 200 and "not run" in status.values()
    leftovers = [p.name for p in out.iterdir() if p.name not in (SUMMARY_CSV, SUMMARY_TXT)]
    assert all(not name.startswith(".") for name in leftovers)  # no temporary file left
    for name in leftovers:  # every output there is whole, and its row says ok
        assert status[name] == "ok"
        assert len((out / name).read_text().splitlines()) == 3001
    assert sum(s == "ok" for s in status.values()) == len(leftovers)


def test_an_interrupt_lost_in_a_finalizer_still_stops_the_batch(tmp_path, capsys, monkeypatch):
    """A signal whose KeyboardInterrupt is raised inside a finalizer (a ``__del__``, a generator the garbage collector
    closes) is printed as "Exception ignored" by Python and goes no further: the batch must still stop (found as a
    subprocess that finished all its files after SIGTERM and exited 0)."""
    import omegahat.cli.many_run as many_run

    d = tmp_path / "in"
    for k in range(4):
        good_log(d / f"t{k}.csv", k)
    real_run_job = many_run.run_job

    class SignalledWhileCollected:
        def __del__(self) -> None:
            signal.raise_signal(signal.SIGTERM)  # the handler's raise ends here, ignored

    def run_job_then_signal(*args, **kwargs):
        outcome = real_run_job(*args, **kwargs)
        SignalledWhileCollected()
        return outcome

    lost: list[type] = []
    monkeypatch.setattr(many_run, "run_job", run_job_then_signal)
    monkeypatch.setattr(sys, "unraisablehook", lambda unraisable: lost.append(unraisable.exc_type))
    code, printed, err = batch(capsys, d, "-o", tmp_path / "out", *OPTS, "--jobs", "1")
    assert lost == [KeyboardInterrupt]  # the raise was indeed lost where it happened
    assert code == 143 and "interrupted by SIGTERM" in err and re.search(r"in/t3\.csv +- +- +- +- +not run", printed)
    status = {Path(k).name: v["status"] for k, v in summary_rows(tmp_path / "out").items()}
    assert sorted(status.values()) == ["not run", "not run", "not run", "ok"]


def test_dask_cluster_gives_the_local_outputs(tmp_path, capsys):
    distributed = pytest.importorskip("distributed", reason='Dask is an extra: pip install ".[dask]"')
    d = tmp_path / "in"
    for k in range(3):
        good_log(d / f"t{k}.csv", k)
    broken_log(d / "bad.csv")
    code, _, _ = batch(capsys, d, "-o", tmp_path / "here", *OPTS, "--jobs", "1")
    assert code == 1
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as lc:
        code, printed, _ = batch(capsys, d, "-o", tmp_path / "there", *OPTS, "--dask", lc.scheduler_address)
    assert code == 1
    assert "4 files (3 ok, 1 failed) in " in printed and "on the Dask cluster" in printed
    for k in range(3):
        assert (tmp_path / "there" / f"t{k}.csv").read_bytes() == (tmp_path / "here" / f"t{k}.csv").read_bytes()
    here, there = summary_rows(tmp_path / "here"), summary_rows(tmp_path / "there")
    for key in here:
        for col in ("output", "format", "rows", "estimator", "status", "message"):
            assert here[key][col] == there[key][col], (key, col)


def test_parquet_outputs_for_a_folder(tmp_path, capsys):
    """``--output-format parquet``: each output a .parquet file holding the one-file CSV run's rows, named in the
    summary; the one-file command refuses the option (its -o name says the format)."""
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    d = tmp_path / "takes"
    logs = [good_log(d / f"take{k}.csv", k) for k in range(2)]
    out = tmp_path / "out"
    code, _, _ = batch(capsys, d, "-o", out, *OPTS, "--jobs", "1", "--output-format", "parquet")
    assert code == 0
    rows = summary_rows(out)
    for k, log in enumerate(logs):
        one_file(capsys, log, tmp_path / f"one{k}.csv")
        expected = pacsv.read_csv(tmp_path / f"one{k}.csv")
        written = pq.read_table(out / f"take{k}.parquet")
        for name in ("t", "wx", "wy", "wz", "status"):
            assert written[name].to_pylist() == expected[name].to_pylist(), name
        assert rows[str(log)]["output"].endswith(f"take{k}.parquet")
    assert [p.name for p in out.glob("*.csv")] == [SUMMARY_CSV]  # the summary is the only CSV
    code, _, err = batch(capsys, logs[0], "-o", tmp_path / "o.csv", *OPTS, "--output-format", "parquet")
    assert code == 2 and "--output-format: for many inputs" in err


def test_parquet_logs_are_run_and_parquet_outputs_skipped(tmp_path, capsys):
    """A folder with a Parquet log and an omegahat output written as Parquet: the log is run (its output named
    ``.csv`` like any other), the output is skipped with its reason, as a CSV output is."""
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    d = tmp_path / "in"
    src = good_log(d / "a.csv")
    pq.write_table(pacsv.read_csv(src), d / "b.parquet")
    assert main(["estimate", str(src), "-o", str(d / "old.parquet"), "--inertia", "1", "1", "1.6"]) == 0
    code, printed, _ = batch(capsys, d, "-o", tmp_path / "o", *OPTS, "--jobs", "1")
    assert code == 0 and "2 files (2 ok)" in printed
    text = (tmp_path / "o" / SUMMARY_TXT).read_text()
    assert "in/old.parquet: an output of omegahat (t,wx,wy,wz,status, as Parquet)" in text
    a, b = ((tmp_path / "o" / name).read_text() for name in ("a.csv", "b.csv"))
    assert a == b  # the same rows, read from CSV and from Parquet, give the same estimates
