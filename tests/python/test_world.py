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


def pillar_scene():
    return dt.load_track(source_path("tests", "data", "scenes", "pillar_and_crate.yaml"))


def drifting(model):
    """At 1.2 m, 2 m/s along +x, rotors stopped, no gravity: a straight line into the pillar."""
    config = dt.SimConfig()
    env = config.environment
    env.gravity_W_m_s2 = np.zeros(3)
    config.environment = env
    sim = dt.Simulator(model, config)
    state = dt.Simulator.hover_state([0.0, 0.0, 1.2])
    state[3] = 2.0
    sim.reset(state)
    return sim


def test_a_simulator_with_a_scene_stops_at_the_pillar(qdrone2):
    shape = qdrone2.collision_shape
    assert shape.kind == "sphere"
    hub_m = max(np.linalg.norm(r.position_m) for r in qdrone2.rotors)
    assert shape.radius_m == pytest.approx(hub_m + 0.1, rel=1e-15)
    sim = drifting(qdrone2)
    sim.set_scene(pillar_scene())
    result = sim.step(3000)
    assert result.status == dt.StepStatus.COLLIDED
    assert "collided with obstacle 'pillar' (cylinder)" in sim.failure_message
    # Stopped short of the pillar's surface (x = 1.8) by less than one step's travel.
    front = sim.state[0] + shape.radius_m
    assert 1.8 - 0.01 < front <= 1.8
    # Without the scene the same flight passes through.
    free = drifting(qdrone2)
    assert free.step(3000).ok


def test_set_scene_none_clears_the_scene(qdrone2):
    sim = drifting(qdrone2)
    sim.set_scene(pillar_scene())
    sim.set_scene(None)
    assert sim.step(3000).ok
    assert sim.state[0] > 1.8  # past the pillar's face


def test_a_box_from_the_spec_reaches_further(qdrone2):
    spec = qdrone2.spec
    spec.collision = dt.CollisionShape.box([0.5, 0.2, 0.05])
    model = dt.VehicleModel(spec)
    assert model.collision_shape.kind == "box"
    assert list(model.collision_shape.half_size_m) == [0.5, 0.2, 0.05]
    sim = drifting(model)
    sim.set_scene(pillar_scene())
    assert sim.step(3000).status == dt.StepStatus.COLLIDED
    assert 1.8 - 0.01 < sim.state[0] + 0.5 <= 1.8
    assert "collision:" in spec.to_yaml()
    with pytest.raises(ValueError, match="collision.half_size_m: expected three numbers > 0"):
        bad = qdrone2.spec
        bad.collision = dt.CollisionShape.box([0.5, 0.0, 0.05])
        dt.VehicleModel(bad)
