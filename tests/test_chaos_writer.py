"""The chaos suite, the writers (issue 23): a disk that fills at every write, a SIGINT or SIGTERM at every chunk, a
SIGKILL at every chunk and in the final rename. Each time the output is whole or absent (here: the previous file,
untouched), no temporary file is left (a killed run's is removed by the next run), and the command says what
happened in one line."""

from __future__ import annotations

import errno
import os
import signal
import time

import numpy as np
import pytest

from faults import full_disk
from logmaker import constant_rate, read_output, write_csv
from omegahat.cli import main
from omegahat.io import ReadOptions
from omegahat.io.output import OmegaWriter

OMEGA = np.array([0.1, -0.2, 0.3])
PREVIOUS = "the previous complete result\n"


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    t = np.arange(2000) / 100.0
    return write_csv(tmp_path_factory.mktemp("log") / "log.csv", t, constant_rate(t, OMEGA, sigma=1e-4))


@pytest.fixture
def many_chunks(monkeypatch):
    monkeypatch.setattr("omegahat.cli.estimate.ReadOptions", lambda **kw: ReadOptions(chunk_bytes=1 << 14, **kw))


def parts(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".part"))


def estimate(log, dst) -> int:
    return main(["estimate", str(log), "-o", str(dst), "--no-progress"])


def test_a_disk_full_at_every_write(log, tmp_path, capsys, many_chunks):
    dst = tmp_path / "o.csv"
    with full_disk(10**9) as counter:
        assert estimate(log, dst) == 0
    whole = dst.read_bytes()
    n = counter[0]
    assert n >= 10  # the header, every chunk, the final flush
    for k in range(n):
        dst.write_text(PREVIOUS)
        with full_disk(k):
            code = estimate(log, dst)
        err = capsys.readouterr().err
        assert code == 2, (k, err)
        assert err.strip().splitlines()[-1].startswith(f"omegahat estimate: error: cannot write {dst}: [Errno 28]")
        assert dst.read_text() == PREVIOUS and parts(tmp_path) == [], k
    assert estimate(log, dst) == 0 and dst.read_bytes() == whole  # and the disk has room again


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_at_every_chunk(log, tmp_path, capsys, monkeypatch, many_chunks, sig):
    dst = tmp_path / "o.csv"
    real = OmegaWriter.write
    calls = {"n": 0, "at": -1}

    def write(self, *a):
        if calls["n"] == calls["at"]:
            os.kill(os.getpid(), sig)
        calls["n"] += 1
        return real(self, *a)

    monkeypatch.setattr(OmegaWriter, "write", write)
    assert estimate(log, dst) == 0
    chunks = calls["n"]
    capsys.readouterr()
    for at in range(chunks):
        dst.write_text(PREVIOUS)
        calls.update(n=0, at=at)
        code = estimate(log, dst)
        err = capsys.readouterr().err
        assert code == 128 + sig, (at, err)
        assert err.strip().splitlines()[-1] == (
            f"omegahat estimate: interrupted by {signal.Signals(sig).name} (outputs are whole or absent)"
        )
        assert "Traceback" not in err and dst.read_text() == PREVIOUS and parts(tmp_path) == [], at


def _killed_child(log, dst, at: int, chunks: int) -> int:
    """Fork; the child runs the command and kills itself with SIGKILL at chunk ``at`` (``at == chunks``: just
    before the final rename). Returns the child's wait status."""
    pid = os.fork()
    if pid == 0:  # the child: never returns
        try:
            calls = {"n": 0}
            real_write, real_replace = OmegaWriter.write, os.replace

            def write(self, *a):
                if calls["n"] == at:
                    os.kill(os.getpid(), signal.SIGKILL)
                calls["n"] += 1
                return real_write(self, *a)

            def replace(src, dst_):
                if at == chunks:
                    os.kill(os.getpid(), signal.SIGKILL)
                return real_replace(src, dst_)

            OmegaWriter.write = write  # type: ignore[method-assign]
            os.replace = replace
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 1)
            os.dup2(devnull, 2)
            estimate(log, dst)
        finally:
            os._exit(3)  # not killed: the parent sees exit status 3
    deadline = time.monotonic() + 120
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            return status
        if time.monotonic() > deadline:  # pragma: no cover - a child stuck after fork
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            pytest.fail(f"the child killed at chunk {at} hung")
        time.sleep(0.01)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="kills a forked copy of the test process")
def test_a_kill_at_every_chunk_leaves_the_previous_output_and_the_next_run_cleans_up(
    log, tmp_path, capsys, many_chunks
):
    dst = tmp_path / "o.csv"
    counter = {"n": 0}
    real = OmegaWriter.write

    def counting(self, *a):
        counter["n"] += 1
        return real(self, *a)

    OmegaWriter.write = counting  # type: ignore[method-assign]
    try:
        assert estimate(log, dst) == 0
    finally:
        OmegaWriter.write = real  # type: ignore[method-assign]
    whole, chunks = dst.read_bytes(), counter["n"]
    capsys.readouterr()
    for at in range(chunks + 1):
        dst.write_text(PREVIOUS)
        status = _killed_child(log, dst, at, chunks)
        assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL, (at, status)
        assert dst.read_text() == PREVIOUS, at  # a killed run never touches the output
        assert len(parts(tmp_path)) == 1, at  # it cannot clean up: its temporary file stays ...
        assert estimate(log, dst) == 0  # ... until the next run writing the same output
        out = capsys.readouterr().out
        assert "removed 1 temporary file left by a killed run" in out, at
        assert dst.read_bytes() == whole and parts(tmp_path) == [], at
    assert len(read_output(dst)[0]) == 2000


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
        assert not out.exists() and parts(tmp_path) == [], fail_at
