"""Attitude logs in, angular-velocity estimates out (see :mod:`omegahat.io.logs`).

Formats are registered by extension in :mod:`omegahat.io.registry` (CSV: :mod:`omegahat.io.csvlog`, NPZ:
:mod:`omegahat.io.npzlog`); a new format registers an opener with :func:`register_format`.
"""

from omegahat.io.columns import MATRIX_COLUMNS, QUATERNION_COLUMNS, TORQUE_COLUMNS, LogFormatError
from omegahat.io.csvlog import open_csv
from omegahat.io.logs import AttitudeLog, read_csv, read_log, read_npz, write_omega_csv
from omegahat.io.npzlog import open_npz
from omegahat.io.output import OmegaWriter, check_output_path
from omegahat.io.registry import LogChunk, LogStream, ReadOptions, open_log, register_format

register_format(".csv", open_csv)
register_format(".npz", open_npz)

__all__ = [
    "MATRIX_COLUMNS",
    "QUATERNION_COLUMNS",
    "TORQUE_COLUMNS",
    "AttitudeLog",
    "LogChunk",
    "LogFormatError",
    "LogStream",
    "OmegaWriter",
    "ReadOptions",
    "check_output_path",
    "open_log",
    "read_csv",
    "read_log",
    "read_npz",
    "register_format",
    "write_omega_csv",
]
