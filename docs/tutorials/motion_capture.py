"""Tutorial: body rates from a Motive export and from a ROS bag (run by tests/test_docs.py)."""

import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

import omegahat
from omegahat.cli import main
from omegahat.io import read_log

workdir = Path(tempfile.mkdtemp())

# --- 1. A take: a hand-held wand seen at 120 Hz (your export replaces this block) ----------------------------
rate = 120.0
t = np.arange(0.0, 10.0, 1.0 / rate)
alpha, beta, c = 0.8, 0.6, 2.0  # yaw at 0.8 rad/s while rocking ±0.6 rad about x at 2 rad/s
A = Rotation.from_rotvec(np.outer(alpha * t, [0, 0, 1]))
B = Rotation.from_rotvec(np.outer(beta * np.sin(c * t), [1, 0, 0]))
attitude = A * B  # body -> world
# its body rate in closed form: ω = Bᵀ (0, 0, α) + (β c cos(ct), 0, 0)
omega_true = B.inv().apply([0, 0, alpha]) + np.outer(beta * c * np.cos(c * t), [1, 0, 0])
rng = np.random.default_rng(3)
measured = attitude * Rotation.from_rotvec(rng.normal(0, 5e-4, (t.size, 3)))  # 0.5 mrad of tracking noise
q = measured.as_quat()  # x, y, z, w: what Motive writes
q[rng.random(t.size) < 0.5] *= -1  # quaternion sign flips, as exports have them: q and -q are one rotation

rows = [
    "Format Version,1.23,Take Name,wand take,Capture Frame Rate,120.000000,Export Frame Rate,120.000000,"
    "Rotation Type,Quaternion,Length Units,Meters,Coordinate Space,Global",
    "",
    ",Type," + ",".join(["Rigid Body"] * 7),
    ",Name," + ",".join(["wand"] * 7),
    ",ID," + ",".join(["1"] * 7),
    ",," + ",".join(["Rotation"] * 4 + ["Position"] * 3),
    "Frame,Time (Seconds),X,Y,Z,W,X,Y,Z",
]
for k in range(t.size):
    values = "" if k in (300, 301, 302) else ",".join(f"{v:.6f}" for v in q[k])  # 3 frames untracked
    rows.append(f"{k},{t[k]:.6f}," + (values or ",,,") + ",0.1,1.2,0.3")
take = workdir / "wand_take.csv"
take.write_text("\n".join(rows) + "\n")

# --- 2. One command: the format is recognised, the gains chosen from the take, the rate in the wand's own axes --
main(["estimate", str(take), "-o", str(workdir / "omega.csv"), "--no-progress"])
table = np.loadtxt(workdir / "omega.csv", delimiter=",", skiprows=1, usecols=(0, 1, 2, 3))  # t, wx, wy, wz(, status)
settled = table[:, 0] > 1.0
rms = np.sqrt(np.mean((table[settled, 1:] - omega_true[settled]) ** 2))
print(f"omegahat: rms error {rms:.4f} rad/s per axis")

# what you would have done by hand: difference consecutive attitudes
R = measured.as_matrix()
diff = Rotation.from_matrix(np.einsum("tji,tjk->tik", R[:-1], R[1:])).as_rotvec() * rate
rms_diff = np.sqrt(np.mean((diff[settled[1:]] - omega_true[1:][settled[1:]]) ** 2))
print(f"differencing: rms error {rms_diff:.4f} rad/s per axis")

# --- 2b. The mocap preset (J and tau unknown), causal and smoothed -------------------------------------------------
# It was tuned on recordings of a fast-moving hand with less noise than this take: here it warns, and the gains
# chosen from the take (step 2) do better causally; offline, --smooth removes the lag.
for extra in ([], ["--smooth"]):
    main(["estimate", str(take), "-o", str(workdir / "preset.csv"), "--no-progress", "--preset", "mocap", *extra])
    table = np.loadtxt(workdir / "preset.csv", delimiter=",", skiprows=1, usecols=(0, 1, 2, 3))
    rms = np.sqrt(np.mean((table[settled, 1:] - omega_true[settled]) ** 2))
    print(f"--preset mocap {' '.join(extra)}: rms error {rms:.4f} rad/s per axis")

# --- 3. The same from Python, with pandas ------------------------------------------------------------------
log = read_log(take)  # what was detected, and the samples the estimator runs on
print(log.description)
frame = pd.DataFrame(log.data, columns=["qx", "qy", "qz", "qw"])
frame["t"] = log.t
with warnings.catch_warnings(record=True) as said:  # what Python would print to stderr, shown here with the rest
    warnings.simplefilter("always")
    omega = omegahat.estimate_frame(frame)  # the model identified from the data, as the command does; a row per row
for w in said:
    print(f"{w.category.__name__}: {w.message}")
print(omega.iloc[-3:])

# --- 4. A ROS bag: a geometry_msgs/PoseStamped topic in, TwistStamped out -------------------------------------
from rosbags.rosbag1 import Writer  # noqa: E402  (pure Python, no ROS needed)
from rosbags.typesys import Stores, get_typestore  # noqa: E402

ts = get_typestore(Stores.ROS1_NOETIC)
Msg = ts.types
bag = workdir / "run.bag"
with Writer(bag) as writer:
    conn = writer.add_connection("/vicon/wand/pose", "geometry_msgs/msg/PoseStamped", typestore=ts)
    for k in range(t.size):
        sec, nsec = divmod(1_700_000_000_000_000_000 + round(t[k] * 1e9), 1_000_000_000)
        header = Msg["std_msgs/msg/Header"](
            seq=k, stamp=Msg["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id="world"
        )
        pose = Msg["geometry_msgs/msg/Pose"](
            position=Msg["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=1.0),
            orientation=Msg["geometry_msgs/msg/Quaternion"](x=q[k, 0], y=q[k, 1], z=q[k, 2], w=q[k, 3]),
        )
        msg = Msg["geometry_msgs/msg/PoseStamped"](header=header, pose=pose)
        writer.write(conn, sec * 1_000_000_000 + nsec, ts.serialize_ros1(msg, "geometry_msgs/msg/PoseStamped"))

main(
    [
        "estimate",
        str(bag),
        "--topic",
        "/vicon/wand/pose",
        "--frame-id",
        "wand",
        "-o",
        str(workdir / "twist.bag"),
        "--no-progress",
    ]
)
