"""A body that never rests and moves up to (and past) the Nyquist frequency: where the noise estimate fails.

Run: ``python benchmarks/broadband.py``. Writes its section of RESULTS.md.

A log like the held-out ones of ``real_world.py --heldout`` (RING's chain: motion up to the Nyquist frequency at
30 Hz), made here so that a correction can be developed without them. The rate is white noise shaped flat up to
``f_max`` (a fourth-order roll-off beyond), 1.5 rad/s RMS about a constant rate (so the body never rests). It is
integrated on a 1.2 kHz grid by SciPy's rotations (midpoint rule), sampled at 30 Hz and given white attitude noise
of 0.5 mrad per axis. Scored as the real recordings (:func:`omegahat.lab.evaluation.corpus.evaluate`, against the
true rate), with the noise the spectrum assumed (:func:`omegahat.identification.spectral.increment_spectrum`)
beside the true one.
"""

from __future__ import annotations

import sys
import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.identification.spectral import increment_spectrum
from omegahat.lab.evaluation.corpus import METHODS, Recording, evaluate
from results_md import machine_line, write_section

SECTION = "## A body that never rests, moving up to the Nyquist frequency (benchmarks/broadband.py)"
FINE_HZ, RATE_HZ, DURATION_S, NOISE_RAD = 1200.0, 30.0, 60.0, 5e-4
CASES = ((0, 6.0), (1, 10.0), (2, 16.0), (3, 16.0))  #: (seed, f_max in Hz)
SHOWN = ("backward diff.", "central diff.", "RotationSpline", "omegahat estimate", "omegahat estimate --smooth")


def broadband_log(seed: int, f_max: float) -> Recording:
    """The log of the module docstring."""
    rng = np.random.default_rng(seed)
    n = int(DURATION_S * FINE_HZ)
    t_fine = np.arange(n) / FINE_HZ
    spectrum = np.fft.rfft(rng.standard_normal((n, 3)), axis=0)
    spectrum *= (1.0 / (1.0 + (np.fft.rfftfreq(n, 1 / FINE_HZ) / f_max) ** 4))[:, None]
    rate = np.fft.irfft(spectrum, n=n, axis=0)
    rate *= 1.5 / rate.std()
    rate += np.array([0.3, -0.2, 0.5])
    steps = Rotation.from_rotvec(0.5 * (rate[1:] + rate[:-1]) / FINE_HZ)
    attitude = [Rotation.identity()]
    for step in steps:
        attitude.append(attitude[-1] * step)
    every = int(FINE_HZ / RATE_HZ)
    sampled = Rotation.concatenate(attitude[::every])
    noisy = sampled * Rotation.from_rotvec(NOISE_RAD * rng.standard_normal((len(sampled), 3)))
    t = t_fine[::every]
    return Recording(f"broadband-{seed}", t, "quaternion", noisy.as_quat(), t_fine, rate, np.ones(t.size, bool), {})


def main() -> int:
    warnings.simplefilter("ignore")
    methods = [m for m in METHODS if m.name in SHOWN]
    lines = [
        "| seed | f_max (Hz) | noise assumed (mrad, per axis) | "
        + " | ".join(f"{m} ÷ backward" for m in SHOWN[1:])
        + " |",
        "| ---: | ---: | --- | " + " | ".join("---:" for _ in SHOWN[1:]) + " |",
    ]
    for seed, f_max in CASES:
        rec = broadband_log(seed, f_max)
        sigma = increment_spectrum(rec.t, rec.R, ~rec.gaps).sigma
        rows = {row.method: row.score.rms for row in evaluate(rec, methods) if row.score is not None}
        ratios = " | ".join(f"{rows[m] / rows['backward diff.']:.3f}" for m in SHOWN[1:])
        lines.append(f"| {seed} | {f_max:g} | {', '.join(f'{1e3 * s:.2g}' for s in sigma)} | {ratios} |")
        print(lines[-1], flush=True)
    intro = (
        f"{machine_line()} Command: `python benchmarks/broadband.py`. 30 Hz, {1e3 * NOISE_RAD:g} mrad of true noise "
        "per axis; every method's RMS error against the true rate (the fair score, low-passed at 10 Hz) over "
        "backward differencing's."
    )
    write_section(SECTION, intro + "\n\n" + "\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
