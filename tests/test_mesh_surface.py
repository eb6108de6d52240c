"""rdmesh.mesh_surface on the public test surfaces and a few user surfaces.

Every property is recomputed from the output arrays (see meshcheck.py), not
read back from rdmesh's own reports.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import rdmesh
import trimesh
from conftest import expected_euler
from meshcheck import (
    assert_good_mesh,
    circumcentre_ref,
    closed_manifold_problems,
    distance_to_surface,
    euler_per_component,
    face_components,
    face_normals,
    numeric_gradient,
    restricted_delaunay_reference,
    triangle_angles_deg,
    triple_keys,
)
from rdmesh.surfaces import SURFACES
from scipy.spatial import cKDTree

# -- every public surface, meshed once (conftest.public_mesh) ---------------


def test_closed_oriented_manifold(public_mesh):
    m = public_mesh.mesh
    assert closed_manifold_problems(m.faces, len(m.vertices)) == []
    tm = trimesh.Trimesh(m.vertices, m.faces, process=False)
    assert tm.is_watertight
    assert tm.is_winding_consistent
    # Every reported vertex is used by some face.
    assert np.array_equal(np.unique(m.faces), np.arange(len(m.vertices)))


def test_components_and_euler(public_mesh):
    m = public_mesh.mesh
    info = SURFACES[public_mesh.name]
    count, _ = face_components(m.faces, len(m.vertices))
    assert count == info.components
    assert euler_per_component(m.faces, len(m.vertices)) == expected_euler(public_mesh.name)
    # The library's own report agrees with the independent count.
    topo = m.topology()
    assert topo["components"] == info.components
    assert sorted(topo["euler"], reverse=True) == expected_euler(public_mesh.name)
    assert topo["closed_manifold"] is True
    assert m.is_closed_manifold()


def test_min_angle(public_mesh):
    m = public_mesh.mesh
    angles = triangle_angles_deg(m.vertices[m.faces])
    assert np.allclose(angles.sum(axis=1), 180.0)
    assert angles.min() >= 30.0 - 1e-9
    # The reported angles are the arccos ones.
    assert np.allclose(m.angles, angles.min(axis=1), atol=1e-6)
    assert m.min_angle >= 30.0 - 1e-9


def test_ball_radius_bound(public_mesh):
    m = public_mesh.mesh
    d = np.linalg.norm(m.facet_centres[:, None, :] - m.vertices[m.faces], axis=2)
    assert d.max() <= public_mesh.radius_bound * (1 + 1e-9)
    # The surface centre is on the dual Voronoi edge (equidistant from the
    # three corners), so any corner gives the ball radius.
    assert np.allclose(d, d[:, :1], rtol=1e-7, atol=0)
    assert np.allclose(m.ball_radii, d[:, 0], rtol=1e-12)


def test_vertices_and_centres_on_surface(public_mesh):
    m, s = public_mesh.mesh, public_mesh.surface
    tol = 1e-6 * s.radius
    assert distance_to_surface(public_mesh.f, public_mesh.grad, m.vertices).max() <= tol
    assert distance_to_surface(public_mesh.f, public_mesh.grad, m.facet_centres).max() <= tol
    # Everything inside the bounding sphere.
    assert np.linalg.norm(m.vertices - s.centre, axis=1).max() < s.radius


def test_surface_delaunay_balls_are_empty(public_mesh):
    """No vertex lies inside a face's surface Delaunay ball (beyond rounding)."""
    m = public_mesh.mesh
    corner_d = np.linalg.norm(m.facet_centres[:, None, :] - m.vertices[m.faces], axis=2)
    r = corner_d.min(axis=1)
    dist, _ = cKDTree(m.vertices).query(m.facet_centres)
    # The nearest vertex is (tied with) a corner: none is strictly inside.
    assert np.all(dist >= r * (1 - 1e-7))


def test_outward_orientation(public_mesh):
    m = public_mesh.mesh
    n = face_normals(m.vertices, m.faces)
    g = public_mesh.grad(m.facet_centres)
    cos = np.einsum("ij,ij->i", n, g) / (np.linalg.norm(n, axis=1) * np.linalg.norm(g, axis=1))
    assert np.all(cos > 0)
    # Small facets approximate the tangent plane: normals nearly agree.
    assert np.median(cos) > 0.95
    count, label = face_components(m.faces, len(m.vertices))
    for k in range(count):
        part = trimesh.Trimesh(m.vertices, m.faces[label == k], process=False)
        assert part.volume > 0


def test_faces_are_the_restricted_delaunay_triangulation(public_mesh):
    """Recomputed from scratch with scipy's Delaunay: the faces are exactly the
    Delaunay facets of the vertices whose dual Voronoi edge meets the surface,
    and each of those duals crosses it exactly once."""
    m, s = public_mesh.mesh, public_mesh.surface
    assert m.stats["samples"] == len(m.vertices)  # no sample left out
    keys, changes = restricted_delaunay_reference(public_mesh.f, m.vertices, s.centre, s.radius)
    faces = triple_keys(m.faces, len(m.vertices))
    restricted = keys[changes > 0]
    assert len(np.setdiff1d(faces, restricted)) == 0
    assert len(np.setdiff1d(restricted, faces)) == 0
    assert np.all(changes[np.isin(keys, faces)] == 1)


def test_run_complete(public_mesh):
    m = public_mesh.mesh
    assert m.complete
    assert len(m.unresolved) == 0
    assert m.stats["unresolved"] == 0
    assert m.stats["vertices"] == len(m.vertices)
    assert m.stats["faces"] == len(m.faces)


# -- specific facts ------------------------------------------------------------


def test_unit_sphere_area_and_volume(sphere_case):
    tm = sphere_case.mesh.to_trimesh()
    assert len(tm.vertices) == len(sphere_case.mesh.vertices)  # no merging
    # An inscribed polyhedron has less area and volume than the sphere.
    assert 0.99 * 4 * math.pi < tm.area < 4 * math.pi
    assert 0.98 * 4 / 3 * math.pi < tm.volume < 4 / 3 * math.pi
    assert tm.euler_number == 2


def test_torus_with_centre_outside(torus_case):
    s = torus_case.surface
    assert s.f(s.centre[None, :])[0] > 0  # the bounding-sphere centre is outside
    assert_good_mesh(
        torus_case.mesh, torus_case.f, torus_case.grad, s.radius, sizing=0.04, euler=[0]
    )


def test_angle_bound_20():
    s = SURFACES["torus"].make()
    m = rdmesh.mesh_surface(s, angle_bound=20.0, radius_bound=0.04)
    assert_good_mesh(m, s.f, s.gradient, s.radius, angle_bound=20.0, sizing=0.04, euler=[0])


def test_callable_sizing_field():
    s = SURFACES["sphere"].make()

    def sizing(p):  # 0.05 for x > 0, 0.1 for x < 0, smooth in between
        return 0.075 - 0.025 * np.tanh(p[:, 0] / 0.1)

    m = rdmesh.mesh_surface(s, radius_bound=sizing)
    assert_good_mesh(m, s.f, s.gradient, s.radius, sizing=sizing, euler=[2])
    # The finer half has clearly more vertices.
    x = m.vertices[:, 0]
    assert np.sum(x > 0.3) > 2 * np.sum(x < -0.3)


def test_distance_bound(sphere_case):
    s = SURFACES["sphere"].make()
    bound = 0.002
    # Without the bound some facet is farther than that from the surface...
    base = sphere_case.mesh
    base_dist = np.linalg.norm(
        circumcentre_ref(base.vertices[base.faces]) - base.facet_centres, axis=1
    )
    assert base_dist.max() > bound
    # ...with it, none is.
    m = rdmesh.mesh_surface(s, radius_bound=0.1, distance_bound=bound)
    assert_good_mesh(m, s.f, s.gradient, s.radius, sizing=0.1, distance_bound=bound, euler=[2])


def test_same_seed_same_mesh():
    s = SURFACES["blob_line"].make()
    a = rdmesh.mesh_surface(s, radius_bound=0.1, seed=7)
    b = rdmesh.mesh_surface(SURFACES["blob_line"].make(), radius_bound=0.1, seed=7)
    assert np.array_equal(a.vertices, b.vertices)
    assert np.array_equal(a.faces, b.faces)
    assert np.array_equal(a.facet_centres, b.facet_centres)


@pytest.mark.parametrize("seed", [1, 12345])
def test_other_seeds_still_correct(torus_case, seed):
    s = SURFACES["torus"].make()
    m = rdmesh.mesh_surface(s, radius_bound=0.04, seed=seed)
    assert_good_mesh(m, s.f, s.gradient, s.radius, sizing=0.04, euler=[0])
    # The seed is used: the sample differs from seed 0's.
    assert len(m.vertices) != len(torus_case.mesh.vertices) or not np.array_equal(
        m.vertices, torus_case.mesh.vertices
    )


@pytest.mark.parametrize("topology", ["non-manifold", "manifold-with-boundary"])
def test_other_topology_modes_on_smooth_surface(topology):
    s = SURFACES["sphere"].make()
    m = rdmesh.mesh_surface(s, radius_bound=0.1, topology=topology)
    assert_good_mesh(m, s.f, s.gradient, s.radius, sizing=0.1, euler=[2])


def test_off_centre_bounding_sphere_and_numeric_gradient():
    """A user surface without gradient, bounding sphere not centred on it."""
    centre = np.array([0.3, -0.2, 0.1])

    def f(p):
        q = p - centre
        return np.einsum("ij,ij->i", q, q) - 0.64

    s = rdmesh.ImplicitSurface(f, ((0.5, 0.0, 0.2), 1.3), name="shifted sphere")
    m = rdmesh.mesh_surface(s, radius_bound=0.06)
    assert_good_mesh(m, f, lambda p: numeric_gradient(f, p), 1.3, sizing=0.06, euler=[2])
    r = np.linalg.norm(m.vertices - centre, axis=1)
    assert np.allclose(r, 0.8, atol=1e-7)


def _union_of_spheres(small_radius: float = 0.15, gap: float = 0.5):
    c = np.array([1.0 + gap + small_radius, 0.0, 0.0])

    def f(p):
        big = np.einsum("ij,ij->i", p, p) - 1.0
        q = p - c
        return np.minimum(big, np.einsum("ij,ij->i", q, q) - small_radius**2)

    return rdmesh.ImplicitSurface(f, ((0.4, 0.0, 0.0), 2.0), name="sphere + small sphere"), f, c


@pytest.mark.parametrize("sizing", ["uniform", "field"])
def test_small_separate_component_is_kept(sizing):
    """A unit sphere and a sphere of radius 0.15 half a unit away: 2 components."""
    rs = 0.15
    s, f, c = _union_of_spheres(rs)
    if sizing == "uniform":
        psi = 0.1
    else:  # below 0.1 * lfs on both spheres

        def psi(p):
            return np.where(np.linalg.norm(p - c, axis=1) < 0.5, 0.1 * rs, 0.1)

    m = rdmesh.mesh_surface(s, radius_bound=psi)
    assert_good_mesh(m, f, lambda p: numeric_gradient(f, p), 2.0, sizing=psi, euler=[2, 2])
    count, label = face_components(m.faces, len(m.vertices))
    assert count == 2
    # One component is the small sphere, the other the big one.
    on_small = np.abs(np.linalg.norm(m.vertices - c, axis=1) - rs) < 1e-6
    on_big = np.abs(np.linalg.norm(m.vertices, axis=1) - 1.0) < 1e-6
    assert np.all(on_small ^ on_big)
    face_small = on_small[m.faces].all(axis=1)
    assert np.all(on_small[m.faces].any(axis=1) == face_small)  # no face spans both
    assert {tuple(np.unique(label[face_small])), tuple(np.unique(label[~face_small]))} == {
        (0,),
        (1,),
    }


def test_evaluations_counted_and_vectorised():
    """stats["evaluations"] counts evaluated points; f always gets (N, 3) arrays."""
    sphere = SURFACES["sphere"].make()
    seen = []

    def f(p):
        seen.append((p.shape, p.dtype))
        return sphere.f(p)

    s = rdmesh.ImplicitSurface(f, sphere.bounding_sphere, gradient=sphere.gradient)
    m = rdmesh.mesh_surface(s, radius_bound=0.1)
    assert m.stats["evaluations"] == s.evaluations
    sizes = [shape[0] for shape, _ in seen]
    assert all(len(shape) == 2 and shape[1] == 3 and dtype == np.float64 for shape, dtype in seen)
    assert min(sizes) > 0  # never called on an empty array
    # Gradient calls are counted too, so f alone accounts for at most that many.
    assert sum(sizes) <= m.stats["evaluations"]
    # Called on large arrays, a limited number of times.
    assert len(seen) < 0.01 * sum(sizes)


@pytest.mark.parametrize("scale", [2.0**-60, 2.0**70])
def test_scaling_f_by_a_power_of_two_changes_nothing(sphere_case, scale):
    """Only signs and ratios of f may matter: no absolute thresholds on f."""
    base = sphere_case.surface

    def f(p):
        return scale * base.f(p)

    def grad(p):
        return scale * base.gradient(p)

    s = rdmesh.ImplicitSurface(f, base.bounding_sphere, gradient=grad)
    m = rdmesh.mesh_surface(s, radius_bound=0.1)
    assert np.array_equal(m.vertices, sphere_case.mesh.vertices)
    assert np.array_equal(m.faces, sphere_case.mesh.faces)


def test_nested_spheres_orientation():
    """A thick shell 0.5 < |p| < 1: two nested components; the inner one's
    outward normals point towards the centre."""

    def f(p):
        q = np.einsum("ij,ij->i", p, p)
        return (q - 1.0) * (q - 0.25)

    def grad(p):
        q = np.einsum("ij,ij->i", p, p)[:, None]
        return 2 * p * (q - 0.25) + 2 * p * (q - 1.0)

    s = rdmesh.ImplicitSurface(f, ((0, 0, 0), 1.5), gradient=grad)
    m = rdmesh.mesh_surface(s, radius_bound=0.025)  # lfs = 0.25 between the spheres
    assert_good_mesh(m, f, grad, 1.5, sizing=0.025, euler=[2, 2])
    r = np.linalg.norm(m.vertices, axis=1)
    inner = r < 0.75
    assert np.allclose(r[inner], 0.5, atol=1e-7) and np.allclose(r[~inner], 1.0, atol=1e-7)
    n = face_normals(m.vertices, m.faces)
    radial = np.einsum("ij,ij->i", n, m.facet_centres)
    face_inner = inner[m.faces[:, 0]]
    assert np.all(radial[face_inner] < 0) and np.all(radial[~face_inner] > 0)
    # Signed volume: shell = outer ball minus inner ball.
    assert m.to_trimesh().volume == pytest.approx(4 / 3 * math.pi * (1 - 0.125), rel=0.02)


def test_surface_through_bounding_sphere_centre():
    """f(c0) = 0 exactly: the sign at the centre is ambiguous."""
    c = np.array([0.5, 0.0, 0.0])

    def f(p):
        q = p - c
        return np.einsum("ij,ij->i", q, q) - 0.25

    s = rdmesh.ImplicitSurface(f, ((0, 0, 0), 1.5), gradient=lambda p: 2 * (p - c))
    assert f(np.zeros((1, 3)))[0] == 0.0
    m = rdmesh.mesh_surface(s, radius_bound=0.04)
    assert_good_mesh(m, f, lambda p: 2 * (p - c), 1.5, sizing=0.04, euler=[2])


def test_generous_bounding_sphere():
    """A bounding sphere ten times larger than the surface."""
    base = SURFACES["sphere"].make()
    s = rdmesh.ImplicitSurface(base.f, ((0.5, -0.5, 1.0), 12.0), gradient=base.gradient)
    m = rdmesh.mesh_surface(s, radius_bound=0.1)
    assert_good_mesh(m, base.f, base.gradient, 1.0, sizing=0.1, euler=[2])


@pytest.mark.parametrize("radius_bound", [0.5, 1.0])
@pytest.mark.parametrize("name", list(SURFACES))
def test_coarse_meshes_are_still_closed_manifolds(name, radius_bound):
    """Far above 0.1 * lfs the topology may differ from the surface's, but
    topology="manifold" still promises a closed 2-manifold meeting every
    criterion (the manifold stage and the isolated-sample rule do that)."""
    s = SURFACES[name].make()
    m = rdmesh.mesh_surface(s, radius_bound=radius_bound)
    assert_good_mesh(m, s.f, s.gradient, s.radius, sizing=radius_bound)


def test_worker_threads_give_the_same_mesh(torus_case):
    """Facets evaluated in two threads: the same mesh as one thread."""
    s = SURFACES["torus"].make()
    two = rdmesh.mesh_surface(s, radius_bound=0.04, workers=2)
    one = torus_case.mesh
    assert np.array_equal(two.vertices, one.vertices)
    assert np.array_equal(two.faces, one.faces)
    assert two.stats["evaluations"] == one.stats["evaluations"]


def test_worker_pool_lives_as_long_as_the_pipeline(monkeypatch):
    """One pool of evaluation threads per run, not one per chunk, and it stops."""
    from rdmesh.refine import pipeline

    pools = []

    class Counted(pipeline.ThreadPoolExecutor):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            pools.append(self)

    monkeypatch.setattr(pipeline, "ThreadPoolExecutor", Counted)
    monkeypatch.setattr(pipeline, "CHUNK", 256)  # several chunks a round
    monkeypatch.setattr(pipeline, "CORE_CHUNK", 256)
    m = rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.07, workers=2)
    assert m.stats["rounds"] >= 2 and m.stats["facets_evaluated"] > 10 * 256
    # The core's job thread and the evaluation pool, both stopped.
    assert [p._max_workers for p in pools] == [1, 2]
    assert all(p._shutdown for p in pools)
