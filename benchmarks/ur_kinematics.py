"""Real Universal Robots recordings: the tool's rotation as read, against the arm's own joint angles.

Run: ``python benchmarks/ur_kinematics.py PATH... [--rate HZ]`` with RTDE recordings holding ``actual_q_0..5`` beside
``actual_TCP_pose_0..5`` (for instance local copies of public repositories' recordings; they are not part of this
repository). ``--rate`` gives the rate of recordings without a time column. Writes its section of
``benchmarks/RESULTS.md``; nothing is written without recordings.

What it checks is the **reader's convention** (:mod:`omegahat.io.ur_rtde`): that ``R = exp(φ×)`` of the pose's
rotation vector maps the tool's axes into the base's, so that the rate comes out in the tool's axes. The joint angles
give the same rotation independently of the file's rotation vector: every Universal Robots arm's kinematic chain
turns about its joint axes and twists by ``α = (90°, 0, 0, 90°, −90°, 0)`` between them (its link lengths move the
tool, they do not turn it), so ``R_q = Π_i Rz(q_i) Rx(α_i)``, base to tool flange. The table gives, after one
constant rotation (the flange-to-tool offset), the largest angle between ``R_q`` and the rotations as read, and
between ``R_q`` and their transposes (the other convention); and the RMS difference between the default
``omegahat estimate``'s rates and the rates of ``R_q`` differenced the same way (backward, in the tool's axes),
beside the rates' own RMS. The joint angles come from the same encoders, so this is a check of frames and
conventions, not of accuracy against an independent sensor.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.cli import main
from omegahat.io import read_log
from results_md import rows_of_files, write_table

SECTION = "## Real Universal Robots recordings against the arm's joint angles (benchmarks/ur_kinematics.py)"
TWISTS = (np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0)  # α_i of every UR arm's chain


def joint_rotations(q: np.ndarray) -> np.ndarray:
    """``R_q (T, 3, 3)``: base to tool flange, ``Π_i Rz(q_i) Rx(α_i)``."""
    R = np.tile(np.eye(3), (q.shape[0], 1, 1))
    for i, alpha in enumerate(TWISTS):
        R = (
            R
            @ Rotation.from_rotvec(np.outer(q[:, i], [0.0, 0.0, 1.0])).as_matrix()
            @ Rotation.from_euler("x", alpha).as_matrix()
        )
    return R


def misfit(R_q: np.ndarray, R: np.ndarray) -> float:
    """The largest angle (rad) between ``R_q · C`` and ``R``, ``C`` the constant offset at the first sample."""
    C = R_q[0].T @ R[0]
    return float(np.max(Rotation.from_matrix(R_q @ C @ np.swapaxes(R, 1, 2)).magnitude()))


def backward_rates(t: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``log(R_{k−1}ᵀ R_k) / Δt`` at ``t_k`` (k ≥ 1), in the body's axes."""
    steps = Rotation.from_matrix(np.swapaxes(R[:-1], 1, 2) @ R[1:]).as_rotvec()
    return steps / np.diff(t)[:, None]


def one(path: Path, rate: float | None, folder: Path) -> list[str] | None:
    if not path.is_file():
        print(f"{path}: no such file: skipped")
        return None
    with open(path) as f:
        header = f.readline()
    delimiter = "," if "," in header else None  # ur_rtde's CSV, or record.py's blanks
    names = header.replace(",", " ").split()
    joints = [names.index(f"actual_q_{i}") for i in range(6)] if "actual_q_5" in names else None
    if joints is None:
        print(f"{path}: no actual_q_0..5 columns: skipped")
        return None
    options = [] if rate is None else [
        "--columns", ",".join(f"rotvec_{a}=actual_TCP_pose_{k}" for a, k in zip("xyz", (3, 4, 5), strict=True)),
        "--rate", f"{rate:g}",
    ]  # fmt: skip
    log = read_log(path) if rate is None else read_log(path, columns=options[1], rate=rate)
    q = np.loadtxt(path, skiprows=1, usecols=joints, delimiter=delimiter, ndmin=2)
    R_q = joint_rotations(q)
    out = folder / "omega.csv"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        if main(["estimate", str(path), "-o", str(out), "--no-progress", *options]) != 0:
            raise RuntimeError(f"omegahat estimate {path} failed")
    w = np.loadtxt(out, delimiter=",", skiprows=1, usecols=(1, 2, 3), ndmin=2)
    t = log.t
    w_q = backward_rates(t, R_q @ (R_q[0].T @ log.data[0]))
    diff = w[1:] - w_q
    turned = float(np.max(Rotation.from_matrix(np.swapaxes(log.data[:1], 1, 2) @ log.data).magnitude()))
    return [
        path.name,
        str(t.size),
        f"{1 / np.median(np.diff(t)):.4g}",
        f"{np.degrees(turned):.0f}",
        f"{misfit(R_q, log.data):.2g}",
        f"{misfit(R_q, np.swapaxes(log.data, 1, 2)):.2g}",
        f"{np.sqrt(np.mean(np.sum(diff**2, axis=1))):.2g}",
        f"{np.sqrt(np.mean(np.sum(w_q**2, axis=1))):.2g}",
    ]


def run(paths: list[Path], rate: float | None) -> None:
    rows = rows_of_files(paths, lambda path, folder: one(path, rate, folder))
    if not rows:
        print("no recordings with joint angles: nothing written")
        return
    given = "" if rate is None else f" --rate {rate:g}"
    write_table(
        SECTION,
        f"python benchmarks/ur_kinematics.py PATH...{given}",
        "(recordings given on the command line, not part of this repository). The rotations as read against the"
        " joint angles' kinematic chain (module docstring): the reader's convention agrees where the first angle is"
        " small and the transposed one is not.",
        ["recording", "samples", "Hz", "turned (deg)", "largest angle to the joints' rotation (rad)",
         "the same, transposed (rad)", "default's rates − joints' rates, RMS (rad/s)", "joints' rates, RMS (rad/s)"],
        rows,
    )  # fmt: skip


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("paths", nargs="+", type=Path)
    parser.add_argument("--rate", type=float, help="Hz, for recordings without a time column")
    args = parser.parse_args()
    sys.exit(run(args.paths, args.rate))
