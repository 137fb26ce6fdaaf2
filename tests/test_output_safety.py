"""Issue 23, the files left behind: a full disk at the final flush, killed runs' temporary files, errors that name
the output, symbolic links as the output, and the writers' registry (no import circle with the bag writer)."""

from __future__ import annotations

import errno
import os
import subprocess
import sys

import numpy as np
import pytest

from faults import full_disk
from logmaker import constant_rate, read_output, write_csv
from omegahat.cli import main
from omegahat.io import OmegaWriter, ReadOptions, register_writer
from omegahat.io.output import remove_stale_parts, staged_folder
from omegahat.io.writers import output_kind, unregister_writer

OMEGA = np.array([0.1, -0.2, 0.3])


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def parts(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".part"))


@pytest.fixture
def log(tmp_path):
    t = np.arange(300) / 100.0
    return write_csv(tmp_path / "log.csv", t, constant_rate(t, OMEGA))


def count_writes(capsys, log, dst) -> int:
    with full_disk(10**9) as counter:
        assert run(capsys, "estimate", log, "-o", dst, "--no-progress")[0] == 0
    return counter[0]


def test_a_disk_full_at_the_final_flush_leaves_nothing_and_names_the_output(log, tmp_path, capsys):
    # The last write of a run is the one the commit waits for; it used to raise out of the commit with the
    # temporary file left behind and a message without a file name.
    dst = tmp_path / "o.csv"
    n = count_writes(capsys, log, dst)
    dst.write_text("previous\n")
    for fail_at in (n - 1, n - 2):  # the final flush, the last chunk
        with full_disk(fail_at):
            code, _, err = run(capsys, "estimate", log, "-o", dst, "--no-progress")
        assert code == 2
        assert f"cannot write {dst}: [Errno {errno.ENOSPC}] No space left on device" in err
        assert f"nothing written; {dst} is as it was before" in err
        assert "Traceback" not in err
        assert dst.read_text() == "previous\n" and parts(tmp_path) == []


def test_commit_failures_leave_nothing(log, tmp_path, capsys, monkeypatch):
    dst = tmp_path / "o.csv"
    dst.write_text("previous\n")
    for name, err_no in (("replace", errno.EXDEV), ("fsync", errno.EIO)):
        real = getattr(os, name)

        def failing(*a, _err=err_no, **kw):
            raise OSError(_err, os.strerror(_err))

        monkeypatch.setattr(os, name, failing)
        code, _, err = run(capsys, "estimate", log, "-o", dst, "--no-progress")
        monkeypatch.setattr(os, name, real)
        assert code == 2 and f"cannot write {dst}: [Errno {err_no}]" in err
        assert dst.read_text() == "previous\n" and parts(tmp_path) == []


def test_a_killed_runs_temporary_file_is_removed_by_the_next_run(log, tmp_path, capsys):
    dst = tmp_path / "o.csv"
    # a run killed with SIGKILL while writing: its temporary file stays, nothing can clean it then
    code = (
        "import os, signal, sys, time, numpy as np\n"
        "from omegahat.io import LogChunk, OmegaWriter\n"
        "w = OmegaWriter(sys.argv[1])\n"
        "n = 1000; w.write(LogChunk(np.arange(n) * 0.01, np.zeros((n, 4)), None, np.arange(n)), np.zeros((n, 3)), "
        "np.ones(n)); time.sleep(0.2)\n"
        "os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code, str(dst)], env={**os.environ}, capture_output=True)
    assert proc.returncode == -9
    (stale,) = parts(tmp_path)
    assert stale.startswith(".o.csv.") and not dst.exists()
    other = tmp_path / ".o.csv.x.0123456789abcdef.part"  # another output's ("o.csv.x") temporary file
    other.write_text("not ours")
    code, out, _ = run(capsys, "estimate", log, "-o", dst, "--no-progress")
    assert code == 0
    assert "removed 1 temporary file left by a killed run" in out
    assert parts(tmp_path) == [other.name]
    assert len(read_output(dst)[0]) == 300


def test_a_living_writers_temporary_file_is_left_alone(tmp_path):
    dst = tmp_path / "o.csv"
    with OmegaWriter(dst) as first:  # another run writing the same output, still alive
        assert remove_stale_parts(dst) == []
        assert len(parts(tmp_path)) == 1
        second = OmegaWriter(dst)
        assert second.removed_stale == [] and len(parts(tmp_path)) == 2
        second.abort()
        del first
    assert dst.read_text() == "t,wx,wy,wz,status\n" and parts(tmp_path) == []


@pytest.mark.parametrize("step", ["open", "pa.array", "WriteOptions", "ThreadPoolExecutor", "_lock"])
def test_an_interrupt_while_the_writer_opens_leaves_nothing(tmp_path, monkeypatch, step):
    # Ctrl-C / SIGTERM (the command raises KeyboardInterrupt) landing after the temporary file exists but before the
    # writer is returned to its ``with``: found by CI, a .part file was left behind.
    import omegahat.io.output as output

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt("SIGTERM")

    if step == "open":
        monkeypatch.setattr(output.PartFile, "open", interrupted)
    elif step == "pa.array":
        monkeypatch.setattr(output.pa, "array", interrupted)
    elif step == "WriteOptions":
        monkeypatch.setattr(output.pacsv, "WriteOptions", interrupted)
    elif step == "ThreadPoolExecutor":
        monkeypatch.setattr(output, "ThreadPoolExecutor", interrupted)
    else:
        monkeypatch.setattr(output, "_lock", interrupted)
    with pytest.raises(KeyboardInterrupt):
        OmegaWriter(tmp_path / "o.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_a_symbolic_link_as_output_is_written_through(log, tmp_path, capsys):
    real_dir = tmp_path / "runs"
    real_dir.mkdir()
    target = real_dir / "omega.csv"
    target.write_text("previous\n")
    link = tmp_path / "latest.csv"
    link.symlink_to(target)
    code, out, _ = run(capsys, "estimate", log, "-o", link, "--no-progress")
    assert code == 0 and f"(a link: written to {target})" in out
    assert link.is_symlink() and os.readlink(link) == str(target)  # the link stays a link
    assert len(read_output(target)[0]) == 300
    assert parts(tmp_path) == [] and parts(real_dir) == []
    dangling = tmp_path / "new.csv"
    dangling.symlink_to(real_dir / "created.csv")
    assert run(capsys, "estimate", log, "-o", dangling, "--no-progress")[0] == 0
    assert dangling.is_symlink() and len(read_output(real_dir / "created.csv")[0]) == 300


def test_a_link_to_the_input_is_still_refused(log, tmp_path, capsys):
    link = tmp_path / "link.csv"
    link.symlink_to(log)
    code, _, err = run(capsys, "estimate", log, "-o", link)
    assert code == 2 and "is the input" in err


def test_an_output_that_is_the_torque_log_is_refused_and_the_log_kept(log, tmp_path, capsys):
    torque = tmp_path / "torque.csv"
    torque.write_text("t,tau_x,tau_y,tau_z\n0,0,0,0\n100,0,0,0\n")
    before = torque.read_bytes()
    code, _, err = run(capsys, "estimate", log, "--inertia", "1", "1", "1", "--torque", torque, "-o", torque)
    assert code == 2 and f"the output {torque} is the input {torque}; write the estimate to another file" in err
    assert torque.read_bytes() == before


def test_a_full_disk_in_a_bag_output_leaves_nothing(tmp_path, capsys, monkeypatch):
    from rosbags.rosbag1 import Writer

    from recording_files import write_bag
    from test_rosbag import motion, pose_messages

    stamps, q, _ = motion(50)
    write_bag(tmp_path / "run.bag", 1, {"/p": ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, q))})

    def full(*a, **kw):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Writer, "write", full)
    code, _, err = run(capsys, "estimate", tmp_path / "run.bag", "-o", tmp_path / "twist.bag", "--no-progress")
    assert code == 2 and f"cannot write {tmp_path / 'twist.bag'}: [Errno {errno.ENOSPC}]" in err
    assert not (tmp_path / "twist.bag").exists() and parts(tmp_path) == []


def test_a_staged_folder_appears_whole_or_not_at_all(tmp_path):
    out = tmp_path / "results"
    with pytest.raises(KeyboardInterrupt), staged_folder(out) as stage:
        (stage / "a.md").write_text("a")
        raise KeyboardInterrupt
    assert not out.exists() and parts(tmp_path) == []
    out.mkdir()
    (out / "a.md").write_text("old")
    (out / "keep.txt").write_text("untouched")
    with staged_folder(out) as stage:
        (stage / "a.md").write_text("new")
        (stage / "sub").mkdir()
        (stage / "sub" / "b.csv").write_text("b")
    assert (out / "a.md").read_text() == "new" and (out / "sub" / "b.csv").read_text() == "b"
    assert (out / "keep.txt").read_text() == "untouched" and parts(tmp_path) == []


def test_the_writers_registry_says_what_a_name_asks_for(tmp_path):
    assert output_kind("o.csv", "csv") == "csv"
    assert output_kind("o.bag", "rosbag1") == "rosbag1" and output_kind("o", "rosbag2") == "rosbag2"
    with pytest.raises(ValueError, match=r"o.bag: a bag output needs a bag input \(its stamps and frames\)"):
        output_kind("o.bag", "csv")
    with pytest.raises(ValueError, match=r"unknown output type '.txt'; use .csv, .parquet, .bag \(ROS 1\) or a name"):
        output_kind("o.txt", "rosbag1")
    assert output_kind("o.PARQUET", "rosbag1") == output_kind("o.parquet", "csv") == "parquet"
    with pytest.raises(ValueError, match=r"a bag output needs a bag input \(its stamps and frames\); write .csv or "):
        output_kind("o.bag", "npz")

    class Lines:
        def __init__(self, path, stream):
            self.path = path

    register_writer(".lines", Lines, name="lines", title=".lines", noun="line file")
    try:
        assert output_kind("o.lines", "npz") == "lines"
    finally:
        unregister_writer("lines")
    with pytest.raises(ValueError, match=r"unknown output type '\.lines'"):
        output_kind("o.lines", "npz")


def test_the_output_and_the_bag_writer_import_no_circle():
    from test_architecture import import_cycles, import_graph

    circles = [c for c in import_cycles(import_graph()) if "omegahat.io.output" in c or "omegahat.io.rosbag" in c]
    assert circles == []


def test_small_chunks_change_nothing(log, tmp_path, capsys, monkeypatch):
    # many chunks, each written in the background while the next is estimated: the same file as one chunk
    import omegahat.cli.estimate as cli_estimate

    assert run(capsys, "estimate", log, "-o", tmp_path / "one.csv", "--no-progress")[0] == 0
    monkeypatch.setattr(cli_estimate, "ReadOptions", lambda **kw: ReadOptions(chunk_bytes=2048, **kw))
    assert run(capsys, "estimate", log, "-o", tmp_path / "many.csv", "--no-progress")[0] == 0
    assert (tmp_path / "one.csv").read_bytes() == (tmp_path / "many.csv").read_bytes()
