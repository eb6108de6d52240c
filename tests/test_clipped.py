"""Surfaces that leave the bounding sphere: topology="manifold-with-boundary"."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
import trimesh
from clipped_surfaces import GYROID, cylinder, plane, torus_off_centre
from meshcheck import boundary_edges
from rdmesh.cli import main
from rdmesh.sampling.boundary import boundary_curve
from rdmesh.topology.complex import boundary_loops


def _on_sphere(m: rdmesh.SurfaceMesh, centre, radius) -> np.ndarray:
    r = np.linalg.norm(m.vertices - np.asarray(centre, float), axis=1)
    return np.abs(r - radius) <= 1e-9 * radius


def _check_clipped(m, f, centre, radius, angle_bound=30.0):
    """What every clipped mesh satisfies: a manifold with boundary whose
    boundary vertices lie on the sphere and on the surface, every boundary
    edge joining consecutive protecting balls (the feature check); the angle
    bound on every triangle without a ball centre, and (measured, not
    proven) at least 20 degrees on those with one."""
    assert m.complete
    assert m.is_manifold_with_boundary()
    assert not m.is_closed_manifold()
    _, bv = boundary_edges(m.faces)
    assert len(bv) > 0
    assert _on_sphere(m, centre, radius)[bv].all()
    assert np.abs(f(m.vertices[bv])).max() <= 1e-9 * radius
    # Every vertex inside the ball (to rounding) and on the surface.
    r = np.linalg.norm(m.vertices - np.asarray(centre, float), axis=1)
    assert r.max() <= radius * (1 + 1e-12)
    assert np.abs(f(m.vertices)).max() <= 1e-6 * radius
    assert m.features is not None and m.features.held
    at_ball = (m.weights > 0)[m.faces].any(axis=1)
    assert m.angles[~at_ball].min() >= angle_bound - 1e-9
    assert m.angles[at_ball].min() >= min(angle_bound, 20.0)
    # The boundary is made of the protected curves' edges only.
    edges, _ = boundary_edges(m.faces)
    assert len(edges) == m.features.edges
    rep = m.report
    assert rep["certified"] is False
    assert m.topology_certified is False
    assert rep["boundary"]["loops_match"] is True
    assert rep["boundary"]["euler_consistent"] is True


@pytest.fixture(scope="module")
def disk():
    s = rdmesh.ImplicitSurface(plane, ((0, 0, 0), 1.0))
    return s, rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=0.1)


def test_plane_through_the_sphere_is_a_disk(disk):
    s, m = disk
    _check_clipped(m, plane, (0, 0, 0), 1.0)
    topo = m.topology()
    assert topo["components"] == 1
    assert topo["euler"] == [1]
    assert topo["boundary_loops"] == [1]
    assert topo["manifold_with_boundary"] is True
    # The boundary polygon is inscribed in the circle: a little shorter.
    edges, _ = boundary_edges(m.faces)
    length = np.linalg.norm(m.vertices[edges[:, 0]] - m.vertices[edges[:, 1]], axis=1).sum()
    d = 0.3 / np.sqrt(1.01)
    circle = 2 * np.pi * np.sqrt(1 - d * d)
    assert circle * 0.995 < length <= circle
    # Boundary edges no longer than twice the size bound (chords of the curve
    # samples, at most the bound apart along it).
    edge_len = np.linalg.norm(m.vertices[edges[:, 0]] - m.vertices[edges[:, 1]], axis=1)
    assert edge_len.max() <= 0.1 + 1e-9


def test_report_and_summary_say_boundary_and_not_certified(disk):
    _, m = disk
    rep = m.report
    assert rep["boundary_loops"] == [1]
    assert rep["boundary"]["curve_loops"] == 1
    assert "leaves the bounding sphere" in rep["statement"]
    assert "nothing is certified" in rep["statement"]
    text = m.summary()
    assert "boundary loops 1" in text
    assert "NOT certified" in text


def test_cylinder_longer_than_the_domain_is_an_annulus():
    s = rdmesh.ImplicitSurface(cylinder, ((0, 0, 0), 1.0))
    m = rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=0.08)
    _check_clipped(m, cylinder, (0, 0, 0), 1.0)
    topo = m.topology()
    assert (topo["components"], topo["euler"], topo["boundary_loops"]) == (1, [0], [2])
    # Two circles of radius 0.5 at z = +-sqrt(0.75).
    _, bv = boundary_edges(m.faces)
    z = m.vertices[bv, 2]
    assert np.allclose(np.abs(z), np.sqrt(0.75), atol=1e-9)
    assert (z > 0).any() and (z < 0).any()


def test_torus_cut_by_the_sphere_is_an_annulus():
    s = rdmesh.ImplicitSurface(torus_off_centre, ((0, 0, 0), 1.0))
    m = rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=0.05)
    _check_clipped(m, torus_off_centre, (0, 0, 0), 1.0)
    topo = m.topology()
    assert (topo["components"], topo["euler"], topo["boundary_loops"]) == (1, [0], [2])


def test_gyroid_in_a_sphere_quick():
    s = rdmesh.ImplicitSurface.from_expression(GYROID, ((0, 0, 0), 2.0))
    m = rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=0.2)
    _check_clipped(m, s.f, (0, 0, 0), 2.0)
    topo = m.topology()
    assert sum(topo["boundary_loops"]) >= 1
    # chi = 2 - 2g - b per component with a whole genus.
    for chi, b in zip(topo["euler"], topo["boundary_loops"], strict=True):
        assert (2 - chi - b) % 2 == 0 and 2 - chi - b >= 0


@pytest.mark.slow
def test_gyroid_in_a_sphere_default_bounds():
    """The case of the issue: the default size bound (R / 20)."""
    s = rdmesh.ImplicitSurface.from_expression(GYROID, ((0, 0, 0), 2.0))
    m = rdmesh.mesh_surface(s, topology="manifold-with-boundary")
    _check_clipped(m, s.f, (0, 0, 0), 2.0)


def test_same_seed_same_mesh():
    s = rdmesh.ImplicitSurface(cylinder, ((0, 0, 0), 1.0))
    a = rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=0.15, seed=3)
    b = rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=0.15, seed=3)
    assert np.array_equal(a.vertices, b.vertices)
    assert np.array_equal(a.faces, b.faces)


def test_distance_bound_tightens_the_curve_sampling():
    s = rdmesh.ImplicitSurface(cylinder, ((0, 0, 0), 1.0))
    loose = boundary_curve(s, 0.3)
    tight = boundary_curve(s, 0.3, distance=1e-3)
    assert loose.n_loops == tight.n_loops == 2
    # Circles of radius 0.5: a chord of length L bulges L^2 / (8 * 0.5).
    assert len(tight.points) > len(loose.points)
    step = np.linalg.norm(np.diff(tight.points[tight.loop == 0], axis=0), axis=1)
    assert (step**2 / 4.0).max() <= 1e-3 * 1.1


@pytest.mark.parametrize("topology", ["manifold", "non-manifold"])
def test_other_topologies_refuse_a_clipped_surface(topology):
    s = rdmesh.ImplicitSurface(plane, ((0, 0, 0), 1.0))
    with pytest.raises(rdmesh.BoundingSphereError, match="manifold-with-boundary"):
        rdmesh.mesh_surface(s, topology=topology, radius_bound=0.1)


def test_topological_ball_and_certify_refuse_manifold_with_boundary():
    s = rdmesh.ImplicitSurface.from_expression("z - 0.3", ((0, 0, 0), 1.0))
    with pytest.raises(ValueError, match="not supported"):
        rdmesh.mesh_surface(s, topology="manifold-with-boundary", method="topological-ball")
    with pytest.raises(ValueError, match="certify=True is not available"):
        rdmesh.mesh_surface(s, topology="manifold-with-boundary", certify=True)


def test_boundary_loops_of_small_meshes():
    one = np.array([[0, 1, 2]])
    assert boundary_loops(one, 3) == [1]
    two = np.array([[0, 1, 2], [3, 4, 5]])
    assert boundary_loops(two, 6) == [1, 1]
    # A closed tetrahedron has none.
    tet = np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]])
    assert boundary_loops(tet, 4) == [0]


def test_cli_writes_a_mesh_with_boundary(tmp_path, capsys):
    out = tmp_path / "disk.ply"
    code = main(
        [
            "mesh",
            "z - 0.3",
            "--bound",
            "1",
            "--radius",
            "0.15",
            "--topology",
            "manifold-with-boundary",
            "-o",
            str(out),
        ]
    )
    assert code == 0
    assert "boundary loops 1" in capsys.readouterr().out
    tm = trimesh.load(out, process=False)
    uniq, counts = np.unique(np.sort(tm.edges, axis=1), axis=0, return_counts=True)
    assert (counts == 1).any() and counts.max() == 2
    assert tm.euler_number == 1
    bv = np.unique(uniq[counts == 1])
    r = np.linalg.norm(tm.vertices[bv], axis=1)
    assert np.abs(r - 1.0).max() <= 1e-6


def test_boundary_follows_the_curve_within_the_distance_bound():
    """Cylinder of radius 0.5: the boundary circles are bent enough that the
    distance bound, not the size bound, sets the boundary's chords."""
    s = rdmesh.ImplicitSurface(cylinder, ((0, 0, 0), 1.0))
    bound = 2e-3
    m = rdmesh.mesh_surface(
        s, topology="manifold-with-boundary", radius_bound=0.15, distance_bound=bound
    )
    _check_clipped(m, cylinder, (0, 0, 0), 1.0)
    edges, _ = boundary_edges(m.faces)
    mid = 0.5 * (m.vertices[edges[:, 0]] + m.vertices[edges[:, 1]])
    # The curve point nearest each midpoint: on the same circle z = const.
    z = np.sign(mid[:, 2]) * np.sqrt(0.75)
    rho = np.hypot(mid[:, 0], mid[:, 1])
    gap = np.hypot(0.5 - rho, mid[:, 2] - z)
    assert gap.max() <= bound


def test_closed_surface_with_this_topology_reports_no_boundary():
    s = rdmesh.ImplicitSurface(
        lambda p: np.einsum("ij,ij->i", p, p) - 0.49, ((0, 0, 0), 1.0), name="sphere"
    )
    m = rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=0.15)
    assert m.is_closed_manifold()
    assert not m.is_manifold_with_boundary()
    assert m.topology()["boundary_loops"] == [0]
    assert m.report["boundary"] is None
    assert "leaves the bounding sphere" not in m.report["statement"]


def test_sizing_field_sets_the_boundary_spacing():
    """A sizing field that grows with |z|: the boundary circles at
    |z| = sqrt(0.75) get chords no longer than the field there."""
    s = rdmesh.ImplicitSurface(cylinder, ((0, 0, 0), 1.0))

    def field(x):
        return 0.03 + 0.1 * np.abs(x[:, 2])

    m = rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=field)
    _check_clipped(m, cylinder, (0, 0, 0), 1.0)
    edges, _ = boundary_edges(m.faces)
    a, b = m.vertices[edges[:, 0]], m.vertices[edges[:, 1]]
    length = np.linalg.norm(a - b, axis=1)
    assert (length <= field(0.5 * (a + b)) * (1 + 1e-6)).all()
    # Not the field's smallest value on the sphere (0.03): the local one.
    assert length.max() > 0.05


@pytest.mark.parametrize("h", [0.5, 0.1, 0.02])
def test_sphere_grid_is_a_closed_triangulation(h):
    from rdmesh.sampling.boundary import sphere_grid

    u, ends, tri_edges = sphere_grid(h)
    np.testing.assert_allclose(np.linalg.norm(u, axis=1), 1.0, atol=1e-12)
    # Every edge in exactly two triangles, each triangle spans three points,
    # and V - E + T = 2: a closed triangulation of the sphere.
    assert np.all(np.bincount(tri_edges.ravel(), minlength=len(ends)) == 2)
    corners = np.sort(ends[tri_edges].reshape(len(tri_edges), 6), axis=1)
    assert np.all((corners[:, ::2] == corners[:, 1::2]).all(axis=1))
    assert len(np.unique(corners[:, ::2], axis=1)[0]) == 3
    assert len(u) - len(ends) + len(tri_edges) == 2
    assert np.linalg.norm(u[ends[:, 0]] - u[ends[:, 1]], axis=1).max() <= 1.5 * h


def test_arc_root_on_a_grid_point_is_that_point():
    """f rounds to 0 at an arc's end (the curve runs through a grid point):
    the crossing is that end, never NaN."""
    from rdmesh.sampling.boundary import _arc_roots

    s = rdmesh.ImplicitSurface(lambda p: p[:, 2] - 0.6, ((0, 0, 0), 1.0))
    p = np.array([[0.8, 0.0, 0.6], [0.0, 0.0, 1.0]])
    q = np.array([[0.0, 0.8, 0.6], [1.0, 0.0, 0.0]])
    x = _arc_roots(s, p, q)
    assert np.all(np.isfinite(x))
    # The first arc runs along the curve: the crossing is one of its ends.
    assert min(np.abs(x[0] - p[0]).max(), np.abs(x[0] - q[0]).max()) < 1e-12
    np.testing.assert_allclose(s(x), 0.0, atol=1e-9)
