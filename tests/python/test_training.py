"""dronetwin.training without torch: recording an evaluation's episodes (EpisodeRecorder,
write_episode_logs, `dronetwin evaluate --record`). The recorded rows are checked against a
replay of the same episodes in an env of its own, and the logs against the viewer's reader."""

import json
import os
import subprocess

import numpy as np
import pytest

import dronetwin
from conftest import source_path
from dronetwin import policy, training, view

HOVER = source_path("config", "training", "hover_ctbr.yaml")
HOVER_POLICY = source_path("models", "policies", "hover_ctbr.dtpolicy")
SHORT = {"episode_time_s": 1.0}  # 100 env steps per episode


@pytest.fixture(scope="module")
def recorded():
    p = policy.load(HOVER_POLICY)
    c = training.load_config(HOVER)
    result, recorder = training.evaluate(p.evaluate, c, episodes=3, seed=7, overrides=SHORT, record=2)
    return p, c, result, recorder


def test_recorded_rows_are_the_flights_and_end_where_the_episodes_ended(recorded):
    p, c, result, recorder = recorded
    assert recorder.count == 2 and len(recorder.rows) == 2
    # The same streams (env i draws from (seed, i) whatever num_envs is) in an env whose episodes
    # last twice as long: after k steps it holds what the evaluation's env i held, including
    # after the last step, which the evaluation's auto-reset replaced.
    env = training.make_env(c, num_envs=2, overrides={"episode_time_s": 2.0})
    obs, _ = env.reset(seed=7)
    states, omega, targets = [env.states()], [env.rotor_speeds()], [[env._env.target(i) for i in range(2)]]
    for _ in range(int(max(result["length"][:2]))):
        obs, *_ = env.step(p.evaluate(obs))
        states.append(env.states())
        omega.append(env.rotor_speeds())
        targets.append([env._env.target(i) for i in range(2)])
    columns = recorder.columns()
    assert columns[:14] == ["t", "x", "y", "z", "vx", "vy", "vz", "qw", "qx", "qy", "qz", "wx", "wy", "wz"]
    assert columns[14:] == ["omega_0", "omega_1", "omega_2", "omega_3", "ref_x", "ref_y", "ref_z"]
    for i in range(2):
        rows = np.array(recorder.rows[i])
        length = int(result["length"][i])
        assert result["cause"][i] == "time_limit" and length == 100
        assert rows.shape == (length + 1, len(columns))
        np.testing.assert_array_equal(rows[:, 0], np.arange(length + 1) * 0.01)
        np.testing.assert_array_equal(rows[:, 1:14], np.array(states)[: length + 1, i])
        np.testing.assert_array_equal(rows[:, 14:18], np.array(omega)[: length + 1, i])
        np.testing.assert_array_equal(rows[:-1, 18:], np.array(targets)[:length, i])
        assert np.all(np.isnan(rows[-1, 18:]))  # no target once the episode is over


def test_episode_logs_are_written_whole_and_read_by_the_viewer(recorded, tmp_path):
    _, _, result, recorder = recorded
    folder = tmp_path / "episodes"
    training.write_episode_logs(folder, recorder, result, {"policy": HOVER_POLICY})
    assert sorted(os.listdir(folder)) == ["episode_000", "episode_001", "episodes.json"]
    assert os.listdir(tmp_path) == ["episodes"]  # no temporary folder left behind
    index = json.loads((folder / "episodes.json").read_text())
    assert index["format"] == "dronetwin.episodes" and index["task"] == "hover"
    assert [e["cause"] for e in index["episodes"]] == result["cause"][:2]
    assert [e["length"] for e in index["episodes"]] == [int(x) for x in result["length"][:2]]
    qdrone2 = dronetwin.load_model(source_path("models", "qdrone2.yaml"))
    np.testing.assert_array_equal(index["rotors"], [r.position_m for r in qdrone2.spec.rotors])
    for i in range(2):
        log = dronetwin.read_log(str(folder / f"episode_{i:03d}" / "log.csv"))
        assert list(log) == recorder.columns()
        np.testing.assert_array_equal(np.stack(list(log.values()), axis=1), np.array(recorder.rows[i]))
    data = view.run_data(str(folder))
    assert len(data["vehicles"]) == 2 and data["title"] == "episodes: 2 episodes"
    assert data["vehicles"][0]["name"] == "episode_000 (time_limit, 1.00 s)"
    assert data["vehicles"][0]["rotors"] == index["rotors"]
    # An existing folder is never replaced, not even an empty one.
    before = (folder / "episodes.json").read_bytes()
    with pytest.raises(ValueError, match="already exists"):
        training.write_episode_logs(folder, recorder, result, {})
    assert (folder / "episodes.json").read_bytes() == before


def test_the_viewer_names_a_broken_episode_index(recorded, tmp_path):
    _, _, result, recorder = recorded
    folder = tmp_path / "episodes"
    training.write_episode_logs(folder, recorder, result, {})
    index = json.loads((folder / "episodes.json").read_text())
    for change, message in (({"format": "dronetwin.run_log"}, "format: expected 'dronetwin.episodes'"),
                            ({"format_version": 2}, "format_version: expected 1, got 2"),
                            ({"rotors": None}, None),
                            ({"episodes": []}, "episodes: empty"),
                            ({"episodes": [{"name": "../x"}]}, r"episodes\[0\]"),
                            ({"episodes": [{"name": ".."}]}, r"episodes\[0\]")):
        broken = {**index, **change}
        if message is None:  # a field left out
            (key,) = change
            del broken[key]
            message = f"no field '{key}'"
        (folder / "episodes.json").write_text(json.dumps(broken))
        with pytest.raises(view.ViewError, match=message):
            view.run_data(str(folder))
    (folder / "episodes.json").write_text("{")
    with pytest.raises(view.ViewError, match="not JSON"):
        view.run_data(str(folder))


def test_cli_records_episodes_and_refuses_an_existing_folder(cli, tmp_path):
    out = tmp_path / "rec"
    r = subprocess.run([cli, "evaluate", HOVER_POLICY, "--config", HOVER, "--episodes", "3",
                        "--record", str(out), "--record-episodes", "2", "--quiet"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    index = json.loads((out / "episodes.json").read_text())
    assert len(index["episodes"]) == 2 and index["seed"] == 1_000_000
    assert index["policy"] == HOVER_POLICY and index["config"] == HOVER
    # 10 s episodes at 100 Hz that reach their time limit: 1001 rows each.
    for e in index["episodes"]:
        assert e["cause"] == "time_limit"
        assert len(dronetwin.read_log(str(out / e["name"] / "log.csv"))["t"]) == 1001
    before = (out / "episodes.json").read_bytes()
    r = subprocess.run([cli, "evaluate", HOVER_POLICY, "--config", HOVER, "--episodes", "3",
                        "--record", str(out)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and "already exists" in r.stderr and str(out) in r.stderr
    assert (out / "episodes.json").read_bytes() == before
    r = subprocess.run([cli, "evaluate", HOVER_POLICY, "--config", HOVER, "--record",
                        str(tmp_path / "r2"), "--record-episodes", "0"], capture_output=True, text=True)
    assert r.returncode == 2 and "--record-episodes: expected an integer >= 1, got 0" in r.stderr
    nowhere = tmp_path / "no" / "rec"
    r = subprocess.run([cli, "evaluate", HOVER_POLICY, "--config", HOVER, "--episodes", "1",
                        "--record", str(nowhere)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and f"folder {tmp_path / 'no'} does not exist" in r.stderr
