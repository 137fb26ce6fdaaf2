"""Attitude logs in, angular-velocity estimates out (see :mod:`omegahat.io.logs`)."""

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

__all__ = [
    "MATRIX_COLUMNS",
    "QUATERNION_COLUMNS",
    "TORQUE_COLUMNS",
    "AttitudeLog",
    "LogFormatError",
    "read_csv",
    "read_log",
    "read_npz",
    "write_omega_csv",
]
