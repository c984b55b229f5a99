"""The world from Python (dronetwin.load_track, dronetwin.cast_rays): numpy rays in, distances and
what was hit out, the same as C++; bad arrays and rays named."""

import math

import numpy as np
import pytest

import dronetwin as dt
from conftest import source_path


def circuit():
    return dt.load_track(source_path("config", "tracks", "circuit.yaml"))


def test_rays_hit_the_ground_and_the_gate_bars():
    track = circuit()
    assert track.num_gates == len(track.gate_names) >= 7
    assert track.obstacles == []
    # Straight down from 2 m, and tilted by 0.3 rad: h and h / cos(0.3) to the ground.
    origins = np.array([[0.3, 0.2, 2.0], [0.3, 0.2, 2.0], [0.3, 0.2, 2.0]])
    directions = np.array([[0.0, 0.0, -1.0], [math.sin(0.3), 0.0, -math.cos(0.3)], [0.0, 0.0, 1.0]])
    distance, kind, index = dt.cast_rays(track, origins, directions, 50.0)
    assert distance.shape == (3,) and kind.dtype == np.uint8 and index.dtype == np.int32
    assert distance[0] == pytest.approx(2.0, abs=1e-14)
    assert distance[1] == pytest.approx(2.0 / math.cos(0.3), abs=1e-14)
    assert list(kind) == [1, 1, 0] and list(index) == [-1, -1, -1]
    assert math.isinf(distance[2])


def test_bad_arrays_and_rays_are_named():
    track = circuit()
    good = np.zeros((2, 3)) + [0.0, 0.0, 1.0]
    with pytest.raises(TypeError, match="origins: expected a float64 numpy array"):
        dt.cast_rays(track, good.astype(np.float32), good, 10.0)
    with pytest.raises(ValueError, match=r"directions: expected shape \(N, 3\)"):
        dt.cast_rays(track, good, np.zeros((2, 2)), 10.0)
    with pytest.raises(ValueError, match="2 origins but 1 directions"):
        dt.cast_rays(track, good, good[:1], 10.0)
    with pytest.raises(ValueError, match="ray 1: direction: expected a unit vector"):
        dt.cast_rays(track, good, np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 2.0]]), 10.0)
    with pytest.raises(ValueError, match="max_range_m: expected a positive number"):
        dt.cast_rays(track, good, good, -1.0)
