"""Shared fixtures: each public surface is meshed once per session.

Radius bounds are at most about 0.1 * lfs, where Boissonnat-Oudot guarantee
that the restricted Delaunay triangulation is homeomorphic to the surface, so
topology assertions are claims the library makes, not luck.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import pytest
import rdmesh
from hypothesis import settings
from rdmesh.surfaces import SURFACES

# CI runs the property-based tests on a fixed sequence of examples, so that a
# run is repeatable; elsewhere hypothesis draws new ones each time.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

# Debug mode: every round of every run below 50k samples checks the core's
# bookkeeping and that each surface Delaunay ball is empty (subprocesses inherit it).
os.environ.setdefault("RDMESH_CHECK", "1")

#: (name, radius_bound): lfs is 1 (sphere), 0.4 (torus), ~1 (tanglecube),
#: 0.05 at the gap (two spheres), ~0.5 (blob line), 1/6 (ellipsoid),
#: ~0.026 on its thinnest part (double torus) and 0.1 (thin torus).
FAST_CASES = [
    ("sphere", 0.1),
    ("torus", 0.04),
    ("tanglecube", 0.1),
    ("two_spheres", 0.05),
    ("blob_line", 0.05),
]
SLOW_CASES = [
    ("ellipsoid", 0.02),
    ("double_torus", 0.01),
    ("thin_torus", 0.01),
]

#: Euler characteristic of each component (largest first). SURFACES only
#: records the total, which is ambiguous when there are several components.
EULER_PER_COMPONENT = {"two_spheres": [2, 2]}


def expected_euler(name: str) -> list[int]:
    info = SURFACES[name]
    if name in EULER_PER_COMPONENT:
        per = EULER_PER_COMPONENT[name]
        assert len(per) == info.components and sum(per) == info.euler
        return per
    assert info.components == 1
    return [info.euler]


@dataclass
class MeshCase:
    name: str
    radius_bound: float
    surface: rdmesh.ImplicitSurface
    mesh: rdmesh.SurfaceMesh

    def f(self, p: np.ndarray) -> np.ndarray:
        """The raw surface function (no evaluation counting or checks)."""
        return self.surface.f(np.atleast_2d(p))

    def grad(self, p: np.ndarray) -> np.ndarray:
        return self.surface.gradient(np.atleast_2d(p))


_cache: dict[tuple[str, float], MeshCase] = {}


def mesh_case(name: str, radius_bound: float) -> MeshCase:
    """Mesh a public surface once per session (shared by all fixtures)."""
    key = (name, radius_bound)
    if key not in _cache:
        surface = SURFACES[name].make()
        mesh = rdmesh.mesh_surface(surface, radius_bound=radius_bound)
        _cache[key] = MeshCase(name, radius_bound, SURFACES[name].make(), mesh)
    return _cache[key]


@pytest.fixture(
    scope="session",
    params=[pytest.param(c, id=c[0]) for c in FAST_CASES]
    + [pytest.param(c, id=c[0], marks=pytest.mark.slow) for c in SLOW_CASES],
)
def public_mesh(request) -> MeshCase:
    """Each public surface meshed at a size where the guarantee applies."""
    return mesh_case(*request.param)


@pytest.fixture(scope="session")
def sphere_case() -> MeshCase:
    """The unit sphere at radius bound 0.1 (about a thousand vertices)."""
    return mesh_case("sphere", 0.1)


@pytest.fixture(scope="session")
def torus_case() -> MeshCase:
    return mesh_case("torus", 0.04)
