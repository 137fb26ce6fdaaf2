"""ROS 1 and ROS 2 bags written by the tests with rosbags: every message type, frame selection, stamps, the
TwistStamped output, sign flips, and every error with its message."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.cli import main
from omegahat.io import LogFormatError, detect_format, read_log
from recording_files import J_AXI, flip_signs, read_omega_csv, read_twist_bag, torque_free_axisymmetric, write_bag

T0_NS = 1_700_000_000_123_456_789  # a realistic epoch stamp (float seconds would round it)
RATE = 100.0
N = 300


def motion(n=N, rate=RATE):
    stamps = T0_NS + np.round(np.arange(n) * 1e9 / rate).astype(np.int64)
    R, omega = torque_free_axisymmetric((stamps - T0_NS) * 1e-9)
    return stamps, Rotation.from_matrix(R).as_quat(), omega


def pose_messages(stamps, q, **extra):
    return [{"stamp_ns": int(s), "q": qq, **extra} for s, qq in zip(stamps, q, strict=True)]


CLI_GAINS = ["--inertia", "1", "1", "1.6"]


def run_cli(*args):
    return main(["estimate", *map(str, args), *CLI_GAINS, "--no-progress"])


@pytest.mark.parametrize("version", [1, 2])
def test_pose_stamped_to_twist_stamped_in_one_command(tmp_path, version, capsys):
    stamps, q, omega = motion()
    rng = np.random.default_rng(version)
    bag = tmp_path / ("run.bag" if version == 1 else "run")
    write_bag(
        bag, version, {"/vicon/body/pose": ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, flip_signs(q, rng)))}
    )
    assert detect_format(bag).name == f"rosbag{version}"
    out = tmp_path / ("twist.bag" if version == 1 else "twist")
    assert run_cli(bag, "--topic", "/vicon/body/pose", "-o", out) == 0
    printed = capsys.readouterr().out
    assert f"detected ROS {version} bag" in printed
    assert "topic /vicon/body/pose (geometry_msgs/PoseStamped, frame world)" in printed
    assert f"wrote {N} geometry_msgs/TwistStamped to ROS {version} bag" in printed
    topic, out_stamps, receive, frames, ang, lin = read_twist_bag(out)
    assert topic == "/omegahat/twist"
    np.testing.assert_array_equal(out_stamps, stamps)  # header stamps copied, to the nanosecond
    np.testing.assert_array_equal(receive, stamps + 2_000_000)  # recorded when the input was received
    assert set(frames) == {"body"}  # PoseStamped names no body frame
    assert np.all(np.isnan(lin))  # not estimated
    # the model is exact (J known, torque-free): after the warm start the rate is the truth
    np.testing.assert_allclose(ang[2:], omega[2:], atol=2e-4)


def test_a_ros2_bag_can_be_named_by_its_storage_file(tmp_path):
    stamps, q, _ = motion(20)
    write_bag(tmp_path / "run", 2, {"/pose": ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, q))})
    (db,) = (tmp_path / "run").glob("*.db3")
    assert detect_format(db).name == "rosbag2"
    assert len(read_log(db)) == 20


def test_quaternion_sign_flips_change_nothing(tmp_path):
    stamps, q, _ = motion()
    rng = np.random.default_rng(7)
    write_bag(tmp_path / "a.bag", 1, {"/p": ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, q))})
    write_bag(
        tmp_path / "b.bag", 1, {"/p": ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, flip_signs(q, rng)))}
    )
    for name in "ab":
        assert run_cli(tmp_path / f"{name}.bag", "-o", tmp_path / f"{name}.csv") == 0
    a = read_omega_csv(tmp_path / "a.csv")[0]
    b = read_omega_csv(tmp_path / "b.csv")[0]
    np.testing.assert_array_equal(a, b)
    assert np.abs(np.diff(a[5:, 1:], axis=0)).max() < 0.05  # no spikes: the rate changes smoothly


def test_csv_output_of_a_bag_carries_the_absolute_stamps(tmp_path):
    stamps, q, omega = motion(50)
    write_bag(tmp_path / "run.bag", 1, {"/p": ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, q))})
    assert run_cli(tmp_path / "run.bag", "-o", tmp_path / "w.csv") == 0
    table = read_omega_csv(tmp_path / "w.csv")[0]
    np.testing.assert_allclose(table[:, 0], stamps * 1e-9, rtol=0, atol=5e-7)  # float64 resolution at 1.7e9 s
    np.testing.assert_allclose(table[2:, 1:], omega[2:], atol=2e-4)


@pytest.mark.parametrize("version", [1, 2])
def test_tf_selects_the_transform_by_parent_and_child(tmp_path, version):
    stamps, q, omega = motion(120)
    q_other = Rotation.random(120, random_state=9).as_quat()
    messages = [
        {
            "transforms": [
                {"stamp_ns": int(s), "q": a, "parent": "world", "child": "drone"},
                {"stamp_ns": int(s), "q": b, "parent": "world", "child": "target"},
            ]
        }
        for s, a, b in zip(stamps, q, q_other, strict=True)
    ]
    bag = tmp_path / ("tf.bag" if version == 1 else "tf")
    write_bag(bag, version, {"/tf": ("tf2_msgs/msg/TFMessage", messages)})
    with pytest.raises(LogFormatError, match=r"2 transforms \(world -> drone, world -> target\); choose one with"):
        read_log(bag, topic="/tf")
    rec = read_log(bag, topic="/tf", parent_frame="/world", child_frame="drone")
    assert rec.meta["child"] == "drone" and rec.meta["parent"] == "world"
    np.testing.assert_array_equal(rec.data, q)
    with pytest.raises(LogFormatError, match=r"no transform from parent 'world' to child 'base'; the topic has"):
        read_log(bag, topic="/tf", parent_frame="world", child_frame="base")
    out = tmp_path / ("out.bag" if version == 1 else "out")
    assert run_cli(bag, "--topic", "/tf", "--child-frame", "drone", "-o", out) == 0
    _, out_stamps, _, frames, ang, _ = read_twist_bag(out)
    assert set(frames) == {"drone"}  # the body frame, named by the transform
    np.testing.assert_array_equal(out_stamps, stamps)
    np.testing.assert_allclose(ang[2:], omega[2:], atol=2e-4)


def test_transform_stamped_odometry_and_imu_topics(tmp_path, capsys):
    stamps, q, omega = motion(100)
    topics = {
        "/vicon/drone/drone": ("geometry_msgs/msg/TransformStamped", pose_messages(stamps, q, child="vicon/drone")),
        "/odom": ("nav_msgs/msg/Odometry", pose_messages(stamps, q, child="base_link")),
        "/imu/data": ("sensor_msgs/msg/Imu", pose_messages(stamps, q, child="imu_link")),
    }
    write_bag(tmp_path / "many.bag", 1, topics)
    with pytest.raises(LogFormatError, match=r"several topics with an orientation; choose one with --topic"):
        read_log(tmp_path / "many.bag")
    expected_frame = {"/vicon/drone/drone": "vicon/drone", "/odom": "base_link", "/imu/data": "imu_link"}
    for topic, frame in expected_frame.items():
        rec = read_log(tmp_path / "many.bag", topic=topic)
        np.testing.assert_array_equal(rec.data, q)
        assert rec.meta["child"] == frame
        out = tmp_path / f"{frame.replace('/', '_')}.bag"
        assert run_cli(tmp_path / "many.bag", "--topic", topic, "-o", out) == 0
        assert f"frame_id {frame!r}" in capsys.readouterr().out
        _, out_stamps, _, frames, ang, _ = read_twist_bag(out)
        assert frames == [frame] * 100
        np.testing.assert_array_equal(out_stamps, stamps)
        np.testing.assert_allclose(ang[2:], omega[2:], atol=2e-4)


def test_imu_without_orientation_is_refused(tmp_path):
    stamps, q, _ = motion(5)
    write_bag(
        tmp_path / "imu.bag",
        1,
        {"/imu/data_raw": ("sensor_msgs/msg/Imu", pose_messages(stamps, q, no_orientation=True))},
    )
    with pytest.raises(LogFormatError, match=r"topic /imu/data_raw, message 0: .*orientation_covariance\[0\] = -1"):
        read_log(tmp_path / "imu.bag")


def test_topic_errors_name_what_the_bag_has(tmp_path):
    stamps, q, _ = motion(5)
    topics = {
        "/pose": ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, q)),
        "/chatter": ("std_msgs/msg/String", [{"stamp_ns": 0}]),
    }
    write_bag(tmp_path / "b.bag", 1, topics)
    with pytest.raises(
        LogFormatError, match=r"no topic '/vicon'; topics in the bag: /chatter \(std_msgs/String\), /pose"
    ):
        read_log(tmp_path / "b.bag", topic="/vicon")
    with pytest.raises(LogFormatError, match=r"topic /chatter: type std_msgs/String carries no orientation"):
        read_log(tmp_path / "b.bag", topic="/chatter")
    assert len(read_log(tmp_path / "b.bag")) == 5  # the one topic with an orientation
    with pytest.raises(
        ValueError,
        match=r"x\.csv is an omegahat CSV log: --topic applies only to a ROS 1 bag, a PX4 ULog flight log and a ROS 2",
    ):
        read_log(tmp_path / "x.csv", topic="/pose")


def test_zero_header_stamps_ask_for_the_receive_time(tmp_path):
    _, q, _ = motion(30)
    receive = T0_NS + np.arange(30) * 10_000_000
    messages = [{"stamp_ns": 0, "receive_ns": int(r), "q": qq} for r, qq in zip(receive, q, strict=True)]
    write_bag(tmp_path / "z.bag", 1, {"/p": ("geometry_msgs/msg/PoseStamped", messages)})
    with pytest.raises(LogFormatError, match=r"every header stamp is zero .* --stamp receive"):
        read_log(tmp_path / "z.bag")
    rec = read_log(tmp_path / "z.bag", stamp="receive")
    np.testing.assert_allclose(rec.t, np.arange(30) * 0.01, atol=1e-15)
    assert "time = receive stamps" in rec.description


def test_out_of_order_and_duplicated_messages(tmp_path):
    stamps, q, _ = motion(40)
    order = np.arange(40)
    order[[10, 11]] = order[[11, 10]]  # two messages delivered swapped
    messages = [{"stamp_ns": int(stamps[k]), "q": q[k], "receive_ns": T0_NS + 10**7 * j} for j, k in enumerate(order)]
    messages.append({"stamp_ns": int(stamps[20]), "q": -q[20], "receive_ns": T0_NS + 10**9})  # resent, sign flipped
    write_bag(tmp_path / "d.bag", 1, {"/p": ("geometry_msgs/msg/PoseStamped", messages)})
    rec = read_log(tmp_path / "d.bag")
    assert len(rec) == 40
    np.testing.assert_array_equal(rec.extra["header_ns"], stamps)
    assert "2 message(s) arrived after a later-stamped one: sorted by time" in rec.notes
    assert "dropped 1 duplicated sample(s) (same time, same attitude)" in rec.notes
    messages[-1]["q"] = Rotation.from_rotvec([0, 0, 0.2]).as_quat()
    write_bag(tmp_path / "c.bag", 1, {"/p": ("geometry_msgs/msg/PoseStamped", messages)})
    with pytest.raises(LogFormatError, match=r"message 20 and .*message 40: two samples at the same time"):
        read_log(tmp_path / "c.bag")


def test_outputs_are_never_overwritten_and_bags_need_bag_inputs(tmp_path, capsys):
    stamps, q, _ = motion(10)
    write_bag(tmp_path / "run.bag", 1, {"/p": ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, q))})
    (tmp_path / "exists.bag").write_text("keep me")
    assert run_cli(tmp_path / "run.bag", "-o", tmp_path / "exists.bag") == 2
    assert "exists.bag exists; omegahat does not overwrite a bag" in capsys.readouterr().err
    assert (tmp_path / "exists.bag").read_text() == "keep me"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exists.bag", "run.bag"]  # no partial output left
    log = tmp_path / "log.csv"
    log.write_text("t,qx,qy,qz,qw\n0,0,0,0,1\n0.1,0,0,0,1\n")
    assert run_cli(log, "-o", tmp_path / "o.bag") == 2
    assert "a bag output needs a bag input" in capsys.readouterr().err
    assert run_cli(tmp_path / "run.bag", "-o", tmp_path / "o.txt") == 2
    assert "unknown output type '.txt'" in capsys.readouterr().err
    assert run_cli(tmp_path / "run.bag", "-o", tmp_path / "o.csv", "--frame-id", "drone") == 2
    assert "--frame-id and --output-topic apply to bag outputs only" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exists.bag", "log.csv", "run.bag"]


def test_estimates_match_the_estimator_fed_directly(tmp_path):
    """The bag path adds nothing to the numbers: the same quaternions through SarrasEstimator give the same rates."""
    from omegahat.observer.estimator import SarrasEstimator
    from omegahat.observer.tuning import bandwidth_gains

    stamps, q, _ = motion(80)
    write_bag(tmp_path / "run.bag", 1, {"/p": ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, q))})
    rec = read_log(tmp_path / "run.bag")
    gains = bandwidth_gains(J_AXI, 30.0 / (2 * np.pi))  # 30 rad/s
    est = SarrasEstimator(J_AXI, gains=gains, warm_start=True)
    expected = est.run((stamps - stamps[0]) * 1e-9, q).omega
    k, l = ([repr(float(x)) for x in a] for a in (gains.k, gains.l_offset))
    assert run_cli(tmp_path / "run.bag", "-o", tmp_path / "w.csv", "--start", "warm", "--k", *k, "--l", *l) == 0
    table, status = read_omega_csv(tmp_path / "w.csv")
    np.testing.assert_allclose(table[1:, 1:], expected[1:], rtol=0, atol=1e-12)
    assert status[0] == "unavailable" and np.all(np.isnan(table[0, 1:]))  # one attitude gives no rate
    assert rec.t0 == pytest.approx(stamps[0] * 1e-9, abs=1e-6)
