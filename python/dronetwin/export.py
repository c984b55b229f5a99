"""A run's log as a ROS 1 bag (rosbag, rqt_bag, RViz with a bag player, Foxglove) or as MCAP.

    dronetwin export out/pid_pulse --bag out/pid_pulse.bag
    dronetwin export out/pid_pulse --mcap out/pid_pulse.mcap
    python3 -m dronetwin.export out/pid_pulse --bag out/pid_pulse.bag

Writes one message per log row and topic, stamped with the row's simulated time (header stamps
and bag times alike, from t = 0):

    /dronetwin/odometry           nav_msgs/Odometry          true state: pose in `world`, twist
                                                             in `base_link` (body velocity, rates)
    /dronetwin/odometry_measured  nav_msgs/Odometry          the measured state (log with meas_*)
    /tf                           tf2_msgs/TFMessage         world -> base_link
    /dronetwin/rotor_speeds       std_msgs/Float64MultiArray omega_0 .. omega_{n-1}, rad/s
    /dronetwin/rotor_speed_references  (the same for omega_ref_*)
    /dronetwin/reference          geometry_msgs/PoseStamped  ref_x .. ref_yaw (closed loop)
    /dronetwin/wind               geometry_msgs/Vector3Stamped  wind_x .. wind_z (when logged)

A fleet run (fleet_summary.json) puts each vehicle under /<vehicle>/ and its frame base_link as
<vehicle>/base_link. The bag is written under a temporary name beside it and moved into place at
the end; an existing file is never replaced. Needs Debian's python3-rosbag and the message
packages (python3-nav-msgs, python3-geometry-msgs, python3-std-msgs, python3-tf2-msgs), which
.ci/install-deps installs; no ROS master or catkin workspace. Format notes: docs/ros.md.

MCAP holds the same topics and messages (ros1 profile: ROS 1 serialisation, the definitions as
ros1msg schemas); it is written by the MCAP project's TypeScript library @mcap/core, bundled with
the viewer at build time and run with Node.js (export_mcap).
"""

from __future__ import annotations

import argparse
import io
import os
import shutil
import struct
import subprocess
import sys
import tempfile

import numpy as np


class ExportError(ValueError):
    """A run folder or bag path that cannot be used: the message names it."""


def _ros():
    try:
        import rosbag
        import rospy
        from geometry_msgs.msg import PoseStamped, TransformStamped, Vector3Stamped
        from nav_msgs.msg import Odometry
        from std_msgs.msg import Float64MultiArray, MultiArrayDimension
        from tf2_msgs.msg import TFMessage
    except ImportError as e:
        raise ExportError(f"bag export needs ROS 1's Python packages ({e}); install them with "
                          "`bash .ci/install-deps` (python3-rosbag and the message packages)"
                          ) from None
    return {"rosbag": rosbag, "Time": rospy.Time, "PoseStamped": PoseStamped,
            "TransformStamped": TransformStamped, "Vector3Stamped": Vector3Stamped,
            "Odometry": Odometry, "Float64MultiArray": Float64MultiArray,
            "MultiArrayDimension": MultiArrayDimension, "TFMessage": TFMessage}


def _rotate_to_body(q, v):
    """R(q)^T v for unit quaternions q = (w, x, y, z), row by row."""
    w, x, y, z = q.T
    # Rows of R (body to world), so R^T v = [col_0 . v, col_1 . v, col_2 . v].
    r = np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1),
    ], axis=1)  # (n, 3, 3)
    return np.einsum("nji,nj->ni", r, v)


def _write_vehicle(R, bag, log, ns, child):
    """Every topic of one vehicle's log into `bag`; returns {topic: count}."""
    counts = {}
    n = len(log["t"])

    def emit(topic, make):
        """make(i, stamp) -> the message of row i, written at the row's time."""
        for i in range(n):
            stamp = R["Time"].from_sec(float(log["t"][i]))
            bag.write(topic, make(i, stamp), stamp)
        counts[topic] = counts.get(topic, 0) + n

    def stamped(kind, stamp, child_frame=None):
        m = R[kind]()
        m.header.stamp = stamp
        m.header.frame_id = "world"
        if child_frame is not None:
            m.child_frame_id = child_frame
        return m

    def row(i, *columns):
        return (float(log[c][i]) for c in columns)

    for prefix, topic in (("", "odometry"), ("meas_", "odometry_measured")):
        if prefix + "qw" not in log:
            continue
        pose_columns = [prefix + c for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]
        q = np.stack([log[c] for c in pose_columns[3:]], axis=1)
        v_body = _rotate_to_body(q, np.stack([log[prefix + c] for c in ("vx", "vy", "vz")], axis=1))

        def odometry(i, stamp, prefix=prefix, pose_columns=pose_columns, v_body=v_body):
            m = stamped("Odometry", stamp, child)
            p, o = m.pose.pose.position, m.pose.pose.orientation
            p.x, p.y, p.z, o.w, o.x, o.y, o.z = row(i, *pose_columns)
            lin, ang = m.twist.twist.linear, m.twist.twist.angular
            lin.x, lin.y, lin.z = (float(c) for c in v_body[i])
            ang.x, ang.y, ang.z = row(i, prefix + "wx", prefix + "wy", prefix + "wz")
            return m

        emit(f"{ns}/dronetwin/{topic}", odometry)

    def transform(i, stamp):
        tf = stamped("TransformStamped", stamp, child)
        tr, rot = tf.transform.translation, tf.transform.rotation
        tr.x, tr.y, tr.z, rot.w, rot.x, rot.y, rot.z = row(i, "x", "y", "z", "qw", "qx", "qy", "qz")
        return R["TFMessage"](transforms=[tf])

    emit("/tf", transform)
    rotors = sorted(int(k.split("_")[-1]) for k in log
                    if k.startswith("omega_") and not k.startswith("omega_ref_"))
    for name, topic in (("omega_", "rotor_speeds"), ("omega_ref_", "rotor_speed_references")):
        if not rotors or not all(f"{name}{r}" in log for r in rotors):
            continue

        def speeds(i, stamp, name=name):
            m = R["Float64MultiArray"]()
            m.layout.dim = [R["MultiArrayDimension"](label="rotor", size=len(rotors), stride=1)]
            m.data = list(row(i, *(f"{name}{r}" for r in rotors)))
            return m

        emit(f"{ns}/dronetwin/{topic}", speeds)
    if "ref_x" in log:

        def reference(i, stamp):
            m = stamped("PoseStamped", stamp)
            p = m.pose.position
            p.x, p.y, p.z, yaw = row(i, "ref_x", "ref_y", "ref_z", "ref_yaw")
            o = m.pose.orientation
            o.w, o.z = float(np.cos(yaw / 2)), float(np.sin(yaw / 2))
            return m

        emit(f"{ns}/dronetwin/reference", reference)
    if "wind_x" in log:

        def wind(i, stamp):
            m = stamped("Vector3Stamped", stamp)
            m.vector.x, m.vector.y, m.vector.z = row(i, "wind_x", "wind_y", "wind_z")
            return m

        emit(f"{ns}/dronetwin/wind", wind)
    return counts


def _vehicles(run_dir):
    """[(namespace, child frame, log.csv path)] of a run or a fleet run folder."""
    from . import run_vehicle_folders

    out = []
    for name, folder in run_vehicle_folders(run_dir):
        ns, child = (f"/{name}", f"{name}/base_link") if name else ("", "base_link")
        out.append((ns, child, os.path.join(folder, "log.csv")))
    return out


def _checked_logs(run_dir, out_path, option, extension):
    """The (namespace, child frame, log) of every vehicle of `run_dir`, after checking that the
    run is readable and `out_path` is a new file ending in `extension` in an existing folder."""
    from . import read_log

    if not os.path.isdir(run_dir):
        raise ExportError(f"{run_dir}: not a folder (expected a run folder with log.csv)")
    vehicles = _vehicles(run_dir)
    for _, _, log_path in vehicles:
        if not os.path.isfile(log_path):
            raise ExportError(f"{log_path}: missing (expected the log of `dronetwin run`)")
    if os.path.lexists(out_path):
        raise ExportError(f"{option} {out_path}: already exists; the export never replaces a file")
    if not out_path.endswith(extension):
        raise ExportError(f"{option} {out_path}: expected a file name ending in {extension}")
    folder = os.path.dirname(os.path.abspath(out_path))
    if not os.path.isdir(folder):
        raise ExportError(f"{option} {out_path}: folder {folder} does not exist")
    return [(ns, child, read_log(path)) for ns, child, path in vehicles]


def _write_atomically(out_path, option, write):
    """Calls write(temporary path) for a file beside `out_path`, then moves it into place unless
    `out_path` appeared meanwhile (then it is kept and ours dropped)."""
    folder = os.path.dirname(os.path.abspath(out_path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(out_path) + ".", suffix=".partial",
                               dir=folder)
    os.close(fd)
    try:
        result = write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would hide the file from other users
        if os.path.lexists(out_path):
            raise ExportError(f"{option} {out_path}: appeared while exporting; not replaced")
        os.replace(tmp, out_path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return result


def export_bag(run_dir, bag_path):
    """Writes the run in `run_dir` (a `dronetwin run` folder or a fleet run) to a new bag at
    `bag_path`; returns {topic: message count}."""
    logs = _checked_logs(run_dir, bag_path, "--bag", ".bag")
    R = _ros()

    def write(tmp):
        counts = {}
        with R["rosbag"].Bag(tmp, "w") as bag:
            for ns, child, log in logs:
                for topic, c in _write_vehicle(R, bag, log, ns, child).items():
                    counts[topic] = counts.get(topic, 0) + c
        return counts

    return _write_atomically(bag_path, "--bag", write)


MCAP_WRITER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "viewer", "mcap_writer.cjs")


class _McapRecords:
    """Takes the messages of _write_vehicle (bag.write's signature) and serialises them, in ROS 1
    wire format with their message definitions, into the input stream of mcap_writer.cjs."""

    def __init__(self):
        self.out = io.BytesIO()
        self.out.write(b"DTMCAPIN")
        self.schemas, self.channels = {}, {}

    def _text(self, value):
        data = value.encode("utf-8") if isinstance(value, str) else value
        self.out.write(struct.pack("<I", len(data)))
        self.out.write(data)

    def write(self, topic, msg, stamp):
        schema = self.schemas.get(msg._type)
        if schema is None:
            schema = self.schemas[msg._type] = len(self.schemas) + 1
            self.out.write(struct.pack("<BH", 1, schema))
            self._text(msg._type)
            self._text(msg._full_text)
        channel = self.channels.get(topic)
        if channel is None:
            channel = self.channels[topic] = len(self.channels) + 1
            self.out.write(struct.pack("<BHH", 2, channel, schema))
            self._text(topic)
        data = io.BytesIO()
        msg.serialize(data)
        self.out.write(struct.pack("<BHQ", 3, channel, stamp.to_nsec()))
        self._text(data.getvalue())


def export_mcap(run_dir, mcap_path):
    """Writes the run in `run_dir` to a new MCAP file at `mcap_path` (ros1 profile: the bag's
    topics and messages, for Foxglove and the mcap tools); returns {topic: message count}. The
    file is written by @mcap/core (npm, bundled at build time) under Node.js."""
    logs = _checked_logs(run_dir, mcap_path, "--mcap", ".mcap")
    node = shutil.which("node") or shutil.which("nodejs")
    if node is None:
        raise ExportError("MCAP export needs Node.js (`node`; Debian's nodejs, installed with npm "
                          "by `bash .ci/install-deps`)")
    if not os.path.isfile(MCAP_WRITER):
        raise ExportError(f"{MCAP_WRITER}: missing: the MCAP writer is bundled from npm when "
                          "dronetwin is built (needs npm; `bash .ci/install-deps` installs it)")
    R = _ros()
    records = _McapRecords()
    counts = {}
    for ns, child, log in logs:
        for topic, c in _write_vehicle(R, records, log, ns, child).items():
            counts[topic] = counts.get(topic, 0) + c

    def write(tmp):
        os.unlink(tmp)  # the writer creates the file itself and refuses to replace one
        done = subprocess.run([node, MCAP_WRITER, tmp], input=records.out.getvalue(),
                              capture_output=True)
        if done.returncode != 0:
            raise ExportError(f"--mcap {mcap_path}: the MCAP writer failed: "
                              f"{done.stderr.decode(errors='replace').strip()}")
        return counts

    return _write_atomically(mcap_path, "--mcap", write)


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="dronetwin export", description="Write a run's log as a ROS 1 bag or MCAP (docs/ros.md).")
    parser.add_argument("run_dir", help="a folder written by `dronetwin run` (or a fleet run)")
    parser.add_argument("--bag", help="the ROS 1 bag to write (must not exist)")
    parser.add_argument("--mcap", help="the MCAP file to write (must not exist)")
    parser.add_argument("--quiet", "-q", action="store_true", help="print nothing on success")
    args = parser.parse_args(argv)
    if not args.bag and not args.mcap:
        print("error: nothing to write: give --bag FILE.bag, --mcap FILE.mcap or both", file=sys.stderr)
        return 2
    for path, export in ((args.bag, export_bag), (args.mcap, export_mcap)):
        if not path:
            continue
        try:
            counts = export(args.run_dir, path)
        except (ExportError, OSError) as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        if not args.quiet:
            print(f"{path}: {sum(counts.values())} messages on {len(counts)} topics")
            for topic in sorted(counts):
                print(f"  {topic}: {counts[topic]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
