"""Build the development corpus of issue 24 from local copies of public recordings and an independent plant.

Run: ``python benchmarks/corpus.py SRC_DIR OUT_DIR [--only broad upenn plant]`` (a few minutes on 2 cores), then
``OMEGAHAT_CORPUS_DIR=OUT_DIR python benchmarks/real_world.py``. Nothing of the data is committed; each recording
becomes ``OUT_DIR/NAME.npz`` (:mod:`omegahat.lab.evaluation.corpus`: an omegahat NPZ log, so ``omegahat estimate
OUT_DIR/NAME.npz -o out.csv`` runs on it, plus its reference rate), and ``OUT_DIR/NOTICE.md`` lists the sources,
their licences and what was changed.

* ``SRC_DIR/broad/*.mat``: BROAD trials (D. Laidig, M. Caruso, A. Cereatti, T. Seel, Data 6(7), 2021,
  doi:10.3390/data6070072, CC BY 4.0; ``dlaidig/broad``), and ``trials.json`` for their descriptions. Trials 02,
  07, 09 and 16 are kept for acceptance and are never converted, even if present. The optical attitude as it is; the
  reference is the gyroscope calibrated against it by :func:`omegahat.calibration.calibrate` (clock offset, frame
  rotation, bias: one calibration shared by every method); the ``movement`` labels are the scored samples; the
  harness also scores every 10th and 30th sample (29 and 10 Hz), as ``benchmarks/real_data.py`` does.
* ``SRC_DIR/upenn/vicon/viconRotN.mat`` with ``upenn/imu/imuRawN.mat`` (UPenn ESE 650 Vicon and IMU recordings,
  from ``yashv28/Orientation-Estimation-using-Unscented-Kalman-Filter``; the repository states no licence: local
  use, never redistributed): ``rots (3, 3, N)`` body → world at ~100 Hz, ``vals (6, M)`` raw ADC counts
  (accelerometer, then gyroscope rows in an order the calibration finds). Both logs' stamps are arrival times with
  jitter (Vicon: up to 28 ms off a regular 100 Hz, in sets 1-6; no frame dropped or repeated): each log's times are
  replaced by the straight line fitted to them over the sample index (the residuals are in ``meta["notes"]``).
  The gyroscope is calibrated with a general scale matrix (raw counts, permuted axes); where it is stuck
  (:func:`stuck_gyro`) its samples are left out. A set whose matrix is ill-conditioned (condition number above
  :data:`MAX_CONDITION`: a channel that does not respond, as the first gyro axis of set 2) is not converted.
* Held out, converted only with ``--only heldout`` and used for nothing but ``real_world.py --heldout``:
  ``SRC_DIR/ring/data`` (the ``data`` folder of ``anonymous-sup-material/ring_supplementary_material``): RepoIMU's
  triple pendulum, RING's five-segment chain and OpenAXES's robot arm (:func:`convert_heldout`; no licence stated
  there: local use); ``SRC_DIR/tyrex/datasets`` (the ``datasets`` folder of
  ``tyrex-team/benchmarks-attitude-smartphones``, CeCILL 2.1: local use): smartphones in Qualisys at 60 Hz with
  their own gyroscopes (:func:`convert_tyrex`); ``SRC_DIR/hinge`` (the ``raw_*.mat`` of
  ``ssong47/compute_relative_angle_between_two_IMUs``'s ``MatlabCode/Data``, MIT): a motor's encoder and the
  gyroscope on its shaft (:func:`convert_hinge`).
* The independent plant (needs ``omegahat[mujoco]``): :mod:`omegahat.lab.evaluation.plant_logs`, 24 logs of issue
  24's grid and the varying-motion case, each also written as ``NAME.csv`` (what ``omegahat estimate`` reads;
  ``meta["command"]`` has the options its model needs) and ``NAME-truth.csv`` (``t, wx, wy, wz``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import scipy.io

from omegahat import so3
from omegahat.calibration import calibrate
from omegahat.cli.calibrate import table
from omegahat.lab.evaluation import broad
from omegahat.lab.evaluation.corpus import Recording, save_recording

ACCEPTANCE = ("02", "07", "09", "16")  #: BROAD trials kept for acceptance: never converted
PARTS = ("broad", "upenn", "plant")  #: the development corpus (the default)
HELDOUT = "heldout"  #: recordings nobody here tuned on: converted only when named (``--only heldout``)
BROAD_SOURCE = (
    "BROAD: D. Laidig, M. Caruso, A. Cereatti, T. Seel, 'BROAD - A Benchmark for Robust Inertial Orientation "
    "Estimation', Data 6(7), 2021, doi:10.3390/data6070072 (github.com/dlaidig/broad)"
)
BROAD_LICENCE = "CC BY 4.0 (https://creativecommons.org/licenses/by/4.0/)"
UPENN_SOURCE = (
    "UPenn ESE 650 (Learning in Robotics) orientation-tracking data: Vicon rotations and raw IMU counts, as in "
    "github.com/yashv28/Orientation-Estimation-using-Unscented-Kalman-Filter"
)
UPENN_LICENCE = "not stated by the repository: used locally for development, never redistributed"


def _calibration_meta(cal) -> dict:
    d = cal.to_dict()
    d.pop("covariance")
    return d


def convert_broad(src: Path, out: Path) -> list[str]:
    described = {}
    if (src / "trials.json").exists():
        described = {k: v["description"] for k, v in json.loads((src / "trials.json").read_text())["trials"].items()}
    written = []
    for path in sorted(src.glob("*.mat")):
        if path.name[:2] in ACCEPTANCE:
            print(f"  {path.name}: an acceptance trial: not converted")
            continue
        trial = broad.load_trial(path)
        cal = calibrate(trial.t, trial.R, trial.t, trial.gyro, max_offset=SEARCH_OFFSET)
        ref_t, ref_w = cal.apply(trial.t, trial.gyro)
        q = np.full((trial.t.size, 4), np.nan)
        ok = ~trial.gaps
        q[ok] = so3.to_quat(trial.R[ok])
        name = f"broad-{path.stem}"
        meta = {
            "source": f"{BROAD_SOURCE}, trial {path.stem}",
            "licence": BROAD_LICENCE,
            "description": described.get(path.stem, ""),
            "changes": "optical quaternion unchanged (stored scalar first); the gyroscope calibrated against it "
            "(offset, rotation, bias) and mapped into the body frame on the attitude's clock",
            "calibration": _calibration_meta(cal),
            "decimate": [10, 30],
            "score": {},
            "truth": False,
            "command": f"omegahat estimate {name}.npz -o out.csv",
            "notes": [f"{int(trial.gaps.sum())} samples without optical attitude"],
        }
        rec = Recording(name, trial.t, "quaternion", q, ref_t, ref_w, np.asarray(trial.movement), meta)
        save_recording(out / f"{name}.npz", rec)
        written.append(name)
        print(f"  {name}: {trial.t.size} samples at {trial.fs:.4g} Hz; calibration: offset {cal.offset * 1e3:+.2f} "
              f"± {cal.offset_std * 1e3:.2f} ms, rotation {np.degrees(np.linalg.norm(so3.log(cal.rotation))):.3f} deg, "
              f"bias {np.array2string(cal.bias, precision=4)} rad/s", flush=True)  # fmt: skip
    return written


def _regular(t: np.ndarray) -> tuple[np.ndarray, str]:
    """The least-squares line through the stamps over the sample index, as seconds after the first stamp (Unix
    times carry only 0.2 µs in a float), and how far the stamps were from it."""
    k = np.arange(t.size)
    rel = t - t[0]
    slope, intercept = np.polyfit(k, rel, 1)
    line = intercept + slope * k
    r = rel - line
    return (
        line,
        f"{1 / slope:.5g} Hz, stamps off the line by {1e3 * r.std():.2g} ms RMS, {1e3 * abs(r).max():.2g} ms max",
    )


STUCK_COUNTS = np.array([382.0, 383.0, 384.0])  #: the UPenn gyroscope's value while it does not respond
STUCK_MIN_SAMPLES = 10
MAX_CONDITION = 3.0  #: a calibrated scale matrix less well conditioned than this has a dead channel
#: s: the clock offset is searched within ± this (the calibration's own default until it searched every overlap):
#: the recordings stay those every table was measured on
SEARCH_OFFSET = 2.0


def stuck_gyro(g: np.ndarray) -> np.ndarray:
    """Samples where the UPenn gyroscope is stuck: runs of at least :data:`STUCK_MIN_SAMPLES` with every axis
    within 2 counts of :data:`STUCK_COUNTS` (seen in sets 2, 4, 5, 8, 9, 10 for 0.5-2.5 s while the Vicon shows
    the board turning; its rest value is about (370, 374, 375)), and 5 samples either side."""
    near = np.all(np.abs(g - STUCK_COUNTS) <= 2.0, axis=1)
    edges = np.diff(np.concatenate([[0], near.astype(int), [0]]))
    out = np.zeros(g.shape[0], dtype=bool)
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        if b - a >= STUCK_MIN_SAMPLES:
            out[max(0, a - 5) : b + 5] = True
    return out


def convert_upenn(src: Path, out: Path) -> tuple[list[str], dict]:
    written, tables = [], {}
    sets = sorted(int(p.stem.removeprefix("viconRot")) for p in (src / "vicon").glob("viconRot*.mat"))
    for n in sets:
        imu_path = src / "imu" / f"imuRaw{n}.mat"
        if not imu_path.exists():
            continue
        v = scipy.io.loadmat(src / "vicon" / f"viconRot{n}.mat")
        imu = scipy.io.loadmat(imu_path)
        R = np.ascontiguousarray(np.moveaxis(np.asarray(v["rots"], dtype=float), 2, 0))
        bad = ~np.all(np.isfinite(R), axis=(1, 2))
        ts_v, ts_i = np.asarray(v["ts"], dtype=float).ravel(), np.asarray(imu["ts"], dtype=float).ravel()
        t_v, vicon_note = _regular(ts_v)
        t_i, imu_note = _regular(ts_i)
        origin = ts_v[0] + t_v[0]  # Unix time of the first Vicon sample: times below count from it
        t_i += (ts_i[0] - ts_v[0]) - t_v[0]
        t_v -= t_v[0]
        g = np.asarray(imu["vals"], dtype=float)[3:6].T  # the gyroscope's counts, in the order stored
        stuck = stuck_gyro(g)
        t_i, g = t_i[~stuck], g[~stuck]  # left out: the calibration and the score treat the holes as gaps
        cal = calibrate(t_v, R, t_i, g, scale="matrix", max_offset=SEARCH_OFFSET)
        sv = np.linalg.svd(cal.matrix, compute_uv=False)
        if sv[-1] < sv[0] / MAX_CONDITION:
            print(f"  upenn-{n:02d}: not converted: a gyroscope channel does not respond (scale factors "
                  f"{np.array2string(cal.scale, precision=3)} counts per rad/s; singular values of A "
                  f"{np.array2string(sv, precision=3)}): no reference", flush=True)  # fmt: skip
            tables[f"upenn-{n:02d} (not converted)"] = table(cal, "counts")
            continue
        ref_t, ref_w = cal.apply(t_i, g)
        q = np.full((t_v.size, 4), np.nan)
        q[~bad] = so3.to_quat(R[~bad])
        name = f"upenn-{n:02d}"
        meta = {
            "source": f"{UPENN_SOURCE}: vicon/viconRot{n}.mat, imu/imuRaw{n}.mat (rows 4-6 of vals: the gyroscope)",
            "licence": UPENN_LICENCE,
            "description": f"hand-held IMU board tracked by Vicon, set {n}",
            "changes": "times regularised (notes) and counted from the first Vicon sample (Unix time "
            f"{origin:.6f}); Vicon rotations as quaternions; the gyroscope's raw counts calibrated with a scale "
            "matrix and mapped into the body frame, rad/s, on the Vicon's clock",
            "calibration": _calibration_meta(cal),
            "decimate": [],
            "score": {},
            "truth": False,
            "command": f"omegahat estimate {name}.npz -o out.csv",
            "notes": [
                f"Vicon: {vicon_note}",
                f"IMU: {imu_note}",
                f"{int(bad.sum())} Vicon samples missing",
                f"{int(stuck.sum())} gyroscope samples left out (stuck at {STUCK_COUNTS.tolist()} counts)",
            ],
        }
        rec = Recording(name, t_v, "quaternion", q, ref_t, ref_w, np.ones(t_v.size, bool), meta)
        save_recording(out / f"{name}.npz", rec)
        written.append(name)
        tables[name] = table(cal, "counts")
        print(f"  {name}: {t_v.size} Vicon samples; {cal.axis_map()}; offset {cal.offset * 1e3:+.1f} ± "
              f"{cal.offset_std * 1e3:.1f} ms", flush=True)  # fmt: skip
    return written, tables


def _write_csv(path: Path, rec: Recording) -> None:
    if rec.kind == "quaternion":
        cols, data = ["qw", "qx", "qy", "qz"], np.roll(rec.data, 1, axis=1)
    else:
        n = rec.data.shape[1]
        cols, data = [f"b{i + 1}{a}" for i in range(n) for a in "xyz"], rec.data.reshape(rec.t.size, -1)
    parts = [rec.t[:, None], data]
    if rec.torque is not None:
        cols += ["tau_x", "tau_y", "tau_z"]
        parts.append(rec.torque)
    np.savetxt(path, np.hstack(parts), delimiter=",", header=",".join(["t", *cols]), comments="", fmt="%.17g")


def convert_plant(out: Path) -> list[str]:
    from omegahat.lab.evaluation.plant_logs import plant_grid, varying_motion

    written = []
    for rec in [*plant_grid(0), varying_motion(0)]:
        save_recording(out / f"{rec.name}.npz", rec)
        _write_csv(out / f"{rec.name}.csv", rec)
        k = np.searchsorted(rec.reference_times, rec.t)
        truth = np.column_stack([rec.t, rec.reference_rates[k]])
        np.savetxt(out / f"{rec.name}-truth.csv", truth, delimiter=",", header="t,wx,wy,wz", comments="", fmt="%.17g")
        written.append(rec.name)
    print(f"  {len(written)} plant logs", flush=True)
    return written


REPOIMU_SOURCE = (
    "RepoIMU: A. Szczęsna et al., 'Reference Data Set for Accuracy Evaluation of Orientation Estimation Algorithms "
    "for Inertial Motion Capture Systems', ICCVG 2016, doi:10.1007/978-3-319-46418-3_45, as re-packaged in "
    "github.com/anonymous-sup-material/ring_supplementary_material (data/repoIMU_dataset)"
)
RING_SOURCE = (
    "the RING validation recordings (optical motion capture of a five-segment chain with an IMU rigidly on each "
    "segment), github.com/anonymous-sup-material/ring_supplementary_material (data/dataset)"
)
OPENAXES_SOURCE = (
    "OpenAXES: F. Webering, C. Fahnemann, N. Stanislawski, 'OpenAXES Example Robot Dataset', LUIS 2023, "
    "doi:10.25835/psqqs9w0, as re-packaged in github.com/anonymous-sup-material/ring_supplementary_material "
    "(data/openaxes_dataset: the robot's encoder attitudes, and the IMUs' gyroscopes resampled onto the robot's clock)"
)
TYREX_SOURCE = (
    "T. Michel, P. Genevès, H. Fourati, N. Layaïda, 'On attitude estimation with smartphones', IEEE PerCom 2017 "
    "(github.com/tyrex-team/benchmarks-attitude-smartphones, datasets/): a Qualisys rigid body on a smartphone at "
    "60 Hz and the phone's own gyroscope (Android Nexus 5, iOS iPhone 4S and 5)"
)
TYREX_LICENCE = "CeCILL 2.1 (the repository's LICENCE): used locally to measure, never redistributed"
HINGE_SOURCE = (
    "S. Y. Song, 'compute_relative_angle_between_two_IMUs' (github.com/ssong47/compute_relative_angle_between_two_IMUs,"
    " MatlabCode/Data/raw_*.mat): a stepper motor's shaft turned back and forth over 0-180 degrees, its encoder "
    "angle and the gyroscope of an MPU6050 on the shaft, on one Teensy clock at about 100 Hz"
)
HINGE_LICENCE = "MIT (the repository's LICENSE): used locally to measure, never redistributed"
ONE_CLOCK_OFFSET = 0.1  #: s: the most two sensors sampled on one clock may lag each other (filters, buses)
QUAT_NORM_TOL = 1e-3  #: as ``omegahat estimate --quat-norm-tol``'s default: a RepoIMU quaternion further off is a gap
MAX_RESIDUAL = 0.5  #: a calibration leaving more of the reference's RMS rate unexplained is a failed one
HELDOUT_LICENCE = "not stated by the repository: used locally to measure, never redistributed"


def _held_run_starts(g: np.ndarray) -> np.ndarray:
    """Rows where a gyroscope sampled slower than its log's rows changes value (the log holds each sample)."""
    return np.flatnonzero(np.r_[True, np.any(np.diff(g, axis=0) != 0, axis=1)])


def _heldout_recording(
    out: Path, name: str, t, q_wxyz, gyro_t, gyro, source: str, changes: str, notes, decimate, max_offset=SEARCH_OFFSET
):
    """Calibrate the gyroscope ``(gyro_t, gyro)`` against the quaternions ``q_wxyz`` (scalar first, NaN rows missing)
    at the times ``t``, and write the recording ``out/name.npz``; its name, or None (said) where the calibration
    refuses the pair or leaves more than :data:`MAX_RESIDUAL` of the gyroscope's RMS rate unexplained."""
    try:
        return _calibrated_recording(out, name, t, q_wxyz, gyro_t, gyro, source, changes, notes, decimate, max_offset)
    except ValueError as e:
        print(f"  {name}: not converted: {e}", flush=True)
        return None


def _calibrated_recording(
    out: Path, name: str, t, q_wxyz, gyro_t, gyro, source, changes, notes, decimate, max_offset=SEARCH_OFFSET
) -> str:
    """:func:`_heldout_recording`'s work; raises ValueError where the pair cannot be calibrated. ``max_offset`` (s):
    how far the clocks may be apart (:data:`SEARCH_OFFSET` for separate clocks)."""
    ok = np.all(np.isfinite(q_wxyz), axis=1)
    q = np.full((t.size, 4), np.nan)
    q[ok] = np.roll(q_wxyz[ok], -1, axis=1)  # scalar last, as Recording keeps it
    R = np.full((t.size, 3, 3), np.nan)
    R[ok] = so3.from_quat(q[ok])
    cal = calibrate(t, R, gyro_t, gyro, max_offset=max_offset)
    ref_t, ref_w = cal.apply(gyro_t, gyro)
    residual, rate = float(np.sqrt(np.sum(cal.residual_rms**2))), float(np.sqrt(np.mean(np.sum(ref_w**2, axis=1))))
    if residual > MAX_RESIDUAL * rate:
        raise ValueError(
            f"the calibration leaves {residual:.3g} rad/s of the gyroscope's {rate:.3g} rad/s RMS unexplained: the "
            "two logs do not describe one motion on one clock"
        )
    meta = {
        "source": source, "licence": HELDOUT_LICENCE, "description": name, "changes": changes,
        "calibration": _calibration_meta(cal), "decimate": decimate, "score": {}, "truth": False,
        "command": f"omegahat estimate {name}.npz -o out.csv", "notes": notes,
    }  # fmt: skip
    rec = Recording(name, t, "quaternion", q, ref_t, ref_w, np.ones(t.size, bool), meta)
    save_recording(out / f"{name}.npz", rec)
    angle = np.degrees(np.linalg.norm(so3.log(cal.rotation)))
    one_axis = "" if cal.free_axis is None else " (one axis turned: the turn about it is not identified)"
    print(f"  {name}: {t.size} samples at {rec.fs:.4g} Hz; offset {cal.offset * 1e3:+.1f} ± "
          f"{cal.offset_std * 1e3:.1f} ms, rotation {angle:.2f} deg{one_axis}, residual "
          f"{residual:.3g} rad/s of {rate:.3g}", flush=True)  # fmt: skip
    return name


def _sampling_frequency(path: Path) -> float:
    """The ``# sampling frequency: F`` of a RING file's first line."""
    return float(path.read_text().split("\n", 1)[0].split(":")[1])


def convert_heldout(src: Path, out: Path) -> list[str]:
    """Recordings of other labs kept out of the development corpus, to measure the defaults on data they were not
    chosen on: RepoIMU's triple pendulum (Vicon quaternions and the IMU's gyroscope in one file per segment, stamps in
    milliseconds; the gyroscope is sampled at about half the rate of the rows, which hold each sample: its reference
    is the rows where it changes), RING's five-segment chain (optical quaternions at 30 Hz, the rigidly attached
    IMUs' gyroscopes at 40 Hz, on separate clocks that the calibration aligns) and OpenAXES's robot arm
    (:func:`convert_openaxes`). A pair the calibration refuses is named and left out."""
    written = []
    for path in sorted((src / "repoIMU_dataset").glob("Pendulum_*.csv")):
        a = np.genfromtxt(path, delimiter=";", skip_header=2)
        keep = np.r_[True, np.diff(a[:, 0]) > 0]  # a stamp repeated: the row is dropped (counted in the notes)
        a = a[keep]
        starts = _held_run_starts(a[:, 8:11])
        held = int(np.sum(np.all(np.diff(a[:, 1:5], axis=0) == 0, axis=1)))
        off_unit = ~(np.abs(np.linalg.norm(a[:, 1:5], axis=1) - 1.0) <= QUAT_NORM_TOL)  # NaN too: as skipped
        a[off_unit, 1:5] = np.nan
        name = "repoimu-" + path.stem.removeprefix("Pendulum_").replace("_Trial1_Segment_", "-s").lower()
        notes = [
            f"{int((~keep).sum())} rows with a repeated stamp dropped",
            f"{held} Vicon rows repeat the previous",
            f"{int(off_unit.sum())} Vicon quaternions NaN or off unit norm by more than {QUAT_NORM_TOL}: missing",
            f"gyroscope: {starts.size} distinct samples of {a.shape[0]} rows",
        ]
        changes = (
            "repeated stamps dropped; quaternions off unit norm made gaps (notes); the gyroscope's held rows left "
            "out; calibrated (offset, rotation, bias)"
        )
        t = a[:, 0] - a[0, 0]
        source = f"{REPOIMU_SOURCE}: {path.name}"
        written.append(
            _heldout_recording(out, name, t, a[:, 1:5], t[starts], a[starts, 8:11], source, changes, notes, [3, 9])
        )
    for trial in sorted((src / "dataset").glob("trial*")):
        omc = np.genfromtxt(trial / "omc.csv", delimiter=",", skip_header=2, names=True)
        imu = np.genfromtxt(trial / "imu_rigid.csv", delimiter=",", skip_header=2, names=True)
        fs_omc, fs_imu = _sampling_frequency(trial / "omc.csv"), _sampling_frequency(trial / "imu_rigid.csv")
        changes = "optical quaternions as they are; the rigid IMU's gyroscope calibrated (offset, rotation, bias)"
        for seg in range(1, 6):
            q = np.column_stack([omc[f"seg{seg}_quat_{c}"] for c in "wxyz"])
            g = np.column_stack([imu[f"seg{seg}_gyr_{c}"] for c in "xyz"])
            t, gyro_t = np.arange(q.shape[0]) / fs_omc, np.arange(g.shape[0]) / fs_imu
            notes = [f"{int(np.sum(~np.all(np.isfinite(q), axis=1)))} samples without optical attitude"]
            source = f"{RING_SOURCE}: {trial.name}, segment {seg}"
            name = f"ring-{trial.name}-seg{seg}"
            written.append(_heldout_recording(out, name, t, q, gyro_t, g, source, changes, notes, [3]))
    written += convert_openaxes(src / "openaxes_dataset", out)
    return [name for name in written if name is not None]


def convert_openaxes(src: Path, out: Path) -> list[str]:
    """OpenAXES's robot arm: the attitude of two of its links from the joint encoders (scalar-first quaternions,
    stamps in microseconds, 125 Hz) and the gyroscope of the IMU on each, which the re-packaging resampled onto the
    robot's stamps by linear interpolation, filling the rows outside the IMU's record with its first value: a
    gyroscope row equal to its neighbour is such a fill (or a held value), and is left out of the reference."""
    written = []
    for trial in sorted((src / "groundtruth").glob("robot-*")):
        scenario = trial.name.removeprefix("robot-")
        for link in ("carpus", "radius"):
            imu = src / "synced_imu" / scenario / f"{link}_adx.csv"
            if not imu.is_file():
                continue
            a = np.genfromtxt(trial / f"{link}.csv", delimiter=",", skip_header=1)
            g = np.genfromtxt(imu, delimiter=",", skip_header=1)[:, 4:7]
            if g.shape[0] != a.shape[0]:
                raise ValueError(f"{imu}: {g.shape[0]} rows beside {a.shape[0]} of {trial / f'{link}.csv'}")
            same = np.all(np.diff(g, axis=0) == 0, axis=1)
            live = ~(np.r_[False, same] | np.r_[same, False])  # differs from both neighbours
            t = (a[:, 0] - a[0, 0]) * 1e-6
            notes = [
                f"gyroscope: {int((~live).sum())} of {g.shape[0]} rows equal to a neighbour (the resampling's fill "
                "outside the IMU's record, or a held value) left out",
                f"{int(np.sum(np.all(np.diff(a[:, 1:5], axis=0) == 0, axis=1)))} encoder attitudes repeat the previous",
            ]
            changes = "encoder quaternions as they are; the gyroscope's live rows calibrated (offset, rotation, bias)"
            source = f"{OPENAXES_SOURCE}: {scenario}, {link}"
            name = f"openaxes-{scenario}-{link}"
            written.append(
                _heldout_recording(out, name, t, a[:, 1:5], t[live], g[live], source, changes, notes, [3, 9])
            )
    return [name for name in written if name is not None]


def _boot_time(description: Path) -> float:
    """The ``BootTime = T`` of an iOS recording's ``description.txt`` (s): its gyroscope's stamps count from boot."""
    for line in description.read_text().splitlines():
        if line.strip().startswith("BootTime"):
            return float(line.split("=")[1].split()[0])
    raise ValueError(f"{description}: no BootTime")


def convert_tyrex(src: Path, out: Path) -> list[str]:
    """The Tyrex smartphone benchmark (``src`` its ``datasets`` folder): per recording a Qualisys ``.mat`` (the first
    rigid body's rotation matrices, 9 per frame in MATLAB's column order, body → room, NaN where untracked; frames at
    ``FrameRate``, 60 Hz, from 0 s) and the phone's folder ``android/NAME`` or ``ios/NAME``: ``gyroscope.txt`` (``t
    gx gy gz`` rad/s, then Android's drift estimates, unused: the calibration fits the bias), iOS stamps from boot
    (``description.txt``'s ``BootTime`` taken off), and ``timeAlignment.txt``, the authors' offset (phone time + it
    = Qualisys time, from the accelerations' norms to 10 ms), which the calibration refines."""
    written = []
    for mat in sorted((src / "qualisys").glob("*.mat")):
        name = f"tyrex-{mat.stem.lower().replace('_', '-')}"
        phone = next((src / kind / mat.stem for kind in ("android", "ios") if (src / kind / mat.stem).is_dir()), None)
        if phone is None:
            print(f"  {name}: not converted: no phone folder for {mat.name}", flush=True)
            continue
        capture = scipy.io.loadmat(mat, squeeze_me=True, struct_as_record=False)
        capture = capture[next(k for k in capture if not k.startswith("__"))]
        body = np.atleast_1d(capture.RigidBodies)[0]
        frames = np.asarray(body.Rotations, dtype=float).reshape(9, -1)
        R = frames.T.reshape(-1, 3, 3).transpose(0, 2, 1)  # each column of 9 is a matrix in column order
        t = np.arange(R.shape[0]) / float(capture.FrameRate)
        tracked = np.all(np.isfinite(frames), axis=0)
        q = np.full((t.size, 4), np.nan)
        q[tracked] = so3.to_quat(so3.project(R[tracked]), scalar_first=True)  # Qualisys rounds its matrices
        g = np.loadtxt(phone / "gyroscope.txt", ndmin=2)
        gyro_t = g[:, 0] - (_boot_time(phone / "description.txt") if phone.parent.name == "ios" else 0.0)
        gyro_t = gyro_t + float(np.loadtxt(phone / "timeAlignment.txt"))
        notes = [
            f"{int((~tracked).sum())} of {t.size} Qualisys frames untracked (NaN): missing",
            f"gyroscope: {g.shape[0]} samples from {phone.parent.name}/{phone.name}",
        ]
        changes = (
            "Qualisys rotations as they are (untracked frames missing); the phone's gyroscope on the Qualisys clock "
            "by the authors' time alignment, then calibrated (offset, rotation, bias)"
        )
        source = f"{TYREX_SOURCE}: {mat.name}"
        written.append(_heldout_recording(out, name, t, q, gyro_t, g[:, 1:4], source, changes, notes, [6]))
    return [name for name in written if name is not None]


def convert_hinge(src: Path, out: Path) -> list[str]:
    """The encoder-and-gyroscope hinge (``src`` holding its ``raw_AXIS_SPEED.mat``): the shaft's angle ``θ``
    (``all_encoder``, degrees) is the attitude, a turn about one axis, ``R = Exp(θ e_z)`` (which body axis is a
    convention: the calibration finds where it points in the gyroscope's axes, step 5 of
    :mod:`omegahat.calibration`); ``all_gyro_2_x, _y, _z`` (deg/s) the gyroscope on the shaft, ``all_time`` (s) the
    one clock of both. Rows from ``data_line`` on (MATLAB's 1-based row where the authors' data phase starts); a row
    whose stamp repeats the previous is dropped (counted in the notes). The clocks are one, so the offset is searched
    within :data:`ONE_CLOCK_OFFSET`: the back-and-forth turn repeats itself, and a shift by half its period with the
    axis reversed fits it as well as none, which the separate clocks' wider search cannot tell apart."""
    written = []
    for mat in sorted(src.glob("raw_*.mat")):
        m = scipy.io.loadmat(mat, squeeze_me=True)
        first = int(m["data_line"]) - 1
        t = np.asarray(m["all_time"], dtype=float)[first:]
        theta = np.radians(np.asarray(m["all_encoder"], dtype=float)[first:])
        g = np.radians(np.column_stack([m[f"all_gyro_2_{c}"] for c in "xyz"]).astype(float)[first:])
        keep = np.r_[True, np.diff(t) > 0]
        t, theta, g = t[keep] - t[keep][0], theta[keep], g[keep]
        q = np.column_stack([np.cos(theta / 2), np.zeros((t.size, 2)), np.sin(theta / 2)])  # w, x, y, z
        name = "hinge-" + mat.stem.removeprefix("raw_").replace("_", "-")
        notes = [f"{int((~keep).sum())} rows with a repeated stamp dropped", f"rows from {first + 1} (data_line)"]
        changes = (
            "the encoder's angle as a turn about the body's z axis; repeated stamps dropped; the shaft's gyroscope "
            "calibrated (offset, the axis's direction, bias: one axis turned)"
        )
        source = f"{HINGE_SOURCE}: {mat.name}"
        written.append(_heldout_recording(out, name, t, q, t, g, source, changes, notes, [10], ONE_CLOCK_OFFSET))
    return [name for name in written if name is not None]


#: the held-out sources: where each lies below SRC_DIR, what it is, and its converter
HELDOUT_SOURCES = (
    ("ring/data", "RepoIMU, RING, OpenAXES", convert_heldout),
    ("tyrex/datasets", "Tyrex smartphones", convert_tyrex),
    ("hinge", "encoder hinge", convert_hinge),
)

NOTICE = """# The development corpus of issue 24 (built by benchmarks/corpus.py; not part of omegahat)

Each `NAME.npz` is one recording: an omegahat NPZ log (`omegahat estimate NAME.npz -o out.csv`) plus its reference
rate; `meta` inside says where it comes from, its licence, what was changed and the calibration applied.

- `broad-*`: {broad}. Licence: {broad_licence}. Changes: the gyroscope is calibrated against the optical attitude
  and stored in the body frame; the optical attitude is unchanged. Trials 02, 07, 09 and 16 are not included.
- `upenn-*`: {upenn}. Licence: {upenn_licence}.
- `repoimu-*`, `ring-*`, `openaxes-*` (only with `--only heldout`: recordings kept out of development): {heldout}.
  Licence: {heldout_licence}.
- `tyrex-*` (only with `--only heldout`): {tyrex}. Licence: {tyrex_licence}.
- `hinge-*` (only with `--only heldout`): {hinge}. Licence: {hinge_licence}.
- `plant-*`: generated with MuJoCo by omegahat.lab.evaluation.plant_logs (also as `NAME.csv` and `NAME-truth.csv`).
"""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("src", type=Path, help="directory holding broad/ and upenn/ (either may be absent)")
    ap.add_argument("out", type=Path, help="where to write the recordings")
    ap.add_argument("--only", nargs="+", choices=(*PARTS, HELDOUT), default=list(PARTS))
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    written: list[str] = []
    if "broad" in args.only:
        if (args.src / "broad").is_dir():
            print("BROAD:")
            written += convert_broad(args.src / "broad", args.out)
        else:
            print(f"BROAD: skipped ({args.src / 'broad'} absent)")
    if "upenn" in args.only:
        if (args.src / "upenn" / "vicon").is_dir():
            print("UPenn:")
            names, tables = convert_upenn(args.src / "upenn", args.out)
            written += names
            for name, table in tables.items():
                print(f"\n{name} (gyro counts = A omega + bias):\n{table}")
        else:
            print(f"UPenn: skipped ({args.src / 'upenn' / 'vicon'} absent)")
    if "plant" in args.only:
        try:
            import mujoco  # noqa: F401
        except ImportError:
            print("plant: skipped (MuJoCo absent: pip install omegahat[mujoco])")
        else:
            print("plant:")
            written += convert_plant(args.out)
    if HELDOUT in args.only:
        for folder, what, convert in HELDOUT_SOURCES:
            found = args.src / folder
            if found.is_dir():
                print(f"held out ({what}):")
                written += convert(found, args.out)
            else:
                print(f"held out ({what}): skipped ({found} absent)")
    (args.out / "NOTICE.md").write_text(
        NOTICE.format(
            broad=BROAD_SOURCE,
            broad_licence=BROAD_LICENCE,
            upenn=UPENN_SOURCE,
            upenn_licence=UPENN_LICENCE,
            heldout=f"{REPOIMU_SOURCE}; {RING_SOURCE}; {OPENAXES_SOURCE}",
            heldout_licence=HELDOUT_LICENCE,
            tyrex=TYREX_SOURCE,
            tyrex_licence=TYREX_LICENCE,
            hinge=HINGE_SOURCE,
            hinge_licence=HINGE_LICENCE,
        )
    )
    print(f"\nwrote {len(written)} recordings to {args.out} in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
