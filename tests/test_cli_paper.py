"""`omegahat paper` writes its figures, trajectory and summary."""

import csv

import numpy as np
import pytest

from omegahat.cli import main
from omegahat.lab.cli.paper import FIGURES
from omegahat.simulation import paper_problem, simulate


def test_paper_command_writes_figures_csv_and_summary(tmp_path, capsys):
    out = tmp_path / "figs"
    assert main(["paper", "--out", str(out), "--horizon", "3"]) == 0
    for name in FIGURES:
        for ext in ("png", "pdf"):
            path = out / f"{name}.{ext}"
            assert path.stat().st_size > 1000, path
    with open(out / "trajectory.csv") as f:
        rows = list(csv.reader(f))
    header = rows[0]
    assert header[:7] == ["t", "wx", "wy", "wz", "wx_hat", "wy_hat", "wz_hat"]
    assert header[7:10] == ["r1x", "r1y", "r1z"] and header[-3:] == ["r2x_hat", "r2y_hat", "r2z_hat"]
    data = np.array(rows[1:], dtype=float)
    assert data.shape == (3001, 19)
    np.testing.assert_allclose(data[0, 1:4], [2.0, -1.0, 0.6])  # ω₀ of the paper
    np.testing.assert_allclose(data[0, 4:7], 0.0, atol=1e-15)  # ω̂₀ = 0
    np.testing.assert_allclose(data[0, 13:16], [0.0, -1.0, 0.0])  # r̂_10
    # the CSV is the simulation: compare with an independent call at t = 3 s
    ref = simulate(paper_problem(), t_out=[0.0, 3.0])
    np.testing.assert_allclose(data[-1, 1:7], np.concatenate([ref.omega[-1], ref.omega_hat[-1]]), atol=1e-9)
    text = capsys.readouterr().out
    assert "stays below 1e-3 after t = " in text
    assert "max |w| = 2.3861 rad/s against omega_M = 3" in text


def test_paper_command_rejects_a_bad_horizon(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["paper", "--horizon", "-2"])
    assert exc.value.code == 2
    assert "expected a positive number, got '-2'" in capsys.readouterr().err
