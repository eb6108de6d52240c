"""The proven component search by default with Boissonnat-Oudot (issue 30)."""

from __future__ import annotations

import pytest
import rdmesh
import rdmesh.refine.methods as methods

#: A sphere of radius 0.02 R beside the unit sphere (R = 2).
SMALL = "min(x**2 + y**2 + z**2 - 1, (x - 1.3)**2 + (y - 0.3)**2 + (z + 0.2)**2 - 0.04**2)"


def small_beside_large() -> rdmesh.ImplicitSurface:
    return rdmesh.ImplicitSurface.from_expression(SMALL, ((0.0, 0.0, 0.0), 2.0))


@pytest.mark.parametrize("seed", range(4))
def test_small_sphere_found_by_default(seed):
    mesh = rdmesh.mesh_surface(small_beside_large(), seed=seed)
    assert mesh.report["components"] == 2
    assert sorted(mesh.report["euler"]) == [2, 2]
    assert mesh.report["seeding"]["level"] == "proven"
    assert mesh.report["seeding"]["seeds"] > 0
    assert not mesh.report["certified"]  # the tests stay sampled without certify


def test_grid_scan_alone_drops_it(monkeypatch):
    # The grid scan alone (before issue 30) misses the small sphere for seed 1.
    monkeypatch.setattr(methods, "find_components", lambda *a, **k: None)
    mesh = rdmesh.mesh_surface(small_beside_large(), seed=1)
    assert mesh.report["components"] == 1
    assert mesh.report["seeding"]["level"] == "sampled"


def test_plain_functions_stay_sampled():
    surface = rdmesh.surfaces.builtin.sphere()
    mesh = rdmesh.mesh_surface(surface)
    assert mesh.report["seeding"]["level"] == "sampled"
