"""``omegahat estimate``: end to end on logs with a known answer, and every error path with its exit code."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat import so3
from omegahat.cli import main
from omegahat.simulation.rigid_body import RigidBody, Torque, integrate

OMEGA = np.array([0.7, -0.4, 1.1])  # constant body rate (J = I, no torque)


def constant_rate_attitudes(t, R0=None):
    """R(t) = R0 exp(t ω×): the exact motion of J = I at constant rate."""
    R0 = so3.exp([0.2, -0.3, 0.5]) if R0 is None else R0
    return R0 @ so3.exp(t[:, None] * OMEGA)


def write_quaternion_csv(path, t, R, blank=()):
    q = Rotation.from_matrix(R).as_quat()  # x, y, z, w
    lines = ["qy,t,qw,qz,qx"]
    for k in range(t.size):
        if k in blank:
            lines.append(f",{float(t[k])!r},,,")
        else:
            x, y, z, w = (float(v) for v in q[k])
            lines.append(f"{y!r},{float(t[k])!r},{w!r},{z!r},{x!r}")
    path.write_text("\n".join(lines) + "\n")


def read_output(path):
    lines = path.read_text().splitlines()
    assert lines[0] == "t,wx,wy,wz,status"
    return np.loadtxt(path, delimiter=",", skiprows=1, usecols=(0, 1, 2, 3))


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


# ------------------------------------------------------------------------------------------- known answers


def test_constant_rate_from_quaternion_csv(tmp_path, capsys):
    t = np.arange(300) * 0.01
    src, dst = tmp_path / "in.csv", tmp_path / "out.csv"
    write_quaternion_csv(src, t, constant_rate_attitudes(t), blank={150, 151})
    code, out, err = run_cli(capsys, "estimate", src, "-o", dst, "--no-progress")
    assert code == 0, err
    assert "wrote 300 estimates" in out
    assert "skipped 2 of 300 samples (2 missing" in out
    w = read_output(dst)
    np.testing.assert_array_equal(w[:, 0], t)
    # The sampled estimator is exact at constant rate: after convergence the error is at rounding level.
    np.testing.assert_allclose(w[100:, 1:], np.broadcast_to(OMEGA, (200, 3)), atol=1e-8)
    assert err == ""  # no progress bar asked


def test_matrix_npz_with_k_and_l(tmp_path, capsys):
    t = np.arange(400) * 0.005
    src, dst = tmp_path / "in.npz", tmp_path / "out.csv"
    np.savez(src, t=t, R=constant_rate_attitudes(t))
    code, out, err = run_cli(capsys, "estimate", src, "-o", dst, "--k", "20", "--l", "5", "30", "50")
    assert code == 0, err
    assert "k = [20. 20. 20.], l = [ 5. 30. 50.]" in out
    np.testing.assert_allclose(read_output(dst)[-50:, 1:], np.broadcast_to(OMEGA, (50, 3)), atol=1e-8)


def test_direction_input_with_references(tmp_path, capsys):
    t = np.arange(400) * 0.005
    R = constant_rate_attitudes(t)
    v = np.array([[0.0, 0.0, 9.83], [-0.9, 15.5, -41.3]])  # gravity reaction and magnetic field (ENU)
    b = np.einsum("nji,kj->nki", R, v)  # b_k = Rᵀ v_k, unnormalised like real sensors
    src, dst = tmp_path / "dirs.npz", tmp_path / "out.csv"
    np.savez(src, t=t, b=b)
    code, _, err = run_cli(
        capsys, "estimate", src, "-o", dst, "--references=0,0,9.83;-0.9,15.5,-41.3", "--bandwidth", "8"
    )
    assert code == 0, err
    np.testing.assert_allclose(read_output(dst)[-50:, 1:], np.broadcast_to(OMEGA, (50, 3)), atol=1e-8)


def test_known_torque_and_inertia(tmp_path, capsys):
    # Truth from the CF4 ground-truth integrator (tested against closed forms and DOP853 in test_rigid_body).
    J = np.array([3.0, 2.0, 1.0])
    tau = np.array([0.3, -0.2, 0.1])
    t = np.arange(1001) * 0.002  # 500 Hz, 2 s
    truth = integrate(RigidBody(J), np.eye(3), [2.0, -1.0, 0.6], t, torque=Torque.constant(tau), max_step=1e-3)
    q = Rotation.from_matrix(truth.R).as_quat()
    rows = ["t,qx,qy,qz,qw,tau_x,tau_y,tau_z"] + [
        ",".join(repr(float(x)) for x in (t[k], *q[k], *tau)) for k in range(t.size)
    ]
    src, dst = tmp_path / "tq.csv", tmp_path / "out.csv"
    src.write_text("\n".join(rows) + "\n")
    code, _, err = run_cli(capsys, "estimate", src, "-o", dst, "--inertia", "3", "2", "1", "--bandwidth", "16")
    assert code == 0, err
    w = read_output(dst)[:, 1:]
    err_end = np.abs(w[-250:] - truth.omega[-250:]).max()
    # With the right J and τ the model error is only the sampling: 1e-4 rad/s is 1e-4 of |ω| ≈ 2.3 rad/s.
    assert err_end < 1e-4
    # Without the torque (wrong model) the estimate lags visibly: the CLI really passed the torque.
    src_no = tmp_path / "notq.csv"
    src_no.write_text("\n".join(line.rsplit(",", 3)[0] for line in rows) + "\n")
    code, _, _ = run_cli(capsys, "estimate", src_no, "-o", dst, "--inertia", "3", "2", "1", "--bandwidth", "16")
    assert code == 0
    assert np.abs(read_output(dst)[-250:, 1:] - truth.omega[-250:]).max() > 10 * err_end


def test_with_the_inertia_the_default_estimator_is_the_supervised_kalman(tmp_path, capsys):
    """A 5 Hz star tracker (10 arcsec) on a spacecraft with known inertia and torque: given --inertia, the command
    uses the observer supervising the EKF of the model it identified (it says so, with why) and beats the
    fixed-gain observer it would otherwise use (--estimator sarras) against the CF4 truth."""
    J = np.array([300.0, 250.0, 200.0])
    tau = np.array([0.5, 0.0, -0.2])
    t = np.arange(0.0, 200.0, 0.2)
    truth = integrate(RigidBody(J), np.eye(3), [0.01, -0.02, 0.015], t, torque=Torque.constant(tau), max_step=0.01)
    sigma = np.radians(10 / 3600)
    noise = Rotation.from_rotvec(np.random.default_rng(3).normal(0.0, sigma, (t.size, 3)))
    q = (Rotation.from_matrix(truth.R) * noise).as_quat()
    rows = ["t,qx,qy,qz,qw,tau_x,tau_y,tau_z"] + [
        ",".join(repr(float(x)) for x in (t[k], *q[k], *tau)) for k in range(t.size)
    ]
    src, dst = tmp_path / "st.csv", tmp_path / "out.csv"
    src.write_text("\n".join(rows) + "\n")
    errors = {}
    for choice in ("auto", "sarras"):
        code, out, err = run_cli(
            capsys, "estimate", src, "-o", dst, "--inertia", *J, "--estimator", choice, "--no-progress"
        )
        assert code == 0, err
        assert ("the model's filter runs" in out and "estimator used: omegahat (observer at" in out) == (
            choice == "auto"
        )  # the identified model's supervised EKF, said with why
        w = read_output(dst)[:, 1:]
        errors[choice] = np.sqrt(np.mean((w[t >= 100.0] - truth.omega[t >= 100.0]) ** 2))
    assert re.search(r"rate noise [0-9.e+-]+ rad/s\^1\.5, chosen from the log", out) is None  # only for auto
    assert errors["auto"] < 0.5 * errors["sarras"]


def test_progress_bar_on_request(tmp_path, capsys):
    t = np.arange(50) * 0.01
    src, dst = tmp_path / "in.csv", tmp_path / "out.csv"
    write_quaternion_csv(src, t, constant_rate_attitudes(t))
    code, _, err = run_cli(capsys, "estimate", src, "-o", dst, "--progress")
    assert code == 0
    assert "estimating" in err
    assert "100%" in err


# ----------------------------------------------------------------------------------------------- errors


@pytest.fixture
def good_csv(tmp_path):
    t = np.arange(20) * 0.01
    p = tmp_path / "good.csv"
    write_quaternion_csv(p, t, constant_rate_attitudes(t))
    return p


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--k", "10"], r"--k and --l go together"),
        (["--k", "10", "--l", "1", "--bandwidth", "5"], r"either --bandwidth or --k and --l, not both"),
        (["--k", "1", "2", "--l", "1"], r"--k takes one number or 3 \(one per direction\); got 2"),
        (["--k", "-1", "--l", "1"], r"k must be positive and finite"),
        (["--bandwidth", "-5"], r"--bandwidth must be a positive number of Hz; got -5\.0"),
        (["--inertia", "1", "2"], r"--inertia must be 3 numbers \(diagonal\), 9 numbers or a 3x3 matrix"),
        (["--inertia", "1", "-1", "1"], r"--inertia must be positive definite"),
        (["--references=0,0,1;0,0,2"], r"--references are nearly collinear"),
    ],
)
def test_bad_options_exit_2_with_a_message(good_csv, tmp_path, capsys, extra, match):
    code, _, err = run_cli(capsys, "estimate", good_csv, "-o", tmp_path / "o.csv", *extra)
    assert code == 2
    assert err.startswith("omegahat estimate: error: ")
    assert re.search(match, err), err
    assert not (tmp_path / "o.csv").exists()


def test_bad_csv_names_line_and_column(tmp_path, capsys):
    src = tmp_path / "bad.csv"
    src.write_text("t,qw,qx,qy,qz\n0,1,0,0,0\n0.1,1,zero,0,0\n")
    code, _, err = run_cli(capsys, "estimate", src, "-o", tmp_path / "o.csv")
    assert code == 2
    assert "bad.csv, line 3, column qx: 'zero' is not a number" in err


def test_missing_input_and_unwritable_output(good_csv, tmp_path, capsys):
    code, _, err = run_cli(capsys, "estimate", tmp_path / "none.csv", "-o", tmp_path / "o.csv")
    assert code == 2
    assert "No such file or directory" in err and "none.csv" in err
    code, _, err = run_cli(capsys, "estimate", good_csv, "-o", tmp_path / "no_dir" / "o.csv")
    assert code == 2
    assert "no_dir" in err


def test_non_unit_quaternion_is_rejected_naming_the_sample(tmp_path, capsys):
    src = tmp_path / "q.csv"
    src.write_text("t,qw,qx,qy,qz\n0,1,0,0,0\n0.1,2,0,0,0\n")
    code, _, err = run_cli(capsys, "estimate", src, "-o", tmp_path / "o.csv")
    assert code == 2
    assert "q.csv, line 3, columns qw,qx,qy,qz: a quaternion far from unit norm: |q| = 2" in err
    assert "--quat-norm-tol" in err and "--skip-bad-samples" in err


def test_direction_input_needs_matching_references(tmp_path, capsys):
    src = tmp_path / "d.npz"
    np.savez(src, t=np.arange(3.0), b=np.tile(np.eye(3)[:2], (3, 1, 1)))
    code, _, err = run_cli(capsys, "estimate", src, "-o", tmp_path / "o.csv")
    assert code == 2
    assert 'holds 2 body-frame directions (b1..b2): give their inertial directions with "--references=X,Y,Z' in err
    code, _, err = run_cli(capsys, "estimate", src, "-o", tmp_path / "o.csv", "--references=1,0,0")
    assert code == 2
    assert "holds 2 directions but --references gives 1" in err


def test_unparsable_reference_is_an_argparse_error(good_csv, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["estimate", str(good_csv), "-o", str(tmp_path / "o.csv"), "--references=1,0,0;1,2"])
    assert exc.value.code == 2
    assert "a reference direction is 3 numbers x,y,z; got '1,2'" in capsys.readouterr().err


def test_output_option_is_required(good_csv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["estimate", str(good_csv)])
    assert exc.value.code == 2
    assert "-o/--output" in capsys.readouterr().err


def test_fit_start_is_the_default_warm_and_zero_on_request(tmp_path, capsys):
    t = np.arange(50) * 0.01
    src = tmp_path / "in.npz"
    np.savez(src, t=t, R=constant_rate_attitudes(t))
    fit, warm, cold = tmp_path / "fit.csv", tmp_path / "warm.csv", tmp_path / "cold.csv"
    assert run_cli(capsys, "estimate", src, "-o", fit)[0] == 0
    assert run_cli(capsys, "estimate", src, "-o", warm, "--warm-start")[0] == 0
    assert run_cli(capsys, "estimate", src, "-o", cold, "--no-warm-start", "--bandwidth", "1")[0] == 0
    # fit: the least-squares rate of the first window is exact at constant rate, from the first row on
    np.testing.assert_allclose(read_output(fit)[:, 1:], np.broadcast_to(OMEGA, (50, 3)), atol=1e-12)
    # warm: exact from the second sample on; the first has no estimate (nan, never 0)
    w_warm = read_output(warm)
    assert np.all(np.isnan(w_warm[0, 1:]))
    np.testing.assert_allclose(w_warm[1:, 1:], np.broadcast_to(OMEGA, (49, 3)), atol=1e-12)
    # zero: starts from rest and converges at the gains' rate (1 Hz: slowly)
    w_cold = read_output(cold)
    assert np.all(np.isnan(w_cold[0, 1:]))
    assert np.linalg.norm(w_cold[1, 1:] - OMEGA) > 0.1 * np.linalg.norm(OMEGA)


def test_a_chunk_without_a_valid_sample_after_the_first_estimate(tmp_path, capsys):
    """Found by the fuzz test: duplicated and missing rows around a few valid ones; the last chunk held no valid
    sample once the estimate existed, and the command failed with an IndexError. Expected: every kept row, the
    missing one predicted (a constant attitude: zero rate)."""
    src, dst = tmp_path / "fz.csv", tmp_path / "out.csv"
    src.write_text(
        "qw,qx,qy,qz,t,note\n,,,,0.01,ok\n,,,,0.01,ok\n1.0,0.0,0.0,0.0,0.01,ok\n1.0,0.0,0.0,0.0,0.02,ok\n"
        "1.0,0.0,0.0,0.0,0.03,ok\n,,,,0.04,ok\n"
    )
    code, out, err = run_cli(capsys, "estimate", src, "-o", dst, "--no-progress")
    assert code == 0, err
    assert "skipped 1 of 4 samples (1 missing" in out
    assert dst.read_text().splitlines()[1:] == [
        "0.01,0,0,0,corrected", "0.02,0,0,0,corrected", "0.03,0,0,0,corrected", "0.04,0,0,0,predicted"
    ]  # fmt: skip
