"""Issue 23, damaged ROS bags: a message that cannot be decoded, a damaged chunk, random bytes, a damaged ROS 2
database. Each gives a message naming the bag (and the topic and message where known), never a traceback; the bags
are built with rosbags' own writers."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pytest

from omegahat.cli import main
from omegahat.io import LogFormatError, read_log
from recording_files import write_bag
from test_rosbag import motion, pose_messages

POSE = "geometry_msgs/msg/PoseStamped"


def ros1_bag(path: Path, n: int = 200, compression: str | None = None) -> Path:
    """A ROS 1 bag of ``n`` PoseStamped on ``/p``, optionally with compressed chunks."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    stamps, q, _ = motion(n)
    ts = get_typestore(Stores.ROS1_NOETIC)
    T = ts.types
    writer = Writer(path)
    if compression:
        writer.set_compression(getattr(Writer.CompressionFormat, compression))
    with writer:
        conn = writer.add_connection("/p", POSE, typestore=ts)
        for s, qq in zip(stamps, q, strict=True):
            sec, nsec = divmod(int(s), 1_000_000_000)
            header = T["std_msgs/msg/Header"](seq=0, stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec),
                                              frame_id="world")  # fmt: skip
            pose = T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                orientation=T["geometry_msgs/msg/Quaternion"](x=qq[0], y=qq[1], z=qq[2], w=qq[3]),
            )
            writer.write(conn, int(s), ts.serialize_ros1(T[POSE](header=header, pose=pose), POSE))
    return path


def test_a_message_of_three_bytes(tmp_path):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    path = tmp_path / "short.bag"
    with Writer(path) as w:
        conn = w.add_connection("/p", POSE, typestore=get_typestore(Stores.ROS1_NOETIC))
        w.write(conn, 1000, b"abc")
    with pytest.raises(
        LogFormatError, match=r"short\.bag, topic /p, message 0: cannot be decoded as geometry_msgs/PoseStamped"
    ):
        read_log(path)


@pytest.mark.parametrize("compression", [None, "BZ2", "LZ4"])
def test_a_damaged_chunk(tmp_path, compression, capsys):
    path = ros1_bag(tmp_path / "run.bag", compression=compression)
    raw = bytearray(path.read_bytes())
    k = len(raw) // 3
    raw[k : k + 40] = b"\xff" * 40  # inside the chunk of messages
    path.write_bytes(bytes(raw))
    code = main(["estimate", str(path), "-o", str(tmp_path / "o.csv")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith(f"omegahat estimate: error: {path}") and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o.csv").exists()


def test_random_bytes_named_bag(tmp_path):
    path = tmp_path / "random.bag"
    path.write_bytes(np.random.default_rng(0).integers(0, 256, 5000, dtype=np.uint8).tobytes())
    with pytest.raises(LogFormatError, match=r"random\.bag: cannot open the bag \("):
        read_log(path)


def test_a_truncated_bag(tmp_path):
    path = ros1_bag(tmp_path / "run.bag")
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) * 2 // 3])
    with pytest.raises(LogFormatError, match=r"run\.bag"):
        read_log(path)


def test_a_damaged_ros2_database(tmp_path):
    stamps, q, _ = motion(50)
    bag = write_bag(tmp_path / "run", 2, {"/p": (POSE, pose_messages(stamps, q))})
    (db,) = Path(bag).glob("*.db3")
    with sqlite3.connect(db) as con:  # a message whose payload is cut to 3 bytes
        con.execute("UPDATE messages SET data = X'616263' WHERE id = 7")
    with pytest.raises(
        LogFormatError, match=r"run, topic /p, message 6: cannot be decoded as geometry_msgs/PoseStamped"
    ):
        read_log(bag)
    raw = bytearray(db.read_bytes())
    raw[100:4000] = bytes(3900)  # the database's first page
    db.write_bytes(bytes(raw))
    with pytest.raises(LogFormatError, match=r"run: cannot (open|read) the bag"):
        read_log(bag)


def test_a_ros2_message_without_data(tmp_path):
    # Found by the chaos suite (rosbag2, "zeros", rng 128): a zeroed page left a message's payload NULL, and the
    # message about it took the length of None (a traceback).
    stamps, q, _ = motion(50)
    bag = write_bag(tmp_path / "run", 2, {"/p": (POSE, pose_messages(stamps, q))})
    (db,) = Path(bag).glob("*.db3")
    with sqlite3.connect(db) as con:  # the table as damaged bytes leave it: its NOT NULL no longer holds
        con.executescript(
            "ALTER TABLE messages RENAME TO kept; CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER, "
            "timestamp INTEGER, data BLOB); INSERT INTO messages SELECT * FROM kept; DROP TABLE kept; "
            "UPDATE messages SET data = NULL WHERE id = 7;"
        )
    with pytest.raises(
        LogFormatError, match=r"run, topic /p, message 6: cannot be decoded as geometry_msgs/PoseStamped \(no data\)"
    ):
        read_log(bag)


def test_a_message_the_bag_lost_is_not_lost_without_a_word(tmp_path):
    # A damaged byte moved a message to a topic that does not exist: the bag's own count says one is missing.
    stamps, q, _ = motion(50)
    bag = write_bag(tmp_path / "run", 2, {"/p": (POSE, pose_messages(stamps, q))})
    (db,) = Path(bag).glob("*.db3")
    with sqlite3.connect(db) as con:
        con.execute("UPDATE messages SET topic_id = 99 WHERE id = 7")
    with pytest.raises(
        LogFormatError, match=r"run, topic /p: the bag says it holds 50 messages there, but 49 could be read"
    ):
        read_log(bag)
