"""dronetwin_ros (src/ros) against a real roscore: the launch file flies a hover with the example
CTBR controller node through topics in lockstep, twice bit for bit; a rotor-speed controller node
reproduces `dronetwin run` of the same experiment exactly, its sensor readings on their topics
included; bad inputs end with the documented
exit codes and messages; the launch file's `bag:=` (Debian's `rosbag record`) holds the flight.
The other checks read what record_topics.py (a recorder without a queue limit) received.

Needs Debian's ROS Noetic (ros-core, libroscpp-dev and the message packages; .ci/install-deps).
Each test module starts its own roscore on a free port and stops it at the end.
"""

import csv
import math
import os
import signal
import socket
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
import rosbag
import yaml

SOURCE = Path(os.environ["DRONETWIN_SOURCE_DIR"])
PACKAGE = Path(os.environ["DRONETWIN_ROS_PACKAGE"])  # build/<preset>/ros/dronetwin
CLI = os.environ["DRONETWIN_CLI"]
NODE = PACKAGE / "dronetwin_ros"
HOLD = Path(__file__).with_name("hold_rotor_speeds.py")
TIMEOUT_S = 120
OFFSET_NS = 1_000_000_000  # ROS time = simulated time + ~time_offset_s (1 s by default)


def free_port():
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def stop(proc):
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


@pytest.fixture(scope="module")
def ros_env(tmp_path_factory):
    home = tmp_path_factory.mktemp("ros_home")
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{port}", ROS_HOME=str(home),
               ROS_LOG_DIR=str(home / "log"), ROS_PACKAGE_PATH=f"{PACKAGE.parent}:/usr/share",
               ROS_HOSTNAME="localhost")
    env.pop("ROS_NAMESPACE", None)
    core = subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while subprocess.run(["rosparam", "get", "/rosdistro"], env=env, capture_output=True,
                             timeout=30).returncode != 0:
            assert core.poll() is None, "roscore exited"
            assert time.monotonic() < deadline, "roscore did not come up within 60 s"
            time.sleep(0.2)
        yield env
    finally:
        stop(core)


RECORD = Path(__file__).with_name("record_topics.py")
HOVER_TOPICS = ["/clock:rosgraph_msgs/Clock", "/tf:tf2_msgs/TFMessage",
                "/dronetwin/odometry:nav_msgs/Odometry",
                "/dronetwin/odometry_measured:nav_msgs/Odometry", "/dronetwin/imu:sensor_msgs/Imu",
                "/dronetwin/rotor_speeds:std_msgs/Float64MultiArray",
                "/dronetwin/scene:visualization_msgs/MarkerArray",
                "/dronetwin/cmd/ctbr:geometry_msgs/TwistStamped"]


def launch_hover(env, bag, *args, subscribers=2):
    """roslaunch of the shipped launch file, recorded by our queue-less recorder into `bag`."""
    recorder = subprocess.Popen(["/usr/bin/python3", str(RECORD), str(bag), *HOVER_TOPICS],
                                env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True)
    try:
        out = subprocess.run(["roslaunch", str(SOURCE / "config/ros/hover_ctbr.launch"),
                              f"wait_for_subscribers:={subscribers}", *args], env=env,
                             capture_output=True, text=True, timeout=TIMEOUT_S,
                             start_new_session=True)
    finally:
        stop(recorder)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "experiment finished" in out.stdout + out.stderr, out.stdout + out.stderr
    return read_bag(bag)


def read_bag(path):
    # Both recorders write under another name and rename when they have closed the file, which
    # for `rosbag record` may be after its wrapper process (and the launch) exited.
    deadline = time.monotonic() + 30
    while not path.exists():
        assert time.monotonic() < deadline, f"{path} was not closed within 30 s"
        time.sleep(0.1)
    topics = {}
    with rosbag.Bag(str(path)) as b:
        for topic, msg, _ in b.read_messages():
            topics.setdefault(topic, []).append(msg)
    return topics


def first_per_stamp(msgs):
    """The bridge sends a state again while it waits; keep the first of each stamp."""
    seen = {}
    for m in msgs:
        seen.setdefault(m.header.stamp.to_nsec(), m)
    return [seen[k] for k in sorted(seen)]


def rotation(q):
    w, x, y, z = q.w, q.x, q.y, q.z
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


@pytest.fixture(scope="module")
def hover(ros_env, tmp_path_factory):
    return launch_hover(ros_env, tmp_path_factory.mktemp("hover") / "hover.bag")


def test_launch_flies_a_hover_through_topics_in_lockstep(hover):
    odometry = first_per_stamp(hover["/dronetwin/odometry"])
    stamps = [m.header.stamp.to_nsec() for m in odometry]
    # Every control period of the 5 s experiment, at exactly k x 10 ms (plus the offset).
    assert stamps == [OFFSET_NS + k * 10_000_000 for k in range(501)]
    clock = sorted({m.clock.to_nsec() for m in hover["/clock"]})
    assert clock == stamps
    # Lockstep: every state but the last (which ends the run) was answered by a command stamped
    # like it; the controller answers the last one too, but nobody waits for that.
    commands = {m.header.stamp.to_nsec() for m in hover["/dronetwin/cmd/ctbr"]}
    assert set(stamps[:-1]) <= commands <= set(stamps)
    # The example controller holds the 1 m setpoint (config/experiments/ros_hover.yaml).
    end = odometry[-1].pose.pose.position
    assert math.dist((end.x, end.y, end.z), (0.0, 0.0, 1.0)) < 0.02
    climbed = [m.pose.pose.position.z for m in odometry]
    assert climbed[0] == 0.0 and max(climbed) > 0.95
    # At rest in the air an accelerometer reads gravity's opposite: |f| = 9.81 within what the
    # residual motion allows.
    imu = first_per_stamp(hover["/dronetwin/imu"])[-1].linear_acceleration
    assert abs(math.hypot(imu.x, imu.y, imu.z) - 9.81) < 0.1
    # tf and odometry carry the same pose.
    tf = hover["/tf"][-1].transforms[0]
    assert (tf.header.frame_id, tf.child_frame_id) == ("world", "base_link")
    assert tf.transform.translation.z == end.z
    # Rotor speeds: four, within the model's limits, near hover.
    speeds = hover["/dronetwin/rotor_speeds"][-1].data
    assert len(speeds) == 4 and all(0 < w < 3000 for w in speeds)


def test_twist_is_in_the_body_frame(hover):
    odometry = first_per_stamp(hover["/dronetwin/odometry"])
    worst = 0.0
    for before, now, after in zip(odometry, odometry[1:], odometry[2:]):
        p0, p2 = before.pose.pose.position, after.pose.pose.position
        difference = (np.array([p2.x, p2.y, p2.z]) - [p0.x, p0.y, p0.z]) / 0.02
        t = now.twist.twist.linear
        v_W = rotation(now.pose.pose.orientation) @ [t.x, t.y, t.z]
        worst = max(worst, np.linalg.norm(v_W - difference) / (0.05 + np.linalg.norm(v_W)))
    # A central difference over 20 ms of a flight that accelerates at a few m/s^2.
    assert worst < 0.05


def test_scene_markers_are_the_tracks_gates_and_obstacles(hover):
    track = yaml.safe_load((SOURCE / "config/tracks/obstacle_course.yaml").read_text())
    (markers,) = hover["/dronetwin/scene"]
    by_ns = {}
    for m in markers.markers:
        by_ns.setdefault(m.ns, []).append(m)
    assert len(by_ns["gates"]) == len(track["gates"])
    assert len(by_ns["obstacles"]) == len(track["obstacles"])
    kinds = {"box": 1, "sphere": 2, "cylinder": 3}  # visualization_msgs/Marker types
    for spec, m in zip(track["obstacles"], by_ns["obstacles"]):
        assert m.text == spec["name"] and m.type == kinds[spec["type"]]
        assert [m.pose.position.x, m.pose.position.y, m.pose.position.z] == spec["center"]


def test_lockstep_runs_are_bitwise_identical(ros_env, hover, tmp_path):
    again = launch_hover(ros_env, tmp_path / "again.bag")
    for topic in ("/dronetwin/odometry", "/dronetwin/odometry_measured", "/dronetwin/imu"):
        a, b = first_per_stamp(hover[topic]), first_per_stamp(again[topic])
        assert len(a) == len(b) == 501
        for x, y in zip(a, b):
            assert x.header.stamp == y.header.stamp
            x.header.seq = y.header.seq = 0  # counts messages sent, republished ones too
            assert str(x) == str(y), topic  # every field, printed with full precision


def test_the_launch_files_bag_records_the_flight(ros_env, hover, tmp_path):
    """bag:= records with Debian's `rosbag record`, paced at real time (see docs/ros.md)."""
    bag = tmp_path / "launch.bag"
    launched = launch_hover(ros_env, tmp_path / "ours.bag", f"bag:={bag}", subscribers=3)
    recorded = read_bag(bag)
    info = subprocess.run(["rosbag", "info", str(bag)], env=ros_env, capture_output=True,
                          text=True, check=True).stdout
    for topic in HOVER_TOPICS:
        assert topic.split(":")[0] in info
    # Its odometry is the flight's (the same as without the bag: lockstep is deterministic).
    theirs = {m.header.stamp.to_nsec(): m for m in first_per_stamp(recorded["/dronetwin/odometry"])}
    ours = first_per_stamp(launched["/dronetwin/odometry"])
    assert len(ours) == 501
    assert len(theirs) == 501
    for m in ours:
        assert theirs[m.header.stamp.to_nsec()].pose == m.pose


def run_node(env, *args, timeout=TIMEOUT_S):
    return subprocess.run([str(NODE), *args], env=env, capture_output=True, text=True,
                          timeout=timeout, start_new_session=True)


def namespaced(env, ns):
    """Private parameters stay on the master after a node exits: one namespace per run."""
    return dict(env, ROS_NAMESPACE=ns)


def fly_holding_speeds(ros_env, ns, experiment, speeds, bag, topics):
    """The bridge flies `experiment` in namespace `ns` on simulated time while a node holds the
    rotor speeds `speeds` (text, one per rotor); returns what the recorder received on `topics`
    (TOPIC:TYPE) and the bridge's measured odometry."""
    env = dict(ros_env, ROS_NAMESPACE=ns)
    subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=env, check=True)
    recorder = subprocess.Popen(["/usr/bin/python3", str(RECORD), str(bag), *topics,
                                 f"/{ns}/odometry_measured:nav_msgs/Odometry"], env=env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True)
    hold = subprocess.Popen(["/usr/bin/python3", str(HOLD), f"_speeds:={speeds}"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        # The recorder and the holder subscribe to odometry_measured: the bridge waits for both.
        out = run_node(env, str(experiment), "_wait_for_subscribers:=2")
        assert out.returncode == 0, out.stderr
    finally:
        stop(hold)
        stop(recorder)
    return read_bag(bag)


def test_rotor_speed_commands_reproduce_dronetwin_run(ros_env, tmp_path):
    experiment = SOURCE / "config/experiments/hover_open_loop.yaml"
    subprocess.run([CLI, "run", str(experiment), "--out", str(tmp_path / "run")], check=True,
                   capture_output=True)
    with open(tmp_path / "run/log.csv") as f:
        rows = list(csv.DictReader(f))
    hover_speeds = " ".join(rows[0][f"omega_{i}"] for i in range(4))
    got = fly_holding_speeds(ros_env, "echo", experiment, hover_speeds, tmp_path / "echo.bag",
                             ["/echo/odometry:nav_msgs/Odometry"])
    odometry = first_per_stamp(got["/echo/odometry"])
    by_time = {round(float(r["t"]), 9): r for r in rows}
    compared = 0
    for m in odometry:
        row = by_time.get(round((m.header.stamp.to_nsec() - OFFSET_NS) * 1e-9, 9))
        if row is None:
            continue
        p, q = m.pose.pose.position, m.pose.pose.orientation
        assert (p.x, p.y, p.z) == (float(row["x"]), float(row["y"]), float(row["z"]))
        assert (q.w, q.x, q.y, q.z) == tuple(float(row[k]) for k in ("qw", "qx", "qy", "qz"))
        compared += 1
    assert compared == 501  # 5 s at 100 Hz (no controller in the experiment), t = 0 included


def test_bad_inputs_end_with_their_exit_codes(ros_env, tmp_path):
    missing = run_node(namespaced(ros_env, "missing"), str(tmp_path / "missing.yaml"), timeout=60)
    assert missing.returncode == 2 and "missing.yaml" in missing.stderr, missing.stderr
    experiment = str(SOURCE / "config/experiments/ros_hover.yaml")
    bad_rate = run_node(namespaced(ros_env, "rate"), experiment, "_control_rate_hz:=300",
                        timeout=60)
    assert bad_rate.returncode == 2 and "control rate 300 Hz" in bad_rate.stderr
    bad_timeout = run_node(namespaced(ros_env, "timeout"), experiment,
                           "_command_timeout_s:=-1", timeout=60)
    assert bad_timeout.returncode == 2 and "~command_timeout_s" in bad_timeout.stderr
    bad_offset = run_node(namespaced(ros_env, "offset"), experiment, "_time_offset_s:=-1",
                          timeout=60)
    assert bad_offset.returncode == 2 and "~time_offset_s" in bad_offset.stderr
    for param, value in (("republish_period_s", "0"), ("real_time_factor", "-1"),
                         ("wait_for_subscribers", "-1"), ("linger_s", "-1")):
        bad = run_node(namespaced(ros_env, param), experiment, f"_{param}:={value}", timeout=60)
        assert bad.returncode == 2 and f"~{param}: expected" in bad.stderr, (param, bad.stderr)
    too_many = run_node(namespaced(ros_env, "args"), experiment, experiment, timeout=60)
    assert too_many.returncode == 2 and "at most one argument" in too_many.stderr
    # Nobody answers: lockstep gives up after the timeout and says on which topics it waited.
    silent = run_node(namespaced(ros_env, "silent"), experiment, "_command_timeout_s:=0.5",
                      timeout=60)
    assert silent.returncode == 4, silent.stderr
    assert "no command on cmd/rotor_speeds, cmd/ctbr stamped 1.000000000 s" in silent.stderr
    # A command of the wrong size is refused (and then nothing valid comes).
    env = namespaced(ros_env, "wrong")
    hold = subprocess.Popen(["/usr/bin/python3", str(HOLD), "_speeds:=1 2 3"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        wrong = run_node(env, experiment, "_command_timeout_s:=2", "_wait_for_subscribers:=1",
                         timeout=60)
    finally:
        stop(hold)
    assert wrong.returncode == 4
    assert ("cmd/rotor_speeds (velocity): command refused: 3 rotor speeds, expected 4"
            in wrong.stderr), wrong.stderr


# The experiment's sensors on topics: one message type per sensor type (docs/ros.md).
SENSOR_TOPICS = {"imu": "sensor_msgs/Imu", "baro": "sensor_msgs/FluidPressure",
                 "mag": "sensor_msgs/MagneticField", "gps/position": "geometry_msgs/PointStamped",
                 "gps/velocity": "geometry_msgs/Vector3Stamped", "mocap": "geometry_msgs/PoseStamped",
                 "range": "sensor_msgs/Range", "flow": "geometry_msgs/Vector3Stamped",
                 "rpm": "sensor_msgs/JointState"}


def test_sensor_topics_carry_what_dronetwin_run_logs(ros_env, tmp_path):
    # The open-loop hover with hover_sensors.yaml's eight sensors, 1 s: `dronetwin run` logs each
    # sensor's latest delivered reading (<name>_t, <name>_<channel>); the bridge, held at the same
    # rotor speeds, must publish every delivery once, with the same stamp and values.
    spec = yaml.safe_load((SOURCE / "config/experiments/hover_open_loop.yaml").read_text())
    spec["model"] = str(SOURCE / "models/qdrone2.yaml")
    spec["duration_s"] = 1.0
    spec["sensors"] = yaml.safe_load((SOURCE / "config/experiments/hover_sensors.yaml").read_text())["sensors"]
    experiment = tmp_path / "hover_sensors_open_loop.yaml"
    experiment.write_text(yaml.safe_dump(spec))
    subprocess.run([CLI, "run", str(experiment), "--out", str(tmp_path / "run")], check=True,
                   capture_output=True)
    log = np.genfromtxt(tmp_path / "run/log.csv", delimiter=",", names=True)
    hover_speeds = " ".join(repr(float(log[f"omega_{i}"][0])) for i in range(4))
    topics = [f"/sens/sensors/{name}:{kind}" for name, kind in SENSOR_TOPICS.items()]
    got = fly_holding_speeds(ros_env, "sens", experiment, hover_speeds, tmp_path / "sensors.bag",
                             [*topics, "/tf_static:tf2_msgs/TFMessage"])

    def deliveries(name):
        """{stamp ns: the row's values} at each delivery of sensor `name` in the log."""
        columns = [c for c in log.dtype.names if c.startswith(name + "_") and c != name + "_t"]
        out = {}
        for row in log:
            stamp = row[name + "_t"]
            if not math.isnan(stamp):
                out.setdefault(round(stamp * 1e9) + OFFSET_NS, [float(row[c]) for c in columns])
        return out

    def same(a, b):
        return all((math.isnan(x) and math.isnan(y)) or x == y for x, y in zip(a, b, strict=True))

    values = {
        "imu": lambda m: [m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z,
                          m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z],
        "baro": lambda m: [m.fluid_pressure],
        "mag": lambda m: [m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z],
        "gps/position": lambda m: [m.point.x, m.point.y, m.point.z],
        "gps/velocity": lambda m: [m.vector.x, m.vector.y, m.vector.z],
        "mocap": lambda m: [m.pose.position.x, m.pose.position.y, m.pose.position.z,
                            m.pose.orientation.w, m.pose.orientation.x, m.pose.orientation.y,
                            m.pose.orientation.z],
        "range": lambda m: [m.range],
        "flow": lambda m: [m.vector.x, m.vector.y],
        "rpm": lambda m: list(m.velocity),
    }
    expected_of = {  # the log's values as the messages carry them
        "mag": lambda v: [x * 1e-6 for x in v],  # uT -> T
        "gps/position": lambda v: v[:3],
        "gps/velocity": lambda v: v[3:],
        "range": lambda v: [float(np.float32(v[0]))],
    }
    for topic in SENSOR_TOPICS:
        name = topic.split("/")[0]
        msgs = got[f"/sens/sensors/{topic}"]
        want = deliveries(name)
        stamps = [m.header.stamp.to_nsec() for m in msgs]
        assert len(want) >= 10 and stamps == sorted(want), topic  # every delivery once, in order
        for m in msgs:
            expected = expected_of.get(topic, lambda v: v)(want[m.header.stamp.to_nsec()])
            assert same(values[topic](m), expected), (topic, m.header.stamp.to_nsec())
        frame = "world" if name in ("gps", "mocap") else f"base_link/{name}"
        assert {m.header.frame_id for m in msgs} == {frame}, topic
    assert len(got["/sens/sensors/imu"]) == 1001  # 1 kHz from t = 0 to 1 s
    assert got["/sens/sensors/imu"][0].orientation_covariance[0] == -1.0  # no orientation
    (mounts,) = got["/tf_static"]
    imu = next(t for t in mounts.transforms if t.child_frame_id == "base_link/imu")
    assert imu.header.frame_id == "base_link"
    t = imu.transform.translation
    assert (t.x, t.y, t.z) == (0.02, 0.0, 0.01)
    assert len(mounts.transforms) == 8
