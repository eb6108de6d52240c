"""The isolated-sample test (T3): shot in chunks, and only counted when a run
stopped at its time limit (shooting from hundreds of thousands of isolated
samples took minutes after the limit)."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
import trimesh
from rdmesh._tol import SHOT_ATOL
from rdmesh.sampling.roots import crossings_along_segments
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


def _sphere_and_plate():
    """A closed mesh of two parts: an icosphere and a plate 1e-3 thick beside it."""
    ball = trimesh.creation.icosphere(subdivisions=2)
    plate = trimesh.creation.box(extents=(0.8, 0.8, 1e-3))
    plate.apply_translation((0.0, 0.0, 1.5))
    both = trimesh.util.concatenate([ball, plate])
    return rdmesh.MeshSurface(both, feature_angle=None), both


def test_shots_cross_a_mesh_exactly():
    """On a mesh input the shots' crossings are the faces they meet (checked
    against every face), the thin plate's included; a shot through a vertex
    falls back to the sampled search."""
    surface, mesh = _sphere_and_plate()
    rng = np.random.default_rng(5)
    start = rng.normal(size=(200, 3)) * 0.3
    d = rng.normal(size=(200, 3))
    d[:100, 2] = np.abs(d[:100, 2]) * 4.0  # towards the plate
    d /= np.linalg.norm(d, axis=1)[:, None]
    length = np.full(200, 3.0)
    hit, point = _shots(surface, start, d, length)
    assert np.all(np.diff(hit) >= 0)
    tri = mesh.vertices[mesh.faces]
    for k in range(200):
        mine = np.sort(np.einsum("ij,j->i", point[hit == k] - start[k], d[k]))
        np.testing.assert_allclose(mine, _ray_hits(tri, start[k], d[k], length[k]), atol=1e-9)
        assert np.all(np.diff(np.einsum("ij,j->i", point[hit == k] - start[k], d[k])) > 0)
    assert len(np.unique(hit[point[:, 2] > 1.4])) > 10  # shots through the plate
    # From the centre through a vertex (2 v is exact: the segment holds v).
    o, u, far = np.zeros((1, 3)), np.asarray(mesh.vertices[:1]), 2.0
    assert surface.exact_crossings(np.stack([o, o + far * u], axis=1))[-1][0]  # unsure
    hit, point = _shots(surface, o, u, np.array([far]))
    np.testing.assert_allclose(point, mesh.vertices[:1], atol=1e-6)


def _shots(surface, start, d, length):
    """The shots' crossings as the isolated-sample test searches them."""
    return crossings_along_segments(
        surface, start, d, length, topology_tests.SHOT_SAMPLES, SHOT_ATOL * surface.radius
    )


def _ray_hits(tri, o, d, length):
    """Distances along ``o + t d`` (``0 <= t <= length``) of its hits with the
    triangles ``(m, 3, 3)`` (Moller-Trumbore, every triangle)."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    s = o - tri[:, 0]
    u = np.einsum("ij,ij->i", s, p) / det
    q = np.cross(s, e1)
    v = (q @ d) / det
    t = np.einsum("ij,ij->i", e2, q) / det
    ok = (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= length)
    return np.sort(t[ok])


def _sampled(surface):
    """``surface`` without its exact crossings (the sampled search)."""
    import copy

    out = copy.copy(surface)
    out.exact_crossings = None
    return out


def test_isolated_samples_of_a_mesh_get_points_of_their_cells():
    """Samples inside an icosphere mesh without faces: the exact shots give
    each a point on the mesh in its own Voronoi cell, for at least every
    sample the sampled search gives one."""
    from scipy.spatial import cKDTree

    vertices, tri, n = _samples_and_faces()
    surface, mesh = _sphere_and_plate()
    exact = topology_tests.isolated_test(surface, vertices, tri)
    sampled = topology_tests.isolated_test(_sampled(surface), vertices, tri)
    assert exact.count == sampled.count == len(vertices) - n
    assert len(exact.centres) >= len(sampled.centres) > 0
    assert len(exact.stuck) <= len(sampled.stuck)
    on = rdmesh.core.MeshDistance(mesh.vertices, mesh.faces, side=False).query(exact.centres)[0]
    assert on.max() < 1e-9
    d, owner = cKDTree(vertices).query(exact.centres)
    np.testing.assert_allclose(d, exact.radii, rtol=1e-9)
    assert set(owner) <= set(range(n, len(vertices)))
