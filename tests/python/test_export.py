"""ROS 1 bags of runs (dronetwin.export, `dronetwin export`): every log row becomes one message
per topic at the row's simulated time, read back with python3-rosbag and checked against the log
(pose and rotor speeds exactly, the body-frame twist rotated back to the world by an independent
quaternion product); `rosbag info` reads the file; a fleet run is namespaced per vehicle; an
existing bag is never replaced. The MCAP export, read by a reader of our own, holds the bag's
messages byte for byte with their definitions."""

import os
import subprocess
from pathlib import Path

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


# ---- MCAP ------------------------------------------------------------------------------------
# A reader of our own for the MCAP records the export uses (mcap.dev/spec: magic, then records
# of opcode u8, length u64, content; little-endian; strings and byte arrays prefixed by a u32
# length), independent of the @mcap/core library that wrote the file.
MCAP_MAGIC = b"\x89MCAP0\r\n"


def mcap_records(data):
    """[(opcode, content)] of an MCAP file, the records inside chunks in place of the chunks
    (whose CRC is checked)."""
    import struct
    import zlib

    assert data[:8] == MCAP_MAGIC and data[-8:] == MCAP_MAGIC
    out, at = [], 8
    while at < len(data) - 8:
        op, length = struct.unpack_from("<BQ", data, at)
        content = data[at + 9: at + 9 + length]
        at += 9 + length
        if op == 0x06:  # chunk: start, end, uncompressed size and CRC, compression, records
            _, _, size, crc = struct.unpack_from("<QQQI", content, 0)
            (n,) = struct.unpack_from("<I", content, 28)
            compression = content[32: 32 + n].decode()
            (m,) = struct.unpack_from("<Q", content, 32 + n)
            records = content[40 + n: 40 + n + m]
            assert compression == "" and len(records) == size and zlib.crc32(records) == crc
            out += mcap_records(MCAP_MAGIC + records + MCAP_MAGIC)
        else:
            out.append((op, content))
    return out


def mcap_messages(path):
    """{topic: [(log time ns, data)]}, the schemas {name: (encoding, text)} and the header."""
    import struct

    def text(content, at):
        (n,) = struct.unpack_from("<I", content, at)
        return content[at + 4: at + 4 + n], at + 4 + n

    schemas, channels, topics, header = {}, {}, {}, None
    for op, c in mcap_records(Path(path).read_bytes()):
        if op == 0x01:
            profile, at = text(c, 0)
            header = (profile.decode(), text(c, at)[0].decode())
        elif op == 0x03:
            (sid,) = struct.unpack_from("<H", c, 0)
            name, at = text(c, 2)
            encoding, at = text(c, at)
            schemas[sid] = (name.decode(), encoding.decode(), text(c, at)[0].decode())
        elif op == 0x04:
            cid, sid = struct.unpack_from("<HH", c, 0)
            topic, at = text(c, 4)
            encoding, _ = text(c, at)
            channels[cid] = (topic.decode(), sid, encoding.decode())
        elif op == 0x05:
            cid, _, log_time, publish_time = struct.unpack_from("<HIQQ", c, 0)
            assert log_time == publish_time
            topics.setdefault(channels[cid][0], []).append((log_time, bytes(c[22:])))
    named = {schemas[sid][0]: schemas[sid][1:] for _, sid, _ in channels.values()}
    assert all(encoding == "ros1" for _, _, encoding in channels.values())
    return topics, named, header


def test_mcap_holds_the_bags_messages_byte_for_byte(cli, se3_run, tmp_path):
    bag_path, mcap_path = tmp_path / "se3.bag", tmp_path / "se3.mcap"
    r = subprocess.run([cli, "export", str(se3_run), "--bag", str(bag_path), "--mcap", str(mcap_path)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    topics, schemas, header = mcap_messages(mcap_path)
    assert header[0] == "ros1"
    bag_topics, definitions = {}, {}
    with rosbag.Bag(str(bag_path)) as bag:
        for topic, raw, t in bag.read_messages(raw=True):
            bag_topics.setdefault(topic, []).append((t.to_nsec(), bytes(raw[1])))
        for c in bag._get_connections():
            definitions[c.datatype] = c.msg_def
    assert set(topics) == set(bag_topics) and len(topics) == 6
    for topic in topics:
        assert topics[topic] == bag_topics[topic], topic
    assert {name: ("ros1msg", text) for name, text in definitions.items()} == schemas
    # The times are the log's, from t = 0.
    log = dt.read_log(se3_run / "log.csv")
    times = [t for t, _ in topics["/dronetwin/odometry"]]
    assert times[0] == 0 and times == [round(t * 1e9) for t in log["t"]]


def test_an_existing_mcap_is_never_replaced_and_bad_input_is_named(cli, se3_run, tmp_path):
    kept = tmp_path / "kept.mcap"
    kept.write_bytes(b"precious")
    r = subprocess.run([cli, "export", str(se3_run), "--mcap", str(kept)], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 2 and "--mcap" in r.stderr and "already exists" in r.stderr
    assert kept.read_bytes() == b"precious"
    r = subprocess.run([cli, "export", str(se3_run), "--mcap", str(tmp_path / "x.bag")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "ending in .mcap" in r.stderr
    r = subprocess.run([cli, "export", str(se3_run)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "nothing to write" in r.stderr
    assert sorted(os.listdir(tmp_path)) == ["kept.mcap"]  # no temporaries left behind
