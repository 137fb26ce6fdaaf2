"""The chaos suite, the writers (issue 23): a disk that fills at every write, a SIGINT or SIGTERM at every chunk, a
SIGKILL at every chunk and before the final rename (``tests/faults.py`` runs each case and says its outcome). Each
time the output is whole or absent (here: the previous file, untouched), no temporary file is left (a killed run's
is removed by the next run), and the command says what happened in one line."""

from __future__ import annotations

import errno
import os
import signal

import pytest

import faults
from omegahat.cli import main


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    return faults.short_log(tmp_path_factory.mktemp("log"))


def check(cases, expected: str, at_least: int) -> None:
    assert len(cases) >= at_least
    wrong = [(case, outcome) for case, outcome in cases if outcome != expected]
    assert not wrong, wrong


def test_a_disk_full_at_every_write(log, tmp_path):
    with faults.many_chunks():
        check(faults.disk_full_cases(log, tmp_path / "o.csv"), "message", at_least=10)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_at_every_chunk(log, tmp_path, sig):
    with faults.many_chunks():
        check(faults.signal_cases(log, tmp_path / "o.csv", sig), "message", at_least=8)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="kills a forked copy of the test process")
def test_a_kill_at_every_chunk_and_the_next_run_cleans_up(log, tmp_path):
    with faults.many_chunks():
        check(faults.kill_cases(log, tmp_path / "o.csv"), "cleaned", at_least=9)


def test_a_disk_full_at_every_message_of_a_bag(tmp_path, capsys, monkeypatch):
    from rosbags.rosbag1 import Writer

    from recording_files import write_bag
    from test_rosbag import motion, pose_messages

    stamps, q, _ = motion(25)
    write_bag(tmp_path / "run.bag", 1, {"/p": ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, q))})
    real = Writer.write
    calls = {"n": 0, "fail_at": -1}

    def write(self, *a, **kw):
        calls["n"] += 1
        if calls["n"] - 1 >= calls["fail_at"] >= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(self, *a, **kw)

    monkeypatch.setattr(Writer, "write", write)
    out = tmp_path / "twist.bag"
    for fail_at in range(25):
        calls.update(n=0, fail_at=fail_at)
        code = main(["estimate", str(tmp_path / "run.bag"), "-o", str(out), "--no-progress"])
        err = capsys.readouterr().err
        assert code == 2 and f"cannot write {out}: [Errno 28]" in err, fail_at
        assert not out.exists() and not list(tmp_path.glob(".*.part")), fail_at


def test_the_judge_tells_each_failure(tmp_path):
    dst = tmp_path / "o.csv"
    want = "omegahat estimate: error: cannot write"
    dst.write_text(faults.PREVIOUS)
    assert faults.judge(2, f"{want} {dst}\n", dst, 2, want) == "message"
    assert faults.judge(2, "Traceback (most recent call last):\n", dst, 2, want) == "traceback"
    assert faults.judge(1, f"{want}\n", dst, 2, want) == "traceback"
    assert faults.judge(2, "omegahat estimate: error: No space left\n", dst, 2, want) == "unnamed"
    (tmp_path / ".o.csv.0123456789abcdef.part").write_text("x")
    assert faults.judge(2, f"{want}\n", dst, 2, want) == "leftover"
    (tmp_path / ".o.csv.0123456789abcdef.part").unlink()
    dst.write_text("t,wx\n0,")
    assert faults.judge(2, f"{want}\n", dst, 2, want) == "partial"
