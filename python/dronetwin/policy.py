"""Trained policies: the ``.dtpolicy`` file (docs/policy-format.md), ONNX export, evaluation.

    from dronetwin import policy
    p = policy.load("policies/hover_ctbr.dtpolicy")      # C++ evaluator, no torch needed
    actions = p(obs)                                      # (n, observation_size) -> (n, action_size)
    stats = policy.evaluate(p, "config/training/hover_ctbr.yaml", episodes=100, seed=1000)

Writing needs only numpy (``write``); ``export_onnx`` needs torch and checks the result with the
``onnx`` package when it is importable.
"""

from __future__ import annotations

import json as _json
import os as _os
import struct as _struct
import tempfile as _tempfile

import numpy as _np

MAGIC = b"DTPOLICY"
FORMAT = "dronetwin.policy"
FORMAT_VERSION = 1
ACTIVATIONS = ("leaky_relu", "relu", "tanh")
OUTPUTS = ("tanh", "identity")


def atomic_write_bytes(path, data):
    """Writes ``data`` to ``path`` through a temporary file in the same folder and a rename, so
    that a reader never sees half a file and a failed write leaves the old file intact."""
    folder = _os.path.dirname(_os.path.abspath(path))
    fd, tmp = _tempfile.mkstemp(prefix=".tmp-", dir=folder)
    try:
        umask = _os.umask(0)
        _os.umask(umask)
        _os.fchmod(fd, 0o666 & ~umask)  # mkstemp makes 0600; a plain file respects the umask
        with _os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            _os.fsync(f.fileno())
        _os.replace(tmp, path)
    except BaseException:
        if _os.path.exists(tmp):
            _os.unlink(tmp)
        raise


def policy_bytes(*, observation, action_mode, normalized_actions, weights, biases, observation_mean,
                 observation_std, action_scale, activation="leaky_relu", negative_slope=0.2,
                 output="tanh", observation_clip=10.0, env=None, training=None):
    """The bytes of a ``.dtpolicy`` file. ``observation``: [(piece name, size), ...];
    ``weights[k]``: (out, in) arrays, ``biases[k]``: (out,) arrays, input layer first."""
    if activation not in ACTIVATIONS:
        raise ValueError(f"policy: activation: expected one of {ACTIVATIONS}, got {activation!r}")
    if output not in OUTPUTS:
        raise ValueError(f"policy: output: expected one of {OUTPUTS}, got {output!r}")
    if len(weights) != len(biases) or not weights:
        raise ValueError(f"policy: expected as many biases as weights (>= 1), got {len(weights)} and {len(biases)}")
    obs_size = int(sum(size for _, size in observation))
    layers = [int(_np.shape(weights[0])[1])] + [int(_np.shape(w)[0]) for w in weights]
    if layers[0] != obs_size:
        raise ValueError(f"policy: the first layer takes {layers[0]} inputs, the observation has {obs_size}")
    tensors = [("observation_mean", _np.asarray(observation_mean)), ("observation_std", _np.asarray(observation_std))]
    for k, (w, b) in enumerate(zip(weights, biases)):
        tensors += [(f"layers.{k}.weight", _np.asarray(w)), (f"layers.{k}.bias", _np.asarray(b))]
    for name, t in tensors:
        if not _np.all(_np.isfinite(t)):
            raise ValueError(f"policy: tensor {name} holds non-finite values")
    header = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "observation": [{"name": str(n), "size": int(s)} for n, s in observation],
        "observation_size": obs_size,
        "action_size": layers[-1],
        "action_mode": str(action_mode),
        "normalized_actions": bool(normalized_actions),
        "network": {
            "layers": layers,
            "activation": activation,
            "negative_slope": float(negative_slope),
            "output": output,
            "action_scale": [float(x) for x in _np.asarray(action_scale, dtype=float).reshape(-1)],
            "observation_clip": float(observation_clip),
        },
        "tensors": [{"name": n, "shape": list(t.shape)} for n, t in tensors],
        "env": env or {},
        "training": training or {},
    }
    text = _json.dumps(header, indent=1, sort_keys=False, allow_nan=False).encode("utf-8")
    body = b"".join(_np.ascontiguousarray(t, dtype="<f4").tobytes() for _, t in tensors)
    return MAGIC + _struct.pack("<II", FORMAT_VERSION, len(text)) + text + body


def write(path, **fields):
    """Writes a ``.dtpolicy`` file atomically (fields: see ``policy_bytes``)."""
    atomic_write_bytes(path, policy_bytes(**fields))


def read_header(path):
    """The JSON header of a ``.dtpolicy`` file, as a dict (no tensors)."""
    with open(path, "rb") as f:
        head = f.read(16)
        if len(head) < 16 or head[:8] != MAGIC:
            raise ValueError(f"{path}: not a dronetwin policy file (expected the magic {MAGIC!r})")
        _, length = _struct.unpack("<II", head[8:16])
        return _json.loads(f.read(length).decode("utf-8"))


def load(path):
    """The policy of a ``.dtpolicy`` file, evaluated in C++ (``dronetwin._core.Policy``):
    ``p(obs)`` / ``p.evaluate(obs)`` map (n, observation_size) to (n, action_size)."""
    from . import _core

    return _core.Policy(_os.fspath(path))
