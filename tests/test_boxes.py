"""Interval subdivision seeding (rdmesh.sampling.boxes): small components of
expression surfaces, which the seeding grid misses, get samples."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from rdmesh.sampling.boxes import interval_boxes
from rdmesh.surfaces.expressions import parse_expression

#: A unit sphere and a sphere of radius 0.02 (the grid's cell is 0.0625) (issue 13).
SMALL = "min(sqrt(x**2+y**2+z**2)-1, sqrt((x-1.5)**2+(y-0.3)**2+(z-0.2)**2)-0.02)"


@pytest.mark.parametrize(
    ("method", "radius_bound"), [("topological-ball", None), ("boissonnat-oudot", 0.2)]
)
def test_component_smaller_than_the_grid_is_kept(method, radius_bound):
    s = rdmesh.ImplicitSurface.from_expression(SMALL, bounding_sphere=((0, 0, 0), 2.0))
    m = rdmesh.mesh_surface(s, method=method, radius_bound=radius_bound)
    topo = m.topology()
    assert topo["components"] == 2 and topo["euler"] == [2, 2]
    assert m.is_closed_manifold()
    centre = np.array([1.5, 0.3, 0.2])
    near = np.linalg.norm(m.vertices - centre, axis=1) < 0.05
    assert np.allclose(np.linalg.norm(m.vertices[near] - centre, axis=1), 0.02, atol=1e-9)


def test_box_search_keeps_few_boxes_and_finds_surface_points():
    """The subdivision discards most of the cube, and the points it returns lie
    on the surface (the sphere of radius 0.7)."""
    expr = parse_expression("x**2 + y**2 + z**2 - 0.49")
    s = rdmesh.ImplicitSurface(expr, ((0, 0, 0), 1.0))
    rng = np.random.default_rng(0)
    search = interval_boxes(s, expr, 0.1, rng)
    assert search.empty_proven and search.side <= 0.1
    # Every point found is on the surface.
    assert np.allclose(np.linalg.norm(search.points, axis=1), 0.7, atol=1e-8)
    # Few boxes of the whole cube are kept; a point was found in most of them.
    assert search.boxes < (2.0 / search.side) ** 3 / 4
    assert len(search.points) >= 0.5 * search.boxes
