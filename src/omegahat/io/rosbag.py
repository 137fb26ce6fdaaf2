r"""ROS 1 and ROS 2 bags, read and written with the pure-Python ``rosbags`` library (no ROS installation).

``pip install "omegahat[ros]"``. A ROS 1 bag is a ``.bag`` file; a ROS 2 bag is a directory holding
``metadata.yaml`` and its ``.db3`` or ``.mcap`` storage (a path to that storage file is taken as its directory).

**Input**: the orientation carried by one topic, with the message type recognised from the bag:

==============================================  ================================  =====================================
message type                                    orientation                       body frame (output ``frame_id``)
==============================================  ================================  =====================================
``geometry_msgs/PoseStamped``                   ``pose.orientation``              not named: ``--frame-id`` or "body"
``geometry_msgs/PoseWithCovarianceStamped``     ``pose.pose.orientation``         not named: as above
``geometry_msgs/TransformStamped``              ``transform.rotation``            ``child_frame_id``
``tf2_msgs/TFMessage`` (``/tf``)                the transform selected by         ``child_frame_id``
                                                parent and child frame
``nav_msgs/Odometry``                           ``pose.pose.orientation``         ``child_frame_id``
``sensor_msgs/Imu``                             ``orientation``                   ``header.frame_id``
==============================================  ================================  =====================================

ROS orientations rotate the child (body) frame into the parent (fixed) frame, ``p_parent = R(q) p_child``:
omegahat's ``R`` (body → inertial), so the estimate is the body's rate **in the body frame**. Quaternions are
``(x, y, z, w)``; ``q`` and ``−q`` are the same rotation and a sign flip between messages changes nothing. An
``Imu`` whose ``orientation_covariance[0]`` is ``−1`` carries no orientation (REP 145) and is refused.

Times are the messages' **header stamps** (the time of capture, which network delivery does not delay) unless
``ReadOptions.stamp`` is ``"receive"`` (``--stamp receive``: the time the recorder received the message), which
helps when a driver leaves the header stamp at zero. Stamps are integer nanoseconds: the stream's times are
seconds since the first stamp (``LogStream.t0``; as floats since 1970 they would be rounded to 0.24 µs), and the
stamps themselves travel with each row (``LogChunk.extra``) to the output. Messages are sorted by stamp
(:func:`omegahat.io.timestamps.sort_by_time`); duplicates are handled by the timestamp policy of
:func:`omegahat.io.registry.open_log`, which names messages by their index in the bag.

**Output** (:class:`TwistBagWriter`): ``geometry_msgs/TwistStamped`` on one topic (default ``/omegahat/twist``),
one message per estimate, ``twist.angular`` the body-frame rate in rad/s (NaN where no estimate exists yet),
``header.frame_id`` the body frame, ``header.stamp`` copied from the input message the estimate belongs to,
recorded at that message's receive time; ``twist.linear`` is NaN (not estimated). A ``.bag`` path gives a ROS 1
bag, a name without extension a ROS 2 bag directory (SQLite storage). The bag is written under a temporary name
beside the target and renamed when complete, so the output is whole or absent; an existing output is never
overwritten (a ROS 2 bag is a directory, which cannot be replaced atomically).

**Damaged bags** (a damaged chunk, a truncated payload, random bytes, a damaged ROS 2 database) are errors naming
the bag, and the topic and message where known: whatever rosbags' parsers raise on damaged bytes becomes a
:class:`~omegahat.io.LogFormatError`. A message is never dropped silently: the messages read on the topic must be
as many as the bag's own count says (its index, or a ROS 2 bag's ``metadata.yaml``).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from omegahat.io.columns import LogFormatError
from omegahat.io.output import AtomicOutput, PartFile, remove_stale_parts, target_of, write_error
from omegahat.io.registry import LogChunk, LogStream, ReadOptions
from omegahat.io.timestamps import sort_by_time

if TYPE_CHECKING:  # rosbags is optional: imported where it is used
    from rosbags.rosbag1 import Writer as Bag1Writer
    from rosbags.rosbag2 import Writer as Bag2Writer

__all__ = [
    "DEFAULT_TWIST_TOPIC",
    "SUPPORTED_TYPES",
    "TwistBagWriter",
    "bag_path",
    "is_ros2_bag",
    "open_bag",
    "open_twist_output",
]

DEFAULT_TWIST_TOPIC = "/omegahat/twist"

SUPPORTED_TYPES = (
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "geometry_msgs/msg/TransformStamped",
    "tf2_msgs/msg/TFMessage",
    "nav_msgs/msg/Odometry",
    "sensor_msgs/msg/Imu",
)


def _rosbags():
    try:
        import rosbags.highlevel
        import rosbags.typesys
    except ImportError:  # pragma: no cover - the test extra installs it
        raise ImportError('reading and writing ROS bags needs rosbags: pip install "omegahat[ros]"') from None
    import rosbags

    return rosbags


def bag_path(path: str | os.PathLike[str]) -> Path | None:
    """The bag a path names (a ``.bag`` file, a ROS 2 bag directory, or a file inside one), else None."""
    p = Path(path)
    if p.suffix == ".bag" and p.is_file():
        return p
    if p.is_dir() and (p / "metadata.yaml").is_file():
        return p
    if p.suffix in (".db3", ".mcap") and (p.parent / "metadata.yaml").is_file():
        return p.parent
    return None


def is_ros2_bag(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a ROS 2 bag: a directory with ``metadata.yaml``, or its ``.db3``/``.mcap`` storage."""
    p = bag_path(path)
    return p is not None and p.is_dir()


def _frame(name: str | None) -> str | None:
    return None if name is None else name.lstrip("/")


def _stamp_ns(header) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def _quat(q) -> tuple[float, float, float, float]:
    return (float(q.x), float(q.y), float(q.z), float(q.w))


def _samples(msgtype: str, msg, topic: str, where: str):
    """Yield ``(header_ns, (x, y, z, w), parent, child)`` for one message (several for a TFMessage)."""
    if msgtype == "tf2_msgs/msg/TFMessage":
        for tr in msg.transforms:
            yield (
                _stamp_ns(tr.header),
                _quat(tr.transform.rotation),
                _frame(tr.header.frame_id),
                _frame(tr.child_frame_id),
            )
    elif msgtype == "geometry_msgs/msg/TransformStamped":
        yield (
            _stamp_ns(msg.header),
            _quat(msg.transform.rotation),
            _frame(msg.header.frame_id),
            _frame(msg.child_frame_id),
        )
    elif msgtype == "geometry_msgs/msg/PoseStamped":
        yield _stamp_ns(msg.header), _quat(msg.pose.orientation), _frame(msg.header.frame_id), None
    elif msgtype == "geometry_msgs/msg/PoseWithCovarianceStamped":
        yield _stamp_ns(msg.header), _quat(msg.pose.pose.orientation), _frame(msg.header.frame_id), None
    elif msgtype == "nav_msgs/msg/Odometry":
        yield (
            _stamp_ns(msg.header),
            _quat(msg.pose.pose.orientation),
            _frame(msg.header.frame_id),
            _frame(msg.child_frame_id),
        )
    elif msgtype == "sensor_msgs/msg/Imu":
        if float(msg.orientation_covariance[0]) == -1.0:
            raise LogFormatError(
                f"{where}: this sensor_msgs/Imu has orientation_covariance[0] = -1, i.e. no orientation "
                "(REP 145); omegahat needs the orientation (an IMU driver with an orientation filter, or a mocap topic)"
            )
        yield _stamp_ns(msg.header), _quat(msg.orientation), None, _frame(msg.header.frame_id)


def _why(exc: BaseException) -> str:
    """An exception from rosbags or a decompressor as words: its type and message."""
    text = str(exc).strip()
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _decoded(reader, conns, where: str) -> Iterator[tuple[int, int, Any]]:
    """``(index, receive time ns, message)`` of the topic's messages; a message that cannot be read or decoded
    (a damaged chunk, a truncated payload) is an error naming it. rosbags' parsers raise many kinds of exception
    on damaged bytes (their own, ``struct.error``, ``UnicodeDecodeError``, a decompressor's ``OSError`` or
    ``RuntimeError``), so any exception of theirs becomes a :class:`~x`."""
    messages = reader.messages(connections=conns)
    k = 0
    while True:
        try:
            conn, timestamp, raw = next(messages)
        except StopIteration:
            return
        except Exception as exc:
            raise LogFormatError(f"{where}: cannot read message {k}: the bag is damaged there ({_why(exc)})") from None
        try:
            msg = reader.deserialize(raw, conn.msgtype)
        except Exception as exc:
            # a damaged SQLite bag can hold a NULL message
            what = "no data" if raw is None else f"{len(raw)} bytes: {_why(exc)}"
            raise LogFormatError(
                f"{where}, message {k}: cannot be decoded as {conn.msgtype.replace('/msg/', '/')} ({what}); the bag is "
                "damaged there"
            ) from None
        yield k, int(timestamp), msg
        k += 1


def _describe_topics(connections) -> str:
    seen: dict[str, str] = {}
    for c in connections:
        seen.setdefault(c.topic, c.msgtype)
    return ", ".join(f"{t} ({m.replace('/msg/', '/')})" for t, m in sorted(seen.items()))


def open_bag(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """The orientation on ``options.topic`` in a ROS 1 or ROS 2 bag (module docstring).

    The topic may be omitted when one topic has a supported type. For ``/tf`` (``tf2_msgs/TFMessage``) and
    other transform topics, ``options.parent_frame`` and ``child_frame`` select the transform (needed when several
    are present; the error lists them). Raises :class:`~omegahat.io.LogFormatError` naming the bag, topic and
    message. The whole topic is read now (to sort it by stamp) and handed on in chunks.
    """
    _rosbags()
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    topic, parent_frame, child_frame, stamp = options.topic, options.parent_frame, options.child_frame, options.stamp
    p = bag_path(path)
    if p is None:
        raise LogFormatError(
            f"{os.fspath(path)}: not a ROS bag (a .bag file, or a ROS 2 bag directory with metadata.yaml)"
        )
    want_parent, want_child = _frame(parent_frame), _frame(child_frame)
    try:
        reader = AnyReader([p], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
    except Exception as exc:  # damaged bytes raise anything from rosbags' parsers (module docstring)
        raise LogFormatError(f"{p}: cannot open the bag ({_why(exc)})") from None
    try:
        supported = [c for c in reader.connections if c.msgtype in SUPPORTED_TYPES]
        if topic is None:
            topics = sorted({c.topic for c in supported})
            if len(topics) != 1:
                raise LogFormatError(
                    f"{p}: {'several' if topics else 'no'} topics with an orientation; choose one with --topic "
                    f"(topics in the bag: {_describe_topics(reader.connections) or 'none'}; readable types: "
                    f"{', '.join(t.replace('/msg/', '/') for t in SUPPORTED_TYPES)})"
                )
            topic = topics[0]
        conns = [c for c in reader.connections if c.topic == topic]
        if not conns:
            raise LogFormatError(
                f"{p}: no topic {topic!r}; topics in the bag: {_describe_topics(reader.connections) or 'none'}"
            )
        msgtype = conns[0].msgtype
        if msgtype not in SUPPORTED_TYPES:
            raise LogFormatError(
                f"{p}, topic {topic}: type {msgtype.replace('/msg/', '/')} carries no orientation omegahat reads; "
                f"readable types: {', '.join(t.replace('/msg/', '/') for t in SUPPORTED_TYPES)}"
            )
        header_ns, receive_ns, quats, pairs, index = [], [], [], [], []
        n_read = 0
        for k, timestamp, msg in _decoded(reader, conns, f"{p}, topic {topic}"):
            n_read += 1
            for h_ns, q, parent, child in _samples(msgtype, msg, topic, f"{p}, topic {topic}, message {k}"):
                header_ns.append(h_ns)
                receive_ns.append(int(timestamp))
                quats.append(q)
                pairs.append((parent, child))
                index.append(k)
        declared = sum(int(c.msgcount) for c in conns)
        if declared and n_read != declared:  # a damaged index or table: messages would be lost without a word
            raise LogFormatError(
                f"{p}, topic {topic}: the bag says it holds {declared} messages there, but {n_read} could be read: "
                "the bag is damaged"
            )
    finally:
        with contextlib.suppress(Exception):  # a damaged bag may fail to close too: the error above tells
            reader.close()
    if not quats:
        raise LogFormatError(f"{p}, topic {topic}: no messages")
    pair_set = sorted(set(pairs), key=lambda x: (x[0] or "", x[1] or ""))
    select = np.ones(len(pairs), dtype=bool)
    if want_parent is not None or want_child is not None:
        select = np.array(
            [(want_parent is None or a == want_parent) and (want_child is None or b == want_child) for a, b in pairs]
        )
        if not select.any():
            raise LogFormatError(
                f"{p}, topic {topic}: no transform from parent {want_parent or '*'!r} to child {want_child or '*'!r}; "
                f"the topic has {', '.join(f'{a} -> {b}' for a, b in pair_set)}"
            )
    chosen = sorted({pairs[i] for i in np.flatnonzero(select)}, key=lambda x: (x[0] or "", x[1] or ""))
    if len(chosen) > 1:
        raise LogFormatError(
            f"{p}, topic {topic}: {len(chosen)} transforms ({', '.join(f'{a} -> {b}' for a, b in chosen)}); choose "
            "one with --parent-frame and --child-frame"
        )
    parent, child = chosen[0]
    idx = np.flatnonzero(select)
    header_stamps = np.array(header_ns, dtype=np.int64)[idx]
    receive_stamps = np.array(receive_ns, dtype=np.int64)[idx]
    q = np.array(quats, dtype=float)[idx]
    msg_index = np.array(index)[idx]
    if stamp == "header" and not np.any(header_stamps):
        raise LogFormatError(
            f"{p}, topic {topic}: every header stamp is zero (the driver does not stamp its messages); use the "
            "receive time instead: --stamp receive (stamp='receive' in Python)"
        )
    stamps = header_stamps if stamp == "header" else receive_stamps
    order, n_late = sort_by_time(stamps)
    times = stamps[order]
    version = 2 if p.is_dir() else 1
    frames = f"{parent} -> {child}" if parent and child else (f"frame {child or parent}" if child or parent else "")
    description = (
        f"ROS {version} bag {p.name}: topic {topic} ({msgtype.replace('/msg/', '/')}"
        + (f", {frames}" if frames else "")
        + f"), {idx.size} orientations, quaternions x,y,z,w, time = {stamp} stamps"
    )
    notes = [f"{n_late} message(s) arrived after a later-stamped one: sorted by time"] if n_late else []
    base = int(times[0])
    return LogStream.from_arrays(
        os.fspath(p),
        "quaternion",
        (times - base).astype(np.float64) * 1e-9,
        q[order],
        labels=msg_index[order],
        extra={"header_ns": header_stamps[order], "receive_ns": receive_stamps[order]},
        label="message",
        context=f", topic {topic}",
        time_name=None,
        t0=base * 1e-9,
        description=description,
        notes=notes,
        meta={"topic": topic, "parent": parent, "child": child, "ros_version": version},
        attitude_name="orientation",
    )


# --------------------------------------------------------------------------------------------------- output


_TWIST = "geometry_msgs/msg/TwistStamped"


def _twist_messages(typestore, header_ns, omega, frame_id: str, ros_version: int, first_seq: int = 0):
    Time = typestore.types["builtin_interfaces/msg/Time"]
    Header = typestore.types["std_msgs/msg/Header"]
    Vector3 = typestore.types["geometry_msgs/msg/Vector3"]
    Twist = typestore.types["geometry_msgs/msg/Twist"]
    TwistStamped = typestore.types["geometry_msgs/msg/TwistStamped"]
    nan = Vector3(x=np.nan, y=np.nan, z=np.nan)
    for k in range(omega.shape[0]):
        sec, nsec = divmod(int(header_ns[k]), 1_000_000_000)
        stamp = Time(sec=sec, nanosec=nsec)
        header = (
            Header(seq=first_seq + k, stamp=stamp, frame_id=frame_id)
            if ros_version == 1
            else Header(stamp=stamp, frame_id=frame_id)
        )
        w = omega[k]
        yield TwistStamped(
            header=header, twist=Twist(linear=nan, angular=Vector3(x=float(w[0]), y=float(w[1]), z=float(w[2])))
        )


class TwistBagWriter(AtomicOutput):
    """Chunked, atomic writer of ``geometry_msgs/TwistStamped`` (module docstring), with the interface of
    :class:`omegahat.io.output.OmegaWriter`: ``write(chunk, omega, status)`` takes the stamps from the chunk's
    ``extra`` (``header_ns``, ``receive_ns``: rows of a bag's stream), the bag appears on a clean exit of the
    ``with`` block, never on an exception. ``path`` ending in ``.bag``: ROS 1, otherwise a ROS 2 bag directory.
    The bag is written in a temporary folder beside it (:class:`omegahat.io.output.PartFile`); a failure (disk
    full, a storage error) removes it and names the output."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        frame_id: str,
        topic: str = DEFAULT_TWIST_TOPIC,
        source: str | None = None,
    ):
        _rosbags()
        from rosbags.typesys import Stores, get_typestore

        self.path = Path(path)
        if not frame_id:
            raise ValueError("a TwistStamped output needs the body frame's name (frame_id)")
        self.target = target_of(self.path)
        if self.target.exists():
            raise FileExistsError(f"{self.path} exists; omegahat does not overwrite a bag (choose another output)")
        self.ros_version = 1 if self.path.suffix == ".bag" else 2
        self.frame_id, self.topic, self.source, self.rows = frame_id, topic, source, 0
        self.removed_stale = remove_stale_parts(self.path)
        try:
            self._staging = PartFile(self.target, folder=True)
        except OSError as exc:
            raise write_error(exc, self.path) from exc
        inner = self._staging.path / self.target.name
        self._writer: Bag1Writer | Bag2Writer
        try:
            if self.ros_version == 1:
                from rosbags.rosbag1 import Writer as Bag1Writer

                self._ts = get_typestore(Stores.ROS1_NOETIC)
                self._serialize = self._ts.serialize_ros1
                self._writer = Bag1Writer(inner)
            else:
                from rosbags.rosbag2 import Writer as Bag2Writer

                self._ts = get_typestore(Stores.LATEST)
                self._serialize = self._ts.serialize_cdr
                self._writer = Bag2Writer(inner, version=8)
            self._writer.open()
            self._conn = self._writer.add_connection(topic, _TWIST, typestore=self._ts)
        except Exception as exc:
            self._staging.discard()
            raise write_error(exc, self.path) from exc
        except BaseException:
            self._staging.discard()
            raise
        self._inner = inner

    def write(self, chunk: LogChunk, omega: np.ndarray, status: np.ndarray) -> None:
        """One message per row of ``chunk`` (stamps from ``chunk.extra``), ``omega (m, 3)`` rad/s."""
        if chunk.extra is None or "header_ns" not in chunk.extra:
            raise ValueError("a TwistStamped output needs the input messages' stamps (a bag input)")
        header_ns, receive_ns = chunk.extra["header_ns"], chunk.extra["receive_ns"]
        messages = _twist_messages(self._ts, header_ns, omega, self.frame_id, self.ros_version, self.rows)
        try:
            for k, msg in enumerate(messages):
                self._writer.write(self._conn, int(receive_ns[k]), self._serialize(msg, _TWIST))
        except _storage_errors() as exc:  # disk full, the storage's own errors (SQLite: "disk is full")
            raise write_error(exc, self.path) from exc
        self.rows += len(chunk)

    def describe(self) -> str:
        """What was written, for the command's closing line."""
        link = "" if self.target == self.path else f" (a link: written to {self.target})"
        return (
            f"{self.rows} geometry_msgs/TwistStamped to ROS {self.ros_version} bag {self.path}{link}, topic "
            f"{self.topic}, frame_id {self.frame_id!r} (body frame)"
            + (f", header stamps copied from {self.source}" if self.source else ", header stamps copied")
            + self.stale_note()
        )

    def commit(self) -> None:
        """Close the bag and move it onto the target; on any failure nothing is left behind."""
        try:
            self._writer.close()
            if self.target.exists():  # appeared while we wrote: still never overwritten
                raise FileExistsError(f"{self.path} exists; omegahat does not overwrite a bag (choose another output)")
            os.rename(self._inner, self.target)
        except FileExistsError:
            self._staging.discard()
            raise
        except _storage_errors() as exc:
            self._staging.discard()
            raise write_error(exc, self.path) from exc
        except BaseException:
            self._staging.discard()
            raise
        self._staging.discard()

    def abort(self) -> None:
        """Remove the temporary folder; the target is left as it was."""
        with contextlib.suppress(Exception):
            self._writer.close()
        self._staging.discard()


def open_twist_output(
    path: str | os.PathLike[str], stream: LogStream, *, frame_id: str | None = None, topic: str | None = None
) -> TwistBagWriter:
    """The :class:`TwistBagWriter` of a bag stream's estimates (the opener of the writers' registry,
    :mod:`omegahat.io.writers`): ``frame_id`` default the body frame the input names, else ``"body"``; ``topic``
    default :data:`DEFAULT_TWIST_TOPIC`."""
    frame = frame_id or stream.meta.get("child") or "body"
    return TwistBagWriter(path, frame_id=frame, topic=topic or DEFAULT_TWIST_TOPIC, source=stream.meta.get("topic"))


def _storage_errors() -> tuple[type[Exception], ...]:
    """The errors of a storage that cannot be written or read: the system's (disk full), SQLite's ("database or
    disk is full") and rosbags' own."""
    import sqlite3

    from rosbags.rosbag1 import ReaderError as Bag1ReaderError
    from rosbags.rosbag1 import WriterError as Bag1WriterError
    from rosbags.rosbag2 import ReaderError as Bag2ReaderError
    from rosbags.rosbag2 import WriterError as Bag2WriterError

    return (OSError, sqlite3.Error, Bag1WriterError, Bag2WriterError, Bag1ReaderError, Bag2ReaderError)
