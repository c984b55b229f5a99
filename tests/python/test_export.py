"""ROS 1 bags of runs (dronetwin.export, `dronetwin export`): every log row becomes one message
per topic at the row's simulated time, read back with python3-rosbag and checked against the log
(pose and rotor speeds exactly, the body-frame twist rotated back to the world by an independent
quaternion product); `rosbag info` reads the file; a fleet run is namespaced per vehicle; an
existing bag is never replaced."""

import os
import subprocess

import numpy as np
import pytest

import dronetwin as dt
from dronetwin import export
from conftest import source_path

rosbag = pytest.importorskip("rosbag", reason="python3-rosbag (bash .ci/install-deps)")


def quat_mul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw])


def to_world(q, v_body):
    """q (0, v) q*: the body vector in the world frame."""
    conj = np.array([q[0], -q[1], -q[2], -q[3]])
    return quat_mul(quat_mul(q, np.r_[0.0, v_body]), conj)[1:]


@pytest.fixture(scope="module")
def se3_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "se3"
    e = dt.load_experiment(source_path("config", "experiments", "se3_circle.yaml"))
    e.duration_s = 1.0
    assert dt.run_experiment(e, str(out)).ok
    return out


def messages(bag_path):
    by_topic = {}
    with rosbag.Bag(str(bag_path)) as bag:
        for topic, msg, t in bag.read_messages():
            by_topic.setdefault(topic, []).append((msg, t))
    return by_topic


def test_every_row_is_a_message_at_its_time_with_the_logged_values(cli, se3_run, tmp_path):
    bag_path = tmp_path / "se3.bag"
    r = subprocess.run([cli, "export", str(se3_run), "--bag", str(bag_path)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    log = dt.read_log(se3_run / "log.csv")
    n = len(log["t"])
    topics = messages(bag_path)
    assert set(topics) == {"/dronetwin/odometry", "/dronetwin/odometry_measured", "/tf",
                           "/dronetwin/rotor_speeds", "/dronetwin/rotor_speed_references",
                           "/dronetwin/reference"}
    assert all(len(v) == n for v in topics.values())
    for i, (m, t) in enumerate(topics["/dronetwin/odometry"]):
        assert t.to_nsec() == round(log["t"][i] * 1e9) == m.header.stamp.to_nsec()
        assert (m.header.frame_id, m.child_frame_id) == ("world", "base_link")
        p, q = m.pose.pose.position, m.pose.pose.orientation
        assert [p.x, p.y, p.z] == [log["x"][i], log["y"][i], log["z"][i]]
        quat = np.array([q.w, q.x, q.y, q.z])
        assert list(quat) == [log["qw"][i], log["qx"][i], log["qy"][i], log["qz"][i]]
        # The twist is in the body frame: rotated back it is the logged world velocity.
        lin, ang = m.twist.twist.linear, m.twist.twist.angular
        v_world = to_world(quat, np.array([lin.x, lin.y, lin.z]))
        np.testing.assert_allclose(v_world, [log["vx"][i], log["vy"][i], log["vz"][i]],
                                   rtol=0, atol=1e-12)
        assert [ang.x, ang.y, ang.z] == [log["wx"][i], log["wy"][i], log["wz"][i]]
    for i, (m, _) in enumerate(topics["/dronetwin/odometry_measured"]):
        assert m.pose.pose.position.x == log["meas_x"][i]
    for i, (m, _) in enumerate(topics["/tf"]):
        (tf,) = m.transforms
        assert (tf.header.frame_id, tf.child_frame_id) == ("world", "base_link")
        assert [tf.transform.translation.z, tf.transform.rotation.w] == [log["z"][i], log["qw"][i]]
    for i, (m, _) in enumerate(topics["/dronetwin/rotor_speeds"]):
        assert list(m.data) == [log[f"omega_{k}"][i] for k in range(4)]
    for i, (m, _) in enumerate(topics["/dronetwin/reference"]):
        assert m.pose.position.y == log["ref_y"][i]
        yaw = 2.0 * np.arctan2(m.pose.orientation.z, m.pose.orientation.w)
        assert yaw == pytest.approx(log["ref_yaw"][i], abs=1e-12)
    # The ROS tool reads it too.
    info = subprocess.run(["rosbag", "info", str(bag_path)], capture_output=True, text=True,
                          timeout=60)
    assert info.returncode == 0, info.stderr
    assert f"messages:    {6 * n}" in info.stdout and "nav_msgs/Odometry" in info.stdout


def test_a_fleet_run_is_namespaced_per_vehicle(cli, tmp_path):
    out = tmp_path / "fleet"
    r = subprocess.run([cli, "run", source_path("config", "experiments", "crossing_downwash.yaml"),
                        "--out", str(out), "--duration", "0.2", "-q"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    bag_path = tmp_path / "fleet.bag"
    counts = export.export_bag(str(out), str(bag_path))
    names = sorted(d for d in os.listdir(out) if (out / d).is_dir())
    assert len(names) == 2
    topics = messages(bag_path)
    for name in names:
        log = dt.read_log(out / name / "log.csv")
        odometry = topics[f"/{name}/dronetwin/odometry"]
        assert len(odometry) == len(log["t"]) == counts[f"/{name}/dronetwin/odometry"]
        assert odometry[-1][0].child_frame_id == f"{name}/base_link"
        assert odometry[-1][0].pose.pose.position.z == log["z"][-1]
    frames = {m.transforms[0].child_frame_id for m, _ in topics["/tf"]}
    assert frames == {f"{name}/base_link" for name in names}


def test_an_existing_bag_is_never_replaced_and_bad_input_is_named(cli, se3_run, tmp_path):
    bag_path = tmp_path / "kept.bag"
    bag_path.write_bytes(b"precious")
    r = subprocess.run([cli, "export", str(se3_run), "--bag", str(bag_path)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "already exists" in r.stderr
    assert bag_path.read_bytes() == b"precious"
    r = subprocess.run([cli, "export", str(tmp_path), "--bag", str(tmp_path / "x.bag")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "log.csv" in r.stderr and "missing" in r.stderr
    r = subprocess.run([cli, "export", str(se3_run), "--bag", str(tmp_path / "x.txt")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "ending in .bag" in r.stderr
    assert sorted(os.listdir(tmp_path)) == ["kept.bag"]  # no temporaries left behind
