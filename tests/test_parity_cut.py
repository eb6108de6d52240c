"""Facets crossed an even number of times below the spacing floor are left out.

A lens of two unit spheres whose centres are 1.96 apart has a rim where the
two normals are about 157 degrees apart: a wedge that looks the same at every
scale, so refinement reaches the topology floor there (features are off, so
nothing protects the rim). Below the floor, a facet whose dual edge crosses
the wedge twice is left out, and the complex is the boundary of the cells
whose Voronoi vertex is inside: every edge has an even number of triangles.
"""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from rdmesh.refine import pipeline
from rdmesh.topology.complex import complex_status


def _lens(p: np.ndarray) -> np.ndarray:
    a = np.linalg.norm(p - [0.0, 0.0, 0.98], axis=1) - 1.0
    b = np.linalg.norm(p - [0.0, 0.0, -0.98], axis=1) - 1.0
    return np.maximum(a, b)


def _mesh(**options):
    surface = rdmesh.ImplicitSurface(_lens, ((0.0, 0.0, 0.0), 0.3), features="none")
    return rdmesh.mesh_surface(surface, radius_bound=0.15, seed=1, **options)


def _edge_counts(mesh) -> np.ndarray:
    return complex_status(mesh.faces, len(mesh.vertices)).edge_count


@pytest.fixture(scope="module")
def lens_mesh():
    return _mesh()


def test_every_edge_has_an_even_number_of_triangles(lens_mesh):
    counts = _edge_counts(lens_mesh)
    assert len(counts) > 1000
    assert np.all(counts % 2 == 0)


def test_cut_facets_are_reported_as_voronoi_edge_violations(lens_mesh):
    edge = lens_mesh.report["tests"]["voronoi_edge"]
    assert edge["cut_by_parity"] > 0
    assert edge["violations"] >= edge["cut_by_parity"]
    assert edge["held"] is False and edge["level"] == "failed"
    assert lens_mesh.report["tbp_holds"] is False
    # The rim's cuts are where the report says the violations lie.
    where = lens_mesh.report["violation_regions"]
    assert where


def test_without_the_rule_edges_have_one_or_three_triangles(monkeypatch):
    # The rule is what makes the complex even: without it the same run leaves
    # edges with an odd number of triangles at the rim.
    monkeypatch.setattr(pipeline, "_cut_by_parity", lambda p, ev, tri: np.zeros(len(tri), bool))
    m = _mesh()
    counts = _edge_counts(m)
    assert np.any(counts % 2 == 1)
    assert "cut_by_parity" in m.report["tests"]["voronoi_edge"]
    assert m.report["tests"]["voronoi_edge"]["cut_by_parity"] == 0


def test_a_smooth_surface_has_nothing_cut():
    m = rdmesh.mesh_surface(rdmesh.surfaces.torus(), radius_bound=0.1, seed=0)
    edge = m.report["tests"]["voronoi_edge"]
    assert edge["cut_by_parity"] == 0 and edge["held"] is True
    assert m.report["closed_manifold"]


def test_the_statement_and_the_log_say_what_was_cut(lens_mesh, caplog):
    assert "were left out" in lens_mesh.report["statement"]
    with caplog.at_level("WARNING", logger="rdmesh"):
        _mesh()
    assert any("left out" in r.getMessage() for r in caplog.records)
