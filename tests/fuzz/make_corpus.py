#!/usr/bin/python3
"""Writes the seed corpora of the fuzz harnesses, tests/fuzz/corpus/<harness>/seed_*, from the
repository's files (docs/reliability.md, "Fuzzing"):

  model_loader       models/*.yaml, tests/data/bad/*.yaml
  experiment         config/experiments/*.yaml, tests/data/bad_experiments/*.yaml (their model
                     and controller paths rewritten as seen from config/experiments/, where the
                     harness places its input)
  controller_config  config/controllers/*.yaml, tests/data/bad_controllers/*.yaml
  track              config/tracks/*.yaml
  csv_log            the first rows of the real CSVs (tests/data/real) and of run and import logs
  crazyflie_csv      the first rows of the real CSVs
  log_metadata       sidecars of short runs (open and closed loop) and of the two importers
  ulog               a slice of the real PX4 log (definitions, and the attitude, position and ESC
                     messages of one second, enough for the import), a file with every message
                     kind, and the hostile files of tests/adapters/ulog_hostile_test.cpp
  policy             small .dtpolicy files (docs/policy-format.md) written here with struct and
                     json: each activation and output, a header as json.dumps(indent=1) writes
                     it and a compact one, and broken ones (cut, trailing byte, NaN weight,
                     zero std, oversized header length, widths far beyond the bytes present)

Inputs the fuzzers found stay next to the seeds as finding_* files; this script replaces only
seed_* files. It runs the dronetwin command for the logs and sidecars:

  /usr/bin/python3 tests/fuzz/make_corpus.py --cli build/release/dronetwin
"""

import argparse
import glob
import json
import math
import os
import struct
import subprocess
import tempfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
CORPUS = os.path.join(ROOT, "tests", "fuzz", "corpus")
REAL = os.path.join(ROOT, "tests", "data", "real")
STAND = os.path.join(REAL, "crazyflie-system-id", "data", "bitcraze2021", "cf2.1-stock-prop.csv")
FLIGHT = os.path.join(REAL, "CrazyPAD", "data", "motor_data", "normal_flight",
                      "E8_log00.fixedFrequency.csv")
ULOG = os.path.join(REAL, "px4-ulog-rs", "esc_status_log.ulg")


def reset(harness):
    d = os.path.join(CORPUS, harness)
    os.makedirs(d, exist_ok=True)
    for f in glob.glob(os.path.join(d, "seed_*")):
        os.remove(f)
    return d


def put(harness, name, data):
    with open(os.path.join(CORPUS, harness, "seed_" + name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def copy_all(harness, pattern, prefix, rewrite=None):
    for path in sorted(glob.glob(os.path.join(ROOT, pattern))):
        with open(path, "rb") as f:
            data = f.read()
        if rewrite:
            data = rewrite(data)
        put(harness, prefix + os.path.basename(path), data)


def head(path, lines):
    with open(path, "rb") as f:
        return b"".join(f.readlines()[:lines])


# ---- ULog ------------------------------------------------------------------------------------

def messages(data):
    """(offset, type, payload) of every message of a ULog file."""
    pos = 16
    while pos + 3 <= len(data):
        size, kind = struct.unpack_from("<HB", data, pos)
        yield pos, chr(kind), data[pos + 3:pos + 3 + size]
        pos += 3 + size


def message(kind, payload):
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def ulog_header():
    return b"ULog\x01\x12\x35\x01" + struct.pack("<Q", 1000)


def real_ulog_slice():
    """Definitions (formats, info, the first parameters), the subscriptions, and the attitude,
    local position and ESC messages between the 10th and 13th ESC message."""
    with open(ULOG, "rb") as f:
        data = f.read()
    out = [data[:16]]
    names, esc_seen, params = {}, 0, 0
    keep = ("vehicle_attitude", "vehicle_local_position", "esc_status")
    for _, kind, payload in messages(data):
        if kind == "P":
            params += 1
            if params > 40:
                continue
        if kind == "M":
            continue
        if kind == "A":
            names[struct.unpack_from("<H", payload, 1)[0]] = payload[3:].decode()
        if kind == "D":
            name = names[struct.unpack_from("<H", payload, 0)[0]]
            if name == "esc_status":
                esc_seen += 1
            if name not in keep or not 10 <= esc_seen <= 13:
                continue
        out.append(message(kind, payload))
    return b"".join(out)


def synthetic_ulog():
    """Every message kind and field kind (as tests/adapters/ulog_synthetic_test.cpp)."""
    f = [ulog_header(), message("B", bytes(8) + b"\x00" + bytes(7) + bytes(24))]
    f.append(message("F", b"inner:float x;int16_t[2] y;uint8_t[2] _padding0;"))
    f.append(message("F", b"all:uint64_t timestamp;int8_t a;uint8_t b;int16_t c;uint16_t d;"
                          b"int32_t e;uint32_t f;int64_t g;uint64_t h;float i;double j;bool k;"
                          b"char l;char[4] name;inner[2] in;uint8_t[3] _padding1;"))
    f.append(message("I", b"\x0bchar[3] sysabc"))
    f.append(message("I", b"\x0bint32_t ver" + struct.pack("<i", -7)))
    f.append(message("M", b"\x00\x0bchar[3] docabc"))
    f.append(message("P", b"\x08float P1" + struct.pack("<f", 1.5)))
    f.append(message("Q", b"\x01\x08float P1" + struct.pack("<f", 9.0)))
    f.append(message("A", struct.pack("<BH", 0, 5) + b"all"))
    f.append(message("A", struct.pack("<BH", 1, 6) + b"all"))
    for msg_id, t in ((5, 2000000), (6, 2100000), (5, 2200000)):
        payload = struct.pack("<QbBhHiIqQfd?c4s", t, -5, 200, -30000, 60000, -2000000000,
                              4000000000, -(1 << 40), 1 << 52, 1.5, -2.25, True, b"A", b"abcd")
        for j in range(2):
            payload += struct.pack("<fhh", 0.5 * j, -j, j + 10) + b"\xee\xee"
        f.append(message("D", struct.pack("<H", msg_id) + payload))
    f.append(message("R", struct.pack("<H", 6)))
    f.append(message("L", b"6" + struct.pack("<Q", 2200000) + b"hello"))
    f.append(message("C", b"3" + struct.pack("<HQ", 7, 2300000) + b"tag"))
    f.append(message("S", bytes([0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12])))
    f.append(message("O", struct.pack("<H", 100)))
    return b"".join(f)


def hostile_ulogs():
    def fmt(text):
        return message("F", text.encode())

    def sub(name, msg_id):
        return message("A", struct.pack("<BH", 0, msg_id) + name.encode())

    return {
        "huge_array.ulg": ulog_header() + fmt("huge:uint64_t timestamp;float[2000000000] x")
        + sub("huge", 0) + message("D", struct.pack("<HQf", 0, 1, 1.0)),
        "nested_overflow.ulg": ulog_header() + fmt("d:uint8_t[32768] x") + fmt("c:d[32768] d")
        + fmt("b:c[32768] c") + fmt("a:b[32768] b") + fmt("z:a[16] a") + sub("z", 0),
        "recursive.ulg": ulog_header() + fmt("a:uint64_t timestamp;b[2] b")
        + fmt("b:float x;a back") + sub("a", 0),
        "unknown_type.ulg": ulog_header() + fmt("t:uint64_t timestamp;vec3 position") + sub("t", 0),
        "info_overflow.ulg": ulog_header()
        + message("I", b"\x1ddouble[2305843009213693952] x"),
    }


# ---- policy files ------------------------------------------------------------------------------

def policy_file(widths, activation, output, *, indent=None, env=None, seed=0, version=1,
                header_length=None, tensors_edit=None, max_values=None):
    """A .dtpolicy file of a network with these widths and deterministic small weights (only the
    first max_values numbers of the tensors, when given: a file cut short)."""
    obs = widths[0]
    tensors = [("observation_mean", [obs]), ("observation_std", [obs])]
    for k in range(len(widths) - 1):
        tensors += [(f"layers.{k}.weight", [widths[k + 1], widths[k]]),
                    (f"layers.{k}.bias", [widths[k + 1]])]
    header = {
        "format": "dronetwin.policy",
        "format_version": 1,
        "observation": [{"name": "target_relative", "size": obs}],
        "observation_size": obs,
        "action_size": widths[-1],
        "action_mode": "ctbr",
        "normalized_actions": True,
        "network": {"layers": widths, "activation": activation, "negative_slope": 0.2,
                    "output": output, "action_scale": [1.0] * widths[-1], "observation_clip": 5.0},
        "tensors": [{"name": n, "shape": s} for n, s in tensors],
        "env": env if env is not None else {"config": "config/rl/hover.yaml", "task": "hover"},
        "training": {"env_steps": 1000, "seed": seed},
    }
    text = json.dumps(header, indent=indent).encode()
    values = []
    for name, shape in tensors:
        n = 1
        for d in shape:
            n *= d
        if max_values is not None:
            n = min(n, max_values - len(values))
        for i in range(n):
            if name == "observation_std":
                values.append(0.5 + 0.25 * ((i + seed) % 3))
            else:
                values.append(((i * 7 + seed * 3) % 11 - 5) / 8.0)
    body = bytearray(struct.pack(f"<{len(values)}f", *values))
    if tensors_edit:
        tensors_edit(body)
    length = len(text) if header_length is None else header_length
    return b"DTPOLICY" + struct.pack("<II", version, length) + text + bytes(body)


def policy_seeds():
    """{name: bytes} of the policy harness's seeds."""
    def nan_at(i):
        return lambda body: body.__setitem__(slice(4 * i, 4 * i + 4), struct.pack("<f", math.nan))

    def zero_std(body):
        body[4 * 3:4 * 3 + 4] = struct.pack("<f", 0.0)

    good = policy_file([3, 4, 2], "leaky_relu", "tanh", indent=1)
    huge = policy_file([3, 65536, 65536, 2], "relu", "identity", max_values=64)
    return {
        "leaky_relu_tanh.dtpolicy": good,
        "relu_identity_compact.dtpolicy": policy_file([2, 3, 3, 1], "relu", "identity", seed=1),
        "tanh_tanh_nested_env.dtpolicy": policy_file(
            [4, 2, 4], "tanh", "tanh", seed=2,
            env={"config": "x.yaml", "list": [1, 2.5e-3, True, None, "\u00e9"], "o": {}}),
        "bad_truncated.dtpolicy": good[:-3],
        "bad_trailing_byte.dtpolicy": good + b"\0",
        "bad_nan_weight.dtpolicy": policy_file([3, 4, 2], "tanh", "tanh", tensors_edit=nan_at(9)),
        "bad_zero_std.dtpolicy": policy_file([3, 4, 2], "tanh", "tanh", tensors_edit=zero_std),
        "bad_version.dtpolicy": policy_file([2, 1], "tanh", "tanh", version=2),
        "bad_header_length.dtpolicy": policy_file([2, 1], "tanh", "tanh", header_length=1 << 21),
        "bad_widths_beyond_the_file.dtpolicy": huge,
    }


# ---- logs and sidecars from the dronetwin command ----------------------------------------------

def cli_outputs(cli):
    """{name: bytes} of run logs, import logs and their sidecars."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        def run(*args):
            subprocess.run([cli, *args], check=True, stdout=subprocess.DEVNULL, cwd=ROOT)

        for exp, duration in (("hover_open_loop", "0.01"), ("se3_circle", "0.01"),
                              ("identification_flight", "0.01")):
            d = os.path.join(tmp, exp)
            run("run", f"config/experiments/{exp}.yaml", "--out", d, "--duration", duration,
                "--quiet")
            out[f"run_{exp}.csv"] = head(os.path.join(d, "log.csv"), 6)
            with open(os.path.join(d, "log.json"), "rb") as f:
                out[f"run_{exp}.json"] = f.read()
        run("import", "ulog", ULOG, "--out", tmp)
        run("import", "crazypad", FLIGHT, "--stand", STAND, "--out", tmp)
        for stem in ("esc_status_log", "E8_log00"):
            out[f"import_{stem}.csv"] = head(os.path.join(tmp, stem + ".csv"), 6)
            with open(os.path.join(tmp, stem + ".json"), "rb") as f:
                out[f"import_{stem}.json"] = f.read()
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cli", required=True, help="the built dronetwin command")
    cli = os.path.abspath(parser.parse_args().cli)
    generated = cli_outputs(cli)

    reset("model_loader")
    copy_all("model_loader", "models/*.yaml", "model_")
    copy_all("model_loader", "tests/data/bad/*.yaml", "bad_")
    with open(os.path.join(ROOT, "models", "qdrone2.yaml"), "rb") as f:
        qdrone2 = f.read()
    put("model_loader", "collision_box.yaml", qdrone2 + b"collision: {shape: box, "
        b"half_size_m: [0.3, 0.3, 0.06], center_m: [0, 0, 0.02]}\n")

    def from_config_experiments(data):
        return (data.replace(b"../../../models/", b"../../models/")
                .replace(b"../../../config/controllers/", b"../controllers/"))

    reset("experiment")
    copy_all("experiment", "config/experiments/*.yaml", "experiment_")
    copy_all("experiment", "tests/data/bad_experiments/*.yaml", "bad_", from_config_experiments)
    put("experiment", "sensors.yaml",
        "name: sensors\nmodel: ../../models/qdrone2.yaml\nduration_s: 0.1\ninput: {type: hover}\n"
        "initial_state: {position_m: [0, 0, 1], rotor_speeds_rad_s: hover}\nsensors:\n"
        "  - {type: imu, rate_hz: 500, mounting: {position_m: [0.02, 0, 0], rpy_deg: [0, 0, 90]},\n"
        "     gyro: {noise_density: 2.0e-4, range: 35}, accel: {turn_on_bias: 0.05}}\n"
        "  - {type: magnetometer, field_uT: [20, 0, -44], hard_iron_uT: [1, 0, 0]}\n"
        "  - {type: barometer, name: baro, noise_Pa: 1.5, origin_altitude_m: 400}\n"
        "  - {type: gps, latency_s: 0.1, position_noise_m: [0.3, 0.3, 0.6]}\n"
        "  - {type: motion_capture, rate_hz: 100, attitude_noise_rad: 0.002}\n"
        "  - {type: range_finder, min_range_m: 0.05, max_range_m: 8}\n"
        "  - {type: optical_flow, max_distance_m: 5}\n"
        "  - {type: rotor_speed, name: esc, noise_rad_s: 3}\n")
    put("experiment", "scene_depth.yaml",
        "name: scene\nmodel: ../../models/qdrone2.yaml\nduration_s: 0.1\ninput: {type: hover}\n"
        "scene: ../tracks/obstacle_course.yaml\n"
        "initial_state: {position_m: [0, 0, 1.2], rotor_speeds_rad_s: hover}\nsensors:\n"
        "  - {type: range_finder}\n"
        "  - {type: depth_camera, name: cam, rate_hz: 30, width_px: 16, height_px: 12,\n"
        "     horizontal_fov_deg: 70, max_range_m: 8, noise_at_1m_m: 0.01,\n"
        "     mounting: {position_m: [0.1, 0, 0], rpy_deg: [0, 20, 0]}}\n")

    reset("controller_config")
    copy_all("controller_config", "config/controllers/*.yaml", "controller_")
    copy_all("controller_config", "tests/data/bad_controllers/*.yaml", "bad_")

    reset("track")
    copy_all("track", "config/tracks/*.yaml", "track_")
    put("track", "obstacles.yaml",
        "name: t\narena: {min: [-5, -5, -1], max: [5, 5, 5]}\nstart: {position: [0, 0, 1]}\n"
        "gates: [{position: [2, 0, 1], width_m: 1, height_m: 1}]\nobstacles:\n"
        "  - {type: box, center: [0, 3, 1], size: [2, 1, 2]}\n"
        "  - {type: cylinder, center: [-3, 0, 2], radius_m: 0.5, height_m: 4}\n"
        "  - {type: sphere, center: [3, -3, 2], radius_m: 0.25}\n")
    # A scene without gates (experiments' `scene:`), which a track may be.
    put("track", "scene_no_gates.yaml",
        "name: s\narena: {min: [-5, -5, -1], max: [5, 5, 5]}\nstart: {position: [0, 0, 1]}\n"
        "obstacles:\n  - {type: sphere, center: [2, 0, 1], radius_m: 0.4}\n")

    for harness in ("csv_log", "crazyflie_csv"):
        reset(harness)
        put(harness, "stand.csv", head(STAND, 12))
        put(harness, "crazypad.csv", head(FLIGHT, 12))
    for name, data in generated.items():
        if name.endswith(".csv"):
            put("csv_log", name, data)

    reset("log_metadata")
    for name, data in generated.items():
        if name.endswith(".json"):
            put("log_metadata", name, data)

    reset("policy")
    for name, data in policy_seeds().items():
        put("policy", name, data)

    reset("ulog")
    put("ulog", "real_slice.ulg", real_ulog_slice())
    put("ulog", "synthetic.ulg", synthetic_ulog())
    for name, data in hostile_ulogs().items():
        put("ulog", name, data)

    for d in sorted(os.listdir(CORPUS)):
        files = os.listdir(os.path.join(CORPUS, d))
        size = sum(os.path.getsize(os.path.join(CORPUS, d, f)) for f in files)
        print(f"{d}: {len(files)} files, {size} bytes")


if __name__ == "__main__":
    main()
