"""Issue 23, SIGINT and SIGTERM: one line, exit 128 + the signal (130, 143), the output whole or absent and no
temporary file left, for ``omegahat estimate`` and the laboratory's commands, wherever the signal lands: in Python
code, inside a compiled kernel (where an interrupt used to come out as ``SystemError: CPUDispatcher(...)``), while
writing, or in a fresh process."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from logmaker import constant_rate, write_csv
from omegahat.cli import main
from omegahat.io import ReadOptions
from omegahat.observer import estimator as estimator_module

OMEGA = np.array([0.1, -0.2, 0.3])


def parts(folder) -> list[str]:
    return sorted(p.name for p in folder.rglob("*") if p.name.endswith(".part"))


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    t = np.arange(60_000) / 100.0
    return write_csv(tmp_path_factory.mktemp("log") / "log.csv", t, constant_rate(t, OMEGA, sigma=1e-4))


def send_later(sig: int, seconds: float) -> None:
    threading.Timer(seconds, os.kill, (os.getpid(), sig)).start()


def expect_interrupted(capsys, code: int, sig: int, command: str = "estimate") -> None:
    err = capsys.readouterr().err
    name = signal.Signals(sig).name
    assert code == 128 + sig, err
    assert err.strip().splitlines()[-1] == f"omegahat {command}: interrupted by {name} (outputs are whole or absent)"
    assert "Traceback" not in err and "SystemError" not in err


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("where", ["kernel", "writer"])
def test_a_signal_during_the_estimate(log, tmp_path, capsys, monkeypatch, sig, where):
    dst = tmp_path / "o.csv"
    small = lambda **kw: ReadOptions(chunk_bytes=1 << 16, **kw)  # noqa: E731  (many chunks)
    monkeypatch.setattr("omegahat.cli.estimate.ReadOptions", small)
    calls = {"n": 0}
    if where == "kernel":  # the signal arrives while the compiled estimator runs on a chunk
        real = estimator_module.SarrasEstimator.run

        def run(self, *a):
            calls["n"] += 1
            if calls["n"] == 6:
                send_later(sig, 0.0005)
            return real(self, *a)

        monkeypatch.setattr(estimator_module.SarrasEstimator, "run", run)
    else:  # while a chunk is being written
        from omegahat.io.output import OmegaWriter

        real_write = OmegaWriter.write

        def write(self, *a):
            calls["n"] += 1
            if calls["n"] == 3:
                os.kill(os.getpid(), sig)
            return real_write(self, *a)

        monkeypatch.setattr(OmegaWriter, "write", write)
    code = main(["estimate", str(log), "-o", str(dst), "--no-progress"])
    time.sleep(0.01)  # a late timer must not fire into the next test
    expect_interrupted(capsys, code, sig)
    assert not dst.exists() and parts(tmp_path) == []


def test_an_interrupt_during_a_laboratory_command_leaves_no_folder(tmp_path, capsys, monkeypatch):
    import omegahat.lab.cli.paper as paper

    real = paper.write_trajectory_csv

    def interrupted(path, traj):
        real(path, traj)
        os.kill(os.getpid(), signal.SIGINT)  # after some files are written in the staging folder
        time.sleep(0.1)

    monkeypatch.setattr(paper, "write_trajectory_csv", interrupted)
    out = tmp_path / "figs"
    code = main(["paper", "--out", str(out), "--horizon", "1"])
    expect_interrupted(capsys, code, signal.SIGINT, "paper")
    assert not out.exists() and parts(tmp_path) == []


def test_sigterm_to_the_command_in_its_own_process(log, tmp_path):
    # The process as a user runs it, on a machine slow enough (each chunk takes 0.2 s more) that the signal arrives
    # while it estimates: after it printed the gains.
    dst = tmp_path / "o.csv"
    slow = (
        "import sys, time\n"
        "from omegahat.observer import estimator\n"
        "run = estimator.SarrasEstimator.run\n"
        "estimator.SarrasEstimator.run = lambda self, *a: (time.sleep(0.2), run(self, *a))[1]\n"
        "from omegahat.cli import entry\n"
        "entry()\n"  # the console script's own path
    )
    argv = [sys.executable, "-u", "-c", slow, "estimate", str(log), "-o", str(dst), "--no-progress"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    while "gains" not in proc.stdout.readline():  # "gains: ...": estimating from now on
        assert proc.poll() is None
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert err.strip().splitlines()[-1] == "omegahat estimate: interrupted by SIGTERM (outputs are whole or absent)"
    assert "Traceback" not in err and not dst.exists() and parts(tmp_path) == []


def test_an_interrupt_that_surfaces_as_numbas_system_error(log, tmp_path, capsys, monkeypatch):
    # What CPython reports when the handler raised while a compiled function ran (seen about once in five runs of
    # the "kernel" case above): made deterministic here. Any other SystemError is a bug and stays one.
    def interrupted_kernel(*a):
        try:
            raise KeyboardInterrupt("SIGINT")
        except KeyboardInterrupt as exc:
            raise SystemError("CPUDispatcher(<function run>) returned a result with an exception set") from exc

    monkeypatch.setattr(estimator_module.SarrasEstimator, "run", interrupted_kernel)
    code = main(["estimate", str(log), "-o", str(tmp_path / "o.csv"), "--no-progress"])
    expect_interrupted(capsys, code, signal.SIGINT)
    assert parts(tmp_path) == [] and not (tmp_path / "o.csv").exists()

    def broken(*a):
        raise SystemError("a real bug")

    monkeypatch.setattr(estimator_module.SarrasEstimator, "run", broken)
    with pytest.raises(SystemError, match="a real bug"):
        main(["estimate", str(log), "-o", str(tmp_path / "o.csv"), "--no-progress"])


def test_the_help_states_the_exit_statuses(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f"{128 + signal.SIGINT} interrupted by SIGINT (Ctrl-C), {128 + signal.SIGTERM} by SIGTERM" in text
    assert "the temporary file of a killed run (SIGKILL, power loss) is removed by the next run" in text
