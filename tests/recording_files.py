"""Test helpers: a motion with a closed-form body rate, and writers of recordings in the formats users have.

The writers follow the documented layouts (module docstrings of ``omegahat.io.mocap``, ``omegahat.io.c3d`` and
``omegahat.io.rosbag``) and use SciPy / rosbags / ezc3d for the conversions, not omegahat's code, so a reader that
misreads a convention fails these tests.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

# ------------------------------------------------------------------------------------- closed-form motion

J_AXI = np.diag([1.0, 1.0, 1.6])  # axisymmetric: torque-free motion in closed form
_I, _J3 = 1.0, 1.6
_OMEGA0 = np.array([0.5, -0.3, 1.2])  # body rate at t = 0
_R0 = Rotation.from_rotvec([0.3, -0.2, 0.9]).as_matrix()


def torque_free_axisymmetric(t):
    """Exact torque-free motion of ``J_AXI``: ``R(t) = exp(t a×) R0 exp(−t λ e3×)``, ``a = L/I``,
    ``λ = (J3 − I) ω3 / I``; returns ``(R (T, 3, 3), omega (T, 3))`` (omega in body axes, ``Rᵀ a − λ e3``)."""
    t = np.asarray(t, dtype=float)
    L = _R0 @ (J_AXI @ _OMEGA0)
    a = L / _I
    lam = (_J3 - _I) * _OMEGA0[2] / _I
    A = Rotation.from_rotvec(t[:, None] * a).as_matrix()
    B = Rotation.from_rotvec(-t[:, None] * lam * np.array([0.0, 0.0, 1.0])).as_matrix()
    R = A @ _R0 @ B
    omega = np.einsum("tji,j->ti", R, a) - lam * np.array([0.0, 0.0, 1.0])
    return R, omega


def noisy(R, sigma, rng):
    """``R exp(δ×)`` with ``δ ~ N(0, σ² I)`` per sample."""
    return R @ Rotation.from_rotvec(rng.normal(0.0, sigma, (R.shape[0], 3))).as_matrix()


def flip_signs(q, rng, fraction=0.5):
    """Quaternions with a random ``fraction`` of them negated (the same rotations)."""
    q = np.array(q, dtype=float)
    flip = rng.random(q.shape[0]) < fraction
    q[flip] *= -1.0
    return q


# ------------------------------------------------------------------------------------- OptiTrack Motive


def _fmt(x, digits):
    if not np.isfinite(x):
        return ""
    return repr(float(x)) if digits is None else f"{x:.{digits}f}"


def write_motive_csv(path, t, bodies: dict, *, missing=(), digits=None, rotation_type="Quaternion", version="1.23"):
    """A Motive export (format 1.2x): ``bodies`` maps a rigid body's name to its quaternions ``(T, 4)`` x,y,z,w;
    each body gets position and mean-marker-error columns and one rigid-body marker, and one unlabeled marker
    follows, as Motive writes them. ``missing``: frame indices where the rigid bodies are untracked (empty)."""
    T = len(t)
    meta = (
        f"Format Version,{version},Take Name,omegahat test take,Take Notes,,Capture Frame Rate,120.000000,"
        f"Export Frame Rate,120.000000,Capture Start Time,2024-01-01 10.00.00.000 AM,Capture Start Frame,0,"
        f"Total Frames in Take,{T},Total Exported Frames,{T},Rotation Type,{rotation_type},Length Units,Meters,"
        "Coordinate Space,Global"
    )
    types, names, ids, comps, axes = [",Type"], [",Name"], [",ID"], [","], ["Frame,Time (Seconds)"]
    for i, name in enumerate(bodies):
        types += ["Rigid Body"] * 8 + ["Rigid Body Marker"] * 4
        names += [name] * 8 + [f"{name}:Marker1"] * 4
        ids += [str(i + 1)] * 8 + [f"{i + 1}:1"] * 4
        comps += ["Rotation"] * 4 + ["Position"] * 3 + ["Mean Marker Error"] + ["Position"] * 3 + ["Marker Quality"]
        axes += ["X", "Y", "Z", "W", "X", "Y", "Z", "", "X", "Y", "Z", ""]
    types += ["Marker"] * 3
    names += ["Unlabeled 1000"] * 3
    ids += ["1000"] * 3
    comps += ["Position"] * 3
    axes += ["X", "Y", "Z"]
    lines = [meta, "", ",".join(types), ",".join(names), ",".join(ids), ",".join(comps), ",".join(axes)]
    for k in range(T):
        row = [str(k), f"{t[k]:.6f}" if digits is not None else repr(float(t[k]))]
        for q in bodies.values():
            if k in missing:
                row += [""] * 12
            else:
                row += [_fmt(v, digits) for v in q[k]] + ["0.1", "1.2", "-0.3", "0.0002", "0.1", "1.3", "-0.3", "1"]
        row += ["0.5", "0.5", "0.5"]
        lines.append(",".join(row))
    Path(path).write_text("\n".join(lines) + "\n")
    return path


# ------------------------------------------------------------------------------------- Vicon


def write_vicon_csv(path, frames, rate, objects: dict, *, unit="deg", title="Segments", trajectories=True, missing=()):
    """A Vicon Nexus-style export: a section ``title`` with each object's helical angles RX,RY,RZ (from SciPy's
    ``as_rotvec``) and TX,TY,TZ, then (``trajectories``) a Trajectories section with one marker."""
    names = [",,"]
    labels = ["Frame,Sub Frame"]
    units = [","]
    for name in objects:
        names.append(name + ",,,,,")
        labels.append("RX,RY,RZ,TX,TY,TZ")
        units.append(",".join([unit] * 3 + ["mm"] * 3))
    lines = [title, f"{rate:g}", "".join(names), ",".join(labels), ",".join(units)]
    rotvecs = {name: Rotation.from_matrix(R).as_rotvec(degrees=(unit == "deg")) for name, R in objects.items()}
    for k, frame in enumerate(frames):
        row = [str(int(frame)), "0"]
        for name in objects:
            if k in missing:
                row += [""] * 6
            else:
                row += [repr(float(v)) for v in rotvecs[name][k]] + ["10.5", "-3.25", "900.0"]
        lines.append(",".join(row))
    if trajectories:
        lines += ["", "Trajectories", f"{rate:g}", ",,drone:m1,,", "Frame,Sub Frame,X,Y,Z", ",,mm,mm,mm"]
        lines += [f"{int(f)},0,1.0,2.0,3.0" for f in frames]
    Path(path).write_text("\n".join(lines) + "\n")
    return path


# ------------------------------------------------------------------------------------- ROS bags


def write_bag(path, version, topics: dict, *, receive_delay_ns=2_000_000):
    """Write a ROS 1 (``version=1``, ``path`` ending ``.bag``) or ROS 2 (``version=2``, a directory) bag.

    ``topics[topic] = (msgtype, messages)`` with ``messages`` a list of dicts: ``stamp_ns`` (header stamp),
    ``q`` (x, y, z, w) and, by type, ``parent``/``child`` (frames) or, for ``tf2_msgs/msg/TFMessage``,
    ``transforms``: a list of such dicts. Each message is recorded ``receive_delay_ns`` after its stamp unless it
    has its own ``receive_ns``.
    """
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    if version == 1:
        from rosbags.rosbag1 import Writer

        ts = get_typestore(Stores.ROS1_NOETIC)
        ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
        serialize = ts.serialize_ros1
        writer = Writer(path)
    else:
        from rosbags.rosbag2 import Writer

        ts = get_typestore(Stores.LATEST)
        serialize = ts.serialize_cdr
        writer = Writer(path, version=9)
    T = ts.types

    def header(stamp_ns, frame_id):
        sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
        stamp = T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec)
        if version == 1:
            return T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame_id)
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)

    def quat(q):
        x, y, z, w = (float(v) for v in q)
        return T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    point = T["geometry_msgs/msg/Point"](x=1.0, y=2.0, z=3.0)
    vec = T["geometry_msgs/msg/Vector3"](x=1.0, y=2.0, z=3.0)
    cov36 = np.zeros(36)

    def transform(m):
        return T["geometry_msgs/msg/TransformStamped"](
            header=header(m["stamp_ns"], m.get("parent", "world")),
            child_frame_id=m.get("child", "body"),
            transform=T["geometry_msgs/msg/Transform"](translation=vec, rotation=quat(m["q"])),
        )

    def build(msgtype, m):
        if msgtype == "geometry_msgs/msg/PoseStamped":
            pose = T["geometry_msgs/msg/Pose"](position=point, orientation=quat(m["q"]))
            return T[msgtype](header=header(m["stamp_ns"], m.get("parent", "world")), pose=pose)
        if msgtype == "geometry_msgs/msg/TransformStamped":
            return transform(m)
        if msgtype == "tf2_msgs/msg/TFMessage":
            return T[msgtype](transforms=[transform(x) for x in m["transforms"]])
        if msgtype == "nav_msgs/msg/Odometry":
            pose = T["geometry_msgs/msg/PoseWithCovariance"](
                pose=T["geometry_msgs/msg/Pose"](position=point, orientation=quat(m["q"])), covariance=cov36
            )
            twist = T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=vec, angular=vec), covariance=cov36
            )
            return T[msgtype](
                header=header(m["stamp_ns"], m.get("parent", "odom")),
                child_frame_id=m.get("child", "base_link"),
                pose=pose,
                twist=twist,
            )
        if msgtype == "sensor_msgs/msg/Imu":
            ocov = np.full(9, -1.0) if m.get("no_orientation") else np.zeros(9)
            return T[msgtype](
                header=header(m["stamp_ns"], m.get("child", "imu_link")),
                orientation=quat(m["q"]),
                orientation_covariance=ocov,
                angular_velocity=vec,
                angular_velocity_covariance=np.zeros(9),
                linear_acceleration=vec,
                linear_acceleration_covariance=np.zeros(9),
            )
        if msgtype == "std_msgs/msg/String":
            return T[msgtype](data="hello")
        raise ValueError(msgtype)

    with writer:
        entries = []
        for topic, (msgtype, messages) in topics.items():
            conn = writer.add_connection(topic, msgtype, typestore=ts)
            for m in messages:
                stamp = m.get("stamp_ns", m["transforms"][0]["stamp_ns"] if "transforms" in m else 0)
                entries.append((m.get("receive_ns", stamp + receive_delay_ns), conn, msgtype, m))
        entries.sort(key=lambda e: e[0])
        for receive, conn, msgtype, m in entries:
            writer.write(conn, int(receive), serialize(build(msgtype, m), msgtype))
    return path


def read_omega_csv(path):
    """``(table (T, 4) of t, wx, wy, wz; status words (T,))`` of an ``omegahat estimate`` CSV output."""
    table = np.loadtxt(path, delimiter=",", skiprows=1, usecols=(0, 1, 2, 3), ndmin=2)
    status = np.loadtxt(path, delimiter=",", skiprows=1, usecols=4, dtype=str, ndmin=1)
    return table, status


def estimate_file(path, tmp_path, capsys, *options):
    """``omegahat estimate path -o tmp_path/o.csv --no-progress *options``, which must succeed: ``(its table, as
    :func:`read_omega_csv`'s, what it printed on both streams)``."""
    from omegahat.cli import main

    out = tmp_path / "o.csv"
    out.unlink(missing_ok=True)
    code = main(["estimate", str(path), "-o", str(out), "--no-progress", *options])
    printed = capsys.readouterr()
    assert code == 0, printed.err
    return read_omega_csv(out)[0], printed.out + printed.err


def read_twist_bag(path):
    """``(topic, header stamps ns, receive ns, frame_ids, angular (T, 3), linear (T, 3))`` from a bag, read
    with rosbags directly."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([Path(path)], default_typestore=get_typestore(Stores.LATEST)) as reader:
        (conn,) = reader.connections
        assert conn.msgtype == "geometry_msgs/msg/TwistStamped"
        stamps, receive, frames, ang, lin = [], [], [], [], []
        for c, ts, raw in reader.messages(connections=[conn]):
            msg = reader.deserialize(raw, c.msgtype)
            stamps.append(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
            receive.append(ts)
            frames.append(msg.header.frame_id)
            ang.append([msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z])
            lin.append([msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z])
    return conn.topic, np.array(stamps), np.array(receive), frames, np.array(ang), np.array(lin)
