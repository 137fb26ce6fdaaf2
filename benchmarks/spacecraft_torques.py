"""A star tracker's attitudes and the controller's commanded torques: what each way of estimating the rate gives.

Run: ``python benchmarks/spacecraft_torques.py`` (about a minute). Writes its section of ``benchmarks/RESULTS.md``.

The plant (``tests/spacecraft.py``): a spacecraft (J = diag(300, 250, 200) kg m²) slewing for 600 s under torques
its controller commands every 0.1 s and holds (a bang-bang slew about x, slow sinusoids about y and z, 0.05 N m),
integrated by SciPy's ``solve_ivp`` over each command's interval. Its attitude is seen by a star tracker at 1, 2 and
10 Hz with 1e-5 or 5e-5 rad of noise per axis (2 and 10 arcsec), written as a CCSDS AEM; the commands are a CSV on
the same clock. Each method's RMS error (rad/s) over the last two thirds of the log:

* backward differencing of the attitudes (:class:`omegahat.DifferencingEstimator`);
* ``omegahat estimate`` by default (no inertia), with ``--inertia``, with ``--inertia --torque``, and the same with
  ``--smooth``.
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import spacecraft  # noqa: E402
from logmaker import noisy  # noqa: E402
from omegahat import DifferencingEstimator  # noqa: E402
from omegahat.cli import main  # noqa: E402
from omegahat.io import read_log  # noqa: E402
from results_md import machine_line, write_section  # noqa: E402

SECTION = "## A star tracker and the commanded torques (benchmarks/spacecraft_torques.py)"
SECONDS = 600.0
RATES_HZ = (1.0, 2.0, 10.0)
NOISES = (1e-5, 5e-5)
INERTIA = ("--inertia", "300", "250", "200")


def estimate(aem: Path, folder: Path, *options: str) -> np.ndarray:
    """The rates of ``omegahat estimate aem *options`` ``(T, 3)`` (its messages swallowed)."""
    out = folder / "omega.csv"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        if main(["estimate", str(aem), "-o", str(out), "--no-progress", *options]) != 0:
            raise RuntimeError(f"omegahat estimate {aem} {' '.join(options)} failed")
    return np.loadtxt(out, delimiter=",", skiprows=1, usecols=(1, 2, 3), ndmin=2)


def rms(w: np.ndarray, truth: np.ndarray) -> float:
    late = slice(len(truth) // 3, None)
    return float(np.sqrt(np.mean(np.sum((w[late] - truth[late]) ** 2, axis=1))))


def main_() -> int:
    start = time.perf_counter()
    command_t, tau = spacecraft.commands(SECONDS)
    fine = np.arange(0.0, SECONDS - 0.5, 1.0 / max(RATES_HZ))  # every rate's samples are among these
    attitude, w = spacecraft.slew(fine, command_t, tau)
    rows = []
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        torques = spacecraft.write_torques(folder / "cmd.csv", spacecraft.EPOCH_NS * 1e-9 + command_t, tau)
        for hz in RATES_HZ:
            pick = slice(None, None, round(max(RATES_HZ) / hz))
            for sigma in NOISES:
                seen = noisy(attitude[pick], sigma, seed=int(hz * 10))
                aem = spacecraft.write_aem(folder / "st.aem", fine[pick], seen)
                log = read_log(aem)
                cells = [
                    rms(DifferencingEstimator().run(log.t, log.data).omega, w[pick]),
                    rms(estimate(aem, folder), w[pick]),
                    rms(estimate(aem, folder, *INERTIA), w[pick]),
                    rms(estimate(aem, folder, *INERTIA, "--torque", str(torques)), w[pick]),
                    rms(estimate(aem, folder, *INERTIA, "--torque", str(torques), "--smooth"), w[pick]),
                ]
                line = f"| {hz:g} Hz | {sigma:.0e} rad | " + " | ".join(f"{c:.2e}" for c in cells) + " |"
                print(line, flush=True)
                rows.append(line)
    speed = float(np.sqrt(np.mean(np.sum(w**2, axis=1))))
    body = "\n".join(
        [
            "Command: `python benchmarks/spacecraft_torques.py`.",
            machine_line(),
            "",
            f"RMS error (rad/s) over the last two thirds of a 600 s slew (the body turning at {speed:.3g} rad/s RMS), "
            "torques commanded every 0.1 s and held; the star tracker's noise per axis.",
            "",
            "| star tracker | noise | backward differencing | default | `--inertia` | `--inertia --torque` "
            "| `--inertia --torque --smooth` |",
            "| --- | --- | ---: | ---: | ---: | ---: | ---: |",
            *rows,
            "",
            f"{time.perf_counter() - start:.0f} s in all.",
        ]
    )
    write_section(SECTION, body)
    return 0


if __name__ == "__main__":
    sys.exit(main_())
