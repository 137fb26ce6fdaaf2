"""The options of ``omegahat estimate`` for recordings (ROS bags, Motive, Vicon, C3D) and bag outputs.

A thin shell over :mod:`omegahat.io.detect`: the input's format is recognised from the file
(:func:`omegahat.io.detect_format`), what was detected is printed, and the output's kind follows its name
(``.csv``; ``.bag`` for ROS 1; a name without extension for a ROS 2 bag directory when the input is a bag).
"""

from __future__ import annotations

import argparse

from omegahat.io import Recording, output_kind, read_recording, write_estimates
from omegahat.io.rosbag import DEFAULT_TWIST_TOPIC

__all__ = ["INPUT_HELP", "add_arguments", "read_input", "write_output"]

INPUT_HELP = (
    "attitude data: an omegahat log (.csv, .npz), a ROS 1 bag (.bag) or ROS 2 bag (directory), an OptiTrack "
    "Motive or Vicon CSV export, or a C3D file with rigid-body rotations (recognised from the file)"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options for recordings, in their own group of ``--help``."""
    g = parser.add_argument_group(
        "recordings (ROS bags, motion-capture exports)",
        "Bags: the orientation on one topic (PoseStamped, TransformStamped or tf2_msgs/TFMessage on /tf, "
        "Odometry, Imu); output -o X.csv, -o X.bag (ROS 1) or -o X (ROS 2 directory) with "
        "geometry_msgs/TwistStamped in the body frame, header stamps copied. Motive/Vicon/C3D: one rigid body.",
    )
    g.add_argument("--topic", help="bag topic to read (optional when one topic carries an orientation)")
    g.add_argument("--parent-frame", metavar="FRAME", help="for /tf and transforms: the fixed (parent) frame")
    g.add_argument("--child-frame", metavar="FRAME", help="for /tf and transforms: the body (child) frame")
    g.add_argument(
        "--stamp",
        choices=("header", "receive"),
        default="header",
        help="bag time: the messages' header stamps (default) or the time the recorder received them",
    )
    g.add_argument(
        "--body", metavar="NAME", help="rigid body / object / segment to read from a Motive, Vicon or C3D file"
    )
    g.add_argument(
        "--output-topic",
        metavar="TOPIC",
        help=f"topic of the TwistStamped messages in a bag output (default {DEFAULT_TWIST_TOPIC})",
    )
    g.add_argument(
        "--frame-id",
        metavar="FRAME",
        help="frame_id of the output messages (default: the body frame the input names, else 'body')",
    )


def read_input(args: argparse.Namespace, progress=None) -> Recording:
    """Read ``args.input`` with the recording options; prints what was detected (nothing for omegahat logs)."""
    recording = read_recording(
        args.input,
        topic=args.topic,
        parent_frame=args.parent_frame,
        child_frame=args.child_frame,
        stamp=args.stamp,
        body=args.body,
        progress=progress,
    )
    if recording.format != "log":
        print(f"detected {recording.summary()}")
    output_kind(args.output, recording)  # an output that cannot be written fails now, not after the work
    return recording


def write_output(args: argparse.Namespace, recording: Recording, omega) -> None:
    """Write the estimates to ``args.output`` (CSV or bag); prints a line for bag outputs."""
    line = write_estimates(args.output, recording, omega, frame_id=args.frame_id, topic=args.output_topic)
    if output_kind(args.output, recording) != "csv":
        print(line)
