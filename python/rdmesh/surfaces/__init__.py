"""Surface oracles: the vectorised ``f``, expressions, and the built-in test surfaces.

``rdmesh.surfaces.torus()``, ``rdmesh.surfaces.get("tanglecube")`` and
``rdmesh.surfaces.SURFACES`` give the built-in surfaces, each with an exact
gradient; :class:`ImplicitSurface` wraps any vectorised function,
:class:`VolumeSurface` the isosurface of a sampled 3-D volume and
:class:`MeshSurface` a triangle mesh (its signed distance).
"""

from .builtin import (
    SURFACES,
    SurfaceInfo,
    blob_line,
    double_torus,
    ellipsoid,
    get,
    sphere,
    tanglecube,
    thin_torus,
    torus,
    two_spheres,
)
from .mesh import MeshSurface
from .oracle import ImplicitSurface
from .volume import VolumeSurface

__all__ = [
    "SURFACES",
    "ImplicitSurface",
    "MeshSurface",
    "SurfaceInfo",
    "VolumeSurface",
    "blob_line",
    "double_torus",
    "ellipsoid",
    "get",
    "sphere",
    "tanglecube",
    "thin_torus",
    "torus",
    "two_spheres",
]
