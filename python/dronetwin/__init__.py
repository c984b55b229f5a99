"""dronetwin: a deterministic, steppable digital twin of multirotor drones (Python side).

The engine is C++ (the extension ``dronetwin._core``); this package re-exports it and adds
numpy/pandas helpers. The same code runs behind the ``dronetwin`` command line tool, so a run
scripted here and the same run from the CLI give bitwise-identical logs.

    import dronetwin as dt
    model = dt.load_model("models/qdrone2.yaml")
    sim = dt.Simulator(model, dt.SimConfig(seed=1))
    sim.reset(dt.Simulator.hover_state([0, 0, 1]), model.hover_speeds_rad_s())
    pid = dt.load_controller("config/controllers/pid_tuned.yaml", model, 1000.0)
    loop = dt.ClosedLoop(sim, pid, dt.PiecewiseConstantReference.thesis_pulse(), 1000.0)
    log = loop.record(10.0)            # dict of numpy arrays
    print(dt.rmse(log))                # [x, y, z, yaw]

Errors from the engine arrive as ValueError (bad input: names the file, field or argument) and
RuntimeError (a failed simulation); wrong array shapes or dtypes raise ValueError / TypeError.
"""

from __future__ import annotations

import os as _os

import numpy as _np

from ._core import *  # noqa: F401,F403  (the bound classes and functions)
from . import _core
from ._core import __version__, read_log_table, sidecar_path  # noqa: F401

STATE_COLUMNS = ("x", "y", "z", "vx", "vy", "vz", "qw", "qx", "qy", "qz", "wx", "wy", "wz")


def _log_csv_path(path):
    path = str(path)
    return _os.path.join(path, "log.csv") if _os.path.isdir(path) else path


def read_log(path, as_frame=False, metadata=False):
    """Reads a run log (``log.csv`` of ``dronetwin run`` / ``run_experiment``).

    Returns a dict {column name: float64 array} (``as_frame=False``) or a pandas DataFrame
    (``as_frame=True``; needs pandas). ``path`` may be the CSV or the run directory holding it.
    With ``metadata=True`` returns ``(log, meta)``: ``meta`` is the LogMetadata of the log's
    JSON sidecar (same stem, ``.json``: units, seed, dt_s, log rate, model hash, ...) or None when
    there is none. Formats: docs/log-format.md.
    """
    path = _log_csv_path(path)
    columns, values = read_log_table(path)
    if as_frame:
        try:
            import pandas as pd
        except ImportError as e:  # pragma: no cover - depends on the machine
            raise ImportError("read_log(as_frame=True) needs pandas (Debian: python3-pandas)") from e
        log = pd.DataFrame(values, columns=columns)
    else:
        log = {name: values[:, i] for i, name in enumerate(columns)}
    if not metadata:
        return log
    sidecar = sidecar_path(path)
    if not _os.path.exists(sidecar):
        return log, None
    meta = _core.read_log_metadata(sidecar)
    if meta.column_names() != list(columns):
        raise ValueError(f"{sidecar}: columns: do not match the header of {path}")
    return log, meta


def run_vehicle_folders(run_dir):
    """[(vehicle name, folder holding its log.csv)] of a run folder: one (None, run_dir) for a
    `dronetwin run` folder, one per vehicle of its fleet_summary.json for a fleet run."""
    fleet = _os.path.join(run_dir, "fleet_summary.json")
    if not _os.path.isfile(fleet):
        return [(None, run_dir)]
    import json

    with open(fleet, encoding="utf-8") as f:
        summary = json.load(f)
    return [(v["name"], _os.path.join(run_dir, v["name"])) for v in summary.get("vehicles", [])]


def read_log_metadata(path):
    """The LogMetadata of a run log's JSON sidecar (``log.json``; docs/log-format.md).

    ``path`` may be the sidecar itself, the log's CSV (its sidecar has the same stem) or the run
    directory. ValueError naming the file and field for a malformed sidecar.
    """
    path = str(path)
    if _os.path.isdir(path):
        path = _os.path.join(path, "log.json")
    elif not path.endswith(".json"):
        path = sidecar_path(path)
    return _core.read_log_metadata(path)


def yaw_from_quaternions(q):
    """ZYX yaw (rad) of quaternions q[..., 4] = [w, x, y, z] (atan2 form, thesis notes #23)."""
    q = _np.asarray(q, dtype=float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return _np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def rmse(record, window_s=None):
    """Tracking RMSE [x, y, z, yaw] of a ClosedLoop.record() result (true state vs reference).

    ``window_s=(t0, t1)`` limits the physics steps used; the yaw error is wrapped into [-pi, pi].
    This calls the C++ metric the runner's summary uses (``tracking_rmse``), so the two agree to
    the bit, window edges included. A record without ``dt_s`` (built by hand) takes the spacing
    of its first two rows as the step.
    """
    t = _np.ascontiguousarray(record["t"], dtype=float)
    dt = record.get("dt_s") if hasattr(record, "get") else None
    if dt is None:
        if t.shape[0] < 2:
            raise ValueError("rmse: the record has no dt_s and fewer than two rows")
        dt = float(t[1] - t[0])
    return _core.tracking_rmse(t, record["state"], record["reference"], float(dt), window_s)


def default_data_dir():
    """The directory holding ``models/`` and ``config/``: the source tree when run from a build
    tree, else the installed share directory (``<prefix>/share/dronetwin``)."""
    here = _os.path.dirname(_os.path.abspath(__file__))
    for candidate in (
        _os.environ.get("DRONETWIN_DATA_DIR", ""),
        _os.path.join(here, "..", "..", "..", ".."),  # <src>/build/<preset>/python/dronetwin
        _os.path.join(here, "..", "..", "..", "..", "share", "dronetwin"),  # <prefix>/lib/pythonX/dist-packages
    ):
        if candidate and _os.path.isdir(_os.path.join(candidate, "models")):
            return _os.path.normpath(candidate)
    return None


def BatchSimulator(model, config=None, num_vehicles=1, num_threads=1, dtype=_np.float64):
    """N vehicles of one airframe stepped together (the batched engine, docs/batch.md).

    Every lane is the Simulator's vehicle with its own state, rotor speeds, wind and parameters;
    in float64 a lane equals a Simulator run bit for bit. ``dtype`` is numpy.float64 (default) or
    numpy.float32 (twice the lanes per instruction). The state is a live (N, 13) view:

        batch = dt.BatchSimulator(model, dt.SimConfig(), num_vehicles=4096, num_threads=2)
        batch.reset(None, dt.Simulator.hover_state([0, 0, 1]), model.hover_speeds_rad_s())
        batch.set_parameter("mass", rng.uniform(1.3, 1.7, 4096))   # domain randomisation
        batch.rotor_speed_reference[:] = model.hover_speeds_rad_s()
        failed = batch.step(100)                                     # GIL released
        z = batch.state[:, 2]

    A lane whose step fails stops at its last good state with a non-zero ``status`` entry
    (a StepStatus value) while the others go on; ``reset`` revives it.
    """
    if config is None:
        config = SimConfig()
    cls = _by_dtype("BatchSimulator", dtype, BatchSimulator64, BatchSimulator32)
    return cls(model, config, num_vehicles, num_threads)


def _by_dtype(what, dtype, f64, f32):
    """The float64 or the float32 class of a batched object, by numpy dtype."""
    dtype = _np.dtype(dtype)
    if dtype == _np.float64:
        return f64
    if dtype == _np.float32:
        return f32
    raise ValueError(f"{what}: dtype: expected float64 or float32, got {dtype}")


def BatchSe3Controller(model, gains, options, num_vehicles, dtype=_np.float64):
    """The SE(3) controller for every lane of a batch, run inside ``BatchSimulator.step``:

        se3 = dt.BatchSe3Controller(model, dt.Se3Gains.thesis(), options, 4096)
        se3.reference[:, 0:3] = targets              # (N, 20): p, v, a, cos/sin yaw, feed-forward
        batch.step(1000, se3)                        # the controller before every physics step

    In float64 a lane equals Se3Controller flown by ClosedLoop at the physics rate. ``dtype``
    must be the batch's.
    """
    cls = _by_dtype("BatchSe3Controller", dtype, BatchSe3Controller64, BatchSe3Controller32)
    return cls(model, gains, options, num_vehicles)


def BatchBodyRateController(model, gains, num_vehicles, dtype=_np.float64):
    """The body-rate (CTBR) controller for every lane of a batch, run inside
    ``BatchSimulator.step``: each lane's command [T (N), wx, wy, wz (rad/s)] becomes body torques
    tau = J K (w_cmd - w) + w x J w and rotor references (thrust first):

        rates = dt.BatchBodyRateController(model, dt.BodyRateGains(), 4096)
        rates.command[:] = actions                   # (N, 4) writable view
        batch.step(10, rates)                        # e.g. a 100 Hz policy over 1 kHz physics

    In float64 a lane equals BodyRateController flown by ClosedLoop at the physics rate.
    ``dtype`` must be the batch's.
    """
    cls = _by_dtype("BatchBodyRateController", dtype, BatchBodyRateController64,
                    BatchBodyRateController32)
    return cls(model, gains, num_vehicles)


def BatchCascadedPid(model, gains, options, control_period_s, num_vehicles, dtype=_np.float64):
    """The cascaded PID for every lane of a batch, run inside ``BatchSimulator.step`` every
    physics step (so ``control_period_s`` is the batch's ``dt_s``):

        pid = dt.BatchCascadedPid(model, gains, options, batch.dt_s, 4096)
        pid.reference[:, 0:3] = targets              # (N, 17): p, v, yaw, yaw rate, feed-forward
        pid.set_reference(lane, reference_point)     # or one lane, feed-forward columns included
        batch.step(1000, pid)

    In float64 a lane equals CascadedPid flown by ClosedLoop at the physics rate.
    """
    cls = _by_dtype("BatchCascadedPid", dtype, BatchCascadedPid64, BatchCascadedPid32)
    return cls(model, gains, options, control_period_s, num_vehicles)
