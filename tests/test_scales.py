"""Surfaces far from unit size: the same mesh, scaled, and no floating-point
warnings (a Newton step's cap over a 1e-300 floor overflowed at R = 1e10)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import rdmesh


def _blob(R: float) -> rdmesh.ImplicitSurface:
    return rdmesh.ImplicitSurface.from_expression(
        f"(x**2 + y**2 + z**2) / ({R}**2) - 1 + 0.3*sin(3*x/{R})*sin(3*y/{R})", ((0, 0, 0), 2 * R)
    )


@pytest.fixture(scope="module")
def unit_mesh():
    return rdmesh.mesh_surface(_blob(1.0), radius_bound=0.1)


@pytest.mark.parametrize("R", [1e-9, 1e10, 1e39])
def test_an_expression_meshes_the_same_at_any_size(R, unit_mesh):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        m = rdmesh.mesh_surface(_blob(R), radius_bound=0.1 * R)
    assert len(m.vertices) == len(unit_mesh.vertices)
    assert np.array_equal(m.faces, unit_mesh.faces)
    assert np.allclose(m.vertices / R, unit_mesh.vertices, rtol=0, atol=1e-9)


@pytest.mark.parametrize("spacing", [1e-9, 1e10])
def test_a_volume_far_from_unit_spacing_meshes_without_warnings(spacing):
    v = np.linspace(-1.5, 1.5, 24)
    x, y, z = np.meshgrid(v, v, v, indexing="ij")
    # Inside is where the values exceed the isovalue: the box, closed around it,
    # with a spherical cavity (two spheres of the same Euler characteristic).
    volume = rdmesh.VolumeSurface(x**2 + y**2 + z**2, isovalue=1.0, spacing=(spacing,) * 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        m = rdmesh.mesh_surface(volume)
    assert m.complete and m.report["closed_manifold"]
    assert m.report["components"] == 2 and m.report["euler"] == [2, 2]
