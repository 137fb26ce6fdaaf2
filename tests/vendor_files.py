"""Test helpers: the trajectory and export files of other tools, written by hand from their vendors' documentation.

Each writer follows the layout its vendor documents (the comment above it says whose), converts with SciPy, never
with omegahat's code, and writes numbers as that tool writes them (digits, separators, time units), so a reader
that misreads a convention fails the tests. Nothing here is copied from another project's files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation


def decimal_seconds(base: int, t: np.ndarray, decimals: int = 9) -> list[str]:
    """``base + t`` written exactly with ``decimals`` decimals, from integers (no float ever holds ``base + t``)."""
    ticks = np.round(np.asarray(t) * 10**decimals).astype(np.int64)
    whole, frac = np.divmod(ticks, 10**decimals)
    return [f"{base + int(w)}.{int(f):0{decimals}d}" for w, f in zip(whole, frac, strict=True)]


def write_plain_csv(path, t_text: list[str], q: np.ndarray, fmt: str = "{:.9f}") -> Path:
    """omegahat's own CSV: ``t,qw,qx,qy,qz`` (``q`` scalar last, as SciPy)."""
    rows = [
        f"{tt},{fmt.format(w)},{fmt.format(x)},{fmt.format(y)},{fmt.format(z)}"
        for tt, (x, y, z, w) in zip(t_text, q, strict=True)
    ]
    Path(path).write_text("t,qw,qx,qy,qz\n" + "\n".join(rows) + "\n")
    return Path(path)


# TUM RGB-D benchmark, "File Formats": "timestamp tx ty tz qx qy qz qw", one pose per line, separated by spaces,
# lines starting with '#' are comments, timestamps in seconds since the Unix epoch.
def write_tum(path, t_text: list[str], q: np.ndarray, fmt: str = "{:.9f}") -> Path:
    lines = ["# ground truth trajectory", "# timestamp tx ty tz qx qy qz qw"]
    for tt, (x, y, z, w) in zip(t_text, q, strict=True):
        lines.append(f"{tt} 1.3405 0.6266 1.6575 {fmt.format(x)} {fmt.format(y)} {fmt.format(z)} {fmt.format(w)}")
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


# EuRoC MAV dataset (ASL dataset format): vicon0/data.csv and state_groundtruth_estimate0/data.csv, a '#timestamp'
# header with units in brackets, timestamps in integer nanoseconds, quaternion q_RS scalar first.
EUROC_VICON = "#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []"
EUROC_GROUND_TRUTH = (
    "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
    "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], "
    "b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]"
)


def write_euroc(path, ns: list[int], q: np.ndarray, fmt: str = "{:.9f}", ground_truth: bool = False) -> Path:
    lines = [EUROC_GROUND_TRUTH if ground_truth else EUROC_VICON]
    tail = ",0.1,0.2,0.3,-0.002,0.02,0.07,-0.01,0.1,0.09" if ground_truth else ""
    for n, (x, y, z, w) in zip(ns, q, strict=True):
        lines.append(f"{n},0.5,1.9,0.97,{fmt.format(w)},{fmt.format(x)},{fmt.format(y)},{fmt.format(z)}{tail}")
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


# KITTI odometry devkit: poses/XX.txt, each line the 12 numbers of the 3x4 matrix [R|t] row by row, space
# separated; sequences/XX/times.txt, one time in seconds per line.
def write_kitti(path, R: np.ndarray, t: np.ndarray | None = None, times_path=None) -> Path:
    rows = []
    for k, Rk in enumerate(R):
        P = np.column_stack([Rk, [0.5 * k, 0.0, 1.0]])
        nums = " ".join(f"{v:e}" for v in P.reshape(-1))
        rows.append(nums if t is None else f"{t[k]:e} {nums}")
    Path(path).write_text("\n".join(rows) + "\n")
    if times_path is not None:
        Path(times_path).write_text("\n".join(f"{x:e}" for x in np.arange(len(R)) * 0.1) + "\n")
    return Path(path)


# Qualisys Track Manager manual, "6DOF data (.tsv)" and "Rotation angle calculations in QTM": a header of
# NAME<tab>value lines, a row of column labels, per body X Y Z Roll Pitch Yaw Residual Rot[0]..Rot[8]; the rotation
# matrix R (local -> global) has its elements column by column, R[i, j] = Rot[i + 3 j]; Roll, Pitch, Yaw rotate the
# local system about X, then the new Y, then the new Z (R = Rx Ry Rz).
def write_qtm_6d(path, t: np.ndarray, bodies: dict, rate: float, *, row_major=False, missing=(), labels=True) -> Path:
    names = list(bodies)
    head = [
        f"NO_OF_FRAMES\t{len(t)}",
        "NO_OF_CAMERAS\t8",
        f"NO_OF_BODIES\t{len(names)}",
        f"FREQUENCY\t{rate:g}",
        "NO_OF_ANALOG\t0",
        "ANALOG_FREQUENCY\t0",
        "DESCRIPTION\t--",
        "TIME_STAMP\t2024-05-02, 10:11:12.345\t1234.56789",
        "DATA_INCLUDED\t6D",
        "BODY_NAMES\t" + "\t".join(names),
    ]
    block = ["X", "Y", "Z", "Roll", "Pitch", "Yaw", "Residual"] + [f"Rot[{k}]" for k in range(9)]
    lines = head + (["Frame\tTime\t" + "\t".join(block * len(names))] if labels else [])
    angles = {n: Rotation.from_matrix(R).as_euler("XYZ", degrees=True) for n, R in bodies.items()}
    for k in range(len(t)):
        row = [str(k + 1), f"{t[k]:.5f}"]
        for n, R in bodies.items():
            if k in missing:
                row += ["0.000"] * 3 + ["0.000"] * 3 + ["-1.000"] + ["0.000000"] * 9
                continue
            M = R[k].T if row_major else R[k]
            rot = [M[i % 3, i // 3] for i in range(9)]  # column by column
            row += ["812.345", "-95.110", "1030.002"] + [f"{a:.3f}" for a in angles[n][k]] + ["0.512"]
            row += [f"{v:.6f}" for v in rot]
        lines.append("\t".join(row))
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


# Qualisys QTM, "Export to MAT file" (as QTM 2.10 writes it): one struct named after the measurement with File,
# Timestamp, StartFrame, Frames, FrameRate, Trajectories and RigidBodies {Bodies, Name (1 x n cells), Positions,
# Rotations, RPYs (n x 3 x F, degrees), Residual}; Rotations (n x 9 x F) hold each 6DOF matrix column by column, an
# untracked frame NaN.
def write_qtm_mat(
    path, bodies: dict, rate: float, *, row_major=False, missing=(), start=1, name="Measurement1", compress=True
) -> Path:
    from scipy.io import savemat

    names = list(bodies)
    frames = len(next(iter(bodies.values())))
    rotations = np.full((len(names), 9, frames), np.nan)
    rpys = np.full((len(names), 3, frames), np.nan)
    for b, R in enumerate(bodies.values()):
        M = np.swapaxes(R, 1, 2) if row_major else R
        rotations[b] = M.transpose(0, 2, 1).reshape(frames, 9).T  # element i + 3 j is R[i, j]: column by column
        rpys[b] = Rotation.from_matrix(R).as_euler("XYZ", degrees=True).T
        rotations[b][:, list(missing)] = np.nan
        rpys[b][:, list(missing)] = np.nan
    cells = np.empty((1, len(names)), dtype=object)
    cells[0, :] = names
    measurement = {
        "File": f"C:\\Data\\{name}.qtm",
        "Timestamp": "2024-05-02, 10:11:12\t1234.56789",
        "StartFrame": float(start),
        "Frames": float(frames),
        "FrameRate": float(rate),
        "Trajectories": {"Labeled": {"Count": 0.0}, "Unidentified": {"Count": 0.0}, "Discarded": {"Count": 0.0}},
        "RigidBodies": {
            "Bodies": float(len(names)),
            "Name": cells,
            "Positions": np.zeros((len(names), 3, frames)),
            "Rotations": rotations,
            "RPYs": rpys,
            "Residual": np.full((len(names), 1, frames), 0.5),
        },
    }
    savemat(path, {name: measurement}, do_compression=compress, oned_as="row")
    return Path(path)


# OptiTrack Motive, "Data Export: CSV": a metadata line, a blank line, rows of kinds, names and IDs (labelled
# ',Type,', ',Name,', ',ID,' from format 1.23 on, unlabelled before), a row of components, then 'Frame,Time...'
# and one row per frame; Rotation Type Quaternion (X,Y,Z,W) or an Euler order (X,Y,Z angles in degrees).
def write_motive(path, t, q: np.ndarray, *, version="1.21", euler: str | None = None, name="rb", labelled=None) -> Path:
    labelled = version >= "1.23" if labelled is None else labelled
    rtype = euler or "Quaternion"
    meta = (
        f"Format Version,{version},Take Name,take,Capture Frame Rate,120.000000,Export Frame Rate,120.000000,"
        f"Capture Start Time,2019-03-01 10.00.00.000 AM,Total Frames in Take,{len(t)},Total Exported Frames,{len(t)},"
        f"Rotation Type,{rtype},Length Units,Meters,Coordinate Space,Global"
    )
    n_rot = 3 if euler else 4
    lead = [",Type", ",Name", ",ID", ","] if labelled else [",", ",", ",", ","]
    kinds = lead[0] + "," + ",".join(["Rigid Body"] * (n_rot + 4) + ["Rigid Body Marker"] * 3)
    names = lead[1] + "," + ",".join([name] * (n_rot + 4) + [f"{name}:Marker1"] * 3)
    ids = lead[2] + "," + ",".join(["1"] * (n_rot + 4) + ["1:1"] * 3)
    comps = lead[3] + "," + ",".join(["Rotation"] * n_rot + ["Position"] * 3 + ["Mean Marker Error"] + ["Position"] * 3)
    time = "Time (Seconds)" if version >= "1.23" else "Time"
    axes = f"Frame,{time}," + ",".join([*"XYZW"[:n_rot], "X", "Y", "Z", "", "X", "Y", "Z"])
    lines = [meta, "", kinds, names, ids, comps, axes]
    if euler:
        values = Rotation.from_quat(q).as_euler(euler, degrees=True)  # angles in the order of the sequence
        cols = np.column_stack([values[:, euler.index(a)] for a in "XYZ"])  # column X holds the angle about X
    else:
        cols = q
    for k in range(len(t)):
        rot = ",".join(f"{v:.6f}" for v in cols[k])
        lines.append(f"{k},{t[k]:.6f},{rot},0.1,1.2,-0.3,0.0002,0.1,1.3,-0.3")
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)
