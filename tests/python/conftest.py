"""Shared fixtures of the Python test suite (run by CTest; see tests/CMakeLists.txt).

CTest sets PYTHONPATH to <build>/python (the package with its compiled extension),
DRONETWIN_SOURCE_DIR to the source tree and DRONETWIN_CLI to the built `dronetwin` command.
"""

import os

import pytest

import dronetwin as dt

SOURCE_DIR = os.environ.get("DRONETWIN_SOURCE_DIR") or os.path.abspath(
    os.path.join(os.path.dirname(__file__), "..", ".."))


def source_path(*parts):
    return os.path.join(SOURCE_DIR, *parts)


@pytest.fixture(scope="session")
def qdrone2():
    return dt.load_model(source_path("models", "qdrone2.yaml"))


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("DRONETWIN_CLI")
    if not path or not os.path.exists(path):
        pytest.skip("DRONETWIN_CLI not set (run through CTest)")
    return path


def flying_se3():
    """Gains and options of config/controllers/se3.yaml: Eq. 3.29 with a faster attitude loop,
    the gravity term, a 0.5 rad tilt cone and non-negative thrust."""
    options = dt.Se3Options()
    options.gravity_compensation = True
    options.max_tilt_rad = 0.5
    options.nonnegative_thrust = True
    gains = dt.Se3Gains.thesis()
    gains.attitude_d = [0.8, 0.8, 0.05]
    return gains, options


def hovering(model, cfg):
    """A simulator at rest 2 m up, rotors at hover speed and the hover speeds as reference."""
    sim = dt.Simulator(model, cfg)
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, 2.0]), model.hover_speeds_rad_s())
    sim.set_rotor_speed_reference(model.hover_speeds_rad_s())
    return sim
