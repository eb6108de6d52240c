"""The isolated-sample test (T3): shot in chunks, and only counted when a run
stopped at its time limit (shooting from hundreds of thousands of isolated
samples took minutes after the limit)."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
import trimesh
from rdmesh.surfaces import SURFACES
from rdmesh.topology import snapshot as snapshot_module
from rdmesh.topology import tests as topology_tests


def _sphere():
    return rdmesh.ImplicitSurface(lambda p: np.linalg.norm(p, axis=1) - 1.0, ((0, 0, 0), 1.5))


def _samples_and_faces():
    """An icosphere's vertices and faces, plus samples just inside the sphere
    with no face (their outward shots cross the sphere within their cells)."""
    s = trimesh.creation.icosphere(subdivisions=2)
    rng = np.random.default_rng(3)
    extra = rng.normal(size=(40, 3))
    extra *= 0.97 / np.linalg.norm(extra, axis=1)[:, None]
    vertices = np.concatenate([s.vertices, extra])
    return vertices, np.asarray(s.faces, np.int64), len(s.vertices)


def test_count_matches_the_shooting_test_and_names_the_samples():
    vertices, tri, n = _samples_and_faces()
    counted = topology_tests.isolated_count(vertices, tri)
    shot = topology_tests.isolated_test(_sphere(), vertices, tri)
    assert counted.count == shot.count == len(vertices) - n
    assert len(counted.centres) == 0
    assert np.array_equal(np.sort(counted.stuck, axis=0), np.sort(vertices[n:], axis=0))
    assert len(shot.centres) > 0  # the shots found points; the count alone has none


def test_count_leaves_out_protecting_balls():
    vertices, tri, n = _samples_and_faces()
    weights = np.zeros(len(vertices))
    weights[n : n + 5] = 0.01
    assert topology_tests.isolated_count(vertices, tri, weights).count == len(vertices) - n - 5
    assert topology_tests.isolated_count(vertices[:n], tri).count == 0


def test_shooting_in_chunks_gives_the_same_points(monkeypatch):
    vertices, tri, _ = _samples_and_faces()
    weights = np.zeros(len(vertices))
    weights[:3] = 0.05
    whole = topology_tests.isolated_test(_sphere(), vertices, tri, weights=weights)
    monkeypatch.setattr(topology_tests, "SHOT_CHUNK", 3)
    monkeypatch.setattr(topology_tests, "BALL_CHUNK", 2)
    chunked = topology_tests.isolated_test(_sphere(), vertices, tri, weights=weights)
    assert whole.count == chunked.count
    assert len(whole.centres) > 0
    assert np.array_equal(whole.centres, chunked.centres)
    assert np.array_equal(whole.radii, chunked.radii)
    assert np.array_equal(whole.stuck, chunked.stuck)


def test_a_run_stopped_by_its_time_limit_counts_without_shooting(monkeypatch):
    def no_shooting(*args, **kwargs):
        raise AssertionError("the isolated test shot rays after the time limit")

    monkeypatch.setattr(snapshot_module, "isolated_test", no_shooting)
    with pytest.raises(rdmesh.BudgetExceeded) as info:
        rdmesh.mesh_surface(SURFACES["torus"].make(), radius_bound=0.04, time_limit=1e-6)
    test = info.value.mesh.report["tests"]["isolated"]
    assert isinstance(test["violations"], int) and test["violations"] >= 0
    assert test["held"] == (test["violations"] == 0)
