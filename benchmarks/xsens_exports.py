"""Real Xsens MT Manager exports: the rates from the orientation as read, against the export's own gyroscope.

Run: ``python benchmarks/xsens_exports.py PATH... [--rate HZ]`` with MT Manager exports holding an orientation
beside ``Gyr_X..Z`` (for instance local copies of public repositories' exports; they are not part of this
repository). ``--rate`` gives the rate of exports that do not state it. Writes its section of
``benchmarks/RESULTS.md``; nothing is written without exports.

What it checks is the **reader's convention** (:mod:`omegahat.io.xsens`): that the orientation maps the sensor's axes
into the global frame, so that the rate comes out in the sensor's axes, those of the gyroscope. The table gives the
RMS difference (vector norm) from ``Gyr_X..Z`` of the default ``omegahat estimate``'s rates, of backward differencing
of the orientation as read (``log(R_{k−1}ᵀ R_k) / Δt``), and of the same differencing of the transposes (the other
convention), beside the gyroscope's own RMS. MT Manager computed the orientation from these gyroscopes (with the
accelerometers and magnetometers), so this checks frames and conventions, not accuracy against an independent
sensor.
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

SECTION = "## Real Xsens MT Manager exports against their gyroscope (benchmarks/xsens_exports.py)"


def rms(x: np.ndarray) -> float:
    """RMS of the rows' norms, over the rows without NaN."""
    x = x[np.all(np.isfinite(x), axis=1)]
    return float(np.sqrt(np.mean(np.sum(x**2, axis=1))))


def backward(t: np.ndarray, R: Rotation) -> np.ndarray:
    """``log(R_{k−1}ᵀ R_k) / Δt`` at ``t_k`` (k ≥ 1), in the sensor's axes."""
    return (R[:-1].inv() * R[1:]).as_rotvec() / np.diff(t)[:, None]


def one(path: Path, rate: float | None, folder: Path) -> list[str] | None:
    if not path.is_file():
        print(f"{path}: no such file: skipped")
        return None
    options = {} if rate is None else {"rate": rate}
    log = read_log(path, **options)
    if log.format != "xsens" or log.extra is None or "reference_rate" not in log.extra:
        print(f"{path}: not an Xsens export with Gyr_X..Z: skipped")
        return None
    out = folder / "omega.csv"
    given = [] if rate is None else ["--rate", f"{rate:g}"]
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        if main(["estimate", str(path), "-o", str(out), "--no-progress", *given]) != 0:
            raise RuntimeError(f"omegahat estimate {path} failed")
    w = np.loadtxt(out, delimiter=",", skiprows=1, usecols=(1, 2, 3), ndmin=2)
    gyro = log.extra["reference_rate"]
    R = Rotation.from_quat(log.data) if log.kind == "quaternion" else Rotation.from_matrix(log.data)
    return [
        path.name,
        str(log.t.size),
        f"{1 / np.median(np.diff(log.t)):.4g}",
        f"{rms(w - gyro):.2g}",
        f"{rms(backward(log.t, R) - gyro[1:]):.2g}",
        f"{rms(backward(log.t, R.inv()) - gyro[1:]):.2g}",
        f"{rms(gyro):.2g}",
    ]


def run(paths: list[Path], rate: float | None) -> None:
    rows = rows_of_files(paths, lambda path, folder: one(path, rate, folder))
    if not rows:
        print("no Xsens exports with a gyroscope: nothing written")
        return
    given = "" if rate is None else f" --rate {rate:g}"
    write_table(
        SECTION,
        f"python benchmarks/xsens_exports.py PATH...{given}",
        "(exports given on the command line, not part of this repository). The rates from the orientation as read"
        " against the export's gyroscope, from which MT Manager computed that orientation (module docstring): the"
        " reader's convention agrees where the differences are small beside the gyroscope's RMS and the transposed"
        " one's are not.",
        ["export", "samples", "Hz", "default − gyroscope, RMS (rad/s)", "backward differencing − gyroscope",
         "the same, transposed", "gyroscope, RMS (rad/s)"],
        rows,
    )  # fmt: skip


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("paths", nargs="+", type=Path)
    parser.add_argument("--rate", type=float, help="Hz, for exports that do not state their rate")
    args = parser.parse_args()
    sys.exit(run(args.paths, args.rate))
