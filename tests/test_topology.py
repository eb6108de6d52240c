"""Topological-ball refinement (method="topological-ball") and the topology report.

Mesh properties are recomputed from the output arrays (meshcheck.py); the
report is checked against those independent counts.
"""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from conftest import expected_euler
from meshcheck import (
    assert_good_mesh,
    closed_manifold_problems,
    euler_per_component,
    face_components,
    triangle_angles_deg,
)
from rdmesh._regions import regions
from rdmesh.sampling.critical import critical_points
from rdmesh.sampling.grid import grid_scan
from rdmesh.sampling.probes import Probes, unit_normals
from rdmesh.surfaces import SURFACES
from rdmesh.topology.tests import TESTS, silhouette_test
from scipy.spatial import cKDTree

TB = "topological-ball"


def _check_topology(name: str, mesh: rdmesh.SurfaceMesh) -> None:
    V, F = mesh.vertices, mesh.faces
    assert closed_manifold_problems(F, len(V)) == []
    assert np.array_equal(np.unique(F), np.arange(len(V)))
    count, _ = face_components(F, len(V))
    assert count == SURFACES[name].components
    assert euler_per_component(F, len(V)) == expected_euler(name)
    rep = mesh.report
    # Every test held, but the crossing search and the loop and silhouette
    # tests rest on samples: nothing certifies the topology.
    assert rep["tbp_holds"] is True
    assert rep["certified"] is False and not mesh.topology_certified
    assert all(rep["tests"][k]["held"] is True for k in TESTS)
    levels = {k: rep["tests"][k]["level"] for k in TESTS}
    assert levels["voronoi_edge"] == levels["voronoi_loop"] == levels["silhouette"] == "sampled"
    assert levels["disk"] == levels["isolated"] == "proven"
    assert all(k in rep["statement"] for k, lv in levels.items() if lv == "sampled")
    assert rep["components"] == count
    assert sorted(rep["euler"], reverse=True) == expected_euler(name)
    assert rep["closed_manifold"] is True
    assert rep["unresolved"] == 0 and len(mesh.unresolved) == 0
    assert rep["singular_points"]["count"] == 0
    assert rep["critical_points"]["agrees_with_mesh"] is True


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("name", list(SURFACES))
def test_no_size_bound_gives_right_topology(name, seed):
    """No size bound, no angle bound: only the topological-ball tests refine."""
    s = SURFACES[name].make()
    m = rdmesh.mesh_surface(s, method=TB, radius_bound=None, angle_bound=0, seed=seed)
    _check_topology(name, m)
    assert m.stats["method"] == TB
    # Coarse: far fewer samples than Boissonnat-Oudot's default size needs.
    assert len(m.vertices) < 400


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("name", list(SURFACES))
def test_no_size_bound_with_angle_bound(name, seed):
    s = SURFACES[name].make()
    m = rdmesh.mesh_surface(s, method=TB, radius_bound=None, angle_bound=30, seed=seed)
    _check_topology(name, m)
    assert triangle_angles_deg(m.vertices[m.faces]).min() >= 30.0 - 1e-9
    assert m.min_angle >= 30.0 - 1e-9


def test_size_bound_and_every_guarantee():
    """With criteria, every Boissonnat-Oudot guarantee holds too (independent checks)."""
    s = SURFACES["torus"].make()
    m = rdmesh.mesh_surface(s, method=TB, radius_bound=0.1, distance_bound=0.02, seed=3)
    assert_good_mesh(
        m,
        s.f,
        s.gradient,
        s.radius,
        sizing=0.1,
        euler=expected_euler("torus"),
        distance_bound=0.02,
    )
    _check_topology("torus", m)


def test_thin_features_are_repaired_and_counted():
    """The thin torus needs every kind of repair; the report counts them."""
    rounds = []
    m = rdmesh.mesh_surface(
        SURFACES["thin_torus"].make(),
        method=TB,
        radius_bound=None,
        angle_bound=0,
        progress=rounds.append,
    )
    tests = m.report["tests"]
    # Counted apart from the report: the progress callback's batches per stage.
    per_stage = {}
    for r in rounds:
        per_stage[r["stage"]] = per_stage.get(r["stage"], 0) + r["inserted"]
    for kind in ("voronoi_edge", "voronoi_facet", "silhouette"):
        assert tests[kind]["repaired"] == per_stage[kind] > 0
    assert (
        sum(t["repaired"] for t in tests.values())
        == len(m.vertices) - (m.stats["inserted"]["seeds"])
    )


def test_same_seed_same_mesh():
    s = SURFACES["double_torus"]
    a = rdmesh.mesh_surface(s.make(), method=TB, seed=5)
    b = rdmesh.mesh_surface(s.make(), method=TB, seed=5)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert a.report == b.report


def test_boissonnat_oudot_report(sphere_case):
    """Boissonnat-Oudot results carry the same report, computed on their output."""
    m = sphere_case.mesh
    rep = m.report
    assert rep["method"] == "boissonnat-oudot"
    assert set(rep["tests"]) == set(TESTS)
    assert rep["tbp_holds"] is True
    assert rep["critical_points"] is None
    assert rep["components"] == 1 and rep["euler"] == [2]
    for t in rep["tests"].values():
        assert t["violations"] == 0 and t["basis"] in (
            "exact",
            "sampled",
            "exact given voronoi_edge",
        )
    # The statement carries the data: the probe spacing, and every sampled test.
    assert f"{rep['probes']['spacing']:.3g}" in rep["statement"]
    sampled = [k for k, t in rep["tests"].items() if t["level"] == "sampled"]
    assert sampled and all(k in rep["statement"] for k in sampled)
    assert "held on samples, NOT certified" in m.summary()


def test_boissonnat_oudot_coarse_report_is_honest(monkeypatch):
    """At a coarse size Boissonnat-Oudot gets the thin torus wrong; the report says so."""
    s = SURFACES["thin_torus"].make()
    # 0.8 (not 0.5 any more: the valley search of the crossings gets 0.5 right),
    # with seeds as sparse as the bound (by default they are at most R / 2
    # apart, and the coarse run gets the torus right).
    monkeypatch.setattr("rdmesh.sampling.grid.MAX_SEED_SPACING", np.inf)
    m = rdmesh.mesh_surface(s, radius_bound=0.8, angle_bound=0)
    right = closed_manifold_problems(m.faces, len(m.vertices)) == [] and euler_per_component(
        m.faces, len(m.vertices)
    ) == [0]
    assert not right
    assert m.report["tbp_holds"] is False
    assert "NOT certified" in m.report["statement"]


# -- broken inputs -----------------------------------------------------------


def pinched() -> rdmesh.ImplicitSurface:
    """x^2 + y^2 = z^2 (1 - z^2): two lobes meeting in a double cone at 0 (grad f = 0)."""

    def f(p):
        x, y, z = p.T
        return x * x + y * y - z * z * (1 - z * z)

    def grad(p):
        x, y, z = p.T
        return np.column_stack([2 * x, 2 * y, -2 * z + 4 * z**3])

    return rdmesh.ImplicitSurface(f, ((0, 0, 0), 1.5), gradient=grad, name="pinched")


def crossing_spheres() -> rdmesh.ImplicitSurface:
    """Two overlapping unit spheres as one product: crosses itself along a circle."""
    c = np.array([0.5, 0.0, 0.0])

    def f(p):
        a, b = p - c, p + c
        return (np.einsum("ij,ij->i", a, a) - 1) * (np.einsum("ij,ij->i", b, b) - 1)

    return rdmesh.ImplicitSurface(f, ((0, 0, 0), 2.0), name="crossing spheres")


@pytest.mark.parametrize("method", [TB, "boissonnat-oudot"])
def test_cusp_is_flagged(method, caplog):
    m = rdmesh.mesh_surface(pinched(), method=method, max_vertices=3000)
    rep = m.report
    assert rep["tbp_holds"] is False and not m.topology_certified
    assert rep["singular_points"]["count"] >= 1
    centre = np.array(rep["singular_points"]["regions"][0]["centre"])
    assert np.linalg.norm(centre) < 1e-3
    assert "NOT certified" in rep["statement"] and "singular" in rep["statement"]
    if method == TB:
        # Refinement stopped at the spacing floor next to the cone point.
        assert len(m.unresolved) > 0
        assert np.linalg.norm(m.unresolved, axis=1).max() < 0.05
        assert np.linalg.norm(rep["unresolved_regions"][0]["centre"]) < 0.05
        assert "below the spacing floor" in caplog.text


def test_singular_search_of_f_alone_finds_the_cone_point():
    """The stencil of f alone (19 evaluations per Newton step) finds the same
    singular point as the gradient's differences, for fewer evaluations."""
    from rdmesh.sampling.probes import Probes
    from rdmesh.topology.singular import _gradient_and_hessian, singular_points

    exact = pinched()
    alone = rdmesh.ImplicitSurface(exact.f, exact.bounding_sphere)
    rng = np.random.default_rng(2)
    x = rng.uniform(-0.8, 0.8, (500, 3))
    for s in (exact, alone):
        g, H = _gradient_and_hessian(s, x, 1e-5 * s.radius, 2.0)
        np.testing.assert_allclose(g, exact.gradient(x) / 2.0, atol=1e-8)
        hess = np.zeros((len(x), 3, 3))
        hess[:, 0, 0] = hess[:, 1, 1] = 1.0
        hess[:, 2, 2] = -1.0 + 6 * x[:, 2] ** 2
        np.testing.assert_allclose(H, hess, atol=1e-4)
    # Probes on the surface, near the cone point too.
    z = rng.uniform(-0.9, 0.9, 4000)
    t = rng.uniform(0, 2 * np.pi, 4000)
    rho = np.abs(z) * np.sqrt(1 - z * z)
    pts = np.column_stack([rho * np.cos(t), rho * np.sin(t), z])
    found = {}
    for key, s in (("exact", exact), ("alone", alone)):
        before = s.evaluations
        found[key] = singular_points(s, Probes(pts, np.zeros_like(pts), 0.05))
        found[key + " cost"] = s.evaluations - before
        assert len(found[key]) == 1 and np.linalg.norm(found[key][0]) < 1e-4
    assert found["alone cost"] < 6 * found["exact cost"]


def test_self_crossing_surface_hits_the_cap_and_is_flagged():
    with pytest.raises(rdmesh.BudgetExceeded) as info:
        rdmesh.mesh_surface(crossing_spheres(), method=TB, max_vertices=1500)
    m = info.value.mesh
    rep = m.report
    assert not m.complete and rep["tbp_holds"] is False
    assert any(t["held"] is False for t in rep["tests"].values())
    # The problems are on the crossing circle x = 0, y^2 + z^2 = 0.75.
    for key in ("violation_regions", "unresolved_regions"):
        assert rep[key]
    pts = np.array([r["centre"] for r in rep["unresolved_regions"]])
    assert np.all(np.abs(pts[:, 0]) < 0.05)
    assert np.allclose(np.linalg.norm(pts[:, 1:], axis=1), np.sqrt(0.75), atol=0.1)
    sing = np.array([r["centre"] for r in rep["singular_points"]["regions"]])
    assert len(sing) and np.all(np.abs(sing[:, 0]) < 0.05)


# -- pieces ------------------------------------------------------------------


@pytest.mark.parametrize("name", ["torus", "tanglecube", "two_spheres"])
def test_critical_points_morse_count(name):
    """A random height direction is Morse; #extrema - #saddles is chi."""
    s = SURFACES[name].make()
    rng = np.random.default_rng(7)
    scan = grid_scan(s, rng, 48)
    cp = critical_points(s, scan.crossings, rng, scan.spacing)
    assert cp.euler == SURFACES[name].euler
    assert not cp.degenerate.any()
    # On the surface, with the gradient parallel to d.
    g = s.gradient(cp.points)
    gn = np.linalg.norm(g, axis=1)
    assert np.all(np.abs(s.f(cp.points)) / gn < 1e-8)
    assert np.all(np.linalg.norm(np.cross(g / gn[:, None], cp.direction), axis=1) < 1e-6)


def test_silhouette_test_on_a_coarse_sphere():
    """Three samples on a great circle: each cell reaches the poles, 90 degrees off."""
    s = SURFACES["sphere"].make()
    t = np.array([0.0, 2 * np.pi / 3, 4 * np.pi / 3])
    samples = np.column_stack([np.cos(t), np.sin(t), np.zeros(3)])
    rng = np.random.default_rng(0)
    u = rng.normal(size=(4000, 3))
    probes = Probes.on(s, u / np.linalg.norm(u, axis=1)[:, None], 0.05)
    v = silhouette_test(probes, samples, unit_normals(s, samples), 80.0)
    assert v.count == 3 and len(v.centres) == 3
    # Each point lies in the cell of a distinct sample, at the reported distance.
    d, owner = cKDTree(samples).query(v.centres)
    assert sorted(owner) == [0, 1, 2]
    assert np.allclose(d, v.radii)
    # Near the poles (farthest from the sample within its wedge).
    assert np.all(np.abs(v.centres[:, 2]) > 0.9)
    # A fine sample has no violation.
    fine = probes.points[:800]
    assert silhouette_test(probes, fine, unit_normals(s, fine), 80.0).count == 0


def test_regions_cluster_points():
    a = np.zeros((3, 3)) + [[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0]]
    b = np.array([[1.0, 1, 1]])
    rs = regions(np.concatenate([a, b]), 0.05)
    assert [r["points"] for r in rs] == [3, 1]
    assert np.allclose(rs[1]["centre"], [1, 1, 1]) and rs[1]["radius"] == 0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"method": "cheng"}, "unknown method"),
        ({"method": TB, "topology": "non-manifold"}, "always produces a closed manifold"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        rdmesh.mesh_surface(SURFACES["sphere"].make(), **kwargs)
