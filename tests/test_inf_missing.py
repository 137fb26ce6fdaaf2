"""Issue 23: ``inf`` in an attitude is a missing sample, as ``nan`` and an empty field are, in every input (the
policy of :mod:`omegahat.measurements`), and the README and the command's help say so."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import omegahat
from logmaker import constant_rate, read_output, write_csv
from omegahat.cli import main

OMEGA = np.array([0.1, -0.2, 0.3])
ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("fmt", ["csv", "npz"])
def test_inf_in_an_attitude_is_a_missing_sample(tmp_path, capsys, fmt):
    t = np.arange(300) / 100.0
    q = constant_rate(t, OMEGA).as_quat()
    q[100, 0], q[200, 3] = np.inf, -np.inf
    if fmt == "csv":
        src = write_csv(tmp_path / "log.csv", t, constant_rate(t, OMEGA))
        lines = src.read_text().splitlines()
        for k, word in ((101, "inf"), (201, "-Infinity")):
            fields = lines[k].split(",")
            fields[2] = word
            lines[k] = ",".join(fields)
        src.write_text("\n".join(lines) + "\n")
    else:
        src = tmp_path / "log.npz"
        np.savez(src, t=t, q=q)
    assert main(["estimate", str(src), "-o", str(tmp_path / "o.csv"), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "skipped 2 of 300 samples (2 missing, 0 with nearly collinear directions)" in out
    _, w, status = read_output(tmp_path / "o.csv")
    assert status[100] == status[200] == "predicted"
    np.testing.assert_allclose(w[1:], np.broadcast_to(OMEGA, (299, 3)), atol=1e-9)


def test_inf_in_a_dataframe_is_a_missing_sample():
    t = np.arange(300) / 100.0
    q = constant_rate(t, OMEGA).as_quat()
    q[100, 1] = np.inf
    df = pd.DataFrame(q, columns=["qx", "qy", "qz", "qw"]).assign(t=t)
    with pytest.warns(omegahat.observer.estimator.SkippedSamplesWarning, match="1 missing"):
        out = omegahat.estimate_frame(df)
    assert out["status"].iloc[100] == "predicted"


def test_the_readme_and_the_help_say_so(capsys):
    readme = " ".join((ROOT / "README.md").read_text().split())
    assert "An attitude with an empty field, `nan` or `inf` is a missing sample" in readme
    with pytest.raises(SystemExit):
        main(["estimate", "--help"])
    assert "an attitude with an empty field, nan or inf is a missing sample" in capsys.readouterr().out
