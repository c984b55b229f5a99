"""Reinforcement-learning environments on the batched engine (thesis chapter 4; docs/rl.md).

    from dronetwin import rl
    env = rl.make("racing", num_envs=1024, num_threads=2, dtype="float32")
    obs, info = env.reset(seed=0)                     # (1024, 45): Eq. 4.18
    for _ in range(1000):
        actions = policy(obs)                         # (1024, 3): Eq. 4.19, metres
        obs, reward, terminated, truncated, info = env.step(actions)

``make`` reads ``config/rl/<task>.yaml`` (or any environment file given as ``config=``) and
applies keyword overrides on top (``episode_time_s=10``, ``reward={"gate": 1.0}``,
``randomization={"mass_scale": [0.9, 1.1]}``). The vector env follows gymnasium's VectorEnv
conventions (0.29, same-step auto-reset): an env whose episode ends is reset in the same step, its
last observation is in ``info["final_observation"]`` (rows marked by ``info["_final_observation"]``)
and its statistics in ``info["episode"]`` (marked by ``info["_episode"]``).

Arrays returned by ``step`` and ``reset`` are read-only views onto the engine's buffers (no copy).
Observations alternate between two buffers, so the observation a policy acted on stays intact when
the next one arrives, but not one step longer; rewards, flags and info arrays are overwritten by
the next step. Copy what you keep (``np.array(obs)``), or ``make(..., copy=True)``.

gymnasium is not a Debian package: the spaces are this module's ``Box`` unless gymnasium is
importable, in which case they are ``gymnasium.spaces.Box``.
"""

from __future__ import annotations

import json as _json
import os as _os

import numpy as _np

from . import _core

END_CAUSES = tuple(_core.END_CAUSES)
REWARD_TERMS = tuple(_core.REWARD_TERMS)
TASKS = ("hover", "trajectory", "racing")

try:  # pragma: no cover - depends on the machine
    import gymnasium as _gym

    _GymBox = _gym.spaces.Box
except ImportError:  # Debian has no gymnasium
    _GymBox = None


class Box:
    """A box in R^n: ``shape``, ``low``, ``high`` (arrays of ``shape``), ``dtype``. The same
    attributes and ``sample`` / ``contains`` / ``seed`` as gymnasium's Box, without it."""

    def __init__(self, low, high, shape=None, dtype=_np.float32, seed=None):
        self.dtype = _np.dtype(dtype)
        low = _np.asarray(low, dtype=_np.float64)
        high = _np.asarray(high, dtype=_np.float64)
        if shape is not None:
            low = _np.broadcast_to(low, shape)
            high = _np.broadcast_to(high, shape)
        if low.shape != high.shape:
            raise ValueError(f"Box: low has shape {low.shape}, high {high.shape}")
        if _np.any(low > high):
            raise ValueError("Box: low must be <= high everywhere")
        self.low = low.astype(self.dtype)
        self.high = high.astype(self.dtype)
        self.shape = tuple(low.shape)
        self._rng = _np.random.default_rng(seed)

    def seed(self, seed=None):
        self._rng = _np.random.default_rng(seed)
        return [seed]

    def sample(self):
        """Uniform in the bounded dimensions, standard normal in the unbounded ones."""
        low = self.low.astype(_np.float64)
        high = self.high.astype(_np.float64)
        bounded = _np.isfinite(low) & _np.isfinite(high)
        out = self._rng.standard_normal(self.shape)
        u = self._rng.uniform(size=self.shape)
        out = _np.where(bounded, low + u * (high - low), out)
        out = _np.where(_np.isfinite(low) & ~_np.isfinite(high), low + _np.abs(out), out)
        out = _np.where(~_np.isfinite(low) & _np.isfinite(high), high - _np.abs(out), out)
        return out.astype(self.dtype)

    def contains(self, x):
        x = _np.asarray(x)
        return x.shape == self.shape and bool(_np.all(x >= self.low) and _np.all(x <= self.high))

    __contains__ = contains

    def __repr__(self):
        return f"Box({self.low.min()}, {self.high.max()}, {self.shape}, {self.dtype})"


def _box(low, high, dtype):
    if _GymBox is not None:  # pragma: no cover - depends on the machine
        return _GymBox(low=_np.asarray(low, dtype=dtype), high=_np.asarray(high, dtype=dtype), dtype=dtype)
    return Box(low, high, dtype=dtype)


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, _np.ndarray):
        return value.tolist()
    if isinstance(value, _np.generic):
        return value.item()
    return value


def config_path(task):
    """The environment file of a task name ("racing" -> <data>/config/rl/racing.yaml) or a path."""
    if _os.path.exists(str(task)) or str(task).endswith((".yaml", ".yml")):
        if not _os.path.exists(str(task)):
            raise ValueError(f"make: environment file '{task}' not found")
        return str(task)
    from . import default_data_dir

    root = default_data_dir()
    if root is None:
        raise ValueError("make: cannot find the dronetwin data directory (models/, config/); set "
                         "DRONETWIN_DATA_DIR or pass config='path/to/env.yaml'")
    path = _os.path.join(root, "config", "rl", f"{task}.yaml")
    if not _os.path.exists(path):
        raise ValueError(f"make: unknown task '{task}' (valid: {', '.join(TASKS)}, or an environment "
                         f"file path); looked for {path}")
    return path


class VectorEnv:
    """``num_envs`` environments stepped together in C++ (see the module docstring)."""

    metadata = {"render_modes": ["rgb_array"], "autoreset_mode": "same-step"}

    def __init__(self, path, overrides=None, num_envs=1, num_threads=1, dtype="float64", copy=False):
        if not isinstance(num_envs, (int, _np.integer)) or isinstance(num_envs, bool) or num_envs < 1:
            raise ValueError(f"make: num_envs: expected an integer >= 1, got {num_envs!r}")
        if not isinstance(num_threads, (int, _np.integer)) or isinstance(num_threads, bool) or num_threads < 1:
            raise ValueError(f"make: num_threads: expected an integer >= 1, got {num_threads!r}")
        dtype = _np.dtype(dtype)
        if dtype not in (_np.dtype(_np.float64), _np.dtype(_np.float32)):
            raise ValueError(f"make: dtype: expected float64 or float32 (the physics' scalar), got {dtype}")
        self._path = path
        self._overrides = dict(overrides or {})
        engine = _core.VecEnv32 if dtype == _np.float32 else _core.VecEnv64
        self._env = engine(path, self._overrides_text(), int(num_envs), int(num_threads))
        self.num_envs = int(num_envs)
        self.copy = bool(copy)
        e = self._env
        obs_dtype = _np.float32 if e.observation_float32 else _np.float64
        act_low = _np.asarray(e.action_low)
        act_high = _np.asarray(e.action_high)
        if e.normalized_actions:
            act_low, act_high = -_np.ones_like(act_low), _np.ones_like(act_high)
        self.action_low_physical = _np.asarray(e.action_low)
        self.action_high_physical = _np.asarray(e.action_high)
        self.single_action_space = _box(act_low, act_high, _np.float32)
        self.single_observation_space = _box(e.observation_low, e.observation_high, obs_dtype)
        self.action_space = _box(_np.tile(act_low, (self.num_envs, 1)), _np.tile(act_high, (self.num_envs, 1)),
                                 _np.float32)
        self.observation_space = _box(_np.tile(e.observation_low, (self.num_envs, 1)),
                                      _np.tile(e.observation_high, (self.num_envs, 1)), obs_dtype)
        self.observation_layout = {name: slice(off, off + size) for name, off, size in e.observation_layout}
        self.task = e.task
        self.action_mode = e.action_mode
        self.dt = e.control_dt_s
        self.substeps = e.substeps
        # Views that stay the same object for the env's life (the buffers do not move).
        self._reward = e.reward()
        self._terms = e.reward_terms()
        self._terminated = e.terminated()
        self._truncated = e.truncated()
        self._done = e.done()
        self._cause = e.end_cause()
        self._finished = e.finished()
        self._running = e.running()
        self.closed = False

    def _overrides_text(self):
        return _json.dumps(_jsonable(self._overrides)) if self._overrides else ""

    # ---- gymnasium API --------------------------------------------------------------------
    def reset(self, seed=None, options=None):
        """Every env starts a new episode. ``seed``: an int (env i draws from stream (seed, i)) or
        None (the next episodes of each env's stream). ``options={"env_ids": ids, "states":
        (k, 13) array}`` resets only those envs, at those states if given (curricula)."""
        self._check_open()
        if options:
            unknown = set(options) - {"env_ids", "states"}
            if unknown:
                raise ValueError(f"reset: options: unknown keys {sorted(unknown)} (valid: env_ids, states)")
            ids = _np.atleast_1d(_np.asarray(options.get("env_ids", _np.arange(self.num_envs))))
            if ids.dtype == bool:
                ids = _np.flatnonzero(ids)
            states = options.get("states")
            if states is not None:
                states = _np.asarray(states, dtype=_np.float64)
                if states.shape != (len(ids), 13):
                    raise ValueError(f"reset: options['states']: expected shape ({len(ids)}, 13), got {states.shape}")
            for k, i in enumerate(ids):
                self._env.reset_env(int(i), None if states is None else states[k])
        elif seed is None:
            for i in range(self.num_envs):
                self._env.reset_env(i, None)
        else:
            if not isinstance(seed, (int, _np.integer)) or isinstance(seed, bool) or seed < 0:
                raise ValueError(f"reset: seed: expected an integer >= 0 or None, got {seed!r}")
            self._env.reset(int(seed))
        return self._out(self._env.observation()), {}

    def step(self, actions):
        """Actions (num_envs, action_size) -> (obs, reward, terminated, truncated, info)."""
        self._check_open()
        self._env.step(actions)
        obs = self._env.observation()
        info = {"reward_terms": self._terms, "end_cause": self._cause}
        done = self._done
        if done.any():
            info["final_observation"] = self._env.final_observation()
            info["_final_observation"] = done
            info["episode"] = {**self._finished, "cause": self._cause}
            info["_episode"] = done
            if self.copy:
                info = _copy_tree(info)
        if self.copy:
            return (_np.array(obs), _np.array(self._reward), _np.array(self._terminated),
                    _np.array(self._truncated), _copy_tree(info))
        return obs, self._reward, self._terminated, self._truncated, info

    def close(self):
        self.closed = True

    def _check_open(self):
        if self.closed:
            raise RuntimeError("VectorEnv: the env is closed")

    def _out(self, obs):
        return _np.array(obs) if self.copy else obs

    # ---- beyond gymnasium -----------------------------------------------------------------
    def configure(self, **overrides):
        """Curriculum hook: changes what the next resets draw (randomization, start, track, laps)
        and what the reward weighs, between steps. Keys as in the environment file; the spaces
        and the engine (task, action, observation, physics) cannot change."""
        merged = _merge(self._overrides, _jsonable(overrides))
        self._env.set_overrides(self._path, _json.dumps(_jsonable(merged)))
        self._overrides = merged

    @property
    def running(self):
        """Per env, the current episode: return, length, gates, laps, next_gate, episode."""
        return self._running

    def states(self):
        """(num_envs, 13) true states (a copy)."""
        return self._env.state()

    def rotor_speeds(self):
        """(num_envs, num_rotors) achieved rotor speeds, rad/s (a copy)."""
        return self._env.rotor_speeds()

    def final_states(self):
        """(num_envs, 13) state each episode that ended in the last step reached before the
        auto-reset replaced it (valid where ``info["_episode"]``; a copy)."""
        return self._env.final_state()

    def final_rotor_speeds(self):
        """(num_envs, num_rotors) rotor speeds each ended episode reached, rad/s (a copy)."""
        return self._env.final_rotor_speeds()

    @property
    def track(self):
        """The env's Track (racing: its gates; every task: its obstacles)."""
        return self._env.track

    @property
    def rotor_positions_m(self):
        """(num_rotors, 3) hub positions of the airframe, body frame, m."""
        return self._env.rotor_positions_m

    @property
    def gates(self):
        """(num_gates, 4, 3) gate-opening corners of the racing track."""
        return self._env.gates

    def end_cause_names(self, causes):
        return [END_CAUSES[int(c)] for c in _np.atleast_1d(causes)]

    def __repr__(self):
        return (f"VectorEnv(task={self.task!r}, action={self.action_mode!r}, num_envs={self.num_envs}, "
                f"obs={self.single_observation_space.shape}, act={self.single_action_space.shape})")


def _merge(base, over):
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _copy_tree(x):
    if isinstance(x, dict):
        return {k: _copy_tree(v) for k, v in x.items()}
    if isinstance(x, _np.ndarray):
        return _np.array(x)
    return x


def make(task="racing", num_envs=1, num_threads=1, dtype="float64", config=None, copy=False, **overrides):
    """A VectorEnv of ``task`` ("hover", "trajectory", "racing") or of the environment file
    ``config``, with ``overrides`` merged over the file (nested dicts merge key by key).

    ``dtype`` is the physics' scalar (float32 is about twice as fast); observations are float64
    unless ``observation_dtype="float32"``. ``num_threads`` threads step the envs; results do not
    depend on it."""
    path = config_path(config if config is not None else task)
    if config is not None and task not in TASKS and task != "racing":
        raise ValueError(f"make: give a task name or config=, not both ({task!r}, {config!r})")
    return VectorEnv(path, overrides, num_envs, num_threads, dtype, copy)


class Env:
    """One environment with the gymnasium Env API, for prototyping: ``reset(seed) -> (obs,
    info)``, ``step(action) -> (obs, reward, terminated, truncated, info)`` with 1-D arrays, and
    ``render()``: a 3-D plot of the episode so far (gates, path) as an RGB array or a PNG."""

    metadata = {"render_modes": ["rgb_array"]}

    def __init__(self, task="racing", dtype="float64", config=None, **overrides):
        self._vec = make(task, num_envs=1, num_threads=1, dtype=dtype, config=config, copy=True, **overrides)
        self.observation_space = self._vec.single_observation_space
        self.action_space = self._vec.single_action_space
        self.observation_layout = self._vec.observation_layout
        self._path = []
        self._needs_reset = True

    def reset(self, seed=None, options=None):
        if seed is not None:
            obs, info = self._vec.reset(seed=seed)
        else:
            obs, info = self._vec.reset(options={"env_ids": [0], **(options or {})})
        self._path = [self._vec.states()[0, :3].copy()]
        self._needs_reset = False
        return obs[0], info

    def step(self, action):
        if self._needs_reset:
            raise RuntimeError("Env.step: call reset() first (the episode has ended or never began)")
        action = _np.asarray(action, dtype=_np.float64).reshape(1, -1)
        obs, reward, terminated, truncated, info = self._vec.step(action)
        done = bool(terminated[0] or truncated[0])
        out = {"reward_terms": {k: float(v[0]) for k, v in info["reward_terms"].items()},
               "end_cause": END_CAUSES[int(info["end_cause"][0])]}
        if done:
            self._needs_reset = True
            obs = info["final_observation"]
            out["episode"] = {k: (v[0].item() if isinstance(v, _np.ndarray) else v) for k, v in info["episode"].items()}
            out["episode"]["cause"] = END_CAUSES[int(info["end_cause"][0])]
            where = self.observation_layout.get("position")
            self._path.append(_np.asarray(obs[0][where], dtype=float) if where is not None else self._path[-1])
        else:
            self._path.append(self._vec.states()[0, :3].copy())
        return obs[0], float(reward[0]), bool(terminated[0]), bool(truncated[0]), out

    def render(self, path=None):
        """The episode's path and the track's gates in 3-D (matplotlib, Agg). Writes a PNG when
        ``path`` is given; returns the image as an (H, W, 3) uint8 array."""
        return render_path(_np.array(self._path), self._vec.gates if self._vec.task == "racing" else None, path)

    def close(self):
        self._vec.close()


def render_path(positions, gates=None, path=None, title=None, labels=None):
    """3-D plot of a path (k, 3) and gate openings (g, 4, 3); PNG at ``path``; RGB array back.
    With ``labels``, ``positions`` is a list of paths drawn in turn with a legend."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    if labels is None:
        paths = [_np.asarray(positions, dtype=float).reshape(-1, 3)]
    else:
        paths = [_np.asarray(p, dtype=float).reshape(-1, 3) for p in positions]
        if len(paths) != len(labels):
            raise ValueError(f"render_path: {len(paths)} paths but {len(labels)} labels")
    fig = plt.figure(figsize=(7, 5), dpi=100)
    ax = fig.add_subplot(projection="3d")
    if gates is not None:
        for g, corners in enumerate(_np.asarray(gates)):
            ring = _np.vstack([corners, corners[:1]])
            ax.plot(ring[:, 0], ring[:, 1], ring[:, 2], color="tab:orange")
            c = corners.mean(axis=0)
            ax.text(c[0], c[1], c[2] + 0.1, str(g), fontsize=7)
    colours = ["tab:blue", "tab:red", "tab:green", "tab:purple"]
    for i, positions in enumerate(paths):
        if len(positions):
            ax.plot(positions[:, 0], positions[:, 1], positions[:, 2], color=colours[i % len(colours)], lw=1.2,
                    label=None if labels is None else labels[i])
            ax.scatter(*positions[0], color="green", s=12)
    if labels is not None:
        ax.legend(loc="upper left", fontsize=8)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    if title:
        ax.set_title(title)
    fig.canvas.draw()
    image = _np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    if path is not None:
        # Atomically: a crash mid-write leaves no half PNG (a temporary file, then a rename).
        path = str(path)
        tmp = f"{path}.tmp{_os.getpid()}.png"
        try:
            fig.savefig(tmp, format="png")
            _os.replace(tmp, path)
        finally:
            if _os.path.exists(tmp):
                _os.remove(tmp)
    plt.close(fig)
    return image
