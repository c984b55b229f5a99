"""Proximal policy optimisation on dronetwin's vector environments (thesis Sec. 4.3.2; docs/rl.md).

A compact PPO (Schulman et al. 2017) with what the thesis uses: GAE, the clipped objective, a
critic trained with the smooth-L1 loss (beta = 1), gradient-norm clipping, minibatches, a KL early
stop, observation normalisation and a tanh-squashed Gaussian policy scaled per action dimension.

    from dronetwin import ppo
    result = ppo.train("config/training/hover_ctbr.yaml", "runs/hover")   # or dronetwin train

Everything a run makes goes to its output folder: metrics.csv (one row per update), training.png,
checkpoint.pt (the latest, for --resume), policy.dtpolicy and policy.onnx (the deterministic
policy), summary.json, and a copy of the configuration. torch is imported here, not by the
package: ``import dronetwin`` works without it.
"""

from __future__ import annotations

import copy as _copy
import csv as _csv
import io as _io
import json as _json
import math as _math
import os as _os
import sys as _sys
import time as _time

import numpy as _np
import torch as _torch
from torch import nn as _nn

from . import policy as _policy
from . import rl as _rl
from .training import evaluate, load_config, make_env

# ---- networks --------------------------------------------------------------------------------

def _activation(name, slope):
    return {"leaky_relu": lambda: _nn.LeakyReLU(slope), "relu": _nn.ReLU, "tanh": _nn.Tanh}[name]()


def mlp(sizes, activation, slope):
    """Linear layers of ``sizes`` with ``activation`` between them (none after the last)."""
    layers = []
    for k in range(len(sizes) - 1):
        layers.append(_nn.Linear(sizes[k], sizes[k + 1]))
        if k < len(sizes) - 2:
            layers.append(_activation(activation, slope))
    return _nn.Sequential(*layers)


class Normalizer(_nn.Module):
    """Running mean and variance of the observations (parallel Welford update), applied as
    clip((o - mean) / sqrt(var + eps)). Frozen at export."""

    def __init__(self, size, clip, eps=1e-8):
        super().__init__()
        self.register_buffer("mean", _torch.zeros(size, dtype=_torch.float64))
        self.register_buffer("var", _torch.ones(size, dtype=_torch.float64))
        self.register_buffer("count", _torch.tensor(1e-4, dtype=_torch.float64))
        self.clip = float(clip)
        self.eps = eps

    def update(self, x):
        x = x.reshape(-1, x.shape[-1]).to(_torch.float64)
        n = x.shape[0]
        mean = x.mean(0)
        var = x.var(0, unbiased=False)
        delta = mean - self.mean
        total = self.count + n
        self.mean += delta * n / total
        self.var = (self.var * self.count + var * n + delta ** 2 * self.count * n / total) / total
        self.count = total

    def std(self):
        return _torch.sqrt(self.var + self.eps)

    def forward(self, x):
        return _torch.clamp((x - self.mean.float()) / self.std().float(), -self.clip, self.clip)


class ActorCritic(_nn.Module):
    """Actor: a = scale * tanh(u), u ~ N(mu(o), sigma), sigma state-independent. Critic: V(o)."""

    def __init__(self, obs_size, act_size, p):
        super().__init__()
        hidden = list(p["hidden"])
        critic_hidden = list(p["critic_hidden"] if p["critic_hidden"] is not None else hidden)
        self.activation = p["activation"]
        self.slope = float(p["negative_slope"])
        self.normalizer = Normalizer(obs_size, p["observation_clip"])
        self.actor = mlp([obs_size, *hidden, act_size], self.activation, self.slope)
        self.critic = mlp([obs_size, *critic_hidden, 1], self.activation, self.slope)
        self.log_std = _nn.Parameter(_torch.full((act_size,), float(p["init_log_std"])))
        scale = p["action_scale"] if p["action_scale"] is not None else [1.0] * act_size
        if len(scale) != act_size:
            raise ValueError(f"policy.action_scale: expected {act_size} values (the action size), got {len(scale)}")
        self.register_buffer("action_scale", _torch.tensor(scale, dtype=_torch.float32))
        # Small last actor layer: the first actions stay near the middle of the box.
        with _torch.no_grad():
            self.actor[-1].weight.mul_(0.01)
            self.actor[-1].bias.zero_()

    def distribution(self, obs_n):
        mu = self.actor(obs_n)
        return _torch.distributions.Normal(mu, self.log_std.exp().expand_as(mu))

    def value(self, obs_n):
        return self.critic(obs_n).squeeze(-1)

    def squash(self, u):
        return self.action_scale * _torch.tanh(u)

    def deterministic(self, obs):
        """The exported policy: scale * tanh(mu(normalised obs))."""
        return self.squash(self.actor(self.normalizer(obs)))


# ---- training --------------------------------------------------------------------------------

class RewardScaler:
    """Divides rewards by the running standard deviation of the discounted return (per env)."""

    def __init__(self, num_envs, gamma):
        self.ret = _np.zeros(num_envs)
        self.gamma = gamma
        self.mean, self.var, self.count = 0.0, 1.0, 1e-4

    def __call__(self, reward, done):
        self.ret = self.ret * self.gamma + reward
        m, v, n = self.ret.mean(), self.ret.var(), self.ret.size
        delta, total = m - self.mean, self.count + n
        self.mean += delta * n / total
        self.var = (self.var * self.count + v * n + delta ** 2 * self.count * n / total) / total
        self.count = total
        self.ret[done] = 0.0
        return reward / _math.sqrt(self.var + 1e-8)

    def state(self):
        return {"ret": self.ret.copy(), "mean": self.mean, "var": self.var, "count": self.count}

    def load(self, s):
        self.ret, self.mean, self.var, self.count = s["ret"].copy(), s["mean"], s["var"], s["count"]


METRIC_COLUMNS = ["update", "env_steps", "wall_clock_s", "samples_per_s", "episodes", "episode_return",
                  "episode_length", "gates", "lap_time_s", "crash_fraction", "ppo_loss", "critic_loss",
                  "entropy", "approx_kl", "clip_fraction", "epochs_run", "explained_variance", "action_std",
                  "learning_rate", "eval_return", "eval_success"]


def _atomic_torch_save(obj, path):
    buf = _io.BytesIO()
    _torch.save(obj, buf)
    _policy.atomic_write_bytes(path, buf.getvalue())


class Trainer:
    """One PPO run. ``Trainer(config, out_dir).run()``; see ``train`` for the file-level entry."""

    def __init__(self, config, out_dir, resume=False, progress=True):
        self.c = config
        self.out = _os.fspath(out_dir)
        self.progress = progress
        c = config
        _torch.manual_seed(c["seed"])
        _torch.set_num_threads(c["num_threads"])
        self.rng = _np.random.default_rng(c["seed"])
        self.env = make_env(c)
        e = self.env
        self.obs_size = e.single_observation_space.shape[0]
        self.act_size = e.single_action_space.shape[0]
        if not (_np.all(e.single_action_space.low == -1.0) and _np.all(e.single_action_space.high == 1.0)):
            scale = c["policy"]["action_scale"]
            if scale is None:
                raise ValueError("training config: policy.action_scale: the env's actions are not normalised "
                                 "to [-1, 1]; give the scale per action dimension (racing: [1, 1, 1.5]) or set "
                                 "env_overrides.normalized_actions: true")
            hi = _np.asarray(e.single_action_space.high, dtype=float)
            if _np.any(_np.asarray(scale) > hi + 1e-9):
                raise ValueError(f"training config: policy.action_scale {list(scale)} exceeds the env's action "
                                 f"bounds {hi.tolist()}")
        self.model = ActorCritic(self.obs_size, self.act_size, c["policy"])
        p = c["ppo"]
        # One Adam, two parameter groups: the thesis's separate policy and critic learning rates
        # (Adam's state is per parameter, so this is two optimisers; the gradient norm is clipped
        # over all of them together, Sec. 4.4).
        m = self.model
        self.base_lr = [p["learning_rate"], p["critic_learning_rate"] or p["learning_rate"]]
        self.opt = _torch.optim.Adam([
            {"params": list(m.actor.parameters()) + [m.log_std], "lr": self.base_lr[0]},
            {"params": list(m.critic.parameters()), "lr": self.base_lr[1]}], eps=1e-5)
        self.rewards = RewardScaler(c["num_envs"], p["gamma"])
        self.update = 0
        self.env_steps = 0
        self.wall_s = 0.0
        self.updates_total = max(1, c["total_env_steps"] // (c["num_envs"] * c["rollout_steps"]))
        self.obs = None
        if resume:
            self._load_checkpoint()

    # -- files --
    def path(self, name):
        return _os.path.join(self.out, name)

    def _checkpoint(self):
        _atomic_torch_save({
            "model": self.model.state_dict(), "optimizer": self.opt.state_dict(), "update": self.update,
            "env_steps": self.env_steps, "wall_s": self.wall_s, "rewards": self.rewards.state(),
            "torch_rng": _torch.get_rng_state(), "numpy_rng": self.rng.bit_generator.state,
            "config": self.c}, self.path("checkpoint.pt"))

    def _load_checkpoint(self):
        path = self.path("checkpoint.pt")
        if not _os.path.exists(path):
            raise ValueError(f"train --resume: no checkpoint at {path}")
        ck = _torch.load(path)
        self.model.load_state_dict(ck["model"])
        self.opt.load_state_dict(ck["optimizer"])
        self.update, self.env_steps, self.wall_s = ck["update"], ck["env_steps"], ck["wall_s"]
        self.rewards.load(ck["rewards"])
        _torch.set_rng_state(ck["torch_rng"])
        self.rng.bit_generator.state = ck["numpy_rng"]

    # -- the loop --
    def _collect(self):
        c, e, m = self.c, self.env, self.model
        n, T = c["num_envs"], c["rollout_steps"]
        gamma = c["ppo"]["gamma"]
        obs_buf = _torch.zeros((T, n, self.obs_size))
        u_buf = _torch.zeros((T, n, self.act_size))
        logp_buf = _torch.zeros((T, n))
        val_buf = _torch.zeros((T, n))
        rew_buf = _np.zeros((T, n))
        term_buf = _np.zeros((T, n), dtype=bool)
        done_buf = _np.zeros((T, n), dtype=bool)
        episodes = []
        for t in range(T):
            obs = _torch.as_tensor(_np.asarray(self.obs, dtype=_np.float32))
            obs_buf[t] = obs
            with _torch.no_grad():
                on = m.normalizer(obs)
                dist = m.distribution(on)
                u = dist.sample()
                logp_buf[t] = dist.log_prob(u).sum(-1)
                val_buf[t] = m.value(on)
                action = m.squash(u).numpy()
            u_buf[t] = u
            nobs, reward, terminated, truncated, info = e.step(action)
            reward = _np.asarray(reward, dtype=_np.float64).copy()
            done = _np.logical_or(terminated, truncated)
            if truncated.any():
                # A time limit is not an end of the task: bootstrap with the value of the state the
                # env was cut off in (its final observation).
                idx = _np.flatnonzero(truncated)
                fo = _torch.as_tensor(_np.asarray(info["final_observation"][idx], dtype=_np.float32))
                with _torch.no_grad():
                    v_final = m.value(m.normalizer(fo)).numpy().astype(_np.float64)
                scale = _math.sqrt(self.rewards.var + 1e-8) if c["ppo"]["normalize_rewards"] else 1.0
                reward[idx] += gamma * v_final * scale
            if "_episode" in info:
                ep = info["episode"]
                mask = info["_episode"]
                for k in _np.flatnonzero(mask):
                    episodes.append({key: float(_np.asarray(val)[k]) for key, val in ep.items()})
            rew_buf[t] = self.rewards(reward, done) if c["ppo"]["normalize_rewards"] else reward
            term_buf[t] = terminated
            done_buf[t] = done
            self.obs = nobs
        with _torch.no_grad():
            last_val = m.value(m.normalizer(_torch.as_tensor(_np.asarray(self.obs, dtype=_np.float32)))).numpy()
        m.normalizer.update(obs_buf)
        self.env_steps += n * T
        return obs_buf, u_buf, logp_buf, val_buf.numpy(), rew_buf, done_buf, last_val, episodes

    def _advantages(self, val, rew, done, last_val):
        p = self.c["ppo"]
        T = rew.shape[0]
        adv = _np.zeros_like(rew)
        gae = _np.zeros(rew.shape[1])
        for t in reversed(range(T)):
            next_val = last_val if t == T - 1 else val[t + 1]
            nonterminal = 1.0 - done[t]
            # After an end (crash or time limit, already bootstrapped) the next row is a new episode.
            delta = rew[t] + p["gamma"] * next_val * nonterminal - val[t]
            gae = delta + p["gamma"] * p["gae_lambda"] * nonterminal * gae
            adv[t] = gae
        return adv, adv + val

    def _optimize(self, obs, u, logp_old, adv, ret, val_old):
        p, m = self.c["ppo"], self.model
        N = obs.shape[0]
        mb = N // p["minibatches"]
        obs_n = m.normalizer(obs)  # the statistics of this update, fixed during it
        adv = _torch.as_tensor(adv, dtype=_torch.float32)
        ret = _torch.as_tensor(ret, dtype=_torch.float32)
        stats = {"ppo_loss": [], "critic_loss": [], "entropy": [], "approx_kl": [], "clip_fraction": []}
        epochs_run = 0
        for _ in range(p["epochs"]):
            perm = _torch.as_tensor(self.rng.permutation(N))
            kls = []
            for s in range(0, N, mb):
                idx = perm[s:s + mb]
                dist = m.distribution(obs_n[idx])
                logp = dist.log_prob(u[idx]).sum(-1)
                log_ratio = logp - logp_old[idx]
                ratio = log_ratio.exp()
                a = adv[idx]
                if p["normalize_advantages"]:
                    a = (a - a.mean()) / (a.std() + 1e-8)
                policy_loss = -_torch.min(ratio * a, _torch.clamp(ratio, 1 - p["clip"], 1 + p["clip"]) * a).mean()
                value = m.value(obs_n[idx])
                critic_loss = _nn.functional.smooth_l1_loss(value, ret[idx], beta=p["smooth_l1_beta"])
                entropy = dist.entropy().sum(-1).mean()
                loss = policy_loss + p["value_coef"] * critic_loss - p["entropy_coef"] * entropy
                self.opt.zero_grad()
                loss.backward()
                _nn.utils.clip_grad_norm_(m.parameters(), p["max_grad_norm"])
                self.opt.step()
                with _torch.no_grad():
                    kl = ((ratio - 1) - log_ratio).mean().item()
                kls.append(kl)
                stats["ppo_loss"].append(policy_loss.item())
                stats["critic_loss"].append(critic_loss.item())
                stats["entropy"].append(entropy.item())
                stats["approx_kl"].append(kl)
                stats["clip_fraction"].append(((ratio - 1).abs() > p["clip"]).float().mean().item())
            epochs_run += 1
            if p["target_kl"] and _np.mean(kls) > p["target_kl"]:
                break  # the KL early stop
        out = {k: float(_np.mean(v)) for k, v in stats.items()}
        out["epochs_run"] = epochs_run
        y, v = ret.numpy(), val_old
        out["explained_variance"] = float(1 - _np.var(y - v) / _np.var(y)) if _np.var(y) > 0 else float("nan")
        return out

    def run(self):
        """Trains until total_env_steps; returns the summary dict (also in summary.json)."""
        c = self.c
        _os.makedirs(self.out, exist_ok=True)
        metrics_path = self.path("metrics.csv")
        new_file = not _os.path.exists(metrics_path) or self.update == 0
        metrics = open(metrics_path, "w" if new_file else "a", newline="", encoding="utf-8")
        writer = _csv.DictWriter(metrics, fieldnames=METRIC_COLUMNS)
        if new_file:
            writer.writeheader()
        obs, _ = self.env.reset(seed=int(c["seed"]) + self.update)
        self.obs = obs
        bar = None
        if self.progress:
            try:
                from tqdm import tqdm

                bar = tqdm(total=self.updates_total, initial=self.update, unit="update", file=_sys.stderr,
                           dynamic_ncols=True)
            except ImportError:  # pragma: no cover
                bar = None
        p = c["ppo"]
        last = {}
        try:
            while self.update < self.updates_total:
                t0 = _time.perf_counter()
                if p["anneal_learning_rate"]:
                    frac = 1.0 - self.update / self.updates_total
                    for g, lr in zip(self.opt.param_groups, self.base_lr):
                        g["lr"] = lr * frac
                obs_b, u_b, logp_b, val_b, rew_b, done_b, last_val, episodes = self._collect()
                adv, ret = self._advantages(val_b, rew_b, done_b, last_val)
                flat = lambda x: x.reshape(-1, *x.shape[2:])  # noqa: E731
                stats = self._optimize(flat(obs_b), flat(u_b), flat(logp_b), adv.reshape(-1), ret.reshape(-1),
                                       val_b.reshape(-1))
                self.update += 1
                dt = _time.perf_counter() - t0
                self.wall_s += dt
                row = {"update": self.update, "env_steps": self.env_steps, "wall_clock_s": round(self.wall_s, 3),
                       "samples_per_s": round(c["num_envs"] * c["rollout_steps"] / dt, 1),
                       "episodes": len(episodes), "action_std": float(self.model.log_std.exp().mean()),
                       "learning_rate": self.opt.param_groups[0]["lr"], **stats}
                if episodes:
                    row["episode_return"] = _np.mean([ep["return"] for ep in episodes])
                    row["episode_length"] = _np.mean([ep["length"] for ep in episodes])
                    row["gates"] = _np.mean([ep.get("gates", 0.0) for ep in episodes])
                    laps = [ep["best_lap_s"] for ep in episodes if _np.isfinite(ep.get("best_lap_s", _np.nan))]
                    row["lap_time_s"] = _np.mean(laps) if laps else ""
                    crash = [_rl.END_CAUSES[int(ep["cause"])] not in ("time_limit", "finished") for ep in episodes]
                    row["crash_fraction"] = _np.mean(crash)
                every = c["evaluation"]["every_updates"]
                if every and self.update % every == 0 and self.update < self.updates_total:
                    ev = self.evaluate()
                    row["eval_return"], row["eval_success"] = ev["return_mean"], ev["success_fraction"]
                writer.writerow({k: row.get(k, "") for k in METRIC_COLUMNS})
                metrics.flush()
                last = row
                if bar is not None:
                    bar.update(1)
                    bar.set_postfix(ret=f"{row.get('episode_return', float('nan')):.2f}",
                                    kl=f"{stats['approx_kl']:.3f}", sps=f"{row['samples_per_s']:.0f}")
                if c["checkpoint_every_updates"] and self.update % c["checkpoint_every_updates"] == 0:
                    self._checkpoint()
        finally:
            if bar is not None:
                bar.close()
            metrics.close()
        self._checkpoint()
        final = self.evaluate()
        self.export(self.path("policy.dtpolicy"), self.path("policy.onnx"))
        summary = {"config": c, "updates": self.update, "env_steps": self.env_steps,
                   "wall_clock_s": self.wall_s, "samples_per_s": self.env_steps / max(self.wall_s, 1e-9),
                   "last_update": {k: v for k, v in last.items() if v != ""}, "evaluation": final}
        _policy.atomic_write_bytes(self.path("summary.json"),
                                   (_json.dumps(summary, indent=2, default=_jsonable) + "\n").encode())
        try:
            plot_metrics(metrics_path, self.path("training.png"))
        except ImportError:  # pragma: no cover - matplotlib missing
            pass
        return summary

    # -- evaluation and export --
    def policy_fn(self):
        m = self.model

        def act(obs):
            with _torch.no_grad():
                return m.deterministic(_torch.as_tensor(_np.asarray(obs, dtype=_np.float32))).numpy()

        return act

    def evaluate(self, episodes=None, seed=None):
        ev = self.c["evaluation"]
        return evaluate(self.policy_fn(), self.c, episodes or ev["episodes"],
                        ev["seed"] if seed is None else seed, ev["overrides"])

    def export(self, dtpolicy_path, onnx_path=None):
        m, e = self.model, self.env
        layers = [mod for mod in m.actor if isinstance(mod, _nn.Linear)]
        std = m.normalizer.std().numpy()
        _policy.write(
            dtpolicy_path,
            observation=[(name, s.stop - s.start) for name, s in e.observation_layout.items()],
            action_mode=e.action_mode, normalized_actions=bool(e._env.normalized_actions),
            weights=[layer.weight.detach().numpy() for layer in layers],
            biases=[layer.bias.detach().numpy() for layer in layers],
            observation_mean=m.normalizer.mean.numpy().astype(_np.float32),
            observation_std=std.astype(_np.float32), action_scale=m.action_scale.numpy(),
            activation=m.activation, negative_slope=m.slope, output="tanh",
            observation_clip=m.normalizer.clip,
            env={"config": _os.path.relpath(self.c["env_path"]), "overrides": self.c["env_overrides"],
                 "task": e.task, "control_rate_hz": 1.0 / e.dt},
            training={"env_steps": self.env_steps, "updates": self.update, "seed": self.c["seed"],
                      "wall_clock_s": round(self.wall_s, 3), "num_envs": self.c["num_envs"]})
        if onnx_path:
            export_onnx(m, self.obs_size, onnx_path)


class _Deterministic(_nn.Module):
    def __init__(self, model):
        super().__init__()
        self.model = model

    def forward(self, observation):
        return self.model.deterministic(observation)


def export_onnx(model, obs_size, path):
    """The deterministic policy (normalisation, MLP, tanh, scale) as ONNX, batch dimension
    dynamic; checked with ``onnx.checker`` when the onnx package is importable."""
    wrapper = _Deterministic(_copy.deepcopy(model)).eval()
    buf = _io.BytesIO()
    _torch.onnx.export(wrapper, _torch.zeros(1, obs_size), buf, input_names=["observation"],
                       output_names=["action"], dynamic_axes={"observation": {0: "batch"}, "action": {0: "batch"}},
                       opset_version=13)
    data = buf.getvalue()
    try:
        import onnx

        onnx.checker.check_model(onnx.load_from_string(data))
    except ImportError:  # pragma: no cover
        pass
    _policy.atomic_write_bytes(path, data)


def _jsonable(x):
    if isinstance(x, (_np.floating, _np.integer)):
        return x.item()
    if isinstance(x, _np.ndarray):
        return x.tolist()
    return str(x)


# ---- plots -----------------------------------------------------------------------------------

def plot_metrics(metrics_csv, png_path):
    """The thesis's training plots (episode return, PPO loss, critic loss, approximate KL,
    evaluation reward) plus gates passed and lap time, against environment steps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = list(_csv.DictReader(open(metrics_csv, encoding="utf-8")))
    if not rows:
        return
    steps = _np.array([float(r["env_steps"]) for r in rows])

    def col(name):
        return _np.array([float(r[name]) if r[name] not in ("", "nan") else _np.nan for r in rows])

    panels = [("episode_return", "episode return"), ("ppo_loss", "PPO loss"), ("critic_loss", "critic loss"),
              ("approx_kl", "approximate KL"), ("eval_return", "evaluation return"), ("gates", "gates passed"),
              ("lap_time_s", "lap time (s)"), ("action_std", "action std")]
    spare = [("crash_fraction", "crashed episodes (fraction)"), ("episode_length", "episode length (steps)"),
             ("eval_success", "evaluation success"), ("explained_variance", "explained variance")]

    def has_data(key):
        y = col(key)
        return bool(_np.isfinite(y).any()) and not (key == "gates" and _np.nanmax(y) == 0)

    # Panels without data (no evaluation during training, no gates when hovering) give way.
    spare = [p for p in spare if has_data(p[0])]
    panels = [p if has_data(p[0]) or not spare else spare.pop(0) for p in panels]
    fig, axes = plt.subplots(2, 4, figsize=(16, 7))
    for ax, (key, title) in zip(axes.flat, panels):
        y = col(key)
        ok = _np.isfinite(y)
        ax.plot(steps[ok], y[ok], marker="o" if key == "eval_return" else None, lw=1)
        ax.set_title(title)
        ax.set_xlabel("environment steps")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    buf = _io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    _policy.atomic_write_bytes(png_path, buf.getvalue())


# ---- entry point -----------------------------------------------------------------------------

def train(config_path, out_dir, resume=False, overrides=None, progress=True):
    """Trains the configuration of ``config_path`` into ``out_dir`` (which must be new or empty,
    unless ``resume``). Returns the run's summary."""
    out_dir = _os.fspath(out_dir)
    c = load_config(config_path, overrides)
    if resume:
        if not _os.path.exists(_os.path.join(out_dir, "checkpoint.pt")):
            raise ValueError(f"train --resume: {out_dir} holds no checkpoint.pt to resume from")
    elif _os.path.exists(out_dir) and _os.listdir(out_dir):
        raise ValueError(f"train: {out_dir} exists and is not empty; choose a new folder, or --resume a run there")
    _os.makedirs(out_dir, exist_ok=True)
    if not resume:
        with open(config_path, "rb") as f:
            _policy.atomic_write_bytes(_os.path.join(out_dir, "config.yaml"), f.read())
    return Trainer(c, out_dir, resume=resume, progress=progress).run()
