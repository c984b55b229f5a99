"""`dronetwin view` (python/dronetwin/view.py and the bundled page of python/dronetwin/viewer):
a real run's page loaded in Debian's headless Chromium shows every frame, the asked time and no
error, and looks like the reference screenshot; the page holds the log's data exactly as
sampled; fleets get one vehicle each; the server serves it; bad input is refused.

Needs the bundle (npm at build time) and Chromium (`chromium`, .ci/install-deps).
"""

import json
import os
import re
import shutil
import subprocess
import urllib.request
from pathlib import Path

import numpy as np
import pytest

import dronetwin
from dronetwin import view

SOURCE = Path(os.environ["DRONETWIN_SOURCE_DIR"])
CLI = os.environ["DRONETWIN_CLI"]
REFERENCE = SOURCE / "tests/data/viewer/ros_hover_t2.5.png"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
WINDOW = (1280, 720)


def chromium(url, tmp_path, *extra):
    """Headless Chromium on software GL (no GPU here), with a fixed window and virtual time."""
    assert CHROMIUM, "chromium is not installed (bash .ci/install-deps)"
    profile = tmp_path / f"profile{len(list(tmp_path.glob('profile*')))}"
    return subprocess.run(
        [CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
         "--enable-unsafe-swiftshader", "--hide-scrollbars", "--force-device-scale-factor=1",
         f"--window-size={WINDOW[0]},{WINDOW[1]}", "--virtual-time-budget=10000",
         f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0", *extra, url],
        capture_output=True, text=True, timeout=180)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """3 s of the ROS bridge's experiment flown by its SE(3) controller: a climb to 1 m at the
    start of the obstacle course (a gate and four obstacles in view)."""
    out = tmp_path_factory.mktemp("view") / "run"
    subprocess.run([CLI, "run", str(SOURCE / "config/experiments/ros_hover.yaml"), "--out",
                    str(out), "--duration", "3"], check=True, capture_output=True)
    return out


@pytest.fixture(scope="module")
def page_path(run):
    path = run.parent / "page.html"
    assert view.main([str(run), "--out", str(path)]) == 0
    return path


def status_of(dom):
    m = re.search(r'<span id="status"([^>]*)>', dom)
    assert m, dom[:2000]
    return dict(re.findall(r'data-([a-z]+)="([^"]*)"', m.group(1)))


def test_page_holds_the_log_exactly_as_sampled(run, page_path):
    html = page_path.read_text()
    data = json.loads(re.search(r'id="run-data">(.*?)</script>', html, re.S).group(1))
    log = dronetwin.read_log(str(run / "log.csv"))
    (vehicle,) = data["vehicles"]
    n = len(log["t"])  # 3 s logged every 10 steps: 301 rows, under --max-frames
    assert len(vehicle["t"]) == n == 301
    np.testing.assert_allclose(vehicle["p"], np.stack([log["x"], log["y"], log["z"]], 1),
                               atol=5e-7)
    np.testing.assert_allclose(vehicle["ref"][-1], [0, 0, 1], atol=5e-7)
    assert len(vehicle["omega"][0]) == 4
    track = dronetwin.load_track(str(SOURCE / "config/tracks/obstacle_course.yaml"))
    assert [g["name"] for g in data["scene"]["gates"]] == track.gate_names
    assert [o["name"] for o in data["scene"]["obstacles"]] == [o["name"] for o in track.obstacles]


def test_sampling_keeps_the_ends_and_at_most_max_frames(run):
    data = view.run_data(str(run), max_frames=50)
    t = data["vehicles"][0]["t"]
    assert len(t) <= 50 and t[0] == 0.0 and t[-1] == pytest.approx(3.0)
    assert np.all(np.diff(t) > 0)


def test_chromium_shows_every_frame_the_asked_time_and_no_error(page_path, tmp_path):
    out = chromium(f"file://{page_path}?t=2.5", tmp_path, "--dump-dom")
    assert out.returncode == 0, out.stderr[-3000:]
    status = status_of(out.stdout)
    assert status["ready"] == "1"
    assert status["errors"] == "0", out.stdout
    assert status["frames"] == "301"
    assert status["time"] == "2.500" and status["frame"] == "251"
    assert "t = 2.500 s · frame 251 / 301" in out.stdout
    console_errors = [line for line in out.stderr.splitlines()
                      if "CONSOLE" in line and ("ERROR" in line or "Uncaught" in line)]
    assert console_errors == []


def test_screenshot_matches_the_reference(page_path, tmp_path):
    shot = tmp_path / "shot.png"
    out = chromium(f"file://{page_path}?t=2.5", tmp_path, f"--screenshot={shot}")
    assert out.returncode == 0 and shot.exists(), out.stderr[-3000:]
    import matplotlib.image as mpimg

    got = mpimg.imread(shot)[..., :3]
    if os.environ.get("DRONETWIN_UPDATE_REFERENCE"):  # to regenerate after a deliberate change
        REFERENCE.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(shot, REFERENCE)
    want = mpimg.imread(REFERENCE)[..., :3]
    assert got.shape == want.shape == (WINDOW[1], WINDOW[0], 3)
    # The 3-D view only: text (plots, clock) is drawn with whatever fonts the machine has. The
    # page fixes the bars' heights, so the view is rows 28 to 680, columns 0 to 800 (the plots
    # take the right 480).
    view_rows, view_cols = slice(28, WINDOW[1] - 40), slice(0, WINDOW[0] - 480)
    difference = np.abs(got - want)[view_rows, view_cols].max(axis=2)
    # Here the software renderer is deterministic (no pixel differs between runs); the margin is
    # for another CPU's SwiftShader code path moving an anti-aliased edge. Showing t = 1.0 s
    # instead (the vehicle 0.16 m lower, a few pixels in this view) differs in 0.039 % of the
    # view's pixels: at most 0.01 % may differ by more than 1/8 of the range.
    assert np.mean(difference > 0.125) < 1e-4, np.mean(difference > 0.125)
    # Not blank: the path's and vehicle's blue and the gate's orange are in the view, and the
    # plots drew their lines.
    scene = got[view_rows, view_cols]
    blue = np.all(np.abs(scene - [0x1f / 255, 0x77 / 255, 0xb4 / 255]) < 0.1, axis=2)
    orange = np.all(np.abs(scene - [1.0, 0x8c / 255, 0x1a / 255]) < 0.25, axis=2)
    assert blue.sum() > 0 and orange.sum() > 50, (blue.sum(), orange.sum())  # a 1-px path line
    plots = got[view_rows, WINDOW[0] - 480:]
    green = np.all(np.abs(plots - [0x2c / 255, 0xa0 / 255, 0x2c / 255]) < 0.1, axis=2)
    assert green.sum() > 100  # z climbing to 1 m, and rotor 2's speed


def test_a_fleet_gets_one_vehicle_each(tmp_path):
    out = tmp_path / "fleet"
    subprocess.run([CLI, "run", str(SOURCE / "config/experiments/crossing_downwash.yaml"),
                    "--out", str(out), "--duration", "1"], check=True, capture_output=True)
    summary = json.loads((out / "fleet_summary.json").read_text())
    data = view.run_data(str(out))
    assert [v["name"] for v in data["vehicles"]] == [v["name"] for v in summary["vehicles"]]
    for v in data["vehicles"]:
        log = dronetwin.read_log(str(out / v["name"] / "log.csv"))
        assert v["p"][-1] == pytest.approx([log["x"][-1], log["y"][-1], log["z"][-1]], abs=5e-7)


def test_the_server_serves_the_page(run):
    proc = subprocess.Popen([CLI, "view", str(run), "--port", "0"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        url = re.search(r"http://127\.0\.0\.1:\d+/", line).group(0)
        with urllib.request.urlopen(url, timeout=30) as r:
            body = r.read().decode()
        assert 'id="run-data"' in body and "three" in body.lower()
        with pytest.raises(urllib.error.HTTPError):
            urllib.request.urlopen(url + "log.csv", timeout=30)
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def test_bad_input_is_refused(run, page_path, tmp_path):
    before = page_path.read_bytes()
    out = subprocess.run([CLI, "view", str(run), "--out", str(page_path)], capture_output=True,
                         text=True)
    assert out.returncode == 2 and "already exists" in out.stderr
    assert page_path.read_bytes() == before
    out = subprocess.run([CLI, "view", str(tmp_path / "nothing")], capture_output=True, text=True)
    assert out.returncode == 2 and "not a folder" in out.stderr
    empty = tmp_path / "empty"
    empty.mkdir()
    out = subprocess.run([CLI, "view", str(empty), "--out", str(tmp_path / "p.html")],
                         capture_output=True, text=True)
    assert out.returncode == 2 and "log.csv" in out.stderr and not (tmp_path / "p.html").exists()
    out = subprocess.run([CLI, "view", str(run), "--out", str(tmp_path / "no" / "p.html")],
                         capture_output=True, text=True)
    assert out.returncode == 2 and "does not exist" in out.stderr
    with pytest.raises(view.ViewError, match="max-frames"):
        view.run_data(str(run), max_frames=1)


def test_rl_episodes_play_together_on_the_longest_episodes_clock(tmp_path):
    # Three racing episodes of the shipped CTBR policy, recorded by `dronetwin evaluate`: they
    # finish at different times, and the timeline runs to the end of the longest.
    out = tmp_path / "episodes"
    subprocess.run([CLI, "evaluate", str(SOURCE / "models/policies/racing_ctbr.dtpolicy"), "--config",
                    str(SOURCE / "config/training/racing_ctbr.yaml"), "--episodes", "3", "--record",
                    str(out), "--quiet"], check=True, capture_output=True, timeout=300)
    rows = [len(dronetwin.read_log(str(out / f"episode_{i:03d}" / "log.csv"))["t"]) for i in range(3)]
    assert len(set(rows)) > 1
    page = tmp_path / "episodes.html"
    assert view.main([str(out), "--out", str(page)]) == 0
    data = json.loads(re.search(r'id="run-data">(.*?)</script>', page.read_text(), re.S).group(1))
    assert [len(v["t"]) for v in data["vehicles"]] == rows
    track = dronetwin.load_track(str(SOURCE / "config/tracks/circuit.yaml"))
    assert [g["name"] for g in data["scene"]["gates"]] == track.gate_names
    t_end = (max(rows) - 1) * 0.01
    result = chromium(f"file://{page}?t={t_end:.2f}", tmp_path, "--dump-dom")
    assert result.returncode == 0, result.stderr[-3000:]
    status = status_of(result.stdout)
    assert status["ready"] == "1" and status["errors"] == "0", result.stdout
    assert status["frames"] == str(max(rows)) and status["frame"] == str(max(rows))
    assert status["time"] == f"{t_end:.3f}"
