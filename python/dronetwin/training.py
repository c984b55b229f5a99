"""Training configurations and policy evaluation, without torch (docs/rl.md).

``load_config`` reads ``config/training/*.yaml`` (the defaults below filled in), ``make_env`` makes
its VectorEnv, and ``evaluate`` flies any deterministic policy (a function obs -> action: the C++
evaluator of a ``.dtpolicy`` file, or the trainer's torch network) over randomised episodes. The
trainer itself is ``dronetwin.ppo``.
"""

from __future__ import annotations

import copy as _copy
import os as _os

import numpy as _np

from . import policy as _policy
from . import rl as _rl

# ---- configuration ---------------------------------------------------------------------------

DEFAULTS = {
    "description": "",
    "env": None,                 # environment file (relative to the training file) or task name
    "env_overrides": {},         # merged over the environment file (rl.make keywords)
    "num_envs": 256,
    "num_threads": 2,            # env stepping and torch
    "dtype": "float32",          # the physics' scalar
    "seed": 0,
    "total_env_steps": 1_000_000,
    "rollout_steps": 64,         # per env and update
    "ppo": {
        "gamma": 0.99,
        "gae_lambda": 0.95,
        "clip": 0.2,
        "epochs": 5,
        "minibatches": 4,
        "learning_rate": 3e-4,     # the policy's (Table 4.1: 3e-5)
        "critic_learning_rate": None,  # None: learning_rate (Table 4.1: 1e-4)
        "anneal_learning_rate": True,
        "entropy_coef": 0.0,
        "value_coef": 0.5,
        "smooth_l1_beta": 1.0,
        "max_grad_norm": 1.0,
        "target_kl": 0.02,
        "normalize_advantages": True,
        "normalize_rewards": True,
    },
    "policy": {
        "hidden": [256, 256],      # thesis Sec. 4.4: 2 x 256
        "critic_hidden": None,     # None: as hidden
        "activation": "leaky_relu",
        "negative_slope": 0.2,     # LeakyReLU(0.2)
        "action_scale": None,      # None: 1 per action dimension; racing: [1, 1, 1.5]
        "init_log_std": -0.5,
        "observation_clip": 10.0,
    },
    "evaluation": {
        "every_updates": 0,        # 0: only at the end
        "episodes": 32,
        "seed": 1_000_000,         # evaluation episodes never share training's streams
        "overrides": {},
    },
    "checkpoint_every_updates": 50,
}

_PPO_KEYS = set(DEFAULTS["ppo"])
_POLICY_KEYS = set(DEFAULTS["policy"])
_EVAL_KEYS = set(DEFAULTS["evaluation"])


def _merge_checked(base, over, where):
    out = _copy.deepcopy(base)
    for k, v in over.items():
        if k not in base:
            raise ValueError(f"{where}: unknown key '{k}' (valid: {', '.join(sorted(base))})")
        if isinstance(base[k], dict) and not isinstance(v, dict):
            raise ValueError(f"{where}.{k}: expected a mapping, got {type(v).__name__}")
        if k in ("env_overrides", "overrides"):
            out[k] = _rl._merge(base[k], v)  # environment keys: checked by the env, merged as rl.make does
        elif isinstance(base[k], dict):
            out[k] = _merge_checked(base[k], v, f"{where}.{k}")
        else:
            out[k] = v
    return out


def _positive_int(c, key, where):
    v = c[key]
    if not isinstance(v, int) or isinstance(v, bool) or v < 1:
        raise ValueError(f"{where}: {key}: expected an integer >= 1, got {v!r}")


def load_config(path=None, overrides=None):
    """The training configuration of a YAML file (``config/training/*.yaml``) with the defaults
    filled in and ``overrides`` (a nested dict) merged on top. Paths stay relative to the file."""
    import yaml  # python3-yaml comes with matplotlib's dependencies; only the trainer needs it

    text = {}
    where = "training config"
    if path is not None:
        where = _os.fspath(path)
        with open(path, encoding="utf-8") as f:
            text = yaml.safe_load(f) or {}
        if not isinstance(text, dict):
            raise ValueError(f"{where}: expected a mapping of training settings, got {type(text).__name__}")
    c = _merge_checked(DEFAULTS, text, where)
    if overrides:
        c = _merge_checked(c, overrides, where + " (overrides)")
    for key in ("num_envs", "num_threads", "total_env_steps", "rollout_steps"):
        _positive_int(c, key, where)
    for key in ("epochs", "minibatches"):
        _positive_int(c["ppo"], key, where + ": ppo")
    if c["env"] is None:
        raise ValueError(f"{where}: env: expected an environment file or a task name, got nothing")
    if (c["num_envs"] * c["rollout_steps"]) % c["ppo"]["minibatches"]:
        raise ValueError(f"{where}: ppo.minibatches: {c['ppo']['minibatches']} does not divide the "
                         f"{c['num_envs'] * c['rollout_steps']} samples of an update (num_envs x rollout_steps)")
    if c["policy"]["activation"] not in _policy.ACTIVATIONS:
        raise ValueError(f"{where}: policy.activation: expected one of {_policy.ACTIVATIONS}, "
                         f"got {c['policy']['activation']!r}")
    env = c["env"]
    if path is not None and env not in _rl.TASKS and not _os.path.isabs(env):
        env = _os.path.normpath(_os.path.join(_os.path.dirname(_os.path.abspath(path)), env))
    c["env_path"] = _rl.config_path(env)
    return c


def make_env(c, num_envs=None, overrides=None):
    """The training (or, with ``overrides``, evaluation) VectorEnv of a configuration."""
    ov = _rl._merge(dict(c["env_overrides"]), dict(overrides or {}))
    return _rl.VectorEnv(c["env_path"], ov, num_envs or c["num_envs"], c["num_threads"], c["dtype"], copy=False)


# ---- evaluation ------------------------------------------------------------------------------

class EpisodeRecorder:
    """The flights of the first ``count`` episodes of an evaluation (env i's first episode): at
    t = 0 and after every env step, the true state, the rotor speeds and, for the hover and
    trajectory tasks, the target. The last row of an episode is the state it ended in (the
    auto-reset has already replaced the vehicle; VectorEnv.final_states keeps it)."""

    def __init__(self, env, count):
        self.env = env
        self.count = min(int(count), env.num_envs)
        self.with_target = env.task != "racing"
        self.rows = [[] for _ in range(self.count)]
        self._append(_np.ones(self.count, dtype=bool), env.states(), env.rotor_speeds(), 0.0,
                     targets=True)
        self.steps = 0

    def _append(self, which, states, omega, t, targets):
        for i in _np.flatnonzero(which):
            if self.with_target:
                # The target is not defined after the episode's end: NaN (as the run log's
                # "not applicable").
                ref = self.env._env.target(int(i)) if targets else _np.full(3, _np.nan)
            else:
                ref = _np.zeros(0)
            self.rows[i].append(_np.concatenate(([t], states[i], omega[i], ref)))

    def after_step(self, done, running):
        """Records the envs whose first episode ran in this step (``running``, before the step's
        ends were counted); ``done`` marks the envs whose episode ended in it."""
        self.steps += 1
        t = self.steps * self.env.dt
        k = self.count
        going_on = running[:k] & ~done[:k]
        ended = running[:k] & done[:k]
        self._append(going_on, self.env.states(), self.env.rotor_speeds(), t, targets=True)
        if ended.any():
            self._append(ended, self.env.final_states(), self.env.final_rotor_speeds(), t,
                         targets=False)

    def columns(self):
        n = self.env.rotor_positions_m.shape[0]
        names = ["t", "x", "y", "z", "vx", "vy", "vz", "qw", "qx", "qy", "qz", "wx", "wy", "wz"]
        names += [f"omega_{r}" for r in range(n)]
        return names + (["ref_x", "ref_y", "ref_z"] if self.with_target else [])


def check_record_folder(folder):
    """The absolute path of `folder` if episode logs can go there (a new folder in an existing
    one), else ValueError naming it."""
    folder = _os.path.abspath(_os.fspath(folder))
    if _os.path.lexists(folder):
        raise ValueError(f"--record {folder}: already exists; episode logs go to a new folder")
    parent = _os.path.dirname(folder)
    if not _os.path.isdir(parent):
        raise ValueError(f"--record {folder}: folder {parent} does not exist")
    return folder


def write_episode_logs(folder, recorder, result, description):
    """Writes the recorded episodes into the new folder ``folder``: ``episodes.json`` (the index:
    each episode's outcome, the airframe's rotor layout and the scene) and one
    ``episode_NNN/log.csv`` per episode (the state columns of the run log, docs/log-format.md).
    The folder is built under a temporary name beside it and renamed into place: it appears
    complete or not at all, and an existing path is never replaced (ValueError)."""
    import json
    import tempfile

    folder = check_record_folder(folder)
    parent = _os.path.dirname(folder)
    from .view import scene_of_track

    env = recorder.env
    columns = recorder.columns()
    index = {
        "format": "dronetwin.episodes",
        "format_version": 1,
        **description,
        "task": env.task,
        "control_dt_s": env.dt,
        "columns": columns,
        "rotors": _np.asarray(env.rotor_positions_m).tolist(),
        "scene": scene_of_track(env.track),
        "episodes": [],
    }
    tmp = tempfile.mkdtemp(prefix="." + _os.path.basename(folder) + ".", suffix=".partial", dir=parent)
    try:
        for i, rows in enumerate(recorder.rows):
            name = f"episode_{i:03d}"
            entry = {"name": name, "env": i, "cause": result["cause"][i]}
            for key in ("return", "length", "gates", "laps", "best_lap_s"):
                value = result[key][i]
                entry[key] = None if value is None or not _np.isfinite(value) else (
                    int(value) if key in ("length", "gates", "laps") else float(value))
            index["episodes"].append(entry)
            _os.mkdir(_os.path.join(tmp, name))
            with open(_os.path.join(tmp, name, "log.csv"), "w", encoding="utf-8", newline="\n") as f:
                f.write(",".join(columns) + "\n")
                for row in rows:
                    f.write(",".join(format(float(v), ".17g") for v in row) + "\n")
        with open(_os.path.join(tmp, "episodes.json"), "w", encoding="utf-8") as f:
            json.dump(index, f, indent=1)
            f.write("\n")
        umask = _os.umask(0)
        _os.umask(umask)
        _os.chmod(tmp, 0o777 & ~umask)  # mkdtemp's 0700 would hide the logs from other users
        _os.rename(tmp, folder)  # onto an empty folder made meanwhile at most: nothing is lost
    except BaseException:
        import shutil

        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return folder


def evaluate(act, config, episodes=100, seed=1_000_000, overrides=None, hold_s=2.0, hold_radius_m=0.05,
             record=0):
    """Flies ``act`` (obs -> action, deterministic) for ``episodes`` episodes, one per env, with
    the evaluation seed (env i draws from stream (seed, i)). Returns per-episode arrays and the
    task's success fraction: hover, the distance to the target stays below ``hold_radius_m`` for
    the last ``hold_s`` of an episode that reached its time limit; racing, the laps were all
    flown (the episode ended "finished"). With ``record`` > 0 the first ``record`` episodes'
    flights are kept (an EpisodeRecorder, returned as the second value: ``write_episode_logs``)."""
    c = config
    env = make_env(c, num_envs=episodes, overrides=overrides)
    obs, _ = env.reset(seed=int(seed))
    n = episodes
    recorder = EpisodeRecorder(env, record) if record else None
    first = _np.zeros(n, dtype=bool)  # env i's first episode is over
    result = {k: _np.full(n, _np.nan) for k in ("return", "length", "gates", "laps", "best_lap_s")}
    cause = _np.full(n, -1)
    target = env.observation_layout.get("target_relative")
    hold_steps = max(1, int(round(hold_s / env.dt)))
    ring = _np.full((hold_steps, n), _np.inf)  # distances after the last hold_steps steps
    result["hold_max_m"] = _np.full(n, _np.nan)
    steps = 0
    while not first.all():
        obs, reward, terminated, truncated, info = env.step(act(obs))
        done = _np.asarray(info.get("_episode", _np.zeros(n, dtype=bool)))
        if target is not None:
            seen = _np.asarray(info["final_observation"]) if done.any() else _np.asarray(obs)
            seen = _np.where(done[:, None], seen, _np.asarray(obs))
            ring[steps % hold_steps] = _np.linalg.norm(seen[:, target], axis=1)
        steps += 1
        if recorder is not None:
            recorder.after_step(done, ~first)
        newly = done & ~first
        if newly.any():
            for key in ("return", "length", "gates", "laps", "best_lap_s"):
                result[key][newly] = _np.asarray(info["episode"][key])[newly]
            cause[newly] = _np.asarray(info["episode"]["cause"])[newly]
            result["hold_max_m"][newly] = ring.max(axis=0)[newly]
            first |= newly
        if steps > 10_000_000:  # pragma: no cover - a time limit always ends an episode
            raise RuntimeError("evaluate: episodes did not end")
    names = [_rl.END_CAUSES[int(k)] for k in cause]
    out = {"episodes": n, "seed": int(seed), "cause": names,
           **{k: v.tolist() for k, v in result.items()},
           "return_mean": float(_np.mean(result["return"])),
           "crash_fraction": float(_np.mean([k not in ("time_limit", "finished") for k in names]))}
    if env.task == "hover":
        ok = _np.array([k == "time_limit" for k in names]) & (result["hold_max_m"] < hold_radius_m)
        out["success_fraction"] = float(ok.mean())
        out["hold_radius_m"] = hold_radius_m
        out["hold_s"] = hold_s
    elif env.task == "racing":
        out["success_fraction"] = float(_np.mean([k == "finished" for k in names]))
        laps = result["best_lap_s"][_np.isfinite(result["best_lap_s"])]
        out["best_lap_s_mean"] = float(laps.mean()) if laps.size else None
        # The whole race (every lap) of the finished episodes.
        race = result["length"][[k == "finished" for k in names]] * env.dt
        out["race_time_s"] = race.tolist()
        out["race_time_s_median"] = float(_np.median(race)) if race.size else None
    else:
        out["success_fraction"] = float(_np.mean([k == "time_limit" for k in names]))
    return (out, recorder) if recorder is not None else out


