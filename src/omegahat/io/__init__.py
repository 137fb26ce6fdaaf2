"""Attitude data in, angular-velocity estimates out.

omegahat's own CSV/NPZ logs (:mod:`omegahat.io.logs`); recordings from where users' data lives: ROS 1 and ROS 2
bags (:mod:`omegahat.io.rosbag`), OptiTrack Motive and Vicon CSV exports (:mod:`omegahat.io.mocap`), C3D files
(:mod:`omegahat.io.c3d`), all recognised by :func:`read_recording` (:mod:`omegahat.io.detect`); pandas and
Polars DataFrames (:func:`estimate_frame`, :mod:`omegahat.io.frames`). Duplicated and irregular timestamps follow
one policy (:mod:`omegahat.io.timestamps`).
"""

from omegahat.io.detect import RECORDING_FORMATS, detect_format, output_kind, read_recording, write_estimates
from omegahat.io.frames import estimate_frame
from omegahat.io.logs import (
    MATRIX_COLUMNS,
    QUATERNION_COLUMNS,
    TORQUE_COLUMNS,
    AttitudeLog,
    LogFormatError,
    read_csv,
    read_log,
    read_npz,
    write_omega_csv,
)
from omegahat.io.recording import BagStamps, Recording
from omegahat.io.timestamps import DUPLICATE_TOL, TidyResult, tidy_samples

__all__ = [
    "DUPLICATE_TOL",
    "MATRIX_COLUMNS",
    "QUATERNION_COLUMNS",
    "RECORDING_FORMATS",
    "TORQUE_COLUMNS",
    "AttitudeLog",
    "BagStamps",
    "LogFormatError",
    "Recording",
    "TidyResult",
    "detect_format",
    "estimate_frame",
    "output_kind",
    "read_csv",
    "read_log",
    "read_npz",
    "read_recording",
    "tidy_samples",
    "write_estimates",
    "write_omega_csv",
]
