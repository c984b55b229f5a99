"""dronetwin.rl from Python: make, the gymnasium-style VectorEnv API, spaces, auto-reset and its
info, determinism, views, the single Env, rendering, curricula and bad input."""

import os
import threading

import numpy as np
import pytest

import dronetwin as dt
from dronetwin import rl


def test_racing_spaces_are_the_thesis_ones():
    env = rl.make("racing", num_envs=4)
    assert env.single_observation_space.shape == (45,)  # Eq. 4.18
    assert env.single_action_space.shape == (3,)  # Eq. 4.19
    np.testing.assert_array_equal(env.single_action_space.high, [1.0, 1.0, 1.5])
    np.testing.assert_array_equal(env.single_action_space.low, [-1.0, -1.0, -1.5])
    assert env.observation_space.shape == (4, 45) and env.action_space.shape == (4, 3)
    assert env.observation_layout["gate_corners"] == slice(21, 45)
    assert env.observation_layout["rotation"] == slice(6, 15)
    obs, info = env.reset(seed=3)
    assert obs.shape == (4, 45) and obs.dtype == np.float64
    assert env.single_observation_space.contains(obs[0])
    sample = env.single_action_space.sample()
    assert env.single_action_space.contains(sample)


def test_step_returns_gymnasium_tuple_and_views():
    env = rl.make("racing", num_envs=8, dtype="float32", observation_dtype="float32")
    obs, _ = env.reset(seed=0)
    assert obs.dtype == np.float32
    assert not obs.flags.writeable
    kept = np.array(obs)
    obs2, reward, terminated, truncated, info = env.step(np.zeros((8, 3), np.float32))
    assert reward.shape == (8,) and terminated.dtype == np.bool_ and truncated.dtype == np.bool_
    # The observation acted on is intact after the next step (two buffers).
    np.testing.assert_array_equal(obs, kept)
    assert set(info["reward_terms"]) == set(rl.REWARD_TERMS)
    total = sum(info["reward_terms"][k] for k in rl.REWARD_TERMS)
    np.testing.assert_allclose(total, reward, rtol=0, atol=1e-12)


def test_auto_reset_reports_final_observation_and_episode():
    env = rl.make("racing", num_envs=3, episode_time_s=0.05)
    env.reset(seed=1)
    for _ in range(4):
        _, _, term, trunc, info = env.step(np.zeros((3, 3)))
        assert not (term | trunc).any() and "final_observation" not in info
    obs, _, term, trunc, info = env.step(np.zeros((3, 3)))
    assert trunc.all() and not term.any()
    assert info["_final_observation"].all() and info["_episode"].all()
    np.testing.assert_array_equal(info["episode"]["length"], [5, 5, 5])
    assert [rl.END_CAUSES[c] for c in info["episode"]["cause"]] == ["time_limit"] * 3
    # The new episode starts at the track's start; the final observation is where it ended.
    assert not np.array_equal(info["final_observation"][:, :3], obs[:, :3])


def test_same_seed_same_run_any_threads_and_batch_size():
    def run(n, threads):
        env = rl.make("racing", num_envs=n, num_threads=threads, noise=True, episode_time_s=0.2,
                      randomization={"mass_scale": [0.9, 1.1], "position_m": [0.3, 0.3, 0.1]},
                      copy=True)
        obs, _ = env.reset(seed=5)
        out = [obs[:3]]
        for t in range(40):
            a = 0.5 * np.sin(0.1 * t + np.arange(3 * n).reshape(n, 3))
            obs, r, *_ = env.step(a)
            out += [obs[:3], r[:3, None]]
        return np.concatenate([o.ravel() for o in out])

    a = run(3, 1)
    np.testing.assert_array_equal(a, run(3, 2))
    np.testing.assert_array_equal(a, run(64, 2))


def test_nan_action_ends_only_that_env():
    env = rl.make("racing", num_envs=3)
    env.reset(seed=0)
    a = np.zeros((3, 3))
    a[1, 2] = np.nan
    _, _, term, _, info = env.step(a)
    assert list(term) == [False, True, False]
    assert rl.END_CAUSES[info["end_cause"][1]] == "invalid_action"


def test_bad_actions_are_refused_with_the_expected_shape():
    env = rl.make("racing", num_envs=2)
    with pytest.raises(ValueError, match=r"\(2, 3\)"):
        env.step(np.zeros((2, 4)))
    with pytest.raises(ValueError, match=r"\(2, 3\)"):
        env.step(np.zeros(6))
    with pytest.raises(TypeError, match="float"):
        env.step(np.array([["a", "b", "c"]] * 2))
    with pytest.raises(ValueError, match="unknown task"):
        rl.make("racin")
    with pytest.raises(ValueError, match="observation"):
        rl.make("racing", observation=["position", "velocty"])
    with pytest.raises(ValueError, match="episode_time_s"):
        rl.make("racing", episode_time_s=-1)
    with pytest.raises(ValueError, match="num_envs"):
        rl.make("racing", num_envs=0)


def test_two_threads_stepping_one_env_are_refused():
    env = rl.make("racing", num_envs=4096)
    env.reset(seed=0)
    errors = []

    def worker():
        try:
            for _ in range(20):
                env.step(np.zeros((4096, 3)))
        except RuntimeError as e:
            errors.append(str(e))

    threads = [threading.Thread(target=worker) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    # Either they happened not to overlap, or the second was told why; never corrupted state.
    assert all("another thread" in e for e in errors)
    assert np.isfinite(env.states()).all()


def test_curriculum_configure_applies_at_next_reset():
    env = rl.make("hover", num_envs=4)
    env.reset(seed=0)
    env.configure(randomization={"mass_scale": [1.3, 1.3]}, hover={"target_m": [1, 1, 2]})
    obs, _ = env.reset(options={"env_ids": [2]})
    target = env._env.target(2)
    # hover.yaml draws the target within +-[1, 1, 0.5] of target_m, now [1, 1, 2].
    assert np.all(np.abs(target - [1, 1, 2]) <= [1, 1, 0.5])
    assert np.all(np.abs(env._env.target(0) - [0, 0, 1.5]) <= [1, 1, 0.5])  # not reset yet
    assert env._env.state().shape == (4, 13)
    with pytest.raises(ValueError, match="action"):
        env.configure(action="ctbr")


def test_arbitrary_reset_places_the_vehicle():
    env = rl.make("hover", num_envs=2)
    env.reset(seed=0)
    state = dt.Simulator.hover_state([0.5, -0.5, 2.0])
    obs, _ = env.reset(options={"env_ids": [1], "states": [state]})
    np.testing.assert_array_equal(env.states()[1, :3], [0.5, -0.5, 2.0])
    # hover observes target - p first.
    np.testing.assert_allclose(obs[1, :3], env._env.target(1) - [0.5, -0.5, 2.0], atol=1e-12)


def test_single_env_and_render(tmp_path):
    env = rl.Env("racing", racing={"track": "../tracks/straight.yaml", "laps": 1})
    obs, _ = env.reset(seed=0)
    assert obs.shape == (45,)
    total, done, steps = 0.0, False, 0
    while not done and steps < 1500:
        # Head for the next gate: the mean of its corners relative to the vehicle.
        # corner 0 - corner 1 is the width axis, corner 0 - corner 3 the up axis: their cross
        # product is the passage direction. Aim 0.5 m past the centre.
        # Fly along the gate's axis: aim 1 m ahead of the projection onto it (at most 0.5 m
        # past the gate), scaled into the action box.
        corners = obs[21:33].reshape(4, 3)
        normal = np.cross(corners[0] - corners[1], corners[0] - corners[3])
        normal /= np.linalg.norm(normal)
        centre = corners.mean(axis=0)  # relative to the vehicle
        along = -centre.dot(normal)
        a = centre + min(along + 1.0, 0.5) * normal
        a *= 0.6 * min(1.0, np.min(np.array([1, 1, 1.5]) / np.maximum(np.abs(a), 1e-9)))
        obs, r, term, trunc, info = env.step(a)
        total += r
        done = term or trunc
        steps += 1
    assert done and info["episode"]["cause"] == "finished", info
    assert info["episode"]["gates"] == 3
    path = tmp_path / "episode.png"
    image = env.render(str(path))
    assert image.ndim == 3 and image.shape[2] == 3
    assert path.exists() and path.stat().st_size > 1000
    assert not [p for p in os.listdir(tmp_path) if ".tmp" in p]
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(3))


def test_render_several_labelled_paths(tmp_path):
    t = np.linspace(0.0, 2.0 * np.pi, 50)
    a = np.stack([np.cos(t), np.sin(t), 1.0 + 0 * t], axis=1)
    b = a * [2.0, 2.0, 1.5]
    gates = rl.make("racing").gates
    image = rl.render_path([a, b], gates, str(tmp_path / "two.png"), labels=["a", "b"])
    # The second path is drawn in matplotlib's tab:red (214, 39, 40); a single path has none.
    red = np.all(np.abs(image.astype(int) - [214, 39, 40]) < 30, axis=2).sum()
    single = rl.render_path(a, gates)
    assert red > 50
    assert np.all(np.abs(single.astype(int) - [214, 39, 40]) < 30, axis=2).sum() == 0
    assert (tmp_path / "two.png").stat().st_size > 1000
    with pytest.raises(ValueError, match="2 paths but 1 labels"):
        rl.render_path([a, b], labels=["a"])


def test_sensors_and_depth_frames_in_observations():
    env = rl.make("hover", num_envs=4, sensors=[
        {"type": "imu", "rate_hz": 100},
        {"type": "range_finder", "rate_hz": 50, "dropout_probability": 0.0},
        {"type": "depth_camera", "name": "cam", "rate_hz": 25, "width_px": 16, "height_px": 12,
         "mounting": {"rpy_deg": [0, 90, 0]}},
    ])
    layout = env.observation_layout
    base = layout["sensor:imu"].start
    assert layout["sensor:imu"] == slice(base, base + 7)
    assert layout["sensor:range"] == slice(base + 7, base + 9)
    assert layout["depth:cam"] == slice(base + 9, base + 9 + 16 * 12)
    assert env.single_observation_space.shape == (base + 9 + 192,)
    obs, _ = env.reset(seed=1)
    for _ in range(20):
        obs, *_ = env.step(np.zeros((4, 3)))
    assert np.all(np.isfinite(obs))
    frames = obs[:, layout["depth:cam"]].reshape(4, 12, 16)
    # Looking down from the hover (about 1 to 2 m up): the ground fills every frame.
    assert np.all((frames > 0.3) & (frames < 4.0))
    # The IMU's specific force along body z is about g while the SE(3) loop holds the vehicles.
    assert np.all(np.abs(obs[:, base + 2] - 9.81) < 3.0)
