"""Sensors from Python: a SensorSuite fed by a Simulator (numpy arrays of every delivery), the
Allan deviation of a simulated static IMU against its configured density, the depth camera's
numpy frames, sensor columns of a run log with their units, and bad specs named."""

import math

import numpy as np
import pytest

import dronetwin as dt
from conftest import source_path


def hovering(model, z=2.0):
    sim = dt.Simulator(model, dt.SimConfig())
    state = np.zeros(13)
    state[2] = z
    state[6] = 1.0
    sim.reset(state, model.hover_speeds_rad_s())
    sim.set_rotor_speed_reference(model.hover_speeds_rad_s())
    return sim


def test_suite_runs_with_the_simulator_and_is_seeded(qdrone2):
    specs = [{"type": "imu", "rate_hz": 500}, {"type": "gps", "rate_hz": 5, "latency_s": 0.2},
             {"type": "range_finder", "dropout_probability": 0.0}]
    runs = []
    for _ in range(2):
        sim = hovering(qdrone2)
        sensors = dt.SensorSuite(specs, dt_s=1e-3, num_rotors=4, seed=3)
        runs.append(sensors.run(sim, 2000))
    a, b = runs
    assert sensors.names == ["imu", "gps", "range"]
    assert [c[0] for c in sensors.channels("gps")] == ["gps_x", "gps_y", "gps_z", "gps_vx", "gps_vy", "gps_vz"]
    t, f_w = a["imu"]
    assert f_w.shape == (1001, 6) and t[0] == 0.0 and t[-1] == pytest.approx(2.0)
    assert np.array_equal(f_w, b["imu"][1])  # bitwise, same seed
    # Hovering: the accelerometer reads about g up, the range finder the height (2 m).
    assert np.mean(f_w[:, 2]) == pytest.approx(9.81, abs=0.2)
    assert np.mean(a["range"][1][:, 0]) == pytest.approx(2.0, abs=0.01)
    # GPS fixes at 5 Hz arrive 0.2 s late: stamps 0 .. 1.8 s by t = 2 s.
    assert len(a["gps"][0]) == 10 and a["gps"][0][-1] == pytest.approx(1.8)
    stamp, values = sensors.latest("range")
    assert stamp == pytest.approx(2.0) and values.shape == (1,)


def test_sensor_faults_from_python_specs(qdrone2):
    """A faulty suite against a healthy one with the same seed: the dropout's samples are gone
    and every other one is bitwise the same; the bias step moves its channel by its value."""
    healthy = [{"type": "motion_capture"}, {"type": "barometer"}]
    faulty = [{"type": "motion_capture", "faults": [{"type": "dropout", "start_s": 0.5, "end_s": 1.0}]},
              {"type": "barometer", "faults": [{"type": "bias_step", "start_s": 1.0, "channel": "p",
                                                "value": -120.0}]}]
    runs = [dt.SensorSuite(s, 1e-3, 4, seed=5).run(hovering(qdrone2), 2000) for s in (healthy, faulty)]
    (ta, ma), (tb, mb) = runs[0]["mocap"], runs[1]["mocap"]
    kept = (ta < 0.5 - 5e-4) | (ta >= 1.0 - 5e-4)
    assert len(tb) == np.count_nonzero(kept) == len(ta) - 50  # 100 Hz for 0.5 s
    assert np.array_equal(tb, ta[kept]) and np.array_equal(mb, ma[kept])
    (pa_t, pa), (pb_t, pb) = runs[0]["baro"], runs[1]["baro"]
    assert np.array_equal(pa_t, pb_t)
    step = pb[:, 0] - pa[:, 0]
    assert np.all(step[pa_t < 1.0 - 5e-4] == 0.0)
    assert np.allclose(step[pa_t >= 1.0 - 5e-4], -120.0, rtol=0, atol=1e-9)
    with pytest.raises(ValueError, match=r"sensors\[0\]\.faults\[0\]\.channel: expected a channel of a "
                                         r"motion_capture \(x, y, z, qw, qx, qy, qz\), got 'p'"):
        dt.SensorSuite([{"type": "motion_capture", "faults": [
            {"type": "bias_step", "start_s": 0, "channel": "p", "value": 1}]}], 1e-3, 4)


def test_static_imu_allan_deviation_matches_the_noise_density(qdrone2):
    density = 2.44e-4
    gyro = {"noise_density": density, "bias_random_walk": 0.0, "bias_instability": 0.0,
            "turn_on_bias": 0.0}
    sensors = dt.SensorSuite([{"type": "imu", "rate_hz": 1000, "gyro": gyro}], 1e-3, 4, seed=9)
    sim = dt.Simulator(qdrone2, dt.SimConfig())  # resting on the ground, rotors stopped
    _, f_w = sensors.run(sim, 200_000)["imu"]
    adev = dt.allan_deviation(f_w[:, 3], 1e-3, [10, 100, 1000])
    expected = density / np.sqrt(adev["tau_s"])
    assert np.all(np.abs(adev["deviation"] / expected - 1.0) < 0.10), adev


def test_depth_camera_frames_are_numpy_float32():
    cam = dt.DepthCamera(width_px=32, height_px=24, mounting_rpy_deg=[0, 90, 0])  # looking down
    states = np.zeros((3, 13))
    states[:, 2] = [1.0, 2.0, 3.0]
    states[:, 6] = 1.0
    frames = cam.render(states)
    assert frames.shape == (3, 24, 32) and frames.dtype == np.float32
    for k, h in enumerate([1.0, 2.0, 3.0]):
        assert np.allclose(frames[k], h, atol=1e-5)
    track = dt.load_track(source_path("config", "tracks", "circuit.yaml"))
    assert cam.render(states, track).shape == (3, 24, 32)
    with pytest.raises(ValueError, match=r"expected shape \(N, 13\)"):
        cam.render(np.zeros((2, 12)))
    with pytest.raises(ValueError, match="width_px: expected 1 .. 4096 pixels, got 0"):
        dt.DepthCamera(width_px=0)


def test_run_log_has_sensor_columns_with_units(tmp_path):
    e = dt.load_experiment(source_path("config", "experiments", "hover_sensors.yaml"))
    e.duration_s = 2.0
    s = dt.run_experiment(e, str(tmp_path / "run"))
    assert s.ok
    log, meta = dt.read_log(str(tmp_path / "run"), metadata=True)
    assert meta.column("baro_p").unit == "Pa" and meta.column("imu_fz").unit == "m/s^2"
    assert meta.column("mag_bx").unit == "uT" and meta.column("flow_x").unit == "rad/s"
    # The barometer at 400 m above sea level reads the ISA pressure of 400 m + z.
    late = log["t"] > 1.5
    alt = np.array([dt.isa_altitude_m(p) for p in log["baro_p"][late]]) - 400.0
    assert np.mean(alt - log["z"][late]) == pytest.approx(0.0, abs=0.1)
    # Motion capture lags 5 ms: its stamps trail t by 5 ms once it runs.
    ok = ~np.isnan(log["mocap_t"])
    assert np.all(log["t"][ok] - log["mocap_t"][ok] >= 0.005 - 1e-12)


def test_obstacle_course_writes_depth_frames_numpy_loads(tmp_path):
    e = dt.load_experiment(source_path("config", "experiments", "obstacle_course_ekf.yaml"))
    e.duration_s = 2.0
    s = dt.run_experiment(e, str(tmp_path / "oc"))
    assert s.ok and s.collided_with == "" and s.scene_path.endswith("obstacle_course.yaml")
    (frames,) = s.depth_frames
    assert frames["name"] == "depth" and frames["shape"] == (61, 48, 64)
    depth = np.load(frames["path"])
    assert depth.dtype == np.float32 and depth.shape == (61, 48, 64)
    assert np.all(np.isfinite(depth)) and depth.max() <= 20.0 and depth.min() > 0.0
    log, meta = dt.read_log(str(tmp_path / "oc"), metadata=True)
    assert meta.column("depth_frame").unit == "1"
    assert int(np.nanmax(log["depth_frame"])) == 60


def test_bad_specs_are_named():
    with pytest.raises(ValueError, match="a depth_camera renders frames, it is not a sensor of a SensorSuite"):
        dt.SensorSuite([{"type": "depth_camera"}], 1e-3, 4)
    with pytest.raises(ValueError, match=r"sensors\[0\].gyro.noise_density: expected a finite number >= 0, got -1"):
        dt.SensorSuite([{"type": "imu", "gyro": {"noise_density": -1.0}}], 1e-3, 4)
    with pytest.raises(ValueError, match="unknown sensor type 'sonar'"):
        dt.SensorSuite([{"type": "sonar"}], 1e-3, 4)
    sensors = dt.SensorSuite([{"type": "barometer"}], 1e-3, 4)
    with pytest.raises(ValueError, match="no sensor named 'imu' \\(sensors: baro\\)"):
        sensors.latest("imu")
    with pytest.raises(ValueError, match=r"sensors: physics_dt_s: expected a number > 0, got 0"):
        dt.SensorSuite([{"type": "imu"}], 0.0, 4)
    assert dt.isa_pressure_Pa(0.0) == 101325.0
    assert math.isclose(dt.isa_altitude_m(dt.isa_pressure_Pa(123.0)), 123.0, rel_tol=1e-12)


def test_flying_the_circle_on_the_ekf_estimate(tmp_path):
    e = dt.load_experiment(source_path("config", "experiments", "se3_circle_ekf.yaml"))
    e.duration_s = 7.0
    s = dt.run_experiment(e, str(tmp_path / "ekf"))
    assert s.ok and s.estimation.controller_on_estimate
    assert s.estimation.position_rmse_m < 0.5e-3 and s.estimation.updates == 700
    log = dt.read_log(str(tmp_path / "ekf"))
    assert np.max(np.abs(log["est_x"] - log["x"])) < 5e-3


def test_update_refuses_a_different_simulator_or_a_skipped_step(qdrone2):
    sensors = dt.SensorSuite([{"type": "imu"}], 1e-3, 4)
    sim = hovering(qdrone2)
    with pytest.raises(ValueError, match="the simulator's dt_s 0.002 differs from the suite's 0.001"):
        sensors.update(dt.Simulator(qdrone2, dt.SimConfig(dt_s=0.002)))
    sensors.update(sim)
    sim.step()
    sim.step()
    with pytest.raises(ValueError, match=r"expected step 1 \(one update per physics step, in order\), got step 2"):
        sensors.update(sim)
    # After the simulator is reset, run() starts the streams again from step 0.
    sim = hovering(qdrone2)
    t, _ = sensors.run(sim, 10)["imu"]
    assert t[0] == 0.0 and len(t) == 11
