"""Attitude data in, angular-velocity estimates out: one path for every format.

1. **Formats** are registered here with :func:`register_format` (:mod:`omegahat.io.registry`) and recognised
   from the file (:func:`detect_format`): omegahat's CSV (:mod:`omegahat.io.csvlog`, which also reads any text log
   through a column map, :mod:`omegahat.io.colmap`), NPZ (:mod:`omegahat.io.npzlog`) and Parquet
   (:mod:`omegahat.io.parquet_input`) logs, OptiTrack Motive and
   Vicon CSV exports (:mod:`omegahat.io.mocap`), Qualisys QTM 6D TSV and MAT exports (:mod:`omegahat.io.qualisys`,
   :mod:`omegahat.io.qtm_mat`), the
   EuRoC / ASL, TUM and KITTI trajectories of robotics (:mod:`omegahat.io.trajectories`), C3D files
   (:mod:`omegahat.io.c3d`), ROS 1 and ROS 2 bags (:mod:`omegahat.io.rosbag`), PX4 ULog flight logs and
   ulog2csv's CSV files (:mod:`omegahat.io.px4`), CCSDS attitude ephemeris messages (:mod:`omegahat.io.aem`),
   Universal Robots RTDE recordings (:mod:`omegahat.io.ur_rtde`), Xsens MT Manager exports (:mod:`omegahat.io.xsens`);
   pandas and Polars DataFrames enter the same path through :func:`omegahat.io.frames.open_frame`.
2. :func:`open_log` opens any of them as a :class:`LogStream` of :class:`LogChunk` and applies, in one place,
   the time unit, the rotation convention, the precision policy (:mod:`omegahat.io.precision`) and the timestamp
   policy (:mod:`omegahat.io.timestamps`);
   :func:`read_log` reads a whole stream into an :class:`AttitudeLog`.
3. :func:`omegahat.io.pipeline.estimate_stream` runs a stream through the estimator with automatic gains and
   writes the result through :func:`open_output`: the output formats are registered here too, beside the input
   formats, with :func:`register_writer` (:mod:`omegahat.io.writers`): CSV with a status column
   (:mod:`omegahat.io.output`, which also says how every output is whole or absent), the same rows as Parquet
   (:mod:`omegahat.io.parquet_output`) and ``geometry_msgs/TwistStamped`` bags (:mod:`omegahat.io.rosbag`).
   ``omegahat estimate`` and :func:`estimate_frame` are thin shells over it.
"""

from omegahat.io.aem import is_aem, open_aem
from omegahat.io.aem_output import open_aem_output
from omegahat.io.c3d import open_c3d
from omegahat.io.colmap import parse_columns, suggest_columns
from omegahat.io.columns import MATRIX_COLUMNS, QUATERNION_COLUMNS, TORQUE_COLUMNS, LogFormatError
from omegahat.io.csvlog import TextFormat, open_csv, open_text
from omegahat.io.frames import estimate_frame, open_frame
from omegahat.io.logs import AttitudeLog, read_csv, read_log, read_npz, write_omega_csv
from omegahat.io.mocap import is_motive, is_vicon, open_motive_csv, open_vicon_csv
from omegahat.io.npzlog import open_npz
from omegahat.io.output import OmegaWriter, check_output_path
from omegahat.io.parquet_input import open_parquet
from omegahat.io.parquet_output import ParquetOmegaWriter
from omegahat.io.px4 import is_px4_csv, is_ulog, open_px4_csv, open_ulog
from omegahat.io.qtm_mat import open_qtm_mat
from omegahat.io.qualisys import is_qtm_6d, open_qtm_6d
from omegahat.io.registry import (
    COLUMN_OPTIONS,
    DIRECTORY,
    MAP_OPTIONS,
    Format,
    LogChunk,
    LogStream,
    ReadOptions,
    detect_format,
    open_log,
    register_format,
)
from omegahat.io.rosbag import is_ros2_bag, open_bag, open_twist_output
from omegahat.io.timestamps import DUPLICATE_TOL
from omegahat.io.trajectories import is_euroc, is_kitti, is_tum, open_euroc, open_kitti, open_tum
from omegahat.io.ur_rtde import is_ur_rtde, open_ur_rtde
from omegahat.io.writers import check_output, open_output, output_kind, register_writer
from omegahat.io.xsens import is_xsens, open_xsens

_BAG = ("topic", "parent_frame", "child_frame", "stamp")
# Sniffing formats before the plain one of their extension (registry.detect_format): the order below is the order
# in which .csv files are asked.
register_format(
    ".csv", open_motive_csv, name="motive", title="an OptiTrack Motive CSV export", sniff=is_motive, options=("body",)
)
register_format(".csv", open_vicon_csv, name="vicon", title="a Vicon CSV export", sniff=is_vicon, options=("body",))
register_format(".csv", open_euroc, name="euroc", title="an EuRoC / ASL trajectory CSV", sniff=is_euroc, options=())
register_format(".csv", open_px4_csv, name="px4-csv", title="a PX4 ulog2csv topic CSV", sniff=is_px4_csv, options=())
register_format(
    (".csv", ".txt"),
    open_ur_rtde,
    name="ur-rtde",
    title="a Universal Robots RTDE recording",
    sniff=is_ur_rtde,
    options=(),
)
register_format(
    (".txt", ".csv", ".tsv"),
    open_xsens,
    name="xsens",
    title="an Xsens export (MT Manager, DOT)",
    sniff=is_xsens,
    options=("rate", "euler", "angle_unit"),
)
register_format(
    (".aem", ".kvn", ".txt", ".xml"),
    open_aem,
    name="aem",
    title="a CCSDS attitude ephemeris message (AEM)",
    sniff=is_aem,
    options=("body",),
)
register_format((".txt", ".tum"), open_tum, name="tum", title="a TUM trajectory", sniff=is_tum, options=())
register_format(".txt", open_kitti, name="kitti", title="a KITTI pose list", sniff=is_kitti, options=("rate", "times"))
register_format(
    ".tsv", open_qtm_6d, name="qtm6d", title="a Qualisys QTM 6D TSV export", sniff=is_qtm_6d, options=("body",)
)
register_format(
    (".csv", ".txt", ".tsv"),
    open_csv,
    name="csv",
    title="an omegahat CSV log",
    options=(*COLUMN_OPTIONS, *MAP_OPTIONS, "rate"),
)
register_format(".npz", open_npz, name="npz", title="an omegahat NPZ log")
register_format(".parquet", open_parquet, name="parquet", title="a Parquet table", options=(*COLUMN_OPTIONS, "columns"))
register_format(".mat", open_qtm_mat, name="qtm-mat", title="a Qualisys QTM MAT export", options=("body",))
register_format(".c3d", open_c3d, name="c3d", title="a C3D file", options=("body",))
register_format(".bag", open_bag, name="rosbag1", title="a ROS 1 bag", options=_BAG)
register_format(".ulg", open_ulog, name="ulog", title="a PX4 ULog flight log", sniff=is_ulog, options=("topic",))
register_format(
    (DIRECTORY, ".db3", ".mcap"), open_bag, name="rosbag2", title="a ROS 2 bag", sniff=is_ros2_bag, options=_BAG
)


def _csv_writer(path, stream: LogStream) -> OmegaWriter:
    return OmegaWriter(path, t0=stream.t0)  # times as the file states them


def _parquet_writer(path, stream: LogStream) -> ParquetOmegaWriter:
    return ParquetOmegaWriter(path, t0=stream.t0)


# The order of the listing in messages: .csv, .bag (ROS 1) or a name without extension (ROS 2 bag directory). A bag
# output copies the input messages' stamps and frames, and is never overwritten (a ROS 2 bag is a directory).
register_writer(".csv", _csv_writer, name="csv", title=".csv", noun="CSV file")
register_writer(".parquet", _parquet_writer, name="parquet", title=".parquet", noun="Parquet file")
register_writer(
    ".aem",
    open_aem_output,
    name="aem",
    title=".aem (CCSDS AEM)",
    noun="CCSDS AEM file",
    inputs=("aem",),
    why_inputs="its frames, time system and epochs",
)
for _ending, _name, _title in (
    (".bag", "rosbag1", ".bag (ROS 1)"),
    ("", "rosbag2", "a name without extension (ROS 2 bag directory)"),
):
    register_writer(
        _ending,
        open_twist_output,
        name=_name,
        title=_title,
        noun="bag",
        inputs=("rosbag1", "rosbag2"),
        settings=("frame_id", "topic"),
        overwrite=False,
        why_inputs="its stamps and frames",
    )

__all__ = [
    "DUPLICATE_TOL",
    "MATRIX_COLUMNS",
    "QUATERNION_COLUMNS",
    "TORQUE_COLUMNS",
    "AttitudeLog",
    "Format",
    "LogChunk",
    "LogFormatError",
    "LogStream",
    "OmegaWriter",
    "ReadOptions",
    "TextFormat",
    "check_output",
    "check_output_path",
    "detect_format",
    "estimate_frame",
    "open_frame",
    "open_log",
    "open_output",
    "open_text",
    "output_kind",
    "parse_columns",
    "read_csv",
    "read_log",
    "read_npz",
    "register_format",
    "register_writer",
    "suggest_columns",
    "write_omega_csv",
]
