"""``omegahat estimate`` with ONE measured direction (b1x,b1y,b1z and one reference): io/single_direction.py."""

from __future__ import annotations

import numpy as np
import pandas as pd

import omegahat
from omegahat.cli import main
from omegahat.simulation.rigid_body import RigidBody, integrate

J = np.diag([3.0, 2.0, 1.0])


def _log(path, omega0, v, t, blank=()):
    """A torque-free body (truth: omegahat's CF4 integrator) seen through one direction b = Rᵀ v."""
    tr = integrate(RigidBody(J), np.eye(3), omega0, t)
    b = np.einsum("tji,j->ti", tr.R, np.asarray(v, float) / np.linalg.norm(v))
    lines = ["t,b1x,b1y,b1z"]
    for k in range(t.size):
        x, y, z = (float(c) for c in b[k])
        lines.append(f"{float(t[k])!r},,," if k in blank else f"{float(t[k])!r},{x!r},{y!r},{z!r}")
    path.write_text("\n".join(lines) + "\n")
    return tr


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _read(path):
    assert path.read_text().splitlines()[0] == "t,wx,wy,wz,status"
    return np.loadtxt(path, delimiter=",", skiprows=1, usecols=(1, 2, 3)), np.loadtxt(
        path, delimiter=",", skiprows=1, usecols=(4,), dtype=str
    )


def test_one_direction_tumbling_converges_with_the_inertia(tmp_path, capsys):
    t = np.arange(0.0, 60.0, 0.1)
    src, dst = tmp_path / "sun.csv", tmp_path / "w.csv"
    tr = _log(src, [0.3, 0.2, -0.4], [0.6, 0.0, 0.8], t, blank={100, 101})
    code, out, err = _run(
        capsys, "estimate", src, "-o", dst, "--references=0.6,0,0.8", "--inertia", 3, 2, 1, "--bandwidth", 0.16
    )
    assert code == 0, err
    assert "warning: one measured direction: the rate about it is not observable at an instant" in out
    assert "no span flagged" in out
    assert "skipped 2 of 600 samples (2 missing, 0 with nearly collinear directions): predicted through" in out
    W, status = _read(dst)
    assert list(status[99:103]) == ["corrected", "predicted", "predicted", "corrected"]
    assert status[0] == "unavailable" and np.isnan(W[0]).all()  # one direction at one instant gives no rate
    err_norm = np.linalg.norm(W - tr.omega, axis=1)
    assert err_norm[1] > 0.4 and err_norm[t > 30].max() < 2e-3  # 1 sample from rest (|ω| 0.54): 0.45; then 5.0e-4


def test_one_direction_spin_about_it_is_reported_with_the_axis(tmp_path, capsys):
    t = np.arange(0.0, 30.0, 0.1)
    src, dst = tmp_path / "spin.csv", tmp_path / "w.csv"
    _log(src, [0.0, 0.0, 0.8], [0.0, 0.0, 1.0], t, blank={0, 1})
    code, out, err = _run(capsys, "estimate", src, "-o", dst, "--references=0,0,1", "--start", "warm")
    assert code == 0, err
    assert "note: with one direction the estimator is the single-direction observer, started from rest" in out
    W, status = _read(dst)
    assert list(status[:4]) == ["unavailable"] * 3 + ["corrected"] and np.isnan(W[:3]).all()  # rate: 2nd valid
    assert "none given: J = I, a constant rate; pass --inertia" in out
    assert "warning: no excitation on 198 of 300 samples (first at line 104)" in out  # t = 10.2 s: a full window
    assert "body axis [0. 0. 1.] is not observable" in out


def test_one_direction_errors(tmp_path, capsys):
    t = np.arange(0.0, 1.0, 0.1)
    src, dst = tmp_path / "sun.csv", tmp_path / "w.csv"
    _log(src, [0.3, 0.2, -0.4], [0.0, 0.0, 1.0], t)
    code, _, err = _run(capsys, "estimate", src, "-o", dst)
    assert (
        code == 2 and 'holds 1 body-frame direction (b1): give its inertial direction with "--references=X,Y,Z"' in err
    )
    code, _, err = _run(capsys, "estimate", src, "-o", dst, "--references=0,0,1;1,0,0")
    assert code == 2 and "holds 1 direction but --references gives 2" in err
    code, _, err = _run(capsys, "estimate", src, "-o", dst, "--references=0,0,0")
    assert code == 2 and "--references must be a non-zero vector; got [0.0, 0.0, 0.0]" in err
    src.write_text("t,b1x,b1y,b1z\n0,0,0,1\n0.1,0,0,0\n")
    code, _, err = _run(capsys, "estimate", src, "-o", dst, "--references=0,0,1")
    assert code == 2 and "line 3, columns b1x..b1z: measured direction b1 has zero length" in err
    assert not dst.exists()
    code, _, err = _run(capsys, "estimate", src, "-o", dst, "--references=0,0,1", "--k", 1, 2, "--l", 1)
    assert code == 2 and "--k takes one number or 1 (one per direction); got 2" in err


def test_one_direction_from_a_dataframe():
    """The DataFrame path (estimate_frame) goes the same way; a constant spin about a transverse axis (J = I)."""
    t = np.arange(0.0, 40.0, 0.1)
    w = np.array([0.0, 0.5, 0.0])
    c, s = np.cos(w[1] * t), np.sin(w[1] * t)
    b = np.stack([-s, np.zeros_like(t), c], axis=1)  # Rᵀ e3 for R = exp(t ω×) about y: b = (−sin, 0, cos)
    df = pd.DataFrame({"t": t, "b1x": b[:, 0], "b1y": b[:, 1], "b1z": b[:, 2]})
    out = omegahat.estimate_frame(df, references=[[0.0, 0.0, 1.0]], bandwidth_hz=0.16)
    assert np.abs(out[["wx", "wy", "wz"]].to_numpy()[-1] - w).max() < 1e-3
