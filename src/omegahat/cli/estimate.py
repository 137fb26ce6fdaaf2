"""``omegahat estimate INPUT -o OUTPUT``: angular velocity from an attitude (or direction) log.

Reads a CSV or NPZ log (:mod:`omegahat.io`: columns ``t`` and ``qw,qx,qy,qz`` or ``r11..r33`` or
``b1x,b1y,b1z,b2x,...``, optional ``tau_x,tau_y,tau_z``), runs the sampled Sarras estimator
(:class:`omegahat.observer.estimator.SarrasEstimator`) over it, causally, and writes ``t,wx,wy,wz`` (rad/s, body axes).

Gains: either ``--k`` and ``--l`` (one number for all directions or one per direction), or ``--bandwidth b``
(rad/s): equal ``k_i = b · (tr J / 3) / μ₁`` with ``μ₁ = λ_min(Σ_i (I − v_i v_iᵀ))`` the geometry factor of the
unit inertial directions (2 for the three rows of R, so ``k = b tr(J)/6`` as ``omegahat compare`` uses), and
``l_i = 10 b``: the linearised error then decays at about b rad/s. The default, 450 rad/s, is the bandwidth
chosen on BROAD trial 01 (285.7 Hz, ``benchmarks/real_data.py``); lower it for noisy or slow logs.

Attitude input uses the three rows of R unless ``--references`` names other inertial directions; direction
input needs ``--references=x,y,z;x,y,z;...`` (one triple per direction, in the order b1, b2, ...; write it
with ``=`` so that a leading minus sign is not taken for an option). Missing samples (empty
fields, NaN) are skipped and predicted through; the count is reported.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
from tqdm import tqdm

from omegahat.cli import recording_options
from omegahat.observer.estimator import SarrasEstimator, SkippedSamplesWarning
from omegahat.observer.gains import ObserverGains
from omegahat.observer.tuning import bandwidth_gains
from omegahat.validation import as_directions, as_inertia

HELP = "Estimate the angular velocity from an attitude log (CSV or NPZ) and write t,wx,wy,wz."

DEFAULT_BANDWIDTH = 450.0  # rad/s, chosen on BROAD trial 01 (benchmarks/real_data.py)
L_PER_BANDWIDTH = 10.0  # l_i = 10 b, as omegahat compare
PROGRESS_MIN_SAMPLES = 100_000  # show a progress bar from this many samples on (unless told otherwise)
CHUNK = 20_000  # samples per estimator call when a progress bar is shown


def _numbers(text: str) -> list[float]:
    try:
        values = [float(x) for x in text.replace(",", " ").split()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected numbers, got {text!r}") from None
    if not values:
        raise argparse.ArgumentTypeError("expected numbers, got nothing")
    return values


def _directions(text: str) -> list[list[float]]:
    """``"x,y,z;x,y,z;..."`` → one 3-vector per ``;``-separated direction."""
    out = []
    for part in text.split(";"):
        v = _numbers(part)
        if len(v) != 3:
            raise argparse.ArgumentTypeError(f"a reference direction is 3 numbers x,y,z; got {part.strip()!r}")
        out.append(v)
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", type=Path, metavar="INPUT", help=recording_options.INPUT_HELP)
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        required=True,
        help="output: .csv (t,wx,wy,wz); for a bag input also .bag (ROS 1) or a name without extension (ROS 2)",
    )
    parser.add_argument(
        "--inertia",
        type=float,
        nargs="+",
        metavar="J",
        help="inertia: 3 numbers (diagonal) or 9 (row-major); default identity",
    )
    parser.add_argument("--k", type=float, nargs="+", help="gain k_i: one number or one per direction")
    parser.add_argument("--l", type=float, nargs="+", help="gain l_i: one number or one per direction")
    parser.add_argument(
        "--bandwidth",
        type=float,
        metavar="B",
        help=f"error decay rate in rad/s, sets k and l (default {DEFAULT_BANDWIDTH:g})",
    )
    parser.add_argument(
        "--references",
        type=_directions,
        metavar="X,Y,Z;X,Y,Z",
        help="known inertial directions, ';' between directions, written with '=' "
        "(--references=0,0,9.8;-0.9,15.5,-41.3) so a leading minus is not read as an "
        "option; required for b1x.. direction input; for attitude input default: the "
        "three inertial axes, i.e. the rows of R",
    )
    warm = parser.add_mutually_exclusive_group()
    warm.add_argument(
        "--warm-start",
        dest="warm_start",
        action="store_true",
        default=True,
        help="start the rate from the first two valid samples (default)",
    )
    warm.add_argument(
        "--no-warm-start",
        dest="warm_start",
        action="store_false",
        help="start from omega_hat = 0 and let the observer converge at its gains' rate",
    )
    bar = parser.add_mutually_exclusive_group()
    bar.add_argument(
        "--progress",
        dest="progress",
        action="store_true",
        default=None,
        help=f"always show a progress bar (default: from {PROGRESS_MIN_SAMPLES} samples on)",
    )
    bar.add_argument("--no-progress", dest="progress", action="store_false", help="never show one")
    recording_options.add_arguments(parser)  # bags, Motive/Vicon/C3D exports: omegahat.io (issue 15)


def _per_direction(values, n: int, name: str) -> np.ndarray:
    a = np.asarray(values, dtype=float)
    if a.size == 1:
        a = np.full(n, a.item())
    if a.shape != (n,):
        raise ValueError(f"--{name} takes one number or {n} (one per direction); got {a.size}: {values}")
    return a


def _gains(args, J, references) -> ObserverGains:
    n = references.shape[0]
    if args.bandwidth is not None and (args.k is not None or args.l is not None):
        raise ValueError("give either --bandwidth or --k and --l, not both")
    if (args.k is None) != (args.l is None):
        raise ValueError("--k and --l go together (or use --bandwidth)")
    if args.k is None:
        b = DEFAULT_BANDWIDTH if args.bandwidth is None else args.bandwidth
        if not (np.isfinite(b) and b > 0):
            raise ValueError(f"--bandwidth must be a positive number of rad/s; got {b!r}")
        return bandwidth_gains(J, b, references, L_PER_BANDWIDTH)
    return ObserverGains(k=_per_direction(args.k, n, "k"), l_offset=_per_direction(args.l, n, "l"))


def _references(args, log) -> np.ndarray:
    if log.kind == "directions":
        n = log.data.shape[1]
        if args.references is None:
            raise ValueError(
                f"{log.source} holds {n} body-frame directions (b1..b{n}): give their inertial "
                f"directions with --references X,Y,Z (one per direction)"
            )
        if len(args.references) != n:
            raise ValueError(f"{log.source} holds {n} directions but --references gives {len(args.references)}")
    if args.references is None:
        return np.eye(3)
    return as_directions(np.array(args.references), name="--references")


def run(args) -> int:
    show = args.progress
    size = args.input.stat().st_size if args.input.exists() else 0
    with tqdm(
        total=size,
        unit="B",
        unit_scale=True,
        desc="reading",
        disable=not (show or (show is None and size > 40 * PROGRESS_MIN_SAMPLES)),
        file=sys.stderr,
    ) as bar:

        def progress(done, total):
            bar.total = total
            bar.n = done
            bar.refresh()

        recording = recording_options.read_input(args, progress=progress)
    log = recording.log
    J = np.eye(3) if args.inertia is None else as_inertia(np.array(args.inertia), name="--inertia")
    references = _references(args, log)
    gains = _gains(args, J, references)
    measurement = "directions" if log.kind == "directions" else "attitude"
    estimator = SarrasEstimator(
        J, gains=gains, references=references, measurement=measurement, warm_start=args.warm_start
    )

    T = log.t.size
    show_run = show if show is not None else T >= PROGRESS_MIN_SAMPLES
    W = np.empty((T, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SkippedSamplesWarning)  # reported below, once
        with tqdm(total=T, unit="sample", desc="estimating", disable=not show_run, file=sys.stderr) as bar:
            for a in range(0, T, CHUNK):  # run() continues from the current state: chunks = one pass
                b = min(T, a + CHUNK)
                tau = None if log.torque is None else log.torque[a:b]
                W[a:b] = estimator.run(log.t[a:b], log.data[a:b], tau)
                bar.update(b - a)
    recording_options.write_output(args, recording, W)
    skipped = estimator.n_missing + estimator.n_collinear
    k_text = np.array2string(gains.k, precision=4)
    l_text = np.array2string(gains.l_offset, precision=4)
    print(f"wrote {T} estimates to {args.output} (k = {k_text}, l = {l_text}, J diag = {np.diag(J).tolist()})")
    if skipped:
        print(
            f"skipped {skipped} of {T} samples ({estimator.n_missing} missing, {estimator.n_collinear} with "
            "nearly collinear directions): predicted through"
        )
    return 0
