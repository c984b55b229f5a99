"""The browser replay viewer: a run in 3-D with its path, reference, scene, rotor speeds and a
timeline, as one self-contained page (docs/viewer.md).

    dronetwin view out/se3_circle                    # serves it on http://127.0.0.1:8765/
    dronetwin view out/se3_circle --out circle.html  # writes the page instead
    python3 -m dronetwin.view out/crossing --port 9000

A run folder of `dronetwin run`, a fleet run (fleet_summary.json: every vehicle in its own
colour) or the RL episodes of `dronetwin evaluate --record` (episodes.json: every episode a
vehicle, all starting together). The page holds three.js, uPlot (bundled from npm when dronetwin was built: no CDN, no
network at view time) and the run's data; it opens from a file as well as from the server.

Long runs are sampled to at most --max-frames frames (default 5000), evenly in time, always
keeping the first and the last row. The page is written under a temporary name and moved into
place; an existing file is never replaced.
"""

from __future__ import annotations

import argparse
import http.server
import json
import os
import sys
import tempfile

import numpy as np

BUNDLE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "viewer", "viewer.js")
TEMPLATE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "viewer", "index.html")


class ViewError(ValueError):
    """A run folder, page path or option that cannot be used: the message names it."""


def _sample(n, max_frames):
    if n <= max_frames:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_frames)).astype(int))


def _vehicle(name, folder, max_frames, hubs=None):
    from . import load_model, read_log

    log_path = os.path.join(folder, "log.csv")
    if not os.path.isfile(log_path):
        raise ViewError(f"{log_path}: missing (expected the log of `dronetwin run`)")
    log, meta = read_log(log_path, metadata=True)
    for column in ("t", "x", "y", "z", "qw", "qx", "qy", "qz", "omega_0"):
        if column not in log:
            raise ViewError(f"{log_path}: no column {column!r} (not a dronetwin run log?)")
    rows = _sample(len(log["t"]), max_frames)
    num_rotors = sum(1 for c in log if c.startswith("omega_") and c[6:].isdigit())
    model_path = meta.model_path if meta is not None else ""
    model = load_model(model_path) if model_path and os.path.isfile(model_path) else None
    if hubs is not None:  # RL episodes: the layout is in their index
        hubs = [list(map(float, h)) for h in hubs]
    elif model is not None:
        hubs = [list(map(float, r.position_m)) for r in model.spec.rotors]
    else:  # the model file moved: draw a generic X layout of the right rotor count
        angles = np.pi / 4 + 2 * np.pi * np.arange(num_rotors) / num_rotors
        hubs = [[0.2 * np.cos(a), 0.2 * np.sin(a), 0.0] for a in angles]
    arm = max(np.hypot(h[0], h[1]) for h in hubs)

    def stack(columns):
        return np.stack([log[c][rows] for c in columns], axis=1).round(6).tolist()

    vehicle = {
        "name": name or (meta.model if meta is not None else "vehicle"),
        "t": log["t"][rows].round(6).tolist(),
        "p": stack(["x", "y", "z"]),
        "q": stack(["qw", "qx", "qy", "qz"]),
        "omega": stack([f"omega_{i}" for i in range(num_rotors)]),
        "ref": stack(["ref_x", "ref_y", "ref_z"]) if "ref_x" in log else None,
        "rotors": hubs,
        "rotor_radius_m": 0.4 * arm,
    }
    scene_path = None
    summary = os.path.join(folder, "summary.json")
    if os.path.isfile(summary):
        with open(summary, encoding="utf-8") as f:
            scene_path = json.load(f).get("scene_path") or None
    return vehicle, scene_path


def _scene(path):
    if not path:
        return {"gates": [], "obstacles": []}
    from . import load_track

    if not os.path.isfile(path):
        raise ViewError(f"scene {path}: missing (the run's summary.json names it)")
    return scene_of_track(load_track(path))


def scene_of_track(track):
    """The page's scene (gates and obstacles) of a Track."""
    gates = [{"name": g["name"], "corners": [list(map(float, c)) for c in g["bar_corners"]],
              "bar_m": float(g["frame_width_m"])} for g in track.gates]
    obstacles = [{"name": o["name"], "type": o["type"],
                  "center": list(map(float, o["center"])),
                  "half_size": list(map(float, o["half_size"]))} for o in track.obstacles]
    return {"gates": gates, "obstacles": obstacles}


def run_data(run_dir, max_frames=5000):
    """The page's data for the run (or fleet run) in `run_dir`, as a JSON-ready dict."""
    if not os.path.isdir(run_dir):
        raise ViewError(f"{run_dir}: not a folder (expected a run folder with log.csv)")
    if not isinstance(max_frames, int) or max_frames < 2:
        raise ViewError(f"--max-frames: expected an integer >= 2, got {max_frames!r}")
    title = os.path.basename(os.path.normpath(run_dir))
    if os.path.isfile(os.path.join(run_dir, "episodes.json")):
        return _episodes_data(run_dir, title, max_frames)
    vehicles, scene_path = [], None
    from . import run_vehicle_folders

    for name, folder in run_vehicle_folders(run_dir):
        vehicle, scene = _vehicle(name, folder, max_frames)
        vehicles.append(vehicle)
        scene_path = scene_path or scene
    return {"title": title, "vehicles": vehicles, "scene": _scene(scene_path)}


def _episodes_data(run_dir, title, max_frames):
    """RL episodes recorded by `dronetwin evaluate --record` (training.write_episode_logs): one
    vehicle per episode, all starting at t = 0, named with how the episode ended."""
    path = os.path.join(run_dir, "episodes.json")
    try:
        with open(path, encoding="utf-8") as f:
            index = json.load(f)
    except json.JSONDecodeError as e:
        raise ViewError(f"{path}: not JSON ({e})") from None
    if not isinstance(index, dict) or index.get("format") != "dronetwin.episodes":
        raise ViewError(f"{path}: format: expected 'dronetwin.episodes', got "
                        f"{index.get('format') if isinstance(index, dict) else index!r}")
    if index.get("format_version") != 1:
        raise ViewError(f"{path}: format_version: expected 1, got {index.get('format_version')!r}")
    for key in ("episodes", "rotors", "scene"):
        if key not in index:
            raise ViewError(f"{path}: no field {key!r}")
    if not index["episodes"]:
        raise ViewError(f"{path}: episodes: empty (nothing was recorded)")
    vehicles = []
    for k, e in enumerate(index["episodes"]):
        name = e.get("name") if isinstance(e, dict) else None
        if not isinstance(name, str) or "/" in name or name in ("", ".", ".."):
            raise ViewError(f"{path}: episodes[{k}]: expected {{name: folder, ...}}, got {e!r}")
        vehicle, _ = _vehicle(e["name"], os.path.join(run_dir, e["name"]), max_frames, index["rotors"])
        t_end = vehicle["t"][-1]
        vehicle["name"] = f"{e['name']} ({e.get('cause', '?')}, {t_end:.2f} s)"
        vehicles.append(vehicle)
    return {"title": f"{title}: {len(vehicles)} episodes", "vehicles": vehicles, "scene": index["scene"]}


def page(data):
    """The self-contained HTML page of `data` (run_data())."""
    if not os.path.isfile(BUNDLE):
        raise ViewError(f"{BUNDLE}: missing: the viewer is bundled from npm when dronetwin is "
                        "built (needs npm; `bash .ci/install-deps` installs it)")
    with open(TEMPLATE, encoding="utf-8") as f:
        template = f.read()
    with open(BUNDLE, encoding="utf-8") as f:
        bundle = f.read()
    # Inside <script> a "</" would end the element; JSON and JavaScript read "<\/" the same.
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    head, rest = template.split("/*DRONETWIN_DATA*/")
    middle, tail = rest.split("/*DRONETWIN_BUNDLE*/")
    return head + payload + middle + bundle.replace("</script", "<\\/script") + tail


def write_page(run_dir, out, max_frames=5000):
    """Writes the page of the run in `run_dir` to the new file `out`; returns its size in bytes."""
    if os.path.lexists(out):
        raise ViewError(f"--out {out}: already exists; the viewer never replaces a file")
    folder = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(folder):
        raise ViewError(f"--out {out}: folder {folder} does not exist")
    text = page(run_data(run_dir, max_frames)).encode("utf-8")
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(out) + ".", suffix=".partial",
                               dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would hide the page from a web server
        os.link(tmp, out)  # fails instead of replacing a file that appeared meanwhile
    finally:
        os.unlink(tmp)
    return len(text)


def serve(run_dir, port=8765, max_frames=5000):
    """Serves the page on http://127.0.0.1:port/ until interrupted."""
    text = page(run_data(run_dir, max_frames)).encode("utf-8")

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self):  # noqa: N802 (the name http.server calls)
            if self.path.split("?")[0] not in ("/", "/index.html"):
                self.send_error(404)
                return
            self.send_response(200)
            self.send_header("Content-Type", "text/html; charset=utf-8")
            self.send_header("Content-Length", str(len(text)))
            self.end_headers()
            self.wfile.write(text)

        def log_message(self, *args):
            pass

    with http.server.ThreadingHTTPServer(("127.0.0.1", port), Handler) as server:
        print(f"dronetwin view: http://127.0.0.1:{server.server_address[1]}/ (Ctrl-C to stop)",
              flush=True)
        try:
            server.serve_forever()
        except KeyboardInterrupt:
            pass


def main(argv=None):
    parser = argparse.ArgumentParser(prog="dronetwin view", description=__doc__.split("\n")[0])
    parser.add_argument("run_dir", help="a run folder of `dronetwin run` (or a fleet run)")
    parser.add_argument("--out", help="write the page to this new .html file instead of serving")
    parser.add_argument("--port", type=int, default=8765, help="port to serve on (0: any free)")
    parser.add_argument("--max-frames", type=int, default=5000,
                        help="sample long runs to at most this many frames")
    args = parser.parse_args(argv)
    try:
        if args.out:
            size = write_page(args.run_dir, args.out, args.max_frames)
            print(f"dronetwin view: wrote {args.out} ({size / 1e6:.1f} MB)")
        else:
            serve(args.run_dir, args.port, args.max_frames)
    except (ViewError, OSError) as e:
        print(f"dronetwin view: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
